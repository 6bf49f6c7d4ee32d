"""Readable equations of motion: the chapter's "... = 0" form, or M, F, B.

    residual_r = sum_s M_rs ddq_s - F_r - sum_k B_rk tau_k = 0

Small systems are shown with their trigonometric terms recombined
(``sympy.trigsimp``) and collected by accelerations and efforts; larger
ones are printed as derived.  Numeric systems print decimals, symbolic
ones exact numbers.
"""
from __future__ import annotations

import sympy as sp

from .canonical import fits
from .eom import EquationsOfMotion
from ..errors import ModelError

FORMATS = ("text", "latex")
FORMS = ("residual", "matrices")


def render(eom: EquationsOfMotion, fmt: str = "text", form: str = "residual") -> str:
    if fmt not in FORMATS:
        raise ModelError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    if form not in FORMS:
        raise ModelError(f"unknown form {form!r}; choose one of {', '.join(FORMS)}")
    readable = fits([*eom.M, *eom.F, *eom.B])
    show = _printer(fmt, eom.symbolic)

    def tidy(expr: sp.Expr, collect: bool = False) -> sp.Expr:
        if readable:
            expr = sp.trigsimp(expr)
            if collect:
                expr = sp.collect(expr, [*eom.ddq, *eom.efforts])
        return expr

    lines = [f"# {eom.method} equations, "
             f"{'symbolic parameters' if eom.symbolic else 'numeric parameters'}"]
    if form == "residual":
        for q, residual in zip(eom.q, eom.residuals):
            lines.append(f"{q}: {show(tidy(residual, collect=True))} = 0")
        return "\n".join(lines)
    for name, matrix in (("M", eom.M), ("F", eom.F), ("B", eom.B)):
        for i in range(matrix.rows):
            for j in range(matrix.cols):
                if name == "M" and j < i:
                    continue          # symmetric
                index = f"{i + 1},{j + 1}" if matrix.cols > 1 or name == "B" else f"{i + 1}"
                lines.append(f"{name}[{index}] = {show(tidy(matrix[i, j]))}")
    return "\n".join(lines)


def _printer(fmt: str, exact: bool):
    def show(expr: sp.Expr) -> str:
        if not exact:
            expr = expr.xreplace({r: sp.Float(r, 8) for r in expr.atoms(sp.Rational)
                                  if not r.is_Integer})
        if fmt == "latex":
            return sp.latex(expr)
        return sp.sstr(expr, full_prec=False)
    return show
