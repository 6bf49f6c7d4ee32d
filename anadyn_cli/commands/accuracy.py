"""anadyn accuracy: work-precision study (error against run time, every method)."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import FormulationOpt, Method, OutOpt, RobotArg, out_dir


def accuracy(
    robot: Path = RobotArg,
    methods: str = typer.Option(None, "--methods", help="Comma-separated methods "
                                "[default: auto,odeint,RK45,RK23,DOP853,Radau,BDF,LSODA]."),
    tolerances: str = typer.Option(None, "--tolerances", help="Comma-separated relative "
                                   "tolerances; atol = rtol * 1e-2 [default: 1e-3,...,1e-10]."),
    repeats: int = typer.Option(3, "--repeats", help="Timed runs per setting; the minimum "
                                                     "is reported."),
    max_calls: int = typer.Option(20000, "--max-calls", help="RHS-call budget per run; a run "
                                  "over it is stopped and tighter tolerances of that method "
                                  "skipped."),
    reference_calls: int = typer.Option(500000, "--reference-calls",
                                        help="RHS-call budget per reference attempt."),
    t_end: float = typer.Option(None, "--t-end", help="Horizon in s [default: from the "
                                                      "file, else 10]."),
    dt: float = typer.Option(None, "--dt", help="Output step in s (the error grid) "
                                                "[default: from the file, else 0.01]."),
    formulation: Method = FormulationOpt,
    out: Path = OutOpt,
    plot: bool = typer.Option(True, help="Write accuracy.png."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Work-precision study: error against run time for every method and tolerance.

    Scores each run against a tight reference from a different method, prints
    the table and, for each error level, the fastest setting that reaches it
    and where auto stands; writes accuracy.csv, accuracy.png, accuracy.json.
    """
    import time

    from ..services import accuracy as service
    from ..numeric.build import prepare

    start = time.perf_counter()
    method_list = service.parse_methods(methods)
    tolerance_list = service.parse_tolerances(tolerances)
    info, compiled = prepare(robot, formulation.value, use_cache=cache)
    result = service.study(info, compiled, method_list, tolerance_list, repeats=repeats,
                           max_calls=max_calls, reference_calls=reference_calls,
                           t_end=t_end, output_step=dt)
    written = service.write(result, out_dir(out, info.name), plot=plot)
    typer.echo(f"{info.name}: {result.t_end:g} s, error over {len(result.grid)} rows, "
               f"atol = rtol * {service.ATOL_RATIO:g}, time = min of {result.repeats} runs, "
               f"budget {result.max_calls} RHS calls per run")
    typer.echo(service.table(result))
    typer.echo(f"time: references {result.timings['references']:.2f} s, study "
               f"{result.timings['study']:.2f} s; total {time.perf_counter() - start:.2f} s")
    typer.echo("wrote " + ", ".join(str(p) for p in written))
