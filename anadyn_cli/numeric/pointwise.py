"""Floating-point values of SymPy expressions at one point, without generating code.

    Evaluator({q1: 0.1, dq1: 0.0, ...})(expr) -> float

A walk over the expression graph in double precision, each distinct
subexpression computed once (shared subtrees, as the equations of motion
have many, cost nothing twice; the memo lives as long as the evaluator).
For the handful of points that ``linearize`` needs this is faster than
generating and compiling code, and runs nothing but arithmetic.  A value
that is not a finite real number (log of a negative, a pole) raises
``ValueError`` naming the subexpression.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import sympy as sp
from ..model.expressions import as_expr


def _sign(x: float) -> float:
    return 0.0 if x == 0 else math.copysign(1.0, x)


def _heaviside(x: float, half: float = 0.5) -> float:
    return 0.0 if x < 0 else 1.0 if x > 0 else half


FUNCTIONS = {
    sp.sin: math.sin, sp.cos: math.cos, sp.tan: math.tan, sp.asin: math.asin,
    sp.acos: math.acos, sp.atan: math.atan, sp.atan2: math.atan2, sp.sinh: math.sinh,
    sp.cosh: math.cosh, sp.tanh: math.tanh, sp.exp: math.exp, sp.log: math.log,
    sp.Abs: abs, sp.sign: _sign, sp.Min: min, sp.Max: max, sp.Heaviside: _heaviside,
}
_RELATIONS = {sp.StrictLessThan: lambda a, b: a < b, sp.LessThan: lambda a, b: a <= b,
              sp.StrictGreaterThan: lambda a, b: a > b, sp.GreaterThan: lambda a, b: a >= b,
              sp.Eq: lambda a, b: a == b, sp.Ne: lambda a, b: a != b}


class Evaluator:
    """Values of expressions in the symbols of ``values`` (symbol -> float)."""

    def __init__(self, values: Mapping[sp.Symbol, float]):
        self.values = {s: float(v) for s, v in values.items()}
        self.memo: dict[sp.Basic, float] = {}

    def __call__(self, expr) -> float:
        expr = as_expr(expr)
        return self._value(expr)

    def matrix(self, matrix: sp.MatrixBase) -> np.ndarray:
        return np.array([[self._value(matrix[i, j]) for j in range(matrix.cols)]
                         for i in range(matrix.rows)], dtype=float).reshape(matrix.shape)

    def vector(self, exprs) -> np.ndarray:
        return np.array([self._value(e) for e in exprs], dtype=float)

    def _value(self, e: sp.Basic) -> float:
        found = self.memo.get(e)
        if found is not None:
            return found
        if e.is_Symbol:
            if e not in self.values:
                raise ValueError(f"no value for {e}")
            result = self.values[e]
        elif e.is_Number or e.is_NumberSymbol:
            result = float(e)
        elif e.is_Add:
            result = math.fsum(self._value(a) for a in e.args)
        elif e.is_Mul:
            result = 1.0
            for a in e.args:
                result *= self._value(a)
        elif e.is_Pow:
            base, exponent = self._value(e.base), self._value(e.exp)
            try:
                result = math.pow(base, exponent)
            except (ValueError, ZeroDivisionError, OverflowError):
                raise ValueError(f"{e} is not a finite real number here") from None
        elif isinstance(e, sp.Piecewise):
            result = math.nan
            for branch, condition in e.args:
                if self._truth(condition):
                    result = self._value(branch)
                    break
        elif e.func in FUNCTIONS:
            try:
                result = float(FUNCTIONS[e.func](*(self._value(a) for a in e.args)))
            except (ValueError, ZeroDivisionError, OverflowError):
                raise ValueError(f"{e} is not a finite real number here") from None
        else:
            raise ValueError(f"cannot evaluate {type(e).__name__} {e}")
        if not math.isfinite(result):
            raise ValueError(f"{e} is not a finite real number here")
        self.memo[e] = result
        return result

    def _truth(self, condition) -> bool:
        if condition is sp.true or condition == True:       # noqa: E712  SymPy's true
            return True
        if condition is sp.false or condition == False:     # noqa: E712
            return False
        if type(condition) in _RELATIONS:
            return _RELATIONS[type(condition)](self._value(condition.lhs),
                                               self._value(condition.rhs))
        if isinstance(condition, sp.And):
            return all(self._truth(c) for c in condition.args)
        if isinstance(condition, sp.Or):
            return any(self._truth(c) for c in condition.args)
        if isinstance(condition, sp.Not):
            return not self._truth(condition.args[0])
        raise ValueError(f"cannot evaluate the condition {condition}")
