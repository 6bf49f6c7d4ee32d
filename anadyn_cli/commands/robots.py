"""anadyn robots: the robot library."""
from __future__ import annotations


def robots() -> None:
    """List the library: the robots, then the test scenes (stress tests for the
    solvers and example studies); name, degrees of freedom, joints, description.

    Any command takes a library name where it takes a robot file (`anadyn
    simulate ur5`); a file of that name in the current folder wins.
    """
    import typer

    from ..model import library
    from ..output import tables

    folders = library.folders()
    entries = library.listing()
    rows = [(e.name, "?" if e.dof is None else str(e.dof), e.joints, e.description)
            for e in entries]
    header = ("name", "DOF", "joints", "description")
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(3)]
    groups = [("Robots", [r for e, r in zip(entries, rows) if e.path.parent == folders[0]]),
              ("Test scenes: stress tests for the solvers and example studies",
               [r for e, r in zip(entries, rows) if e.path.parent != folders[0]])]
    width = tables.terminal_width()             # a description too long ends in "..."
    for k, (title, members) in enumerate(g for g in groups if g[1]):
        typer.echo(("\n" if k else "") + f"{title} ({len(members)}):")
        for row in [header, *members]:
            line = "  " + "  ".join([row[0].ljust(widths[0]), row[1].rjust(widths[1]),
                                     row[2].ljust(widths[2]), row[3]]).rstrip()
            typer.echo(line if not width or len(line) < width else line[:width - 2] + "\u2026")
    typer.echo("library: " + ", ".join(str(f) for f in folders))
