"""What a sweep runs, decided before any sample runs: the command's settings
(checked by their library names, as its service checks them), the metric
columns and bounds, and the robot derived and compiled once with the varied
names free (the ``Payload`` every worker gets)."""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field
from pathlib import Path

from ... import errors
from ...errors import ModelError, SettingError
from ...model.info import RobotInfo
from .design import Design, design
from .grammar import parse_bound, parse_vary

COMMANDS = ("simulate", "inverse", "check")
GROUPS = ("effort", "tracking", "settling", "final", "energy", "check", "limits", "calls")
DEFAULT_GROUPS = {
    "simulate": ("effort", "tracking", "settling", "final", "limits", "calls"),
    "inverse": ("effort", "tracking", "limits", "calls"),
    "check": ("effort", "tracking", "settling", "final", "energy", "check", "limits", "calls"),
}
SETTLE_BAND = 0.02
CHECK_SAMPLES = 200            # eigenvalue samples of --command check (as anadyn check)
#: settings of the integrated runs (simulate, check), not of inverse
RUN_SETTINGS = ("method", "rtol", "atol", "t_end", "energy_tol", "max_condition")
SETTINGS = (*RUN_SETTINGS, "output_step", "roundtrip", "roundtrip_tolerance",
            "roundtrip_segment")


@dataclass(frozen=True)
class Payload:
    """What a worker needs, shipped once per worker (see ``executors``)."""
    source: str                   # the generated module with the varied names free
    info: dict                    # RobotInfo.to_dict()
    source_name: str
    formulation: str
    command: str
    options: tuple                # (name, value) pairs for the command's service
    groups: tuple[str, ...]
    columns: tuple[str, ...]      # metric columns, in order
    settle_band: float
    energy: tuple                 # (rtol, atol, t_end, output_step) of the energy run
    version: str = ""             # anadyn's, where the sweep was planned
    fixed_motion: bool = False    # initial state and trajectory do not depend on them
    fixed_bodies: tuple[str, ...] = ()   # welded bodies: a mass of 0 adds nothing, is valid


@dataclass
class Plan:
    robot: RobotInfo
    folding: object               # numeric.bindable.Folding
    design: Design
    payload: Payload
    bounds: tuple[tuple[str, str, float], ...]   # (metric, "max" or "min", bound)
    settings: dict
    timings: dict = field(default_factory=dict)

    @property
    def judged(self) -> bool:
        """Whether samples are judged: --max/--min, or the file's own joint limits."""
        return bool(self.bounds) or "limits_passed" in self.payload.columns

    @property
    def columns(self) -> list[str]:
        """CSV header: the varied names, status, reason, metrics (and the limits)."""
        limits = ["within_limits", "limit_miss"] if self.judged else []
        return [*self.design.names, "status", "reason", *self.payload.columns, *limits]


def rated(nq: int, n: int) -> int:
    """How many coordinates have their rate among the n speeds (all of them, but not a
    spherical joint's quaternion: 4 coordinates, 3 speeds; those come last)."""
    return n - 3 * (nq - n)


def metric_columns(info: RobotInfo, command: str, groups: tuple[str, ...]) -> list[str]:
    columns = []
    if "effort" in groups:
        columns += [f"peak_{a.name}" for a in info.actuators]
        columns += [f"rms_{a.name}" for a in info.actuators]
    if "tracking" in groups:
        columns += ["tracking_error", "final_error"]
    if "settling" in groups:
        columns.append("settling_time")
    if "final" in groups:
        columns += [f"final_{c.name}" for c in info.coordinates]
        columns += [f"final_d{c.name}" for c in info.coordinates[
            :rated(len(info.coordinates), len(info.speeds or info.coordinates))]]
    if "energy" in groups:
        columns.append("energy_error")
    if "check" in groups:
        columns += ["stiff", "fastest_decay", "mass_condition_scaled", "check_passed"]
    if "limits" in groups:
        columns.append("limits_passed")
    if "calls" in groups:
        columns += ["rhs_calls"] + (["steps"] if command != "check" else [])
    return columns


