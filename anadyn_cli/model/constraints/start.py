"""Checks of the constraint equations at numbers, and the consistent start: redundant
and inconsistent rows (rank at random configurations), the dependent coordinates solved
by Newton's method, and the rates solved from A dq + a_0 = 0."""
from __future__ import annotations

import math

import numpy as np

from .equations import DIRECTIONS
from .geometry import System

NEWTON_ITERATIONS = 100
CLOSED = 1e-10            # |f| at the start, relative to the mechanism's size
RANDOM_STATES = 3         # configurations at which redundancy is judged
RANK_TOL = 1e-8           # singular values below this times the largest: rank lost
DEAD_POINT = 1e6          # condition number of df/dq_dependent at the start: locked
RATE_TOL = 1e-9           # a given rate of a solved speed must agree to this (relative)


def random_states(coordinates, rng) -> list[np.ndarray]:
    q0 = np.array([float(c.initial) for c in coordinates])
    spread = np.array([math.pi if c.unit == "rad" else max(0.1, abs(float(c.initial)))
                       for c in coordinates])
    return [q0 + spread * rng.uniform(-1, 1, len(q0)) for _ in range(RANDOM_STATES)]


def check_redundancy(system: System, cursors: dict, coordinates) -> None:
    """Constraint rows that are dependent at every random configuration: redundant (or,
    for a row that never changes and is not zero, inconsistent)."""
    c = system.h + len(system.velocities)
    if c == 0:
        return
    rng = np.random.default_rng(0)
    states = random_states(coordinates, rng)
    matrices = [system.pfaffian(q, 0.0)[0] for q in states]
    if any(not np.isfinite(A).all() for A in matrices):
        return                                   # not evaluable there: judged at the start
    scale = max(1.0, max(float(np.abs(A).max(initial=0.0)) for A in matrices))
    for row in range(c):
        if all(np.abs(A[row]).max(initial=0.0) <= 1e-12 * scale for A in matrices):
            _refuse_constant_row(system, cursors, row, states)
    ranks = [np.linalg.matrix_rank(A, tol=RANK_TOL * max(1.0, np.abs(A).max())) for A in
             matrices]
    if max(ranks) == c:
        return
    A = matrices[int(np.argmax(ranks))]
    kept = np.zeros((0, system.n))
    for row in range(c):
        trial = np.vstack([kept, A[row]])
        if np.linalg.matrix_rank(trial, tol=RANK_TOL * max(1.0, np.abs(A).max())) == len(kept):
            path = system.paths[row]
            what = _describe_row(system, row)
            raise cursors[path].error(
                f"{what} is redundant: at every configuration tried it is a combination of "
                f"the constraint equations before it (rank {max(ranks)} of {c}); leave it out")
        kept = trial


def _describe_row(system: System, row: int) -> str:
    if row < sum(len(loop.directions) for loop in system.loops):
        k = row
        for loop in system.loops:
            if k < len(loop.directions):
                return f"the loop's {loop.directions[k]} equation"
            k -= len(loop.directions)
    return "this constraint"


def _refuse_constant_row(system: System, cursors: dict, row: int, states) -> None:
    path = system.paths[row]
    if row >= system.h:
        raise cursors[path].error("the velocity constraint's coefficients are zero at every "
                                  "configuration tried; it constrains no rate")
    value = float(system.f(states[0], 0.0)[row])
    if row < sum(len(loop.directions) for loop in system.loops):
        axis = _describe_row(system, row).split("'s ")[1].split()[0]
        if abs(value) <= CLOSED * system.scale:
            raise cursors[path].error(
                f"along {axis} the two points never move apart (they stay in one plane), so "
                f"that direction constrains nothing; list only the others, e.g. directions: "
                f"[{', '.join(d for d in DIRECTIONS if d != axis)}]")
        raise cursors[path].error(
            f"along {axis} the two points are {abs(value):.6g} m apart whatever the "
            "coordinates, so the loop can never close; check the points and the joint origins")
    if abs(value) <= CLOSED * system.scale:
        raise cursors[path].error("the position constraint is 0 whatever the coordinates; it "
                                  "constrains nothing")
    raise cursors[path].error(f"the position constraint stays {value:.6g} whatever the "
                              "coordinates, so it can never hold")


