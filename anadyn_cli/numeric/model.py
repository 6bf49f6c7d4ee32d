"""Generated numeric functions, loaded and wrapped for the integrators.

Only NumPy is imported here: a robot whose generated source is cached runs
without importing SymPy.  The source is anadyn's own output (from
``numeric.source``), never text from a robot file.

    rhs(t, x)      -> dx/dt = [dq, ddq], M ddq = G   (a fresh array each call)
    jacobian(t, x) -> [[0, I], [M^-1 K]]     (2n x 2n)
"""
from __future__ import annotations

import math

import numpy as np


class CompiledRobot:
    """State x = [q, dq]; counts the calls the integrators make."""

    def __init__(self, source: str):
        namespace: dict[str, object] = {}
        exec(compile(source, "<anadyn generated>", "exec"), namespace)   # noqa: S102
        self.source = source
        self.coordinates: tuple[str, ...] = namespace["COORDINATES"]
        self.effort_names: tuple[str, ...] = namespace["EFFORTS"]
        self.n = len(self.coordinates)
        self._accelerations = namespace["accelerations"]
        self._jacobian = namespace["dynamics_jacobian"]
        self._efforts = namespace["efforts"]
        self._mfb = namespace["mfb"]
        self._potential = namespace["potential"]
        self.rhs_calls = 0
        self.jacobian_calls = 0
        self.failure: tuple[float, np.ndarray, str] | None = None   # first bad state

    def reset_counters(self) -> None:
        self.rhs_calls = self.jacobian_calls = 0
        self.failure = None

    def _fail(self, t: float, x: np.ndarray, why: str) -> np.ndarray:
        """Record the first failure and hand the integrator NaNs, which it cannot step over."""
        if self.failure is None:
            self.failure = (float(t), np.array(x, dtype=float), why)
        return np.full(2 * self.n, np.nan)

    def accelerations(self, t: float, x) -> list[float]:
        """ddq solving M ddq = G at one state (np.linalg.LinAlgError if M is singular)."""
        return self._accelerations(t, *x.tolist())

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        self.rhs_calls += 1
        values = x.tolist()
        try:
            out = np.array(values[self.n:] + self._accelerations(t, *values))
        except np.linalg.LinAlgError:
            return self._fail(t, x, "singular mass matrix")
        except (OverflowError, ValueError, ZeroDivisionError) as err:
            return self._fail(t, x, f"cannot evaluate the equations ({err})")
        if not math.isfinite(out.sum()):
            return self._fail(t, x, "non-finite state derivative")
        return out

    def rhs_tfirst(self, x: np.ndarray, t: float) -> np.ndarray:
        """``rhs`` with odeint's argument order (x, t)."""
        return self.rhs(t, x)

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        self.jacobian_calls += 1
        n = self.n
        values = x.tolist()
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        try:
            M, K = self._jacobian(t, *values, *self._accelerations(t, *values))
            J[n:, :] = np.linalg.solve(M, K)
        except (np.linalg.LinAlgError, OverflowError, ValueError, ZeroDivisionError) as err:
            self._fail(t, x, "singular mass matrix" if isinstance(err, np.linalg.LinAlgError)
                       else f"cannot evaluate the equations ({err})")
            J[n:, :] = np.nan
        if not np.isfinite(J).all():
            self._fail(t, x, "non-finite Jacobian")
        return J

    def finite_jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        """``jacobian`` with a failure (recorded) given as zeros, not NaN: solve_ivp's
        LU factorization raises on NaN, while a NaN RHS stops the step as it should."""
        return np.nan_to_num(self.jacobian(t, x), nan=0.0, posinf=0.0, neginf=0.0)

    def efforts(self, t, q, dq) -> np.ndarray:
        """Efforts under the control laws; q, dq of shape (n, ...) -> (m, ...)."""
        with np.errstate(all="ignore"):      # overflow or a domain error: NaN, reported
            tau = self._efforts(t, *q, *dq)   # by the caller, never a stray warning line
        return np.moveaxis(tau, -1, 0)

    def mfb(self, q, dq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """M (..., n, n), F (..., n), B (..., n, m) over arrays of states."""
        with np.errstate(all="ignore"):
            return self._mfb(*q, *dq)

    def energy(self, q, dq) -> tuple[np.ndarray, np.ndarray]:
        """(T, V) over arrays of states: T = 1/2 dq^T M dq, V of gravity."""
        with np.errstate(all="ignore"):
            M, _, _ = self._mfb(*q, *dq)
            rates = np.moveaxis(np.asarray(dq, dtype=float), 0, -1)
            kinetic = 0.5 * np.einsum("...i,...ij,...j->...", rates, M, rates)
            return kinetic, self._potential(*q)[..., 0]
