"""The ``parameters`` and ``coordinates`` sections, and the constants (numbers or
expressions of the parameters) every other section reads."""
from __future__ import annotations

import math

import sympy as sp

from ...errors import ModelError, shorten
from .. import expressions
from ..robot import Coordinate
from .cursor import Cursor

#: a guard against a runaway file, as ``bodies.MAX_BODIES``
MAX_COORDINATES = 1000
# constants beyond these make SymPy's exact arithmetic crawl (300-digit rationals)
SMALLEST, LARGEST = 1e-30, 1e30


class _Numbers:
    """The builder's parameters, constants and coordinates (part of
    ``builder._RobotBuilder``)."""

    def parameters(self, cursor: Cursor) -> None:
        """name: number, or an expression of the parameters above it."""
        for key, item in cursor.mapping().items():
            name = self.key_name(item, key, "parameter name")
            if name in self.overrides:           # the caller's value, at the file's place
                item = Cursor(self.overrides[name], item.path, item.source, item.lines)
            self.claim(item, name, "a parameter")
            definition = item.expr(self.symbols, self.unavailable(self.symbols))
            self.check_numeric(item, definition)
            value = definition.xreplace(self.values)
            symbol = sp.Symbol(name, real=True)
            self.symbols[name] = symbol
            self.definitions[name] = definition
            self.values[symbol] = value

    def constant(self, cursor: Cursor) -> sp.Expr:
        """A number or an expression of the parameters."""
        return cursor.expr(self.symbols, self.unavailable(self.symbols))

    def check_numeric(self, cursor: Cursor, expr: sp.Expr) -> float:
        """The finite real value of a constant expression (ModelError otherwise)."""
        try:
            expressions.approximate(expr, {**self.values, **self.gain_values})
            value = expr.xreplace(self.values).xreplace(self.gain_values)
            if value.free_symbols:
                raise cursor.error("must be a number here, got an expression of "
                                   f"{', '.join(sorted(map(str, value.free_symbols)))}")
            number = complex(value.evalf())
        except ModelError:
            raise
        except expressions.ExpressionError as err:      # overflows: not evaluated exactly
            raise cursor.error(str(err)) from None
        except (RecursionError, MemoryError):
            raise cursor.error(expressions.TOO_DEEP) from None
        except (TypeError, ValueError, ArithmeticError):
            raise cursor.error(f"cannot evaluate {shorten(value)} to a number") from None
        if number.imag != 0 or not math.isfinite(number.real):
            raise cursor.error(f"must be a finite real number, got {shorten(value)}")
        if number.real != 0 and not SMALLEST <= abs(number.real) <= LARGEST:
            raise cursor.error(f"{number.real:g} is out of range: numbers in a robot file are 0 "
                               f"or between {SMALLEST:g} and {LARGEST:g} in size (SI units)")
        return number.real

    def constant_vector(self, cursor: Cursor | None) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """[x, y, z] of parameter expressions (zero when the key is absent)."""
        if cursor is None:
            return (sp.Integer(0),) * 3
        vector = cursor.vector(self.symbols, self.unavailable(self.symbols))
        for i, component in enumerate(vector):
            self.check_numeric(cursor.child(i, component), component)
        return vector

    def positive(self, cursor: Cursor, expr: sp.Expr, what: str) -> float:
        value = self.check_numeric(cursor, expr)
        if value <= 0:
            raise cursor.error(f"must be positive ({what}), got {value:g}")
        return value

    # -- coordinates ---------------------------------------------------------
    def coordinate_names(self, cursor: Cursor) -> dict[str, Cursor]:
        items = cursor.mapping()
        if not items:
            raise cursor.error("at least one coordinate is required, e.g. {q1: {initial: 0}}")
        if len(items) > MAX_COORDINATES:
            raise cursor.error(f"{len(items)} coordinates; anadyn handles at most "
                               f"{MAX_COORDINATES}")
        for key, item in items.items():
            self.key_name(item, key, "coordinate name")
            self.claim(item, key, "a coordinate")
            self.claim(item, "d" + key, f"the rate of coordinate {key!r}")
            self.claim(item, "dd" + key, f"the acceleration of coordinate {key!r}")
        self.q = {k: sp.Symbol(k, real=True) for k in items}
        return items

    def coordinates(self, items: dict[str, Cursor], units: dict[str, str]) -> tuple[Coordinate, ...]:
        result = []
        for key, item in items.items():
            fields = item.mapping(("initial", "rate", "dependent")) if item.value is not None else {}
            fields.pop("dependent", None)        # read by model.constraints
            if key not in units:
                raise item.error("no joint displacement uses this coordinate; every coordinate "
                                 "must move some joint")
            values = {}
            for name in ("initial", "rate"):
                if name in fields:
                    expr = self.constant(fields[name])
                    self.check_numeric(fields[name], expr)
                    values[name] = expr.xreplace(self.values)
                else:
                    values[name] = sp.Integer(0)
            result.append(Coordinate(key, values["initial"], values["rate"], units[key]))
        return tuple(result)
