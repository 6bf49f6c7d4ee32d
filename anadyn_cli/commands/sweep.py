"""anadyn sweep: one robot, many values of its parameters or gains."""
from __future__ import annotations

from pathlib import Path
from typing import List

import typer

from .common import (AtolOpt, FontSizeOpt, Formulation, OutOpt, RobotArg, RtolOpt, SizeOpt,
                     SymbolicFormulationOpt, TEndOpt, TitleOpt, echo_table, figure_style,
                     out_dir, time_line)


def sweep(
    robot: Path = RobotArg,
    vary: List[str] = typer.Option(..., "--vary", metavar="NAME=SPEC", show_default=False,
                                   help="A parameter or gain and its values: FROM:TO:COUNT "
                                        "(grid), V1,V2,... (list), normal(MEAN,SD) or "
                                        "uniform(LOW,HIGH) (Monte-Carlo). Repeat for more "
                                        "names: grids combine in full."),
    command: str = typer.Option("simulate", "--command",
                                help="What each sample runs: simulate, inverse or check."),
    samples: int = typer.Option(None, "--samples", help="Monte-Carlo draws per distribution "
                                                        "[default: 100]."),
    seed: int = typer.Option(0, "--seed", help="Seed of the Monte-Carlo draws."),
    metrics: str = typer.Option(None, "--metrics",
                                help="Comma-separated metrics: effort, tracking, settling, "
                                     "final, energy, check, calls [default: the command's]."),
    maxima: List[str] = typer.Option([], "--max", metavar="METRIC=BOUND",
                                     help="Limit: a sample is within limits when METRIC <= "
                                          "BOUND, e.g. --max peak_T12y=800 (repeatable)."),
    minima: List[str] = typer.Option([], "--min", metavar="METRIC=BOUND",
                                     help="Limit: METRIC >= BOUND (repeatable)."),
    jobs: int = typer.Option(None, "--jobs", "-j", help="Local worker processes "
                                                        "[default: all cores]."),
    scheduler: str = typer.Option(None, "--scheduler", metavar="ADDRESS",
                                  help="Run on a Dask cluster, e.g. tcp://10.0.0.5:8786 "
                                       "[default: $ANADYN_SCHEDULER, else local]."),
    formulation: Formulation = SymbolicFormulationOpt,
    method: str = typer.Option(None, help="Integrator (simulate) [default: from the file, "
                                          "else auto]."),
    rtol: float = RtolOpt,
    atol: float = AtolOpt,
    t_end: float = TEndOpt,
    dt: float = typer.Option(None, "--dt", help="Output step in s, the grid the metrics are "
                                                "taken on [default: from the file, else 0.01]."),
    settle_band: float = typer.Option(0.02, "--settle-band",
                                      help="Settling band, a fraction of each coordinate's "
                                           "largest deviation from its final value."),
    roundtrip: bool = typer.Option(True, "--roundtrip/--no-roundtrip",
                                   help="Inverse: run the round trip (the tracking error)."),
    roundtrip_tol: float = typer.Option(None, "--roundtrip-tol",
                                        help="Inverse: round-trip tolerance, rad or m."),
    roundtrip_segment: float = typer.Option(None, "--roundtrip-segment",
                                            help="Inverse: round-trip segment length, s."),
    energy_tol: float = typer.Option(None, "--energy-tol", help="Check: energy threshold."),
    max_condition: float = typer.Option(None, "--max-condition",
                                        help="Check: scaled condition-number threshold."),
    out: Path = OutOpt,
    plot: bool = typer.Option(True, help="Write sweep.png."),
    size: str = SizeOpt,
    title: str = TitleOpt,
    font_size: float = FontSizeOpt,
    cache: bool = typer.Option(True, help="Reuse the derived equations from the cache."),
) -> None:
    """Run ROBOT for many values of its parameters or gains, derived and compiled once.

    Writes sweep.csv (one row per sample: the varied names, status, reason,
    metrics), sweep.json and sweep.png (metrics against one name, a heat map
    for two, histograms for Monte-Carlo).  Failed samples are rows, not
    errors: the exit code is 0 once the sweep has run.
    """
    import time

    start = time.perf_counter()
    address = _address(scheduler, jobs)
    settings = dict(samples=samples, seed=seed, metrics=metrics, maxima=maxima, minima=minima,
                    settle_band=settle_band, use_cache=cache, method=method, rtol=rtol,
                    atol=atol, t_end=t_end, output_step=dt, roundtrip=roundtrip,
                    roundtrip_tolerance=roundtrip_tol, roundtrip_segment=roundtrip_segment,
                    energy_tol=energy_tol, max_condition=max_condition)
    plan, result = _run(robot, vary, command, formulation, settings, address, jobs)
    _report(plan, result, out, plot, figure_style(size, title, font_size), start)


def _address(scheduler: str | None, jobs: int | None) -> str | None:
    """The Dask scheduler's address (None: local workers, ``jobs`` of them, checked)."""
    from ..studies import executors

    address = executors.scheduler_address(scheduler)
    if address is None:
        executors.check_jobs(jobs)
    elif jobs is not None:
        from ..errors import ModelError
        raise ModelError("--jobs is for local runs; a Dask cluster has its own workers "
                         "(drop --jobs or --scheduler)")
    return address


def _run(robot: Path, vary: List[str], command: str, formulation: Formulation, settings: dict,
         address: str | None, jobs: int | None):
    """(plan, result): the design checked first, the robot derived with the varied names
    free, the samples run locally or on the Dask cluster at ``address``."""
    import contextlib

    from .. import progress
    from ..studies import executors
    from ..studies import sweep as service

    service.design([service.parse_vary(v) for v in vary], settings["samples"],
                   settings["seed"])   # fail fast
    with contextlib.ExitStack() as stack:
        client = None
        if address is not None:
            with progress.task(f"connecting to the Dask scheduler at {address}"):
                client = executors.connect(address)
            stack.callback(client.close)
        with progress.task(f"deriving {robot.name} with "
                           f"{', '.join(v.partition('=')[0] for v in vary)} free"):
            plan = service.plan(robot, vary, command.strip().lower(), formulation.value,
                                **settings)
        typer.echo(f"{plan.robot.name}: {plan.payload.command} for {plan.design.count} "
                   f"samples ({plan.design.kind}) of {plan.folding.describe()}")
        where = f" on Dask at {address}" if address else ""
        with progress.task(f"sweep: {plan.payload.command}{where}",
                           total=plan.design.count) as step:
            def advance(done: int, failed: int, total: int) -> None:
                step.advance(done - step.completed, detail=f"{failed} not ok" if failed else "")

            result = service.run(plan, jobs=jobs, scheduler=client, on_progress=advance)
    return plan, result


def _report(plan, result, out: Path | None, plot: bool, style, start: float) -> None:
    """Write the files (in the figure ``style``) and print the table, the summary, the
    timings and what was written."""
    from ..output.plots import styled
    from ..studies import sweep as service

    with styled(style):
        written = service.write(result, out_dir(out, plan.robot.name), plot=plot)
    echo_table(service.table(result), "sweep.csv")
    for line in service.lines(result):
        typer.echo(line)
    typer.echo(time_line({k: v for k, v in result.timings.items()
                          if k in ("load", "cache", "derive", "compile", "write")}, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
