"""The three checks of Lagrange against Kane: (a) symbolic, (b) numeric at random
states, (c) along simulated trajectories (see the package's docstring)."""
from __future__ import annotations

import math
import time

import numpy as np

from ...errors import shorten
from ...numeric import constrained, integrators
from ...numeric.model import NumericModel
from ...numeric.settings import output_grid, resolve
from .results import (ANGLE_RANGE, ENTRY_TERMS, QUANTITIES, RATE_RANGE, RTOL, SAMPLES, SEED,
                      SLIDE_RANGE, SYMBOLIC_TERMS, TRAJECTORY_TOL, Difference, Symbolic)


def _label(name: str, i: int, j: int) -> str:
    return f"{name}[{i + 1}]" if name == "F" else f"{name}[{i + 1},{j + 1}]"


def symbolic_check(kane, lagrange, budget: int = SYMBOLIC_TERMS,
                   entry_budget: int = ENTRY_TERMS, seed: int = SEED) -> Symbolic:
    """Check (a) on two ``EquationsOfMotion``; time bounded by the term budgets."""
    import sympy as sp

    from ...symbolic.canonical import canonical, expanded_terms

    start = time.perf_counter()
    result = Symbolic("zero")
    pending = []
    # with a spherical joint Kane's entries divide by the quaternion's norm and
    # Lagrange's are taken at q / |q|: no common denominator to clear, so a residual
    # the canonical form leaves is evaluated at random states (``_vanishes``)
    quaternion = kane.kinematic
    for name in ("M", "F", "B"):
        a, b = getattr(kane, name), getattr(lagrange, name)
        if a.shape != b.shape:
            result.status, result.entry = "nonzero", name
            result.residual = f"shapes differ: {b.shape} against {a.shape}"
            return result
        for i in range(a.rows):
            for j in range(a.cols):
                result.entries += 1
                difference = b[i, j] - a[i, j]
                if difference != 0 and quaternion is None and _rational(difference):
                    difference = sp.fraction(sp.together(difference))[0]   # closed chains
                if difference == 0:
                    result.proven += 1
                else:
                    size = expanded_terms(difference, entry_budget)
                    pending.append((size, len(pending), _label(name, i, j),
                                    difference, a[i, j]))
    if budget <= 0 and pending:
        result.status = "off"
        result.too_large = len(pending)
        result.seconds = time.perf_counter() - start
        return result
    rng = np.random.default_rng(seed)
    for size, _, label, difference, reference in sorted(pending, key=lambda p: p[:2]):
        if size > entry_budget or result.terms + size > budget:
            result.too_large += 1
            continue
        result.terms += size
        residual = canonical(difference)
        if residual == 0:
            result.proven += 1
        elif _vanishes(residual, reference, rng, sp):
            result.not_reduced += 1
        else:
            result.status, result.entry = "nonzero", label
            result.residual = shorten(residual, 120)
            result.seconds = time.perf_counter() - start
            return result
    if result.too_large or result.not_reduced:
        result.status = "numeric only"
    result.seconds = time.perf_counter() - start
    return result


def _vanishes(residual, reference, rng, sp, points: int = 3) -> bool:
    """Whether ``residual`` is zero to 30 digits at random states (an incomplete
    canonical form, not a real difference)."""
    symbols = sorted(residual.free_symbols | reference.free_symbols, key=str)
    for _ in range(points):
        values = {s: sp.Float(float(v), 30) for s, v in zip(symbols, rng.uniform(-2, 2,
                                                                              len(symbols)))}
        value = abs(complex(residual.xreplace(values).evalf(30)))
        size = max(1.0, abs(complex(reference.xreplace(values).evalf(30))))
        if not value <= 1e-20 * size:
            return False
    return True


