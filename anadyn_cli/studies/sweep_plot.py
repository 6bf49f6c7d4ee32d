"""sweep.png: what a sweep found, drawn for the shape of its design.

* one varied name (a grid or a list): each metric against it, one panel per
  quantity and unit (peak efforts, RMS efforts, tracking, settling, final
  state; efforts whose joints have different effort limits in the file in
  panels of their own, so that one joint's limit never crosses another's
  curve), each metric's --max/--min bounds and file limit dashed in its own
  colour and named in the legend, samples that did not run marked by red
  dotted lines;
* two varied names on a grid: a heat map of each headline metric over them,
  samples that did not run or missed a limit crossed out;
* Monte-Carlo draws (or three names and more): a histogram of each headline
  metric over the samples that ran, with the bounds dashed.

The title is the robot and the command; what the marks mean is said under
the panels; the varied name's unit (kg for a body's mass, m for a length in
a body's placement) is on the x axis.
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


def _file_limit(result, column: str) -> float | None:
    """The file's effort limit of a peak or RMS column's actuator, when the sweep
    judges the file's limits."""
    if "limits_passed" not in result.plan.payload.columns:
        return None
    name = column.split("_", 1)[1]
    return next((a.effort_limit for a in result.plan.robot.actuators if a.name == name), None)


def _groups(result) -> list[tuple[str, list[str]]]:
    """Panels: (y label, metric columns) sharing a quantity, a unit and (efforts) the
    file's effort limit."""
    columns = result.plan.payload.columns
    units = _units(result)
    panels: list[tuple[str, list[str]]] = []
    for prefix, label in (("peak_", "peak |effort|"), ("rms_", "RMS effort")):
        chosen = [c for c in columns if c.startswith(prefix)]
        kinds = dict.fromkeys((units[c], _file_limit(result, c) or 0.0) for c in chosen)
        for unit, limit in sorted(kinds):
            panels.append((f"{label} ({unit})", [c for c in chosen if units[c] == unit and
                                                (_file_limit(result, c) or 0.0) == limit]))
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
    title = f"{plan.robot.name}: sweep ({plan.payload.command})"
    if len(names) <= 1 and not any(s.random for s in plan.design.specs):
        return _lines(result, names[0] if names else plan.design.names[0], title, Figure,
                      capacity)
    if len(names) == 2:
        return _heat_maps(result, names, title, Figure, headline[:MAX_PANELS])
    return _histograms(result, title, Figure, headline[:MAX_PANELS])


def name_label(result, name: str) -> str:
    """The varied name with its unit, where the robot file says: kg for a name that is
    a body's mass, m for one in a body's centre of mass or joint origin."""
    import sympy as sp

    robot = result.plan.folding.robot
    symbol = sp.Symbol(name, real=True)
    unit = ""
    for body in robot.bodies:
        if body.mass == symbol:
            unit = "kg"
            break
        places = [*body.com, *body.joint.origin]
        if any(symbol in getattr(v, "free_symbols", ()) for v in places):
            unit = "m"
    return f"{name} ({unit})" if unit else f"{name} (in the file's units)"


def _notes(figure, notes: list[str]) -> None:
    """What the marks mean, under the panels (in the layout: never cut)."""
    if notes:
        import textwrap

        width = int(figure.get_figwidth() * 14)
        figure.supxlabel("\n".join(textwrap.wrap("; ".join(notes), width)), fontsize=8)


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
        limits: dict[tuple[str, float], list[tuple[str, str]]] = {}
        for column in metrics:
            y = _values(result, column)
            line, = ax.plot(x[order], y[order], marker="o", markersize=3, linewidth=1.1,
                            label=column)
            for kind, bound in _bounds(result, column):
                limits.setdefault((kind, float(_scaled(result, column, np.array(bound)))),
                                  []).append((column, line.get_color()))
        for (kind, bound), owners in limits.items():    # one line per bound: one curve's
            whose = "" if len(owners) == len(metrics) else \
                " " + ", ".join(column for column, _ in owners)    # in its colour, else grey
            ax.axhline(bound, linestyle="--", linewidth=0.9,
                       color=owners[0][1] if len(owners) == 1 else "0.3",
                       label=f"{kind}{whose} = {bound:g}")
        for value in bad:
            ax.axvline(value, color="tab:red", linestyle=":", linewidth=0.9)
        if edge is not None:
            ax.axvline(edge, color="0.2", linestyle="-.", linewidth=1.0)
        ax.set_ylabel(label, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.35, linewidth=0.6)
        ax.legend(fontsize=7, loc="best")
        if k + columns >= len(panels):
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel(name_label(result, name), fontsize=8)
    notes = [f"{len(result.rows)} samples, {result.counts['ok']} ok"]
    if len(bad):
        notes.append(f"red dotted: {len(bad)} not run")
    if edge is not None:
        notes.append(f"dash-dotted: within the limits up to {name} = {edge:g}")
    figure.suptitle(title, fontsize=10)
    _notes(figure, notes)
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
        ax.set_xlabel(name_label(result, names[0]), fontsize=8)
        ax.set_ylabel(name_label(result, names[1]), fontsize=8)
        ax.tick_params(labelsize=7)
    figure.suptitle(title, fontsize=10)
    _notes(figure, [f"{len(result.rows)} samples, {result.counts['ok']} ok",
                    "red x: did not run" + (" or missed a limit" if plan.judged else "")])
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
    _notes(figure, [f"{len(result.rows)} samples, {result.counts['ok']} ok"])
    return figure
