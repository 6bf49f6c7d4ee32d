"""anadyn equations: the equations of motion, readable."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import Format, Method, RobotArg


def equations(
    robot: Path = RobotArg,
    method: Method = typer.Option(Method.kane, help="Formulation."),
    fmt: Format = typer.Option(Format.text, "--format", help="Output format."),
    symbolic: bool = typer.Option(False, help="Keep the parameters as symbols."),
    matrices: bool = typer.Option(False, help="Print M, F, B instead of one equation per "
                                              "coordinate."),
) -> None:
    """Print the equations of motion, M(q) ddq = F(q, dq) + B(q) tau."""
    from ..symbolic.render import render
    from ..symbolic.formulations import derive
    from ..model import load_robot

    eom = derive(load_robot(robot), method.value, symbolic=symbolic)
    typer.echo(render(eom, fmt.value, "matrices" if matrices else "residual"))