# ----------------------------------------------------------------------------
# (b) numeric
# ----------------------------------------------------------------------------
def sample_states(info, compiled, count: int, seed: int = SEED):
    """q (nq, S), dq (n, S), tau (m, S) around the robot's initial state; dq are the
    speeds (with a spherical joint its angular velocity), and each quaternion is a
    random unit one (normal draws made unit: uniform over the rotations)."""
    rng = np.random.default_rng(seed)
    x0 = compiled.initial_state()
    q0, dq0 = x0[:compiled.nq], x0[compiled.nq:]
    spread = np.array([ANGLE_RANGE if c.unit == "rad" else max(SLIDE_RANGE, abs(c.initial))
                       for c in info.coordinates])
    rates = np.maximum(RATE_RANGE, 2 * np.abs(dq0))
    q = q0[:, None] + spread[:, None] * rng.uniform(-1, 1, (len(q0), count))
    for index in compiled.quaternions:
        drawn = rng.normal(size=(4, count))
        q[list(index)] = drawn / np.linalg.norm(drawn, axis=0)
    dq = dq0[:, None] + rates[:, None] * rng.uniform(-1, 1, (len(dq0), count))
    m = len(info.actuators)
    scale = np.ones(m)
    if m and info.has_controller:
        with np.errstate(all="ignore"):
            start = np.asarray(compiled.efforts(0.0, q0, dq0), dtype=float).reshape(m)
        scale = np.where(np.isfinite(start), np.maximum(1.0, np.abs(start)), 1.0)
    tau = scale[:, None] * rng.uniform(-1, 1, (m, count))
    return q, dq, tau


def sample_times(info, count: int, seed: int = SEED) -> np.ndarray:
    """``count`` times within the robot's horizon (F depends on t through loads)."""
    horizon = info.simulation.t_end or 10.0
    return np.random.default_rng([seed, 1]).uniform(0.0, horizon, count)


def accelerations(compiled, q, dq, tau, t=0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                        np.ndarray]:
    """M, F, B (states first) and ddq = M^-1 (F + B tau) at every state (and time)."""
    count = q.shape[1]
    M, F, B = compiled.mfb(t, q, dq)
    n, m = compiled.n, tau.shape[0]
    M = np.broadcast_to(M, (count, n, n))
    F = np.broadcast_to(F, (count, n))
    B = np.broadcast_to(B, (count, n, m))
    rhs = F + np.einsum("kij,jk->ki", B, tau)
    ddq = np.full((count, n), np.nan)
    for k in range(count):
        try:
            ddq[k] = np.linalg.solve(M[k], rhs[k])
        except np.linalg.LinAlgError:
            pass                                   # stays NaN: reported as a mismatch
    return M, F, B, ddq


def difference(quantity: str, kane: np.ndarray, lagrange: np.ndarray, rtol: float,
               describe) -> Difference:
    """max |lagrange - kane| over the states, and relative to max(|kane|, |lagrange|)."""
    count = kane.shape[0]
    if kane.size == 0:
        return Difference(quantity, 0.0, 0.0, rtol, True, note="empty")
    a, b = kane.reshape(count, -1), lagrange.reshape(count, -1)
    with np.errstate(all="ignore"):
        absolute = np.abs(b - a).max(axis=1)
        scale = np.maximum(np.abs(a).max(axis=1), np.abs(b).max(axis=1))
        relative = np.where(absolute == 0, 0.0, absolute / scale)
    absolute = np.where(np.isfinite(absolute), absolute, np.inf)
    relative = np.where(np.isfinite(relative), relative, np.inf)
    bad = ~(absolute <= rtol * scale)
    worst = int(np.argmax(relative))
    return Difference(quantity, float(absolute.max()), float(relative.max()), rtol,
                      not bad.any(), where=describe(worst),
                      note=f"{int(bad.sum())} of {count} states over" if bad.any() else "")


