"""The one contract between the formulations and everything else:

    M(q) ddq = F(t, q, dq) + B(q) tau

in the generalized speeds: ``dq`` are the speeds u and ``ddq`` their rates du.
For every joint but a spherical one the speeds are the coordinates' rates
(u = dq, ``kinematic`` None).  A robot with a spherical joint has more
coordinates (nq: its quaternion's four) than speeds (n: its angular velocity's
three, body axes), and ``kinematic`` carries the kinematic differential
equations dq = W(q) u as nq expressions of q and u (``rates`` names the
coordinates' rates d<q> they give); then M du = F(t, q, u) + B tau.

M is n x n, B is n x m (actuator efforts tau, in the order of the robot's
actuators), F is n x 1: gravity and velocity-product terms plus Q, the
generalized forces of the joint forces (damping, friction, springs) and the
external loads.  Only loads depend on t; without them F is F(q, dq).  Q is
also kept on its own (n x 1, zero for a robot without such forces) so that
the equations can show it apart; it is already part of F.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

TIME = sp.Symbol("t", real=True)


@dataclass(frozen=True)
class EquationsOfMotion:
    formulation: str                     # "kane" or "lagrange"
    q: tuple[sp.Symbol, ...]
    dq: tuple[sp.Symbol, ...]
    ddq: tuple[sp.Symbol, ...]
    efforts: tuple[sp.Symbol, ...]       # tau, one symbol per actuator
    M: sp.ImmutableMatrix
    F: sp.ImmutableMatrix
    B: sp.ImmutableMatrix
    symbolic: bool = False               # parameters left as symbols
    Q: sp.ImmutableMatrix | None = None  # joint forces and loads (part of F); None: zero
    #: dq = W(q) u (nq x 1) when the speeds ``dq`` are not the coordinates' rates
    kinematic: sp.ImmutableMatrix | None = None

    @property
    def rates(self) -> tuple[sp.Symbol, ...]:
        """The coordinates' rates d<q> (the speeds themselves unless ``kinematic``)."""
        if self.kinematic is None:
            return self.dq
        return tuple(sp.Symbol("d" + s.name, real=True) for s in self.q)

    @property
    def t(self) -> sp.Symbol:
        """Time, as it appears in F through the loads."""
        return TIME

    @property
    def joint_forces_and_loads(self) -> sp.ImmutableMatrix:
        """Q (n x 1), zeros when the robot has no joint forces or loads."""
        return self.Q if self.Q is not None else sp.ImmutableMatrix.zeros(len(self.dq), 1)

    @property
    def residuals(self) -> list[sp.Expr]:
        """Left-hand sides of ``M ddq - F - B tau = 0``, one per speed."""
        tau = sp.Matrix(len(self.efforts), 1, list(self.efforts))   # n x 1 even when m = 0
        lhs = self.M * sp.Matrix(self.ddq) - self.F - self.B * tau
        return list(lhs)

    @property
    def parameters(self) -> set[sp.Symbol]:
        """Symbols other than q, the speeds, tau (non-empty only when symbolic)."""
        known = set(self.q) | set(self.dq) | set(self.efforts) | {TIME}
        found: set[sp.Symbol] = set()
        for matrix in (self.M, self.F, self.B):
            found |= matrix.free_symbols
        return found - known
