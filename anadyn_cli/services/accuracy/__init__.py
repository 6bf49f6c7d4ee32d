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

import math
import time

from ... import errors
from ...errors import NumericalError
from ...numeric import constrained, contact_run, integrators
from ...numeric.build import computation
from ...numeric.integrators import state_error
from ...numeric.model import NumericModel
from ...numeric.settings import output_grid, resolve
from .report import (AccuracyStudy, Row, csv_text, figure, plot_bytes, reference_lines,
                     summary, table, write)
from .runs import (ATOL_RATIO, REFERENCE_CALLS, REFERENCE_SECONDS, Reference, RigidRuns,
                   family, reference_for, references, run)

TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
MAX_CALLS = 20_000                 # RHS calls per study run
REPEATS = 3
MIN_TIMED = 0.05                   # cheap runs repeat (up to MAX_REPEATS) until 50 ms in all
MAX_REPEATS = 20

__all__ = ["study", "AccuracyStudy", "Row", "Reference", "RigidRuns", "ATOL_RATIO", "family",
           "run", "references", "reference_for", "state_error", "csv_text", "summary",
           "figure", "plot_bytes", "reference_lines", "table", "write"]


def _over_budget(method: str, rtol: float, atol: float, t: float, grid,
                 max_calls: int, ref) -> Row:
    """The row of a run stopped at ``max_calls`` RHS calls at time ``t``, with the calls
    the whole grid would take at its pace."""
    horizon = grid[-1] - grid[0]
    reached = max(t - grid[0], 0.0)
    projected = (f"; ~{max_calls * horizon / reached:.2g} projected"
                 if reached > 0 else "")
    return Row(method, rtol, atol, "over budget", rhs_calls=max_calls,
               reference=ref.describe(), note=(
                   f"stopped at {max_calls} RHS calls, t = {t:.3g} of "
                   f"{grid[-1]:g} s{projected}"))


def _drift_and_events(row: Row, model: NumericModel, rigid, grid, solution,
                      ref) -> None:
    """A closed chain's constraint drift (part of the error) and, with contacts, the
    error of the contact events' times against the reference's, into ``row``."""
    if constrained.is_constrained(model):
        row.drift = max(constrained.drift(model, solution.t, solution.x))
    if rigid is not None:                     # the located events' times
        row.event_error = contact_run.event_error(
            rigid.events[(row.method, row.rtol)], rigid.events[(ref.method, ref.rtol)])
    elif model.contact_names:                 # the contact events' times
        row.event_error = contact_run.event_error(*(
            contact_run.run_report(model, grid, x).events() for x in (solution.x, ref.x)))


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
                over_at = rtol
                rows.append(_over_budget(method, rtol, atol, solution.over_budget.t, grid,
                                         max_calls, ref))
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
            _drift_and_events(rows[-1], model, rigid, grid, solution, ref)
    timings["study"] = time.perf_counter() - start
    return AccuracyStudy(robot, settings.t_end, settings.output_step, grid, refs, given_up,
                         ref_error, rows, repeats, max_calls, timings, computation(model))
