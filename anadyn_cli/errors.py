"""anadyn's own exception types; the CLI maps each to one line and an exit code.

    ModelError      bad input or usage       exit 2
    CheckFailed     a check or tolerance      exit 1
    NumericalError  blow-up, singular M, ...  exit 3
"""
from __future__ import annotations

import math


class AnadynError(Exception):
    """Base class: ``str(err)`` is the one line shown to the user."""

    exit_code = 2


class ModelError(AnadynError):
    """A robot file (or a command's arguments) is wrong.

    The message names the file, the line where known, the key path and what
    is allowed, e.g. ``rr.yaml:12: bodies[1].mass: must be positive, got -1``.
    """

    exit_code = 2

    def __init__(self, message: str, source: str | None = None,
                 path: str | None = None, line: int | None = None):
        self.source, self.path, self.line, self.reason = source, path, line, message
        where = source or ""
        if where and line is not None:
            where += f":{line}"
        head = ": ".join(part for part in (where, path) if part)
        super().__init__(f"{head}: {message}" if head else message)


class CheckFailed(AnadynError):
    """A comparison or tolerance check did not pass."""

    exit_code = 1


class NumericalError(AnadynError):
    """The numbers failed: non-finite state, singular mass matrix, step collapse."""

    exit_code = 3


class SettingError(ModelError):
    """A run setting is wrong: ``setting`` is its name in the library (e.g.
    ``output_step``); the CLI names the flag that set it instead (``--dt``)."""

    def __init__(self, setting: str, reason: str):
        self.setting = setting
        super().__init__(f"{setting} {reason}")
        self.reason = reason


def positive(setting: str, value: float) -> float:
    """``value`` of ``setting`` if it is a finite number > 0, else SettingError."""
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise SettingError(setting, f"must be a positive number, got {value:g}")
    return value
