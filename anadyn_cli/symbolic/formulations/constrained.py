"""Equations of motion of a constrained robot, reduced to the independent speeds.

The tree (the robot with its loops cut) has M ddq = F + B tau from either
formulation; the constraints (``symbolic.constraints``) are A dq + a0 = 0
and A ddq = b.  Split the speeds into c dependent ones (the dependent
coordinates' rates, then one per velocity constraint: ``dependent_speeds``)
and n - c independent ones u, and write A = [A_i | A_d] accordingly:

    dq  = T u + t0,     T = [I; C],  C = -A_d^-1 A_i,  t0 = [0; -A_d^-1 a0]

(rows in coordinate order).  The equations projected on the independent
speeds, with ddq = T du + e:

    T^T M T du = T^T (F - M e) + T^T B tau

Both formulations end in this form; they differ in the tree equations and
in how they get e, the dependent accelerations at du = 0:

* **Kane's method with dependent speeds** differentiates the dependent
  speeds u_d = C u + c0 along the motion (e = d/dt(T u + t0) at du = 0) and
  takes the generalized active and inertia forces of the tree, Fr + Fr* =
  F + B tau - M ddq, combined by the nonholonomic partial velocities T:
  F~r = T^T (Fr + Fr*) = 0;
* **Lagrange's equations with multipliers**, M ddq = F + B tau + A^T lambda
  with A ddq = b, take e = [0; A_d^-1 b] and eliminate the multipliers by
  T^T A^T = (A T)^T = 0.

Everything is a function of all the coordinates q, the independent rates u
and t, with the dependent rates replaced by C u + c0.  ``compare`` proves
the two reduced systems equal (``reduced``).  The numeric models
(``numeric.constrained``) use the tree equations and the constraints
directly, so a choice of dependent speeds that becomes singular along the
motion (a knife edge turning across the axis) never stops a run.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .. import constraints as constraint_equations
from .. import kinematics
from ..derivative import Derivative
from ..eom import TIME, EquationsOfMotion
from ...model.robot import Robot

Matrix = sp.ImmutableMatrix


@dataclass(frozen=True)
class ConstrainedEquations:
    method: str
    tree: EquationsOfMotion                            # M ddq = F + B tau + A^T lambda
    constraints: constraint_equations.ConstraintEquations
    independent: tuple[int, ...]                       # indices of the independent speeds
    dependent: tuple[int, ...]                         # ... of the dependent ones
    reduced: EquationsOfMotion                         # M_r du = F_r + B_r tau


def reduced_equations(robot: Robot, tree: EquationsOfMotion, method: str) -> ConstrainedEquations:
    """Reduce equations the caller has already derived (same parameters as ``tree``)."""
    kin = kinematics.build(robot, symbolic=tree.symbolic)
    return reduce(robot, tree, constraint_equations.build(robot, kin), method)


def speeds_split(robot: Robot) -> tuple[tuple[int, ...], tuple[int, ...]]:
    names = [c.name for c in robot.coordinates]
    dependent = tuple(names.index(name) for name in robot.constraints.dependent_speeds)
    return tuple(k for k in range(len(names)) if k not in dependent), dependent


def reduce(robot: Robot, tree: EquationsOfMotion, cons, method: str) -> ConstrainedEquations:
    independent, dependent = speeds_split(robot)
    q, dq = list(tree.q), list(tree.dq)
    n = len(q)
    A, a0 = sp.Matrix(cons.A), sp.Matrix(cons.a0)
    A_i, A_d = A[:, list(independent)], A[:, list(dependent)]
    inverse = _inverse(A_d)
    C = -inverse * A_i
    c0 = -inverse * a0
    u = sp.Matrix([dq[k] for k in independent])
    rates = {dq[k]: (C * u + c0)[j] for j, k in enumerate(dependent)}
    T = sp.zeros(n, len(independent))
    for j, k in enumerate(independent):
        T[k, j] = 1
    for j, k in enumerate(dependent):
        T[k, :] = C[j, :]
    if method == "kane":
        along = Derivative({**{q[k]: dq[k] for k in range(n)}, TIME: 1})
        e_dep = [along(rates[dq[k]]) for k in dependent]       # d/dt u_d at du = 0
        e_dep = [v.xreplace(rates) for v in e_dep]
    else:
        e_dep = list(inverse * sp.Matrix(cons.b))
        e_dep = [v.xreplace(rates) for v in e_dep]
    e = sp.zeros(n, 1)
    for j, k in enumerate(dependent):
        e[k] = e_dep[j]
    M = sp.Matrix(tree.M).xreplace(rates)
    F = sp.Matrix(tree.F).xreplace(rates)
    B = sp.Matrix(tree.B).xreplace(rates)
    M_r = T.T * M * T
    F_r = T.T * (F - M * e)
    B_r = T.T * B
    reduced = EquationsOfMotion(
        formulation=method, q=tuple(q[k] for k in independent), dq=tuple(u),
        ddq=tuple(tree.ddq[k] for k in independent), efforts=tree.efforts,
        M=Matrix(M_r), F=Matrix(F_r), B=Matrix(B_r), symbolic=tree.symbolic)
    return ConstrainedEquations(method, tree, cons, independent, dependent, reduced)


def _inverse(A_d: sp.Matrix) -> sp.Matrix:
    """A_d^-1 as adjugate / determinant (c is small: one per constraint equation)."""
    if A_d.rows == 1:
        return sp.Matrix([[1 / A_d[0, 0]]])
    det = A_d.det(method="berkowitz")
    return A_d.adjugate(method="berkowitz") / det


def render_constraints(robot: Robot, fmt: str = "text", symbolic: bool = False) -> str:
    """The constraints as printed by ``anadyn equations``: the generalized constraint
    forces each equation of the tree gets, the constraints themselves and what each
    multiplier is."""
    from ..render import printer

    kin = kinematics.build(robot, symbolic=symbolic)
    cons = constraint_equations.build(robot, kin)
    show = printer(fmt, symbolic, kin.q)
    lam = sp.Matrix([sp.Symbol(label, real=True) for label in cons.labels])
    forces = sp.Matrix(cons.A).T * lam
    rows = robot.constraints.rows
    lines = ["# closed chain: M ddq = F + B tau + A^T lambda; each equation above also "
             "has - (A^T lambda)_r, the generalized constraint forces"]
    lines += [f"C[{q}] = {show(sp.trigsimp(force))}" for q, force in zip(kin.q, forces)]
    if cons.holonomic:
        lines.append("# holonomic constraints f(q, t) = 0 (a loop: point a - point b along "
                     "a world axis)")
        for label, value in zip(cons.labels, cons.f):
            lines.append(f"{label.removeprefix('lambda_')}: {show(value)} = 0")
    if cons.count > cons.holonomic:
        lines.append("# velocity constraints (eq. 6.8): sum_k a_k dq_k + a_0 = 0")
        for k in range(cons.holonomic, cons.count):
            residual = cons.velocity_residual[k]
            lines.append(f"{cons.labels[k].removeprefix('lambda_')}: {show(residual)} = 0")
    lines.append("# multipliers: " + "; ".join(
        f"{r.column}{' (' + r.unit + ')' if r.unit else ''}: {r.meaning}" for r in rows))
    lines.append(f"# dependent coordinates {', '.join(robot.constraints.dependent) or 'none'}; "
                 f"dependent speeds {', '.join(robot.constraints.dependent_speeds)}")
    return "\n".join(lines)
