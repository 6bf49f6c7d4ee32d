"""Stability report along the simulated path (``anadyn check``).

The scene is integrated once, by LSODA with its compiled stepping loop (the
method ``auto`` runs), at the scene's tolerances, with the actuators' work
carried along as one more state.  Along that path:

* **Jacobian eigenvalues** of dx/dt at up to ``samples`` rows: the fastest
  decay max(-Re lambda) and its time constant, the fastest growth
  max(Re lambda) (nearby paths diverge), the fastest rate max|lambda|, and two
  stiffness ratios: the classic max|Re lambda| / min|Re lambda| over the
  decaying modes at one state, with min|Re lambda| floored at 1/horizon (a
  mode that decays slower than that is neutral over the run, and the
  unfloored ratio explodes on conservative scenes), and ``auto``'s fastest
  decay x horizon.
* **Explicit probe**: RK45 at rtol 1e-3 and 1e-7 over the same window.  For a
  smooth non-stiff problem its RHS calls fall ~6x (10^(4/5)) when the
  tolerance is loosened 10^4 times; when they fall less than 2x the step is
  set by stability, not accuracy: explicit methods are stability-limited
  and the scene is called **stiff**.  This is the verdict; the eigenvalues
  explain it.  Each run stops at a call budget (the window then ends where
  the loose run stopped), so very stiff scenes stay cheap.  A path on which
  no mode decays (every eigenvalue 0, e.g. coaxial vertical joints at rest:
  gravity along the axes moves nothing) is not stiff, whatever the counts:
  both runs then take the fewest steps, and the time constant is "none".
* **Mass matrix** condition number at every row (up to 20,000 rows), raw and
  after symmetric diagonal scaling D^-1/2 M D^-1/2, D = diag(M).  The raw
  number mixes units and link sizes (a 1 mm link gives 1e9 and LU solves it
  to full accuracy); the scaled one measures real ill-conditioning, which
  is what costs digits in ``numpy.linalg.solve`` (van der Sluis).  The
  threshold applies to the scaled number; a large raw number is a warning.
* **Energy balance**: T + V - W - W_loads + E_d - E0 along the path, with V
  gravity's and the joint springs' potential energy, W the actuators' work,
  W_loads the external loads' work and E_d the energy dissipated by joint
  damping and friction (>= 0), over the energy scale max(max T,
  max V - min V, max |W|, max |W_loads|, max E_d).  Passive scenes (no
  actuators, loads or joint forces) have W = W_loads = E_d = 0 and this is
  the energy drift.  With contacts (``numeric.contact``), V also holds their
  springs' energy V_c = k max(0, d)^(p+1) / (p+1) and E_d what their damping and
  friction dissipate; the report gives each contact's largest penetration and the
  time constant sqrt(m / k_eff) of its body's mass m on the spring linearized there,
  k_eff = p k d^(p-1).

* **Momentum** of a free robot (every root on a floating joint): the linear
  momentum P and the angular momentum L about the world origin (world axes, from
  the body velocities, ``NumericModel.momentum``), whose conserved parts
  (``NumericModel.conserved``: all of them without gravity, loads or contacts;
  under gravity the part of P normal to g and L . g) must stay at their start:
  max |C (h - h0)| over the largest sum of the bodies' own momenta along the
  path (sum |p_i|, sum |l_i| + d_i |p_i|: a satellite's total is zero, its
  bus's and wheel's are not), under the energy threshold.

How W is integrated: it is **augmented to the state**, dW/dt = P(t, x) =
tau . (B^T dq) (generalized force of the actuators times rate), and stepped
by the same integrator under the same error control.  Quadrature of P on the
output grid from dense output was the alternative, but the power is largest
exactly when the fast modes move (RR's damping power b dq^2 peaks within the
first milliseconds, far below a 10 ms output step), so a grid quadrature
would report its own error rather than the integrator's.  Augmenting costs
one effort and one B evaluation per RHS call; the Jacobian of the augmented
system is the analytic one bordered by a finite-difference row dP/dx (W
feeds back into nothing, so the column for W is zero).  W_loads and E_d are
carried the same way, from the model's ``powers``: computed from the
kinematics (the loads' points' velocities, the joint rates), not from F, so
a wrong force term in the equations breaks the balance.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import errors
from ..errors import CheckFailed, NumericalError, positive
from ..model.info import RobotInfo
from ..numeric import constrained, contact_run, integrators
from ..numeric.build import computation
from ..numeric.integrators import Problem
from ..numeric.model import NumericModel, scaled_condition
from ..numeric.settings import output_grid, resolve
from .. import files as output

SAMPLES = 200                 # Jacobian eigenvalue samples along the path
PROBE_CALLS = 5_000           # RHS calls for the loose explicit probe (4x for the tight one)
PROBE_RTOLS = (1e-3, 1e-7)
STABILITY_LIMITED = 0.5       # calls(loose) / calls(tight) above this: stability-limited
MAX_CONDITION = 1e8           # scaled mass-matrix condition number
BADLY_SCALED = 1e6            # raw condition number above this: a warning
UNDAMPED = 1e-6               # fastest decay x horizon below this: nothing decays
ENERGY_TOL = 1e-6             # |T + V - W - E0| / energy scale
CONDITION_ROWS = 20_000


@dataclass
class Probe:
    window: float                 # s, from the start
    loose_calls: int
    tight_calls: int
    loose_capped: bool
    tight_capped: bool

    @property
    def ratio(self) -> float:
        return self.loose_calls / max(self.tight_calls, 1)

    @property
    def limited(self) -> bool:
        return self.ratio > STABILITY_LIMITED


@dataclass
class Check:
    name: str
    value: float
    threshold: float
    passed: bool
    text: str


@dataclass
class StabilityReport:
    robot: RobotInfo
    t_end: float
    rtol: float
    atol: float
    t: np.ndarray                 # path rows
    x: np.ndarray
    work: np.ndarray              # actuators' work W(t)
    rhs_calls: int
    solve_wall: float
    sample_t: np.ndarray
    decay: np.ndarray             # max(-Re lambda) per sample, 1/s
    growth: np.ndarray            # max(Re lambda) per sample
    speed: np.ndarray             # max |lambda| per sample
    classic: np.ndarray           # max|Re| / max(min|Re|, 1/horizon) over decaying modes
    condition: np.ndarray         # raw condition number per row checked
    scaled_condition: np.ndarray
    condition_t: np.ndarray
    energy_residual: np.ndarray   # T + V - W - E0 per row, J
    energy_scale: float
    probe: Probe
    checks: list[Check] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    load_work: np.ndarray | None = None   # loads' work W_loads(t); None: no loads or
    dissipated: np.ndarray | None = None  # joint forces; energy dissipated E_d(t) >= 0
    constraints: "constrained.ConstraintCheck | None" = None   # closed chains
    contacts: "contact_run.ContactRun | None" = None     # contact forces on the rows
    contact_laws: tuple = ()                     # per contact: k, p, its body's mass
    momentum: "Momentum | None" = None           # a free robot's momentum (``momentum``)
    computation: dict = field(default_factory=dict)   # what ran (numeric.build.computation)

    @property
    def passive(self) -> bool:
        return not self.robot.actuators and self.load_work is None

    @property
    def balance(self) -> str:
        """The balance checked, e.g. T + V - W - W_loads + E_d - E0."""
        return ("T + V" + ("" if self.contacts is None else " + V_c")
                + ("" if not self.robot.actuators else " - W")
                + ("" if self.load_work is None else " - W_loads + E_d") + " - E0")

    @property
    def stiff(self) -> bool:
        """The probe's verdict, given a mode that decays: with none (e.g. two
        coaxial vertical joints under gravity along them, where nothing moves
        and every eigenvalue is 0) both probe runs take the fewest steps, and
        equal call counts measure nothing; stability limits no step."""
        return self.probe.limited and self.auto_ratio > UNDAMPED

    @property
    def fastest_decay(self) -> float:
        return float(self.decay.max(initial=0.0))

    @property
    def auto_ratio(self) -> float:
        return self.fastest_decay * self.t_end

    @property
    def energy_error(self) -> float:
        return float(np.abs(self.energy_residual).max() / self.energy_scale)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)


# ----------------------------------------------------------------------------
# the path, with the actuators' work
# ----------------------------------------------------------------------------
def actuator_power(model: NumericModel, t: float, x: np.ndarray) -> float:
    """P = tau . (B^T dq) = dq . (B tau): the actuators' power at one state."""
    n, nq = model.n, model.nq
    q, dq = x[:nq], x[nq:]
    tau = np.asarray(model.efforts(t, q, dq), dtype=float).reshape(-1)
    _, _, B = model.mfb(t, q, dq)
    return float(dq @ (np.asarray(B).reshape(n, -1) @ tau))


