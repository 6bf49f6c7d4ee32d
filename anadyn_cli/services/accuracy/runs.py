"""The timed runs a work-precision study is made of: one budgeted run of the smooth
field (``run``), the event-driven runs of a scene with rigid contacts (``RigidRuns``),
and the references (``references``): the first candidates that finish, tight."""
from __future__ import annotations

import gc
import time
from dataclasses import dataclass

import numpy as np

from ...numeric import integrators
from ...numeric.integrators import Problem
from ...numeric.model import NumericModel

ATOL_RATIO = 1e-2                  # atol = rtol * ATOL_RATIO, like anadyn's defaults
REFERENCE_CALLS = 500_000          # RHS calls per reference attempt ...
REFERENCE_SECONDS = 30.0           # ... and seconds
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
        from ...numeric import impacts

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
