"""anadyn robots: the robot library."""
from __future__ import annotations


def robots() -> None:
    """List the library's robots: name, degrees of freedom, joints, description.

    Any command takes a library name where it takes a robot file (`anadyn
    simulate ur5`); a file of that name in the current folder wins.
    """
    import typer

    from ..model import library

    rows = [(e.name, "?" if e.dof is None else str(e.dof), e.joints, e.description)
            for e in library.listing()]
    header = ("name", "DOF", "joints", "description")
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(3)]
    for row in [header, *rows]:
        typer.echo("  ".join([row[0].ljust(widths[0]), row[1].rjust(widths[1]),
                              row[2].ljust(widths[2]), row[3]]).rstrip())
    typer.echo("library: " + ", ".join(str(f) for f in library.folders()))
