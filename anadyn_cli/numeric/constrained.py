"""The numeric model of a constrained robot (closed chains, velocity constraints).

State x = [q, dq] over all n coordinates.  The generated module (the tree's
functions from ``closed_form`` plus ``source`` below) gives, at (t, q, dq):
the tree's M, F, B; the control laws tau; the holonomic residuals f (h);
the Pfaffian matrix A (c x n), the velocity residual g = A dq + a0 and the
acceleration right side b (A ddq = b).  With G = F + B tau, the
accelerations and multipliers solve

    M ddq = G + A^T lambda,   A ddq = b

by the formulation the model was derived with:

* ``lagrange``: the multipliers first, lambda = S^-1 (b - A M^-1 G) with
  S = A M^-1 A^T, then ddq = M^-1 (G + A^T lambda);
* ``kane``: dependent speeds: ddq = T du + e with T = [I; -A_d^-1 A_i],
  e = [0; A_d^-1 b], and T^T M T du = T^T (G - M e) (Kane's equations with
  the nonholonomic partial velocities T); lambda from the dependent rows,
  A_d^T lambda = (M ddq - G)_d.  The dependent speeds are the file's while
  they stay well determined (|A_d^-1 A_i| <= 1e6: they move at most 1e6
  times as fast as the independent ones), else the best-conditioned c
  columns of A (greedy column pivoting), so a choice that becomes singular
  along the motion (the knife edge heading along y) does not stop the run.

**Drift control** (Ascher, Chin and Reich's stabilization of the invariant
manifold): the integrated field is

    dq/dt  = dq  - gamma W Ah^T (Ah W Ah^T)^-1 f
    ddq/dt = ddq - gamma W A^T  (A W A^T)^-1 g,      W = M^-1

which is the exact dynamics on the constraints (f = 0, g = 0) and pulls any
deviation back at the rate gamma (df/dt = -gamma f, dg/dt = -gamma g to first
order), so the integrator's local errors cannot accumulate into drift: the
drift stays near (local error rate) / gamma.  gamma = STABILIZATION (1/s);
W = M^-1 moves the state along the constraint normals in the kinetic-energy
metric (free of units).  The drift is measured on the integrated state
(never projected away) and reported with every run.

The Jacobian of the field is taken by forward differences (2n more field
evaluations, not counted as RHS calls).

Only NumPy is imported at module level; ``source`` (code generation) needs
SymPy and imports it inside.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError, NumericalError
from .integrators import Problem
from .model import NumericModel

MARKER = "# -- constraints (anadyn_cli.numeric.constrained) --"
STABILIZATION = 10.0          # 1/s, the rate at which a drift from the constraints decays
SPLIT_LIMIT = 1e6             # |A_d^-1 A_i| above this: pivot the dependent speeds (Kane)
NEWTON_ITERATIONS = 50
SINGULAR_CONSTRAINTS = 1e8    # condition number of A above this: a singular configuration
DEAD_POINT = 100.0            # |A_h| / sigma_min(A_h,d) above this: near a dead point, warn


def model_type(code: str):
    """The model class for generated ``code``: ConstrainedModel if it has constraints."""
    return ConstrainedModel if MARKER in code else NumericModel


def is_constrained(model) -> bool:
    return isinstance(model, ConstrainedModel)


# ----------------------------------------------------------------------------
# code generation
# ----------------------------------------------------------------------------
def source(robot, eom) -> str:
    """Source of the constraint functions, appended to the tree's generated module."""
    import sympy as sp

    from .closed_form import control_laws
    from .codegen import Function, module_source
    from ..symbolic import constraints as equations, kinematics

    kin = kinematics.build(robot, symbolic=eom.symbolic)
    cons = equations.build(robot, kin)
    t = sp.Symbol("t", real=True)
    q, dq = list(eom.q), list(eom.dq)
    state = (t, *q, *dq)
    c, h = cons.count, cons.holonomic
    f = list(cons.f) if h else []
    functions = [
        Function("constrained_terms", state,
                 (("M", sp.Matrix(eom.M)), ("F", list(eom.F)),
                  ("B", sp.Matrix(eom.B) if eom.B.cols else sp.zeros(len(q), 0)),
                  ("tau", list(control_laws(robot))), ("A", sp.Matrix(cons.A)), ("f", f),
                  ("g", list(cons.velocity_residual)), ("b", list(cons.b))), False,
                 "M, F, B, tau (control laws), A, f (holonomic residuals), "
                 "g = A dq + a0, b (A ddq = b)."),
        Function("pfaffian", (t, *q), (("A", sp.Matrix(cons.A)), ("a0", list(cons.a0)),
                                      ("f", f)), False,
                 "A, a0 (A dq + a0 = 0) and f (holonomic residuals)."),
        Function("acceleration_bias", state, (("b", list(cons.b)),), False,
                 "b with A ddq = b."),
    ]
    closing = robot.constraints
    names = [cc.name for cc in robot.coordinates]
    rows = tuple((r.column, r.source, r.kind, r.meaning, r.unit) for r in closing.rows)
    text = module_source(functions, MARKER + f"\n{c} constraint equations, {h} holonomic")
    constants = (f"CONSTRAINT_ROWS = {rows!r}\n"
                 f"HOLONOMIC = {h!r}\n"
                 f"DEPENDENT = {tuple(names.index(d) for d in closing.dependent)!r}\n"
                 f"DEPENDENT_SPEEDS = "
                 f"{tuple(names.index(d) for d in closing.dependent_speeds)!r}\n")
    return "\n" + text + "\n" + constants


