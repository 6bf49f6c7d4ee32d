"""anadyn show: the robot drawn at its initial pose (or another)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from .common import (FontSizeOpt, OutOpt, PlotFormat, PlotFormatOpt, RobotArg, SizeOpt, TitleOpt,
                     figure_style, out_dir, time_line)


def show(
    robot: Path = RobotArg,
    at: Optional[List[str]] = typer.Option(
        None, "--at", metavar="COORDINATE=VALUE",
        help="Pose to draw instead of the initial one: q1=0.3, q2=pi/4, q1=30deg (rad or m "
             "unless deg); repeat it or separate with commas."),
    out: Path = OutOpt,
    plot_format: PlotFormat = PlotFormatOpt,
    size: str = SizeOpt,
    title: str = TitleOpt,
    font_size: float = FontSizeOpt,
    cache: bool = typer.Option(True, help="Reuse the generated kinematics from the cache."),
) -> None:
    """Draw the robot: links, joints and their axes, body frames, centres of mass, names.

    A 3-D view and the front, side and top views (up against gravity), or, for a
    planar robot, the plane it moves in alone; from the same kinematics as the
    dynamics.  Writes show.png (or .svg, .pdf) and
    show.json (every drawn point, in world axes).
    """
    import time

    from ..numeric.frames import frames
    from .. import progress
    from ..output.plots import styled
    from ..services import show as service

    start = time.perf_counter()
    with progress.task("forward kinematics"):
        kinematics = frames(robot, use_cache=cache)
    drawing = service.draw(kinematics, at)
    with styled(figure_style(size, title, font_size)):
        written = service.write_drawing(drawing, out_dir(out, kinematics.skeleton.name),
                                        plot_format.value)
    typer.echo(drawing.title())
    for name, body in service.points(drawing).items():
        ends = "; ".join(_xyz(p) for p in body["link_end"])
        typer.echo(f"  {name}: joint {_xyz(body['joint'])} ({body['joint_type']}"
                   f"{', ' + body['displacement'] if body['displacement'] else ''}), "
                   f"centre of mass {_xyz(body['com'])}, link to {ends}")
    typer.echo(time_line(drawing.timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))


def _xyz(point) -> str:
    return "(" + ", ".join(f"{v + 0.0:.4g}" for v in point) + ") m"
