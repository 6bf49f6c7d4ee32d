"""Parameter sweeps: a robot derived and compiled once, run for many values of a few names.

    anadyn sweep ROBOT --vary NAME=SPEC ... [--command simulate|inverse|check]

NAME is a parameter or a controller gain of the robot file; SPEC is one of

    FROM:TO:COUNT        a grid, COUNT values evenly from FROM to TO (10:60:11)
    V1,V2,...            a list (100,450; one value fixes the name)
    normal(MEAN,SD)      a Monte-Carlo draw from a normal distribution
    uniform(LOW,HIGH)    a Monte-Carlo draw from a uniform distribution

Numbers may be constant expressions (``pi/6``), read by the robot file's
own safe parser; nothing is evaluated as Python.  Grids and lists combine as
a full grid (the first --vary varies slowest); distributions draw
``--samples`` values each from one generator seeded by ``--seed``, and at
every grid point the same draws are used (common random numbers).

The varied names stay symbols and everything else is folded to numbers:
the robot is derived and compiled once (``numeric.bindable``), and each
sample only binds its numbers and runs the command's service (the same
code ``anadyn simulate``, ``inverse`` and ``check`` run).  What the file
computes from a varied name follows it: derived parameters, gains defined
from parameters, initial values, the trajectory.

Per sample, on the output grid (t = k dt), over the whole run:

    peak_<a>         max |tau_a(t)|                       (N*m or N)
    rms_<a>          sqrt(integral of tau_a^2 dt / duration), trapezoidal
    tracking_error   max over t and coordinates of |q(t) - r(t)|, rad or m, with
                     r(t) the file's trajectory held at its end after its duration
                     (simulate, check); for inverse the round trip's largest error
                     (the direct dynamics driven by the efforts against the motion)
    final_error      max over coordinates of |q - r| at the end of the run: the
                     steady-state error against the trajectory's end, the target
    settling_time    the time after which every coordinate stays within
                     --settle-band (2 %) of its largest deviation from its final
                     value, around that final value; near t_end: not settled
    final_<q>        q and d<q> at the end of the run
    energy_error     check's energy balance max |T + V - W - E0| / energy scale
                     (simulate: one more solve with the actuators' work W)
    stiff, fastest_decay, mass_condition_scaled, check_passed     (check)
    limits_passed    how many of the file's joint limits (position, rate, effort;
                     ``numeric.limits``) the run passes
    rhs_calls, steps the integrator's work

``--max METRIC=BOUND`` and ``--min METRIC=BOUND`` judge each sample, with the
file's joint limits: ``within_limits`` (1 or 0) and ``limit_miss`` (which
not); for one varied name, ``capacity`` gives the range of values from the
first one within the limits up to the first miss.

``status`` is ok, failed (the run failed numerically: ``reason`` says where),
invalid (the values make no robot: a mass not positive, an inertia that no
body has, actuators that cannot produce the motion) or error (anything else,
a bug).  A failed sample is data, not the end of the sweep.
"""
from __future__ import annotations

import csv
import hashlib
import io
import math
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import ModelError, NumericalError, SettingError, positive
from ..model.info import RobotInfo
from .. import files as output
from . import executors

COMMANDS = ("simulate", "inverse", "check")
GROUPS = ("effort", "tracking", "settling", "final", "energy", "check", "limits", "calls")
DEFAULT_GROUPS = {
    "simulate": ("effort", "tracking", "settling", "final", "limits", "calls"),
    "inverse": ("effort", "tracking", "limits", "calls"),
    "check": ("effort", "tracking", "settling", "final", "energy", "check", "limits", "calls"),
}
DISTRIBUTIONS = ("normal", "uniform")
DEFAULT_SAMPLES = 100          # Monte-Carlo draws when --samples is not given
MAX_SAMPLES = 1_000_000
SETTLE_BAND = 0.02
STILL = 1e-9                   # rad or m: a coordinate that deviates less never "settles"
JSON_ROWS = 10_000             # sweep.json lists the rows up to this many samples
STATUSES = ("ok", "failed", "invalid", "error")
CHECK_SAMPLES = 200            # eigenvalue samples of --command check (as anadyn check)
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_CALL = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*\((.*)\)\s*\Z", re.S)
EXAMPLES = ("e.g. m2=0.5:2:7 (grid), m2=1,2,5 (list), m2=normal(1,0.05) or "
            "m2=uniform(0.8,1.2)")


