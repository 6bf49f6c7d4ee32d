"""Straight-line programs: scalar statements with constants folded and zeros dropped.

The recursive dynamics (``recursive``) is traced, not derived: every scalar
quantity is an ``Ex``, a sum of monomials ``c * a1 * a2 ...`` over *atoms*
(the inputs t, q, dq, ddq and earlier statements), with float coefficients.
Arithmetic on ``Ex`` folds constants at generation time (0*x and x+0
vanish, 1*x is x), so structural zeros (planar scenes, diagonal inertias,
axis-aligned joints, fixed joints) never reach the generated code.  A
quantity becomes a statement ``_aK = <sum of monomials>`` when it is
``Program.emit``-ed; identical statements are emitted once (hash-consing).

Statement kinds:

    sum     _aK = c1*a*b + c2*c + ...          (a polynomial in atoms)
    call    _aK = f(a), f in sin cos sqrt tanh recip (recip: 1/a)
    sympy   _aK = <sympy expression of atoms>  (control laws, loads, nonlinear
                                                displacements: printed as such)
    check   raise / return 1 when atom a <= 0   (Cholesky pivots)

``Program.derivatives`` differentiates the statements in forward mode
(dx/ds = sum_a (dx/da)(da/ds), sparse in the seeds s), itself as new
statements.  ``prune`` keeps what the outputs need; ``count`` gives the
multiplications, additions, divisions and calls; ``printers`` writes the
statements as Python (``math`` on floats, or NumPy over arrays) and C.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import sympy as sp

_current: list["Program"] = []


class Ex:
    """sum_k coef_k * prod(atoms_k); ``terms`` maps a sorted tuple of atom
    names (() for the constant) to its nonzero coefficient."""
    __slots__ = ("terms",)

    def __init__(self, terms: dict | None = None):
        self.terms = terms if terms is not None else {}

    # construction -------------------------------------------------------
    @staticmethod
    def const(value: float) -> "Ex":
        value = float(value)
        return Ex({(): value}) if value != 0.0 else Ex()

    @staticmethod
    def atom(name: str) -> "Ex":
        return Ex({(name,): 1.0})

    # inspection ---------------------------------------------------------
    def is_zero(self) -> bool:
        return not self.terms

    def constant(self) -> float | None:
        """The value if this is a constant (0.0 for zero), else None."""
        if not self.terms:
            return 0.0
        if len(self.terms) == 1 and () in self.terms:
            return self.terms[()]
        return None

    def single_atom(self) -> str | None:
        """The atom's name if this is exactly 1.0 * atom."""
        if len(self.terms) == 1:
            (mono, coef), = self.terms.items()
            if len(mono) == 1 and coef == 1.0:
                return mono[0]
        return None

    def _nonconstant_terms(self) -> int:
        return sum(1 for m in self.terms if m)

    # arithmetic ---------------------------------------------------------
    def __add__(self, other) -> "Ex":
        other = _ex(other)
        if not other.terms:
            return self
        if not self.terms:
            return other
        terms = dict(self.terms)
        for mono, coef in other.terms.items():
            value = terms.get(mono, 0.0) + coef
            if value == 0.0:
                terms.pop(mono, None)
            else:
                terms[mono] = value
        return Ex(terms)

    __radd__ = __add__

    def __neg__(self) -> "Ex":
        return Ex({m: -c for m, c in self.terms.items()})

    def __sub__(self, other) -> "Ex":
        return self + (-_ex(other))

    def __rsub__(self, other) -> "Ex":
        return _ex(other) + (-self)

    def scale(self, factor: float) -> "Ex":
        factor = float(factor)
        if factor == 0.0 or not self.terms:
            return Ex()
        if factor == 1.0:
            return self
        return Ex({m: c * factor for m, c in self.terms.items()})

    def __mul__(self, other) -> "Ex":
        other = _ex(other)
        a, b = self, other
        ca, cb = a.constant(), b.constant()
        if ca is not None:
            return b.scale(ca)
        if cb is not None:
            return a.scale(cb)
        # a product of two sums: name the larger sum first (fewer operations)
        if a._nonconstant_terms() > 1 and b._nonconstant_terms() > 1:
            if len(a.terms) >= len(b.terms):
                a = _current[-1].emit(a)
            else:
                b = _current[-1].emit(b)
        if len(a.terms) > 1 and len(b.terms) > 1:
            a = _current[-1].emit(a)
        terms: dict = {}
        for ma, ca_ in a.terms.items():
            for mb, cb_ in b.terms.items():
                mono = tuple(sorted(ma + mb))
                value = terms.get(mono, 0.0) + ca_ * cb_
                if value == 0.0:
                    terms.pop(mono, None)
                else:
                    terms[mono] = value
        return Ex(terms)

    __rmul__ = __mul__

    def __repr__(self) -> str:
        return f"Ex({python_sum(self.terms)})"


