"""Report-ready plots: PNG (200 dpi), SVG or PDF, written atomically.

Figures are ``matplotlib.figure.Figure`` objects rendered straight to bytes:
no pyplot, no global backend switch, so a notebook or an application that
imports anadyn keeps its own Matplotlib state.

Time plots are small multiples: one panel per quantity, and never two units
on one axis (angles in degrees apart from lengths in metres, N·m apart from
N).  The panels fill a grid of up to four columns and five rows per column
(then the rows shrink), so a 12-joint arm stays within a page: at most
FIGURE_MAX_HEIGHT inches tall.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from ..errors import ModelError
from ..files import write_bytes

FORMATS = ("png", "svg", "pdf")
DPI = 200                      # PNG resolution; SVG and PDF are vector
PANEL_HEIGHT = 1.9             # inches per row of panels
FIGURE_MAX_HEIGHT = 10.5       # inches, title included
COLUMN_WIDTH = 4.6             # inches per column of panels (one column: 7.5)
MAX_ROWS = 5                   # rows per column before another column is opened
MAX_SERIES = 6                 # lines in one panel (more are split over panels)
QUANTITY = {"N*m": "torque", "N": "force", "rad": "angle", "m": "length"}


@dataclass(frozen=True)
class Panel:
    """One axis: ``label`` (quantity and unit, e.g. ``q1 (deg)``) and its lines."""
    label: str
    series: tuple[tuple[str, np.ndarray], ...]


def unit_text(unit: str) -> str:
    """``N*m`` -> ``N·m`` (as printed on axes and in tables)."""
    return unit.replace("*", "·")


def plot_format(value: str | None) -> str:
    """A known format, matched without regard to case (ModelError otherwise)."""
    fmt = (value or "png").lower().lstrip(".")
    if fmt not in FORMATS:
        raise ModelError(f"--plot-format: unknown format {value!r}; choose one of "
                         f"{', '.join(FORMATS)}")
    return fmt


def state_panels(coordinates: Sequence[tuple[str, str]], q: np.ndarray,
                 dq: np.ndarray | None = None) -> list[Panel]:
    """One panel per coordinate (degrees or metres), each followed by its rate's
    panel (deg/s or m/s) when ``dq`` is given.  ``q``, ``dq``: rows x n."""
    panels = []
    for i, (name, unit) in enumerate(coordinates):
        angle = unit == "rad"
        scale = (lambda v: np.degrees(v)) if angle else (lambda v: v)
        shown = "deg" if angle else unit_text(unit)
        panels.append(Panel(f"{name} ({shown})", ((name, scale(q[:, i])),)))
        if dq is not None:
            panels.append(Panel(f"d{name} ({shown}/s)", ((f"d{name}", scale(dq[:, i])),)))
    return panels


def effort_panels(actuators: Sequence[tuple[str, str]], values: np.ndarray,
                  one_each: bool = False) -> list[Panel]:
    """Efforts grouped by unit (torques apart from forces), at most MAX_SERIES lines
    a panel; ``one_each``: a panel per actuator.  ``values``: rows x m."""
    if one_each:
        return [Panel(f"{name} ({unit_text(unit)})", ((name, values[:, k]),))
                for k, (name, unit) in enumerate(actuators)]
    panels = []
    for unit in dict.fromkeys(u for _, u in actuators):
        members = [(name, values[:, k]) for k, (name, u) in enumerate(actuators) if u == unit]
        for start in range(0, len(members), MAX_SERIES):
            chunk = members[start:start + MAX_SERIES]
            label = QUANTITY.get(unit, "effort")
            if len(members) > MAX_SERIES:
                label += f" {chunk[0][0]}..{chunk[-1][0]}"
            panels.append(Panel(f"{label} ({unit_text(unit)})", tuple(chunk)))
    return panels


def grid(count: int, pairs: bool = False) -> tuple[int, int]:
    """(rows, columns) for ``count`` panels: one column up to MAX_ROWS panels,
    then as many columns as needed (at most 4); ``pairs`` (a coordinate's panel
    followed by its rate's): an even number of columns, so each pair shares a row."""
    columns = min(4, max(1, math.ceil(count / MAX_ROWS)))
    if pairs and count > 1:
        columns = 2 if count <= 3 * MAX_ROWS else 4
    return math.ceil(count / columns), columns


def time_figure(t: np.ndarray, panels: Iterable, title: str, xlabel: str = "t (s)",
                pairs: bool = False):
    """The small-multiples figure of ``panels`` against ``t`` (a Figure); ``pairs``:
    see ``grid``."""
    from matplotlib.figure import Figure

    panels = [p if isinstance(p, Panel) else Panel(p[0], tuple(p[1])) for p in panels]
    rows, columns = grid(len(panels), pairs)
    height = min(FIGURE_MAX_HEIGHT, PANEL_HEIGHT * rows + 0.8)
    width = 7.5 if columns == 1 else (COLUMN_WIDTH if columns == 2 else 4.0) * columns
    small = columns > 1 or rows > 4
    figure = Figure(figsize=(width, height), layout="constrained")
    axes = figure.subplots(rows, columns, sharex=True, squeeze=False)
    size = 8 if small else 9
    for k, ax in enumerate(axes.flat):
        if k >= len(panels):
            ax.set_visible(False)
            continue
        panel = panels[k]
        for name, values in panel.series:
            ax.plot(t, values, label=name, linewidth=1.1)
        ax.set_ylabel(panel.label, fontsize=size)
        ax.tick_params(labelsize=size - 1)
        ax.grid(True, alpha=0.35, linewidth=0.6)
        ax.margins(x=0)
        if len(panel.series) > 1:
            ax.legend(loc="best", fontsize=size - 1, ncols=min(3, len(panel.series)),
                      handlelength=1.5, framealpha=0.7)
        row, column = divmod(k, columns)
        below = (row + 1) * columns + column
        if below >= len(panels):                 # lowest panel of its column
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel(xlabel, fontsize=size)
    figure.suptitle(title, fontsize=10)
    return figure


def figure_bytes(figure, fmt: str, dpi: int = DPI) -> bytes:
    """``figure`` rendered as png (DPI), svg or pdf, without a creation date
    (the same run gives the same file)."""
    import matplotlib

    buffer = io.BytesIO()
    metadata = {"png": {"Software": None}, "svg": {"Date": None},
                "pdf": {"CreationDate": None, "ModDate": None}}[fmt]
    with matplotlib.rc_context({"svg.hashsalt": "anadyn"}):   # SVG ids: the same each run
        figure.savefig(buffer, format=fmt, dpi=dpi, metadata=metadata)
    return buffer.getvalue()


def write_figure(path: Path, figure, fmt: str | None = None) -> Path:
    """Render ``figure`` in ``fmt`` (default: from the suffix) and write it atomically."""
    path = Path(path)
    fmt = plot_format(fmt or path.suffix)
    write_bytes(path, figure_bytes(figure, fmt))
    return path


def write_plot(path: Path, t: np.ndarray, panels: Iterable, title: str,
               fmt: str | None = None, pairs: bool = False) -> Path:
    """Panels (``Panel`` or (y label, [(legend, values)])) sharing the time axis."""
    return write_figure(path, time_figure(t, panels, title, pairs=pairs), fmt)


def plot_path(out: Path, stem: str, fmt: str) -> Path:
    """``out/stem.fmt``."""
    return Path(out) / f"{stem}.{plot_format(fmt)}"