def external_powers(model: NumericModel, t: float, x: np.ndarray) -> np.ndarray:
    """[P_loads, P_dissipated] at one state: the loads' power and the power that joint
    damping and friction dissipate (>= 0)."""
    nq = model.nq
    out = np.asarray(model.powers(t, x[:nq], x[nq:]), dtype=float).reshape(2)
    if model.contact_names:                   # what the contacts dissipate
        out[1] += float(np.sum(model.contacts(t, x[:nq], x[nq:])[:, 5]))
    return out


def forced(model: NumericModel) -> bool:
    """Whether W_loads and E_d are carried: loads, joint forces or contacts."""
    return model.has_forces or bool(model.contact_names)


def with_work(model: NumericModel, actuated: bool) -> Problem:
    """The direct dynamics with the actuators' work W as one more state, W' = P; with
    loads or joint forces also their work W_loads and the dissipated energy E_d."""
    n2 = model.nq + model.n
    extra = 3 if forced(model) else 1

    def powers(t, x):
        out = np.zeros(extra)
        if actuated:
            out[0] = actuator_power(model, t, x)
        if extra > 1:
            out[1:] = external_powers(model, t, x)
        return out

    def rhs(t, y):
        out = np.empty(n2 + extra)
        out[:n2] = model.rhs(t, y[:n2])
        out[n2:] = powers(t, y[:n2])
        return out

    def jacobian(t, y):
        J = np.zeros((n2 + extra, n2 + extra))
        x = y[:n2]
        J[:n2, :n2] = model.jacobian(t, x)
        if actuated or extra > 1:
            p0 = powers(t, x)
            for j in range(n2):
                h = 1.5e-8 * max(1.0, abs(x[j]))
                shifted = x.copy()
                shifted[j] += h
                J[n2:, j] = (powers(t, shifted) - p0) / h
        return J

    names = ("W", "W_loads", "E_d")[:extra]
    return Problem(rhs, jacobian, (*model.state_names(), *names), model.diagnose)


