"""Direct dynamics under the robot's feedback laws (passive without a controller).

    x = [q, dq],  dx/dt = [dq, M(q)^-1 (F(q, dq) + B(q) tau(t, q, dq))]

integrated from the coordinates' initial values and rates, with rows at
t = k * output_step exactly.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..numeric import integrators
from ..output import files as output
from ..output import plots
from ..numeric.build import compile_robot
from ..numeric.model import CompiledRobot
from ..errors import ModelError, NumericalError, positive
from ..model.info import RobotInfo, Simulation

DEFAULTS = Simulation(t_end=10.0, output_step=0.01, method="auto", rtol=1e-10, atol=1e-12)
#: settings -> the command-line options that set them
OPTIONS = {"t_end": "--t-end", "output_step": "--dt", "rtol": "--rtol", "atol": "--atol"}
MAX_ROWS = 1_000_000     # output rows; the robot file is held to the same (model.loader)


@dataclass
class SimulationResult:
    robot: RobotInfo
    settings: Simulation
    solution: integrators.Solution
    efforts: np.ndarray                   # m x rows
    timings: dict = field(default_factory=dict)
    estimated_error: float | None = None  # accuracy.estimate_error, when asked for
    formulation: str = ""                 # kane or lagrange (named in the plot's title)

    @property
    def t(self) -> np.ndarray:
        return self.solution.t

    @property
    def x(self) -> np.ndarray:
        return self.solution.x


def resolve(robot: RobotInfo, **overrides) -> Simulation:
    """Settings: command line, then the robot file, then anadyn's defaults."""
    chosen = {k: v for k, v in overrides.items() if v is not None}
    for key, option in OPTIONS.items():     # the file's values are checked by the loader
        if key in chosen:
            positive(option, chosen[key])
    settings = replace(DEFAULTS, **{k: v for k, v in robot.simulation.__dict__.items()
                                    if v is not None})
    settings = replace(settings, **chosen)
    if settings.method not in integrators.METHODS:
        raise ModelError(f"unknown method {settings.method!r}; choose one of "
                         f"{', '.join(integrators.METHODS)}")
    if settings.output_step > settings.t_end:
        raise ModelError(f"output step {settings.output_step:g} s is longer than "
                         f"t_end {settings.t_end:g} s")
    if settings.t_end / settings.output_step > MAX_ROWS:
        raise ModelError(f"t_end / output step = {settings.t_end / settings.output_step:.3g} "
                         f"rows; at most {MAX_ROWS:,} (raise --dt or shorten --t-end)")
    return settings


def output_grid(t_end: float, step: float) -> np.ndarray:
    """t = k * step for k = 0, 1, ... up to t_end (inclusive when it is a multiple)."""
    count = int(math.floor(t_end / step * (1 + 1e-12))) + 1
    return np.arange(count) * step


def initial_state(robot: RobotInfo) -> np.ndarray:
    return np.array([float(c.initial) for c in robot.coordinates]
                    + [float(c.rate) for c in robot.coordinates])


def simulate(robot, formulation: str = "kane", compiled: CompiledRobot | None = None,
             timings: dict | None = None, **overrides) -> SimulationResult:
    """Integrate ``robot`` (a Robot, or a RobotInfo with ``compiled``).

    A failure is returned in ``result.solution``, not raised.
    """
    timings = {} if timings is None else timings
    if compiled is None:
        compiled = compile_robot(robot, formulation, timings)
    if not isinstance(robot, RobotInfo):
        robot = RobotInfo.from_robot(robot)
    settings = resolve(robot, **overrides)
    grid = output_grid(settings.t_end, settings.output_step)
    solution = integrators.integrate(compiled, initial_state(robot), grid, settings.method,
                                     settings.rtol, settings.atol)
    timings["solve"] = solution.wall
    n = compiled.n
    q, dq = solution.x[:, :n].T, solution.x[:, n:].T
    efforts = compiled.efforts(solution.t, q, dq) if robot.actuators else np.zeros((0, len(q[0])))
    efforts = np.broadcast_to(efforts, (len(robot.actuators), len(solution.t)))
    return SimulationResult(robot, settings, solution, np.asarray(efforts), timings,
                            formulation=formulation)


