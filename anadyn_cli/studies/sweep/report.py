"""A sweep's results and what is written and shown of them: ``SweepResult``,
sweep.csv, sweep.json (``summary``), sweep.png and the terminal's table and lines."""
from __future__ import annotations

import csv
import io
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import files as output
from .plan import Plan

STATUSES = ("ok", "failed", "invalid", "error")
JSON_ROWS = 10_000             # sweep.json lists the rows up to this many samples


@dataclass
class SweepResult:
    plan: Plan
    rows: list[dict]                       # one per sample, in design order
    executor: str
    workers: int
    address: str
    wall: float                            # s, running the samples
    solve_seconds: float                   # summed over the samples
    sample_seconds: float
    timings: dict = field(default_factory=dict)

    @property
    def counts(self) -> dict:
        counts = {s: 0 for s in STATUSES}
        for row in self.rows:
            counts[row["status"]] += 1
        return counts

    @property
    def samples_per_second(self) -> float:
        return len(self.rows) / self.wall if self.wall > 0 else math.inf



def _cell(value) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


def csv_text(result: SweepResult) -> str:
    """One row per sample; numbers in full double precision, empty where not computed."""
    columns = result.plan.columns
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in result.rows:
        writer.writerow([_cell(row.get(c, math.nan)) for c in columns])
    return buffer.getvalue()


def _numbers(result: SweepResult, column: str, status: str = "ok") -> np.ndarray:
    return np.array([float(r.get(column, math.nan)) if r["status"] == status else math.nan
                     for r in result.rows])


def metric_summary(result: SweepResult) -> dict:
    """Per metric over the ok samples: min, max, mean, sd, percentiles, where min and max are."""
    names = result.plan.design.names
    summary = {}
    for column in result.plan.payload.columns:
        values = _numbers(result, column)
        ok = np.isfinite(values)
        if not ok.any():
            continue
        v = values[ok]
        low, high = int(np.nanargmin(values)), int(np.nanargmax(values))
        summary[column] = {
            "min": float(v.min()), "max": float(v.max()), "mean": float(v.mean()),
            "sd": float(v.std(ddof=1)) if len(v) > 1 else 0.0,
            "p5": float(np.percentile(v, 5)), "p50": float(np.percentile(v, 50)),
            "p95": float(np.percentile(v, 95)),
            "at_min": {n: result.rows[low][n] for n in names},
            "at_max": {n: result.rows[high][n] for n in names}}
    return summary


def capacity(result: SweepResult) -> dict | None:
    """For a one-name grid or list under --max/--min: the largest and smallest values
    from which every value towards the nominal one stays within the limits."""
    plan = result.plan
    if not plan.judged or len(plan.design.specs) != 1 or plan.design.specs[0].random:
        return None
    name = plan.design.names[0]
    pairs = sorted((r[name], bool(r.get("within_limits"))) for r in result.rows)
    values = [v for v, _ in pairs]
    within = [w for _, w in pairs]
    info: dict = {"name": name, "within": [v for v, w in pairs if w],
                  "largest_within": max((v for v, w in pairs if w), default=None),
                  "smallest_within": min((v for v, w in pairs if w), default=None)}
    # contiguous run upward from the smallest value that is within
    if any(within):
        first = within.index(True)
        last = first
        while last + 1 < len(within) and within[last + 1]:
            last += 1
        info["contiguous_from"], info["contiguous_to"] = values[first], values[last]
        if last + 1 < len(values):
            miss = next(r for r in result.rows if r[name] == values[last + 1])
            info["next_value"], info["next_miss"] = values[last + 1], miss.get("limit_miss", "")
    return info


def summary(result: SweepResult) -> dict:
    """Key figures (``sweep.json``)."""
    plan = result.plan
    folding = plan.folding
    counts = result.counts
    data = {
        "robot": plan.robot.name, "source": plan.robot.source,
        "formulation": plan.payload.formulation, "evaluator": "closed-form",
        "command": plan.payload.command,
        "design": plan.design.kind, "shape": list(plan.design.shape),
        "draws": plan.design.draws, "seed": plan.design.seed,
        "vary": [{**s.to_dict(), "type": folding.kinds[s.name],
                  "nominal": folding.nominal[s.name]} for s in plan.design.specs],
        "follows": {k: list(v) for k, v in folding.follows.items() if v},
        "settings": plan.settings, "metrics": list(plan.payload.groups),
        "settle_band": plan.payload.settle_band,
        "columns": plan.columns, "samples": len(result.rows), **counts,
        "failures": _failures(result),
        "bounds": [{"metric": m, "kind": k, "bound": b} for m, k, b in plan.bounds],
        "within_limits": (sum(int(r.get("within_limits", 0)) for r in result.rows)
                          if plan.judged else None),
        "capacity": capacity(result),
        "summary": metric_summary(result),
        "executor": {"kind": result.executor, "workers": result.workers,
                     "address": result.address},
        "wall_s": result.wall, "samples_per_second": result.samples_per_second,
        "solve_s": result.solve_seconds, "sample_s": result.sample_seconds,
        "cost_over_solve": (result.wall * result.workers / result.solve_seconds
                            if result.solve_seconds > 0 else None),
        "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
    }
    if len(result.rows) <= JSON_ROWS:
        data["rows"] = [{c: (None if isinstance(r.get(c), float) and math.isnan(r[c])
                             else r.get(c)) for c in plan.columns} for r in result.rows]
    return data