def eigen_samples(model: NumericModel, t: np.ndarray, x: np.ndarray, samples: int):
    """(sample times, decay, growth, speed, classic ratio) of the state Jacobian."""
    floor = 1.0 / max(t[-1] - t[0], 1e-300)
    index = np.unique(np.linspace(0, len(t) - 1, min(samples, len(t))).round().astype(int))
    decay, growth, speed, classic = [], [], [], []
    for k in index:
        lam = integrators.eigenvalues(model.jacobian, t[k], x[k])
        if lam is None:
            decay.append(np.nan), growth.append(np.nan), speed.append(np.nan)
            classic.append(np.nan)
            continue
        re = lam.real
        size = np.abs(lam).max(initial=0.0)
        decaying = -re[re < -1e-9 * max(size, 1.0)]
        decay.append(decaying.max(initial=0.0))
        growth.append(max(re.max(initial=0.0), 0.0))
        speed.append(size)
        classic.append(decaying.max() / max(decaying.min(), floor) if len(decaying) else 1.0)
    return (t[index], np.array(decay), np.array(growth), np.array(speed), np.array(classic))


def explicit_probe(problem: Problem, x0: np.ndarray, t0: float, t_end: float,
                   calls: int = PROBE_CALLS) -> Probe:
    """RK45 at a loose and a tight tolerance over the same window; see the module docstring."""
    loose, tight = PROBE_RTOLS
    solution = integrators.integrate(problem, x0, np.array([t0, t_end]), "RK45", loose,
                                     loose * 1e-2, budget=calls)
    if solution.over_budget is not None:
        window, loose_calls, loose_capped = solution.over_budget.t, calls, True
    else:
        window = solution.t[-1] if not solution.success else t_end
        loose_calls, loose_capped = solution.rhs_calls, False
    if window <= t0:
        return Probe(0.0, loose_calls, loose_calls, loose_capped, False)
    solution = integrators.integrate(problem, x0, np.array([t0, window]), "RK45", tight,
                                     tight * 1e-2, budget=4 * calls)
    over = solution.over_budget is not None
    tight_calls = 4 * calls if over else solution.rhs_calls
    return Probe(window - t0, loose_calls, tight_calls, loose_capped, over)


