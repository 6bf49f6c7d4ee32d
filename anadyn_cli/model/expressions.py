"""Safe parsing of the arithmetic expressions that robot files contain.

An expression is parsed by Python's ``ast`` module (which only parses, it
runs nothing) and every node is checked against a whitelist before it is
turned into a SymPy object node by node.  Nothing ever reaches ``eval``,
``sympify`` or ``parse_expr``.

Allowed: decimal numbers (``12``, ``0.5``, ``1e-3``: not Python's ``1_0``,
``0x10`` or ``0o7``), the names the caller passes in, ``pi``, the operators
``+ - * / **`` and calls of FUNCTIONS with positional arguments, nested at
most MAX_DEPTH deep (a chain ``a + b - c ...`` of one precedence counts as
one level).  Exact numbers are kept below MAX_EXACT_BITS (larger ones are
floating point, and overflow is an error), so that ``10**10**10`` or a tower
of powers neither hangs nor eats memory.
"""
from __future__ import annotations

import ast
import cmath
import datetime
import difflib
import math
import re
from collections.abc import Mapping

import sympy as sp

from ..errors import shorten


#: name -> (sympy function, allowed argument counts; None = two or more)
FUNCTIONS: dict[str, tuple[object, tuple[int, ...] | None]] = {
    "sin": (sp.sin, (1,)), "cos": (sp.cos, (1,)), "tan": (sp.tan, (1,)),
    "asin": (sp.asin, (1,)), "acos": (sp.acos, (1,)), "atan": (sp.atan, (1,)),
    "atan2": (sp.atan2, (2,)), "sinh": (sp.sinh, (1,)), "cosh": (sp.cosh, (1,)),
    "tanh": (sp.tanh, (1,)), "exp": (sp.exp, (1,)), "log": (sp.log, (1,)),
    "sqrt": (sp.sqrt, (1,)), "abs": (sp.Abs, (1,)), "sign": (sp.sign, (1,)),
    "min": (sp.Min, None), "max": (sp.Max, None),
}
CONSTANTS = {"pi": sp.pi}

MAX_LENGTH = 2000          # characters in one expression
MAX_DEPTH = 100            # nesting of calls, parentheses, signs and powers
#: a number as its text reads (Python would also take 1_0, 0x10, 0o7, 0b1)
DECIMAL = re.compile(r"(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\Z")
#: functions with a kink or a jump, written or made by SymPy (sqrt(q**2) = Abs(q))
KINKS = (sp.Abs, sp.sign, sp.Min, sp.Max, sp.Heaviside, sp.DiracDelta, sp.Piecewise)
MAX_EXACT_EXPONENT = 64    # larger numeric powers are computed in floating point
MAX_EXACT_BITS = 4096      # exact numbers beyond this are computed in floating point
#: functions with a kink or a jump: not allowed where the expression is differentiated
NOT_SMOOTH = frozenset({"abs", "sign", "min", "max"})

_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}


class ExpressionError(ValueError):
    """The text is not an allowed expression; ``str()`` says why."""


