"""sweep.png: what a sweep found, drawn for the shape of its design.

* one varied name (a grid or a list): each metric against it, one panel per
  quantity and unit (peak efforts, RMS efforts, tracking, settling, final
  state), with the --max/--min bounds dashed and samples that did not run
  marked by red dotted lines;
* two varied names on a grid: a heat map of each headline metric over them,
  samples that did not run or missed a limit crossed out;
* Monte-Carlo draws (or three names and more): a histogram of each headline
  metric over the samples that ran, with the bounds dashed.
"""
from __future__ import annotations

import math

import numpy as np

from ..output.plots import unit_text

MAX_PANELS = 12


def _axes_names(result) -> list[str]:
    """The varied names that take more than one value on the grid (none: Monte-Carlo)."""
    design = result.plan.design
    if any(s.random for s in design.specs):
        return []
    return [s.name for s in design.specs if len(set(s.values)) > 1]


def _units(result) -> dict[str, str]:
    """Metric column -> unit."""
    robot = result.plan.robot
    units = {}
    for a in robot.actuators:
        units[f"peak_{a.name}"] = units[f"rms_{a.name}"] = unit_text(a.unit)
    coordinate_units = {c.unit for c in robot.coordinates}
    tracking = "rad or m" if len(coordinate_units) > 1 else next(iter(coordinate_units), "")
    units.update(tracking_error=tracking, final_error=tracking, settling_time="s",
                 energy_error="", fastest_decay="1/s", mass_condition_scaled="",
                 rhs_calls="", steps="", stiff="", check_passed="")
    for c in robot.coordinates:
        units[f"final_{c.name}"] = c.unit
        units[f"final_d{c.name}"] = f"{c.unit}/s"
    return units


def _groups(result) -> list[tuple[str, list[str]]]:
    """Panels: (y label, metric columns) sharing a quantity and a unit."""
    columns = result.plan.payload.columns
    units = _units(result)
    panels: list[tuple[str, list[str]]] = []
    for prefix, label in (("peak_", "peak |effort|"), ("rms_", "RMS effort")):
        chosen = [c for c in columns if c.startswith(prefix)]
        for unit in sorted({units[c] for c in chosen}):
            panels.append((f"{label} ({unit})", [c for c in chosen if units[c] == unit]))
    if "tracking_error" in columns:
        panels.append((f"error ({units['tracking_error']})", ["tracking_error", "final_error"]))
    for c in ("settling_time", "energy_error", "fastest_decay", "mass_condition_scaled"):
        if c in columns:
            panels.append((f"{c.replace('_', ' ')}" + (f" ({units[c]})" if units[c] else ""),
                           [c]))
    finals = [c for c in columns if c.startswith("final_") and c != "final_error"
              and not c.startswith("final_d")]
    for unit in sorted({units[c] for c in finals}):
        panels.append((f"final state ({'deg' if unit == 'rad' else unit})",
                       [c for c in finals if units[c] == unit]))
    return panels[:MAX_PANELS]


def _values(result, column: str) -> np.ndarray:
    data = np.array([float(r.get(column, math.nan)) if r["status"] == "ok" else math.nan
                     for r in result.rows])
    return _scaled(result, column, data)


def _scaled(result, column: str, values: np.ndarray) -> np.ndarray:
    if column.startswith("final_") and column != "final_error" and \
            _units(result).get(column, "").startswith("rad"):
        return np.degrees(values)
    return values


def _unit_shown(result, column: str) -> str:
    """The unit of the plotted values (final angles in degrees)."""
    unit = _units(result).get(column, "")
    if column.startswith("final_") and column != "final_error" and unit.startswith("rad"):
        return unit.replace("rad", "deg")
    return unit


def _bounds(result, column: str):
    """The limits drawn on ``column``: --max/--min, and the file's effort limits."""
    found = [(kind, bound) for metric, kind, bound in result.plan.bounds if metric == column]
    if "limits_passed" in result.plan.payload.columns:
        found += [("file max", a.effort_limit) for a in result.plan.robot.actuators
                  if column == f"peak_{a.name}" and a.effort_limit is not None]
    return found


def figure(result, capacity: dict | None, headline: list[str]):
    """sweep.png's Figure; ``capacity`` and ``headline`` as ``sweep`` computes them."""
    from matplotlib.figure import Figure

    plan = result.plan
    names = _axes_names(result)
    title = (f"{plan.robot.name}: {plan.payload.command} sweep of "
             f"{', '.join(plan.design.names)} ({len(result.rows)} samples, "
             f"{result.counts['ok']} ok)")
    if len(names) <= 1 and not any(s.random for s in plan.design.specs):
        return _lines(result, names[0] if names else plan.design.names[0], title, Figure,
                      capacity)
    if len(names) == 2:
        return _heat_maps(result, names, title, Figure, headline[:MAX_PANELS])
    return _histograms(result, title, Figure, headline[:MAX_PANELS])


def _layout(count: int) -> tuple[int, int]:
    columns = 1 if count <= 3 else 2 if count <= 8 else 3
    return math.ceil(count / columns), columns


