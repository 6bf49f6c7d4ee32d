"""Inverse dynamics of a closed chain: efforts and multipliers for a prescribed
motion of the independent coordinates, and its round trip."""
from __future__ import annotations

import math
import time

import numpy as np

from ...errors import ModelError, NumericalError
from .dynamics import ConstrainedModel

ROUNDTRIP_RTOL, ROUNDTRIP_ATOL = 1e-11, 1e-12
AMPLIFICATION = 1e3           # largest growth of a deviation within one round-trip segment
GROWTH_SAMPLES = 21
VELOCITY_TOL = 1e-8           # |A dq + a0| a prescribed motion may leave (velocity rows)


class ClosedChainInverse:
    """Efforts (and multipliers) for a prescribed motion of the independent coordinates.

    The motion gives q_i(t), dq_i(t), ddq_i(t) for the coordinates not marked
    dependent; the dependent ones follow by Newton's method on f(q, t) = 0
    (started from the previous row, so the assembly mode is kept), their rates
    from the holonomic rows of A dq + a0 = 0 and their accelerations from
    A ddq = b.  A velocity constraint must hold along the prescribed motion
    (checked).  Then, with N a basis of the null space of A (the motions the
    constraints allow),

        N^T B tau = N^T (M ddq - F)      (k = n - c equations, m efforts)

    m = k: one solution; m > k (redundant actuation): the solution of least
    Euclidean norm sum tau_j^2 (the least-squares solution of an
    underdetermined system); m < k or N^T B rank-deficient: refused, naming
    the motions no actuator reaches.  The multipliers, the constraint forces,
    solve A^T lambda = M ddq - F - B tau.
    """

    def __init__(self, model: ConstrainedModel, motion, grid: np.ndarray):
        self.model, self.motion = model, motion
        self.n, self.m = model.n, model.m
        hol = set(model.dependent)
        self.prescribed = [k for k in range(self.n) if k not in hol]
        self.grid = grid
        self.q = self.dq = self.ddq = None

    def kinematics(self, t: np.ndarray, guess: np.ndarray | None = None):
        """q, dq, ddq (rows x n) along ``t`` (sorted), dependent coordinates solved."""
        model, n, h = self.model, self.n, self.model.h
        dep, pres = list(model.dependent), self.prescribed
        qp, dqp, ddqp = self.motion(t)
        rows = len(t)
        q, dq, ddq = np.array(qp, dtype=float), np.array(dqp, dtype=float), np.array(ddqp)
        current = (guess if guess is not None else model.initial_state()[:n]).copy()
        for k in range(rows):
            current[pres] = q[k, pres]
            if self.grid is not None and self.q is not None:        # nearest solved row
                near = int(np.clip(np.searchsorted(self.grid, t[k]), 0, len(self.grid) - 1))
                current[dep] = self.q[near, dep]
            try:
                current = model.close(float(t[k]), current)
            except NumericalError:
                where = ", ".join(f"{model.info.coordinates[i].name} = {current[i]:.6g}"
                                  for i in pres)
                raise ModelError(f"the prescribed motion leaves the mechanism's reach at t = "
                                 f"{t[k]:g} s: the constraints cannot be closed there "
                                 f"({where})", source=model.info.source,
                                 path="trajectory") from None
            q[k] = current
            A, a0, _ = model._pfaffian(float(t[k]), *current.tolist())
            if h:
                dq[k, dep] = np.linalg.solve(A[:h, dep], -(A[:h, pres] @ dq[k, pres] + a0[:h]))
                b = np.asarray(model._bias(float(t[k]), *current.tolist(), *dq[k].tolist()))
                ddq[k, dep] = np.linalg.solve(A[:h, dep], b[:h] - A[:h, pres] @ ddq[k, pres])
        return q, dq, ddq

    def check_velocity(self, t, q, dq, source: str) -> None:
        model = self.model
        if model.c == model.h:
            return
        for k in range(len(t)):
            A, a0, _ = model._pfaffian(float(t[k]), *q[k].tolist())
            g = (A @ dq[k] + a0)[model.h:]
            scale = max(1.0, float(np.abs(A[model.h:]).max() * np.abs(dq[k]).max()))
            worst = int(np.argmax(np.abs(g)))
            if abs(g[worst]) > VELOCITY_TOL * scale:
                row = model.rows[model.h + worst]
                raise ModelError(f"the prescribed motion breaks the velocity constraint "
                                 f"{row.source} (sum a_k dq_k + a_0 = {g[worst]:.3g} at t = "
                                 f"{t[k]:g} s); a trajectory of a robot with velocity "
                                 "constraints must satisfy them", source=source,
                                 path="trajectory")

    def solve(self, t: float, q, dq, ddq):
        """(tau, lambda, whether N^T B keeps full row rank) at one point."""
        model = self.model
        M, F, B, _, A, _, _, _ = model._terms(t, *q.tolist(), *dq.tolist())
        demand = M @ ddq - F
        N = np.linalg.svd(A)[2][model.c:].T
        P = N.T @ B
        tau = np.linalg.lstsq(P, N.T @ demand, rcond=None)[0] if self.m else np.zeros(0)
        lam = np.linalg.lstsq(A.T, demand - (B @ tau if self.m else 0.0), rcond=None)[0]
        size = max(1.0, float(np.abs(P).max(initial=0.0)))
        full = (not P.shape[0]) or (P.size and np.linalg.matrix_rank(P, tol=1e-10 * size)
                                    == P.shape[0])
        return tau, lam, bool(full)

    def actuation(self, t: float, q, dq) -> tuple[int, int, np.ndarray]:
        """(rank of N^T B, k, N^T B) at one point."""
        model = self.model
        _, _, B, _, A, _, _, _ = model._terms(t, *q.tolist(), *dq.tolist())
        N = np.linalg.svd(A)[2][model.c:].T
        P = N.T @ B if self.m else np.zeros((N.shape[1], 0))
        size = max(1.0, float(np.abs(P).max(initial=0.0)))
        rank = np.linalg.matrix_rank(P, tol=1e-10 * size) if P.size else 0
        return rank, N.shape[1], P

    def along(self, t, q, dq, ddq):
        """(tau rows x m, lambda rows x c, first row where the actuators lose a motion
        or None)."""
        tau = np.zeros((len(t), self.m))
        lam = np.zeros((len(t), self.model.c))
        lost = None
        for k in range(len(t)):
            tau[k], lam[k], full = self.solve(float(t[k]), q[k], dq[k], ddq[k])
            if not full and lost is None:
                lost = k
        return tau, lam, lost

    def efforts(self, t):
        """(q, dq, ddq, tau) at the times ``t`` (the inverse table's interface)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q, dq, ddq = self.kinematics(t)
        return q, dq, ddq, self.along(t, q, dq, ddq)[0]

    def effort_at(self, t: float) -> np.ndarray:
        q, dq, ddq = self.kinematics(np.array([t]))
        return self.solve(float(t), q[0], dq[0], ddq[0])[0]

    def round_trip(self, t, q, dq, segment: float | None, tolerance: float) -> dict:
        """The constrained direct dynamics driven by tau(t) against the prescribed
        independent coordinates, in segments each started from the prescribed state
        (as ``services.inverse.round_trip`` does for trees)."""
        from .. import integrators

        start_clock = time.perf_counter()
        problem = self.model.driven_problem(self.effort_at)
        samples = np.linspace(t[0], t[-1], min(GROWTH_SAMPLES, len(t)))
        index = np.clip(np.searchsorted(t, samples), 0, len(t) - 1)
        rates = []
        for k in index:
            x = np.concatenate([q[k], dq[k]])
            lam = integrators.eigenvalues(problem.jacobian, float(t[k]), x)
            rates.append(float(lam.real.max()) if lam is not None else 0.0)
        rates = np.array(rates)
        rate = float(rates.max(initial=0.0))
        growing = np.maximum(rates, 0.0)
        growth = float(np.sum((growing[1:] + growing[:-1]) / 2 * np.diff(t[index])))
        if segment is None:
            count = max(1, math.ceil(rate * (t[-1] - t[0]) / math.log(AMPLIFICATION) - 1e-9))
        else:
            count = max(1, math.ceil((t[-1] - t[0]) / segment - 1e-9))
        targets = np.linspace(t[0], t[-1], count + 1)
        rows = np.unique(np.concatenate([[0], np.searchsorted(t, targets).clip(0, len(t) - 1),
                                         [len(t) - 1]]))
        error = np.zeros((len(t), len(self.prescribed)))
        calls = steps = 0
        pres = self.prescribed
        for first, last in zip(rows[:-1], rows[1:]):
            x0 = np.concatenate([q[first], dq[first]])
            solution = integrators.integrate(problem, x0, t[first:last + 1], "odeint",
                                             ROUNDTRIP_RTOL, ROUNDTRIP_ATOL, stop_at_end=True)
            calls, steps = calls + solution.rhs_calls, steps + solution.steps
            if not solution.success:
                raise NumericalError(f"{self.model.info.source}: round trip: the direct "
                                     f"dynamics failed: {solution.message}")
            error[first:last + 1] = np.maximum(
                error[first:last + 1], np.abs(solution.x[:, pres] - q[first:last + 1][:, pres]))
        row, column = np.unravel_index(int(np.argmax(error)), error.shape)
        names = [c.name for c in self.model.info.coordinates]
        return {"method": "odeint (LSODA)", "rtol": ROUNDTRIP_RTOL, "atol": ROUNDTRIP_ATOL,
                "tolerance": tolerance, "max_error": float(error[row, column]),
                "coordinate": names[pres[column]], "time": float(t[row]),
                "errors": {names[k]: float(e) for k, e in zip(pres, error.max(axis=0))},
                "final_error": float(error[-1].max()), "rhs_calls": calls, "steps": steps,
                "wall": time.perf_counter() - start_clock,
                "segments": len(rows) - 1, "segment": float((t[-1] - t[0]) / (len(rows) - 1)),
                "growth_rate": rate, "growth_time": float(t[index][int(np.argmax(rates))]),
                "growth": growth}
