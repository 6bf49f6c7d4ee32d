"""What a work-precision study found: its rows (``Row``), the study (``AccuracyStudy``,
with the fastest setting per error level), and accuracy.csv, accuracy.json, the plot
and the terminal table."""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import files as output
from ...model.info import RobotInfo
from .runs import ATOL_RATIO, Reference


@dataclass
class Row:
    method: str
    rtol: float
    atol: float
    status: str                    # ok, over budget, skipped, failed, no reference
    ran: str = ""                  # the method that ran (auto -> odeint)
    max_error: float = math.nan
    final_error: float = math.nan
    wall_s: float = math.nan
    rhs_calls: int = 0
    jacobian_calls: int = 0
    steps: int = 0
    reference: str = ""
    note: str = ""
    drift: float = math.nan        # closed chains: largest constraint residual along the run
    event_error: float = math.nan  # contacts: largest error of the events' times, s

    @property
    def ok(self) -> bool:
        return self.status == "ok"


@dataclass
class AccuracyStudy:
    robot: RobotInfo
    t_end: float
    output_step: float
    grid: np.ndarray
    references: list[Reference]
    given_up: list[Reference]
    reference_error: float          # max error between the two references (nan if one)
    rows: list[Row]
    repeats: int
    max_calls: int
    timings: dict = field(default_factory=dict)
    computation: dict = field(default_factory=dict)   # what ran (numeric.build.computation)

    def levels(self) -> list[dict]:
        """For each error level 10^-k reached by some run: the fastest setting, and auto.

        auto's rank is among the methods other than odeint (its own choice), by
        each method's fastest setting that reaches the level; its ratio is to
        the fastest setting overall.  Levels finer than 10x the reference
        error estimate are left out.
        """
        good = [r for r in self.rows if r.ok]
        if not good:
            return []
        low = min(r.max_error for r in good)
        high = max(r.max_error for r in good)
        first = max(1, math.floor(-math.log10(high)) if high > 0 else 1)
        last = math.floor(-math.log10(low)) if low > 0 else 16
        levels = []
        floor = 10 * self.reference_error if math.isfinite(self.reference_error) else 0.0
        for k in range(first, min(last, 16) + 1):
            level = 10.0 ** -k
            if level < floor:           # not resolved by the reference
                break
            reaching = [r for r in good if r.max_error <= level]
            if not reaching:
                continue
            best: dict[str, Row] = {}
            for r in reaching:
                if r.method not in best or r.wall_s < best[r.method].wall_s:
                    best[r.method] = r
            fastest = min(best.values(), key=lambda r: r.wall_s)
            # auto is ranked against the other methods; odeint is auto's own choice
            ranked = sorted((r for r in best.values() if r.method != "odeint"),
                            key=lambda r: r.wall_s)
            auto = best.get("auto")
            entry = {"level": level, "method": fastest.method, "rtol": fastest.rtol,
                     "wall_s": fastest.wall_s, "methods_reaching": len(ranked),
                     "auto_rank": None, "auto_rtol": None, "auto_wall_s": None,
                     "auto_ratio": None}
            if auto is not None:
                entry.update(auto_rank=ranked.index(auto) + 1, auto_rtol=auto.rtol,
                             auto_wall_s=auto.wall_s, auto_ratio=auto.wall_s / fastest.wall_s)
            levels.append(entry)
        return levels


CSV_COLUMNS = ("method", "ran", "rtol", "atol", "status", "max_error", "final_error", "wall_s",
               "rhs_calls", "jacobian_calls", "steps", "reference", "note")


def csv_text(result: AccuracyStudy) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    drift = any(not math.isnan(r.drift) for r in result.rows)     # closed chains
    events = any(not math.isnan(r.event_error) for r in result.rows)    # contacts
    writer.writerow(CSV_COLUMNS + (("constraint_drift",) if drift else ())
                    + (("event_error",) if events else ()))
    for r in result.rows:
        writer.writerow([r.method, r.ran, f"{r.rtol:.17g}", f"{r.atol:.17g}", r.status,
                         "" if math.isnan(r.max_error) else f"{r.max_error:.17g}",
                         "" if math.isnan(r.final_error) else f"{r.final_error:.17g}",
                         "" if math.isnan(r.wall_s) else f"{r.wall_s:.9g}",
                         r.rhs_calls, r.jacobian_calls, r.steps, r.reference, r.note]
                        + ([("" if math.isnan(r.drift) else f"{r.drift:.17g}")] if drift
                           else [])
                        + ([("" if math.isnan(r.event_error) else f"{r.event_error:.17g}")]
                           if events else []))
    return buffer.getvalue()