# ----------------------------------------------------------------------------
# SPEC grammar
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Spec:
    """One --vary: ``values`` for a grid or list, ``arguments`` for a distribution."""
    name: str
    text: str
    kind: str                               # grid, list, normal, uniform
    values: tuple[float, ...] = ()
    arguments: tuple[float, float] = (math.nan, math.nan)

    @property
    def random(self) -> bool:
        return self.kind in DISTRIBUTIONS

    def describe(self) -> str:
        if self.kind == "grid":
            return f"{len(self.values)} values from {self.values[0]:g} to {self.values[-1]:g}"
        if self.kind == "list":
            return ", ".join(f"{v:g}" for v in self.values)
        a, b = self.arguments
        return f"normal(mean {a:g}, sd {b:g})" if self.kind == "normal" else \
            f"uniform({a:g}, {b:g})"

    def to_dict(self) -> dict:
        data = {"name": self.name, "spec": self.text, "kind": self.kind}
        if self.random:
            data.update(zip(("mean", "sd") if self.kind == "normal" else ("low", "high"),
                            self.arguments))
        else:
            data["values"] = list(self.values)
        return data


def parse_vary(option: str) -> Spec:
    """``NAME=SPEC`` (see the module docstring); ModelError naming the option."""
    name, equals, spec = option.partition("=")
    name, spec = name.strip(), spec.strip()
    if not equals or not name or not spec:
        raise ModelError(f"--vary {option!r}: expected NAME=SPEC, {EXAMPLES}")
    if not _NAME.match(name):
        raise ModelError(f"--vary {option}: {name!r} is not a parameter or gain name")
    return parse_spec(name, spec)


def parse_spec(name: str, spec: str) -> Spec:
    where = f"--vary {name}={spec}"
    call = _CALL.match(spec)
    if call and call.group(1).lower() in DISTRIBUTIONS:
        kind = call.group(1).lower()
        items = _split(where, call.group(2))
        shape = "normal(MEAN,SD)" if kind == "normal" else "uniform(LOW,HIGH)"
        if len(items) != 2:
            raise ModelError(f"{where}: {kind} takes two numbers, {shape}")
        a, b = (_number(where, item) for item in items)
        if kind == "normal" and not b > 0:
            raise ModelError(f"{where}: the standard deviation must be positive, got {b:g}")
        if kind == "uniform" and not b > a:
            raise ModelError(f"{where}: uniform(LOW,HIGH) needs LOW < HIGH, got {a:g} and "
                             f"{b:g}")
        return Spec(name, spec, kind, arguments=(a, b))
    if call and not _known_function(call.group(1)) and "," not in spec.replace(
            call.group(2), ""):
        raise ModelError(f"{where}: unknown distribution {call.group(1)!r}; use "
                         "normal(MEAN,SD) or uniform(LOW,HIGH)")
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3:
            raise ModelError(f"{where}: a grid is FROM:TO:COUNT, e.g. 10:60:11 "
                             "(11 values from 10 to 60)")
        low, high = _number(where, parts[0]), _number(where, parts[1])
        count = parts[2].strip()
        if not re.fullmatch(r"\d{1,9}", count) or not 1 <= int(count) <= MAX_SAMPLES:
            raise ModelError(f"{where}: the grid's COUNT must be a whole number from 1 to "
                             f"{MAX_SAMPLES:,}, got {count!r}")
        count = int(count)
        if count == 1 and low != high:
            raise ModelError(f"{where}: a grid of 1 value from {low:g} to {high:g}; give "
                             "2 or more values, or one value as a list")
        return Spec(name, spec, "grid", tuple(float(v) for v in np.linspace(low, high, count)))
    values = tuple(_number(where, item) for item in _split(where, spec))
    if len(values) > MAX_SAMPLES:
        raise ModelError(f"{where}: {len(values)} values; at most {MAX_SAMPLES:,} samples")
    return Spec(name, spec, "list", values)


