"""Integrators by name: every ODE run of anadyn goes through ``integrate``.

A service hands over a ``Problem``, plain callables for x' = f(t, x) and,
optionally, its Jacobian df/dx.  This layer owns what every run needs:
counting RHS and Jacobian calls (SciPy's ``nfev`` leaves out finite-difference
Jacobians), call and time budgets, a stall limit, and failure capture.

The stall limit holds for every run, budget or not: after ``STALL_CALLS`` RHS
calls in a row that take t less than ``STALL_FRACTION`` of the horizon
further, the run fails there as where the equations cannot be evaluated (the
rows before it kept, the message naming the time and state).  At that pace
the run would need more than STALL_CALLS / STALL_FRACTION = 2e13 calls: the
step size has collapsed, as at a singularity of the equations or of a law
(``1/(t - 0.5)``), where LSODA would otherwise step on without end.  The result is a
``Solution`` on the requested grid; failure comes back as data (``success``
False, ``message`` naming the time and state, the rows before it), never as
an exception.

    odeint   LSODA with its stepping loop in compiled code; switches between
             Adams (non-stiff) and BDF (stiff) by itself; analytic Jacobian
    LSODA, RK45, RK23, DOP853, Radau, BDF   scipy.integrate.solve_ivp (the
             implicit ones get the analytic Jacobian)
    auto     odeint, after the Jacobian eigenvalues at the start say how stiff
             the problem is (printed as the reason)
"""
from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..errors import ModelError
from ..model.info import METHODS

IVP_METHODS = METHODS[2:]             # scipy.integrate.solve_ivp's, after auto and odeint
IMPLICIT = ("Radau", "BDF", "LSODA")
STIFF_RATIO = 1000.0     # |lambda|max * horizon above this: explicit methods are step-limited
STALL_CALLS = 20_000     # RHS calls in a row ...
STALL_FRACTION = 1e-9    # ... taking t less than this fraction of the horizon further: stalled
#: what a right-hand side may raise at a state where the equations cannot be evaluated
EVALUATION_ERRORS = (np.linalg.LinAlgError, OverflowError, ValueError, ZeroDivisionError)


@dataclass(frozen=True)
class Problem:
    """x' = rhs(t, x), with d(x')/dx = jacobian(t, x) when known.

    ``names`` label the state in messages; ``diagnose(x)`` may add a note on
    why the equations fail near x (e.g. a nearly singular mass matrix).
    """
    rhs: Callable[[float, np.ndarray], np.ndarray]
    jacobian: Callable[[float, np.ndarray], np.ndarray] | None = None
    names: tuple[str, ...] = ()
    diagnose: Callable[[np.ndarray], str] | None = None


@dataclass
class Solution:
    t: np.ndarray                 # the grid rows computed (all of them on success)
    x: np.ndarray                 # rows x states
    method: str                   # the method that ran
    success: bool
    message: str
    rhs_calls: int = 0
    jacobian_calls: int = 0
    steps: int = 0
    wall: float = 0.0             # seconds in the integrator
    reason: str = ""              # why auto chose the method
    over_budget: "OverBudget | None" = None   # set when a call or time budget stopped it
    last: tuple[float, np.ndarray] | None = field(default=None, repr=False)


class OverBudget(Exception):
    """A run stopped by its RHS-call or time budget (``t``: the latest time reached)."""

    def __init__(self, calls: int, t: float, seconds: bool = False):
        super().__init__(f"over {'time' if seconds else 'budget'} after {calls} RHS calls "
                         f"at t = {t:g} s")
        self.calls, self.t, self.seconds = calls, t, seconds