def number(value: object) -> sp.Expr:
    """A finite real number as an exact SymPy number: a decimal is taken as
    written (0.4 -> 2/5), so that equal terms cancel exactly."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ExpressionError(f"expected a number, got {_describe(value)}")
    if isinstance(value, int):
        if value.bit_length() > MAX_EXACT_BITS:
            raise ExpressionError(f"number too large (more than {MAX_EXACT_BITS} bits), the "
                                  "largest allowed is about 1.8e308")
        return sp.Integer(value)
    if not math.isfinite(value):
        raise ExpressionError(f"expected a finite number, got {value}")
    return sp.Rational(repr(value))


def as_expr(value: object) -> sp.Basic:
    """A SymPy object for a value that already is one, or a Python int or
    float: never text (text goes through ``parse``)."""
    if isinstance(value, sp.Basic):
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"expected a SymPy expression or a number, got {type(value).__name__}")
    return sp.Integer(value) if isinstance(value, int) else sp.Float(value)


def parse(value: object, names: Mapping[str, sp.Expr],
          unavailable: Mapping[str, str] | None = None, smooth: bool = False) -> sp.Expr:
    """Turn a YAML scalar (number or expression string) into a SymPy expression.

    ``names`` maps every name the expression may use to its SymPy value;
    ``unavailable`` maps names that exist in the file but not here to what they
    are (for the message, e.g. ``{"q1": "a coordinate"}``); ``smooth`` refuses
    the functions with kinks or jumps (NOT_SMOOTH), for expressions that get
    differentiated.
    """
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return number(value)
    if not isinstance(value, str):
        raise ExpressionError(f"expected a number or an expression, got {_describe(value)}")
    text = value.strip()
    if not text:
        raise ExpressionError("empty expression")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_LENGTH} characters")
    shown = shorten(text)
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as err:
        hint = " (use ** for powers)" if "^" in text else ""
        why = f": {err.msg}" if err.msg and err.msg != "invalid syntax" else ""
        where = f" at column {err.offset}" if err.offset else " at the end"
        raise ExpressionError(f"syntax error in {shown!r}{where}{why}{hint}; "
                              "write an arithmetic expression such as 2*L1*cos(q1)") from None
    except (RecursionError, MemoryError):
        raise ExpressionError(TOO_DEEP) from None
    except ValueError:
        raise ExpressionError(f"cannot parse {shown!r}") from None
    _check_depth(tree.body)
    _check_numbers(tree.body, text)
    try:
        result = _Builder(names, unavailable or {}, smooth).build(tree.body)
        infinite = result.has(sp.zoo, sp.oo, -sp.oo, sp.nan)
    except ExpressionError:
        raise
    except (RecursionError, MemoryError):
        raise ExpressionError(TOO_DEEP) from None
    except (TypeError, ValueError, ArithmeticError) as err:   # SymPy refusing, e.g. max(I, 1)
        raise ExpressionError(f"cannot evaluate {shown!r} ({shorten(str(err))})") from None
    if infinite:
        raise ExpressionError(f"{shown!r} is not finite (division by zero or overflow)")
    if smooth:
        kinks = [f for f in result.atoms(*KINKS) if f.free_symbols]
        if kinks:
            raise ExpressionError(
                f"{shown!r} is {shorten(str(result))}: {shorten(str(kinks[0]))} has a kink "
                "or a jump, not allowed here (this expression is differentiated twice)")
    return result


TOO_DEEP = f"expression too deeply nested (limit {MAX_DEPTH})"


def _check_depth(tree: ast.AST) -> None:
    """ExpressionError if the syntax tree nests deeper than MAX_DEPTH; a left-deep
    chain of binary operators (a + b + c, as the parser builds it) is one level,
    as ``_Builder`` walks it without recursion."""
    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise ExpressionError(TOO_DEEP)
        for child in ast.iter_child_nodes(node):
            if not isinstance(child, ast.expr):            # ast.Load, operators
                continue
            chained = isinstance(node, ast.BinOp) and child is node.left
            stack.append((child, depth if chained else depth + 1))


def _check_numbers(tree: ast.AST, text: str) -> None:
    """ExpressionError for a number not written as a decimal (``1_0``, ``0x10``)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
                and not isinstance(node.value, bool):
            written = ast.get_source_segment(text, node) or ""
            if not DECIMAL.match(written):
                raise ExpressionError(f"{shorten(written, 30)!r} is not a decimal number; "
                                      "write digits, a point and an exponent, such as "
                                      "1000, 0.5 or 1e-3 (no underscores, 0x, 0o or 0b)")


def approximate(expr: sp.Expr, values: Mapping[sp.Symbol, object] | None = None) -> complex:
    """``expr`` in double precision, its symbols taken from ``values`` (nan for
    a symbol without a value or where a function is undefined, e.g. log(0)).

    The guard to pass before SymPy evaluates a number (``evalf``, or the
    automatic evaluation ``xreplace`` triggers): SymPy works at a precision
    that grows with the size of the number, so exp(exp(exp(100))) would take
    forever.  Raises ExpressionError when any intermediate value overflows.
    """
    memo: dict[sp.Symbol, complex] = {}

    def value(node: sp.Expr) -> complex:
        if node.is_Symbol:
            if node not in memo:
                given = values.get(node) if values else None
                memo[node] = (complex("nan") if given is None else value(given)
                              if isinstance(given, sp.Basic) else complex(given))
            return memo[node]
        if node.is_Number or node.is_NumberSymbol or node is sp.I:
            if node in (sp.oo, -sp.oo, sp.zoo, sp.nan):
                return complex("nan")
            result = complex(node)
            if cmath.isinf(result):                    # e.g. 10**400
                raise OverflowError
            return result
        args = [value(arg) for arg in node.args]      # every argument, even after a nan
        if any(not _finite(a) for a in args):
            return complex("nan")
        try:
            if node.is_Add or node.is_Mul:
                result = args[0]
                for a in args[1:]:                     # stop at the first overflow
                    result = result + a if node.is_Add else result * a
                    if cmath.isinf(result):
                        raise OverflowError
            elif node.is_Pow:
                base, exponent = args
                result = (base.real ** exponent.real if base.imag == exponent.imag == 0
                          and base.real >= 0 else base ** exponent)
            elif node.func in _APPROXIMATE:
                result = _APPROXIMATE[node.func](*args)
            else:                                      # a form SymPy made: arguments checked
                return complex("nan")
        except (ValueError, ZeroDivisionError):       # undefined here, e.g. log(0), 0**-1
            return complex("nan")
        result = complex(result)
        if cmath.isinf(result):
            raise OverflowError
        return result

    try:
        return value(expr)
    except OverflowError:
        if expr.is_Number:
            raise ExpressionError("number too large (the largest allowed is about "
                                  "1.8e308)") from None
        raise ExpressionError(f"{shorten(str(expr))} overflows in floating point (the "
                              "largest number allowed is about 1.8e308)") from None
    except RecursionError:
        raise ExpressionError(TOO_DEEP) from None


