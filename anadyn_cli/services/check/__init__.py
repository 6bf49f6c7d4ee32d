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

import time

import numpy as np

from ... import errors
from ...errors import ModelError, NumericalError, positive
from ...numeric import constrained, contact_run, integrators
from ...numeric.build import computation
from ...numeric.model import NumericModel
from ...numeric.settings import output_grid, resolve
from . import path
from .path import (PROBE_CALLS, eigen_samples, explicit_probe, forced, mass_conditions,
                   momentum, with_work)
from .report import (Check, StabilityReport, contact_figures, raise_if_failed, seconds,
                     summary, text, write)

SAMPLES = 200                 # Jacobian eigenvalue samples along the path
MAX_CONDITION = 1e8           # scaled mass-matrix condition number
BADLY_SCALED = 1e6            # raw condition number above this: a warning
ENERGY_TOL = 1e-6             # |T + V - W - E0| / energy scale

__all__ = ["check", "Check", "StabilityReport", "contact_figures", "raise_if_failed",
           "summary", "text", "write", "path"]


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
    rigid = model.rigid_contacts is not None
    if rigid:                                  # from event to event (numeric.impacts)
        x, lost, contacts, calls, wall = _rigid_path(model, grid, settings)
        work, load_work, dissipated = np.zeros(len(grid)), None, None
    else:
        extra = 3 if forced(model) else 1
        actuated = bool(robot.actuators) and robot.has_controller    # else the efforts are 0
        solution = integrators.integrate(with_work(model, actuated),
                                         np.append(x0, np.zeros(extra)), grid, "odeint",
                                         settings.rtol, settings.atol)
        if not solution.success:
            raise NumericalError(f"{solution.message}; the path cannot be checked")
        n2 = len(x0)
        x, work = solution.x[:, :n2], solution.x[:, n2]
        calls, wall = solution.rhs_calls, solution.wall
        load_work, dissipated = ((solution.x[:, n2 + 1], solution.x[:, n2 + 2]) if extra > 1
                                 else (None, None))
        contacts = contact_run.run_report(model, grid, x)
    timings["solve"] = wall

    start = time.perf_counter()
    sample_t, decay, growth, speed, classic = eigen_samples(model, grid, x, samples)
    timings["eigenvalues"] = time.perf_counter() - start
    start = time.perf_counter()
    probe = explicit_probe(model.problem(open_contacts=True) if rigid else model.problem(),
                           x0, grid[0], grid[-1], probe_calls)
    timings["probe"] = time.perf_counter() - start
    start = time.perf_counter()
    cond_t, raw, scaled = mass_conditions(model, grid, x)
    nq = model.nq
    T, V = model.energy(x[:, :nq].T, x[:, nq:].T)
    T, V = np.asarray(T, dtype=float), np.asarray(V, dtype=float)
    if contacts is not None:                   # the contacts' springs
        V = V + contacts.values[:, 4].sum(axis=0)
    E = T + V
    residual = E - work - E[0]
    if rigid:                                  # what sliding and the impacts took
        residual = residual + lost
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


def _rigid_path(model: NumericModel, grid: np.ndarray, settings):
    """The path of a scene with rigid contacts (``numeric.impacts.run``, DOP853: events
    located on its dense output): (states, energy the contacts took per row, the contacts'
    run, RHS calls, wall seconds).  Its energy balance T + V + taken = E0 needs every
    other force's work, which the event-driven run does not integrate: actuators, loads
    and joint forces are refused in one line."""
    from ...numeric import impacts

    if model.info.actuators or model.has_forces:
        raise ModelError("check with rigid contacts balances T + V + the contacts' losses, "
                         "so it takes scenes without actuators, loads or joint forces; use "
                         "simulate (or model: compliant) for this one",
                         source=model.info.source)
    ran = impacts.run(model, grid, impacts.DEFAULT_METHOD, settings.rtol, settings.atol)
    solution = ran.solution
    if not solution.success or len(solution.t) != len(grid):
        raise NumericalError(f"{solution.message}; the path cannot be checked")
    return solution.x, ran.lost, ran.contacts, solution.rhs_calls, solution.wall


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
            f"(fastest time constant {seconds(1 / report.fastest_decay)}); "
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
