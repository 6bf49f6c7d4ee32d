"""What ``inverse`` gives: ``InverseResult``, inverse.csv's columns, the terminal
tables (efforts at round times, each actuator's sizing figures), inverse.json and the
plot."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import files as output
from ...model.info import RobotInfo
from ...numeric import constrained, contact_inverse
from ...numeric.build import titled
from ...numeric.measured import MeasuredMotion
from ...output.csv_table import write_csv
from ...output.notebook import Displayed
from ...numeric import limits
from .dynamics import InverseDynamics
from .roundtrip import RoundTrip, error_unit


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
    wrench: np.ndarray | None = None  # (N, k) the wrench the motion needs (``free_rows``)
    wrench_columns: tuple = ()        # its (column, unit) pairs
    contact: "contact_inverse.Distribution | None" = None   # the contact forces needed
    contact_report: dict = field(default_factory=dict)      # inverse.json's ``contact``

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
        from ...output.plots import time_figure

        return time_figure(self.t, _panels(self, rates), plot_title(self))

    def sizing(self) -> list["Sizing"]:
        """Each actuator's figures for choosing a motor (``sizing``)."""
        return sizing(self)


def unit_label(unit: str) -> str:
    return unit.replace("*", "·")


def columns(result: InverseResult) -> tuple[list[str], list[np.ndarray]]:
    """CSV contract: t, coordinates, rates d<name>, accelerations dd<name>, efforts; with
    spherical joints the speeds (``wx``) in place of the rates and their derivatives
    (``dwx``) in place of the accelerations, each quaternion made unit, and the wrench
    the motion needs (``free_rows``; on a robot in contact what the contacts leave)
    after the efforts, then per contact ``<contact>_fn``, ``_ft1``, ``_ft2`` (the forces
    it must give, N, as simulate's columns) and ``_active`` (1 or 0)."""
    names = [c.name for c in result.robot.coordinates]
    speeds = ([u.name for u in result.robot.speeds] if result.robot.speeds
              else ["d" + n for n in names])
    header = ["t", *names, *speeds, *("d" + u for u in speeds),
              *(a.name for a in result.robot.actuators),
              *(name for name, _ in result.wrench_columns)]
    data = [result.t, *result.q.T, *result.dq.T, *result.ddq.T, *result.efforts.T]
    if result.wrench is not None:
        data += list(result.wrench.T)
    if result.contact is not None:
        for c, name in enumerate(result.dynamics.model.contact_names):
            header += [f"{name}_{part}" for part in ("fn", "ft1", "ft2", "active")]
            data += [*result.contact.forces[:, c].T, result.contact.active[:, c].astype(float)]
    if result.constraints is not None:           # after the contract: the multipliers
        header += [r.column for r in result.constraints.rows]
        data += list(result.constraints.multipliers.T)
    return header, data


def table_times(duration: float) -> np.ndarray:
    """Round times over the motion, about 15 rows whatever its duration (t = 0, 1,
    ..., 15 s for the chapter's 15 s), and T itself."""
    from ...output.tables import table_times as round_times

    return np.array(round_times(duration))


def table(result: InverseResult) -> str:
    """Efforts at round times (computed at those exact times; a measured motion's at
    the samples nearest them, which need no interpolation)."""
    times = result.t[0] + table_times(result.duration)
    if isinstance(result.dynamics.motion, MeasuredMotion):
        times = result.dynamics.motion.samples_near(times)
    tau = result.dynamics.efforts(times)[3]
    if result.wrench is not None:
        tau = np.concatenate(result.dynamics.forces(times), -1)
    heads = (["t (s)"] + [f"{a.name} ({unit_label(a.unit)})" for a in result.robot.actuators]
             + [f"{name} ({unit_label(unit)})" for name, unit in result.wrench_columns])
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


def root_mean_square(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """sqrt(integral of v^2 dt / T) of each column of ``values`` (N, k), trapezoidal
    (|v(t0)| for a single row)."""
    span = float(t[-1] - t[0])
    squares = values ** 2
    return (np.sqrt(np.diff(t) @ (squares[1:] + squares[:-1]) / (2 * span)) if span > 0
            else np.abs(values[0]))


def sizing(result: InverseResult) -> list[Sizing]:
    """Peak, RMS, peak rate and peak mechanical power of every actuator."""
    t, tau = result.t, result.efforts
    rms = root_mean_square(t, tau)
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
    from ...output.tables import render

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
    for name, figures in _wrench_summary(result).get("wrench", {}).get("columns", {}).items():
        unit = unit_label(figures["unit"])           # the wrench the motion needs
        rows.append([name, f"{figures['peak']:+.6g} {unit}", f"{figures['t_peak']:g}",
                     f"{figures['rms']:.6g} {unit}", "-", "-", "-"])
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
    unit = error_unit(result.robot, trip.coordinate)
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
    from ...output.plots import plot_path, write_plot

    out = output.prepare_dir(out)
    start = time.perf_counter()
    header, data = columns(result)
    written = [out / "inverse.csv"]
    write_csv(written[0], header, data)
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
            **_measured_summary(result.dynamics.motion), **_wrench_summary(result),
            **_contact_summary(result),
            **({} if result.constraints is None else
               {"actuation": result.note or "unique",
                "multipliers": result.constraints.summary()["constraints"]["multipliers"]})}