def summary(result: AccuracyStudy) -> dict:
    """Key figures (``accuracy.json``)."""
    return {
        "robot": result.robot.name, **result.computation, "t_end": result.t_end,
        "output_step": result.output_step,
        "rows_on_grid": len(result.grid), "repeats": result.repeats,
        "max_calls": result.max_calls, "atol_ratio": ATOL_RATIO,
        "references": [{"method": r.method, "rtol": r.rtol, "atol": r.atol,
                        "rhs_calls": r.rhs_calls, "jacobian_calls": r.jacobian_calls,
                        "steps": r.steps, "wall_s": r.wall} for r in result.references],
        "references_given_up": [{"method": r.method, "rtol": r.rtol, "note": r.note}
                                for r in result.given_up],
        "reference_error": None if math.isnan(result.reference_error)
        else result.reference_error,
        "rows": [{"method": r.method, "ran": r.ran, "rtol": r.rtol, "atol": r.atol,
                  "status": r.status,
                  "max_error": None if math.isnan(r.max_error) else r.max_error,
                  "final_error": None if math.isnan(r.final_error) else r.final_error,
                  "wall_s": None if math.isnan(r.wall_s) else r.wall_s,
                  "rhs_calls": r.rhs_calls, "jacobian_calls": r.jacobian_calls,
                  "steps": r.steps, "reference": r.reference, "note": r.note,
                  **({} if math.isnan(r.drift) else {"constraint_drift": r.drift}),
                  **({} if math.isnan(r.event_error) or math.isinf(r.event_error)
                     else {"event_error": r.event_error}),
                  **({"event_error": "events differ"} if math.isinf(r.event_error) else {})}
                 for r in result.rows],
        "levels": result.levels(),
        "timings": dict(result.timings),
    }


def plot_bytes(result: AccuracyStudy, fmt: str = "png") -> bytes:
    """The work-precision diagram (``figure``) rendered as png, svg or pdf."""
    from ...output.plots import figure_bytes

    return figure_bytes(figure(result), fmt)