def columns(result: SimulationResult) -> tuple[list[str], list[np.ndarray]]:
    """CSV contract: t, coordinates, rates d<name>, actuator efforts."""
    names = [c.name for c in result.robot.coordinates]
    header = ["t", *names, *("d" + n for n in names), *(a.name for a in result.robot.actuators)]
    return header, [result.t, *result.x.T, *result.efforts]


def write(result: SimulationResult, out: Path, plot: bool = True, plot_format: str = "png",
          rates: bool = False) -> list[Path]:
    """simulate.csv (+ the plot, png/svg/pdf, with the rates if asked); on failure only
    simulate.partial.csv, then NumericalError."""
    out = output.prepare_dir(out)
    start = time.perf_counter()
    header, data = columns(result)
    if not result.solution.success:
        partial = out / "simulate.partial.csv"
        output.write_csv(partial, header, data)
        raise NumericalError(f"{result.robot.source}: {result.solution.message}; "
                             f"{len(result.t)} rows before it in {partial}")
    written = [out / "simulate.csv"]
    output.write_csv(written[0], header, data)
    if plot:
        written.append(plots.plot_path(out, "simulate", plot_format))
        plots.write_plot(written[-1], result.t, _panels(result, rates), plot_title(result))
    (out / "simulate.partial.csv").unlink(missing_ok=True)
    result.timings["write"] = time.perf_counter() - start
    written.append(out / "simulate.json")
    output.write_json(written[-1], summary(result))
    return written


def summary(result: SimulationResult) -> dict:
    """Key figures of a run (``simulate.json``)."""
    solution = result.solution
    final = dict(zip(columns(result)[0][1:], (float(v) for v in
                                              np.concatenate([solution.x[-1],
                                                              result.efforts[:, -1]]))))
    return {"robot": result.robot.name, "method": solution.method, "reason": solution.reason,
            "success": solution.success, "rhs_calls": solution.rhs_calls,
            "jacobian_calls": solution.jacobian_calls, "steps": solution.steps,
            "rtol": result.settings.rtol, "atol": result.settings.atol,
            "t_end": float(result.t[-1]), "rows": len(result.t), "final": final,
            "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
            **({} if result.estimated_error is None
               else {"estimated_error": result.estimated_error})}


def plot_title(result: SimulationResult) -> str:
    """Robot, what was integrated, the method and its tolerances."""
    solution, settings = result.solution, result.settings
    method = (f"auto -> {solution.method}" if solution.reason else solution.method)
    formulation = f"{result.formulation}, " if result.formulation else ""
    return (f"{result.robot.name}: direct dynamics, {formulation}{method}, "
            f"rtol {settings.rtol:g}, atol {settings.atol:g}")


def _panels(result: SimulationResult, rates: bool = False) -> list:
    """A panel per coordinate (and rate), efforts grouped by unit."""
    n = len(result.robot.coordinates)
    coordinates = [(c.name, c.unit) for c in result.robot.coordinates]
    panels = plots.state_panels(coordinates, result.x[:, :n], result.x[:, n:] if rates else None)
    if result.robot.actuators:
        panels += plots.effort_panels([(a.name, a.unit) for a in result.robot.actuators],
                                      result.efforts.T)
    return panels


def table(result: SimulationResult, times=range(6)) -> str:
    """The state at t = 0, 1, ..., 5 s (rows of the output grid), like the chapter."""
    names = [c.name for c in result.robot.coordinates]
    header = ["t(s)"] + [h for n in names for h in (n, "d" + n)]
    n = len(names)
    lines = ["  ".join(f"{h:>12}" for h in header)]
    for moment in times:
        k = int(round(moment / result.settings.output_step))
        if k >= len(result.t) or abs(result.t[k] - moment) > 1e-9:
            continue
        x = result.x[k]
        values = [result.t[k]] + [v for i in range(n) for v in (x[i], x[n + i])]
        lines.append("  ".join(f"{v:12.6f}" for v in values))
    return "\n".join(lines)