class _Counted:
    """The problem's callables with counting, budgets and the first failure recorded.

    A state where the equations cannot be evaluated, or give non-finite
    values, is recorded and answered with NaNs, which no integrator steps over;
    so is every call once the run has stalled (the stall limit).
    """

    def __init__(self, problem: Problem, budget: int | None, seconds: float | None,
                 horizon: float = math.inf):
        self.problem, self.budget = problem, budget
        self.deadline = None if seconds is None else time.perf_counter() + seconds
        self.rhs_calls = self.jacobian_calls = 0
        self.t_reached = -math.inf
        self.stall_span = STALL_FRACTION * horizon      # progress that resets the stall count
        self.progress = (-math.inf, 0)                  # (t, calls) at the last such progress
        self.stalled = False
        self.failure: tuple[float, np.ndarray, str] | None = None

    def _fail(self, t: float, x: np.ndarray, why: str) -> None:
        if self.failure is None:
            self.failure = (float(t), np.array(x, dtype=float), why)

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        calls = self.rhs_calls
        if self.budget is not None and calls >= self.budget:
            raise OverBudget(calls, self.t_reached)
        if self.deadline is not None and calls % 64 == 0 and time.perf_counter() > self.deadline:
            raise OverBudget(calls, self.t_reached, seconds=True)
        self.rhs_calls = calls + 1
        self.t_reached = max(self.t_reached, float(t))
        if self.t_reached > self.progress[0] + self.stall_span:
            self.progress = (self.t_reached, calls)
        elif self.stalled or calls - self.progress[1] >= STALL_CALLS:
            self.stalled = True
            self._fail(t, x, f"the step size collapsed (a singularity of the equations or of "
                             f"a law?): {STALL_CALLS} RHS calls took t less than "
                             f"{STALL_FRACTION:g} of the horizon further")
            return np.full(len(x), np.nan)
        try:
            out = self.problem.rhs(t, x)
        except EVALUATION_ERRORS as err:
            self._fail(t, x, _why(err))
            return np.full(len(x), np.nan)
        if not math.isfinite(out.sum()):
            self._fail(t, x, "non-finite state derivative")
            return np.full(len(x), np.nan)
        return out

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        self.jacobian_calls += 1
        try:
            J = self.problem.jacobian(t, x)
        except EVALUATION_ERRORS as err:
            self._fail(t, x, _why(err))
            return np.full((len(x), len(x)), np.nan)
        if not np.isfinite(J).all():
            self._fail(t, x, "non-finite Jacobian")
        return J

    def finite_jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        """``jacobian`` with a failure (recorded) given as zeros, not NaN: solve_ivp's
        LU factorization raises on NaN, while a NaN RHS stops the step as it should."""
        return np.nan_to_num(self.jacobian(t, x), nan=0.0, posinf=0.0, neginf=0.0)


def _why(err: Exception) -> str:
    if isinstance(err, np.linalg.LinAlgError):
        return "singular mass matrix"
    return f"cannot evaluate the equations ({err})"


@dataclass(frozen=True)
class Stiffness:
    eigenvalues: np.ndarray
    fastest: float                # max |Re lambda|, 1/s
    horizon: float

    @property
    def ratio(self) -> float:
        """max |Re lambda| times the horizon: how many fastest time constants fit."""
        return self.fastest * self.horizon

    @property
    def stiff(self) -> bool:
        return self.ratio > STIFF_RATIO

    def describe(self) -> str:
        if self.fastest == 0:
            return "no decaying modes at the start"
        return (f"fastest time constant {1 / self.fastest:.3g} s over a {self.horizon:g} s "
                f"horizon (ratio {self.ratio:.3g}): {'stiff' if self.stiff else 'not stiff'}")


def eigenvalues(jacobian: Callable, t: float, x: np.ndarray) -> np.ndarray | None:
    """Eigenvalues of d(x')/dx at (t, x); None where the Jacobian is not finite
    or cannot be evaluated (the one eigenvalue scan every service uses)."""
    try:
        J = jacobian(t, x)
    except EVALUATION_ERRORS:
        return None
    if not np.isfinite(J).all():
        return None
    return np.linalg.eigvals(J)


def stiffness(problem: Problem, t: float, x: np.ndarray, horizon: float) -> Stiffness:
    """The fastest decay max |Re lambda| of the state Jacobian at (t, x)."""
    lam = eigenvalues(problem.jacobian, t, x) if problem.jacobian else None
    if lam is None:
        return Stiffness(np.array([]), 0.0, horizon)
    return Stiffness(lam, float(np.abs(lam.real).max(initial=0.0)), horizon)


def integrate(problem: Problem, x0: np.ndarray, grid: np.ndarray, method: str = "auto",
              rtol: float = 1e-10, atol: float = 1e-12, budget: int | None = None,
              seconds: float | None = None, stop_at_end: bool = False) -> Solution:
    """States on ``grid`` (grid[0] is the start) by ``method``.

    ``budget`` (RHS calls) and ``seconds`` stop a run early: the solution then
    has ``success`` False and ``over_budget`` set.  ``stop_at_end``: odeint
    never evaluates the RHS past grid[-1] (for a forcing defined only up to it).
    """
    if method not in METHODS:
        raise ModelError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    x0 = np.asarray(x0, dtype=float)
    reason = ""
    if method == "auto":
        analysis = stiffness(problem, grid[0], x0, grid[-1] - grid[0])
        reason = (f"{analysis.describe()}; odeint (LSODA) steps in compiled code and "
                  f"switches between Adams and BDF itself")
        method = "odeint"
    counted = _Counted(problem, budget, seconds, float(grid[-1] - grid[0]))
    if method == "odeint":      # imported before the clock starts, not inside a solve
        from . import odepack
        odepack.extension()
    else:
        import scipy.integrate  # noqa: F401
    start = time.perf_counter()
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")          # failures are reported as data below
        try:
            if not np.isfinite(counted.rhs(grid[0], x0)).all():     # fails where it starts
                solution = Solution(grid[:1], x0[None, :], method, False,
                                    "the equations fail at the start")
            elif method == "odeint":
                solution = _odeint(counted, x0, grid, rtol, atol, stop_at_end)
            else:
                solution = _solve_ivp(counted, x0, grid, method, rtol, atol)
        except OverBudget as over:
            solution = Solution(grid[:1], x0[None, :], method, False, str(over),
                                over_budget=over)
    solution.wall = time.perf_counter() - start
    solution.rhs_calls, solution.jacobian_calls = counted.rhs_calls, counted.jacobian_calls
    solution.reason = reason
    return solution if solution.over_budget else _cut_at_failure(counted, solution)


