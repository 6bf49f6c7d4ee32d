"""anadyn simulate: direct dynamics under the feedback laws."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import (AtolOpt, DtOpt, Formulation, FormulationOpt, MethodOpt, OutOpt,
                     PlotFormat, PlotFormatOpt, RobotArg, RtolOpt, TEndOpt, integrator_name,
                     out_dir, time_line)


def simulate(
    robot: Path = RobotArg,
    formulation: Formulation = FormulationOpt,
    method: str = MethodOpt,
    rtol: float = RtolOpt,
    atol: float = AtolOpt,
    t_end: float = TEndOpt,
    dt: float = DtOpt,
    out: Path = OutOpt,
    plot: bool = typer.Option(True, help="Write simulate.png (or .svg, .pdf)."),
    plot_format: PlotFormat = PlotFormatOpt,
    rates: bool = typer.Option(False, "--rates", help="Plot the rates too (a panel each)."),
    animate: bool = typer.Option(False, "--animate",
                                 help="Also write animate.gif (and animate.mp4 when ffmpeg "
                                      "is on the PATH) of the motion."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
    estimate: bool = typer.Option(False, "--estimate-error",
                                  help="Also estimate the run's global error by a re-solve "
                                       "at rtol * 1e-3 (not below 1e-13)."),
) -> None:
    """Direct dynamics under the robot's feedback laws: simulate.csv and simulate.png."""
    import time

    from ..numeric.build import numeric_model
    from .. import progress
    from ..services import simulate as service

    start = time.perf_counter()
    timings: dict = {}
    with progress.task(f"preparing the {formulation.value} equations"):
        model = numeric_model(robot, formulation.value, use_cache=cache, timings=timings)
    info = model.info
    with progress.task(f"integrating {info.name}" + (" and estimating the error"
                                                     if estimate else "")):
        result = service.simulate(model, method=integrator_name(method), rtol=rtol, atol=atol,
                                  t_end=t_end, output_step=dt, estimate_error=estimate,
                                  timings=timings)
    with progress.task("writing the results"):
        written = service.write(result, out_dir(out, info.name), plot=plot,
                                plot_format=plot_format.value, rates=rates)
    note = ""
    if animate:
        from .animate import animate_run
        movie, note = animate_run(result, robot, out_dir(out, info.name), cache=cache,
                                  timings=result.timings)
        written = written[:-1] + movie[:-1] + written[-1:] + movie[-1:]
    solution = result.solution
    typer.echo(service.table(result))
    if solution.reason:
        typer.echo(f"method: auto -> {solution.method}: {solution.reason}")
    else:
        typer.echo(f"method: {solution.method}")
    typer.echo(f"rhs calls {solution.rhs_calls}, jacobian calls {solution.jacobian_calls}, "
               f"steps {solution.steps}, rtol {result.settings.rtol:g}, "
               f"atol {result.settings.atol:g}")
    typer.echo(time_line(result.timings, start)
               + ("" if result.estimated_error is None
                  else f"; estimated error {result.estimated_error:.2e}"))
    if result.constraints is not None:
        typer.echo(result.constraints.line())
    if note:
        typer.echo(f"animation: {note}")
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    from ..numeric.limits import lines
    for line in lines(result.limits):
        typer.echo(f"anadyn: warning: {line}", err=True)
