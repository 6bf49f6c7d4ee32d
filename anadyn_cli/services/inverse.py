"""Inverse dynamics: the actuator efforts that produce a prescribed motion.

Given q(t) from the robot file's ``trajectory`` (exact rates and
accelerations, see ``trajectory``) or measured samples of it (``measured``:
rates and accelerations as given or differentiated, efforts at the samples),
the equations M(q) ddq = F(t, q, dq) + B(q) tau
give, with B square and non-singular,

    tau(t) = B^-1 (M ddq - F)        at (t, q(t), dq(t), ddq(t))

F holds the joint forces and loads, so the efforts overcome friction,
damping, springs and loads.

evaluated over the whole time grid at once (the model's ``demand`` on arrays:
the recursive Newton-Euler algorithm, O(n) a point, on the recursive path;
one batched solve for B; no Python loop per point).

Round trip: the direct dynamics x' = [dq, M^-1 (F + B tau(t))], driven by the
efforts as exact functions of time (recomputed from the trajectory at the
integrator's t, never interpolated), integrated from the trajectory's start
state, must follow the prescribed q(t); the largest deviation on the output
grid is reported and checked against a tolerance.  An arm held against
gravity is usually unstable in open loop (the chapter's arms: deviations grow
like exp(3..5 t/s), some 1e24-fold over their 15 s), so such a motion is
integrated in segments short enough for double precision, each restarted
from the prescribed state (see ``round_trip``).  A measured motion is followed
between its samples by its piecewise quintic (``MeasuredMotion``), which passes
through every sample with the sample's rate and acceleration, so its round trip
checks the efforts against the measured positions the same way.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import CheckFailed, ModelError, NumericalError, SettingError, positive
from ..model.info import RobotInfo
from ..numeric import constrained, integrators
from ..numeric.integrators import Problem
from ..numeric.measured import MeasuredMotion
from ..numeric.build import titled
from ..numeric.model import NumericModel
from ..numeric.settings import trajectory_grid
from .. import files as output
from ..output.notebook import Displayed
from ..numeric import limits

DEFAULT_STEP = 0.01          # s, output grid (else the file's simulation.output_step)
DEFAULT_TOLERANCE = 1e-6     # rad or m, largest round-trip tracking error
ROUNDTRIP_RTOL = 1e-11
ROUNDTRIP_ATOL = 1e-12
AMPLIFICATION = 1e3          # largest exp(growth rate * segment) of a round-trip segment
MAX_POINTS = 10**7           # rows of the output grid
GROWTH_SAMPLES = 31          # points along the motion where the growth rate is estimated
SINGULAR = 1e-10             # |det B| / prod |columns of B| below this: B singular


class InverseDynamics:
    """tau(t) = B^-1 (M ddq - F) along a prescribed motion.

    ``motion(t) -> q, dq, ddq`` (arrays of shape t.shape + (n,)); M ddq - F and
    B come from the model's ``demand`` (the recursive Newton-Euler algorithm on
    the recursive path, O(n) a point); both take arrays of any shape or scalars.
    """

    def __init__(self, model: NumericModel, motion):
        self.model = model
        self.motion = motion
        self.n = model.n
        self.m = len(model.effort_names)

    def demand(self, t, q, dq, ddq):
        """(M ddq - F (..., n), B (..., n, m)) with the coordinates last."""
        return self.model.demand(t, *(np.moveaxis(v, -1, 0) for v in (q, dq, ddq)))

    def efforts(self, t):
        """(q, dq, ddq, tau) over the time array ``t``; tau has shape t.shape + (m,)."""
        q, dq, ddq = self.motion(t)
        return q, dq, ddq, self.solve(*self.demand(t, q, dq, ddq))

    @staticmethod
    def solve(demand, B):
        """tau solving B tau = demand (= M ddq - F) at every point (B square); one LU
        when B is constant."""
        if B.ndim > 2 and len(B) and _constant(B):
            return np.linalg.solve(B[0], demand.T).T
        return np.linalg.solve(B, demand[..., None])[..., 0]

    def effort_at(self, t: float) -> np.ndarray:
        """tau at one time (the round trip's exact forcing)."""
        return self.efforts(np.array(t, dtype=float))[3]


@dataclass
class RoundTrip:
    """Direct dynamics driven by the computed efforts, against the prescribed q(t)."""
    method: str
    rtol: float
    atol: float
    tolerance: float
    max_error: float              # max |q - q_prescribed| over the grid and coordinates
    coordinate: str               # where it occurs
    time: float
    errors: dict                  # coordinate -> its largest error
    final_error: float            # max over the coordinates at the end
    rhs_calls: int
    steps: int
    wall: float
    segments: int                 # integrated pieces, each from the prescribed state
    segment: float                # their length, s
    growth_rate: float            # largest open-loop growth rate along the motion, 1/s
    growth_time: float            # where it occurs, s
    growth: float                 # integral of the positive growth rate over the motion

    @property
    def passed(self) -> bool:
        return self.max_error <= self.tolerance


@dataclass
class InverseResult(Displayed):
    robot: RobotInfo
    formulation: str | None       # of the closed forms; None: the recursive evaluator
    kind: str                     # trajectory kind
    duration: float
    step: float
    t: np.ndarray                 # (N,)
    q: np.ndarray                 # (N, n)
    dq: np.ndarray
    ddq: np.ndarray
    efforts: np.ndarray           # (N, m)
    dynamics: InverseDynamics
    roundtrip: RoundTrip | None = None
    timings: dict = field(default_factory=dict)
    constraints: "constrained.ConstraintRun | None" = None   # multipliers (closed chains)
    note: str = ""                # how redundant actuation was resolved
    limits: list = field(default_factory=list)   # limits.Exceeded: bounds of the file passed
    rates: np.ndarray | None = None   # (N, m) each actuator's joint speed B^T dq (open chains)

    @property
    def evaluator(self) -> str:
        """recursive or closed-form: what computed the efforts (``numeric.build``)."""
        return self.dynamics.model.evaluator

    def table(self) -> tuple[list[str], list[np.ndarray]]:
        """inverse.csv's header and columns (``to_csv`` writes them; notebooks show them)."""
        return columns(self)

    def figure(self, rates: bool = False):
        """Prescribed motion and efforts as a Matplotlib Figure (the global
        backend is not touched)."""
        from ..output.plots import time_figure

        return time_figure(self.t, _panels(self, rates), plot_title(self))

    def sizing(self) -> list["Sizing"]:
        """Each actuator's figures for choosing a motor (``sizing``)."""
        return sizing(self)


def inverse(model: NumericModel, step: float | None = None, roundtrip: bool = True,
            tolerance: float = DEFAULT_TOLERANCE, segment: float | None = None,
            timings: dict | None = None, measured: MeasuredMotion | None = None
            ) -> InverseResult:
    """Efforts along the file's trajectory (``model.motion``), or along a ``measured``
    motion (``numeric.measured``: at its samples), and the round trip.

    ``step``: output step, s (default: the file's output step, else 0.01; a measured
    motion has its samples instead); ``tolerance``: largest round-trip tracking error,
    rad or m; ``segment``: length of the round trip's pieces, s (default: automatic,
    see round_trip).
    """
    timings = {} if timings is None else timings
    info = model.info
    if model.quaternions:
        raise ModelError(f"{info.source}: inverse dynamics of a robot with a spherical joint "
                         "are not supported yet: a prescribed motion (trajectory or measured) "
                         "gives coordinates, not a quaternion's path and angular velocity")
    if model.contact_names:
        raise ModelError(f"{info.source}: inverse dynamics of a robot with contacts are not "
                         "supported yet (which contact forces a motion needs is not resolved); "
                         "simulate, check and accuracy run it")
    if measured is not None and step is not None:
        raise SettingError("output_step", "does not apply to a measured motion: its efforts "
                                          "are computed at its samples")
    step = positive("output_step", step if step is not None
                    else info.simulation.output_step or DEFAULT_STEP)
    tolerance = positive("roundtrip_tolerance", tolerance)
    if segment is not None:
        positive("roundtrip_segment", segment)
    start = time.perf_counter()
    motion = model.motion if measured is None else _measured(model, measured)
    if not constrained.is_constrained(model):
        _check_counts(info)
    timings["trajectory"] = time.perf_counter() - start
    if measured is not None:
        t, step = measured.t, measured.duration / (len(measured.t) - 1)
    elif step > motion.duration:
        raise SettingError("output_step", f"{step:g} s is longer than the trajectory's "
                                          f"duration {motion.duration:g} s")
    elif motion.duration / step > MAX_POINTS:
        raise SettingError("output_step", f"{step:g} s gives more than {MAX_POINTS:.0e} "
                                          f"points over {motion.duration:g} s")
    else:
        t = trajectory_grid(motion.duration, step)
    dynamics = InverseDynamics(model, motion)
    if constrained.is_constrained(model):         # closed chains (numeric.constrained)
        return _closed_chain(model, motion, t, step, roundtrip, tolerance, segment, timings)
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        q, dq, ddq = motion(t) if measured is None else (motion.q, motion.dq, motion.ddq)
        demand, B = dynamics.demand(t, q, dq, ddq)
    elapsed = time.perf_counter() - start
    for name, values in (("q", q), ("dq", dq), ("ddq", ddq)):
        bad = ~np.isfinite(values)
        if bad.any():
            k, i = np.argwhere(bad)[0]
            raise ModelError(f"the prescribed {name} of {info.coordinates[i].name} "
                             f"is not finite at t = {t[k]:g} s", source=info.source,
                             path="trajectory")
    B = np.broadcast_to(B, (len(t), dynamics.n, dynamics.m))
    _check_actuation(info, t, B)
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        tau = dynamics.solve(demand, B)
    timings["efforts"] = elapsed + time.perf_counter() - start
    _finite(info, t, tau, "the efforts")
    result = InverseResult(info, model.formulation, motion.kind, motion.duration, step, t,
                           q, dq, ddq, tau, dynamics, timings=timings,
                           rates=np.einsum("kim,ki->km", B, dq))
    result.limits = limits.check(info, t, q, dq, tau)
    if roundtrip:
        result.roundtrip = round_trip(result, tolerance, segment)
        timings["roundtrip"] = result.roundtrip.wall
    return result


def _measured(model: NumericModel, measured: MeasuredMotion) -> MeasuredMotion:
    """``measured`` if it moves this robot's coordinates, in their order (open chains)."""
    if constrained.is_constrained(model):
        raise ModelError("a measured motion drives open chains only: this robot has "
                         "loop constraints (give it a trajectory section)",
                         source=model.info.source)
    if tuple(measured.names) != tuple(model.coordinates):
        raise ModelError(f"the measured motion moves {', '.join(measured.names)}; the robot's "
                         f"coordinates are {', '.join(model.coordinates)}",
                         source=measured.source)
    return measured


def growth_rates(dynamics: InverseDynamics, times: np.ndarray) -> np.ndarray:
    """Largest real part of the eigenvalues of d(x')/dx at each of ``times``, the efforts
    held at tau(t): how fast the open-loop motion departs from the trajectory, 1/s.

    A step-length estimate for the round trip only; the Jacobian is taken by central
    differences of x' = [dq, M^-1 (F + B tau)] at the prescribed states.
    """
    n, driven = dynamics.n, dynamics.model.driven_accelerations
    rates = np.empty(len(times))
    for i, moment in enumerate(times):
        q, dq, _ = dynamics.motion(float(moment))
        x, tau = np.concatenate([q, dq]), dynamics.effort_at(float(moment))
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        for k in range(2 * n):
            h = 1e-6 * max(1.0, abs(x[k]))
            shifted = [x.copy(), x.copy()]
            shifted[0][k] += h
            shifted[1][k] -= h
            J[n:, k] = (driven(moment, shifted[0], tau) - driven(moment, shifted[1], tau)) / (2 * h)
        rates[i] = np.linalg.eigvals(J).real.max()
    return rates


def segment_rows(t: np.ndarray, count: int) -> np.ndarray:
    """Rows of ``t`` nearest to k T / count, k = 0..count (first and last row included)."""
    targets = np.linspace(t[0], t[-1], count + 1)
    right = np.clip(np.searchsorted(t, targets), 1, len(t) - 1)
    left = right - 1
    rows = np.where(targets - t[left] <= t[right] - targets, left, right)
    return np.unique(np.concatenate([[0], rows, [len(t) - 1]]))


def round_trip(result: InverseResult, tolerance: float = DEFAULT_TOLERANCE,
               segment: float | None = None, rtol: float = ROUNDTRIP_RTOL,
               atol: float = ROUNDTRIP_ATOL) -> RoundTrip:
    """Integrate x' = [dq, M^-1 (F + B tau(t))] (LSODA) and compare q with the trajectory.

    The open-loop motion of an arm held against gravity is often unstable: a
    deviation grows like exp(lambda t), lambda the growth rate above, and over
    the whole motion no double-precision integration can follow it.  So the
    run is split into segments over which exp(lambda h) <= AMPLIFICATION, each
    started from the prescribed state at its first row (the first from the
    trajectory's start); a stable motion is one segment from the start state.
    ``segment`` (s) overrides the automatic length.
    """
    dynamics, n, t = result.dynamics, result.dynamics.n, result.t
    driven, effort_at = dynamics.model.driven_accelerations, dynamics.effort_at
    start = time.perf_counter()
    samples = np.linspace(t[0], t[-1], GROWTH_SAMPLES)
    with np.errstate(all="ignore"):
        rates = growth_rates(dynamics, samples)
    if not np.isfinite(rates).all():
        raise NumericalError(f"{result.robot.source}: round trip: the direct dynamics cannot "
                             f"be evaluated at t = {samples[~np.isfinite(rates)][0]:g} s "
                             "(singular mass matrix?)")
    rate, rate_time = float(rates.max()), float(samples[rates.argmax()])
    growing = np.maximum(rates, 0.0)
    growth = float(np.sum((growing[1:] + growing[:-1]) / 2 * np.diff(samples)))
    if segment is None:
        count = max(1, math.ceil(rate * (t[-1] - t[0]) / math.log(AMPLIFICATION) - 1e-9))
    else:
        count = max(1, math.ceil((t[-1] - t[0]) / positive("roundtrip_segment", segment)
                                 - 1e-9))
    rows = segment_rows(t, count)

    def rhs(moment, x):
        """x' = [dq, M^-1 (F + B tau(t))], tau the computed efforts at this t."""
        return np.concatenate([x[n:], driven(moment, x, effort_at(moment))])

    problem = Problem(rhs, names=result.dynamics.model.state_names())
    error = np.zeros_like(result.q)
    steps = calls = 0
    for first, last in zip(rows[:-1], rows[1:]):
        x0 = np.concatenate([result.q[first], result.dq[first]])
        solution = integrators.integrate(problem, x0, t[first:last + 1], "odeint", rtol, atol,
                                         stop_at_end=True)
        calls, steps = calls + solution.rhs_calls, steps + solution.steps
        if not solution.success:
            raise NumericalError(f"{result.robot.source}: round trip: the direct dynamics "
                                 f"failed: {solution.message}")
        x = solution.x
        error[first:last + 1] = np.maximum(error[first:last + 1],
                                           np.abs(x[:, :n] - result.q[first:last + 1]))
    wall = time.perf_counter() - start
    row, column = np.unravel_index(int(np.argmax(error)), error.shape)
    names = [c.name for c in result.robot.coordinates]
    return RoundTrip("odeint (LSODA)", rtol, atol, tolerance, float(error[row, column]),
                     names[column], float(t[row]),
                     {name: float(e) for name, e in zip(names, error.max(axis=0))},
                     float(error[-1].max()), calls, steps, wall, len(rows) - 1,
                     float((t[-1] - t[0]) / (len(rows) - 1)), rate, rate_time, growth)


def raise_if_failed(result: InverseResult) -> None:
    """CheckFailed when the round trip missed its tolerance."""
    trip = result.roundtrip
    if trip is None or trip.passed:
        return
    unit = next(c.unit for c in result.robot.coordinates if c.name == trip.coordinate)
    raise CheckFailed(f"{result.robot.source}: round trip: largest tracking error "
                      f"{trip.max_error:.3g} {unit} ({trip.coordinate} at t = {trip.time:g} s) "
                      f"exceeds the round trip's tolerance {trip.tolerance:g}")


def _closed_chain(model, motion, t, step, roundtrip, tolerance, segment, timings):
    """Efforts for a closed chain: the independent coordinates follow the trajectory,
    the dependent ones the constraints (``constrained.ClosedChainInverse``)."""
    info = model.info
    chain = constrained.ClosedChainInverse(model, motion, None)
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        q, dq, ddq = chain.kinematics(t)
    chain.grid, chain.q = t, q
    chain.check_velocity(t, q, dq, info.source)
    rank, k, P = chain.actuation(float(t[0]), q[0], dq[0])
    m = chain.m
    counts = (f"{k} degree{'s' * (k != 1)} of freedom ({model.n} coordinates, {model.c} "
              f"constraint equation{'s' * (model.c != 1)}), {m} actuator{'s' * (m != 1)}")
    if rank < k:
        names = [c.name for c in info.coordinates]
        N = np.linalg.svd(np.asarray(model._pfaffian(float(t[0]), *q[0].tolist())[0]))[2]
        lost = _null_space(P.T) if P.size else np.eye(k)
        motions = N[model.c:].T @ lost
        raise ModelError(f"{counts}: inverse dynamics needs actuators that drive every motion "
                         f"the constraints allow; not actuated: "
                         f"{_describe(motions, ['d' + n for n in names])}",
                         source=info.source, path="actuators")
    note = ("" if m == k else f"redundant actuation ({counts}): of the efforts that produce "
            "the motion, the one of least Euclidean norm")
    with np.errstate(all="ignore"):
        tau, lam, lost = chain.along(t, q, dq, ddq)
    if lost is not None:
        raise ModelError(f"{counts}: the actuators cannot drive every motion the constraints "
                         f"allow at t = {t[lost]:g} s (a singular configuration for them)",
                         source=info.source, path="actuators")
    timings["efforts"] = time.perf_counter() - start
    _finite(info, t, tau, "the efforts")
    result = InverseResult(info, model.formulation, motion.kind, motion.duration, step, t,
                           q, dq, ddq, tau, chain, timings=timings, note=note)
    drift = np.array([np.abs(model.residuals(float(moment), np.concatenate([a, b]))[0]).max(
        initial=0.0) for moment, a, b in zip(t, q, dq)])
    result.constraints = constrained.ConstraintRun(model.rows, model.h, t, drift,
                                                   np.zeros(len(t)), lam, 0.0)
    if roundtrip:
        result.roundtrip = RoundTrip(**chain.round_trip(t, q, dq, segment, tolerance))
        timings["roundtrip"] = result.roundtrip.wall
    return result


# -- checks ------------------------------------------------------------------------
NEEDS = "inverse dynamics needs one independent actuator per coordinate (B square and non-singular)"


def _check_counts(info: RobotInfo) -> None:
    if not info.actuators:
        names = [c.name for c in info.coordinates]
        raise ModelError(f"{len(names)} coordinate{'s' * (len(names) != 1)}, no actuators: "
                         f"{NEEDS}; "
                         f"not actuated: {', '.join(names)}", source=info.source,
                         path="actuators")


def _constant(B: np.ndarray) -> bool:
    """Whether the stack B (N, n, m) is one matrix (a broadcast one is, unread)."""
    return B.strides[0] == 0 or bool((B == B[:1]).all())


def _check_actuation(info: RobotInfo, t: np.ndarray, B: np.ndarray) -> None:
    """B (N, n, m) must be square and non-singular at every point; say what is not actuated."""
    n, m = B.shape[1:]
    names = [c.name for c in info.coordinates]
    counts = f"{n} coordinate{'s' * (n != 1)}, {m} actuator{'s' * (m != 1)}"
    if m != n:
        lost = _not_actuated(B[0], names)
        if lost:
            raise ModelError(f"{counts}: {NEEDS}; not actuated: {lost}",
                             source=info.source, path="actuators")
        idle = _describe(_null_space(B[0]), [a.name for a in info.actuators])
        raise ModelError(f"{counts}: {NEEDS}; the efforts are not unique (efforts {idle} "
                         "produce no generalized force)", source=info.source, path="actuators")
    if len(B) and _constant(B):
        bad = 0 if _singular(B[:1])[0] else None
    else:
        flags = np.flatnonzero(_singular(B))
        bad = int(flags[0]) if len(flags) else None
    if bad is not None:
        raise ModelError(f"{counts}, but B is singular at t = {t[bad]:g} s: {NEEDS}; "
                         f"not actuated: {_not_actuated(B[bad], names)}",
                         source=info.source, path="actuators")


def _singular(B: np.ndarray) -> np.ndarray:
    """Per point: |det B| small against the product of its column lengths (Hadamard)."""
    with np.errstate(all="ignore"):
        scale = np.prod(np.linalg.norm(B, axis=-2), axis=-1)
        ratio = np.abs(np.linalg.det(B)) / scale
    return ~(ratio > SINGULAR)


def _null_space(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis (columns) of {v : A v = 0}."""
    _, s, vt = np.linalg.svd(A)
    tol = max(A.shape) * np.finfo(float).eps * 1e3 * (s[0] if len(s) else 0.0)
    rank = int((s > tol).sum())
    return vt[rank:].T


def _not_actuated(B: np.ndarray, names: list[str]) -> str:
    """Coordinates (or combinations) along which B^T v = 0: no effort reaches them."""
    basis = _null_space(B.T)
    if basis.shape[1] == 0:
        return ""
    size = np.abs(B).max(axis=1, initial=0.0)
    zero = [i for i in range(len(names)) if size[i] <= 1e-12 * max(size.max(), 1.0)]
    words = [names[i] for i in zero]
    if len(zero) < basis.shape[1]:
        rest = basis.copy()
        rest[zero] = 0
        u, s, _ = np.linalg.svd(rest, full_matrices=False)
        rest = u[:, s > 1e-9][:, : basis.shape[1] - len(zero)]
        words.append("the combined motion " + _describe(rest, ["d" + n for n in names]))
    return ", ".join(words)


def _describe(basis: np.ndarray, names: list[str]) -> str:
    """Columns of ``basis`` as ratios of ``names``, e.g. 'q1:q2 = 1:1'."""
    out = []
    for v in basis.T:
        v = v / v[np.argmax(np.abs(v))]
        used = [(name, c) for name, c in zip(names, v) if abs(c) > 1e-9]
        out.append(":".join(name for name, _ in used) + " = "
                   + ":".join(f"{c:.4g}" for _, c in used))
    return ", ".join(out)


def _finite(info: RobotInfo, t, values, what: str) -> None:
    bad = ~np.isfinite(values).all(axis=-1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise NumericalError(f"{info.source}: {what} are not finite at t = {t[k]:g} s")


# -- output --------------------------------------------------------------------------
def unit_label(unit: str) -> str:
    return unit.replace("*", "·")


def columns(result: InverseResult) -> tuple[list[str], list[np.ndarray]]:
    """CSV contract: t, coordinates, rates d<name>, accelerations dd<name>, efforts."""
    names = [c.name for c in result.robot.coordinates]
    header = ["t", *names, *("d" + n for n in names), *("dd" + n for n in names),
              *(a.name for a in result.robot.actuators)]
    data = [result.t, *result.q.T, *result.dq.T, *result.ddq.T, *result.efforts.T]
    if result.constraints is not None:           # after the contract: the multipliers
        header += [r.column for r in result.constraints.rows]
        data += list(result.constraints.multipliers.T)
    return header, data


def table_times(duration: float) -> np.ndarray:
    """Round times over the motion, about 15 rows whatever its duration (t = 0, 1,
    ..., 15 s for the chapter's 15 s), and T itself."""
    from ..output.tables import table_times as round_times

    return np.array(round_times(duration))


def table(result: InverseResult) -> str:
    """Efforts at round times (computed at those exact times)."""
    times = result.t[0] + table_times(result.duration)
    tau = result.dynamics.efforts(times)[3]
    heads = ["t (s)"] + [f"{a.name} ({unit_label(a.unit)})" for a in result.robot.actuators]
    width = max(12, *(len(h) for h in heads))
    lines = ["  ".join(f"{h:>{width}}" for h in heads)]
    for k, moment in enumerate(times):
        lines.append("  ".join([f"{moment:>{width}g}"]
                               + [f"{round(v, 6) + 0.0:>{width}.6f}" for v in tau[k]]))
    return "\n".join(lines)


@dataclass(frozen=True)
class Sizing:
    """One actuator's figures over the motion, on the output grid:

        peak        tau(t_peak), the effort of largest |tau|
        rms         sqrt(integral of tau^2 dt / T), trapezoidal (what heats a motor)
        peak_rate   max |w|, w = (B^T dq)_a the speed of the actuator's joint (rad/s or
                    m/s): tau_a w is the power it delivers, sum_a tau_a w_a = Q . dq
        peak_power  max |tau w|, W (mechanical, at the joint)

    ``limit``: the file's |effort| bound of its joint, if any.  Open chains only
    have ``peak_rate`` and ``peak_power`` (None for a closed chain)."""
    name: str
    unit: str
    peak: float
    t_peak: float
    rms: float
    peak_rate: float | None
    peak_power: float | None
    limit: float | None

    @property
    def rate_unit(self) -> str:
        return "rad/s" if self.unit == "N*m" else "m/s"

    @property
    def share(self) -> float | None:
        """|peak| / limit."""
        return None if self.limit is None else abs(self.peak) / self.limit


def sizing(result: InverseResult) -> list[Sizing]:
    """Peak, RMS, peak rate and peak mechanical power of every actuator."""
    t, tau = result.t, result.efforts
    span = float(t[-1] - t[0])
    squares = tau ** 2
    rms = (np.sqrt(np.diff(t) @ (squares[1:] + squares[:-1]) / (2 * span)) if span > 0
           else np.abs(tau[0]))
    rates = getattr(result, "rates", None)
    out = []
    for k, a in enumerate(result.robot.actuators):
        j = int(np.argmax(np.abs(tau[:, k])))
        rate = power = None
        if rates is not None:
            rate = float(np.abs(rates[:, k]).max())
            power = float(np.abs(tau[:, k] * rates[:, k]).max())
        out.append(Sizing(a.name, a.unit, float(tau[j, k]) + 0.0,
                          round(float(t[j]), 9) + 0.0, float(rms[k]), rate, power,
                          a.effort_limit))
    return out


def sizing_table(result: InverseResult) -> str:
    """The actuators' sizing table: peak effort (and when), RMS effort, peak rate,
    peak mechanical power, and the share of the joint's effort limit where the
    robot gives one."""
    from ..output.tables import render

    heads = ["actuator", "peak effort", "at t (s)", "RMS effort", "peak rate",
             "peak power (W)", "of its limit"]
    rows = []
    for s in sizing(result):
        unit = unit_label(s.unit)
        share = "-" if s.share is None else (f"{100 * s.share:.0f}% of {s.limit:g}"
                                             + (" EXCEEDED" if s.share > 1 else ""))
        rows.append([s.name, f"{s.peak:+.6g} {unit}", f"{s.t_peak:g}", f"{s.rms:.6g} {unit}",
                     "-" if s.peak_rate is None else f"{s.peak_rate:.4g} {s.rate_unit}",
                     "-" if s.peak_power is None else f"{s.peak_power:.4g}", share])
    return render(heads, rows, min_width=8)


def roundtrip_line(result: InverseResult) -> str:
    """Two lines: how the round trip was integrated, and its verdict."""
    trip = result.roundtrip
    if trip is None:
        return "round trip: skipped (not asked for)"
    if trip.segments == 1:
        how = (f"round trip: one run from the start state over {result.duration:g} s "
               f"(open-loop growth rate up to {trip.growth_rate:.3g} 1/s)")
    else:
        how = (f"round trip: {trip.segments} pieces of {trip.segment:.3g} s, each from the "
               "prescribed motion (without feedback the arm drifts off it; see inverse.json)")
    unit = next(c.unit for c in result.robot.coordinates if c.name == trip.coordinate)
    verdict = "ok" if trip.passed else "FAILED"
    return (f"{how}\nround trip: largest tracking error {trip.max_error:.3g} {unit} "
            f"({trip.coordinate} at t = {trip.time:g} s), tolerance {trip.tolerance:g}: "
            f"{verdict} [{trip.method}, rtol {trip.rtol:g}, {trip.rhs_calls} rhs calls, "
            f"{trip.steps} steps, {trip.wall:.3f} s]")


@output.one_set
def write(result: InverseResult, out: Path, plot: bool = True, plot_format: str = "png",
          rates: bool = False) -> list[Path]:
    """inverse.csv, inverse.png (or .svg, .pdf; the rates and accelerations too if
    asked) and inverse.json in ``out``."""
    from ..output.plots import plot_path, write_plot

    out = output.prepare_dir(out)
    start = time.perf_counter()
    header, data = columns(result)
    written = [out / "inverse.csv"]
    output.write_csv(written[0], header, data)
    if plot:
        written.append(plot_path(out, "inverse", plot_format))
        write_plot(written[-1], result.t, _panels(result, rates), plot_title(result))
    result.timings["write"] = time.perf_counter() - start
    written.append(out / "inverse.json")
    output.write_json(written[-1], summary(result))
    return written


def plot_title(result: InverseResult) -> str:
    """The robot, the command and what computed the numbers (``build.describe``); the
    round trip's settings are in inverse.json."""
    return titled(f"{result.robot.name}: inverse", result.formulation, result.evaluator)


def summary(result: InverseResult) -> dict:
    """Key figures (``inverse.json``)."""
    efforts = {}
    for k, (a, size) in enumerate(zip(result.robot.actuators, sizing(result))):
        values = result.efforts[:, k]
        low, high = int(np.argmin(values)), int(np.argmax(values))
        efforts[a.name] = {"unit": a.unit, "min": float(values[low]),
                           "t_min": float(result.t[low]), "max": float(values[high]),
                           "t_max": float(result.t[high]), "start": float(values[0]),
                           "end": float(values[-1]), "peak": size.peak,
                           "t_peak": size.t_peak, "rms": size.rms,
                           "peak_rate": size.peak_rate, "rate_unit": size.rate_unit,
                           "peak_power_W": size.peak_power, "limit": size.limit}
    trip = result.roundtrip
    roundtrip = None if trip is None else {
        "passed": trip.passed, "max_error": trip.max_error, "coordinate": trip.coordinate,
        "t": trip.time, "errors": trip.errors, "final_error": trip.final_error,
        "tolerance": trip.tolerance, "method": trip.method, "rtol": trip.rtol,
        "atol": trip.atol, "rhs_calls": trip.rhs_calls, "steps": trip.steps,
        "segments": trip.segments, "segment": trip.segment, "growth_rate": trip.growth_rate,
        "growth_time": trip.growth_time, "growth_log10": trip.growth / math.log(10)}
    return {"robot": result.robot.name, "formulation": result.formulation,
            "evaluator": result.evaluator,
            "trajectory": result.kind, "duration": result.duration, "dt": result.step,
            "points": len(result.t),
            "points_per_second": (len(result.t) / result.timings["efforts"]
                                  if result.timings.get("efforts") else None),
            "efforts": efforts, "roundtrip": roundtrip,
            "limits": limits.summary(result.robot, result.limits),
            "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
            **_measured_summary(result.dynamics.motion),
            **({} if result.constraints is None else
               {"actuation": result.note or "unique",
                "multipliers": result.constraints.summary()["constraints"]["multipliers"]})}


def _measured_summary(motion) -> dict:
    """Where a measured motion came from and how its derivatives were obtained."""
    if not isinstance(motion, MeasuredMotion):
        return {}
    how = motion.differentiator
    return {"measured": {"file": motion.source, "samples": len(motion.t),
                         "given": list(motion.given), "differentiated": list(motion.differentiated),
                         "differentiator": {"method": "Savitzky-Golay", "window": how.window,
                                            "order": how.order}}}


def _panels(result: InverseResult, rates: bool = False):
    """The prescribed motion (one axis per unit: degrees apart from metres; rates and
    accelerations too if asked), then one panel per effort, as in the chapter."""
    panels = []
    quantities = [("", result.q, "")]
    if rates:
        quantities += [("d", result.dq, "/s"), ("dd", result.ddq, "/s²")]
    for prefix, values, per in quantities:
        for unit, label in (("rad", "deg"), ("m", "m")):
            series = [(prefix + c.name, np.degrees(values[:, i]) if unit == "rad"
                       else values[:, i])
                      for i, c in enumerate(result.robot.coordinates) if c.unit == unit]
            for start in range(0, len(series), 6):      # at most 6 lines an axis
                panels.append((f"prescribed {prefix}q ({label}{per})", series[start:start + 6]))
    from ..output.plots import effort_panels       # one panel per effort, as in the
                                                   # chapter's figures, with its limit
    return panels + effort_panels([(a.name, a.unit) for a in result.robot.actuators],
                                  result.efforts, one_each=True,
                                  limits=[a.effort_limit for a in result.robot.actuators])
