"""Report-ready plots: PNG (200 dpi), SVG or PDF, written atomically.

Figures are ``matplotlib.figure.Figure`` objects rendered straight to bytes:
no pyplot, no global backend switch, so a notebook or an application that
imports anadyn keeps its own Matplotlib state.

Time plots are small multiples: one panel per quantity, and never two units
on one axis (angles in degrees apart from lengths in metres, N·m apart from
N).  The panels fill a grid of up to four columns and five rows per column
(then the rows shrink), so a 12-joint arm stays within a page: at most
FIGURE_MAX_HEIGHT inches tall.  Every panel names its signals: the y label
starts with the signal's name, or the panel has a legend (placed by
Matplotlib where it hides the fewest points); an effort panel can carry its
actuator's limit as dashed lines at +-limit.

A report's own size, title and font size (``FigureStyle``: ``--size``,
``--title``, ``--font-size``) are applied to a finished figure by
``apply_style``; ``styled(style)`` makes every figure rendered inside it
(``figure_bytes``, hence ``write_figure`` and ``write_plot``) take that style,
so a command sets it once for whatever its service draws.
"""
from __future__ import annotations

import contextlib
import contextvars
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
    """One axis: ``label`` (quantity and unit, e.g. ``q1 (deg)``), its lines, and
    ``limit``: a bound drawn as dashed lines at +-limit (an actuator's effort limit)."""
    label: str
    series: tuple[tuple[str, np.ndarray], ...]
    limit: float | None = None

    @property
    def named(self) -> bool:
        """Whether the y label already names the panel's one signal (``q1 (deg)``)."""
        return len(self.series) == 1 and self.label.split(" ")[0] == self.series[0][0]


@dataclass(frozen=True)
class FigureStyle:
    """A report's wishes for a figure: ``size`` (width, height) in inches, ``title``
    (replaces the figure's own), ``font_size`` in points for the axis labels (every
    other text, ticks, legends and the title, scales with it)."""
    size: tuple[float, float] | None = None
    title: str | None = None
    font_size: float | None = None


_STYLE: contextvars.ContextVar[FigureStyle] = contextvars.ContextVar("anadyn_figure_style",
                                                                     default=FigureStyle())


@contextlib.contextmanager
def styled(style: FigureStyle):
    """Within the block, every figure rendered by ``figure_bytes`` takes ``style``."""
    token = _STYLE.set(style)
    try:
        yield style
    finally:
        _STYLE.reset(token)


def current_style() -> FigureStyle:
    """The style set by the innermost ``styled`` block (an empty one outside)."""
    return _STYLE.get()


def apply_style(figure, style: FigureStyle | None = None):
    """``figure`` resized, retitled and its texts scaled as ``style`` (default: the
    current one) says; returns the figure."""
    from matplotlib.text import Text

    style = current_style() if style is None else style
    if style.size is not None:
        figure.set_size_inches(*style.size)
    if style.title is not None:
        figure.suptitle(style.title, fontsize=11)
    if style.font_size is not None:
        labels = [label.get_fontsize() for ax in figure.axes
                  for label in (ax.xaxis.label, ax.yaxis.label) if label.get_text()]
        reference = float(np.median(labels)) if labels else 10.0
        factor = style.font_size / reference
        ticks = {id(ax): _tick_size(ax) for ax in figure.axes}
        for text in set(figure.findobj(Text)):
            text.set_fontsize(text.get_fontsize() * factor)
        for ax in figure.axes:
            ax.tick_params(labelsize=ticks[id(ax)] * factor)
    return figure


def _tick_size(ax) -> float:
    labels = ax.xaxis.get_ticklabels() or ax.yaxis.get_ticklabels()
    return labels[0].get_fontsize() if labels else 10.0


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
                  one_each: bool = False, limits: Sequence[float | None] = ()) -> list[Panel]:
    """Efforts grouped by unit (torques apart from forces), at most MAX_SERIES lines
    a panel; ``one_each``: a panel per actuator, with its ``limits[k]`` (|effort|
    bound, None: none) drawn.  ``values``: rows x m."""
    if one_each:
        bounds = list(limits) + [None] * (len(actuators) - len(limits))
        return [Panel(f"{name} ({unit_text(unit)})", ((name, values[:, k]),), bounds[k])
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
        if panel.limit is not None:
            for sign in (1, -1):
                ax.axhline(sign * panel.limit, color="tab:red", linestyle="--", linewidth=0.9,
                           label=f"limit ±{panel.limit:g}" if sign > 0 else None)
        ax.set_ylabel(panel.label, fontsize=size)
        ax.tick_params(labelsize=size - 1)
        ax.grid(True, alpha=0.35, linewidth=0.6)
        ax.margins(x=0)
        if not panel.named or panel.limit is not None:
            entries = len(panel.series) + (panel.limit is not None)
            ax.legend(loc="best", fontsize=size - 1, ncols=min(3, entries),
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
    (the same run gives the same file), in the current style (``styled``)."""
    import matplotlib

    apply_style(figure)
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
