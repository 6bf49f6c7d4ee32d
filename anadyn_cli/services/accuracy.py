"""Work-precision study: error against run time for every integrator.

For a robot's scene (its feedback laws, horizon and output grid) every
method in ``integrators.METHODS`` runs at every relative tolerance (default
1e-3 ... 1e-10, atol = rtol * 1e-2), and each run is scored against a
reference solution on the output grid:

    error(t_k) = max_i |x_i(t_k) - xref_i(t_k)| / s_i,   s_i = max(1, max_k |xref_i(t_k)|)

i.e. absolute for states of order one or smaller (rad, m, rad/s, m/s) and
relative to the state's largest magnitude for larger ones (a fast spin);
``max_error`` is the maximum over the grid, ``final_error`` the value at the
last row.  Run time is the minimum over ``repeats`` timed calls of
``integrators.integrate`` (for ``auto`` that includes its stiffness
analysis; with more than one repeat, runs of a few ms repeat until 50 ms
in all, at most 20 times, as these machines are noisy); RHS and Jacobian
calls and steps come from the first run.

The reference (Hairer-Wanner, SciML DiffEqDevTools practice): two solutions
at very tight tolerance from different methods, the first two of DOP853 at
rtol 1e-13, LSODA (solve_ivp) at rtol 1e-13, Radau at rtol 1e-12 and BDF at
rtol 1e-12 (the implicit ones with the analytic Jacobian) that finish within
the reference budget (500,000 RHS calls or 30 s each).  Their difference,
in the same norm, is printed as the reference's own error estimate.  Each
row is scored against the first reference from a different method family
than its own (LSODA, odeint and auto are one family), so a method is never
judged against itself: on a non-stiff scene DOP853 judges everything but
DOP853, which LSODA judges; on a stiff one DOP853 is skipped without a try
(its stability bound alone, ~2 |lambda|max T calls, is over budget) and
Radau judges the LSODA family.  LSODA comes before Radau because at these
tolerances Radau's Newton iterations cost 10-50x more RHS calls (36,000
against 5,000 on RR) for the same agreement with DOP853 (~1e-12).

Cost cap: a run that needs more than ``max_calls`` RHS calls is stopped
there and shown as ``over budget`` with the time it reached; tighter
tolerances of the same method are then ``skipped``, since a method's call
count does not fall as the tolerance tightens.  On the stiff RR scene this
is what keeps the explicit methods (~50,000 calls whatever the tolerance)
from dominating the study.

``estimate_error`` gives any run its global error by a re-solve at a 1000x
tighter tolerance (``anadyn simulate --estimate-error``).

On a scene with contacts each run also gets ``event_error``: the largest difference
between its touch-down and lift-off times and its reference's, both found from the
output rows (``contact_run``); inf when a bounce is missing or extra.  With rigid
contacts (``numeric.impacts``) the runs go from event to event with solve_ivp's
methods only (auto and odeint have no dense output to locate events on), and
``event_error`` compares the events each run located (touch-downs, lift-offs, slips,
sticks) with the reference's.
"""
from __future__ import annotations

import csv
import io
import gc
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import errors
from ..errors import NumericalError
from ..model.info import RobotInfo
from ..numeric import constrained, contact_run, integrators
from ..numeric.build import computation
from ..numeric.integrators import Problem, state_error
from ..numeric.model import NumericModel
from ..numeric.settings import output_grid, resolve
from .. import files as output

TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
ATOL_RATIO = 1e-2                  # atol = rtol * ATOL_RATIO, like anadyn's defaults
MAX_CALLS = 20_000                 # RHS calls per study run
REFERENCE_CALLS = 500_000          # RHS calls per reference attempt ...
REFERENCE_SECONDS = 30.0           # ... and seconds
REPEATS = 3
MIN_TIMED = 0.05                   # cheap runs repeat (up to MAX_REPEATS) until 50 ms in all
MAX_REPEATS = 20
REFERENCE_CANDIDATES = (("DOP853", 1e-13), ("LSODA", 1e-13), ("Radau", 1e-12), ("BDF", 1e-12))
EXPLICIT = ("RK45", "RK23", "DOP853")


def family(method: str) -> str:
    """Methods that share an algorithm: auto runs odeint, which is LSODA."""
    return "LSODA" if method in ("auto", "odeint", "LSODA") else method


def run(problem: Problem, x0: np.ndarray, grid: np.ndarray, method: str, rtol: float,
        atol: float, budget: int | None = None, seconds: float | None = None):
    """(solution, wall seconds) of one budgeted, timed run.

    The cyclic garbage collector is off while it runs, as in ``timeit``: its
    full passes over the references' many objects would otherwise land in
    whichever runs come first and double their times.
    """
    return _timed(lambda: integrators.integrate(problem, x0, grid, method, rtol, atol,
                                                budget, seconds))


