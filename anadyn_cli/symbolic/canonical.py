"""A canonical form for small trigonometric polynomials, within a size budget.

    canonical(e) = expand(reduce(expand(expand_trig(e))))

where reduce rewrites sin(x)**k as sin(x)**(k mod 2) (1 - cos(x)**2)**(k div 2).
Sines and cosines of sums are split into products of single angles, so two
expressions that are equal by the Pythagorean and angle-sum identities get
the same form, and one that is identically zero becomes 0.  Expansion can
grow exponentially, so ``expanded_terms`` bounds it first and larger
expressions are returned unchanged.

Two kinds of function are kept whole (their arguments put in canonical form
themselves): tanh, the smoothed friction, whose expansion of a sum or a
multiple angle (tanh(100 dq)) explodes; and anything of the time t, the
loads the user wrote, e.g. sin(10 t).  Both come from the same expressions
in either formulation, so they need no identities to cancel.
"""
from __future__ import annotations

import sympy as sp

TERM_BUDGET = 1000      # for a whole system of equations
TIME = sp.Symbol("t", real=True)


def expanded_terms(expr: sp.Expr, limit: int = TERM_BUDGET,
                   cache: dict | None = None) -> int:
    """Upper bound on the number of terms of the full expansion (capped past limit)."""
    cache = {} if cache is None else cache

    def size(e: sp.Expr) -> int:
        if e in cache:
            return cache[e]
        if e.is_Add:
            value = sum(size(a) for a in e.args)
        elif e.is_Mul:
            value = 1
            for a in e.args:
                value = min(value * size(a), limit + 1)
        elif e.is_Pow and e.exp.is_Integer and e.exp > 0:
            base = size(e.base)
            value = base if base <= 1 else (limit + 1 if e.exp > limit
                                            else min(base ** int(e.exp), limit + 1))
        elif isinstance(e, (sp.sin, sp.cos)) and e.args[0].is_Add:
            value = min(2 ** (len(e.args[0].args) - 1), limit + 1)
        else:
            value = 1
        cache[e] = min(value, limit + 1)
        return cache[e]

    return size(expr)


def _reduce_sine_squares(expr: sp.Expr) -> sp.Expr:
    def is_sine_power(e):
        return e.is_Pow and isinstance(e.base, sp.sin) and e.exp.is_Integer and e.exp >= 2

    def rewrite(e):
        k = int(e.exp)
        return e.base ** (k % 2) * (1 - sp.cos(e.base.args[0]) ** 2) ** (k // 2)

    return expr.replace(is_sine_power, rewrite)


def canonical(expr: sp.Expr) -> sp.Expr:
    """The canonical form of ``expr`` (check its size with ``fits`` first)."""
    if expr.is_Number:
        return expr
    hidden: dict[sp.Expr, sp.Dummy] = {}
    if expr.has(sp.tanh) or TIME in expr.free_symbols:
        expr = _hide(expr, hidden)
    result = sp.expand(_reduce_sine_squares(sp.expand(sp.expand_trig(expr))))
    return result.xreplace({d: e for e, d in hidden.items()}) if hidden else result


def _hide(expr: sp.Expr, hidden: dict) -> sp.Expr:
    """``expr`` with tanh(...) and functions of t replaced by placeholders (``hidden``)."""
    if expr.is_Atom:
        return expr
    if isinstance(expr, sp.Function) and (isinstance(expr, sp.tanh)
                                          or TIME in expr.free_symbols):
        whole = expr.func(*[canonical(a) for a in expr.args])
        return hidden.setdefault(whole, sp.Dummy())
    return expr.func(*[_hide(a, hidden) for a in expr.args])


def fits(exprs, budget: int = TERM_BUDGET) -> bool:
    """Whether all of ``exprs`` together expand to at most ``budget`` terms."""
    cache: dict[sp.Expr, int] = {}
    total = 0
    for expr in exprs:
        total += expanded_terms(expr, budget, cache)
        if total > budget:
            return False
    return True
