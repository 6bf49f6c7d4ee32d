"""The equations a linearization evaluates, by either of two evaluators with one
interface (``Road``): ``Equations``, the closed forms of a formulation (Kane or
Lagrange) differentiated symbolically, and the recursive Newton-Euler algorithm with
its derivatives (``recursive.road``: the generic kernel's ``KernelEquations``, else
the generated derivatives' ``RecursiveEquations``).  ``code`` says which code ran.
At a time t and state (q, dq) (q: nq coordinates, dq: n speeds; tau: m efforts):

    terms(t, q, dq)               -> M (n, n), F (n,), B (n, m)
    accelerations(t, q, dq, tau)  -> ddq solving M ddq = F + B tau
    slopes(t, q, dq, tau)         -> d(ddq)/dx (n, nq + n) at fixed tau, d(ddq)/dtau = M^-1 B
    law(t, q, dq)                 -> the control laws' efforts tau_c (m,)
    law_slopes(t, q, dq)          -> d(tau_c)/dx (m, nq + n)

(the laws: the file's controller, ``laws`` None without one; both evaluators
differentiate its few expressions symbolically).  A value that is not finite raises
ValueError, a mass matrix that is not positive definite numpy.linalg.LinAlgError;
``at_point`` words both for the operating point.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from ...errors import NumericalError
from ...numeric.pointwise import Evaluator
from ...symbolic.derivative import Derivative

TIME = sp.Symbol("t", real=True)


def jacobian(exprs: sp.Matrix, variables: list) -> sp.Matrix:
    """d(exprs)/d(variables), one column per variable (one ``Derivative`` each: its
    memo serves every expression)."""
    columns = [list(map(Derivative({v: 1}), exprs)) for v in variables]
    return sp.Matrix(len(exprs), len(variables), lambda i, j: columns[j][i])


class Road:
    """What both evaluators share: the symbols of the state and the efforts, the sizes,
    and the control laws with their Jacobian (module docstring)."""
    formulation: str | None = None
    evaluator: str = "closed-form"
    code: str = "SymPy expressions evaluated pointwise"     # what computes the numbers
    kinematic = None                # dq = W(q) u with a spherical joint (closed forms)

    def __init__(self, robot, q, dq, tau, symbolic: bool = False):
        self.q, self.dq, self.tau = list(q), list(dq), list(tau)
        self.n, self.m = len(self.dq), len(self.tau)      # speeds (the size of M), efforts
        self.nq = len(self.q)                              # coordinates: n, or more with a
        self.laws = self.Lx = None                         # quaternion
        if robot.controller is not None and self.m:
            from ...numeric.closed_form import control_laws

            self.laws = control_laws(robot, symbolic)
            self.Lx = jacobian(self.laws, self.q + self.dq)

    def values(self, t, q, dq, tau=()) -> dict:
        """The symbols' values: t, q, dq and the efforts ``tau`` when given."""
        return {TIME: t, **dict(zip(self.q, q)), **dict(zip(self.dq, dq)),
                **dict(zip(self.tau, tau))}

    def law(self, t, q, dq) -> np.ndarray:
        return Evaluator(self.values(t, q, dq)).vector(self.laws)

    def law_slopes(self, t, q, dq) -> np.ndarray:
        return Evaluator(self.values(t, q, dq)).matrix(self.Lx)

    def closed_loop_slopes(self, t, q, dq) -> np.ndarray:
        """d(ddq)/dx (n, nq + n) with the efforts under the laws, tau = tau_c(t, x)
        (zero without a controller)."""
        if self.laws is None:
            return self.slopes(t, q, dq, np.zeros(self.m))[0]
        D, G = self.slopes(t, q, dq, self.law(t, q, dq))
        return D + G @ self.law_slopes(t, q, dq)


class Equations(Road):
    """The closed forms M, F, B of ``eom`` (``symbolic.formulations.derive``) and the
    Jacobian Rx in x of R = F + B tau - M ddq, tau and ddq as symbols: M d(ddq)/dx = Rx
    at the point's tau and ddq."""

    def __init__(self, robot, eom):
        super().__init__(robot, eom.q, eom.dq, eom.efforts, eom.symbolic)
        self.formulation = eom.formulation
        self.ddq = list(eom.ddq)
        self.kinematic = eom.kinematic
        self.M, self.F, self.B = sp.Matrix(eom.M), sp.Matrix(eom.F), sp.Matrix(eom.B)
        R = self.F - self.M * sp.Matrix(self.ddq)
        if self.m:
            R += self.B * sp.Matrix(self.tau)
        self.Rx = jacobian(R, self.q + self.dq)

    def terms(self, t, q, dq):
        ev = Evaluator(self.values(t, q, dq))
        return (ev.matrix(self.M), ev.vector(self.F),
                ev.matrix(self.B) if self.m else np.zeros((self.n, 0)))

    def accelerations(self, t, q, dq, tau) -> np.ndarray:
        M, F, B = self.terms(t, q, dq)
        return spd_solve(M, F + B @ tau)

    def slopes(self, t, q, dq, tau):
        M, F, B = self.terms(t, q, dq)
        ddq = spd_solve(M, F + B @ tau)
        K = Evaluator({**self.values(t, q, dq, tau), **dict(zip(self.ddq, ddq))}).matrix(self.Rx)
        return np.linalg.solve(M, K), np.linalg.solve(M, B)


def positive_definite(M: np.ndarray) -> None:
    """numpy.linalg.LinAlgError unless the mass matrix M is positive definite to
    working precision: its smallest eigenvalue above n eps times its largest (joints
    that together move nothing in the state, or a joint that moves no inertia,
    leave M singular, and rounding decides its Cholesky factorization)."""
    values = np.linalg.eigvalsh(M)
    if values.size and not values[0] > len(M) * np.finfo(float).eps * values[-1]:
        raise np.linalg.LinAlgError("mass matrix singular to working precision")


def spd_solve(M: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """M^-1 rhs; numpy.linalg.LinAlgError unless M is positive definite
    (``positive_definite``)."""
    positive_definite(M)
    return np.linalg.solve(M, rhs)


def at_point(where: str, what: str, function):
    """``function()``, its failures as NumericalError at the operating point ``where``."""
    try:
        return function()
    except np.linalg.LinAlgError:
        raise NumericalError(f"the mass matrix is singular or not positive definite at {where}") \
            from None
    except ValueError as err:
        raise NumericalError(f"cannot evaluate the {what} at the operating point ({err})") \
            from None