def _known_function(name: str) -> bool:
    from ..model.names import FUNCTION_NAMES
    return name in FUNCTION_NAMES


def _split(where: str, text: str) -> list[str]:
    """Comma-separated items at the outer level (commas inside parentheses stay)."""
    items, depth, current = [], 0, []
    for char in text:
        if char == "(":
            depth += 1
        elif char == ")":
            depth -= 1
        if char == "," and depth == 0:
            items.append("".join(current))
            current = []
        else:
            current.append(char)
    items.append("".join(current))
    if any(not item.strip() for item in items):
        raise ModelError(f"{where}: empty value in the list; write numbers separated by "
                         "commas, " + EXAMPLES)
    return [item.strip() for item in items]


def _number(where: str, text: str) -> float:
    """A finite real constant: a number or an expression of numbers and pi."""
    from ..model import expressions

    try:
        value = complex(expressions.parse(text.strip(), {}).evalf())
    except expressions.ExpressionError as err:
        raise ModelError(f"{where}: {err}") from None
    except (TypeError, ValueError, ArithmeticError):
        raise ModelError(f"{where}: {text.strip()!r} is not a number") from None
    if value.imag != 0 or not math.isfinite(value.real):
        raise ModelError(f"{where}: {text.strip()!r} is not a finite real number")
    return float(value.real)


def parse_bound(option: str, text: str) -> tuple[str, float]:
    """``--max METRIC=BOUND`` (value <= BOUND) or ``--min METRIC=BOUND``."""
    metric, equals, bound = text.partition("=")
    metric, bound = metric.strip(), bound.strip()
    if not equals or not metric or not bound:
        raise ModelError(f"{option} {text!r}: expected METRIC=BOUND, e.g. {option} "
                         "peak_T01z=50")
    return metric, _number(f"{option} {text}", bound)


# ----------------------------------------------------------------------------
# the samples
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Design:
    """The samples: ``values`` (N x k, columns in the order of ``specs``)."""
    specs: tuple[Spec, ...]
    values: np.ndarray
    kind: str                      # "grid", "monte-carlo" or "grid x monte-carlo"
    shape: tuple[int, ...]         # grid sizes of the grid and list specs, in order
    draws: int                     # Monte-Carlo draws per grid point (0: none)
    seed: int | None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.specs)

    @property
    def count(self) -> int:
        return len(self.values)


def design(specs: list[Spec], samples: int | None = None, seed: int = 0) -> Design:
    if not specs:
        raise ModelError("nothing to vary: give one or more --vary NAME=SPEC, " + EXAMPLES)
    fixed = [s for s in specs if not s.random]
    random = [s for s in specs if s.random]
    if samples is not None and not random:
        raise ModelError("--samples is the number of draws from a distribution "
                         "(normal(...), uniform(...)); grids and lists run every value once")
    if samples is not None and (isinstance(samples, bool) or samples < 1):
        raise ModelError(f"--samples must be 1 or more, got {samples}")
    draws = (DEFAULT_SAMPLES if samples is None else samples) if random else 0
    shape = tuple(len(s.values) for s in fixed)
    total = math.prod(shape) * max(draws, 1)
    if total > MAX_SAMPLES:
        raise ModelError(f"{total:,} samples ({' x '.join(map(str, shape + ((draws,) if draws else ())))}"
                         f"); at most {MAX_SAMPLES:,}")
    rng = np.random.default_rng(seed)
    drawn = {}
    for s in random:
        a, b = s.arguments
        drawn[s.name] = rng.normal(a, b, draws) if s.kind == "normal" else rng.uniform(a, b, draws)
    points = np.indices(shape).reshape(len(shape), -1).T if shape else np.zeros((1, 0), int)
    repeat = max(draws, 1)
    columns = []
    fixed_index = {s.name: k for k, s in enumerate(fixed)}
    for s in specs:
        if s.random:
            columns.append(np.tile(drawn[s.name], len(points)))
        else:
            column = np.asarray(s.values)[points[:, fixed_index[s.name]]]
            columns.append(np.repeat(column, repeat))
    values = np.column_stack(columns) if columns else np.zeros((total, 0))
    kind = "monte-carlo" if not fixed else "grid" if not random else "grid x monte-carlo"
    return Design(tuple(specs), values, kind, shape, draws, seed if random else None)