@dataclass
class Momentum:
    """A free robot's momentum along the path: ``h`` (rows, 6) = (P, L) in world axes,
    ``conserved`` the rows of C (``NumericModel.conserved``) and the relative drift of
    the conserved linear and angular parts (0 where none is conserved)."""
    h: np.ndarray
    conserved: np.ndarray
    linear: float
    angular: float

    @property
    def drift(self) -> float:
        return max(self.linear, self.angular)


def momentum(model: NumericModel, t: np.ndarray, x: np.ndarray) -> Momentum | None:
    """The momentum check of a free robot (module docstring); None for another."""
    C = model.conserved()
    if C is None:
        return None
    nq = model.nq
    values = np.asarray(model.momentum(t, x[:, :nq].T, x[:, nq:].T), dtype=float).T
    h, scales = values[:, :6], values[:, 6:].max(axis=0)
    change = np.abs((h - h[0]) @ C.T)
    drifts = []
    for part, scale in zip((slice(0, 3), slice(3, 6)), scales):
        rows = np.any(C[:, part] != 0, axis=1)
        drifts.append(float(change[:, rows].max()) / scale if rows.any() and scale > 0
                      else 0.0)
    return Momentum(h, C, *drifts)


def mass_conditions(model: NumericModel, t: np.ndarray, x: np.ndarray):
    """(times, raw, scaled) condition numbers of M at up to 20,000 rows."""
    stride = max(1, math.ceil(len(t) / CONDITION_ROWS))
    rows = np.arange(0, len(t), stride)
    n, nq = model.n, model.nq
    q, dq = x[rows, :nq].T, x[rows, nq:].T
    M = np.asarray(model.mfb(t[rows], q, dq)[0], dtype=float).reshape(len(rows), n, n)
    return t[rows], np.linalg.cond(M), scaled_condition(M)


