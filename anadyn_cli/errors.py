"""anadyn's own exception types; the CLI maps each to one line and an exit code.

    ModelError      bad input or usage       exit 2
    CheckFailed     a check or tolerance      exit 1
    NumericalError  blow-up, singular M, ...  exit 3

and the range of every numeric setting (``ALLOWED``, checked by ``check``),
so that the library and the command line refuse the same values in the same
words.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


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


@dataclass(frozen=True)
class Allowed:
    """The values a numeric setting may take: an interval (``low`` and ``high``,
    None for no bound; ``*_open`` when the bound itself is excluded), finite, and
    whole numbers only when ``whole``.  ``why`` says where a bound comes from.

    ``check`` is the one range check of anadyn's settings and options: it
    accepts a number or its text (the command line's ``1e3`` is a whole number)
    and raises SettingError, whose message states the allowed range.
    """
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    whole: bool = False
    why: str = ""

    def describe(self) -> str:
        """``a number greater than 0 and less than 1``, ``a whole number from 0 to 9``."""
        kind = "a whole number" if self.whole else "a number"
        if self.low == 0 and self.low_open and self.high is None:
            return f"a positive {kind[2:]}"
        if self.low is not None and self.high is not None and not (self.low_open
                                                                   or self.high_open):
            return f"{kind} from {_show(self.low)} to {_show(self.high)}"
        bounds = []
        if self.low is not None:
            bounds.append(("greater than " if self.low_open else "at least ") + _show(self.low))
        if self.high is not None:
            bounds.append(("less than " if self.high_open else "at most ") + _show(self.high))
        if not bounds:
            return f"a finite {kind[2:]}"
        return f"{kind} {'' if bounds[0].startswith('greater') else 'of '}" + " and ".join(bounds)

    def check(self, setting: str, value):
        """``value`` as a float (an int when ``whole``) if allowed, else SettingError."""
        number = _number(value)
        allowed = number is not None and math.isfinite(number) and not (
            self.whole and number != int(number))
        if allowed:
            allowed = not ((self.low is not None and (number < self.low or self.low_open
                                                      and number == self.low))
                           or (self.high is not None and (number > self.high or self.high_open
                                                          and number == self.high)))
        if not allowed:
            why = f" ({self.why})" if self.why else ""
            raise SettingError(setting, f"must be {self.describe()}{why}, got {_given(value)}")
        return int(number) if self.whole else float(number)


POSITIVE = Allowed(0, low_open=True)


def positive(setting: str, value: float) -> float:
    """``value`` of ``setting`` if it is a finite number > 0, else SettingError."""
    return POSITIVE.check(setting, value)


# -- the range of every numeric setting of runs and studies (the command line
#    checks its options by this table when it reads them, before any work)
MAX_SAMPLES = 1_000_000  # random states, points or draws of a study
RELATIVE = Allowed(0, 1, low_open=True, high_open=True)     # a relative tolerance or fraction
CALLS = Allowed(100, whole=True)                            # a budget of RHS calls

#: setting (its library name) -> the values it may take
ALLOWED = {
    "rtol": RELATIVE,
    "atol": Allowed(1e-100, 1, high_open=True, why="below it the integrators' error norms, "
                                                   "which square error / atol, overflow"),
    "t_end": POSITIVE, "output_step": POSITIVE,
    "numeric_tolerance": RELATIVE, "trajectory_tolerance": RELATIVE, "energy_tol": RELATIVE,
    "settle_band": RELATIVE,
    "roundtrip_tolerance": POSITIVE, "roundtrip_segment": POSITIVE, "contact_gap": POSITIVE,
    "max_condition": POSITIVE,
    "samples": Allowed(1, MAX_SAMPLES, whole=True),
    "seed": Allowed(0, 2**32 - 1, whole=True),
    "symbolic_terms": Allowed(0, whole=True),
    "repeats": Allowed(1, whole=True),
    "max_calls": CALLS, "reference_calls": CALLS, "probe_calls": CALLS,
    "frames": Allowed(2, whole=True),
    "jobs": Allowed(1, whole=True),
}


def check(setting: str, value):
    """``value`` if ``setting`` (a key of ALLOWED) may take it, else SettingError
    stating the range; None (not given) passes."""
    return None if value is None else ALLOWED[setting].check(setting, value)


def _number(value) -> float | int | None:
    """A number from a number or its text; None for anything else (bools too).
    Whole numbers stay exact ints, however large."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        text = value.strip()
        if text.lstrip("+-").isdigit() and len(text) <= 400:
            return int(text)
        value = text
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return int(number) if math.isfinite(number) and number.is_integer() else number


def _show(bound: float) -> str:
    """A bound as people write it: 0, 0.5, 1e-100, 4294967295, 1,000,000 (round
    thousands grouped)."""
    if isinstance(bound, int):
        return f"{bound:,}" if bound >= 10_000 and bound % 1000 == 0 else str(bound)
    return f"{bound:g}"


def _given(value) -> str:
    """The refused value as the user gave it (text quoted unless it is a number)."""
    if isinstance(value, str):
        return value.strip() if _number(value) is not None else repr(value.strip())
    return f"{value:g}" if isinstance(value, float) else repr(value)


def printable(text: str) -> str:
    """``text`` on one line, every character Python would not print escaped: line
    breaks and other controls as ``\\n``, ``\\x85``, ``\\u2028``, the bytes of a
    file name that are not UTF-8 (``os.fsdecode``'s surrogates) as ``\\xff``."""
    def escaped(ch: str) -> str:
        if "\udc80" <= ch <= "\udcff":
            return f"\\x{ord(ch) - 0xdc00:02x}"
        return ch.encode("unicode_escape").decode("ascii")
    return "".join(ch if ch.isprintable() else escaped(ch) for ch in text)


def shorten(value: object, limit: int = 60) -> str:
    """``str(value)`` for a one-line message: cut to ``limit`` characters, the last
    three ``...``, when longer (an integer too long to print is "a huge number")."""
    try:
        text = str(value)
    except ValueError:
        text = "a huge number"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def display_name(path) -> str:
    """A file's name as messages, generated code and JSON show it: ``printable``."""
    return printable(str(path))