WRENCH_CONVENTION = ("the generalized force the motion needs at the speeds of spherical and "
                     "floating joints no actuator reaches: a floating joint's force along its "
                     "slides (the joint frame's axes: the world's for a base without rpy), N, "
                     "and moment about the body's origin in body axes, N*m, acting on the "
                     "body from outside (zero for a motion a free robot makes with its "
                     "joints alone; on a robot in contact, what the contacts' forces leave)")


def _wrench_summary(result: InverseResult) -> dict:
    """Each wrench column's extremes and RMS (``inverse.json``), with its convention."""
    if result.wrench is None:
        return {}
    t, out = result.t, {}
    rms = root_mean_square(t, result.wrench)
    for k, (name, unit) in enumerate(result.wrench_columns):
        values = result.wrench[:, k]
        peak = int(np.argmax(np.abs(values)))
        out[name] = {"unit": unit, "min": float(values.min()), "max": float(values.max()),
                     "peak": float(values[peak]) + 0.0, "t_peak": float(t[peak]),
                     "rms": float(rms[k]), "start": float(values[0]), "end": float(values[-1])}
    return {"wrench": {"convention": WRENCH_CONVENTION, "columns": out}}


CONTACT_RESOLUTION = {
    "least-norm": ("the rows no actuator reaches are given by the active contacts' forces of "
                   "least Euclidean norm (minimum-norm least squares); the actuators give "
                   "the rest; what neither gives is the residual (the wrench columns)"),
    "cone": ("the rows no actuator reaches are given by the active contacts' forces of "
             "least Euclidean norm, and where those pull or leave a friction cone by the "
             "least-norm ones inside the cones linearized as 16-sided polygons (when there "
             "are such); the actuators give the rest; what neither gives is the residual "
             "(the wrench columns)")}


def _contact_summary(result: InverseResult) -> dict:
    """inverse.json's ``contact``: the model, how redundancy was resolved, the activity
    gap, per contact its active samples and largest forces, and the samples the
    contacts cannot support (``ContactSupport.assess``)."""
    if result.contact is None:
        return {}
    model, share = result.dynamics.model, result.contact
    per = {}
    for c, name in enumerate(model.contact_names):
        fn, ft = share.forces[:, c, 0], np.hypot(share.forces[:, c, 1], share.forces[:, c, 2])
        per[name] = {"active_samples": int(share.active[:, c].sum()),
                     "max_fn": float(fn.max(initial=0.0)), "min_fn": float(fn.min()),
                     "max_ft": float(ft.max(initial=0.0))}
    return {"contact": {"model": "rigid" if model.rigid_contacts is not None else "compliant",
                        "resolution": result.dynamics.support.resolution,
                        "how": CONTACT_RESOLUTION[result.dynamics.support.resolution],
                        "gap": result.dynamics.support.gap,
                        "contacts": per, "unsupported": result.contact_report}}


def unsupported_line(result: InverseResult) -> str:
    """One warning line when the contacts cannot support some samples; '' otherwise."""
    report = result.contact_report
    if not report.get("samples"):
        return ""
    words = [f"{reason.replace('_', ' ')} at {figures['samples']} (worst by "
             f"{figures['by']:.3g} at t = {figures['t']:g} s"
             + (f", {figures['contact']})" if "contact" in figures else ")")
             for reason, figures in report["reasons"].items()]
    return (f"the contacts cannot support {report['samples']} of {len(result.t)} samples: "
            + "; ".join(words) + " (inverse.json: contact.unsupported)")


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
    """The prescribed motion (one axis per unit: degrees apart from metres, a quaternion's
    numbers apart; the speeds and their derivatives too if asked), then one panel per
    effort, as in the chapter, and the wrench the motion needs."""
    names = [(c.name, c.unit) for c in result.robot.coordinates]
    speeds = ([(u.name, u.unit[:-2]) for u in result.robot.speeds] if result.robot.speeds
              else [("d" + name, unit) for name, unit in names])
    quantities = [("", names, result.q, "")]
    if rates:
        quantities += [("", speeds, result.dq, "/s"), ("d", speeds, result.ddq, "/s²")]
    panels = []
    for prefix, named, values, per in quantities:
        for unit, label in (("rad", "deg"), ("m", "m"), ("1", "1")):
            series = [(prefix + name, np.degrees(values[:, i]) if unit == "rad"
                       else values[:, i]) for i, (name, u) in enumerate(named) if u == unit]
            for start in range(0, len(series), 6):      # at most 6 lines an axis
                what = "q" if not per else "dq" if per == "/s" else "ddq"
                panels.append((f"prescribed {what} ({label}{per})", series[start:start + 6]))
    from ...output.plots import effort_panels       # one panel per effort, as in the
                                                   # chapter's figures, with its limit
    panels += effort_panels([(a.name, a.unit) for a in result.robot.actuators],
                            result.efforts, one_each=True,
                            limits=[a.effort_limit for a in result.robot.actuators])
    if result.wrench is not None:        # the wrench the motion needs, forces and moments
        panels += effort_panels(list(result.wrench_columns), result.wrench)
    if result.contact is not None:       # the normal forces the contacts must give
        panels += effort_panels([(f"{name}_fn", "N") for name in
                                 result.dynamics.model.contact_names],
                                result.contact.forces[:, :, 0])
    return panels
