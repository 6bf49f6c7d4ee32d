"""anadyn check: stability report along the simulated path."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import (AtolOpt, DtOpt, Evaluator, EvaluatorOpt, Formulation, FormulationOpt,
                     OutOpt, RobotArg, RtolOpt, TEndOpt, out_dir, prepared_model, time_line)


def check(
    robot: Path = RobotArg,
    rtol: float = RtolOpt,
    atol: float = AtolOpt,
    t_end: float = TEndOpt,
    dt: float = DtOpt,
    max_condition: float = typer.Option(1e8, "--max-condition",
                                        help="Threshold on the mass matrix's condition "
                                             "number after diagonal scaling."),
    energy_tol: float = typer.Option(1e-6, "--energy-tol",
                                     help="Threshold on max |T + V - W - E0| over the "
                                          "energy scale."),
    samples: int = typer.Option(200, "--samples", help="Points along the path where the "
                                                       "Jacobian's eigenvalues are taken."),
    formulation: Formulation = FormulationOpt,
    evaluator: Evaluator = EvaluatorOpt,
    out: Path = OutOpt,
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Stability report: eigenvalues and stiffness, mass-matrix conditioning, energy balance.

    Exit 1 when the energy balance or the mass matrix's conditioning misses
    its threshold; stiffness is reported as a warning.  Writes check.csv and
    check.json.
    """
    import time

    from .. import progress
    from ..services import check as service

    start = time.perf_counter()
    timings: dict = {}                 # the cache's, and an earlier background build's cost
    model = prepared_model(robot, formulation, evaluator, cache, timings)
    info = model.info
    with progress.task(f"checking {info.name}: energy balance, eigenvalues, explicit probe, "
                       "conditioning"):
        report = service.check(model, rtol=rtol, atol=atol, t_end=t_end,
                               output_step=dt, samples=samples, max_condition=max_condition,
                               energy_tol=energy_tol)
    report.timings = {**timings, **report.timings}
    written = service.write(report, out_dir(out, info.name))
    typer.echo(service.text(report))
    typer.echo(time_line(report.timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    service.raise_if_failed(report)