# ----------------------------------------------------------------------------
# the report
# ----------------------------------------------------------------------------
def check(model: NumericModel, rtol: float | None = None,
          atol: float | None = None, t_end: float | None = None,
          output_step: float | None = None, samples: int = SAMPLES,
          max_condition: float = MAX_CONDITION, energy_tol: float = ENERGY_TOL,
          probe_calls: int = PROBE_CALLS) -> StabilityReport:
    """Simulate ``robot`` and examine the path; see the module docstring."""
    positive("max_condition", max_condition)
    positive("energy_tol", energy_tol)
    errors.check("samples", samples)
    errors.check("probe_calls", probe_calls)
    robot = model.info
    settings = resolve(robot, rtol=rtol, atol=atol, t_end=t_end, output_step=output_step)
    grid = output_grid(settings.t_end, settings.output_step)
    x0 = model.initial_state()
    timings: dict = {}
    extra = 3 if forced(model) else 1
    solution = integrators.integrate(with_work(model, bool(robot.actuators)),
                                     np.append(x0, np.zeros(extra)), grid, "odeint",
                                     settings.rtol, settings.atol)
    if not solution.success:
        raise NumericalError(f"{solution.message}; the path cannot be checked")
    n2 = len(x0)
    x, work, calls, wall = solution.x[:, :n2], solution.x[:, n2], solution.rhs_calls, solution.wall
    load_work, dissipated = ((solution.x[:, n2 + 1], solution.x[:, n2 + 2]) if extra > 1
                             else (None, None))
    timings["solve"] = wall

    start = time.perf_counter()
    sample_t, decay, growth, speed, classic = eigen_samples(model, grid, x, samples)
    timings["eigenvalues"] = time.perf_counter() - start
    start = time.perf_counter()
    probe = explicit_probe(model.problem(), x0, grid[0], grid[-1], probe_calls)
    timings["probe"] = time.perf_counter() - start
    start = time.perf_counter()
    cond_t, raw, scaled = mass_conditions(model, grid, x)
    nq = model.nq
    T, V = model.energy(x[:, :nq].T, x[:, nq:].T)
    T, V = np.asarray(T, dtype=float), np.asarray(V, dtype=float)
    contacts = contact_run.run_report(model, grid, x)
    if contacts is not None:                   # the contacts' springs
        V = V + contacts.values[:, 4].sum(axis=0)
    E = T + V
    residual = E - work - E[0]
    scale = max(float(T.max()), float(V.max() - V.min()), float(np.abs(work).max()))
    if load_work is not None:
        residual = residual - load_work + dissipated
        scale = max(scale, float(np.abs(load_work).max()), float(dissipated.max()))
    scale = scale if scale > 0 else 1.0
    timings["mass_and_energy"] = time.perf_counter() - start

    report = StabilityReport(robot, float(grid[-1]), settings.rtol, settings.atol, grid, x,
                             work, calls, wall, sample_t, decay, growth, speed, classic, raw,
                             scaled, cond_t, residual, scale, probe, timings=timings,
                             load_work=load_work, dissipated=dissipated,
                             contacts=contacts, contact_laws=model.contact_laws,
                             momentum=momentum(model, grid, x), computation=computation(model))
    if constrained.is_constrained(model):      # constraint Jacobian along the path
        report.constraints = constrained.conditioning(model, grid, x)
    _judge(report, max_condition, energy_tol)
    return report


def _judge(report: StabilityReport, max_condition: float, energy_tol: float) -> None:
    what = "energy drift" if report.passive else "energy balance"
    error = report.energy_error
    report.checks.append(Check(what, error, energy_tol, error <= energy_tol, (
        f"{what}: max |{report.balance}| / scale = {error:.2e}"
        f" (threshold {energy_tol:.0e})")))
    h = report.momentum
    if h is not None and len(h.conserved):
        report.checks.append(Check("momentum", h.drift, energy_tol, h.drift <= energy_tol, (
            f"momentum: max |conserved part of (P, L) - its start| / scale = linear "
            f"{h.linear:.2e}, angular {h.angular:.2e} (threshold {energy_tol:.0e})")))
    worst = float(np.nanmax(report.scaled_condition))
    report.checks.append(Check("mass matrix conditioning", worst, max_condition,
                               worst <= max_condition, (
                                   f"mass matrix conditioning: scaled condition number "
                                   f"{worst:.3g} (threshold {max_condition:.0e})")))
    if report.stiff:
        report.warnings.append(
            f"stiff: explicit methods (RK45, RK23, DOP853) are stability-limited here "
            f"(fastest time constant {_seconds(1 / report.fastest_decay)}); "
            "use auto, odeint, Radau, BDF or LSODA")
    raw = float(np.nanmax(report.condition))
    if raw > BADLY_SCALED and worst <= max_condition:
        report.warnings.append(
            f"mass matrix near-singular in absolute terms (condition number {raw:.2g}) but "
            f"{worst:.3g} after diagonal scaling: a coordinate that moves very little "
            "inertia, which the linear solve handles at full accuracy; expect fast motion "
            "in that coordinate")
    growth = float(np.nanmax(report.growth))
    if growth * report.t_end > 10:
        report.warnings.append(
            f"unstable modes along the path (Re lambda up to {growth:.3g} 1/s): nearby paths "
            "diverge, so errors can grow faster than the tolerance suggests")
    if report.constraints is not None:
        _judge_constraints(report, max_condition)
    for c in report.checks:
        if not c.passed:
            report.warnings.append(f"{c.name} misses its threshold: {c.value:.3g} > "
                                   f"{c.threshold:.0e}")