def as_expr(value) -> sp.Basic:
    """A SymPy object as it is; a Python number as a SymPy number (never text)."""
    if isinstance(value, sp.Basic):
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"not a SymPy expression or a number: {value!r}")
    return sp.Integer(value) if isinstance(value, int) else sp.Float(value)


def _ex(value) -> Ex:
    return value if isinstance(value, Ex) else Ex.const(value)


ZERO = Ex()
ONE = Ex.const(1.0)


@dataclass
class Statement:
    name: str
    kind: str           # "sum", "call", "sympy", "check"
    payload: object     # dict of terms; (function, atom); sympy expression; (atom, message)

    def atoms(self) -> set[str]:
        if self.kind == "sum":
            return {a for mono in self.payload for a in mono}
        if self.kind == "call":
            return {self.payload[1]}
        if self.kind == "sympy":
            return {s.name for s in self.payload.free_symbols}
        return {self.payload[0]}


class Program:
    """An ordered list of statements; ``with program:`` makes it the one that
    names the operands of products of sums."""

    def __init__(self, prefix: str = "_a"):
        self.statements: list[Statement] = []
        self._known: dict = {}
        self._prefix = prefix
        self._count = 0

    def __enter__(self) -> "Program":
        _current.append(self)
        return self

    def __exit__(self, *exc) -> None:
        _current.pop()

    def _new(self, kind: str, payload, key) -> Ex:
        if key is not None and key in self._known:
            return Ex.atom(self._known[key])
        name = f"{self._prefix}{self._count}"
        self._count += 1
        self.statements.append(Statement(name, kind, payload))
        if key is not None:
            self._known[key] = name
        return Ex.atom(name)

    def emit(self, value) -> Ex:
        """``value`` as a constant, a lone atom (with its sign) or a new statement."""
        value = _ex(value)
        if value.constant() is not None:
            return value
        if len(value.terms) == 1:
            (mono, coef), = value.terms.items()
            if len(mono) == 1 and coef in (1.0, -1.0):
                return value
        # factor out a sign so that x and -x share one statement
        first = next(iter(sorted(value.terms.items())))[1]
        sign = -1.0 if first < 0 else 1.0
        terms = value.terms if sign > 0 else {m: -c for m, c in value.terms.items()}
        atom = self._new("sum", dict(terms), ("sum", tuple(sorted(terms.items()))))
        return atom if sign > 0 else -atom

    def call(self, function: str, value) -> Ex:
        """function(value) folded for a constant argument."""
        value = _ex(value)
        c = value.constant()
        if c is not None:
            return Ex.const(_FOLD[function](c))
        arg = value.single_atom()
        if arg is None:
            arg = self._name(value)
        return self._new("call", (function, arg), ("call", function, arg))

    def _name(self, value: Ex) -> str:
        """An atom name holding ``value`` (a statement if needed)."""
        atom = value.single_atom()
        if atom is not None:
            return atom
        return self._new("sum", dict(value.terms), ("sum", tuple(sorted(value.terms.items())))
                         ).single_atom()

    def sympy(self, expr: sp.Expr) -> Ex:
        """A SymPy expression whose symbols are atom names."""
        expr = as_expr(expr)
        if expr.is_number:
            return Ex.const(float(expr))
        if isinstance(expr, sp.Symbol):
            return Ex.atom(expr.name)
        return self._new("sympy", expr, ("sympy", expr))

    def check_positive(self, value: Ex, message: str) -> Ex:
        """value, with a statement that fails when it is not > 0."""
        c = value.constant()
        if c is not None and c > 0:
            return value
        name = self._name(value)
        self.statements.append(Statement("", "check", (name, message)))
        return Ex.atom(name)

    # forward-mode differentiation -------------------------------------
    def derivatives(self, seeds: dict[str, int], start: int = 0) -> dict[str, dict[int, Ex]]:
        """d(atom)/d(seed) for every atom defined by a statement, sparse in the seeds;
        the derivatives are emitted as new statements after the existing ones."""
        D: dict[str, dict[int, Ex]] = {name: {k: ONE} for name, k in seeds.items()}
        partials_cache: dict = {}
        for statement in list(self.statements[start:]):
            if statement.kind == "check":
                continue
            acc: dict[int, Ex] = {}
            if statement.kind == "sum":
                for mono, coef in statement.payload.items():
                    for i, atom in enumerate(mono):
                        if atom not in D or (i > 0 and mono[i - 1] == atom):
                            continue
                        power = mono.count(atom)
                        rest = list(mono)
                        rest.remove(atom)
                        factor = Ex({tuple(rest): coef * power})
                        for k, d in D[atom].items():
                            acc[k] = acc.get(k, ZERO) + factor * d
            elif statement.kind == "call":
                function, atom = statement.payload
                if atom in D:
                    x, y = Ex.atom(atom), Ex.atom(statement.name)
                    factor = {"sin": lambda: self.call("cos", x),
                              "cos": lambda: -self.call("sin", x),
                              "sqrt": lambda: self.call("recip", y).scale(0.5),
                              "tanh": lambda: 1.0 - y * y,
                              "recip": lambda: -(y * y)}[function]()
                    factor = self.emit(factor)
                    for k, d in D[atom].items():
                        acc[k] = acc.get(k, ZERO) + factor * d
            else:  # sympy
                expr = statement.payload
                for symbol in sorted(expr.free_symbols, key=lambda s: s.name):
                    if symbol.name not in D:
                        continue
                    key = (expr, symbol)
                    if key not in partials_cache:
                        partials_cache[key] = self.sympy(_partial(expr, symbol))
                    factor = self.emit(partials_cache[key])
                    for k, d in D[symbol.name].items():
                        acc[k] = acc.get(k, ZERO) + factor * d
            named = {}
            for k, value in acc.items():
                value = self.emit(value)
                if not value.is_zero():
                    named[k] = value
            if named:
                D[statement.name] = named
        return D

    def derivative_of(self, value: Ex, D: dict[str, dict[int, Ex]]) -> dict[int, Ex]:
        """d(value)/d(seed) for an Ex built from atoms that ``D`` covers."""
        acc: dict[int, Ex] = {}
        for mono, coef in value.terms.items():
            for i, atom in enumerate(mono):
                if atom not in D or (i > 0 and mono[i - 1] == atom):
                    continue
                rest = list(mono)
                rest.remove(atom)
                factor = Ex({tuple(rest): coef * mono.count(atom)})
                for k, d in D[atom].items():
                    acc[k] = acc.get(k, ZERO) + factor * d
        return {k: v for k, v in acc.items() if not v.is_zero()}


