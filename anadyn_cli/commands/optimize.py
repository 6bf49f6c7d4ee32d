"""anadyn optimize: a rest-to-rest motion of least effort or least time under the limits."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from .common import OutOpt, RobotArg, out_dir, time_line


class Objective(str, Enum):
    effort = "effort"
    time = "time"


def _pose(text: str | None, setting: str) -> dict | None:
    """``q1=0.5,q2=-1`` as {name: float} (numbers only: nothing is evaluated)."""
    from ..errors import SettingError

    if text is None:
        return None
    pose = {}
    for item in text.split(","):
        name, _, value = item.partition("=")
        try:
            pose[name.strip()] = float(value)
        except ValueError:
            raise SettingError(setting, f"takes NAME=NUMBER pairs separated by commas, got "
                                        f"{item.strip()!r}") from None
    return pose


def optimize(
    robot: Path = RobotArg,
    to: str = typer.Option(None, "--to", help="Goal pose, e.g. q1=0.5,q2=1 (coordinates left "
                                              "out: their start value) [default: the file's "
                                              "trajectory 'to']."),
    start: str = typer.Option(None, "--from", help="Start pose, same form [default: the "
                                                   "trajectory's 'from', else the initial "
                                                   "values]."),
    minimize: Objective = typer.Option(Objective.effort, "--minimize",
                                       help="effort (integral of the squared efforts over "
                                            "--duration) or time (needs effort limits)."),
    duration: float = typer.Option(None, "--duration",
                                   help="Duration in s (time: the first guess) [default: the "
                                        "file's trajectory duration]."),
    intervals: int = typer.Option(20, "--intervals", help="Collocation intervals (1 to 200)."),
    out: Path = OutOpt,
) -> None:
    """Optimal rest-to-rest motion by Hermite-Simpson collocation with IPOPT (needs CasADi:
    pip install 'anadyn[casadi]') under the file's position, rate and effort limits.
    Writes optimize.csv (t, q, dq, ddq, efforts at the knots and midpoints: `anadyn
    inverse ROBOT --motion optimize.csv` replays it), trajectory.yaml (the motion as a
    robot file's trajectory section, kind spline), for a YAML robot NAME_optimized.yaml
    (the file with that trajectory) and optimize.json (status, defect, limit margins) to
    --out/optimize [default: results/NAME/optimize/]."""
    import time

    from ..api import optimize as run
    from ..model import load_robot
    from ..services import optimize as service

    begin = time.perf_counter()
    goal, first = _pose(to, "goal"), _pose(start, "start")
    model = load_robot(robot)
    timings = {"load": time.perf_counter() - begin}
    result = run(model, goal, first, duration, minimize.value, intervals)
    timings["optimize"] = time.perf_counter() - begin - timings["load"]
    written = service.write(result, out_dir(out, model.name) / "optimize", model.source)
    typer.echo(f"{model.name}: {result.status} after {result.iterations} iterations; "
               f"{result.objective} {result.cost:.6g}, duration {result.duration:.6g} s, "
               f"defect {result.defect:.3g}, goal error {result.goal_error:.3g}")
    for margin in result.margins:
        typer.echo(f"  {margin['name']} {margin['quantity']}: margin {margin['margin']:.4g} "
                   f"at t = {margin['t']:.4g} s")
    typer.echo(time_line(timings, begin))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    service.raise_if_failed(result)
