"""The recursive evaluator of a linearization: ``RecursiveEquations``, the interface
of ``equations.Road`` on the generated derivatives of the recursive Newton-Euler
algorithm (``numeric.derivatives``: exact, the analytic derivatives of the traced
recursions or their forward-mode differentiation, no symbolic equations of
motion).  Open trees of revolute and prismatic joints (their couplings, springs,
dampers, friction and loads too); a spherical joint is the closed forms'
(``covers``)."""
from __future__ import annotations

import numpy as np
import sympy as sp

from .equations import Road


def covers(robot) -> bool:
    """Whether the recursive evaluator linearizes ``robot`` (an open tree without
    contacts, which linearize refuses anyway): no spherical joint."""
    return not robot.spherical


def _finite(*arrays):
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise ValueError("a value that is not a finite number")
    return arrays if len(arrays) > 1 else arrays[0]


class RecursiveEquations(Road):
    """``equations.Road`` by ``numeric.derivatives.Derivatives`` (generated Python,
    vectorized by NumPy: a linearization needs a handful of points, so no C is
    compiled): M from the inverse dynamics' d(ID)/d(ddq), ddq and M^-1 B from the
    forward dynamics and its derivatives, F = M ddq(tau = 0) and B = M (M^-1 B)."""
    evaluator = "recursive"

    def __init__(self, robot):
        from ...numeric.derivatives import derivatives

        super().__init__(robot, robot.q, robot.dq,
                         [sp.Symbol(a.name, real=True) for a in robot.actuators])
        self.derivatives = derivatives(robot, native=False)

    def _state(self, q, dq):
        return np.asarray(q, dtype=float), np.asarray(dq, dtype=float)

    def terms(self, t, q, dq):
        q, dq = self._state(q, dq)
        d = self.derivatives
        M = _finite(d.inverse_derivatives(t, q, dq, np.zeros(self.n))[2])
        np.linalg.cholesky(M)
        free = self.accelerations(t, q, dq, np.zeros(self.m))
        G = self.slopes(t, q, dq, np.zeros(self.m))[1]
        return M, M @ free, M @ G

    def accelerations(self, t, q, dq, tau) -> np.ndarray:
        q, dq = self._state(q, dq)
        return _finite(self.derivatives.forward_dynamics(t, q, dq, np.asarray(tau, dtype=float)))

    def slopes(self, t, q, dq, tau):
        q, dq = self._state(q, dq)
        Dq, Ddq, G = _finite(*self.derivatives.forward_derivatives(
            t, q, dq, np.asarray(tau, dtype=float)))
        return np.hstack([Dq, Ddq]), G
