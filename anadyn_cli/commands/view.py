"""anadyn view: the robot in 3-D, one HTML page that opens offline in a browser."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from .common import OutOpt, RobotArg, out_dir, time_line


def view(
    robot: Path = RobotArg,
    run: Optional[Path] = typer.Argument(
        None, metavar="[RESULT_CSV]", show_default=False,
        help="A run to play: simulate.csv or inverse.csv of this robot (columns t, the "
             "coordinates, ...). Without it: a slider per coordinate."),
    package_path: Optional[List[Path]] = typer.Option(
        None, "--package-path", metavar="DIR",
        help="A folder holding the ROS packages that the URDF's package:// mesh paths "
             "name (repeatable); ROS_PACKAGE_PATH and pip's example-robot-data are "
             "searched too."),
    out: Path = OutOpt,
    cache: bool = typer.Option(True, help="Reuse the generated kinematics from the cache."),
) -> None:
    """Write view.html: the robot in 3-D with its URDF meshes (or generated shapes),
    playing a run with a time slider, or with a slider per coordinate.

    The page is self-contained (three.js inlined): it opens from the file, offline.
    Drag to turn, wheel to zoom, right-drag to pan; "body frames" shows each body's
    axes; arrows are the run's actuator efforts (red) and the file's loads (purple).
    Also writes view.json.
    """
    import time

    from ..model import load_robot
    from ..model.library import resolve
    from .. import progress
    from ..services import view as service

    start = time.perf_counter()
    with progress.task("reading the robot"):
        model = load_robot(robot)
    played = None
    if run is not None:
        with progress.task(f"reading {run}"):
            played = service.read_run(run, [c.name for c in model.coordinates])
    urdf = resolve(robot)
    with progress.task("building the view"):
        result = service.view(model, played, urdf if urdf.suffix.lower() == ".urdf" else None,
                              package_path or (), use_cache=cache)
    for warning in result.warnings:
        typer.echo(f"anadyn: warning: {warning}", err=True)
    if result.note:
        typer.echo(f"anadyn: note: {result.note}", err=True)
    written = service.write(result, out_dir(out, result.name))
    figures = result.figures()
    typer.echo(f"{result.title}; {figures['shapes']} shapes, {figures['meshes']} meshes "
               f"({figures['triangles']} triangles)"
               + (f", arrows: {', '.join(figures['arrows'])}" if figures["arrows"] else ""))
    typer.echo(time_line(result.timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written)
               + f" ({written[0].stat().st_size / 1e6:.2f} MB); open it in a browser")