def _odeint(counted: _Counted, x0, grid, rtol, atol, stop_at_end: bool) -> Solution:
    from .odepack import odeint

    jacobian = counted.jacobian if counted.problem.jacobian else None
    x, info = odeint(counted.rhs, x0, grid, jacobian, rtol=rtol, atol=atol,
                     mxstep=10**6, tcrit=[grid[-1]] if stop_at_end else None, tfirst=True)
    ok = info["message"].startswith("Integration successful")
    steps = int(info["nst"][-1]) if len(info["nst"]) else 0
    if not ok:      # rows past the last time reached are not valid (nor is tcur there)
        reached = np.flatnonzero(grid <= min(info["tcur"].max(), counted.t_reached))
        x = x[: reached[-1] + 1] if len(reached) else x[:1]
    return Solution(grid[: len(x)], x, "odeint", ok, info["message"], steps=steps)


def _solve_ivp(counted: _Counted, x0, grid, method, rtol, atol) -> Solution:
    from scipy.integrate import solve_ivp

    jac = counted.finite_jacobian if method in IMPLICIT and counted.problem.jacobian else None
    sol = solve_ivp(counted.rhs, (grid[0], grid[-1]), x0, method=method, rtol=rtol, atol=atol,
                    jac=jac, dense_output=True)
    reached = grid[grid <= sol.t[-1]] if sol.status != 0 else grid
    x = sol.sol(reached).T if len(reached) > 1 else x0[None, :]
    x[0] = x0
    return Solution(reached, x, method, sol.status == 0, sol.message, steps=len(sol.t) - 1,
                    last=(float(sol.t[-1]), sol.y[:, -1].copy()))


def _cut_at_failure(counted: _Counted, solution: Solution) -> Solution:
    """Keep the rows before the first non-finite one; name the failure."""
    finite = np.isfinite(solution.x).all(axis=1)
    bad = np.flatnonzero(~finite)
    if len(bad):
        solution.t, solution.x = solution.t[: bad[0]], solution.x[: bad[0]]
        solution.success = False
    problem = counted.problem
    if counted.failure is not None and not solution.success:
        t, x, why = counted.failure
        solution.message = f"{why} at t = {t:.6g} s, state {_state(x, problem.names)}"
    elif not solution.success:
        t, x = solution.last or (solution.t[-1], solution.x[-1])
        note = problem.diagnose(x) if problem.diagnose else ""
        solution.message = (f"integration failed ({solution.method}: "
                            f"{solution.message.strip().rstrip('.')}{note}) "
                            f"at t = {t:.6g} s, state {_state(x, problem.names)}")
    return solution


def _state(x: np.ndarray, names: tuple[str, ...]) -> str:
    names = names or tuple(f"x{k}" for k in range(len(x)))
    return "(" + ", ".join(f"{n}={v:.6g}" for n, v in zip(names, x)) + ")"


# ----------------------------------------------------------------------------
# every run knows its error
# ----------------------------------------------------------------------------
ESTIMATE_FACTOR = 1e-3             # estimate_error re-solves at rtol * 1e-3 ...
ESTIMATE_FLOOR = 1e-13             # ... but not below 1e-13


def state_scale(reference: np.ndarray) -> np.ndarray:
    """s_i = max(1, max_k |xref_i|): absolute error for O(1) states, relative for large ones."""
    return np.maximum(1.0, np.abs(reference).max(axis=0))


def state_error(x: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """(max over the grid, value at the last row) of max_i |x_i - xref_i| / s_i."""
    if x.shape != reference.shape:
        raise ValueError(f"solution rows {x.shape} do not match the reference {reference.shape}")
    per_row = (np.abs(x - reference) / state_scale(reference)).max(axis=1)
    return float(per_row.max()), float(per_row[-1])


def estimate_error(problem: Problem, solution: Solution, rtol: float, atol: float) -> float:
    """Estimated global error of a run: max over its grid, in ``state_error``'s norm.

    The run is repeated by the same method (``auto``'s choice, e.g. odeint)
    at rtol * 1e-3 and atol * 1e-3 (rtol not below 1e-13); by tolerance
    proportionality the re-solve's own error is ~1000x smaller, so the
    difference is the run's error.  At rtol <= 1e-13 there is no tighter
    re-solve and the estimate is only an upper bound of the re-solve noise.
    NaN if the re-solve fails.
    """
    fine_rtol = max(rtol * ESTIMATE_FACTOR, ESTIMATE_FLOOR)
    fine = integrate(problem, solution.x[0], solution.t, solution.method, fine_rtol,
                     atol * (fine_rtol / rtol))
    if not fine.success or len(fine.t) != len(solution.t):
        return math.nan
    return state_error(solution.x, fine.x)[0]
