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
) -> None:
    """Print the equations of motion, M(q) ddq = F(q, dq) + B(q) tau.

    --energies and --kane-terms print what the chapter derives them from
    (with --matrices too, every part asked for is printed, in that order).
    """
    from ..model import load_robot
    from .. import progress
    from ..symbolic import render as printout
    from ..symbolic import terms
    from ..symbolic.formulations import derive

    model = load_robot(robot)
    parts = []
    what = "symbolic" if symbolic else "numeric"
    if matrices or not (energies or kane_terms) or kane_terms:
        with progress.task(f"deriving {formulation.value} equations of {model.name}"):
            eom = derive(model, formulation.value, symbolic=symbolic)
    if matrices or not (energies or kane_terms):
        parts.append(printout.render(eom, fmt.value, "matrices" if matrices else "residual"))
    if model.constraints is not None and (matrices or not (energies or kane_terms)):
        from ..symbolic.formulations.constrained import render_constraints
        parts.append(render_constraints(model, fmt.value, symbolic))
    if energies:
        with progress.task(f"energies of {model.name}"):
            parts.append(terms.render_energies(terms.energies(model, symbolic), fmt.value,
                                               model.q, printout.printer))
    if kane_terms:
        with progress.task(f"Kane's terms of {model.name}"):
            parts.append(terms.render_kane_terms(terms.kane_terms(model, eom), fmt.value,
                                                 printout.printer))
    text = "\n".join(parts)
    if fmt.value == "latex":
        text = printout.latex_document(text, f"{model.name}: {formulation.value}, "
                                             f"{what} parameters")
    size = len(text.encode("utf-8"))
    if size > LARGE_OUTPUT:
        typer.echo(f"anadyn: note: the equations of {model.name} take {size / 1e6:.1f} MB "
                   f"({text.count(chr(10)) + 1} lines); redirect them to a file", err=True)
    typer.echo(text)