# ----------------------------------------------------------------------------
# the plan: everything decided before any sample runs
# ----------------------------------------------------------------------------
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
        columns += [f"final_d{c.name}" for c in info.coordinates]
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
         settle_band: float = SETTLE_BAND, use_cache: bool = False, method: str | None = None,
         rtol: float | None = None, atol: float | None = None, t_end: float | None = None,
         output_step: float | None = None, roundtrip: bool = True,
         roundtrip_tolerance: float | None = None, roundtrip_segment: float | None = None,
         energy_tol: float | None = None, max_condition: float | None = None) -> Plan:
    """Check every option, then derive and compile the robot once with the varied
    names free.  Nothing runs and nothing is written yet."""
    from ..model import robot_from_text
    from ..model.yamlsource import read_text
    from ..numeric import bindable, settings as run_settings

    if command not in COMMANDS:
        raise ModelError(f"--command: {command!r} cannot be swept; choose one of "
                         f"{', '.join(COMMANDS)}")
    specs = [parse_vary(v) for v in vary]
    chosen = design(specs, samples, seed)
    if not (math.isfinite(settle_band) and 0 < settle_band < 1):
        raise ModelError(f"--settle-band must be a fraction between 0 and 1, got "
                         f"{settle_band:g}")
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
    has_motion = robot.trajectory is not None
    from ..numeric import limits

    groups = metric_groups(command, metrics, has_motion, roundtrip, limits.bounds(info) > 0)
    columns = metric_columns(info, command, groups)
    for metric, kind, _ in bounds:
        if metric not in columns:
            listed = ", ".join(columns) or "none"
            raise ModelError(f"--{kind} {metric}: not a metric of this sweep; metrics: "
                             f"{listed}")
    # settings, checked as the services would check them
    if command == "inverse":
        if not has_motion:
            raise ModelError("no trajectory section: inverse dynamics needs a prescribed "
                             "motion (trajectory: kind cycloidal, quintic or expression)",
                             source=source)
        if not robot.actuators:
            raise ModelError("no actuators: inverse dynamics needs one independent actuator "
                             "per coordinate", source=source, path="actuators")
        step = positive("output_step", output_step if output_step is not None
                        else info.simulation.output_step or 0.01)
        duration = float(robot.trajectory.duration)
        if step > duration and not folding.follows["trajectory"]:
            raise SettingError("output_step", f"{step:g} s is longer than the trajectory's "
                                              f"duration {duration:g} s")
        options = {"step": step, "roundtrip": roundtrip}
        if roundtrip_tolerance is not None:
            options["tolerance"] = positive("roundtrip_tolerance", roundtrip_tolerance)
        if roundtrip_segment is not None:
            options["segment"] = positive("roundtrip_segment", roundtrip_segment)
        given = [flag for flag, value in (("--method", method), ("--rtol", rtol),
                                          ("--atol", atol), ("--t-end", t_end),
                                          ("--energy-tol", energy_tol),
                                          ("--max-condition", max_condition))
                 if value is not None]
        if given:
            raise ModelError(f"{given[0]} applies to --command simulate or check, not inverse "
                             "(which runs on the trajectory's own time grid, --dt)")
        settings = run_settings.resolve(info)
        chosen_settings = {k: v for k, v in options.items()}
    else:
        if command == "check" and method is not None:
            raise ModelError("--method applies to --command simulate; check integrates with "
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
                options["energy_tol"] = positive("energy_tol", energy_tol)
            if max_condition is not None:
                options["max_condition"] = positive("max_condition", max_condition)
        chosen_settings = dict(options)
    energy = (settings.rtol, settings.atol, settings.t_end, settings.output_step)
    # derive and compile once
    from ..numeric import cache

    digest = hashlib.sha256(f"{robot.digest}|sweep|{','.join(chosen.names)}".encode()
                            ).hexdigest()
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
    from .. import __version__

    payload = Payload(code, info.to_dict(), source, formulation, command,
                      tuple(sorted(options.items())), groups, tuple(columns), settle_band,
                      energy, __version__,
                      not (folding.follows["trajectory"] or folding.follows["initial"]),
                      tuple(b.name for b in robot.bodies if b.joint.type == "fixed"))
    moment = time.perf_counter()
    bindable.BoundModel(info, code, formulation)       # compiles here: a bad module fails now
    timings["compile"] = time.perf_counter() - moment
    return Plan(info, folding, chosen, payload, tuple(bounds), chosen_settings, timings)


# ----------------------------------------------------------------------------
# one sample (runs on the workers)
# ----------------------------------------------------------------------------
class Runner:
    """A worker's compiled robot and the command to run for each sample."""

    def __init__(self, payload: Payload):
        import scipy.integrate  # noqa: F401  imported here, once, not inside a timed solve

        from .. import __version__
        from ..numeric.bound import BoundModel

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
        from ..services import simulate

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
        from ..services import check

        rtol, atol, t_end, output_step = self.payload.energy
        try:
            report = check.check(self.model, rtol=rtol, atol=atol, t_end=t_end,
                                 output_step=output_step, samples=1, probe_calls=100)
        except NumericalError as err:
            raise NumericalError(f"energy run: {err}") from None
        row["energy_error"] = report.energy_error
        return float(report.timings.get("solve", 0.0))

    def _inverse(self, row: dict) -> float:
        from ..services import inverse

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
        from ..services import check

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
        from ..numeric import limits

        passed = limits.check(self.model.info, t, q, dq, tau)
        row["limits_passed"] = len(passed)
        if passed:
            row["_file_limit"] = passed[0].line()

    def _path(self, row: dict, t: np.ndarray, x: np.ndarray, tau: np.ndarray) -> None:
        n = self.model.n
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
                row[f"final_d{name}"] = float(x[-1, n + i])


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


# ----------------------------------------------------------------------------
# the sweep
# ----------------------------------------------------------------------------
@dataclass
class SweepResult:
    plan: Plan
    rows: list[dict]                       # one per sample, in design order
    executor: str
    workers: int
    address: str
    wall: float                            # s, running the samples
    solve_seconds: float                   # summed over the samples
    sample_seconds: float
    timings: dict = field(default_factory=dict)

    @property
    def counts(self) -> dict:
        counts = {s: 0 for s in STATUSES}
        for row in self.rows:
            counts[row["status"]] += 1
        return counts

    @property
    def samples_per_second(self) -> float:
        return len(self.rows) / self.wall if self.wall > 0 else math.inf


def run(plan: Plan, jobs: int | None = None, scheduler=None,
        on_progress: Callable[[int, int, int], None] | None = None) -> SweepResult:
    """Run every sample, locally on ``jobs`` processes or on Dask (``scheduler``: an
    address or a ``distributed.Client``); ``on_progress(done, failed, total)`` as
    pieces finish."""
    import scipy.integrate  # noqa: F401  forked workers start with it (and the services) loaded

    from ..services import check, inverse, simulate  # noqa: F401

    design = plan.design
    total = design.count
    if isinstance(scheduler, str):             # an address: connect for this run only
        client = executors.connect(scheduler)
        try:
            return run(plan, scheduler=client, on_progress=on_progress)
        finally:
            client.close()
    work_ = executors.Work(setup, work, plan.payload, label="anadyn-sweep")
    workers = (executors.workers(scheduler) if scheduler is not None
               else min(executors.check_jobs(jobs), total))
    samples = [(i, tuple(float(v) for v in design.values[i])) for i in range(total)]
    pieces = [[samples[i] for i in r] for r in executors.chunks(total, max(1, workers))]
    done = [0, 0]

    def finished(index: int, result) -> None:
        if isinstance(result, BaseException):
            done[0] += len(pieces[index])
            done[1] += len(pieces[index])
        else:
            done[0] += len(result)
            done[1] += sum(row["status"] != "ok" for _, row, _, _ in result)
        if on_progress is not None:
            on_progress(done[0], done[1], total)

    ran = executors.run(work_, pieces, jobs=workers, scheduler=scheduler, on_done=finished)
    rows: list = [None] * total
    solve = sample = 0.0
    for piece, result in zip(pieces, ran.results):
        if isinstance(result, BaseException):      # lost for good (Dask gave up)
            why = f"{type(result).__name__}: {result}".splitlines()[0]
            for index, _ in piece:
                rows[index] = {"status": "error", "reason": f"not run ({why})"}
            continue
        for index, row, seconds, whole in result:
            rows[index] = row
            solve += seconds
            sample += whole
    for index, row in enumerate(rows):
        for name, value in zip(design.names, design.values[index]):
            row[name] = float(value)
        _judge_limits(plan, row)
    return SweepResult(plan, rows, ran.executor, ran.workers, ran.address, ran.wall, solve,
                       sample, dict(plan.timings))


def _judge_limits(plan: Plan, row: dict) -> None:
    """within_limits: every --max/--min bound holds and the run passes none of the
    file's joint limits; limit_miss says which do not."""
    file_limit = row.pop("_file_limit", "")
    if not plan.judged:
        return
    if row["status"] != "ok":
        row["within_limits"], row["limit_miss"] = 0, f"not run ({row['status']})"
        return
    misses = [f"file limit {file_limit}"] if file_limit else []
    for metric, kind, bound in plan.bounds:
        value = row.get(metric, math.nan)
        if not (value <= bound if kind == "max" else value >= bound):
            misses.append(f"{metric} {value:.4g} {'>' if kind == 'max' else '<'} {bound:g}")
    row["within_limits"] = int(not misses)
    row["limit_miss"] = "; ".join(misses)


# ----------------------------------------------------------------------------
# reports
# ----------------------------------------------------------------------------
def _cell(value) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


def csv_text(result: SweepResult) -> str:
    """One row per sample; numbers in full double precision, empty where not computed."""
    columns = result.plan.columns
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in result.rows:
        writer.writerow([_cell(row.get(c, math.nan)) for c in columns])
    return buffer.getvalue()


def _numbers(result: SweepResult, column: str, status: str = "ok") -> np.ndarray:
    return np.array([float(r.get(column, math.nan)) if r["status"] == status else math.nan
                     for r in result.rows])


def metric_summary(result: SweepResult) -> dict:
    """Per metric over the ok samples: min, max, mean, sd, percentiles, where min and max are."""
    names = result.plan.design.names
    summary = {}
    for column in result.plan.payload.columns:
        values = _numbers(result, column)
        ok = np.isfinite(values)
        if not ok.any():
            continue
        v = values[ok]
        low, high = int(np.nanargmin(values)), int(np.nanargmax(values))
        summary[column] = {
            "min": float(v.min()), "max": float(v.max()), "mean": float(v.mean()),
            "sd": float(v.std(ddof=1)) if len(v) > 1 else 0.0,
            "p5": float(np.percentile(v, 5)), "p50": float(np.percentile(v, 50)),
            "p95": float(np.percentile(v, 95)),
            "at_min": {n: result.rows[low][n] for n in names},
            "at_max": {n: result.rows[high][n] for n in names}}
    return summary


def capacity(result: SweepResult) -> dict | None:
    """For a one-name grid or list under --max/--min: the largest and smallest values
    from which every value towards the nominal one stays within the limits."""
    plan = result.plan
    if not plan.judged or len(plan.design.specs) != 1 or plan.design.specs[0].random:
        return None
    name = plan.design.names[0]
    pairs = sorted((r[name], bool(r.get("within_limits"))) for r in result.rows)
    values = [v for v, _ in pairs]
    within = [w for _, w in pairs]
    info: dict = {"name": name, "within": [v for v, w in pairs if w],
                  "largest_within": max((v for v, w in pairs if w), default=None),
                  "smallest_within": min((v for v, w in pairs if w), default=None)}
    # contiguous run upward from the smallest value that is within
    if any(within):
        first = within.index(True)
        last = first
        while last + 1 < len(within) and within[last + 1]:
            last += 1
        info["contiguous_from"], info["contiguous_to"] = values[first], values[last]
        if last + 1 < len(values):
            miss = next(r for r in result.rows if r[name] == values[last + 1])
            info["next_value"], info["next_miss"] = values[last + 1], miss.get("limit_miss", "")
    return info


def summary(result: SweepResult) -> dict:
    """Key figures (``sweep.json``)."""
    plan = result.plan
    folding = plan.folding
    counts = result.counts
    data = {
        "robot": plan.robot.name, "source": plan.robot.source,
        "formulation": plan.payload.formulation, "evaluator": "closed-form",
        "command": plan.payload.command,
        "design": plan.design.kind, "shape": list(plan.design.shape),
        "draws": plan.design.draws, "seed": plan.design.seed,
        "vary": [{**s.to_dict(), "type": folding.kinds[s.name],
                  "nominal": folding.nominal[s.name]} for s in plan.design.specs],
        "follows": {k: list(v) for k, v in folding.follows.items() if v},
        "settings": plan.settings, "metrics": list(plan.payload.groups),
        "settle_band": plan.payload.settle_band,
        "columns": plan.columns, "samples": len(result.rows), **counts,
        "failures": _failures(result),
        "bounds": [{"metric": m, "kind": k, "bound": b} for m, k, b in plan.bounds],
        "within_limits": (sum(int(r.get("within_limits", 0)) for r in result.rows)
                          if plan.judged else None),
        "capacity": capacity(result),
        "summary": metric_summary(result),
        "executor": {"kind": result.executor, "workers": result.workers,
                     "address": result.address},
        "wall_s": result.wall, "samples_per_second": result.samples_per_second,
        "solve_s": result.solve_seconds, "sample_s": result.sample_seconds,
        "cost_over_solve": (result.wall * result.workers / result.solve_seconds
                            if result.solve_seconds > 0 else None),
        "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
    }
    if len(result.rows) <= JSON_ROWS:
        data["rows"] = [{c: (None if isinstance(r.get(c), float) and math.isnan(r[c])
                             else r.get(c)) for c in plan.columns} for r in result.rows]
    return data


def _failures(result: SweepResult) -> dict:
    """The first reason of each kind (status), with how many samples share the status."""
    seen = {}
    for row in result.rows:
        if row["status"] != "ok" and row["status"] not in seen:
            seen[row["status"]] = {name: row[name] for name in result.plan.design.names}
            seen[row["status"]]["reason"] = row["reason"]
    return seen


def write(result: SweepResult, out: Path, plot: bool = True) -> list[Path]:
    """sweep.csv, sweep.png (unless ``plot`` is off) and sweep.json in ``out``: rendered
    first, then written with signals held (``progress.uninterrupted``), so an
    interruption leaves all three of this sweep or those there before."""
    from .. import progress

    out = output.prepare_dir(out)
    start = time.perf_counter()
    contents = {out / "sweep.csv": csv_text(result).encode("utf-8")}
    if plot:
        from .sweep_plot import figure
        from ..output import plots

        contents[out / "sweep.png"] = plots.figure_bytes(
            figure(result, capacity(result), headline(result)), "png")
    result.timings["write"] = time.perf_counter() - start
    with progress.uninterrupted():
        for path, data in contents.items():
            output.write_bytes(path, data)
        output.write_json(out / "sweep.json", summary(result))
    return [*contents, out / "sweep.json"]


def headline(result: SweepResult) -> list[str]:
    """The metric columns worth a table: peaks, tracking, settling, energy, final states."""
    columns = result.plan.payload.columns
    keep = [c for c in columns if c.startswith("peak_")]
    keep += [c for c in ("tracking_error", "final_error", "settling_time", "energy_error",
                         "check_passed") if c in columns]
    if len(keep) < 6:
        keep += [c for c in columns if c.startswith("final_") and not c.startswith("final_d")
                 and c != "final_error"][: 6 - len(keep)]
    return keep


def _short(value) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def table(result: SweepResult, rows: int = 20) -> str:
    """All samples (up to ``rows``), else each metric's spread over the samples."""
    from ..output import tables

    plan = result.plan
    names = list(plan.design.names)
    columns = headline(result)
    if len(result.rows) <= rows:
        heads = names + ["status"] + columns + (["limits"] if plan.judged else [])
        body = []
        for r in result.rows:
            line = [_short(r[n]) for n in names] + [r["status"]]
            line += [_short(r.get(c, math.nan)) for c in columns]
            if plan.judged:
                line.append("ok" if r.get("within_limits") else "MISS")
            body.append(line)
        return tables.render(heads, body, min_width=8)
    stats = metric_summary(result)
    heads = ["metric", "min", "p5", "median", "p95", "max", "at max"]
    body = []
    for c in columns:
        s = stats.get(c)
        if s is None:
            continue
        where = ", ".join(f"{n}={_short(v)}" for n, v in s["at_max"].items())
        body.append([c, *(_short(s[k]) for k in ("min", "p5", "p50", "p95", "max")), where])
    return tables.render(heads, body, min_width=8)


def lines(result: SweepResult) -> list[str]:
    """Counts, limits, capacity and speed, one line each."""
    plan = result.plan
    counts = result.counts
    out = [f"{len(result.rows)} samples: " + ", ".join(f"{counts[s]} {s}" for s in STATUSES
                                                        if counts[s] or s == "ok")]
    for status, first in _failures(result).items():
        where = ", ".join(f"{n}={_short(v)}" for n, v in first.items() if n != "reason")
        out.append(f"first {status}: {where}: {first['reason']}")
    if plan.judged:
        limits = ", ".join([f"{m} {'<=' if k == 'max' else '>='} {b:g}" for m, k, b in plan.bounds]
                           + (["the file's joint limits"]
                              if "limits_passed" in plan.payload.columns else []))
        within = sum(int(r.get("within_limits", 0)) for r in result.rows)
        out.append(f"limits {limits}: {within} of {len(result.rows)} samples within")
        cap = capacity(result)
        if cap and cap.get("contiguous_to") is not None:
            text = (f"{cap['name']}: within the limits from {cap['contiguous_from']:g} to "
                    f"{cap['contiguous_to']:g}")
            if cap.get("next_value") is not None:
                text += f"; {cap['next_value']:g} misses ({cap['next_miss']})"
            out.append(text)
        elif cap:
            out.append(f"{cap['name']}: no value within the limits")
    where = (f"{result.workers} local process{'es' if result.workers != 1 else ''}"
             if result.executor == "local processes" else
             "this process" if result.executor == "this process" else
             f"Dask at {result.address} ({result.workers} workers)")
    out.append(f"ran {len(result.rows)} samples in {result.wall:.2f} s on {where}: "
               f"{result.samples_per_second:.1f} samples/s; solves {result.solve_seconds:.2f} s "
               f"in all")
    return out


def dask_setup(worker=None) -> None:
    """``dask worker ADDRESS --preload anadyn_cli.studies.sweep``: import what a
    sweep's pieces run (NumPy, SciPy's integrators, anadyn's numeric model and
    services) when the worker starts, not inside the first piece."""
    import scipy.integrate  # noqa: F401

    from ..numeric import bound  # noqa: F401
    from ..services import check, simulate  # noqa: F401
