"""Command line: thin commands over the library.

This is the one place where errors become messages and exit codes:
0 ok, 1 a check failed, 2 bad input or usage, 3 numerical failure
(4 is an internal error: a bug, reported without a traceback unless
ANADYN_DEBUG=1).  Heavy libraries are imported inside the commands.
"""
from __future__ import annotations

import os
import sys

import typer

from .errors import AnadynError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  pretty_exceptions_enable=False, rich_markup_mode=None,
                  help="Analytical dynamics of robot arms: Kane's method and Lagrange's "
                       "equations from a YAML robot description.")


@app.callback()
def _group() -> None:
    """Analytical dynamics of robot arms (every command takes --help)."""


def _register_commands() -> None:
    """Add every command of ``commands`` to ``app`` (once)."""
    if app.registered_commands:
        return
    from .commands import COMMANDS

    for command in COMMANDS:
        app.command()(command)


def main(argv: list[str] | None = None) -> int:
    """Console entry point; returns the process exit code.

    Typer itself reports usage errors (exit 2) and --help; anadyn's own
    errors become one line on stderr with their exit code.
    """
    _register_commands()
    try:
        app(args=argv, prog_name="anadyn")
    except SystemExit as done:
        return done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
    except AnadynError as err:
        typer.echo(f"anadyn: error: {err}", err=True)
        return err.exit_code
    except KeyboardInterrupt:
        typer.echo("anadyn: interrupted; results written before the interruption are "
                   "complete, none is half-written", err=True)
        return 130
    except Exception as err:                  # a bug: one line, traceback on request
        if os.environ.get("ANADYN_DEBUG"):
            raise
        typer.echo(f"anadyn: internal error: {type(err).__name__}: {err} "
                   "(set ANADYN_DEBUG=1 for the traceback)", err=True)
        return 4
    return 0


def run() -> None:
    """The ``anadyn`` console script.

    Ends the process with ``os._exit`` once stdout and stderr are flushed:
    every result file is complete on disk by then (``output`` writes a
    temporary file and renames it), and tearing SymPy, SciPy and Matplotlib
    down module by module would add 0.3-0.5 s to every command.
    """
    code = main()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except OSError:             # e.g. stdout piped into a command that has quit
        code = code or 1
    os._exit(code)


if __name__ == "__main__":
    run()
