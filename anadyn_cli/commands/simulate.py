"""anadyn simulate: direct dynamics under the feedback laws."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import FormulationOpt, Method, OutOpt, RobotArg, out_dir, time_line


def simulate(
    robot: Path = RobotArg,
    formulation: Method = FormulationOpt,
    method: str = typer.Option(None, help="Integrator: auto, odeint, RK45, RK23, DOP853, "
                                          "Radau, BDF, LSODA [default: from the file, "
                                          "else auto]."),
    rtol: float = typer.Option(None, help="Relative tolerance [default: 1e-10]."),
    atol: float = typer.Option(None, help="Absolute tolerance [default: 1e-12]."),
    t_end: float = typer.Option(None, "--t-end", help="Horizon in s [default: from the "
                                                      "file, else 10]."),
    dt: float = typer.Option(None, "--dt", help="Output step in s [default: from the file, "
                                                "else 0.01]."),
    out: Path = OutOpt,
    plot: bool = typer.Option(True, help="Write simulate.png."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
    estimate: bool = typer.Option(False, "--estimate-error",
                                  help="Also estimate the run's global error by a re-solve "
                                       "at rtol * 1e-3 (not below 1e-13)."),
) -> None:
    """Direct dynamics under the robot's feedback laws: simulate.csv and simulate.png."""
    import time

    from ..services import simulate as service
    from ..numeric.build import prepare

    start = time.perf_counter()
    timings: dict = {}
    info, compiled = prepare(robot, formulation.value, use_cache=cache, timings=timings)
    result = service.simulate(info, formulation.value, compiled=compiled, timings=timings,
                              method=method, rtol=rtol, atol=atol, t_end=t_end,
                              output_step=dt)
    if estimate and result.solution.success:
        from ..services.accuracy import estimate_error
        moment = time.perf_counter()
        result.estimated_error = estimate_error(result, compiled)
        result.timings["estimate"] = time.perf_counter() - moment
    written = service.write(result, out_dir(out, info.name), plot=plot)
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
    typer.echo("wrote " + ", ".join(str(p) for p in written))
