"""anadyn import: a URDF or MJCF (MuJoCo) robot as an anadyn robot file."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from .common import (ContactsOpt, FixBaseOpt, FloatingBaseOpt, InertiaOpt, InertiaPolicy,
                     LockOpt, reading_options)


def import_urdf(
    urdf: Path = typer.Argument(..., help="URDF (.urdf) or MJCF (MuJoCo .xml) file, or the "
                                          "name of a library robot (`anadyn robots`).",
                                show_default=False),
    output: Path = typer.Option(None, "-o", "--output",
                                help="Write the robot file here [default: standard output]."),
    fix_base: bool = FixBaseOpt,
    floating_base: bool = FloatingBaseOpt,
    inertia: InertiaPolicy = InertiaOpt,
    lock: Optional[List[str]] = LockOpt,
    contacts: bool = ContactsOpt,
) -> None:
    """Import a URDF or MJCF (MuJoCo XML) robot as an anadyn robot file (YAML, with
    comments).

    Links become bodies (links on fixed joints folded into the body they are
    fixed to), revolute, continuous and prismatic joints coordinates with one
    actuator each, floating and planar joints anadyn's of the same names (no
    actuator), <mimic> joints coupled displacements; limits, damping and friction
    are kept; --lock holds joints at a value (a reduced robot); --floating-base
    frees the root link, which a URDF fixes to the world.  MJCF:
    hinge and slide joints, geom inertias, defaults, armature, springs and
    motor/position/velocity actuators, with --contacts the contact geoms against
    the world's planes (docs: how-to/mjcf).  Every command also
    takes the .urdf or .xml file directly, with these options.
    """
    from ..model import library
    from ..model.loader import robot_from_text
    from ..errors import display_name
    from ..errors import ModelError

    path = library.resolve(urdf)
    shown = display_name(path)
    if not library.imports(path):
        raise ModelError("not a URDF or MJCF file (expected a .urdf or .xml file name)",
                         source=shown)
    options = reading_options(fix_base, inertia, lock, floating_base, contacts)
    imported = library.import_robot(path, options)
    robot = robot_from_text(imported.text, f"{shown} (imported)")   # what is written loads
    for warning in imported.warnings:
        typer.echo(f"anadyn: warning: {warning}", err=True)
    freedom = len(robot.speeds) - (robot.constraints.count if robot.constraints else 0)
    summary = (f"{robot.name}: {len(robot.coordinates)} coordinates, {freedom} "
               f"degrees of freedom, {len(robot.bodies)} bodies, {len(robot.actuators)} "
               "actuators")
    if output is None:
        typer.echo(imported.text, nl=False)
        typer.echo(f"anadyn: imported {shown} ({summary})", err=True)
        return
    from ..files import write_text

    if output.is_dir():
        raise ModelError("is a folder; give the robot file's name, e.g. -o robot.yaml",
                         source=display_name(output))
    if output.exists() and output.resolve() == path.resolve():
        raise ModelError("is the imported file itself; give another name, e.g. -o robot.yaml",
                         source=display_name(output))
    write_text(output, imported.text)
    typer.echo(f"wrote {display_name(output)} ({summary}) from {shown}")


import_urdf.cli_name = "import"
