"""anadyn inverse: the efforts that produce the file's prescribed motion."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import (Evaluator, EvaluatorOpt, FontSizeOpt, Formulation, FormulationOpt, OutOpt,
                     PlotFormat, PlotFormatOpt, RobotArg, SizeOpt, TitleOpt, echo_limits,
                     SmoothingOrderOpt, SmoothingWindowOpt, echo_table, figure_style, out_dir,
                     prepared_model, time_line)


def inverse(
    robot: Path = RobotArg,
    formulation: Formulation = FormulationOpt,
    evaluator: Evaluator = EvaluatorOpt,
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
    size: str = SizeOpt,
    title: str = TitleOpt,
    font_size: float = FontSizeOpt,
    rates: bool = typer.Option(False, "--rates", help="Plot the prescribed rates and "
                                                      "accelerations too."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
    motion: Path = typer.Option(
        None, "--motion", help="Measured motion instead of the file's trajectory: a CSV "
                               "with the columns of inverse.csv (t, each coordinate, "
                               "optionally d<q> and dd<q> (a spherical joint's speeds "
                               "wx.. and dwx..); other columns ignored).",
        dir_okay=False),
    smoothing_window: int = SmoothingWindowOpt,
    smoothing_order: int = SmoothingOrderOpt,
    contact_gap: float = typer.Option(
        1e-6, "--contact-gap", help="A robot in contact: the largest gap (m) at which a "
                                    "contact counts as active and may push."),
    contact_resolution: str = typer.Option(
        "least-norm", "--contact-resolution",
        help="A robot in contact: how redundant contact forces are chosen: least-norm, or "
             "cone (the least-norm ones inside the friction cones where those leave them)."),
) -> None:
    """Efforts tau = B^-1 (M ddq - F) along the file's trajectory, or along a measured
    motion (--motion data.csv): inverse.csv, inverse.png.

    Exit 1 when the round trip misses --roundtrip-tol; exit 2 when the file has
    no trajectory and no --motion is given, or its actuators cannot produce an
    arbitrary motion.
    """
    import time

    from .. import progress
    from ..errors import ModelError
    from ..numeric import measured
    from ..output.plots import styled
    from ..services import inverse as service

    start = time.perf_counter()
    timings: dict = {}
    if motion is None and (smoothing_window, smoothing_order) != (None, None):
        raise ModelError("--smoothing-window and --smoothing-order apply to --motion data")
    how = measured.Differentiator.given(smoothing_window, smoothing_order)
    model = prepared_model(robot, formulation, evaluator, cache, timings)
    samples = _samples(robot, model, motion, how)
    with progress.task(f"efforts of {model.name}"
                       + (" and the round trip" if roundtrip else "")):
        result = service.inverse(model, step=dt, roundtrip=roundtrip, tolerance=roundtrip_tol,
                                 segment=roundtrip_segment, timings=timings, measured=samples,
                                 contact_gap=contact_gap,
                                 contact_resolution=contact_resolution)
    with progress.task("writing the results"), styled(figure_style(size, title, font_size)):
        written = service.write(result, out_dir(out, model.name), plot=plot,
                                plot_format=plot_format.value, rates=rates)
    _report(result, model, samples, contact_resolution)
    typer.echo(time_line(result.timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    echo_limits(result.limits, "inverse.json")
    service.raise_if_failed(result)


def _samples(robot: Path, model, motion: Path | None, how):
    """The measured motion of ``--motion`` (None without it); a URDF without one has no
    motion to follow (ModelError)."""
    from ..errors import ModelError
    from ..numeric import measured

    samples = None if motion is None else measured.read_motion(
        motion, model.coordinates, how, speeds=model.speeds, quaternions=model.quaternions)
    if samples is None and robot.suffix.lower() == ".urdf":
        raise ModelError("a URDF has no trajectory: give the motion as measured data "
                         "(--motion data.csv with columns t, "
                         f"{', '.join(model.coordinates[:3])}{', ...' * (model.n > 3)}) or "
                         "write a robot file with 'anadyn import' and add a trajectory: "
                         "section", source=str(robot))
    return samples


def _report(result, model, samples, contact_resolution: str) -> None:
    """The terminal's summary: what ran, the measured motion, the tables, the round trip,
    the constraint and contact forces."""
    from ..numeric.build import describe
    from ..services import inverse as service

    typer.echo(f"{result.robot.name}: {result.kind} motion over {result.duration:g} s "
               f"({describe(result.formulation, result.evaluator)}); efforts at "
               f"{len(result.t)} points in {result.timings['efforts'] * 1e3:.2f} ms")
    if samples is not None:
        typer.echo(f"measured motion: {samples.source}, {len(samples.t)} samples; "
                   f"{samples.describe()}")
    echo_table(service.table(result), "inverse.csv")
    echo_table(service.sizing_table(result), "inverse.json")
    typer.echo(service.roundtrip_line(result))
    if result.constraints is not None:            # closed chains: the constraint forces
        typer.echo("constraint forces: " + ", ".join(
            f"{r.column} up to {abs(result.constraints.multipliers[:, k]).max():.4g}"
            f"{' ' + r.unit if r.unit else ''}" for k, r in enumerate(result.constraints.rows))
            + (f"; {result.note}" if result.note else ""))
    if result.contact is not None:                # robots in contact: the forces needed
        typer.echo(f"contact forces ({contact_resolution}): " + ", ".join(
            f"{name}_fn up to {result.contact.forces[:, c, 0].max():.4g} N"
            for c, name in enumerate(model.contact_names)))