def numeric_check(info, kane, lagrange, samples: int = SAMPLES, seed: int = SEED,
                  rtol: float = RTOL) -> dict[str, Difference]:
    """Check (b) on two ``CompiledRobot``s."""
    q, dq, tau = sample_states(info, kane, samples, seed)
    t = sample_times(info, samples, seed)
    names = [c.name for c in info.coordinates]

    def describe(k: int) -> str:
        values = [f"t={t[k]:.6g}"] if kane.has_forces else []      # F of t: loads
        values += [f"{n}={v:.6g}" for n, v in zip(names, q[:, k])]
        values += [f"{n}={v:.6g}" for n, v in zip(kane.speeds, dq[:, k])]
        return f"state {k}: " + ", ".join(values)

    with np.errstate(all="ignore"):
        ours = accelerations(kane, q, dq, tau, t)
        theirs = accelerations(lagrange, q, dq, tau, t)
    return {name: difference(name, a, b, rtol, describe)
            for name, a, b in zip(QUANTITIES, ours, theirs)}


def constrained_check(kane, lagrange, samples: int = SAMPLES, seed: int = SEED,
                      rtol: float = RTOL) -> dict[str, Difference]:
    """Closed chains: ddq and the multipliers lambda of both formulations at states on
    the constraints (``constrained.consistent_states``), replacing the tree's ddq."""
    t, X, tau = constrained.consistent_states(kane, samples, seed)
    names = [c.name for c in kane.info.coordinates]
    if not len(t):
        return {"ddq": Difference("ddq", math.inf, math.inf, rtol, False,
                                  note="no state on the constraints found")}

    def describe(k: int) -> str:
        values = [f"t={t[k]:.6g}"] + [f"{n}={v:.6g}" for n, v in zip(names, X[k, :len(names)])]
        return f"state {k} on the constraints: " + ", ".join(values)

    with np.errstate(all="ignore"):
        ours = constrained.accelerations(kane, t, X, tau)
        theirs = constrained.accelerations(lagrange, t, X, tau)
    return {"ddq": difference("ddq", ours[0], theirs[0], rtol, describe),
            "lambda": difference("lambda", ours[1], theirs[1], rtol, describe)}


def _rational(expr) -> bool:
    """Whether ``expr`` divides by something other than a number."""
    import sympy as sp

    return any(p.exp.is_negative and not p.base.is_number for p in expr.atoms(sp.Pow))


# ----------------------------------------------------------------------------
# (c) trajectory
# ----------------------------------------------------------------------------
def trajectory_check(kane: NumericModel, lagrange: NumericModel,
                     tolerance: float = TRAJECTORY_TOL,
                     t_end: float | None = None) -> tuple[Difference, str]:
    """Check (c): (difference, failure message or "")."""
    settings = resolve(kane.info, t_end=t_end)
    grid = output_grid(settings.t_end, settings.output_step)
    a, b = (integrators.integrate(model.problem(), model.initial_state(), grid,
                                  settings.method, settings.rtol, settings.atol)
            for model in (kane, lagrange))
    failed = [f"{f}: {r.message}" for f, r in (("kane", a), ("lagrange", b)) if not r.success]
    rows = min(len(a.t), len(b.t))
    xa, xb = a.x[:rows], b.x[:rows]
    absolute = np.abs(xb - xa)
    scaled = absolute / np.maximum(1.0, np.abs(xa).max(axis=0, initial=0.0))
    per_row = scaled.max(axis=1) if rows else np.zeros(0)
    worst = int(np.argmax(per_row)) if rows else 0
    note = (f"{rows} rows to {a.t[rows - 1]:g} s, {a.method} rtol "
            f"{settings.rtol:g}" if rows else "no rows")
    result = Difference("trajectory", float(absolute.max(initial=0.0)),
                        float(per_row.max(initial=0.0)), tolerance,
                        bool(per_row.max(initial=0.0) <= tolerance),
                        where=f"t = {a.t[worst]:g} s" if rows else "", note=note)
    return result, "; ".join(failed)


