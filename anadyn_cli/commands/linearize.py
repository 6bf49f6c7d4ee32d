"""anadyn linearize: state-space matrices, modes and controllability at an operating point."""
from __future__ import annotations

from pathlib import Path

import typer

from enum import Enum

from .common import (Evaluator, EvaluatorOpt, Formulation, FormulationOpt, OutOpt, RobotArg,
                     echo_table, out_dir, time_line)


class Efforts(str, Enum):
    auto = "auto"
    controller = "controller"
    holding = "holding"
    zero = "zero"


def linearize(
    robot: Path = RobotArg,
    at: str = typer.Option(None, "--at", help="Operating point, name=value items separated by "
                                              "commas: t, coordinates (q1=pi/6), rates "
                                              "(dq1=0), efforts (T01z=3), or vectors "
                                              "q=[...], dq=[...], tau=[...] [default: the "
                                              "file's initial state at t = 0; efforts from "
                                              "the controller, else static holding efforts]."),
    equilibrium: bool = typer.Option(False, help="First find the static equilibrium (at rest) "
                                                 "nearest the given state, under the "
                                                 "controller, the given efforts, or none."),
    symbolic: bool = typer.Option(False, help="Also give the matrices with the parameters "
                                              "and gains as symbols."),
    efforts: Efforts = typer.Option(Efforts.auto, "--efforts",
                                help="Efforts at the point unless --at gives them: auto "
                                     "(the controller's, else static holding efforts), "
                                     "controller, holding (e.g. about a set point, for a "
                                     "controller design), zero."),
    formulation: Formulation = FormulationOpt,
    evaluator: Evaluator = EvaluatorOpt,
    out: Path = OutOpt,
    cache: bool = typer.Option(True, help="Reuse a URDF's import, and what an earlier run "
                                          "read of the robot, from the cache."),
) -> None:
    """A = d(dx/dt)/dx and B = d(dx/dt)/d(tau) about an operating point, the closed-loop A
    under the file's control laws, eigenvalues with natural frequencies and damping ratios,
    and the controllability rank: linearize.json and linearize_*.csv."""
    import time

    from ..model import Robot
    from ..numeric.build import robot_of
    from ..services import linearize as service

    start = time.perf_counter()
    timings: dict = {}
    plain = not symbolic and formulation is None and evaluator in (None, Evaluator.recursive)
    model = robot_of(robot, cache, service.serves if plain else None)
    if not isinstance(model, Robot):             # the kernel's record of an earlier run
        model = service.RecordedRobot(model)
    timings["load"] = time.perf_counter() - start
    service.check_efforts(model, efforts.value, service.parse_at(at, model))   # before any work
    result = service.linearize(model, None if formulation is None else formulation.value, at,
                               equilibrium, symbolic, timings, efforts=efforts.value,
                               evaluator=None if evaluator is None else evaluator.value,
                               use_cache=cache)
    written = service.write(result, out_dir(out, model.name))
    echo_table(service.report(result), "linearize_*.csv")
    typer.echo(time_line(timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
