"""The constraint equations of a closed chain, from the shared kinematics.

With the robot's constraints (``model.constraints``), in the order
holonomic rows first (loops, then position entries), then velocity rows:

    holonomic     f(q, t) = 0,  f = (r_a - r_b) . e  for a loop, r the world
                  position of a point (r = p_i + R_i (point - com_i) on body i,
                  the point itself on the ground) and e a world axis;
                  f = the expression for a position entry
    velocity form A(q, t) dq + a0(q, t) = 0   (Pfaffian form, eqs. 6.6 and 6.8):
                  A = df/dq, a0 = df/dt for a holonomic row; the file's
                  coefficients and constant term for a velocity row
    acceleration  A ddq = b,  b = -(dA/dt dq + da0/dt), the time derivatives
                  along the motion with ddq = 0 (what differentiating the
                  velocity form once more leaves besides A ddq)

The multipliers lambda enter the equations of motion as
M ddq = F + B tau + A^T lambda; for a loop row, lambda is the force on body a
at its point along the world axis, with the opposite force on body b.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .derivative import Derivative
from .eom import TIME
from .kinematics import Kinematics
from ..model.names import GROUND
from ..model.robot import Robot

Matrix = sp.ImmutableMatrix
AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class ConstraintEquations:
    q: tuple[sp.Symbol, ...]
    dq: tuple[sp.Symbol, ...]
    f: Matrix                    # h x 1, holonomic residuals f(q, t)
    A: Matrix                    # c x n
    a0: Matrix                   # c x 1
    b: Matrix                    # c x 1, A ddq = b
    holonomic: int               # h: the first h rows are holonomic
    labels: tuple[str, ...]      # the multipliers' column names, one per row

    @property
    def count(self) -> int:
        return self.A.rows

    @property
    def velocity_residual(self) -> Matrix:
        """A dq + a0 (c x 1)."""
        return Matrix(self.A * Matrix(self.dq) + self.a0)


def point_position(kin: Kinematics, body: str, point) -> Matrix:
    """World position of ``point`` (body axes) of ``body``; of the world point on ground."""
    p = Matrix(point)
    if body == GROUND:
        return p
    b = next(b for b in kin.bodies if b.body.name == body)
    return Matrix(b.position + b.R * (p - b.com))


def build(robot: Robot, kin: Kinematics) -> ConstraintEquations:
    """The constraint equations of ``robot`` (parameters substituted as in ``kin``)."""
    closing = robot.constraints
    values = robot.parameter_substitution(kin.symbolic)

    def sub(expr: sp.Expr) -> sp.Expr:
        return expr.xreplace(values) if values else expr

    q, dq = kin.q, kin.dq
    f = []
    for loop in closing.loops:
        gap = (point_position(kin, loop.a.body, [sub(v) for v in loop.a.point])
               - point_position(kin, loop.b.body, [sub(v) for v in loop.b.point]))
        f += [gap[AXES[axis]] for axis in loop.directions]
    f += [sub(entry.expression) for entry in closing.positions]
    along = [Derivative({qk: 1}) for qk in q]
    in_time = Derivative({TIME: 1})
    rows = [[d(fj) for d in along] for fj in f]
    constant = [in_time(fj) for fj in f]
    for entry in closing.velocities:
        rows.append([sub(entry.coefficients.get(s.name, sp.Integer(0))) for s in q])
        constant.append(sub(entry.constant))
    A, a0 = Matrix(rows) if rows else Matrix.zeros(0, len(q)), Matrix(constant)
    rate = Derivative({**dict(zip(q, dq)), TIME: 1})   # d/dt along the motion, ddq = 0
    residual = A * Matrix(dq) + a0
    b = Matrix([-rate(g) for g in residual])
    return ConstraintEquations(q, dq, Matrix(f) if f else Matrix.zeros(0, 1), A, a0, b,
                               len(f), tuple(r.column for r in closing.rows))