def figure(result: AccuracyStudy):
    """Log-log work-precision diagram: max error (x) against run time (y), one line per
    method (a Matplotlib Figure; the global backend is not touched)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 5.2), layout="constrained")
    ax = fig.subplots()
    markers = "osD^v<>ph*"
    methods = list(dict.fromkeys(r.method for r in result.rows))
    for k, method in enumerate(methods):
        rows = [r for r in result.rows if r.method == method and r.ok and r.max_error > 0]
        if not rows:
            continue
        ax.loglog([r.max_error for r in rows], [r.wall_s for r in rows],
                  marker=markers[k % len(markers)], linewidth=1.4 if method == "auto" else 1.0,
                  color="black" if method == "auto" else None, markersize=5, label=method)
        for r in (rows[0], rows[-1]):
            ax.annotate(f"{r.rtol:.0e}", (r.max_error, r.wall_s), fontsize=6,
                        textcoords="offset points", xytext=(3, 3), alpha=0.7)
    if not math.isnan(result.reference_error) and result.reference_error > 0:
        ax.axvline(result.reference_error, color="grey", linestyle="--", linewidth=1,
                   label=f"reference error ~{result.reference_error:.1e}")
    skipped = sorted({r.method for r in result.rows if r.status in ("over budget", "skipped")})
    fig.suptitle(f"{result.robot.name}: accuracy", fontsize=11)   # the settings: accuracy.json
    if skipped:
        ax.set_title(f"over {result.max_calls} RHS calls (not shown): {', '.join(skipped)}",
                     fontsize=8)
    ax.set_xlabel("max error over the output grid (scaled state norm)")
    ax.set_ylabel(f"run time, s (min of {result.repeats})")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    return fig


@output.one_set
def write(result: AccuracyStudy, out: Path, plot: bool = True,
          plot_format: str = "png") -> list[Path]:
    """accuracy.csv, accuracy.png (or .svg, .pdf) and accuracy.json in ``out``."""
    from ...output.plots import plot_path

    out = output.prepare_dir(out)
    written = [out / "accuracy.csv"]
    output.write_text(written[0], csv_text(result))
    if plot:
        written.append(plot_path(out, "accuracy", plot_format))
        output.write_bytes(written[-1], plot_bytes(result, plot_format))
    written.append(out / "accuracy.json")
    output.write_json(written[-1], summary(result))
    return written


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.3g} ms" if seconds < 1 else f"{seconds:.3g} s"


def reference_lines(result: AccuracyStudy) -> list[str]:
    lines = []
    for k, r in enumerate(result.references):
        lines.append(f"reference {'AB'[k]}: {r.describe()} atol {r.atol:g}: {r.rhs_calls} RHS "
                     f"calls, {r.jacobian_calls} Jacobian calls, {r.steps} steps, "
                     f"{_ms(r.wall)}")
    for r in result.given_up:
        lines.append(f"reference {r.describe()}: {r.note}")
    if len(result.references) > 1:
        lines.append(f"reference error estimate |A - B|: {result.reference_error:.2e} "
                     "(errors near or below it are not resolved)")
    else:
        lines.append("reference error estimate: unavailable (only one reference)")
    return lines


def table(result: AccuracyStudy, header_every: int | None = None) -> str:
    """The study as text: references, the rows (their header again after every
    ``header_every`` rows, e.g. a screenful), and the fastest setting per error level."""
    from ...output.tables import repeat_header

    lines = reference_lines(result)
    lines.append("")
    header = (f"{'method':<7} {'rtol':>7} {'max_error':>10} {'final_err':>10} {'time':>9} "
              f"{'rhs':>7} {'jac':>5} {'steps':>6}  note")
    body: list[str] = []
    floor = 10 * result.reference_error if not math.isnan(result.reference_error) else 0.0
    rows = list(result.rows)
    k = 0
    while k < len(rows):
        r = rows[k]
        k += 1
        if r.status == "skipped":
            last = r
            while k < len(rows) and rows[k].status == "skipped" and rows[k].method == r.method:
                last = rows[k]
                k += 1
            through = "" if last is r else f" (and every rtol down to {last.rtol:.0e})"
            body.append(f"{r.method:<7} {r.rtol:7.0e} {'skipped':>10}  {r.note}{through}")
        elif r.ok:
            mark = "*" if r.max_error <= floor else ""
            note = " ".join(p for p in ((f"ran {r.ran}" if r.ran != r.method else ""),
                                        "vs " + r.reference.split(" rtol")[0], r.note,
                                        "" if math.isnan(r.drift) else
                                        f"constraint drift {r.drift:.1e}",
                                        "" if math.isnan(r.event_error) else
                                        f"events {r.event_error:.1e} s") if p)
            body.append(f"{r.method:<7} {r.rtol:7.0e} {r.max_error:9.2e}{mark or ' '} "
                         f"{r.final_error:10.2e} {_ms(r.wall_s):>9} {r.rhs_calls:7d} "
                         f"{r.jacobian_calls:5d} {r.steps:6d}  {note}")
        else:
            calls = f">{r.rhs_calls}" if r.status == "over budget" else ""
            body.append(f"{r.method:<7} {r.rtol:7.0e} {r.status:>10} {'':>10} {'':>9} "
                         f"{calls:>7} {'':5} {'':6}  {r.note}")
    lines += repeat_header(body, header, header_every)
    if floor > 0 and any(r.ok and r.max_error <= floor for r in result.rows):
        lines.append("* within 10x of the reference error estimate: a bound, not a measurement")
    lines.append("")
    levels = result.levels()
    ran_auto = any(r.method == "auto" for r in result.rows)
    if levels:
        lines.append(f"{'error <=':>9}  {'fastest setting':<22} {'time':>9}   "
                     + ("auto (rank among the methods reaching it, odeint aside)" if ran_auto
                        else "(auto not run)"))
        for e in levels:
            setting = f"{e['method']} rtol {e['rtol']:.0e}"
            if not ran_auto:
                auto = ""
            elif e["auto_rank"] is None:
                auto = "does not reach it"
            else:
                auto = (f"rtol {e['auto_rtol']:.0e}, {_ms(e['auto_wall_s'])}: "
                        f"{_ordinal(e['auto_rank'])} of {e['methods_reaching']}, "
                        f"{e['auto_ratio']:.2g}x the fastest")
            lines.append(f"{e['level']:9.0e}  {setting:<22} {_ms(e['wall_s']):>9}   "
                         f"{auto}".rstrip())
    return "\n".join(lines)


def _ordinal(k: int) -> str:
    return f"{k}{'th' if 10 <= k % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(k % 10, 'th')}"
