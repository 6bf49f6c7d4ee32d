"""The round trip: the direct dynamics driven by the computed efforts (and wrench, and
contact forces) as exact functions of time, against the prescribed motion, in segments
short enough for double precision where the open-loop motion is unstable."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ...errors import CheckFailed, NumericalError, positive
from ...model.info import RobotInfo
from ...numeric import integrators
from ...numeric.integrators import Problem
from ...numeric.measured import SpeedMap
from ...numeric.model import NumericModel
from .dynamics import InverseDynamics

DEFAULT_TOLERANCE = 1e-6     # rad or m, largest round-trip tracking error
ROUNDTRIP_RTOL = 1e-11
ROUNDTRIP_ATOL = 1e-12
AMPLIFICATION = 1e3          # largest exp(growth rate * segment) of a round-trip segment
GROWTH_SAMPLES = 31          # points along the motion where the growth rate is estimated


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


def growth_rates(dynamics: InverseDynamics, times: np.ndarray) -> np.ndarray:
    """Largest real part of the eigenvalues of d(x')/dx at each of ``times``, the efforts
    held at tau(t): how fast the open-loop motion departs from the trajectory, 1/s.

    A step-length estimate for the round trip only; the Jacobian is taken by central
    differences of x' = [W(q) u, M^-1 (F + B tau + wrench)] (``state_rate``) at the
    prescribed states.
    """
    rates = np.empty(len(times))
    for i, moment in enumerate(times):
        q, dq, _ = dynamics.motion(float(moment))
        x, applied = np.concatenate([q, dq]), dynamics.applied_at(float(moment))
        J = np.zeros((len(x), len(x)))
        for k in range(len(x)):
            h = 1e-6 * max(1.0, abs(x[k]))
            shifted = [x.copy(), x.copy()]
            shifted[0][k] += h
            shifted[1][k] -= h
            J[:, k] = (dynamics.state_rate(moment, shifted[0], *applied)
                       - dynamics.state_rate(moment, shifted[1], *applied)) / (2 * h)
        rates[i] = np.linalg.eigvals(J).real.max()
    return rates


def segment_rows(t: np.ndarray, count: int) -> np.ndarray:
    """Rows of ``t`` nearest to k T / count, k = 0..count (first and last row included)."""
    targets = np.linspace(t[0], t[-1], count + 1)
    right = np.clip(np.searchsorted(t, targets), 1, len(t) - 1)
    left = right - 1
    rows = np.where(targets - t[left] <= t[right] - targets, left, right)
    return np.unique(np.concatenate([[0], rows, [len(t) - 1]]))


def round_trip(result, tolerance: float = DEFAULT_TOLERANCE,
               segment: float | None = None, rtol: float = ROUNDTRIP_RTOL,
               atol: float = ROUNDTRIP_ATOL) -> RoundTrip:
    """Integrate x' = [W(q) u, M^-1 (F + B tau(t) + wrench(t))] (LSODA; W = 1 and u = dq
    without spherical joints) and compare q with the trajectory: |q - q(t)| for every
    coordinate, the angle of the turn between the attitudes for a quaternion
    (``SpeedMap.deviations``).

    The open-loop motion of an arm held against gravity is often unstable: a
    deviation grows like exp(lambda t), lambda the growth rate above, and over
    the whole motion no double-precision integration can follow it.  So the
    run is split into segments over which exp(lambda h) <= AMPLIFICATION, each
    started from the prescribed state at its first row (the first from the
    trajectory's start); a stable motion is one segment from the start state.
    ``segment`` (s) overrides the automatic length.
    """
    dynamics, t, model = result.dynamics, result.t, result.dynamics.model
    speed_map = SpeedMap(model.nq, model.quaternions)
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
        """x' = [W(q) u, M^-1 (F + B tau(t) + wrench(t))], the computed efforts and
        wrench at this t."""
        return dynamics.state_rate(moment, x, *dynamics.applied_at(moment))

    problem = Problem(rhs, names=model.state_names())
    names = deviation_names(model, speed_map)
    error = np.zeros((len(t), len(names)))
    steps = calls = 0
    for first, last in zip(rows[:-1], rows[1:]):
        x0 = np.concatenate([result.q[first], result.dq[first]])
        solution = integrators.integrate(problem, x0, t[first:last + 1], "odeint", rtol, atol,
                                         stop_at_end=True)
        calls, steps = calls + solution.rhs_calls, steps + solution.steps
        if not solution.success:
            raise NumericalError(f"{result.robot.source}: round trip: the direct dynamics "
                                 f"failed: {solution.message}")
        error[first:last + 1] = np.maximum(error[first:last + 1], speed_map.deviations(
            solution.x[:, :model.nq], result.q[first:last + 1]))
    wall = time.perf_counter() - start
    row, column = np.unravel_index(int(np.argmax(error)), error.shape)
    return RoundTrip("odeint (LSODA)", rtol, atol, tolerance, float(error[row, column]),
                     names[column], float(t[row]),
                     {name: float(e) for name, e in zip(names, error.max(axis=0))},
                     float(error[-1].max()), calls, steps, wall, len(rows) - 1,
                     float((t[-1] - t[0]) / (len(rows) - 1)), rate, rate_time, growth)


def deviation_names(model: NumericModel, speed_map: SpeedMap) -> list[str]:
    """The round trip's errors by name (``SpeedMap.deviations``): the coordinates, then
    ``<qw>..<qz> turn`` per quaternion (an angle, rad)."""
    return [*(model.coordinates[i] for i in speed_map.plain),
            *(f"{model.coordinates[g[0]]}..{model.coordinates[g[-1]]} turn"
              for g in speed_map.quaternions)]


def error_unit(robot: RobotInfo, name: str) -> str:
    """The unit of a round-trip error named ``name`` (``deviation_names``)."""
    return next((c.unit for c in robot.coordinates if c.name == name), "rad")


def raise_if_failed(result) -> None:
    """CheckFailed when the round trip of ``result`` (an ``InverseResult``) missed its
    tolerance."""
    trip = result.roundtrip
    if trip is None or trip.passed:
        return
    unit = error_unit(result.robot, trip.coordinate)
    raise CheckFailed(f"{result.robot.source}: round trip: largest tracking error "
                      f"{trip.max_error:.3g} {unit} ({trip.coordinate} at t = {trip.time:g} s) "
                      f"exceeds the round trip's tolerance {trip.tolerance:g}")
