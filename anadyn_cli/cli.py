"""Command line: thin commands over the library.

This is the one place where errors become messages and exit codes:
0 ok, 1 a check failed, 2 bad input or usage, 3 numerical failure
(4 is an internal error: a bug, reported without a traceback unless
ANADYN_DEBUG=1).  Heavy libraries are imported inside the commands.
"""
from __future__ import annotations

import os
import sys
from enum import Enum
from pathlib import Path

import typer

from .errors import AnadynError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  pretty_exceptions_enable=False,
                  help="Analytical dynamics of robot arms: Kane's method and Lagrange's "
                       "equations from a YAML robot description.")

RobotArg = typer.Argument(..., help="Robot description (YAML).", show_default=False)


class Method(str, Enum):
    kane = "kane"
    lagrange = "lagrange"


class Format(str, Enum):
    text = "text"
    latex = "latex"


@app.command()
def equations(
    robot: Path = RobotArg,
    method: Method = typer.Option(Method.kane, help="Formulation."),
    fmt: Format = typer.Option(Format.text, "--format", help="Output format."),
    symbolic: bool = typer.Option(False, help="Keep the parameters as symbols."),
    matrices: bool = typer.Option(False, help="Print M, F, B instead of one equation per "
                                              "coordinate."),
) -> None:
    """Print the equations of motion, M(q) ddq = F(q, dq) + B(q) tau."""
    from .equations import render
    from .formulations import derive
    from .model import load_robot

    eom = derive(load_robot(robot), method.value, symbolic=symbolic)
    typer.echo(render(eom, fmt.value, "matrices" if matrices else "residual"))


@app.callback()
def _group() -> None:
    """Analytical dynamics of robot arms (every command takes --help)."""


def main(argv: list[str] | None = None) -> int:
    """Console entry point; returns the process exit code.

    Typer itself reports usage errors (exit 2) and --help; anadyn's own
    errors become one line on stderr with their exit code.
    """
    try:
        app(args=argv, prog_name="anadyn")
    except SystemExit as done:
        return done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
    except AnadynError as err:
        typer.echo(f"anadyn: error: {err}", err=True)
        return err.exit_code
    except Exception as err:                  # a bug: one line, traceback on request
        if os.environ.get("ANADYN_DEBUG"):
            raise
        typer.echo(f"anadyn: internal error: {type(err).__name__}: {err} "
                   "(set ANADYN_DEBUG=1 for the traceback)", err=True)
        return 4
    return 0


def run() -> None:
    """The ``anadyn`` console script."""
    sys.exit(main())


if __name__ == "__main__":
    run()
