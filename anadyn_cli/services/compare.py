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

import csv
import io
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import files as output
from .. import progress
from ..errors import CheckFailed, NumericalError, check, shorten
from ..numeric import constrained, integrators
from ..numeric.model import NumericModel
from ..numeric.settings import output_grid, resolve

SAMPLES = 200
SEED = 0
RTOL = 1e-9                 # numeric check, relative to the quantity's size per state
TRAJECTORY_TOL = 1e-7       # scaled state difference over the output grid
SYMBOLIC_TERMS = 10_000     # expanded terms put in canonical form per robot (a few s)
ENTRY_TERMS = 5_000         # ... and per entry
ANGLE_RANGE = math.pi       # rad around the initial value
SLIDE_RANGE = 0.1           # m, at least; else |q0|
RATE_RANGE = 2.0            # rad/s or m/s, at least; else 2 |dq0|
QUANTITIES = ("M", "F", "B", "ddq")


@dataclass
class Symbolic:
    """Outcome of check (a)."""
    status: str                  # "zero", "numeric only", "nonzero", "off"
    entries: int = 0             # entries of M, F and B
    proven: int = 0              # differences shown identically zero
    too_large: int = 0           # left to the numeric check by the budget
    not_reduced: int = 0         # canonical residual that evaluates to zero (30 digits)
    terms: int = 0               # estimated expanded terms put in canonical form
    entry: str = ""              # the first entry found to differ
    residual: str = ""           # lagrange - kane there, in canonical form
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return self.status != "nonzero"

    def describe(self) -> str:
        if self.status == "zero":
            return f"0 exactly (all {self.entries} entries of M, F, B)"
        if self.status == "off":
            return "numeric only (symbolic check off)"
        if self.status == "nonzero":
            return f"{self.entry}: lagrange - kane = {self.residual}"
        why = ("too large for a symbolic check" if self.too_large
               else "canonical form does not reduce it")
        return (f"numeric only ({why}); {self.proven} of {self.entries} entries "
                f"proven 0")


@dataclass
class Difference:
    """Largest difference of one quantity between the formulations."""
    quantity: str                # "M", "F", "B", "ddq", "trajectory"
    max_abs: float
    max_rel: float               # relative to the quantity's size (scaled state: trajectory)
    tolerance: float
    passed: bool
    where: str = ""              # worst state or time
    note: str = ""

    def to_dict(self) -> dict:
        return {"max_abs": _finite_or_none(self.max_abs), "max_rel": _finite_or_none(self.max_rel),
                "tolerance": self.tolerance, "passed": self.passed, "where": self.where,
                "note": self.note}


@dataclass
class RobotComparison:
    name: str
    source: str
    symbolic: Symbolic
    numeric: dict[str, Difference]
    trajectory: Difference
    samples: int
    failure: str = ""            # a simulation that failed (NumericalError)
    timings: dict = field(default_factory=dict)

    @property
    def mismatches(self) -> list[str]:
        found = [] if self.symbolic.passed else ["symbolic"]
        found += [q for q, d in self.numeric.items() if not d.passed]
        if not self.failure and not self.trajectory.passed:
            found.append("trajectory")
        return found

    @property
    def passed(self) -> bool:
        return not self.mismatches and not self.failure


@dataclass
class CompareResult:
    robots: list[RobotComparison]
    samples: int
    seed: int
    rtol: float
    trajectory_tol: float
    symbolic_terms: int
    timings: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.robots)

    def to_csv(self, path) -> Path:
        """Write compare.csv (one row per robot and quantity) to ``path``."""
        output.write_text(Path(path), csv_text(self))
        return Path(path)


# ----------------------------------------------------------------------------
# (a) symbolic
# ----------------------------------------------------------------------------
def _label(name: str, i: int, j: int) -> str:
    return f"{name}[{i + 1}]" if name == "F" else f"{name}[{i + 1},{j + 1}]"


def symbolic_check(kane, lagrange, budget: int = SYMBOLIC_TERMS,
                   entry_budget: int = ENTRY_TERMS, seed: int = SEED) -> Symbolic:
    """Check (a) on two ``EquationsOfMotion``; time bounded by the term budgets."""
    import sympy as sp

    from ..symbolic.canonical import canonical, expanded_terms

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


# ----------------------------------------------------------------------------
# the service
# ----------------------------------------------------------------------------
def compare_robot(robot, samples: int = SAMPLES, seed: int = SEED, rtol: float = RTOL,
                  trajectory_tol: float = TRAJECTORY_TOL, symbolic_terms: int = SYMBOLIC_TERMS,
                  t_end: float | None = None, use_cache: bool = False) -> RobotComparison:
    """Checks (a), (b), (c) for one validated ``Robot``."""
    from ..numeric.build import numeric_model
    from ..symbolic.formulations import derive

    robot.refuse_contacts("symbolic equations (compare)")
    timings: dict = {}
    start = time.perf_counter()
    eoms = {f: derive(robot, f) for f in ("kane", "lagrange")}
    compared = eoms
    if robot.constraints is not None:     # closed chains: the reduced equations, Kane's with
        from ..symbolic.formulations.constrained import reduced_equations   # dependent speeds,
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
                              f"{_g(d.max_rel)} > {d.tolerance:g} at {d.where}")
    if missed:
        raise CheckFailed("compare: " + "; ".join(missed))
    failed = [f"{r.name}: simulation failed ({r.failure})" for r in result.robots if r.failure]
    if failed:
        raise NumericalError("compare: " + "; ".join(failed))


# ----------------------------------------------------------------------------
# output
# ----------------------------------------------------------------------------
def _g(value: float) -> str:
    return f"{value:.2e}" if value and math.isfinite(value) else ("0" if value == 0 else
                                                                  str(value))