def closed_start(system: System, cursors: dict, coordinates, dependent: list[str],
                  coordinate_cursors: dict) -> np.ndarray:
    """q0 with the dependent coordinates solved from f(q, 0) = 0 (Newton, damped)."""
    names = [c.name for c in coordinates]
    q = np.array([float(c.initial) for c in coordinates])
    if system.h == 0:
        return q
    index = [names.index(name) for name in dependent]
    residual = system.f(q)
    if not np.isfinite(residual).all():
        raise cursors[system.paths[0]].error("the constraints cannot be evaluated at the "
                                             "initial state")
    norm = np.abs(residual).max()
    for _ in range(NEWTON_ITERATIONS):
        if norm <= CLOSED * system.scale * 1e-3:
            break
        J = system.jacobian(q)[:, index]
        step = np.linalg.lstsq(J, -residual, rcond=None)[0]
        scale = 1.0
        while scale > 1e-6:
            trial = q.copy()
            trial[index] += scale * step
            trial_residual = system.f(trial)
            trial_norm = np.abs(trial_residual).max()
            if np.isfinite(trial_norm) and trial_norm < norm:
                break
            scale /= 2
        else:
            break                                # no progress: the closest point found
        q, residual, norm = trial, trial_residual, trial_norm
    if norm > CLOSED * system.scale:
        row = int(np.argmax(np.abs(residual)))
        held = ", ".join(f"{names[i]} = {q[i]:.6g}" for i in range(len(names))
                         if names[i] not in dependent)
        path = system.paths[row]
        if row < sum(len(loop.directions) for loop in system.loops):
            loop_rows = [r for r in range(system.h) if system.paths[r] == path]
            gap = float(np.linalg.norm(residual[loop_rows]))
            what = (f"the loop cannot close at the start: with {held} held, its points stay "
                    f"{gap:.6g} m apart at the closest found ({_solved(q, names, dependent)})")
        else:
            what = (f"cannot be met at the start: with {held} held, it stays "
                    f"{residual[row]:.6g} at the closest found ({_solved(q, names, dependent)})")
        raise cursors[path].error(f"{what}; check the lengths, the points and the independent "
                                  "coordinates' initial values")
    J = system.jacobian(q)
    condition = np.linalg.cond(J[:, index]) if index else 1.0
    if not condition < DEAD_POINT:
        raise coordinate_cursors[dependent[0]].error(
            f"at the start the dependent coordinates {', '.join(dependent)} are not determined "
            f"by the independent ones (df/d({', '.join(dependent)}) has condition number "
            f"{condition:.3g}): the mechanism starts at a dead point, where it can lock or flip; "
            "move the independent coordinates' initial values or mark other coordinates "
            "dependent")
    return q


def _solved(q, names, dependent) -> str:
    return ", ".join(f"{name} = {q[names.index(name)]:.6g}" for name in dependent)


def consistent_rates(system: System, cursors: dict, coordinates, dependent: list[str],
                      q0: np.ndarray, coordinate_cursors: dict) -> tuple[np.ndarray, list[str]]:
    """dq0 solving A dq + a0 = 0 for the dependent speeds; (rates, dependent speeds)."""
    names = [c.name for c in coordinates]
    given = {name for name, cursor in coordinate_cursors.items()
             if isinstance(cursor.value, dict) and "rate" in cursor.value}
    rates = np.array([float(c.rate) for c in coordinates])
    c = system.h + len(system.velocities)
    if c == 0:
        return rates, []
    A, a0 = system.pfaffian(q0, 0.0)
    speeds = [names.index(name) for name in dependent]
    for row in range(system.h, c):
        candidates = [k for k in range(len(names)) if k not in speeds]
        best, best_size = None, -1.0
        for pool in ([k for k in candidates if names[k] not in given], candidates):
            for k in pool:
                size = np.linalg.svd(A[: row + 1, speeds + [k]], compute_uv=False).min()
                if size > best_size * (1 + 1e-12):
                    best, best_size = k, size
            if best is not None and best_size > 1e-9 * max(1.0, np.abs(A).max()):
                break
        if best is None or not best_size > 1e-9 * max(1.0, np.abs(A).max()):
            raise cursors[system.paths[row]].error(
                "at the start this velocity constraint fixes no rate the others leave free "
                "(its coefficients are zero or a combination of the constraints before it)")
        speeds.append(best)
    known = [k for k in range(len(names)) if k not in speeds]
    rhs = -(A[:, known] @ rates[known] + a0)
    try:
        solved = np.linalg.solve(A[:, speeds], rhs)
    except np.linalg.LinAlgError:
        raise cursors[system.paths[0]].error("the constraints do not determine the dependent "
                                             "rates at the start") from None
    for k, value in zip(speeds, solved):
        if names[k] in given:
            stated = rates[k]
            if abs(stated - value) > RATE_TOL * max(1.0, abs(value), abs(stated)):
                raise coordinate_cursors[names[k]].child("rate", None).error(
                    f"{stated:g} breaks the constraints at the start (they give {value + 0.0:.6g} "
                    f"for d{names[k]} with the other rates as given); leave it out to have it "
                    "solved, or make the rates consistent")
        rates[k] = value
    return rates, [names[k] for k in speeds]
