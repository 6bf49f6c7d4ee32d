"""anadyn inverse: the efforts that produce the file's prescribed motion."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import (Formulation, FormulationOpt, OutOpt, PlotFormat, PlotFormatOpt, RobotArg,
                     out_dir, time_line)


def inverse(
    robot: Path = RobotArg,
    formulation: Formulation = FormulationOpt,
    dt: float = typer.Option(None, "--dt", help="Output step in s (default: the file's "
                                                "simulation.output_step, else 0.01)."),
    out: Path = OutOpt,
    roundtrip: bool = typer.Option(True, "--roundtrip/--no-roundtrip",
                                   help="Integrate the direct dynamics driven by the "
                                        "efforts and check that it follows the motion."),
    roundtrip_tol: float = typer.Option(1e-6, "--roundtrip-tol",
                                        help="Largest allowed tracking error of the round "
                                             "trip, rad or m."),
    roundtrip_segment: float = typer.Option(
        None, "--roundtrip-segment",
        help="Length in s of the round trip's pieces, each started from the prescribed "
             "state (default: short enough that the open-loop growth stays below 1e3; "
             "the whole motion when it is stable)."),
    plot: bool = typer.Option(True, help="Write inverse.png (or .svg, .pdf)."),
    plot_format: PlotFormat = PlotFormatOpt,
    rates: bool = typer.Option(False, "--rates", help="Plot the prescribed rates and "
                                                      "accelerations too."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Efforts tau = B^-1 (M ddq - F) along the file's trajectory: inverse.csv, inverse.png.

    Exit 1 when the round trip misses --roundtrip-tol; exit 2 when the file has
    no trajectory or its actuators cannot produce an arbitrary motion.
    """
    import time

    from ..numeric.build import numeric_model
    from .. import progress
    from ..services import inverse as service

    start = time.perf_counter()
    timings: dict = {}
    with progress.task(f"preparing the {formulation.value} equations"):
        model = numeric_model(robot, formulation.value, use_cache=cache, timings=timings)
    with progress.task(f"efforts of {model.name}"
                       + (" and the round trip" if roundtrip else "")):
        result = service.inverse(model, step=dt, roundtrip=roundtrip, tolerance=roundtrip_tol,
                                 segment=roundtrip_segment, timings=timings)
    with progress.task("writing the results"):
        written = service.write(result, out_dir(out, model.name), plot=plot,
                                plot_format=plot_format.value, rates=rates)
    typer.echo(f"{result.robot.name}: {result.kind} motion over {result.duration:g} s "
               f"({result.formulation}); efforts at {len(result.t)} points in "
               f"{timings['efforts'] * 1e3:.2f} ms")
    typer.echo(service.table(result))
    typer.echo(service.peaks(result))
    typer.echo(service.roundtrip_line(result))
    if result.constraints is not None:            # closed chains: the constraint forces
        typer.echo("constraint forces: " + ", ".join(
            f"{r.column} up to {abs(result.constraints.multipliers[:, k]).max():.4g}"
            f"{' ' + r.unit if r.unit else ''}" for k, r in enumerate(result.constraints.rows))
            + (f"; {result.note}" if result.note else ""))
    typer.echo(time_line(result.timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    from ..numeric.limits import lines
    for line in lines(result.limits):
        typer.echo(f"anadyn: warning: {line}", err=True)
    service.raise_if_failed(result)
