"""Terminal tables: sensible times for any horizon, units in every header.

The rows sit at a round step (1, 2 or 5 times a power of ten) chosen so
that a table has about ROWS rows whatever the horizon (0.5 s or 1000 s),
plus the last time when the step does not reach it.

Wide tables fit the terminal (``fit``): a table (two or more lines of one
length, its columns separated by blank gutters) wider than the terminal
keeps its first columns and its last one, with an ellipsis column for the
rest, cut only in the gutters (a value, minus sign and all, is never split
or wrapped), and a line says where every column is.  Output that is not a
terminal (a pipe, a file, a CI log) keeps every column.
"""
from __future__ import annotations

import math
import os
import shutil
import sys
from typing import Sequence

ROWS = 15           # at most this many steps in a table (ROWS + 1 rows, + the end)


def nice_step(span: float, target: int = ROWS) -> float:
    """The smallest of 1, 2, 5 x 10^k that divides ``span`` into at most ``target`` steps."""
    if not span > 0:
        return 1.0
    raw = span / target
    power = 10.0 ** math.floor(math.log10(raw))
    for factor in (1, 2, 5, 10):
        if factor * power >= raw * (1 - 1e-9):
            return factor * power
    return 10 * power


def table_times(duration: float, target: int = ROWS) -> list[float]:
    """0, h, 2h, ... up to ``duration`` at a round step h, and ``duration`` itself."""
    step = nice_step(duration, target)
    count = int(math.floor(duration / step * (1 + 1e-9)))
    times = [round(k * step, 12) for k in range(count + 1)]
    if duration - times[-1] > 1e-9 * max(1.0, duration):
        times.append(duration)
    return times


def grid_rows(count: int, step: float, target: int = ROWS) -> list[int]:
    """Row indices of an output grid t_k = k * step (``count`` rows): every row at
    a round time step when that step is a whole number of grid steps (else at a
    round number of rows, e.g. for a grid step of 0.03 s), and the last row."""
    if count <= 0:
        return []
    span = (count - 1) * step
    round_step = nice_step(span, target)
    every = int(round(round_step / step))
    if every < 1 or abs(every * step - round_step) > 1e-9 * round_step:
        every = max(1, int(nice_step(count - 1, target)))
    rows = list(range(0, count, every))
    if rows[-1] != count - 1:
        rows.append(count - 1)
    return rows


def number(value: float, decimals: int = 6) -> str:
    """Fixed-point text, never ``-0.000000``."""
    return f"{round(float(value), decimals) + 0.0:.{decimals}f}"


def time_text(value: float) -> str:
    """A time as short as it can be written exactly enough (``7.5``, ``0.05``)."""
    return f"{round(float(value), 9) + 0.0:g}"


def render(headers: Sequence[str], rows: Sequence[Sequence[str]], min_width: int = 12) -> str:
    """Right-aligned columns, each as wide as its header (at least ``min_width``)."""
    widths = [max(min_width, len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(headers)]
    lines = ["  ".join(f"{h:>{w}}" for h, w in zip(headers, widths))]
    lines += ["  ".join(f"{v:>{w}}" for v, w in zip(row, widths)) for row in rows]
    return "\n".join(lines)


def rate_unit(unit: str) -> str:
    return f"{unit}/s"


ELLIPSIS = "  \u2026"        # the column standing for the columns left out


def terminal_width() -> int | None:
    """Columns of the terminal (``$COLUMNS`` wins); None when standard output is
    not a terminal and ``$COLUMNS`` is not set: every column is printed."""
    return _terminal("COLUMNS", 0)


def terminal_lines() -> int | None:
    """Lines of the terminal (``$LINES`` wins); None when not a terminal."""
    return _terminal("LINES", 1)


def _terminal(variable: str, index: int) -> int | None:
    value = os.environ.get(variable, "")
    if value.isdigit() and int(value) > 0:
        return int(value)
    if not sys.stdout.isatty():
        return None
    return shutil.get_terminal_size()[index]


def _fields(block: list[str]) -> list[tuple[int, int]]:
    """(start, end) of the columns of ``block`` (lines of one length): the runs of
    positions where some line has a character, between gutters blank in every line."""
    used = [any(line[k] != " " for line in block) for k in range(len(block[0]))]
    fields, start = [], None
    for k, busy in enumerate(used + [False]):
        if busy and start is None:
            start = k
        elif not busy and start is not None:
            fields.append((start, k))
            start = None
    return fields


def _cut(block: list[str], width: int) -> tuple[list[str], int] | None:
    """``block`` with its middle columns left out so that it is at most ``width``
    wide (the first columns that fit, an ellipsis, the last column), and how many
    columns were left out; None when it has too few columns to cut."""
    fields = _fields(block)
    if len(fields) < 3:
        return None
    tail = len(block[0]) - fields[-2][1]          # the last column with its gutter
    keep = 0
    while keep + 1 < len(fields) - 1 and \
            fields[keep + 1][1] + len(ELLIPSIS) + tail <= width:
        keep += 1
    end, resume = fields[keep][1], fields[-2][1]
    return [line[:end] + ELLIPSIS + line[resume:] for line in block], len(fields) - keep - 2


def fit(text: str, width: int | None, full: str) -> str:
    """``text`` with every table wider than ``width`` (less one column, so that no
    terminal wraps it) cut to fit; ``full`` names where every column is, said in one
    line under each cut table.  ``width`` None: ``text`` unchanged."""
    if not width:
        return text
    limit = max(width - 1, 20)
    lines = text.split("\n")
    out, k = [], 0
    while k < len(lines):
        j = k + 1
        while j < len(lines) and len(lines[j]) == len(lines[k]):
            j += 1
        block = lines[k:j]
        cut = _cut(block, limit) if len(block) >= 2 and len(block[0]) > limit else None
        if cut is None:
            out += block
        else:
            out += cut[0]
            out.append(f"({cut[1]} column{'s' * (cut[1] != 1)} left out to fit {width} "
                       f"columns; {full} has every one)")
        k = j
    return "\n".join(out)


def repeat_header(lines: list[str], header: str, every: int | None) -> list[str]:
    """``lines`` (a table's rows) with ``header`` before them and again after every
    ``every`` rows (a screenful), so that a long table keeps its header in view."""
    if not every or every < 5 or len(lines) <= every:
        return [header, *lines]
    out = []
    for start in range(0, len(lines), every):
        out += [header, *lines[start:start + every]]
    return out