def _timed(call):
    """(call(), wall seconds), the cyclic garbage collector off while it runs."""
    enabled = gc.isenabled()
    gc.disable()
    start = time.perf_counter()
    try:
        result = call()
    finally:
        if enabled:
            gc.enable()
    return result, time.perf_counter() - start


class RigidRuns:
    """Runs of a scene with rigid contacts (``numeric.impacts.run``: from event to event,
    solve_ivp's methods only), timed as ``run``; ``events[(method, rtol)]``: the events
    each located (touch-downs, lift-offs, slips, sticks: an impact's share on a closed
    contact left out), for ``event_error``.  No call budget: an event-driven run has
    no stiffness to blow it up."""

    def __init__(self, model: NumericModel, grid: np.ndarray):
        self.model, self.grid, self.events = model, grid, {}

    def __call__(self, method: str, rtol: float, atol: float, budget: int | None = None,
                 seconds: float | None = None):
        from ..numeric import impacts

        ran, wall = _timed(lambda: impacts.run(self.model, self.grid, method, rtol, atol))
        self.events[(method, rtol)] = [e for e in ran.contacts.located
                                       if e["event"] != "impulse"]
        return ran.solution, wall


# ----------------------------------------------------------------------------
# references
# ----------------------------------------------------------------------------
@dataclass
class Reference:
    method: str
    rtol: float
    atol: float
    x: np.ndarray | None           # states on the grid (None when not available)
    wall: float = 0.0
    rhs_calls: int = 0
    jacobian_calls: int = 0
    steps: int = 0
    note: str = ""

    @property
    def ok(self) -> bool:
        return self.x is not None

    def describe(self) -> str:
        return f"{self.method} rtol {self.rtol:g}"


def _stability_bound(problem: Problem, x0: np.ndarray, grid: np.ndarray) -> float:
    """Lower bound on DOP853's RHS calls from the fastest decay at the start.

    DOP853's stability interval on the negative real axis is about 6/h, and it
    makes 12 RHS calls per step: calls >= 12 * |lambda| T / 6 = 2 |lambda| T.
    """
    analysis = integrators.stiffness(problem, grid[0], x0, grid[-1] - grid[0])
    return 2.0 * analysis.fastest * analysis.horizon


def references(problem: Problem, x0: np.ndarray, grid: np.ndarray, count: int = 2,
               budget: int = REFERENCE_CALLS, exclude: tuple[str, ...] = (),
               candidates=REFERENCE_CANDIDATES, seconds: float = REFERENCE_SECONDS,
               rigid: RigidRuns | None = None) -> tuple[list[Reference], list[Reference]]:
    """The first ``count`` candidates that finish within ``budget`` RHS calls and ``seconds``.

    Candidates whose family is in ``exclude`` are not tried; with ``rigid`` the runs
    are its own (``problem`` unused).  Returns (references, attempts that were given up,
    with the reason in ``note``).
    """
    found: list[Reference] = []
    given_up: list[Reference] = []
    excluded = {family(m) for m in exclude}
    for method, rtol in candidates:
        if len(found) == count:
            break
        if family(method) in excluded:
            continue
        atol = rtol * ATOL_RATIO
        if method in EXPLICIT and rigid is None:
            bound = _stability_bound(problem, x0, grid)
            if bound > budget:
                given_up.append(Reference(method, rtol, atol, None, note=(
                    f"skipped: stiff, its stability bound alone is ~{bound:.2g} RHS calls "
                    f"(budget {budget})")))
                continue
        solution, wall = (rigid(method, rtol, atol) if rigid is not None else
                          run(problem, x0, grid, method, rtol, atol, budget, seconds))
        over = solution.over_budget
        if over is not None:
            limit = f"{seconds:g} s" if over.seconds else f"{budget} RHS calls"
            given_up.append(Reference(method, rtol, atol, None, wall, over.calls, note=(
                f"gave up: over {limit} at t = {over.t:.4g} of {grid[-1]:g} s")))
            continue
        if not solution.success:
            given_up.append(Reference(method, rtol, atol, None, wall, solution.rhs_calls,
                                      note=f"failed: {solution.message}"))
            continue
        found.append(Reference(method, rtol, atol, solution.x, wall, solution.rhs_calls,
                               solution.jacobian_calls, solution.steps))
    return found, given_up


def reference_for(method: str, refs: list[Reference]) -> Reference | None:
    """The first reference from a different method family than ``method``."""
    return next((r for r in refs if family(r.method) != family(method)), None)