def _judge_constraints(report: StabilityReport, max_condition: float) -> None:
    """Closed chains: the constraint Jacobian A must keep its rank (a singular A is a
    locked or singular configuration: fail above ``max_condition``); a large
    condition number of A_d, the Jacobian with respect to the dependent speeds,
    is a dead point nearby (warning)."""
    c = report.constraints
    worst, at = c.worst(c.condition)
    report.checks.append(Check("constraint Jacobian conditioning", worst, max_condition,
                               worst <= max_condition, (
                                   f"constraint Jacobian conditioning: condition number "
                                   f"{worst:.3g} at t = {at:.4g} s (threshold "
                                   f"{max_condition:.0e})")))
    dead, dead_at = c.worst(c.dead)
    if dead > constrained.DEAD_POINT:
        report.warnings.append(
            f"near a dead point at t = {dead_at:.4g} s: the loops barely determine "
            f"{', '.join(c.dependent)} from the independent coordinates (|A_h| / sigma_min "
            f"= {dead:.3g}); the mechanism can lock or flip its assembly mode there")


def _seconds(value: float) -> str:
    if not math.isfinite(value):
        return "none"
    if value >= 1:
        return f"{value:.3g} s"
    if value >= 1e-3:
        return f"{value * 1e3:.3g} ms"
    return f"{value * 1e6:.3g} us"


