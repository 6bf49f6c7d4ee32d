"""Directional derivatives of SymPy expressions, memoized over shared subtrees.

    D e = sum_x seed[x] * de/dx

``sympy.diff`` walks an expression as a tree, so a subexpression shared by
many parents (as rotation matrices are along a chain) is differentiated
once per use.  Here every distinct subexpression is differentiated once,
which keeps Lagrange's equations linear in the size of T.
"""
from __future__ import annotations

from collections.abc import Mapping

import sympy as sp

ZERO = sp.Integer(0)


class Derivative:
    """D e = sum over seeds x of seed[x] * de/dx; call it on expressions."""

    def __init__(self, seeds: Mapping[sp.Symbol, sp.Expr]):
        self.seeds = dict(seeds)
        self.memo: dict[sp.Expr, sp.Expr] = {}

    def __call__(self, expr: sp.Expr) -> sp.Expr:
        if expr.is_Atom:
            return self.seeds.get(expr, ZERO)
        found = self.memo.get(expr)
        if found is None:
            found = self.memo[expr] = self._rule(expr)
        return found

    def _rule(self, e: sp.Expr) -> sp.Expr:
        if e.is_Add:
            return sp.Add(*[self(a) for a in e.args])
        if e.is_Mul:
            args = e.args
            terms = []
            for i, a in enumerate(args):
                da = self(a)
                if da != 0:
                    terms.append(sp.Mul(*args[:i], da, *args[i + 1:]))
            return sp.Add(*terms)
        if e.is_Pow:
            base, exponent = e.args
            d_base, d_exp = self(base), self(exponent)
            result = exponent * base ** (exponent - 1) * d_base if d_base != 0 else ZERO
            if d_exp != 0:
                result += e * sp.log(base) * d_exp
            return result
        if isinstance(e, (sp.sign, sp.Heaviside, sp.DiracDelta)):
            return ZERO                     # piecewise constant: zero almost everywhere
        if isinstance(e, sp.Function):      # chain rule through sin, cos, abs, ...
            terms = []
            for i, arg in enumerate(e.args):
                d_arg = self(arg)
                if d_arg != 0:
                    terms.append(e.fdiff(i + 1) * d_arg)
            return sp.Add(*terms)
        # anything else (e.g. Piecewise from min/max): fall back to sympy
        return sp.Add(*[seed * sp.diff(e, x) for x, seed in self.seeds.items()])