def _finite_or_none(value: float):
    return value if math.isfinite(value) else None


def rows(result: CompareResult) -> list[list[str]]:
    """robot, check, max abs, max rel, tolerance, result."""
    table = []
    for r in result.robots:
        table.append([r.name, "symbolic", "-", "-", "exact",
                      ("MISMATCH " if not r.symbolic.passed else "") + r.symbolic.describe()])
        for d in [*r.numeric.values(), r.trajectory]:
            if d.quantity == "trajectory" and r.failure:
                verdict = f"FAILED: {r.failure}"
            elif d.passed:
                verdict = "ok" + (f" ({d.note})" if d.quantity == "trajectory" else "")
            else:
                verdict = f"MISMATCH ({d.note or d.where})"
            tolerance = (f"{d.tolerance:g} rel" if d.quantity != "trajectory"
                         else f"{d.tolerance:g} scaled")
            table.append([r.name, d.quantity, _g(d.max_abs), _g(d.max_rel), tolerance,
                          verdict])
    return table


def table(result: CompareResult) -> str:
    header = ["robot", "check", "max abs", "max rel", "tolerance", "result"]
    body = rows(result)
    widths = [max(len(line[i]) for line in [header, *body]) for i in range(len(header) - 1)]
    lines = []
    for line in [header, *body]:
        lines.append("  ".join(f"{cell:<{w}}" for cell, w in zip(line, widths))
                     + "  " + line[-1])
    return "\n".join(lines)


def settings_line(result: CompareResult) -> str:
    return (f"kane vs lagrange: symbolic budget {result.symbolic_terms} terms per robot; "
            f"{result.samples} random states (seed {result.seed}), "
            f"|lagrange - kane| <= {result.rtol:g} x size per state; trajectories: "
            f"states scaled by max(1, |x|max) within {result.trajectory_tol:g}")


def summary(result: CompareResult) -> dict:
    """Key figures (``compare.json``); ``robots`` is keyed by robot name."""
    robots: dict[str, dict] = {}
    worst = {q: {"max_abs": 0.0, "max_rel": 0.0} for q in (*QUANTITIES, "lambda",
                                                           "trajectory")}
    for key, r in zip(keys(result), result.robots):
        s = r.symbolic
        robots[key] = {
            "source": r.source, "passed": r.passed, "mismatches": r.mismatches,
            "simulation_failure": r.failure or None,
            "symbolic": {"status": s.status, "entries": s.entries, "proven": s.proven,
                         "too_large": s.too_large, "not_reduced": s.not_reduced,
                         "terms": s.terms, "entry": s.entry or None,
                         "residual": s.residual or None, "seconds": s.seconds,
                         "text": s.describe()},
            "numeric": {q: d.to_dict() for q, d in r.numeric.items()},
            "trajectory": r.trajectory.to_dict(),
            "timings": dict(r.timings)}
        for d in [*r.numeric.values(), r.trajectory]:
            for part in ("max_abs", "max_rel"):
                value = getattr(d, part)
                current = worst[d.quantity][part]
                worst[d.quantity][part] = (None if current is None or not math.isfinite(value)
                                           else max(current, value))
    return {"passed": result.passed, "formulation": ["kane", "lagrange"],
            "evaluator": "closed-form", "mismatches": sum(len(r.mismatches) for r in result.robots),
            "simulation_failures": sum(bool(r.failure) for r in result.robots),
            "robots_compared": len(result.robots),
            "symbolic_proven": sum(r.symbolic.status == "zero" for r in result.robots),
            "samples": result.samples, "seed": result.seed, "rtol": result.rtol,
            "trajectory_tol": result.trajectory_tol, "symbolic_terms": result.symbolic_terms,
            "worst": worst, "robots": robots, "timings": dict(result.timings)}


def csv_text(result: CompareResult) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["robot", "check", "max_abs", "max_rel", "tolerance", "passed", "detail"])
    for r in result.robots:
        s = r.symbolic
        writer.writerow([r.name, "symbolic", "", "", 0, s.passed, s.describe()])
        for d in [*r.numeric.values(), r.trajectory]:
            detail = r.failure if d.quantity == "trajectory" and r.failure else (
                "; ".join(p for p in (d.where, d.note) if p))
            passed = d.passed and not (d.quantity == "trajectory" and r.failure)
            writer.writerow([r.name, d.quantity, repr(d.max_abs), repr(d.max_rel),
                             d.tolerance, passed, detail])
    return buffer.getvalue()


def keys(result: CompareResult) -> list[str]:
    """Each robot's name, made unique (a name met again gets -2, -3, ...): its key in
    compare.json and, comparing several, its folder."""
    found: list[str] = []
    for r in result.robots:
        key, k = r.name, 2
        while key in found:
            key, k = f"{r.name}-{k}", k + 1
        found.append(key)
    return found


@output.one_set
def write(result: CompareResult, out: Path) -> list[Path]:
    """compare.csv and compare.json of each robot: in ``out`` when there is one
    robot, else in ``out/<robot name>/`` for each (the command's ``out`` is then
    results/, so every robot's files are in results/<robot>/ as with any command);
    the files of all the robots go in place together (``files.one_set``)."""
    parts = ([(out, result)] if len(result.robots) == 1 else
             [(out / key, replace(result, robots=[r]))
              for key, r in zip(keys(result), result.robots)])
    written = []
    for folder, part in parts:
        folder = output.prepare_dir(folder)
        written += [folder / "compare.csv", folder / "compare.json"]
        output.write_text(written[-2], csv_text(part))
        output.write_json(written[-1], summary(part))
    return written