def text(report: StabilityReport) -> str:
    """The report as printed by ``anadyn check``."""
    r = report
    k_decay = int(np.nanargmax(r.decay)) if len(r.decay) else 0
    k_speed = int(np.nanargmax(r.speed)) if len(r.speed) else 0
    k_classic = int(np.nanargmax(r.classic)) if len(r.classic) else 0
    k_cond = int(np.nanargmax(r.condition))
    k_scaled = int(np.nanargmax(r.scaled_condition))
    p = r.probe
    lines = [
        f"{r.robot.name}: {r.t_end:g} s, {len(r.t)} rows, odeint (LSODA) rtol {r.rtol:g} "
        f"atol {r.atol:g}, {r.rhs_calls} RHS calls"
        + ("" if r.passive else ", actuators' work integrated with the state"
           if r.load_work is None else
           ", actuators' and loads' work and dissipated energy integrated with the state"),
        f"eigenvalues of the Jacobian at {len(r.sample_t)} points along the path:",
        "  fastest decay        " + (
            f"{r.fastest_decay:.4g} 1/s at t = {r.sample_t[k_decay]:.4g} s (time constant "
            f"{_seconds(1 / r.fastest_decay)})" if r.fastest_decay * r.t_end > UNDAMPED else
            "none: no motion dies out over the run (an undamped robot: its modes oscillate "
            "or drift; the figures are in check.json)"),
        f"  fastest rate |lambda| {r.speed[k_speed]:.4g} 1/s at t = {r.sample_t[k_speed]:.4g} s",
        "  fastest growth       " + (f"{float(np.nanmax(r.growth)):.4g} 1/s"
                                     if float(np.nanmax(r.growth)) * r.t_end > UNDAMPED
                                     else "none: no motion grows over the run"),
        f"  stiffness ratio      {r.classic[k_classic]:.3g} (max/min |Re lambda| of the decaying"
        f" modes, min at least 1/horizon, at t = {r.sample_t[k_classic]:.4g} s); fastest decay"
        f" x horizon {r.auto_ratio:.3g} (auto's threshold {integrators.STIFF_RATIO:g})",
        f"explicit probe (RK45): {p.loose_calls}{'+' if p.loose_capped else ''} RHS calls at "
        f"rtol {PROBE_RTOLS[0]:.0e}, {p.tight_calls}{'+' if p.tight_capped else ''} at rtol "
        f"{PROBE_RTOLS[1]:.0e} over the first {p.window:.4g} s: calls fall "
        f"{'at least ' if p.tight_capped else ''}{1 / p.ratio:.2g}x for a 1e4 looser tolerance"
        f" (~6x when accuracy sets the step, ~1x when stability does)",
        f"stiffness: {'stiff' if r.stiff else 'not stiff'} (explicit methods are "
        f"{'' if r.stiff else 'not '}stability-limited"
        + ("; no mode decays along the path, so the equal call counts measure nothing)"
           if p.limited and not r.stiff else ")"),
        f"mass matrix: condition number up to {r.condition[k_cond]:.3g} (t = "
        f"{r.condition_t[k_cond]:.4g} s), {r.scaled_condition[k_scaled]:.3g} after diagonal "
        "scaling",
        (f"energy: passive, T + V drifts by at most {np.abs(r.energy_residual).max():.3g} J "
         f"(energy scale {r.energy_scale:.4g} J)" if r.passive else
         f"energy: actuators' work W from {r.work.min():.4g} to {r.work.max():.4g} J; "
         f"{r.balance} at most {np.abs(r.energy_residual).max():.3g} J (energy scale "
         f"{r.energy_scale:.4g} J)"),
    ]
    if r.load_work is not None:
        lines.insert(-1, f"energy: loads' work W_loads from {r.load_work.min():.4g} to "
                         f"{r.load_work.max():.4g} J; dissipated by joint damping and "
                         f"friction{'' if r.contacts is None else ' and the contacts'} "
                         f"E_d = {r.dissipated[-1]:.4g} J at the end")
    if r.constraints is not None:
        lines.append(r.constraints.line())
    if r.momentum is not None:
        lines.insert(-1, _momentum_line(r.momentum))
    for name, depth, at, tau in contact_figures(r):
        lines.insert(-1, f"contact {name} (compliant): largest penetration {depth:.3g} m" + (
            f" at t = {at:.4g} s; time constant sqrt(m/k_eff) there {_seconds(tau)}"
            if depth > 0 else " (never touched)"))
    for c in r.checks:
        lines.append(f"{'ok  ' if c.passed else 'FAIL'} {c.text}")
    for w in r.warnings:
        lines.append(f"warning: {w}")
    failed = [c.name for c in r.checks if not c.passed]
    lines.append(f"check: {'passed' if not failed else 'FAILED (' + ', '.join(failed) + ')'}")
    return "\n".join(lines)


def _momentum_line(h: Momentum) -> str:
    """What is conserved of a free robot's momentum, and its end values."""
    P, L = h.h[-1, :3], h.h[-1, 3:]
    what = ("nothing conserved: loads or contacts act" if not len(h.conserved) else
            "all conserved (no external force)" if len(h.conserved) == 6 else
            "conserved: P normal to gravity, L along it")
    return (f"momentum: free robot, {what}; at the end P = "
            f"({', '.join(f'{v:.4g}' for v in P)}) kg m/s, L = "
            f"({', '.join(f'{v:.4g}' for v in L)}) kg m^2/s (world axes, about the origin)")


def contact_figures(report: StabilityReport) -> list[tuple[str, float, float, float]]:
    """Per contact: its largest penetration d (m, 0 if it never touched), when, and the
    time constant sqrt(m / k_eff) of its body's mass on the spring linearized there,
    k_eff = p k d^(p-1) (inf when it never touched or its body has no mass)."""
    if report.contacts is None:
        return []
    out = []
    for c, name in enumerate(report.contacts.names):
        depth = report.contacts.values[c, 3]
        row = int(np.argmax(depth))
        d = max(float(depth[row]), 0.0)
        k, p, mass = report.contact_laws[c]
        stiffness = p * k * d ** (p - 1) if d > 0 else 0.0
        tau = math.sqrt(mass / stiffness) if stiffness > 0 and mass > 0 else math.inf
        out.append((name, d, float(report.t[row]), tau))
    return out


