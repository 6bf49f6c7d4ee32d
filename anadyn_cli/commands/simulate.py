"""anadyn simulate: direct dynamics under the feedback laws."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import (AtolOpt, DtOpt, Evaluator, EvaluatorOpt, FontSizeOpt, Formulation,
                     FormulationOpt, MethodOpt, OutOpt, PlotFormat, PlotFormatOpt, RobotArg,
                     RtolOpt, SizeOpt, TEndOpt, TitleOpt, echo_limits, echo_table,
                     figure_style, integrator_name, out_dir, prepared_model, time_line)


def simulate(
    robot: Path = RobotArg,
    formulation: Formulation = FormulationOpt,
    evaluator: Evaluator = EvaluatorOpt,
    method: str = MethodOpt,
    rtol: float = RtolOpt,
    atol: float = AtolOpt,
    t_end: float = TEndOpt,
    dt: float = DtOpt,
    out: Path = OutOpt,
    plot: bool = typer.Option(True, help="Write simulate.png (or .svg, .pdf)."),
    plot_format: PlotFormat = PlotFormatOpt,
    size: str = SizeOpt,
    title: str = TitleOpt,
    font_size: float = FontSizeOpt,
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

    from .. import progress
    from ..output.plots import styled
    from ..services import simulate as service

    start = time.perf_counter()
    timings: dict = {}
    model = prepared_model(robot, formulation, evaluator, cache, timings)
    info = model.info
    with progress.task(f"integrating {info.name}" + (" and estimating the error"
                                                     if estimate else "")):
        result = service.simulate(model, method=integrator_name(method), rtol=rtol, atol=atol,
                                  t_end=t_end, output_step=dt, estimate_error=estimate,
                                  timings=timings)
    with progress.task("writing the results"), styled(figure_style(size, title, font_size)):
        written = service.write(result, out_dir(out, info.name), plot=plot,
                                plot_format=plot_format.value, rates=rates)
    note = ""
    if animate:
        from .animate import animate_run, force_columns
        n = len(info.coordinates)
        movie, note = animate_run(robot, result.t, result.x[:, :n], f"{info.name}: simulate",
                                  out_dir(out, info.name), cache=cache, timings=result.timings,
                                  computation={"formulation": result.formulation,
                                               "evaluator": result.evaluator},
                                  columns=force_columns(result))
        written = written[:-1] + movie[:-1] + written[-1:] + movie[-1:]
    solution = result.solution
    echo_table(service.table(result), "simulate.csv")
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
    echo_limits(result.limits, "simulate.json")
