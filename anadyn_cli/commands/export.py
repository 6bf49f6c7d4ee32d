"""anadyn export: the equations as standalone C, Python, MATLAB/Octave or LaTeX."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from .common import Formulation, OutOpt, RobotArg, time_line


class Language(str, Enum):
    python = "python"
    c = "c"
    matlab = "matlab"
    latex = "latex"
    casadi = "casadi"
    jax = "jax"


def export(
    robot: Path = RobotArg,
    lang: Language = typer.Option(..., "--lang", help="Language of the files: python (NAME.py), "
                                                      "c (NAME.h, NAME.c), matlab (NAME_*.m, "
                                                      "for MATLAB and Octave), latex (NAME.tex), "
                                                      "casadi (NAME_*.casadi: casadi.Function."
                                                      "deserialize), jax (NAME_jax.py)."),
    out: Path = typer.Option(None, "--out", callback=OutOpt.callback,
                             help="Output folder [default: results/NAME/export/LANG/]."),
    symbolic: bool = typer.Option(False, help="Pass the parameters and gains in (a struct or "
                                              "mapping, defaulting to the file's values) "
                                              "instead of folding them in."),
    formulation: Formulation = typer.Option(Formulation.kane, "--formulation",
                                       help="Formulation the equations come from."),
    fragment: bool = typer.Option(False, help="LaTeX only: the body without preamble, to "
                                              "\\input in a document that loads amsmath."),
    derivatives: bool = typer.Option(False, "--derivatives",
                                     help="c and python: also NAME_derivatives.{h,c} or "
                                          "NAME_derivatives.py, the forward and inverse "
                                          "dynamics' derivatives and M^-1, one state or a "
                                          "batch (the numbers of anadyn.derivatives)."),
    parameter: list[str] = typer.Option(None, "--parameter",
                                        help="With --derivatives: also differentiate with "
                                             "respect to this parameter or gain of the robot "
                                             "file (repeat for more)."),
    regressor: bool = typer.Option(False, "--regressor",
                                   help="c and python: also NAME_regressor.{h,c} or "
                                        "NAME_regressor.py, the regressor Y(q, dq, ddq) "
                                        "with M ddq - F = Y pi (n x p, row-major), one "
                                        "state or a batch, and "
                                        "NAME_regressor_parameters.csv, pi's order."),
) -> None:
    """Standalone files for M(q), F(t, q, dq), B(q), the control laws, the state derivative,
    its analytic Jacobian and the inverse dynamics; or a LaTeX document of the equations;
    or (casadi, jax) forward and inverse dynamics and M(q) for CasADi or JAX.
    Written to --out [default: results/NAME/export/LANG/]."""
    import time

    from ..model import load_robot
    from ..services import export as service

    start = time.perf_counter()
    parameters = tuple(parameter or ())
    service.check_options(lang.value, fragment, symbolic, derivatives, parameters, regressor)
    timings: dict = {}
    moment = time.perf_counter()
    model = load_robot(robot)
    timings["load"] = time.perf_counter() - moment
    result = service.export(model, lang.value, formulation.value, symbolic, fragment, timings,
                            derivatives=derivatives, parameters=parameters,
                            regressor=regressor)
    folder = out if out is not None else Path("results") / model.name / "export" / lang.value
    written = service.write(result, folder)
    exported = result.model
    if lang.value in service.TRACED:
        typer.echo(f"{exported.robot_name}: {exported.n} coordinates, {exported.m} efforts, "
                   f"{', '.join(exported.functions)} from the recursive dynamics")
    else:
        typer.echo(f"{exported.robot_name}: {exported.n} coordinates, {exported.m} efforts, "
                   f"{exported.formulation}, "
                   + (f"{len(exported.parameters)} parameters passed in" if exported.symbolic
                      else "parameters folded in"))
    typer.echo(time_line(timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
