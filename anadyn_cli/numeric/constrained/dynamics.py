"""The numeric model of a constrained robot (``ConstrainedModel``: accelerations,
multipliers, the stabilized field of the package docstring) and what the
constraints did along a run (``ConstraintRun``)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import NumericalError
from ..integrators import Problem
from ..model import NumericModel
from .generation import MARKER

STABILIZATION = 10.0          # 1/s, the rate at which a drift from the constraints decays
SPLIT_LIMIT = 1e6             # |A_d^-1 A_i| above this: pivot the dependent speeds (Kane)
NEWTON_ITERATIONS = 50
SINGULAR_CONSTRAINTS = 1e8    # condition number of A above this: a singular configuration


def model_type(code: str):
    """The model class for generated ``code``: ConstrainedModel if it has constraints."""
    return ConstrainedModel if MARKER in code else NumericModel


def is_constrained(model) -> bool:
    return isinstance(model, ConstrainedModel)


class ConstrainedModel(NumericModel):
    """A constrained robot's generated functions; see the module docstring."""

    def __init__(self, info, source: str, formulation: str = "kane",
                 stabilization: float = STABILIZATION):
        super().__init__(info, source, formulation)
        if formulation != "lagrange":     # a closed chain's "kane" (cached as "recursive")
            self.formulation = "kane"
        namespace = self._namespace           # the generated module, run by NumericModel
        self._terms = namespace["constrained_terms"]
        self._pfaffian = namespace["pfaffian"]
        self._bias = namespace["acceleration_bias"]
        self.rows = tuple(Row(*r) for r in namespace["CONSTRAINT_ROWS"])
        self.h = int(namespace["HOLONOMIC"])
        self.c = len(self.rows)
        self.dependent = tuple(namespace["DEPENDENT"])
        self.speeds = tuple(namespace["DEPENDENT_SPEEDS"])
        self.free = tuple(k for k in range(self.n) if k not in self.speeds)
        self.stabilization = float(stabilization)
        self.m = len(self.effort_names)

    # -- the dynamics ---------------------------------------------------------
    def _pivot(self, A: np.ndarray) -> tuple[list[int], list[int]]:
        """(dependent, independent) speeds: the best-conditioned c columns of A (greedy
        column pivoting, as in a pivoted QR)."""
        R = A.astype(float).copy()
        dep: list[int] = []
        for _ in range(self.c):
            norms = (R * R).sum(axis=0)
            norms[dep] = -1.0
            k = int(np.argmax(norms))
            dep.append(k)
            v = R[:, k] / math.sqrt(norms[k]) if norms[k] > 0 else R[:, k]
            R -= np.outer(v, v @ R)
        return dep, [k for k in range(self.n) if k not in dep]

    def solve(self, M, G, A, b, multipliers: bool = True):
        """(ddq, lambda, Y = M^-1 A^T, S = A Y) of M ddq = G + A^T lambda, A ddq = b
        (lambda None for Kane unless ``multipliers``: the field does not need it)."""
        Z = np.linalg.solve(M, np.column_stack([G, A.T]))
        z, Y = Z[:, 0], Z[:, 1:]
        S = A @ Y
        if self.formulation == "lagrange":
            lam = np.linalg.solve(S, b - A @ z)
            return z + Y @ lam, lam, Y, S
        dep, ind = list(self.speeds), list(self.free)
        try:                 # the file's dependent speeds, while they stay well determined
            CE = np.linalg.solve(A[:, dep], np.column_stack([A[:, ind], b]))
            usable = np.abs(CE[:, :-1]).max(initial=0.0) <= SPLIT_LIMIT
        except np.linalg.LinAlgError:
            usable = False
        if not usable:
            dep, ind = self._pivot(A)
            CE = np.linalg.solve(A[:, dep], np.column_stack([A[:, ind], b]))
        T = np.zeros((self.n, len(ind)))
        T[ind, np.arange(len(ind))] = 1.0
        T[dep] = -CE[:, :-1]
        e = np.zeros(self.n)
        e[dep] = CE[:, -1]
        du = np.linalg.solve(T.T @ M @ T, T.T @ (G - M @ e))
        ddq = T @ du + e
        lam = np.linalg.solve(A[:, dep].T, (M @ ddq - G)[dep]) if multipliers else None
        return ddq, lam, Y, S

    def _evaluate(self, t, values, tau=None):
        M, F, B, control, A, f, g, b = self._terms(t, *values)
        G = F + (B @ (control if tau is None else tau) if self.m else 0.0)
        return M, G, A, f, g, b

    def field(self, t: float, x: np.ndarray, tau=None) -> np.ndarray:
        """The stabilized state derivative; ``tau``: efforts instead of the control laws."""
        n, h = self.n, self.h
        M, G, A, f, g, b = self._evaluate(t, x.tolist(), tau)
        ddq, _, Y, S = self.solve(M, G, A, b, multipliers=False)
        out = np.empty(2 * n)
        out[:n] = x[n:]
        out[n:] = ddq
        gamma = self.stabilization
        if gamma:
            out[n:] -= gamma * (Y @ np.linalg.solve(S, g))
            if h:
                out[:n] -= gamma * (Y[:, :h] @ np.linalg.solve(S[:h, :h], f))
        return out

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        return self.field(t, x)

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        return _difference_jacobian(self.rhs, t, x)

    def accelerations(self, t: float, x) -> list[float]:
        return self.field(t, np.asarray(x, dtype=float))[self.n:].tolist()

    def problem(self) -> Problem:
        return Problem(self.rhs, self.jacobian, self.state_names(), self.diagnose)

    def driven_problem(self, efforts) -> Problem:
        """The dynamics under efforts ``efforts(t)`` (not the control laws)."""
        def rhs(t, x):
            return self.field(t, x, np.asarray(efforts(t), dtype=float))

        def jacobian(t, x):
            return _difference_jacobian(rhs, t, x)

        return Problem(rhs, jacobian, self.state_names(), self.diagnose)

    # -- states on the constraints ------------------------------------------------
    def initial_state(self) -> np.ndarray:
        """The file's start (the loader solved it) polished onto the generated constraints."""
        x = super().initial_state()
        q = self.close(0.0, x[: self.n])
        return np.concatenate([q, self.rates(0.0, q, x[self.n:])])

    def close(self, t: float, q: np.ndarray, hold=None) -> np.ndarray:
        """q with the dependent coordinates (``hold`` the others) solved from f(q, t) = 0 by
        Newton's method; NumericalError if it does not converge."""
        q = np.array(q, dtype=float)
        if not self.h:
            return q
        dep = list(self.dependent)
        best = math.inf
        for _ in range(NEWTON_ITERATIONS):
            A, _, f = self._pfaffian(t, *q.tolist())
            size = float(np.abs(f).max())
            if not math.isfinite(size):
                break
            if size <= 1e-15 * max(1.0, float(np.abs(q).max())) or size >= best:
                if size <= 1e-9:
                    return q
                break
            best = size
            try:
                q[dep] -= np.linalg.solve(A[: self.h, dep], f)
            except np.linalg.LinAlgError:
                break
        if best <= 1e-9:
            return q
        raise NumericalError(f"the constraints cannot be closed at t = {t:.6g} s "
                             f"(residual {best:.3g}): the dependent coordinates have no "
                             "solution near the previous ones")

    def rates(self, t: float, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """dq with the dependent speeds solved from A dq + a0 = 0 (the others kept)."""
        A, a0, _ = self._pfaffian(t, *q.tolist())
        dq = np.array(dq, dtype=float)
        speeds, free = list(self.speeds), list(self.free)
        dq[speeds] = np.linalg.solve(A[:, speeds], -(A[:, free] @ dq[free] + a0))
        return dq

    # -- reports ------------------------------------------------------------------
    def residuals(self, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f, g): holonomic residuals and velocity residuals A dq + a0 at one state."""
        n = self.n
        A, a0, f = self._pfaffian(t, *x[:n].tolist())
        return np.asarray(f, dtype=float), A @ x[n:] + a0

    def multipliers(self, t: float, x: np.ndarray, tau=None) -> np.ndarray:
        M, G, A, _, _, b = self._evaluate(t, x.tolist(), tau)
        return self.solve(M, G, A, b)[1]

    def constraint_conditions(self, t: float, x: np.ndarray) -> tuple[float, float]:
        """(cond(A), sigma_max(A_h) / sigma_min(A_h,d)).  A singular A is a locked or
        singular configuration: the constraints lose a direction.  The second number
        grows without bound at a dead point, where the holonomic constraints A_h no
        longer determine the dependent coordinates' rates from the independent ones
        (the mechanism can lock or flip its assembly mode); 1 without holonomic rows."""
        A, _, _ = self._pfaffian(t, *x[: self.n].tolist())
        with np.errstate(all="ignore"):
            whole = float(np.linalg.cond(A))
            if not self.h:
                return whole, 1.0
            A_h = A[: self.h]
            smallest = np.linalg.svd(A_h[:, list(self.dependent)], compute_uv=False).min()
            largest = np.linalg.svd(A_h, compute_uv=False).max()
            return whole, float(largest / smallest) if smallest > 0 else math.inf

    def run_report(self, t: np.ndarray, x: np.ndarray, efforts: np.ndarray | None = None
                   ) -> "ConstraintRun":
        """Drift and multipliers along a run (rows t, states x, efforts per row if driven)."""
        rows = len(t)
        position = np.zeros(rows)
        velocity = np.zeros(rows)
        lam = np.full((rows, self.c), np.nan)
        for k in range(rows):
            f, g = self.residuals(t[k], x[k])
            position[k] = float(np.abs(f).max(initial=0.0))
            velocity[k] = float(np.abs(g).max(initial=0.0))
            try:
                lam[k] = self.multipliers(t[k], x[k], None if efforts is None else efforts[k])
            except np.linalg.LinAlgError:
                pass
        return ConstraintRun(self.rows, self.h, t, position, velocity, lam,
                             self.stabilization)

    def diagnose(self, x: np.ndarray) -> str:
        note = super().diagnose(x)
        try:
            whole, split = self.constraint_conditions(0.0, x)
        except (np.linalg.LinAlgError, ValueError):
            return note
        if whole > SINGULAR_CONSTRAINTS:
            note += (f"; the constraint Jacobian is nearly singular there (condition number "
                     f"{whole:.3g}): a locked or singular configuration")
        return note


def _difference_jacobian(function, t: float, x: np.ndarray) -> np.ndarray:
    f0 = function(t, x)
    J = np.empty((len(f0), len(x)))
    for k in range(len(x)):
        step = 1.5e-8 * max(1.0, abs(x[k]))
        shifted = x.copy()
        shifted[k] += step
        J[:, k] = (function(t, shifted) - f0) / step
    return J


@dataclass(frozen=True)
class Row:
    column: str
    source: str
    kind: str
    meaning: str
    unit: str


@dataclass
class ConstraintRun:
    """What the constraints did along a run."""
    rows: tuple[Row, ...]
    holonomic: int
    t: np.ndarray
    position_drift: np.ndarray    # max_j |f_j| per row (m for loops)
    velocity_drift: np.ndarray    # max_j |A dq + a0|_j per row
    multipliers: np.ndarray       # rows x c
    stabilization: float

    @property
    def max_position_drift(self) -> float:
        return float(self.position_drift.max(initial=0.0))

    @property
    def max_velocity_drift(self) -> float:
        return float(self.velocity_drift.max(initial=0.0))

    def columns(self) -> tuple[list[str], list[np.ndarray]]:
        """CSV columns after the contract ones: the multipliers, then the drift."""
        header = [r.column for r in self.rows] + ["drift_position", "drift_velocity"]
        return header, [*self.multipliers.T, self.position_drift, self.velocity_drift]

    def summary(self) -> dict:
        return {"constraints": {
            "equations": len(self.rows), "holonomic": self.holonomic,
            "stabilization": self.stabilization,
            "max_position_drift": self.max_position_drift,
            "max_velocity_drift": self.max_velocity_drift,
            "final_position_drift": float(self.position_drift[-1]) if len(self.t) else 0.0,
            "multipliers": [{"column": r.column, "constraint": r.source, "kind": r.kind,
                             "meaning": r.meaning, "unit": r.unit,
                             "max_abs": _max_abs(self.multipliers[:, k])}
                            for k, r in enumerate(self.rows)]}}

    def line(self) -> str:
        what = []
        if self.holonomic:
            what.append(f"position {self.max_position_drift:.2e}")
        what.append(f"velocity {self.max_velocity_drift:.2e}")
        forces = ", ".join(f"{r.column} up to {_max_abs(self.multipliers[:, k]):.4g}"
                           f"{' ' + r.unit if r.unit else ''}" for k, r in enumerate(self.rows))
        return (f"constraints: {len(self.rows)} equations, largest drift {', '.join(what)} "
                f"(stabilized at {self.stabilization:g} 1/s); multipliers: {forces}")


def _max_abs(values: np.ndarray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(np.abs(finite).max()) if len(finite) else None