def _partial(expr: sp.Expr, symbol: sp.Symbol) -> sp.Expr:
    """d expr / d symbol, zero almost everywhere for the piecewise-constant parts:
    sign' = 0 (no DiracDelta), min/max through Piecewise (no Heaviside), as the
    closed forms' ``symbolic.derivative`` has it."""
    d = sp.diff(expr, symbol)
    d = d.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.Integer(0))
    if d.has(sp.Heaviside):
        d = d.rewrite(sp.Piecewise)
    return d


_FOLD = {"sin": math.sin, "cos": math.cos, "sqrt": math.sqrt, "tanh": math.tanh,
         "recip": lambda x: 1.0 / x}


def prune(statements: list[Statement], outputs: list[Ex]) -> list[Statement]:
    """The statements the outputs need (checks are kept when their atom is)."""
    needed: set[str] = {a for value in outputs for mono in value.terms for a in mono}
    kept: list[Statement] = []
    for statement in reversed(statements):
        if statement.kind == "check":
            kept.append(statement)       # decided below, once its atom is known
            continue
        if statement.name in needed:
            kept.append(statement)
            needed |= statement.atoms()
    kept.reverse()
    return [s for s in kept if s.kind != "check" or s.payload[0] in needed
            or any(k.name == s.payload[0] for k in kept)]


@dataclass
class Counts:
    mul: int = 0
    add: int = 0
    div: int = 0
    calls: int = 0          # sin, cos, sqrt, tanh
    other: int = 0          # operations inside printed SymPy expressions

    def __add__(self, other: "Counts") -> "Counts":
        return Counts(self.mul + other.mul, self.add + other.add, self.div + other.div,
                      self.calls + other.calls, self.other + other.other)

    @property
    def total(self) -> int:
        return self.mul + self.add + self.div + self.calls + self.other


def count(statements: list[Statement], outputs: list[Ex] = ()) -> Counts:
    """Floating-point operations of the statements and of the output sums."""
    c = Counts()

    def sum_ops(terms: dict) -> None:
        nonconstant = 0
        for mono, coef in terms.items():
            if mono:
                c.mul += len(mono) - 1 + (0 if coef in (1.0, -1.0) else 1)
                nonconstant += 1
        c.add += max(0, len(terms) - 1)

    for s in statements:
        if s.kind == "sum":
            sum_ops(s.payload)
        elif s.kind == "call":
            if s.payload[0] == "recip":
                c.div += 1
            else:
                c.calls += 1
        elif s.kind == "sympy":
            c.other += int(sp.count_ops(s.payload))
    for value in outputs:
        if value.constant() is None and value.single_atom() is None:
            sum_ops(value.terms)
    return c


# the text of a sum of products: an Ex's own, and the printers' ---------------

def _number(value: float) -> str:
    text = repr(float(value))
    return text if ("e" in text or "." in text or "n" in text) else text + ".0"


def python_sum(terms: dict) -> str:
    """C and Python share the syntax of a sum of products."""
    if not terms:
        return "0.0"
    parts = []
    for mono, coef in terms.items():
        factors = list(mono)
        if not factors:
            text, negative = _number(abs(coef)), coef < 0
        elif coef in (1.0, -1.0):
            text, negative = "*".join(factors), coef < 0
        else:
            text, negative = _number(abs(coef)) + "*" + "*".join(factors), coef < 0
        parts.append((text, negative))
    first, negative = parts[0]
    out = ("-" if negative else "") + first
    for text, negative in parts[1:]:
        out += (" - " if negative else " + ") + text
    return out
