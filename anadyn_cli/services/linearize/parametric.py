"""The linearization with the parameters (and gains) as symbols: ``symbolic_form``."""
from __future__ import annotations

import sympy as sp

from .equations import TIME, Equations
from .point import OperatingPoint


def symbolic_form(robot, formulation: str, point: OperatingPoint) -> dict:
    """E dx = A_bar dx + B_bar du at the point, parameters (and gains) as symbols, from
    the closed forms of ``formulation`` (whichever evaluator gave the numbers).

    E = diag(I, M(q0)); A_bar = [[0, I], [K]]; B_bar = [[0], [B(q0)]].  K
    holds the point's efforts (the actuator symbols) and accelerations (the
    ddq symbols) unless the point is an equilibrium (ddq = 0) or passive
    (tau = 0).  Explicit A = E^-1 A_bar and B for n <= 2.
    """
    from ...symbolic.formulations import derive

    eom = derive(robot, formulation, symbolic=True)
    eq = Equations(robot, eom)
    n, m = eq.n, eq.m
    values = {TIME: point.exact[TIME]}
    for s in eq.q + eq.dq:
        values[s] = point.exact[s]
    if point.equilibrium:
        values.update({a: sp.Integer(0) for a in eq.ddq})
    if point.efforts_from == "none":
        values.update({u: sp.Integer(0) for u in eq.tau})

    def at(expr: sp.Expr) -> sp.Expr:
        """The expression at the point, functions of plain numbers (sin(3/10)) as floats."""
        expr = expr.xreplace(values)
        numbers = {f: f.evalf(17) for f in expr.atoms(sp.Function) if not f.free_symbols}
        return expr.xreplace(numbers) if numbers else expr

    M = eq.M.applyfunc(at)
    K = eq.Rx.applyfunc(at)
    B = eq.B.applyfunc(at) if m else sp.zeros(n, 0)
    eye, zero = sp.eye(n), sp.zeros(n, n)
    E = sp.diag(eye, M)
    A_bar = sp.Matrix(sp.BlockMatrix([[zero, eye], [K[:, :n], K[:, n:]]]))
    B_bar = sp.Matrix.vstack(sp.zeros(n, m), B) if m else sp.zeros(2 * n, 0)
    result = {"parameters": sorted(str(s) for s in (E.free_symbols | A_bar.free_symbols
                                                     | B_bar.free_symbols)
                                   - set(eq.tau) - set(eq.ddq)),
              "form": "E dx/dt = A_bar dx + B_bar du", "formulation": formulation,
              "E": E, "A_bar": A_bar, "B_bar": B_bar}
    closed = None
    if eq.laws is not None:
        laws = eq.laws.applyfunc(at)
        K_c = K.xreplace(dict(zip(eq.tau, laws))) + B * eq.Lx.applyfunc(at)
        closed = sp.Matrix(sp.BlockMatrix([[zero, eye], [K_c[:, :n], K_c[:, n:]]]))
        result["A_bar_closed_loop"] = closed
    if n <= 2:
        Minv = M.inv()
        lower = (Minv * K).applyfunc(_tidy)
        result["A"] = sp.Matrix(sp.BlockMatrix([[zero, eye], [lower[:, :n], lower[:, n:]]]))
        result["B"] = (sp.Matrix.vstack(sp.zeros(n, m), (Minv * B).applyfunc(_tidy)) if m
                       else sp.zeros(2 * n, 0))
        if closed is not None:
            lower = (Minv * closed[n:, :]).applyfunc(_tidy)
            result["A_closed_loop"] = sp.Matrix.vstack(closed[:n, :], lower)
    note = []
    if not point.equilibrium:
        note.append("ddq symbols are the accelerations at the point")
    if m and point.efforts_from != "none":
        note.append("actuator symbols are the efforts at the point")
    result["note"] = "; ".join(note) or "at an equilibrium"
    return result


def _tidy(expr: sp.Expr) -> sp.Expr:
    """A rational function of the parameters in lowest terms (cheap; no simplify)."""
    return sp.factor_terms(sp.cancel(expr)) if sp.count_ops(expr) < 2000 else expr


def as_strings(matrix: sp.Matrix) -> list[list[str]]:
    return [[sp.sstr(matrix[i, j]) for j in range(matrix.cols)] for i in range(matrix.rows)]
