"""Integrators by name, and the stiffness analysis behind ``auto``.

Every method returns a ``Solution`` on the requested grid; failure comes back
as data (``success`` False, ``message``, the rows before it), never as an
exception.  RHS and Jacobian calls are counted by ``CompiledRobot`` itself:
SciPy's own ``nfev`` leaves out the calls of finite-difference Jacobians.

    odeint   LSODA with its stepping loop in compiled code; switches between
             Adams (non-stiff) and BDF (stiff) by itself; analytic Jacobian
    LSODA, RK45, RK23, DOP853, Radau, BDF   scipy.integrate.solve_ivp (the
             implicit ones get the analytic Jacobian)
    auto     odeint, after the Jacobian eigenvalues at the start say how stiff
             the problem is (printed as the reason)
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .model import CompiledRobot
from ..errors import ModelError

IVP_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
IMPLICIT = ("Radau", "BDF", "LSODA")
METHODS = ("auto", "odeint", *IVP_METHODS)
STIFF_RATIO = 1000.0     # |lambda|max * horizon above this: explicit methods are step-limited


@dataclass
class Solution:
    t: np.ndarray                 # the grid rows computed (all of them on success)
    x: np.ndarray                 # rows x 2n states [q, dq]
    method: str                   # the method that ran
    success: bool
    message: str
    rhs_calls: int = 0
    jacobian_calls: int = 0
    steps: int = 0
    wall: float = 0.0             # seconds in the integrator
    reason: str = ""              # why auto chose the method
    notes: dict = field(default_factory=dict)
    last: tuple[float, np.ndarray] | None = None   # last accepted step, when it failed


@dataclass(frozen=True)
class Stiffness:
    eigenvalues: np.ndarray
    fastest: float                # max |Re lambda|, 1/s
    slowest: float                # min |Re lambda| over the decaying modes, 1/s
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


def stiffness(robot: CompiledRobot, t: float, x: np.ndarray, horizon: float) -> Stiffness:
    """Eigenvalues of the state Jacobian at (t, x)."""
    J = robot.jacobian(t, x)
    if not np.isfinite(J).all():
        return Stiffness(np.array([]), 0.0, 0.0, horizon)
    eigenvalues = np.linalg.eigvals(J)
    real = np.abs(eigenvalues.real)
    decaying = real[real > 1e-12]
    return Stiffness(eigenvalues, float(real.max(initial=0.0)),
                     float(decaying.min(initial=0.0)), horizon)


def integrate(robot: CompiledRobot, x0: np.ndarray, grid: np.ndarray, method: str = "auto",
              rtol: float = 1e-10, atol: float = 1e-12) -> Solution:
    """States on ``grid`` (grid[0] is the start) by ``method``."""
    if method not in METHODS:
        raise ModelError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    reason = ""
    if method == "auto":
        analysis = stiffness(robot, grid[0], x0, grid[-1] - grid[0])
        reason = (f"{analysis.describe()}; odeint (LSODA) steps in compiled code and "
                  f"switches between Adams and BDF itself")
        method = "odeint"
    robot.reset_counters()
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # failures are reported as data below
        if not np.isfinite(robot.rhs(grid[0], x0)).all():     # fails where it starts
            solution = Solution(grid[:1], np.array(x0, dtype=float)[None, :], method, False,
                                "the equations fail at the start")
        elif method == "odeint":
            solution = _odeint(robot, x0, grid, rtol, atol)
        else:
            solution = _solve_ivp(robot, x0, grid, method, rtol, atol)
    solution.wall = time.perf_counter() - start
    solution.rhs_calls, solution.jacobian_calls = robot.rhs_calls, robot.jacobian_calls
    solution.reason = reason
    return _cut_at_failure(robot, solution)


def _odeint(robot, x0, grid, rtol, atol) -> Solution:
    from scipy.integrate import odeint

    x, info = odeint(robot.rhs_tfirst, x0, grid, Dfun=lambda x, t: robot.jacobian(t, x),
                     rtol=rtol, atol=atol, full_output=True, mxstep=10**6)
    ok = info["message"].startswith("Integration successful")
    used = info["mused"][: max(1, len(grid) - 1)]
    notes = {"bdf_fraction": float(np.mean(used == 2)) if len(used) else 0.0}
    steps = int(info["nst"][-1]) if len(info["nst"]) else 0
    if not ok:      # rows past the last time reached are not valid
        reached = np.flatnonzero(grid <= info["tcur"].max())
        x = x[: reached[-1] + 1] if len(reached) else x[:1]
    return Solution(grid[: len(x)], x, "odeint", ok, info["message"], steps=steps, notes=notes)


def _solve_ivp(robot, x0, grid, method, rtol, atol) -> Solution:
    from scipy.integrate import solve_ivp

    jac = robot.finite_jacobian if method in IMPLICIT else None
    sol = solve_ivp(robot.rhs, (grid[0], grid[-1]), x0, method=method, rtol=rtol, atol=atol,
                    jac=jac, dense_output=True)
    reached = grid[grid <= sol.t[-1]] if sol.status != 0 else grid
    x = sol.sol(reached).T if len(reached) > 1 else x0[None, :]
    x[0] = x0
    return Solution(reached, x, method, sol.status == 0, sol.message, steps=len(sol.t) - 1,
                    last=(float(sol.t[-1]), sol.y[:, -1].copy()))


def _cut_at_failure(robot: CompiledRobot, solution: Solution) -> Solution:
    """Keep the rows before the first non-finite one; name the failure."""
    finite = np.isfinite(solution.x).all(axis=1)
    bad = np.flatnonzero(~finite)
    if len(bad):
        solution.t, solution.x = solution.t[: bad[0]], solution.x[: bad[0]]
        solution.success = False
    if robot.failure is not None and not solution.success:
        t, x, why = robot.failure
        solution.message = f"{why} at t = {t:.6g} s, state {_state(x, robot)}"
    elif not solution.success:
        t, x = solution.last or (solution.t[-1], solution.x[-1])
        solution.message = (f"integration failed ({solution.method}: "
                            f"{solution.message.strip().rstrip('.')}{_conditioning(robot, x)}) "
                            f"at t = {t:.6g} s, state {_state(x, robot)}")
    return solution


def _conditioning(robot: CompiledRobot, x: np.ndarray) -> str:
    """A note when the mass matrix at ``x`` is nearly singular (the usual cause)."""
    n = robot.n
    M = robot.mfb(x[:n, None], x[n:, None])[0][0]
    d = np.sqrt(np.abs(np.diag(M)))
    if not np.isfinite(M).all() or not d.all():
        return "; the mass matrix is singular there"
    condition = np.linalg.cond(M / np.outer(d, d))
    return (f"; the mass matrix is nearly singular there, condition number {condition:.3g}"
            if condition > 1e10 else "")


def _state(x: np.ndarray, robot: CompiledRobot) -> str:
    names = [*robot.coordinates, *("d" + c for c in robot.coordinates)]
    return "(" + ", ".join(f"{n}={v:.6g}" for n, v in zip(names, x)) + ")"