def summary(report: StabilityReport) -> dict:
    """Key figures (``check.json``)."""
    r = report
    return {
        "robot": r.robot.name, **r.computation, "t_end": r.t_end, "rows": len(r.t),
        "rtol": r.rtol,
        "atol": r.atol, "rhs_calls": r.rhs_calls, "passed": r.passed, "stiff": r.stiff,
        "fastest_decay": r.fastest_decay,
        "fastest_time_constant": 1 / r.fastest_decay if r.fastest_decay else None,
        "fastest_rate": float(np.nanmax(r.speed)),
        "fastest_growth": float(np.nanmax(r.growth)),
        "stiffness_ratio": float(np.nanmax(r.classic)),
        "decay_times_horizon": r.auto_ratio,
        "probe": {"method": "RK45", "rtols": list(PROBE_RTOLS), "window": r.probe.window,
                  "loose_calls": r.probe.loose_calls, "tight_calls": r.probe.tight_calls,
                  "loose_capped": r.probe.loose_capped, "tight_capped": r.probe.tight_capped,
                  "ratio": r.probe.ratio, "stability_limited": r.probe.limited},
        "mass_condition": float(np.nanmax(r.condition)),
        "mass_condition_scaled": float(np.nanmax(r.scaled_condition)),
        "passive": r.passive, "energy_error": r.energy_error,
        "momentum": None if r.momentum is None else {
            "conserved_rows": r.momentum.conserved.tolist(), "linear_drift": r.momentum.linear,
            "angular_drift": r.momentum.angular, "start": r.momentum.h[0].tolist(),
            "end": r.momentum.h[-1].tolist()},
        "energy_residual_max": float(np.abs(r.energy_residual).max()),
        "energy_scale": r.energy_scale,
        "actuator_work_final": float(r.work[-1]),
        "load_work_final": float(r.load_work[-1]) if r.load_work is not None else 0.0,
        "dissipated_final": float(r.dissipated[-1]) if r.dissipated is not None else 0.0,
        "checks": [{"name": c.name, "value": c.value, "threshold": c.threshold,
                    "passed": c.passed} for c in r.checks],
        "warnings": list(r.warnings),
        "timings": dict(r.timings),
        **({} if r.constraints is None else {"constraints": r.constraints.summary()}),
        **({} if r.contacts is None else {"contacts": {
            name: {"model": "compliant", "max_penetration": depth, "at": at,
                   "time_constant": tau if math.isfinite(tau) else None}
            for name, depth, at, tau in contact_figures(r)}}),
    }


@output.one_set
def write(report: StabilityReport, out: Path) -> list[Path]:
    """check.csv (the path's figures per eigenvalue sample) and check.json."""
    out = output.prepare_dir(out)
    written = [out / "check.csv"]
    rows = np.searchsorted(report.t, report.sample_t)
    cond_rows = np.searchsorted(report.condition_t, report.sample_t).clip(
        0, len(report.condition_t) - 1)
    forces = ([] if report.load_work is None else
              [("load_work", report.load_work[rows]), ("dissipated", report.dissipated[rows])])
    output.write_csv(written[0], ["t", "fastest_decay", "fastest_growth", "fastest_rate",
                                  "stiffness_ratio", "mass_condition", "mass_condition_scaled",
                                  "energy_residual", "actuator_work", *(f[0] for f in forces)],
                     [report.sample_t, report.decay, report.growth, report.speed,
                      report.classic, report.condition[cond_rows],
                      report.scaled_condition[cond_rows], report.energy_residual[rows],
                      report.work[rows], *(f[1] for f in forces)])
    written.append(out / "check.json")
    output.write_json(written[-1], summary(report))
    return written


def raise_if_failed(report: StabilityReport) -> None:
    failed = [c for c in report.checks if not c.passed]
    if failed:
        raise CheckFailed(f"{report.robot.source}: " + "; ".join(
            f"{c.name} {c.value:.3g} exceeds {c.threshold:.0e}" for c in failed))
