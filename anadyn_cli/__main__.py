"""``python -m anadyn_cli`` and the ``anadyn`` console script run the command line.

SIGINT and SIGTERM are caught before the command line's modules load, so
that a signal at startup too ends with one line and exit 130 or 143.
"""
from . import progress


def console() -> None:
    """The entry point: signal handlers first, then ``cli.run``."""
    progress.stop_on_signals()
    try:
        from .cli import run
        run()
    except progress.Interrupted as stop:          # before the command line had started
        import os
        import sys

        line, code = progress.interruption(stop.signum)
        print(line, file=sys.stderr, flush=True)
        os._exit(code)


if __name__ == "__main__":
    console()
