"""anadyn accuracy: work-precision study (error against run time, every method)."""
from __future__ import annotations

import math
from pathlib import Path

import typer

from ..errors import ModelError
from .common import (Evaluator, EvaluatorOpt, FontSizeOpt, Formulation, FormulationOpt, OutOpt,
                     PlotFormat, PlotFormatOpt, RobotArg, SizeOpt, TEndOpt, TitleOpt,
                     figure_style, out_dir, prepared_model)


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
    t_end: float = TEndOpt,
    dt: float = typer.Option(None, "--dt", help="Output step in s (the error grid) "
                                                "[default: from the file, else 0.01]."),
    formulation: Formulation = FormulationOpt,
    evaluator: Evaluator = EvaluatorOpt,
    out: Path = OutOpt,
    plot: bool = typer.Option(True, help="Write accuracy.png (or .svg, .pdf)."),
    plot_format: PlotFormat = PlotFormatOpt,
    size: str = SizeOpt,
    title: str = TitleOpt,
    font_size: float = FontSizeOpt,
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Work-precision study: error against run time for every method and tolerance.

    Scores each run against a tight reference from a different method, prints
    the table and, for each error level, the fastest setting that reaches it
    and where auto stands; writes accuracy.csv, accuracy.png, accuracy.json.
    """
    import time

    from .. import progress
    from ..output import tables
    from ..output.plots import styled
    from ..services import accuracy as service

    start = time.perf_counter()
    method_list = parse_methods(methods)
    tolerance_list = parse_tolerances(tolerances)
    model = prepared_model(robot, formulation, evaluator, cache)
    info = model.info
    with progress.task(f"work-precision study of {info.name} "
                       f"({len(method_list)} methods x {len(tolerance_list)} tolerances)") as step:
        step.note("references (two tight runs)")
        result = service.study(model, method_list, tolerance_list, repeats=repeats,
                               max_calls=max_calls, reference_calls=reference_calls,
                               t_end=t_end, output_step=dt,
                               progress=lambda method, rtol: step.note(f"{method} rtol "
                                                                       f"{rtol:.0e}"))
    with styled(figure_style(size, title, font_size)):
        written = service.write(result, out_dir(out, info.name), plot=plot,
                                plot_format=plot_format.value)
    typer.echo(f"{info.name}: {result.t_end:g} s, error over {len(result.grid)} rows, "
               f"atol = rtol * {service.ATOL_RATIO:g}, time = min of {result.repeats} runs, "
               f"budget {result.max_calls} RHS calls per run")
    screen = tables.terminal_lines()
    typer.echo(service.table(result, header_every=screen - 3 if screen else None))
    typer.echo(f"time: references {result.timings['references']:.2f} s, study "
               f"{result.timings['study']:.2f} s; total {time.perf_counter() - start:.2f} s")
    typer.echo("wrote " + ", ".join(str(p) for p in written))


def parse_methods(text: str | None) -> tuple[str, ...]:
    """--methods: comma-separated integrator names (any case)."""
    from ..numeric.integrators import METHODS

    if not text:
        return METHODS
    methods = tuple(m.strip() for m in text.replace(" ", ",").split(",") if m.strip())
    by_name = {m.lower(): m for m in METHODS}
    for m in methods:
        if m.lower() not in by_name:
            raise ModelError(f"--methods: unknown method {m!r}; choose from "
                             f"{', '.join(METHODS)}")
    return tuple(dict.fromkeys(by_name[m.lower()] for m in methods))


def parse_tolerances(text: str | None) -> tuple[float, ...]:
    """--tolerances: comma-separated relative tolerances in 1e-14 .. 1."""
    from ..services.accuracy import TOLERANCES

    if not text:
        return TOLERANCES
    values = []
    for part in text.replace(" ", ",").split(","):
        if not part.strip():
            continue
        try:
            value = float(part)
        except ValueError:
            raise ModelError(f"--tolerances: {part.strip()!r} is not a number") from None
        if not (math.isfinite(value) and 1e-14 <= value < 1):
            raise ModelError(f"--tolerances: {part.strip()} is outside 1e-14 .. 1")
        values.append(value)
    if not values:
        raise ModelError("--tolerances: give at least one relative tolerance")
    return tuple(sorted(set(values), reverse=True))