# ----------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------
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


# ----------------------------------------------------------------------------
# inverse dynamics of a closed chain
# ----------------------------------------------------------------------------
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
        from . import integrators

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


# ----------------------------------------------------------------------------
# states on the constraints (for compare)
# ----------------------------------------------------------------------------
def consistent_states(model: ConstrainedModel, count: int, seed: int = 0, steps: int = 16,
                      horizon: float | None = None):
    """(t, x rows, tau rows): ``count`` random states on the constraints near the start.

    The independent coordinates are drawn within +-pi rad (+-max(0.1, |q0|) m) of
    their start and reached from it in ``steps`` steps, closing the constraints at
    each (so the assembly mode is kept); draws the constraints cannot follow to are
    skipped.  Rates: within +-max(2, 2 |dq0|) of the start for the free speeds, the
    dependent ones solved; efforts of the size the control laws give at the start.
    """
    rng = np.random.default_rng([seed, 7])
    n = model.n
    x0 = model.initial_state()
    q0, dq0 = x0[:n], x0[n:]
    info = model.info
    spread = np.array([math.pi if c.unit == "rad" else max(0.1, abs(c.initial))
                       for c in info.coordinates])
    width = np.maximum(2.0, 2 * np.abs(dq0))
    free = [k for k in range(n) if k not in model.dependent]
    scale = np.ones(model.m)
    if model.m and info.has_controller:
        with np.errstate(all="ignore"):
            start = np.asarray(model.efforts(0.0, q0, dq0), dtype=float).reshape(model.m)
        scale = np.where(np.isfinite(start), np.maximum(1.0, np.abs(start)), 1.0)
    horizon = horizon if horizon is not None else (info.simulation.t_end or 10.0)
    times, states, efforts = [], [], []
    for _ in range(count):
        target = q0 + spread * rng.uniform(-1, 1, n)
        moment = float(rng.uniform(0.0, horizon))
        rates = dq0 + width * rng.uniform(-1, 1, n)
        tau = scale * rng.uniform(-1, 1, model.m)
        q = q0.copy()
        try:
            for s in np.linspace(0, 1, steps + 1)[1:]:
                q[free] = q0[free] + s * (target[free] - q0[free])
                q = model.close(s * moment, q)
            dq = model.rates(moment, q, rates)
        except (NumericalError, np.linalg.LinAlgError):
            continue
        times.append(moment)
        states.append(np.concatenate([q, dq]))
        efforts.append(tau)
    return (np.array(times), np.array(states, dtype=float).reshape(len(times), 2 * n),
            np.array(efforts, dtype=float).reshape(len(times), model.m))


