"""Safe parsing of the arithmetic expressions that robot files contain.

An expression is parsed by Python's ``ast`` module (which only parses, it
runs nothing) and every node is checked against a whitelist before it is
turned into a SymPy object node by node.  Nothing ever reaches ``eval``,
``sympify`` or ``parse_expr``.

Allowed: numbers, the names the caller passes in, ``pi``, the operators
``+ - * / **`` and calls of FUNCTIONS with positional arguments.
"""
from __future__ import annotations

import ast
import difflib
import math
from collections.abc import Mapping

import sympy as sp

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
RESERVED = frozenset(FUNCTIONS) | frozenset(CONSTANTS)

MAX_LENGTH = 2000          # characters in one expression
MAX_EXACT_EXPONENT = 64    # larger numeric powers are computed in floating point

_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}


class ExpressionError(ValueError):
    """The text is not an allowed expression; ``str()`` says why."""


def number(value: object) -> sp.Expr:
    """A finite real number as an exact SymPy number: a decimal is taken as
    written (0.4 -> 2/5), so that equal terms cancel exactly."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ExpressionError(f"expected a number, got {_describe(value)}")
    if isinstance(value, int):
        return sp.Integer(value)
    if not math.isfinite(value):
        raise ExpressionError(f"expected a finite number, got {value}")
    return sp.Rational(repr(value))


def parse(value: object, names: Mapping[str, sp.Expr]) -> sp.Expr:
    """Turn a YAML scalar (number or expression string) into a SymPy expression.

    ``names`` maps every name the expression may use to its SymPy value.
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
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as err:
        hint = " (use ** for powers)" if "^" in text else ""
        raise ExpressionError(f"syntax error in {text!r} at column {err.offset}{hint}") from None
    except (ValueError, RecursionError, MemoryError):
        raise ExpressionError(f"cannot parse {text[:60]!r}") from None
    try:
        result = _Builder(names).build(tree.body)
    except RecursionError:
        raise ExpressionError("expression nested too deeply") from None
    if result.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
        raise ExpressionError(f"{text!r} is not finite (division by zero or overflow)")
    return result


class _Builder:
    def __init__(self, names: Mapping[str, sp.Expr]):
        self.names = names

    def build(self, node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise ExpressionError(f"{_describe(node.value)} is not allowed in an expression")
            return number(node.value)
        if isinstance(node, ast.Name):
            return self._name(node.id)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            operand = self.build(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return self._binary(node.op, self.build(node.left), self.build(node.right))
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
        close = difflib.get_close_matches(name, allowed, n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        shown = ", ".join(allowed[:20]) + (", ..." if len(allowed) > 20 else "")
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
                right.is_Integer and abs(right) <= MAX_EXACT_EXPONENT):
            try:   # keep huge exact powers from eating memory
                return number(float(left) ** float(right))
            except (OverflowError, ZeroDivisionError, TypeError):
                raise ExpressionError("numeric power overflows") from None
        return left ** right

    def _call(self, node: ast.Call) -> sp.Expr:
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            called = node.func.id if isinstance(node.func, ast.Name) else _construct(node.func)
            raise ExpressionError(f"call of {called} is not allowed; allowed functions: "
                                  + ", ".join(sorted(FUNCTIONS)))
        if node.keywords or any(isinstance(arg, ast.Starred) for arg in node.args):
            raise ExpressionError(f"{node.func.id}() takes positional arguments only")
        function, arities = FUNCTIONS[node.func.id]
        count = len(node.args)
        if (arities is None and count < 2) or (arities is not None and count not in arities):
            wanted = "two or more" if arities is None else " or ".join(map(str, arities))
            raise ExpressionError(f"{node.func.id}() takes {wanted} argument(s), got {count}")
        return function(*(self.build(arg) for arg in node.args))


def _construct(node: ast.AST) -> str:
    """A user-facing name for a disallowed syntax node."""
    names = {ast.Attribute: "attribute access", ast.Subscript: "subscripting",
             ast.Lambda: "lambda", ast.Compare: "comparison", ast.BoolOp: "and/or",
             ast.IfExp: "if-expression", ast.List: "a list", ast.Tuple: "a tuple",
             ast.Dict: "a dict", ast.Set: "a set", ast.JoinedStr: "an f-string",
             ast.NamedExpr: ":=", ast.Starred: "*-unpacking"}
    for kind, label in names.items():
        if isinstance(node, kind):
            return label
    if isinstance(node, ast.BinOp):
        return f"the operator {type(node.op).__name__}"
    if isinstance(node, ast.UnaryOp):
        return f"the operator {type(node.op).__name__}"
    return type(node).__name__


def _describe(value: object) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if value is None:
        return "nothing (null)"
    if isinstance(value, str):
        return f"the string {value!r}"
    return f"a {type(value).__name__}"
