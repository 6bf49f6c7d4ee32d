"""Command line: thin commands over the library.

This is the one place where errors become messages and exit codes:
0 ok, 1 a check failed, 2 bad input or usage, 3 numerical failure
(4 is an internal error: a bug, reported without a traceback unless
ANADYN_DEBUG=1).  Heavy libraries are imported inside the commands.
"""
from __future__ import annotations

import functools
import gc
import os
import signal
import sys

import typer

from .errors import AnadynError, SettingError
from .plain_options import plain_coercion

#: the typer settings of ``app`` and of the one-command apps of ``_app_for``
_SETTINGS = dict(add_completion=True, no_args_is_help=True,
                 context_settings={"help_option_names": ["-h", "--help"]},
                 pretty_exceptions_enable=False, rich_markup_mode=None,
                 help="Analytical dynamics of robot arms: Kane's method and Lagrange's "
                      "equations from a YAML robot description.")
app = typer.Typer(**_SETTINGS)


def _show_version(value: bool) -> None:
    if value:
        from . import __version__
        typer.echo(f"anadyn {__version__}")
        raise typer.Exit()


def _group(version: bool = typer.Option(False, "--version", "-V", callback=_show_version,
                                        is_eager=True, help="Print anadyn's version and exit."),
           ) -> None:
    """Analytical dynamics of robot arms (every command takes -h / --help)."""


app.callback()(_group)


def _interruptible(command):
    """``command`` with a KeyboardInterrupt raised inside it (anadyn's handlers raise
    ``progress.Interrupted``; a KeyboardInterrupt comes from elsewhere) passed on as
    ``Interrupted``: typer would turn it into a silent exit 130 (signature kept)."""
    from . import progress

    @functools.wraps(command)
    def run(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except KeyboardInterrupt:
            raise progress.Interrupted(signal.SIGINT) from None
    return run


def _register_commands(target: typer.Typer = app, commands=None) -> None:
    """Add ``commands`` (default: every command of ``commands.COMMANDS``) to ``target`` (once)."""
    if target.registered_commands:
        return
    from .commands import COMMANDS
    from .commands.common import check_options

    for command in COMMANDS if commands is None else commands:
        target.command(name=getattr(command, "cli_name", None))(
            _interruptible(check_options(command)))


_ONE_COMMAND: dict[str, typer.Typer] = {}


def _app_for(argv: list[str] | None) -> typer.Typer:
    """The app that runs the command line ``argv``: when its first word names a
    command, an app like ``app`` with that command alone (the same usage lines,
    help and messages; typer builds the parameters of every registered command on
    each run), else ``app`` with every command."""
    from .commands import COMMANDS

    words = sys.argv[1:] if argv is None else argv
    chosen = [c for c in COMMANDS if words and words[0] == (
        getattr(c, "cli_name", None) or c.__name__.lower().replace("_", "-"))]
    if len(chosen) != 1:
        _register_commands()
        return app
    name = words[0]
    if name not in _ONE_COMMAND:
        one = typer.Typer(**_SETTINGS)
        one.callback()(_group)
        _register_commands(one, chosen)
        _ONE_COMMAND[name] = one
    return _ONE_COMMAND[name]


def main(argv: list[str] | None = None) -> int:
    """Console entry point; returns the process exit code.

    Typer itself reports usage errors (exit 2) and --help; anadyn's own
    errors become one line on stderr with their exit code.  SIGINT and
    SIGTERM stop the command (``progress.stop_on_signals``): one line, exit
    130 or 143.
    """
    from . import progress

    restore = progress.stop_on_signals()
    try:
        return _main(argv)
    finally:
        restore()


def _main(argv: list[str] | None) -> int:
    from . import progress

    try:
        command = typer.main.get_command(_app_for(argv))
        plain_coercion(command)           # no Pydantic for plain values (plain_options)
        with progress.session():          # what long commands are doing, on stderr
            try:
                command(args=argv, prog_name="anadyn")
            finally:
                progress.raise_lost()
    except SystemExit as done:
        return done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
    except SettingError as err:
        from .commands.common import flag_message
        typer.echo(f"anadyn: error: {flag_message(err.setting, err.reason)}", err=True)
        return err.exit_code
    except AnadynError as err:
        typer.echo(f"anadyn: error: {err}", err=True)
        return err.exit_code
    except (KeyboardInterrupt, progress.Interrupted) as stop:
        line, code = progress.interruption(getattr(stop, "signum", signal.SIGINT))
        typer.echo(line, err=True)
        return code
    except Exception as err:                  # a bug: one line, traceback on request
        if os.environ.get("ANADYN_DEBUG"):
            raise
        typer.echo(f"anadyn: internal error: {type(err).__name__}: {err} "
                   "(set ANADYN_DEBUG=1 for the traceback)", err=True)
        return 4
    return 0


#: the variables by which a user chooses OpenBLAS's threads (NumPy's and SciPy's BLAS)
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def _one_blas_thread() -> None:
    """OPENBLAS_NUM_THREADS=1 unless one of BLAS_THREADS is set, before NumPy loads
    OpenBLAS (a command imports it later): anadyn's matrices are small (a robot's
    n <= ~100), on which OpenBLAS's other threads only wait, spinning, and that CPU
    time was up to half a warm run's (TIAGo: simulate 0.46 -> 0.25 s, inverse
    0.37 -> 0.27 s); the results are the same bytes."""
    if not any(os.environ.get(name) for name in BLAS_THREADS):
        os.environ["OPENBLAS_NUM_THREADS"] = "1"


def run() -> None:
    """The ``anadyn`` console script.

    Ends the process with ``os._exit`` once stdout and stderr are flushed:
    every result file is complete on disk by then (``output`` writes a
    temporary file and renames it), and tearing SymPy, SciPy and Matplotlib
    down module by module would add 0.3-0.5 s to every command.  OpenBLAS runs
    on one thread unless the user chose (``_one_blas_thread``).

    The cyclic garbage collector runs rarely (as mypy sets it): deriving and
    tracing allocate millions of small acyclic objects, and the default
    thresholds spent ~28 % of code generation scanning them (chain12: tracing
    0.14 s -> 0.10 s); what a command leaves for it is freed at exit anyway.
    """
    gc.freeze()                                 # what the imports made: never scanned
    gc.set_threshold(200_000, 30, 30)
    _one_blas_thread()
    code = main()
    for signum in (signal.SIGINT, signal.SIGTERM):     # done: a late signal changes nothing
        signal.signal(signum, signal.SIG_IGN)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except OSError:             # e.g. stdout piped into a command that has quit
        code = code or 1
    os._exit(code)


if __name__ == "__main__":
    run()