def metric_groups(command: str, metrics: str | None, has_motion: bool,
                  roundtrip: bool, has_limits: bool = False) -> tuple[str, ...]:
    """The metric groups to compute: --metrics, else the command's defaults."""
    applies = {"simulate": set(GROUPS) - {"check"}, "check": set(GROUPS),
               "inverse": {"effort", "tracking", "limits", "calls"}}[command]
    if metrics is None:
        chosen = list(DEFAULT_GROUPS[command])
        if not has_motion or (command == "inverse" and not roundtrip):
            chosen.remove("tracking")
        if not has_limits:
            chosen.remove("limits")
        return tuple(chosen)
    chosen = [m.strip().lower() for m in metrics.split(",") if m.strip()]
    if not chosen:
        raise ModelError(f"--metrics: give one or more of {', '.join(GROUPS)}")
    for group in chosen:
        if group not in GROUPS:
            raise ModelError(f"--metrics: unknown metric {group!r}; choose from "
                             f"{', '.join(GROUPS)}")
        if group not in applies:
            raise ModelError(f"--metrics: {group} does not apply to --command {command} "
                             f"(it takes {', '.join(g for g in GROUPS if g in applies)})")
    if "tracking" in chosen and not has_motion:
        raise ModelError("--metrics tracking: the robot file has no trajectory to track "
                         "(the tracking error is measured against it)")
    if "limits" in chosen and not has_limits:
        raise ModelError("--metrics limits: the robot file gives no joint limits (limits: "
                         "{lower, upper, velocity, effort} of a joint); give bounds with "
                         "--max/--min")
    if "tracking" in chosen and command == "inverse" and not roundtrip:
        raise ModelError("--metrics tracking: inverse's tracking error is the round trip's; "
                         "drop --no-roundtrip")
    return tuple(g for g in GROUPS if g in chosen)


def plan(path: str | Path, vary: list[str], command: str = "simulate",
         formulation: str = "kane", samples: int | None = None, seed: int = 0,
         metrics: str | None = None, maxima: list[str] = (), minima: list[str] = (),
         settle_band: float = SETTLE_BAND, use_cache: bool = False, **settings) -> Plan:
    """Check every option, then derive and compile the robot once with the varied
    names free.  Nothing runs and nothing is written yet.

    ``settings`` are the command's, by their library names: ``method``, ``rtol``,
    ``atol``, ``t_end``, ``output_step`` (simulate, check), ``energy_tol``,
    ``max_condition`` (check), ``output_step``, ``roundtrip``,
    ``roundtrip_tolerance``, ``roundtrip_segment`` (inverse)."""
    from ...model import robot_from_text
    from ...model.yamlsource import read_text
    from ...numeric import bindable, limits

    unknown = sorted(set(settings) - set(SETTINGS))
    if unknown:
        raise TypeError(f"plan() got an unexpected setting {unknown[0]!r}")
    if command not in COMMANDS:
        raise ModelError(f"--command: {command!r} cannot be swept; choose one of "
                         f"{', '.join(COMMANDS)}")
    chosen = design([parse_vary(v) for v in vary], samples, seed)
    errors.check("settle_band", settle_band)
    bounds = [(m, "max", b) for m, b in (parse_bound("--max", t) for t in maxima)]
    bounds += [(m, "min", b) for m, b in (parse_bound("--min", t) for t in minima)]
    timings: dict = {}
    start = time.perf_counter()
    text, source = read_text(path)
    robot = robot_from_text(text, source)
    timings["load"] = time.perf_counter() - start
    if getattr(robot, "constraints", None) is not None:
        raise ModelError("a robot with closed loops or constraints cannot be swept yet (its "
                         "numeric model is not bindable); sweep an open chain",
                         source=source)
    folding = bindable.fold(robot, text, chosen.names)
    info = RobotInfo.from_robot(robot)
    groups = metric_groups(command, metrics, robot.trajectory is not None,
                           settings.get("roundtrip", True), limits.bounds(info) > 0)
    columns = metric_columns(info, command, groups)
    for metric, kind, _ in bounds:
        if metric not in columns:
            listed = ", ".join(columns) or "none"
            raise ModelError(f"--{kind} {metric}: not a metric of this sweep; metrics: "
                             f"{listed}")
    if command == "inverse":
        options, energy = _inverse_options(robot, info, folding, source, **settings)
    else:
        options, energy = _run_options(command, info, **settings)
    code = _derive(robot, folding, formulation, chosen.names, use_cache, timings)
    from ... import __version__

    payload = Payload(code, info.to_dict(), source, formulation, command,
                      tuple(sorted(options.items())), groups, tuple(columns), settle_band,
                      energy, __version__,
                      not (folding.follows["trajectory"] or folding.follows["initial"]),
                      tuple(b.name for b in robot.bodies if not b.joint.joint_type.moving))
    moment = time.perf_counter()
    bindable.BoundModel(info, code, formulation)       # compiles here: a bad module fails now
    timings["compile"] = time.perf_counter() - moment
    return Plan(info, folding, chosen, payload, tuple(bounds), dict(options), timings)


