"""The equations of motion of a linearization, differentiated once, and their
values at a point."""
from __future__ import annotations

import numpy as np
import sympy as sp

from ...errors import NumericalError
from ...numeric.pointwise import Evaluator
from ...symbolic.derivative import Derivative

TIME = sp.Symbol("t", real=True)


class Equations:
    """R = F + B tau - M ddq with tau and ddq as symbols, its Jacobian in x, the laws'."""

    def __init__(self, robot, eom):
        self.q, self.dq = list(eom.q), list(eom.dq)
        self.ddq, self.tau = list(eom.ddq), list(eom.efforts)
        self.n, self.m = len(self.dq), len(self.tau)      # speeds (the size of M), efforts
        self.nq = len(self.q)                              # coordinates: n, or more with a
        self.kinematic = eom.kinematic                     # quaternion (dq = W(q) u)
        self.M, self.F, self.B = sp.Matrix(eom.M), sp.Matrix(eom.F), sp.Matrix(eom.B)
        R = self.F - self.M * sp.Matrix(self.ddq)
        if self.m:
            R += self.B * sp.Matrix(self.tau)
        self.R = R
        self.laws = None
        if robot.controller is not None and self.m:
            from ...numeric.closed_form import control_laws
            self.laws = control_laws(robot, eom.symbolic)
        self.Rx = self._jacobian(R)
        self.Lx = self._jacobian(self.laws) if self.laws is not None else None

    def _jacobian(self, exprs: sp.Matrix) -> sp.Matrix:
        columns = []
        for variable in self.q + self.dq:
            d = Derivative({variable: 1})
            columns.append([d(e) for e in exprs])
        return sp.Matrix(len(exprs), self.nq + self.n, lambda i, j: columns[j][i])

    def values(self, t, q, dq, tau=None, ddq=None, constants=None) -> dict:
        values = dict(constants or {})
        values[TIME] = t
        values.update(zip(self.q, q))
        values.update(zip(self.dq, dq))
        if tau is not None:
            values.update(zip(self.tau, tau))
        if ddq is not None:
            values.update(zip(self.ddq, ddq))
        return values


def evaluate(ev: Evaluator, what: str, function):
    try:
        return function()
    except ValueError as err:
        raise NumericalError(f"cannot evaluate the {what} at the operating point ({err})") \
            from None


def solve_spd(M: np.ndarray, rhs: np.ndarray, where: str) -> np.ndarray:
    try:
        np.linalg.cholesky(M)
        return np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError:
        raise NumericalError(f"the mass matrix is singular or not positive definite at {where}") \
            from None