def _failures(result: SweepResult) -> dict:
    """The first reason of each kind (status), with how many samples share the status."""
    seen = {}
    for row in result.rows:
        if row["status"] != "ok" and row["status"] not in seen:
            seen[row["status"]] = {name: row[name] for name in result.plan.design.names}
            seen[row["status"]]["reason"] = row["reason"]
    return seen


@output.one_set
def write(result: SweepResult, out: Path, plot: bool = True) -> list[Path]:
    """sweep.csv, sweep.png (unless ``plot`` is off) and sweep.json in ``out``: rendered
    first, then written with signals held (``progress.uninterrupted``), so an
    interruption leaves all three of this sweep or those there before."""
    from ... import progress

    out = output.prepare_dir(out)
    start = time.perf_counter()
    contents = {out / "sweep.csv": csv_text(result).encode("utf-8")}
    if plot:
        from ..sweep_plot import figure
        from ...output import plots

        contents[out / "sweep.png"] = plots.figure_bytes(
            figure(result, capacity(result), headline(result)), "png")
    result.timings["write"] = time.perf_counter() - start
    with progress.uninterrupted():
        for path, data in contents.items():
            output.write_bytes(path, data)
        output.write_json(out / "sweep.json", summary(result))
    return [*contents, out / "sweep.json"]


def headline(result: SweepResult) -> list[str]:
    """The metric columns worth a table: peaks, tracking, settling, energy, final states."""
    columns = result.plan.payload.columns
    keep = [c for c in columns if c.startswith("peak_")]
    keep += [c for c in ("tracking_error", "final_error", "settling_time", "energy_error",
                         "check_passed") if c in columns]
    if len(keep) < 6:
        keep += [c for c in columns if c.startswith("final_") and not c.startswith("final_d")
                 and c != "final_error"][: 6 - len(keep)]
    return keep


def _short(value) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def table(result: SweepResult, rows: int = 20) -> str:
    """All samples (up to ``rows``), else each metric's spread over the samples."""
    from ...output import tables

    plan = result.plan
    names = list(plan.design.names)
    columns = headline(result)
    if len(result.rows) <= rows:
        heads = names + ["status"] + columns + (["limits"] if plan.judged else [])
        body = []
        for r in result.rows:
            line = [_short(r[n]) for n in names] + [r["status"]]
            line += [_short(r.get(c, math.nan)) for c in columns]
            if plan.judged:
                line.append("ok" if r.get("within_limits") else "MISS")
            body.append(line)
        return tables.render(heads, body, min_width=8)
    stats = metric_summary(result)
    heads = ["metric", "min", "p5", "median", "p95", "max", "at max"]
    body = []
    for c in columns:
        s = stats.get(c)
        if s is None:
            continue
        where = ", ".join(f"{n}={_short(v)}" for n, v in s["at_max"].items())
        body.append([c, *(_short(s[k]) for k in ("min", "p5", "p50", "p95", "max")), where])
    return tables.render(heads, body, min_width=8)


def lines(result: SweepResult) -> list[str]:
    """Counts, limits, capacity and speed, one line each."""
    plan = result.plan
    counts = result.counts
    out = [f"{len(result.rows)} samples: " + ", ".join(f"{counts[s]} {s}" for s in STATUSES
                                                        if counts[s] or s == "ok")]
    for status, first in _failures(result).items():
        where = ", ".join(f"{n}={_short(v)}" for n, v in first.items() if n != "reason")
        out.append(f"first {status}: {where}: {first['reason']}")
    if plan.judged:
        limits = ", ".join([f"{m} {'<=' if k == 'max' else '>='} {b:g}" for m, k, b in plan.bounds]
                           + (["the file's joint limits"]
                              if "limits_passed" in plan.payload.columns else []))
        within = sum(int(r.get("within_limits", 0)) for r in result.rows)
        out.append(f"limits {limits}: {within} of {len(result.rows)} samples within")
        cap = capacity(result)
        if cap and cap.get("contiguous_to") is not None:
            text = (f"{cap['name']}: within the limits from {cap['contiguous_from']:g} to "
                    f"{cap['contiguous_to']:g}")
            if cap.get("next_value") is not None:
                text += f"; {cap['next_value']:g} misses ({cap['next_miss']})"
            out.append(text)
        elif cap:
            out.append(f"{cap['name']}: no value within the limits")
    where = (f"{result.workers} local process{'es' if result.workers != 1 else ''}"
             if result.executor == "local processes" else
             "this process" if result.executor == "this process" else
             f"Dask at {result.address} ({result.workers} workers)")
    out.append(f"ran {len(result.rows)} samples in {result.wall:.2f} s on {where}: "
               f"{result.samples_per_second:.1f} samples/s; solves {result.solve_seconds:.2f} s "
               f"in all")
    return out