def _inverse_options(robot, info: RobotInfo, folding, source: str,
                     output_step: float | None = None, roundtrip: bool = True,
                     roundtrip_tolerance: float | None = None,
                     roundtrip_segment: float | None = None, **others) -> tuple[dict, tuple]:
    """inverse's options (as ``services.inverse`` takes them) and the energy run's
    settings, the file's."""
    from ...numeric import settings as run_settings

    if robot.trajectory is None:
        raise ModelError("no trajectory section: inverse dynamics needs a prescribed "
                         "motion (trajectory: kind cycloidal, quintic or expression)",
                         source=source)
    if not robot.actuators:
        raise ModelError("no actuators: inverse dynamics needs one independent actuator "
                         "per coordinate", source=source, path="actuators")
    step = errors.check("output_step", output_step if output_step is not None
                        else info.simulation.output_step or 0.01)
    duration = float(robot.trajectory.duration)
    if step > duration and not folding.follows["trajectory"]:
        raise SettingError("output_step", f"{step:g} s is longer than the trajectory's "
                                          f"duration {duration:g} s")
    options = {"step": step, "roundtrip": roundtrip}
    if roundtrip_tolerance is not None:
        options["tolerance"] = errors.check("roundtrip_tolerance", roundtrip_tolerance)
    if roundtrip_segment is not None:
        options["segment"] = errors.check("roundtrip_segment", roundtrip_segment)
    given = [name for name in RUN_SETTINGS if others.get(name) is not None]
    if given:
        raise SettingError(given[0], "applies to --command simulate or check, not inverse "
                                     "(which runs on the trajectory's own time grid, --dt)")
    return options, _energy(run_settings.resolve(info))


def _run_options(command: str, info: RobotInfo, method: str | None = None,
                 rtol: float | None = None, atol: float | None = None,
                 t_end: float | None = None, output_step: float | None = None,
                 roundtrip: bool = True, roundtrip_tolerance: float | None = None,
                 roundtrip_segment: float | None = None, energy_tol: float | None = None,
                 max_condition: float | None = None) -> tuple[dict, tuple]:
    """simulate's or check's options (as their services take them) and the energy
    run's settings: the given ones, then the file's (``numeric.settings``)."""
    from ...numeric import settings as run_settings

    if command == "check" and method is not None:
        raise SettingError("method", "applies to --command simulate; check integrates with "
                                     "odeint (LSODA), as anadyn check does")
    if command == "simulate" and (energy_tol is not None or max_condition is not None):
        raise ModelError("--energy-tol and --max-condition apply to --command check")
    if not roundtrip or roundtrip_tolerance is not None or roundtrip_segment is not None:
        raise ModelError("--no-roundtrip, --roundtrip-tol and --roundtrip-segment apply to "
                         "--command inverse")
    settings = run_settings.resolve(info, method=method, rtol=rtol, atol=atol,
                                    t_end=t_end, output_step=output_step)
    options = {"rtol": settings.rtol, "atol": settings.atol, "t_end": settings.t_end,
               "output_step": settings.output_step}
    if command == "simulate":
        options["method"] = settings.method
    else:
        options["samples"] = CHECK_SAMPLES
        if energy_tol is not None:
            options["energy_tol"] = errors.check("energy_tol", energy_tol)
        if max_condition is not None:
            options["max_condition"] = errors.check("max_condition", max_condition)
    return options, _energy(settings)


def _energy(settings) -> tuple:
    """(rtol, atol, t_end, output_step) of the energy balance's run."""
    return settings.rtol, settings.atol, settings.t_end, settings.output_step


def _derive(robot, folding, formulation: str, names: tuple[str, ...], use_cache: bool,
            timings: dict) -> str:
    """The generated module with ``names`` free: from the cache, else derived (and
    stored when ``use_cache``)."""
    from ...numeric import bindable, cache

    robot.refuse_contacts("sweeps (sweep: the closed forms with free parameters)")

    digest = hashlib.sha256(f"{robot.digest}|sweep|{','.join(names)}".encode()).hexdigest()
    code = None
    if use_cache:
        entry = cache.load(digest, formulation)
        code = entry.get("code") if entry else None
        timings["cache"] = "hit" if code else "miss"
    if code is None:
        moment = time.perf_counter()
        code = bindable.source(folding, formulation)
        timings["derive"] = time.perf_counter() - moment
        if use_cache:
            cache.store(digest, formulation, {"code": code})
    return code
