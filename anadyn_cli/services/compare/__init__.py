"""Lagrange against Kane: the two formulations share only the kinematics, so
their agreement checks both.  For each robot:

(a) symbolic: every entry of M, F and B by Lagrange minus the same entry by
    Kane must be identically zero.  Small systems come out of ``derive`` in
    canonical form (``anadyn_cli.canonical``), so equal entries cancel on
    subtraction.  Any other difference is put in canonical form itself, one
    entry at a time, smallest first, while the estimated size of its full
    expansion (``canonical.expanded_terms``) stays within a per-entry and a
    per-robot budget of terms; that estimate, not a clock, bounds the time.
    Entries over the budget are left to the numbers, and the check says
    "numeric only (too large for a symbolic check)".  A residual that the
    canonical form does not remove is evaluated to 30 digits at random
    states before it is called a mismatch.
(b) numeric: the compiled ``mfb`` of both formulations at ``samples`` random
    states (coordinates within +-pi rad of the initial value, or
    +-max(0.1, |q0|) m, rates within +-max(2, 2 |dq0|) of the initial rate,
    a spherical joint's quaternion a random unit one and its speeds (body
    angular velocity) as rates, times within the simulation's horizon, for F
    of t through the loads), and
    ddq = M^-1 (F + B tau) with random efforts of the size the control laws
    give at the start.  Per state, with s = the larger max-norm of the two
    values, the difference must satisfy max|lagrange - kane| <= rtol * s.
(c) trajectory: ``simulate`` with each formulation over the robot's horizon;
    the largest difference of the states on the output grid, each state
    scaled by max(1, its largest magnitude), must stay within
    ``trajectory_tol``.

Mismatches raise ``CheckFailed`` naming the robot and the quantity (after
the table and files are written); a simulation that fails raises
``NumericalError``.
"""
from __future__ import annotations

import time

from ... import progress
from ...errors import CheckFailed, NumericalError, check
from ...numeric import constrained
from .checks import (constrained_check, numeric_check, sample_states, sample_times,
                     symbolic_check, trajectory_check)
from .report import keys, rows, settings_line, summary, table, write
from .results import (RTOL, SAMPLES, SEED, SYMBOLIC_TERMS, TRAJECTORY_TOL, CompareResult,
                      RobotComparison, number_text)

__all__ = ["compare", "compare_robot", "raise_if_failed", "symbolic_check", "numeric_check",
           "constrained_check", "trajectory_check", "sample_states", "sample_times",
           "keys", "rows", "settings_line", "summary", "table", "write", "CompareResult",
           "RobotComparison"]


def compare_robot(robot, samples: int = SAMPLES, seed: int = SEED, rtol: float = RTOL,
                  trajectory_tol: float = TRAJECTORY_TOL, symbolic_terms: int = SYMBOLIC_TERMS,
                  t_end: float | None = None, use_cache: bool = False) -> RobotComparison:
    """Checks (a), (b), (c) for one validated ``Robot``."""
    from ...numeric.build import numeric_model
    from ...symbolic.formulations import derive

    robot.refuse_contacts("symbolic equations (compare)")
    timings: dict = {}
    start = time.perf_counter()
    eoms = {f: derive(robot, f) for f in ("kane", "lagrange")}
    compared = eoms
    if robot.constraints is not None:     # closed chains: the reduced equations, Kane's with
        from ...symbolic.formulations.constrained import reduced_equations   # dependent speeds,
        compared = {f: reduced_equations(robot, eoms[f], f).reduced        # Lagrange's with
                    for f in eoms}                                          # multipliers
    timings["derive"] = time.perf_counter() - start
    symbolic = symbolic_check(compared["kane"], compared["lagrange"], symbolic_terms,
                              seed=seed)
    timings["symbolic"] = symbolic.seconds
    start = time.perf_counter()
    models = {f: numeric_model(robot, f, use_cache, eom=eoms[f], jacobian=False) for f in eoms}
    timings["compile"] = time.perf_counter() - start
    start = time.perf_counter()
    numeric = numeric_check(models["kane"].info, models["kane"], models["lagrange"], samples,
                            seed, rtol)
    if constrained.is_constrained(models["kane"]):
        numeric.update(constrained_check(models["kane"], models["lagrange"], samples, seed,
                                         rtol))
    timings["numeric"] = time.perf_counter() - start
    start = time.perf_counter()
    trajectory, failure = trajectory_check(models["kane"], models["lagrange"], trajectory_tol,
                                           t_end)
    timings["trajectory"] = time.perf_counter() - start
    return RobotComparison(robot.name, robot.source, symbolic, numeric, trajectory, samples,
                           failure, timings)


def compare(robots, samples: int = SAMPLES, seed: int = SEED, rtol: float = RTOL,
            trajectory_tol: float = TRAJECTORY_TOL, symbolic_terms: int = SYMBOLIC_TERMS,
            t_end: float | None = None, use_cache: bool = False) -> CompareResult:
    """Compare Kane and Lagrange on each of ``robots`` (validated ``Robot``s)."""
    samples, seed = check("samples", samples), check("seed", seed)
    symbolic_terms = check("symbolic_terms", symbolic_terms)
    rtol = check("numeric_tolerance", rtol)
    trajectory_tol = check("trajectory_tolerance", trajectory_tol)
    t_end = check("t_end", t_end)
    start = time.perf_counter()
    done = []
    with progress.task("comparing kane and lagrange", total=len(robots)) as step:
        for r in robots:
            step.note(r.name)
            done.append(compare_robot(r, samples, seed, rtol, trajectory_tol, symbolic_terms,
                                      t_end, use_cache))
            step.advance()
    return CompareResult(done, samples, seed, rtol, trajectory_tol, symbolic_terms,
                         {"total": time.perf_counter() - start})


def raise_if_failed(result: CompareResult) -> None:
    """CheckFailed naming each robot and quantity that differs; NumericalError if a
    simulation failed."""
    missed = []
    for r in result.robots:
        for quantity in r.mismatches:
            if quantity == "symbolic":
                missed.append(f"{r.name}: {r.symbolic.entry} differs symbolically "
                              f"(lagrange - kane = {r.symbolic.residual})")
            else:
                d = r.numeric.get(quantity) or r.trajectory
                kind = "scaled" if quantity == "trajectory" else "relative"
                missed.append(f"{r.name}: {quantity} differs: max {kind} difference "
                              f"{number_text(d.max_rel)} > {d.tolerance:g} at {d.where}")
    if missed:
        raise CheckFailed("compare: " + "; ".join(missed))
    failed = [f"{r.name}: simulation failed ({r.failure})" for r in result.robots if r.failure]
    if failed:
        raise NumericalError("compare: " + "; ".join(failed))