def _lines(result, name: str, title: str, Figure, cap: dict | None):
    panels = _groups(result)
    rows, columns = _layout(len(panels))
    figure = Figure(figsize=(7.5 if columns == 1 else 4.6 * columns, min(10.5, 2.1 * rows + 0.8)),
                    layout="constrained")
    axes = figure.subplots(rows, columns, squeeze=False, sharex=True)
    x = np.array([r[name] for r in result.rows])
    order = np.argsort(x, kind="stable")
    bad = x[[r["status"] != "ok" for r in result.rows]]
    edge = cap.get("contiguous_to") if cap else None
    for k, ax in enumerate(axes.flat):
        if k >= len(panels):
            ax.set_visible(False)
            continue
        label, metrics = panels[k]
        for column in metrics:
            y = _values(result, column)
            ax.plot(x[order], y[order], marker="o", markersize=3, linewidth=1.1,
                    label=column)
            for kind, bound in _bounds(result, column):
                ax.axhline(_scaled(result, column, np.array(bound)), linestyle="--",
                           linewidth=0.9, color="0.3")
                ax.annotate(f"{kind} {column}", (1, float(_scaled(result, column,
                                                                    np.array(bound)))),
                            xycoords=("axes fraction", "data"), ha="right", va="bottom",
                            fontsize=7, color="0.3")
        for value in bad:
            ax.axvline(value, color="tab:red", linestyle=":", linewidth=0.9)
        if edge is not None:
            ax.axvline(edge, color="tab:green", linestyle="--", linewidth=1.0)
        ax.set_ylabel(label, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.35, linewidth=0.6)
        if len(metrics) > 1:
            ax.legend(fontsize=7, loc="best")
        if k + columns >= len(panels):
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel(name, fontsize=8)
    notes = [f"red dotted: {len(bad)} not run"] if len(bad) else []
    if edge is not None:
        notes.append(f"green: within the limits up to {name} = {edge:g}")
    figure.suptitle(title + "".join(f"; {n}" for n in notes), fontsize=10)
    return figure


def _heat_maps(result, names: list[str], title: str, Figure, columns: list[str]):
    plan = result.plan
    rows_, cols_ = _layout(len(columns))
    figure = Figure(figsize=(4.8 * cols_, min(10.5, 3.4 * rows_ + 0.8)), layout="constrained")
    axes = figure.subplots(rows_, cols_, squeeze=False)
    xs = sorted({r[names[0]] for r in result.rows})
    ys = sorted({r[names[1]] for r in result.rows})
    xi = {v: i for i, v in enumerate(xs)}
    yi = {v: i for i, v in enumerate(ys)}
    for k, ax in enumerate(axes.flat):
        if k >= len(columns):
            ax.set_visible(False)
            continue
        column = columns[k]
        grid = np.full((len(ys), len(xs)), math.nan)
        crossed = []
        values = _values(result, column)
        for r, v in zip(result.rows, values):
            grid[yi[r[names[1]]], xi[r[names[0]]]] = v
            if r["status"] != "ok" or (plan.judged and not r.get("within_limits")):
                crossed.append((r[names[0]], r[names[1]]))
        mesh = ax.pcolormesh(_edges(xs), _edges(ys), np.ma.masked_invalid(grid),
                             shading="flat", cmap="viridis")
        figure.colorbar(mesh, ax=ax, shrink=0.9).ax.tick_params(labelsize=7)
        if crossed:
            ax.plot(*zip(*crossed), "x", color="tab:red", markersize=5)
        unit = _unit_shown(result, column)
        ax.set_title(column + (f" ({unit})" if unit else ""), fontsize=9)
        if len(xs) * len(ys) <= 64:                   # small grids: the numbers themselves
            for r, v in zip(result.rows, values):
                if math.isfinite(v):
                    ax.text(r[names[0]], r[names[1]], f"{v:.3g}", ha="center", va="center",
                            fontsize=6, color="white")
        ax.set_xlabel(names[0], fontsize=8)
        ax.set_ylabel(names[1], fontsize=8)
        ax.tick_params(labelsize=7)
    note = "red x: did not run" + (" or missed a limit" if plan.judged else "")
    figure.suptitle(f"{title}; {note}", fontsize=10)
    return figure


def _edges(values: list[float]) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    middle = (v[1:] + v[:-1]) / 2
    return np.concatenate([[v[0] - (middle[0] - v[0])], middle,
                           [v[-1] + (v[-1] - middle[-1])]])


def _histograms(result, title: str, Figure, columns: list[str]):
    rows_, cols_ = _layout(len(columns))
    figure = Figure(figsize=(4.6 * cols_ if cols_ > 1 else 7.5, min(10.5, 2.3 * rows_ + 0.8)),
                    layout="constrained")
    axes = figure.subplots(rows_, cols_, squeeze=False)
    for k, ax in enumerate(axes.flat):
        if k >= len(columns):
            ax.set_visible(False)
            continue
        column = columns[k]
        values = _values(result, column)
        values = values[np.isfinite(values)]
        unit = _unit_shown(result, column)
        if len(values):
            ax.hist(values, bins=min(50, max(5, int(math.sqrt(len(values))))),
                    color="tab:blue", alpha=0.8)
        for kind, bound in _bounds(result, column):
            ax.axvline(float(_scaled(result, column, np.array(bound))), linestyle="--",
                       color="0.3", linewidth=0.9)
        ax.set_xlabel(column + (f" ({unit})" if unit else ""), fontsize=8)
        ax.set_ylabel("samples", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.35, linewidth=0.6)
    figure.suptitle(title, fontsize=10)
    return figure
