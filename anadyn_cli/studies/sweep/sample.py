"""One sample, on a worker: bind the sampled values into the compiled robot, run the
command's service (the code ``anadyn simulate``, ``inverse`` and ``check`` run)
and take the metrics."""
from __future__ import annotations

import math
import time

import numpy as np

from ...errors import ModelError, NumericalError
from ...model.info import RobotInfo
from .plan import Payload, rated

STILL = 1e-9                   # rad or m: a coordinate that deviates less never "settles"


class Runner:
    """A worker's compiled robot and the command to run for each sample."""

    def __init__(self, payload: Payload):
        import scipy.integrate  # noqa: F401  imported here, once, not inside a timed solve

        from ... import __version__
        from ...numeric.bound import BoundModel

        if payload.version != __version__:     # the services here would not be the planner's
            raise RuntimeError(f"this worker runs anadyn {__version__}, the sweep was planned "
                               f"with anadyn {payload.version}; install the same version on "
                               "the workers")
        self.payload = payload
        info = RobotInfo.from_dict(payload.info, payload.source_name)
        self.model = BoundModel(info, payload.source, payload.formulation)
        self.options = dict(payload.options)
        self.groups = set(payload.groups)
        self.actuators = [a.name for a in info.actuators]
        self.coordinates = [c.name for c in info.coordinates]
        self._reference: tuple | None = None    # (t, r(t)) when the motion is fixed

    def sample(self, values) -> tuple[dict, float]:
        """(row of metrics with status and reason, seconds in the solvers)."""
        self.model.bind(values)
        row: dict = {"status": "ok", "reason": ""}
        solve = 0.0
        try:
            why = self.invalid()
            if why:
                return {"status": "invalid", "reason": why}, 0.0
            command = self.payload.command
            if command == "simulate":
                solve = self._simulate(row)
            elif command == "inverse":
                solve = self._inverse(row)
            else:
                solve = self._check(row)
        except NumericalError as err:
            row.update(status="failed", reason=str(err))
        except ModelError as err:       # e.g. actuators that cannot produce the motion
            row.update(status="invalid", reason=str(err))
        except Exception as err:        # noqa: BLE001  a bug: the sweep goes on, says so
            row.update(status="error", reason=f"{type(err).__name__}: {err}")
        return row, solve

    def invalid(self) -> str:
        """Why the bound values make no robot ('' when they do), like the loader says it."""
        for body, mass, inertia in self.model.inertial():
            if not (math.isfinite(mass) and np.isfinite(inertia).all()):
                return f"body {body}: mass or inertia is not a finite number"
            if mass < 0 or (mass == 0 and body not in self.payload.fixed_bodies):
                return (f"body {body}: mass {mass:g} kg is not positive" if mass < 0 else
                        f"body {body}: mass 0 kg; only a fixed (welded) body may be massless")
            diagonal = np.diagonal(inertia)
            moments = (np.sort(diagonal) if not (inertia - np.diag(diagonal)).any()
                       else np.linalg.eigvalsh(inertia))
            scale = max(1.0, float(np.abs(moments).max()))
            if moments[0] < -1e-12 * scale:
                return (f"body {body}: inertia tensor not positive semidefinite, principal "
                        f"moments {', '.join(f'{m:g}' for m in moments)}")
            if body not in self.model.triangle_unchecked and \
                    moments[0] + moments[1] < moments[2] - 1e-9 * scale:
                return (f"body {body}: principal moments {', '.join(f'{m:g}' for m in moments)}"
                        " break the triangle inequality")
        if not self.payload.fixed_motion and not np.isfinite(self.model.initial_state()).all():
            return "the initial state is not a finite number"
        if not self.payload.fixed_motion and (self.payload.command == "inverse"
                                              or "tracking" in self.groups):
            try:
                duration = self.model.motion.duration
            except ModelError:
                return ""
            if not (math.isfinite(duration) and duration > 0):
                return f"the trajectory's duration {duration:g} s is not positive"
        return ""

    # -- the commands ----------------------------------------------------------
    def _simulate(self, row: dict) -> float:
        from ...services import simulate

        options = {k: self.options[k] for k in ("method", "rtol", "atol", "t_end",
                                                "output_step")}
        result = simulate.simulate(self.model, **options)
        solution = result.solution
        self._calls(row, solution.rhs_calls, solution.steps)
        solve = solution.wall
        if not solution.success:
            row.update(status="failed", reason=solution.message)
            return solve
        self._path(row, result.t, result.x, np.asarray(result.efforts).reshape(len(result.t), -1))
        if "energy" in self.groups:
            solve += self._energy(row)
        return solve

    def _energy(self, row: dict) -> float:
        """check's energy balance along the same scene (one more solve, with W)."""
        from ...services import check

        rtol, atol, t_end, output_step = self.payload.energy
        try:
            report = check.check(self.model, rtol=rtol, atol=atol, t_end=t_end,
                                 output_step=output_step, samples=1, probe_calls=100)
        except NumericalError as err:
            raise NumericalError(f"energy run: {err}") from None
        row["energy_error"] = report.energy_error
        return float(report.timings.get("solve", 0.0))

    def _inverse(self, row: dict) -> float:
        from ...services import inverse

        result = inverse.inverse(self.model, **self.options)
        trip = result.roundtrip
        if "calls" in self.groups:
            self._calls(row, trip.rhs_calls if trip else 0, trip.steps if trip else 0)
        self._effort(row, result.t, np.asarray(result.efforts))
        self._limits(row, result.t, result.q, result.dq, np.asarray(result.efforts))
        if trip is not None and "tracking" in self.groups:
            row["tracking_error"], row["final_error"] = trip.max_error, trip.final_error
        return float(result.timings.get("efforts", 0.0) + result.timings.get("roundtrip", 0.0))

    def _check(self, row: dict) -> float:
        from ...services import check

        report = check.check(self.model, **self.options)
        summary = check.summary(report)
        if "calls" in self.groups:
            row["rhs_calls"] = summary["rhs_calls"]
        n = self.model.n
        t, x = report.t, report.x
        tau = self.model.efforts(t, x[:, :n].T, x[:, n:].T) if self.actuators else \
            np.zeros((0, len(t)))
        self._path(row, t, x, np.broadcast_to(tau, (len(self.actuators), len(t))).T)
        if "energy" in self.groups:
            row["energy_error"] = summary["energy_error"]
        if "check" in self.groups:
            row.update(stiff=int(bool(summary["stiff"])), fastest_decay=summary["fastest_decay"],
                       mass_condition_scaled=summary["mass_condition_scaled"],
                       check_passed=int(bool(summary["passed"])))
        return float(sum(v for v in report.timings.values() if isinstance(v, float)))

    # -- metrics ---------------------------------------------------------------
    def _calls(self, row: dict, calls: int, steps: int) -> None:
        if "calls" in self.groups:
            row["rhs_calls"], row["steps"] = int(calls), int(steps)

    def _effort(self, row: dict, t: np.ndarray, tau: np.ndarray) -> None:
        """peak and RMS of each effort; ``tau`` rows x m."""
        if "effort" not in self.groups:
            return
        if not self.actuators:
            return
        span = t[-1] - t[0]
        peaks = np.abs(tau).max(axis=0)
        squares = tau ** 2
        rms = (np.sqrt(np.diff(t) @ (squares[1:] + squares[:-1]) / (2 * span)) if span > 0
               else np.abs(tau[0]))                       # trapezoidal rule, all at once
        for k, name in enumerate(self.actuators):
            row[f"peak_{name}"], row[f"rms_{name}"] = float(peaks[k]), float(rms[k])

    def _limits(self, row: dict, t, q, dq, tau) -> None:
        """How many of the file's joint limits the run passes (``numeric.limits``), and
        the first, in words."""
        if "limits" not in self.groups:
            return
        from ...numeric import limits

        passed = limits.check(self.model.info, t, q, dq, tau)
        row["limits_passed"] = len(passed)
        if passed:
            row["_file_limit"] = passed[0].line()

    def _path(self, row: dict, t: np.ndarray, x: np.ndarray, tau: np.ndarray) -> None:
        n = self.model.nq                   # coordinates, then the speeds
        q = x[:, :n]
        self._effort(row, t, tau)
        self._limits(row, t, q, x[:, n:], tau)
        if "tracking" in self.groups:
            error = np.abs(q - self.reference(t))
            row["tracking_error"] = float(error.max())
            row["final_error"] = float(error[-1].max())
        if "settling" in self.groups:
            row["settling_time"] = settling_time(t, q, self.payload.settle_band)
        if "final" in self.groups:
            for i, name in enumerate(self.coordinates):
                row[f"final_{name}"] = float(x[-1, i])
            for k, name in enumerate(self.coordinates[:rated(self.model.nq, self.model.n)]):
                row[f"final_d{name}"] = float(x[-1, n + k])


    def reference(self, t: np.ndarray) -> np.ndarray:
        """r(t): the trajectory held at its end after its duration (computed once when
        it does not depend on the varied names)."""
        cached = self._reference
        if cached is not None and len(cached[0]) == len(t) and (cached[0] == t).all():
            return cached[1]
        motion = self.model.motion
        reference = motion(np.minimum(t, motion.duration))[0]
        if self.payload.fixed_motion:
            self._reference = (t.copy(), reference)
        return reference


