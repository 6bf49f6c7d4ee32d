"""anadyn import: a URDF robot as an anadyn robot file."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from .common import FixBaseOpt, InertiaOpt, InertiaPolicy, LockOpt, reading_options


def import_urdf(
    urdf: Path = typer.Argument(..., help="URDF file, or the name of a library robot "
                                          "(`anadyn robots`).", show_default=False),
    output: Path = typer.Option(None, "-o", "--output",
                                help="Write the robot file here [default: standard output]."),
    fix_base: bool = FixBaseOpt,
    inertia: InertiaPolicy = InertiaOpt,
    lock: Optional[List[str]] = LockOpt,
) -> None:
    """Import a URDF robot as an anadyn robot file (YAML, with comments).

    Links become bodies (links on fixed joints folded into the body they are
    fixed to), revolute, continuous and prismatic joints coordinates with one
    actuator each, <mimic> joints coupled displacements; limits, damping and
    friction are kept; --lock holds joints at a value (a reduced robot).  Every
    command also takes the .urdf file directly, with these options.
    """
    from ..model import library
    from ..model.loader import robot_from_text
    from ..model.urdf import import_file
    from ..errors import display_name
    from ..errors import ModelError

    path = library.resolve(urdf)
    shown = display_name(path)
    if path.suffix.lower() != ".urdf":
        raise ModelError("not a URDF file (expected a .urdf file name)", source=shown)
    options = reading_options(fix_base, inertia, lock)
    imported = import_file(path, options.fix_base, options.inertia, options.lock)
    robot = robot_from_text(imported.text, f"{shown} (imported)")   # what is written loads
    for warning in imported.warnings:
        typer.echo(f"anadyn: warning: {warning}", err=True)
    summary = (f"{robot.name}: {len(robot.coordinates)} coordinates, {len(robot.bodies)} "
               f"bodies, {len(robot.actuators)} actuators")
    if output is None:
        typer.echo(imported.text, nl=False)
        typer.echo(f"anadyn: imported {shown} ({summary})", err=True)
        return
    from ..files import write_text

    if output.is_dir():
        raise ModelError("is a folder; give the robot file's name, e.g. -o robot.yaml",
                         source=display_name(output))
    if output.exists() and output.resolve() == path.resolve():
        raise ModelError("is the URDF file itself; give another name, e.g. -o robot.yaml",
                         source=display_name(output))
    write_text(output, imported.text)
    typer.echo(f"wrote {display_name(output)} ({summary}) from {shown}")


import_urdf.cli_name = "import"
