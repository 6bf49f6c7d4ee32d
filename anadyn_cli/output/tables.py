"""Terminal tables: sensible times for any horizon, units in every header.

The rows sit at a round step (1, 2 or 5 times a power of ten) chosen so
that a table has about ROWS rows whatever the horizon (0.5 s or 1000 s),
plus the last time when the step does not reach it.
"""
from __future__ import annotations

import math
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
