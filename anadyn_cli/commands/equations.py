"""anadyn equations: the equations of motion, readable."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import Format, Formulation, RobotArg


#: bytes of printout above which the size is said first (on stderr)
LARGE_OUTPUT = 1_000_000


def equations(
    robot: Path = RobotArg,
    formulation: Formulation = typer.Option(Formulation.kane, "--formulation",
                                            case_sensitive=False,
                                            help="Formulation: kane or lagrange."),
    fmt: Format = typer.Option(Format.text, "--format", case_sensitive=False,
                               help="Output format; latex prints a document that compiles "
                                    "as it is (pdflatex)."),
    symbolic: bool = typer.Option(False, help="Keep the parameters as symbols."),
    matrices: bool = typer.Option(False, help="Print M, F, B instead of one equation per "
                                              "coordinate."),
    energies: bool = typer.Option(False, "--energies",
                                  help="Print the kinetic and potential energy of each body "
                                       "and in total (T_i, V_i, T, V) instead."),
    kane_terms: bool = typer.Option(False, "--kane-terms",
                                    help="Print Kane's generalized active and inertia forces "
                                         "per coordinate (Q_r = Fr, Kin_r = Fr*; "
                                         "Q_r + Kin_r = 0) instead."),
    base_parameters: bool = typer.Option(False, "--base-parameters",
                                         help="Print the base parameters (identifiable "
                                              "combinations of the inertial and drive "
                                              "parameters) instead."),
) -> None:
    """Print the equations of motion, M(q) ddq = F(q, dq) + B(q) tau.

    --energies and --kane-terms print what the chapter derives them from
    (with --matrices too, every part asked for is printed, in that order).
    """
    from ..api import equations as text_of
    from ..model import load_robot

    model = load_robot(robot)
    if base_parameters:
        from ..api import base_parameters as base

        typer.echo(base(model).text(model.name))
        return
    text = text_of(model, formulation.value, fmt.value, symbolic, matrices, energies, kane_terms)
    size = len(text.encode("utf-8"))
    if size > LARGE_OUTPUT:
        typer.echo(f"anadyn: note: the equations of {model.name} take {size / 1e6:.1f} MB "
                   f"({text.count(chr(10)) + 1} lines); redirect them to a file", err=True)
    typer.echo(text)