# ----------------------------------------------------------------------------
# the study
# ----------------------------------------------------------------------------
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


def study(model: NumericModel, methods=integrators.METHODS,
          tolerances=TOLERANCES, repeats: int = REPEATS, max_calls: int = MAX_CALLS,
          reference_calls: int = REFERENCE_CALLS,
          reference_seconds: float = REFERENCE_SECONDS, t_end: float | None = None,
          output_step: float | None = None, progress=None) -> AccuracyStudy:
    """Run every (method, rtol) against the references; see the module docstring."""
    errors.check("repeats", repeats)
    errors.check("max_calls", max_calls)
    errors.check("reference_calls", reference_calls)
    robot = model.info
    settings = resolve(robot, t_end=t_end, output_step=output_step)
    grid = output_grid(settings.t_end, settings.output_step)
    x0 = model.initial_state()
    rigid = RigidRuns(model, grid) if model.rigid_contacts is not None else None
    problem = model.problem() if rigid is None else None
    if rigid is not None:                         # the event-driven runs: solve_ivp's
        methods = [m for m in methods if m in integrators.IVP_METHODS]

    def runner(method: str, rtol: float, atol: float, budget: int | None = None):
        return (rigid(method, rtol, atol) if rigid is not None else
                run(problem, x0, grid, method, rtol, atol, budget))

    timings: dict = {}
    start = time.perf_counter()
    refs, given_up = references(problem, x0, grid, 2, reference_calls,
                                seconds=reference_seconds, rigid=rigid)
    timings["references"] = time.perf_counter() - start
    if not refs:
        raise NumericalError(f"{robot.source}: no reference solution: " +
                             "; ".join(f"{g.describe()} {g.note}" for g in given_up))
    ref_error = state_error(refs[0].x, refs[1].x)[0] if len(refs) > 1 else math.nan
    rows: list[Row] = []
    start = time.perf_counter()
    for method in methods:
        over_at: float | None = None
        for rtol in tolerances:
            atol = rtol * ATOL_RATIO
            ref = reference_for(method, refs)
            if ref is None:
                rows.append(Row(method, rtol, atol, "no reference",
                                note="no reference from another method"))
                continue
            if over_at is not None:
                rows.append(Row(method, rtol, atol, "skipped", reference=ref.describe(),
                                note=f"over budget at rtol {over_at:.0e}"))
                continue
            if progress:
                progress(method, rtol)
            solution, wall = runner(method, rtol, atol, max_calls)
            if solution.over_budget is not None:
                over = solution.over_budget
                over_at = rtol
                horizon = grid[-1] - grid[0]
                reached = max(over.t - grid[0], 0.0)
                projected = (f"; ~{max_calls * horizon / reached:.2g} projected"
                             if reached > 0 else "")
                rows.append(Row(method, rtol, atol, "over budget", rhs_calls=max_calls,
                                reference=ref.describe(), note=(
                                    f"stopped at {max_calls} RHS calls, t = {over.t:.3g} of "
                                    f"{grid[-1]:g} s{projected}")))
                continue
            if not solution.success:
                rows.append(Row(method, rtol, atol, "failed", solution.method,
                                rhs_calls=solution.rhs_calls, reference=ref.describe(),
                                note=solution.message))
                continue
            walls = [wall]
            while len(walls) < repeats or (repeats > 1 and sum(walls) < MIN_TIMED
                                           and len(walls) < MAX_REPEATS):
                walls.append(runner(method, rtol, atol)[1])
            max_error, final_error = state_error(solution.x, ref.x)
            rows.append(Row(method, rtol, atol, "ok", solution.method, max_error, final_error,
                            min(walls), solution.rhs_calls, solution.jacobian_calls,
                            solution.steps, ref.describe()))
            if constrained.is_constrained(model):     # constraint drift, part of the error
                rows[-1].drift = max(constrained.drift(model, solution.t, solution.x))
            if rigid is not None:                     # the located events' times
                rows[-1].event_error = contact_run.event_error(
                    rigid.events[(method, rtol)], rigid.events[(ref.method, ref.rtol)])
            elif model.contact_names:                 # the contact events' times
                rows[-1].event_error = contact_run.event_error(*(
                    contact_run.run_report(model, grid, x).events() for x in (solution.x,
                                                                              ref.x)))
    timings["study"] = time.perf_counter() - start
    return AccuracyStudy(robot, settings.t_end, settings.output_step, grid, refs, given_up,
                         ref_error, rows, repeats, max_calls, timings, computation(model))


# ----------------------------------------------------------------------------
# output
# ----------------------------------------------------------------------------
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
    from ..output.plots import figure_bytes

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
    from ..output.plots import plot_path

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
    from ..output.tables import repeat_header

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