def _finite(value: complex) -> bool:
    return cmath.isfinite(value)


def _real(function):
    """A function of real arguments only (nan for complex ones)."""
    def call(*args: complex) -> complex:
        if any(a.imag != 0 for a in args):
            return complex("nan")
        return function(*(a.real for a in args))
    return call


def _sign(z: complex) -> complex:
    return z / abs(z) if z != 0 else 0j


#: SymPy function -> the same in double precision (``approximate``)
_APPROXIMATE = {
    sp.sin: cmath.sin, sp.cos: cmath.cos, sp.tan: cmath.tan, sp.asin: cmath.asin,
    sp.acos: cmath.acos, sp.atan: cmath.atan, sp.atan2: _real(math.atan2),
    sp.sinh: cmath.sinh, sp.cosh: cmath.cosh, sp.tanh: cmath.tanh, sp.exp: cmath.exp,
    sp.log: cmath.log, sp.Abs: abs, sp.sign: _sign, sp.Min: _real(min), sp.Max: _real(max),
}


class _Builder:
    def __init__(self, names: Mapping[str, sp.Expr], unavailable: Mapping[str, str] = {},
                 smooth: bool = False):
        self.names, self.unavailable, self.smooth = names, unavailable, smooth

    def build(self, node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            spine = []                  # a + b + c + ... is left-deep: walk it, not recurse
            while isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
                spine.append(node)
                node = node.left
            value = self.build(node)
            for parent in reversed(spine):
                value = _exact(self._binary(parent.op, value, self.build(parent.right)))
            return value
        return self._node(node)

    def _node(self, node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise ExpressionError(f"{_describe(node.value)} is not allowed in an expression; "
                                      "use numbers, names, + - * / ** and the functions "
                                      + ", ".join(sorted(FUNCTIONS)))
            if isinstance(node.value, float) and math.isinf(node.value):
                raise ExpressionError("number too large (the largest allowed is about 1.8e308)")
            return number(node.value)
        if isinstance(node, ast.Name):
            return self._name(node.id)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            operand = self.build(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.Call):
            return self._call(node)
        raise ExpressionError(f"{_construct(node)} is not allowed; use numbers, names, "
                              "+ - * / ** and the functions " + ", ".join(sorted(FUNCTIONS)))

    def _name(self, name: str) -> sp.Expr:
        if name in CONSTANTS:
            return CONSTANTS[name]
        if name in self.names:
            return self.names[name]
        if name in FUNCTIONS:
            raise ExpressionError(f"{name} is a function; call it as {name}(...)")
        allowed = sorted(self.names) + sorted(CONSTANTS)
        shown = ", ".join(allowed[:20]) + (", ..." if len(allowed) > 20 else "")
        if name.startswith("_"):
            raise ExpressionError(f"name {shorten(name, 30)!r} is not allowed (no name starts "
                                  f"with _); allowed here: {shown}")
        if name in self.unavailable:
            raise ExpressionError(f"{name!r} is {self.unavailable[name]} and cannot be used "
                                  f"here; allowed here: {shown}")
        close = difflib.get_close_matches(name, allowed, n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise ExpressionError(f"unknown name {name!r}{hint}; allowed here: {shown}")

    @staticmethod
    def _binary(op: ast.operator, left: sp.Expr, right: sp.Expr) -> sp.Expr:
        if isinstance(op, ast.Add):
            return left + right
        if isinstance(op, ast.Sub):
            return left - right
        if isinstance(op, ast.Mult):
            return left * right
        if isinstance(op, ast.Div):
            if right == 0:
                raise ExpressionError("division by zero")
            return left / right
        if left.is_Number and right.is_Number and not (
                right.is_Integer and abs(right) <= MAX_EXACT_EXPONENT and left.is_Rational
                and _bits(left) * abs(int(right)) <= MAX_EXACT_BITS):
            try:   # keep huge exact powers from eating memory
                return number(float(left) ** float(right))
            except (OverflowError, ZeroDivisionError, TypeError, ValueError):
                raise ExpressionError("numeric power overflows (the largest number allowed "
                                      "is about 1.8e308)") from None
        return left ** right

    def _call(self, node: ast.Call) -> sp.Expr:
        if not isinstance(node.func, ast.Name):
            raise ExpressionError(f"{_construct(node.func)} is not allowed; use numbers, names, "
                                  "+ - * / ** and the functions " + ", ".join(sorted(FUNCTIONS)))
        if node.func.id not in FUNCTIONS:
            raise ExpressionError(f"call of {shorten(node.func.id, 30)} is not allowed; allowed "
                                  "functions: " + ", ".join(sorted(FUNCTIONS)))
        if node.keywords or any(isinstance(arg, ast.Starred) for arg in node.args):
            raise ExpressionError(f"{node.func.id}() takes positional arguments only")
        if self.smooth and node.func.id in NOT_SMOOTH:
            raise ExpressionError(f"{node.func.id}() has a kink or a jump and is not allowed "
                                  "here (this expression is differentiated twice); use the "
                                  "smooth functions " + ", ".join(sorted(set(FUNCTIONS)
                                                                         - NOT_SMOOTH)))
        function, arities = FUNCTIONS[node.func.id]
        count = len(node.args)
        if (arities is None and count < 2) or (arities is not None and count not in arities):
            wanted = "two or more" if arities is None else " or ".join(map(str, arities))
            raise ExpressionError(f"{node.func.id}() takes {wanted} argument(s), got {count}")
        args = [self.build(arg) for arg in node.args]
        for arg in args:         # SymPy evaluates numbers given to a function: huge ones hang
            if not arg.is_Number and not arg.free_symbols:
                approximate(arg)
        return function(*args)


def _bits(value: sp.Rational) -> int:
    return max(int(value.p).bit_length(), int(value.q).bit_length())


def _exact(value: sp.Expr) -> sp.Expr:
    """An exact number past MAX_EXACT_BITS becomes a float (or an overflow error)."""
    if value.is_Rational and _bits(value) > MAX_EXACT_BITS:
        try:
            return number(float(value))
        except (OverflowError, ValueError):
            raise ExpressionError("number too large (the largest allowed is about "
                                  "1.8e308)") from None
    return value


def _construct(node: ast.AST) -> str:
    """A user-facing name for a disallowed syntax node."""
    names = {ast.Attribute: "attribute access", ast.Subscript: "subscripting",
             ast.Lambda: "lambda", ast.Compare: "comparison", ast.BoolOp: "and/or",
             ast.IfExp: "if-expression", ast.List: "a list",
             ast.Tuple: "a comma (a tuple; write decimals with a point, e.g. 1.5)",
             ast.Dict: "a dict", ast.Set: "a set", ast.JoinedStr: "an f-string",
             ast.NamedExpr: ":=", ast.Starred: "*-unpacking", ast.ListComp: "a comprehension",
             ast.SetComp: "a comprehension", ast.DictComp: "a comprehension",
             ast.GeneratorExp: "a comprehension", ast.Await: "await", ast.Yield: "yield",
             ast.YieldFrom: "yield"}
    if isinstance(node, ast.Attribute):
        return f"attribute access (.{shorten(node.attr, 30)})"
    for kind, label in names.items():
        if isinstance(node, kind):
            return label
    if isinstance(node, (ast.BinOp, ast.UnaryOp)):
        symbol = _OPERATORS.get(type(node.op), type(node.op).__name__)
        return f"the operator {symbol}" + (" (use ** for powers)" if symbol == "^" else "")
    return type(node).__name__


_OPERATORS = {ast.BitXor: "^", ast.BitAnd: "&", ast.BitOr: "|", ast.FloorDiv: "//",
              ast.Mod: "%", ast.LShift: "<<", ast.RShift: ">>", ast.MatMult: "@",
              ast.Invert: "~", ast.Not: "not"}


def _describe(value: object) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if value is None:
        return "nothing (null)"
    if isinstance(value, str):
        return f"the string {shorten(value, 40)!r}"
    if value is Ellipsis:
        return "..."
    labels = {complex: "a complex number", bytes: "bytes", list: "a list", dict: "a mapping",
              int: "an integer", float: "a number", datetime.date: "a date",
              datetime.datetime: "a date and time"}
    return labels.get(type(value), f"a value of type {type(value).__name__}")