def accelerations(model: ConstrainedModel, t, X, tau) -> tuple[np.ndarray, np.ndarray]:
    """(ddq rows, lambda rows) at states on the constraints under efforts ``tau``
    (no stabilization: the exact constrained dynamics)."""
    ddq = np.full((len(t), model.n), np.nan)
    lam = np.full((len(t), model.c), np.nan)
    for k in range(len(t)):
        try:
            M, G, A, _, _, b = model._evaluate(float(t[k]), X[k].tolist(), tau[k])
            ddq[k], lam[k] = model.solve(M, G, A, b)[:2]
        except np.linalg.LinAlgError:
            pass
    return ddq, lam


# ----------------------------------------------------------------------------
# conditioning along a path (for check)
# ----------------------------------------------------------------------------
@dataclass
class ConstraintCheck:
    """The constraint Jacobian's conditioning and the drift along a checked path."""
    t: np.ndarray
    condition: np.ndarray         # cond(A) per row checked
    dead: np.ndarray              # |A_h| / sigma_min(A_h,d) per row (constraint_conditions)
    position_drift: np.ndarray
    velocity_drift: np.ndarray
    dependent: tuple[str, ...]    # the file's dependent coordinates
    stabilization: float

    def worst(self, values: np.ndarray) -> tuple[float, float]:
        k = int(np.nanargmax(values)) if np.isfinite(values).any() else 0
        return float(values[k]), float(self.t[k])

    def line(self) -> str:
        cond, at = self.worst(self.condition)
        dead, dead_at = self.worst(self.dead)
        distance = (f"dead-point measure |A_h| / sigma_min(dA_h/d({', '.join(self.dependent)}))"
                    f" up to {dead:.3g} (t = {dead_at:.4g} s); " if self.dependent else "")
        return (f"constraints: Jacobian condition number up to {cond:.3g} (t = {at:.4g} s); "
                f"{distance}drift up to "
                f"{float(self.position_drift.max(initial=0.0)):.2e} in position, "
                f"{float(self.velocity_drift.max(initial=0.0)):.2e} in velocity "
                f"(stabilized at {self.stabilization:g} 1/s)")

    def summary(self) -> dict:
        cond, at = self.worst(self.condition)
        dead, dead_at = self.worst(self.dead)
        return {"jacobian_condition": cond, "jacobian_condition_t": at,
                "dependent_condition": dead, "dependent_condition_t": dead_at,
                "max_position_drift": float(self.position_drift.max(initial=0.0)),
                "max_velocity_drift": float(self.velocity_drift.max(initial=0.0)),
                "stabilization": self.stabilization}


def conditioning(model: ConstrainedModel, t: np.ndarray, x: np.ndarray,
                 rows: int = 20_000) -> ConstraintCheck:
    """cond(A), cond(A_d) and the drift at up to ``rows`` rows of a path."""
    index = np.arange(0, len(t), max(1, math.ceil(len(t) / rows)))
    condition, dead = np.empty(len(index)), np.empty(len(index))
    position, velocity = np.empty(len(index)), np.empty(len(index))
    for j, k in enumerate(index):
        condition[j], dead[j] = model.constraint_conditions(float(t[k]), x[k])
        f, g = model.residuals(float(t[k]), x[k])
        position[j] = float(np.abs(f).max(initial=0.0))
        velocity[j] = float(np.abs(g).max(initial=0.0))
    names = tuple(model.info.coordinates[k].name for k in model.dependent)
    return ConstraintCheck(t[index], condition, dead, position, velocity, names,
                           model.stabilization)


def drift(model: ConstrainedModel, t: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """(largest |f|, largest |A dq + a0|) over the rows of a run."""
    position = velocity = 0.0
    for k in range(len(t)):
        f, g = model.residuals(float(t[k]), x[k])
        position = max(position, float(np.abs(f).max(initial=0.0)))
        velocity = max(velocity, float(np.abs(g).max(initial=0.0)))
    return position, velocity