def settling_time(t: np.ndarray, q: np.ndarray, band: float) -> float:
    """First grid time after which every coordinate stays within ``band`` of its
    largest deviation from its final value (coordinates that deviate less than
    STILL are ignored; 0 when none moves)."""
    deviation = np.abs(q - q[-1])
    largest = deviation.max(axis=0)
    moving = largest > STILL
    if not moving.any():
        return float(t[0])
    outside = (deviation[:, moving] > band * largest[moving]).any(axis=1)
    last = np.flatnonzero(outside)
    return float(t[min(last[-1] + 1, len(t) - 1)]) if len(last) else float(t[0])


def setup(payload: Payload) -> Runner:
    return Runner(payload)


def work(runner: Runner, piece) -> list:
    """[(index, row, solve seconds, sample seconds)] for the samples of ``piece``."""
    results = []
    for index, values in piece:
        start = time.perf_counter()
        row, solve = runner.sample(values)
        results.append((index, row, solve, time.perf_counter() - start))
    return results



def dask_setup(worker=None) -> None:
    """``dask worker ADDRESS --preload anadyn_cli.studies.sweep``: import what a
    sweep's pieces run (NumPy, SciPy's integrators, anadyn's numeric model and
    services) when the worker starts, not inside the first piece."""
    import scipy.integrate  # noqa: F401

    from ...numeric import bound  # noqa: F401
    from ...services import check, simulate  # noqa: F401
