"""The rigid contact model: unilateral constraints with impacts, integrated event by event.

Every contact (``model.contacts``; ``numeric.contact`` gives its gap g = -d and the
velocity of its material point along n, t1, t2, all linear in the speeds u: the rows
J_n, J_t1, J_t2 of the contact Jacobian) is, at any time, in one of three states:

* ``open``: no force; the integration stops where g falls through 0 (touch-down);
* ``slide``: closed, g'' = 0, normal force f_n >= 0, friction -mu f_n s (s the unit
  slip direction in the ground's tangent plane); frictionless contacts are always
  this; it stops where f_n would pull (lift-off) or where the slip speed along s
  reaches 0 (it sticks, or slides on the other way);
* ``stick`` (mu > 0): closed, and the contact point's tangential velocity held at 0
  too; it stops where f_n would pull or where |f_t| reaches mu f_n (it slips).

Between events the accelerations solve, with the mode's constraint rows A (J_n of the
closed contacts, J_t of the sticking ones) and force rows F (J_n - mu s J_t for a
sliding contact, the same rows as A otherwise):

    M u' = G + F^T lambda,    A u' = b = -(dA/dt) u - 2 gamma A u - gamma^2 g

(G = F + B tau the free dynamics of the generated model; dA/dt u by a central
difference of A(q) u along q' (``DIFFERENCE``); gamma = ``STABILIZATION``: the gaps
and sticking velocities that the integrator's local errors leave are pulled back, as
for the closed chains, ``numeric.constrained``).  The events are located by
``scipy.integrate.solve_ivp`` on its dense output (Brent's method, to ~4 eps in t),
and the integration restarts there in the new mode.

**Impacts**: where a contact touches down (g <= ``GAP``) approaching faster than
``SPEED`` (J_n u < -SPEED), the speeds jump by an impulse, M (u+ - u-) = F^T Lambda
(momentum balance with the contact Jacobian), with Newton's restitution at every
touching contact: J_n u+ = -e J_n u- where Lambda_n > 0, J_n u+ >= -e J_n u- where
Lambda_n = 0 (several simultaneous contacts: all the touching ones, each with its own
e; the persistent ones approach at 0, so they stay at 0 or leave; the subset that
carries impulse is found by enumeration).  With friction each impulse-carrying
contact first sticks (J_t u+ = 0) if that impulse lies in the cone |Lambda_t| <=
mu Lambda_n, else slides with Lambda_t = -mu Lambda_n s, s the direction of the slip
before the impact (or, from rest, of -Lambda_t).  A rebound slower than SPEED is taken
as 0 (the contact stays closed: a bouncing ball's infinite bounces end).  The kinetic
energy lost in each impact is recorded; it is never negative for Newton's law on one
contact (and checked on every impact: ``Event.energy_lost``).

**Mode selection** after each event and at the start: among the touching contacts
at rest (|J_n u| <= SPEED), every combination of open and closed ones is tried,
closed ones first, until one is consistent (closed: f_n >= 0; open: g'' >= 0; stick:
inside the cone, else slide along -f_t); a contact whose lift-off or slip was the
event is not offered its old state.  Redundant constraints (more closed rows than
they fix) get the least-norm multipliers (``numpy.linalg.lstsq``).

Friction has one coefficient (static = kinetic).  What the contacts dissipate,
E_d' = -lambda^T F u (sliding friction; the stabilization's tiny work), is one more
integrated state, so that the energy balance T + V + E_d + (impact losses) = E0
holds on a passive robot.

Two guards of the event location: an event function that starts a stretch at 0 (a
contact that has just lifted off, rebounded or begun to slide) is divided by the time
since the start, so that its root there is not taken for the next event (a ball
rebounding slowly comes back within one step); and while an open sphere pair
approaches, the step is kept below half the time it takes to close the sum of the
radii (``Rigid.max_step``), since the gap of two spheres is not monotone and one could
pass through the other between two steps.

This module runs the model from event to event (``run``); the model at one state (the
modes, the kinematics, the field, the event functions, the impacts, the mode selection
and the constants named above) is ``contact_modes``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .contact_modes import GAP, Event, Mode, Rigid, _Kinematics
from .contact_run import ContactRun
from .integrators import ESTIMATE_FACTOR, ESTIMATE_FLOOR, IVP_METHODS, Solution, state_error

MAX_EVENTS = 100_000     # events in one run before it is given up (a Zeno run)
DEFAULT_METHOD = "DOP853"    # auto and odeint have no dense output to locate events on


@dataclass
class RigidRun:
    """A run of the rigid model: the rows (``solution``), the contacts on them (with
    the events and the energy balance), the events, and per row the energy the
    contacts took so far (``lost``: sliding friction's work and the impacts' losses)."""
    solution: Solution
    contacts: ContactRun
    events: list[Event]
    lost: np.ndarray


def run(model, grid: np.ndarray, method: str, rtol: float, atol: float,
        max_events: int = MAX_EVENTS) -> RigidRun:
    """The rigid model's run of ``model`` from its initial state, rows on ``grid``
    (``method``: a solve_ivp method; auto and odeint take ``DEFAULT_METHOD``)."""
    from scipy.integrate import solve_ivp

    chosen = method if method in IVP_METHODS else DEFAULT_METHOD
    reason = ("" if chosen == method else
              f"rigid contacts: events located on solve_ivp's dense output ({method} has "
              f"none to locate them on): {chosen}")
    sim = Rigid(model)
    start = time.perf_counter()
    t, y = float(grid[0]), np.append(model.initial_state(), 0.0)
    events: list[Event] = []
    mode, new = _resolve(sim, t, y, {})
    y = new[0]
    events += new[1]
    rows_t, rows_y, rows_c = [], [], []
    steps, handled, success, message = 0, 0, True, "rigid contacts: done"
    while True:
        watched = sim.events(mode, t, y)
        sol = solve_ivp(sim.field(mode), (t, float(grid[-1])), y, method=chosen, rtol=rtol,
                        atol=atol, events=watched, dense_output=True,
                        max_step=sim.max_step(mode, _Kinematics(model, t, y[:-1])))
        steps += len(sol.t) - 1
        end = float(sol.t[-1])
        inside = grid[(grid >= t) & ((grid < end) if sol.status == 1 else (grid <= end))]
        if len(inside):
            rows_t.append(inside)
            rows_y.append(sol.sol(inside).T.reshape(len(inside), -1))
            rows_c.append(np.stack([_contact_values(*sim.solve(tk, yk, mode)[1:])
                                    for tk, yk in zip(inside, rows_y[-1])], axis=-1))
        if sol.status == -1:
            success, message = False, (f"integration failed ({chosen}: {sol.message}) at "
                                       f"t = {end:.6g} s")
            break
        if sol.status == 0:
            break
        handled += 1
        if handled > max_events:
            success, message = False, (f"over {max_events} contact events by t = {end:.6g} s "
                                       "(a Zeno run: bounces without end?)")
            break
        fired = [sol.t_events[k].size > 0 for k in range(len(sol.t_events))]
        c, kind = watched[fired.index(True)].why
        t, y = end, sol.y[:, -1].copy()
        if kind in ("lift-off", "slip", "stick"):
            events.append(Event(t, sim.names[c], sim.bodies[c], kind))
        mode, new = _resolve(sim, t, y, {c: kind})
        y = new[0]
        events += new[1]
    wall = time.perf_counter() - start
    t_rows = np.concatenate(rows_t) if rows_t else grid[:1]
    y_rows = np.vstack(rows_y) if rows_y else y[None, :]
    x = y_rows[:, :-1]
    solution = Solution(t_rows, x, chosen, success, message, rhs_calls=sim.calls, steps=steps,
                        wall=wall, reason=reason)
    values = np.concatenate(rows_c, axis=-1) if rows_c else np.zeros((len(sim.names), 9, 0))
    strikes = np.array([[e.t, e.energy_lost] for e in events if e.energy_lost] or
                       np.zeros((0, 2)))
    losses = np.array([strikes[strikes[:, 0] <= s, 1].sum() for s in t_rows])
    lost = y_rows[:, -1] + losses
    contacts = ContactRun(model.contact_names, t_rows, values, model="rigid",
                          located=[e.summary() for e in events], balance=_balance(model, x, lost))
    return RigidRun(solution, contacts, events, lost)


def _balance(model, x: np.ndarray, lost: np.ndarray) -> float | None:
    """max |T + V + lost - E0| over the rows, relative to the largest of T and the
    range of V (``lost``: what the contacts dissipated and the impacts took); None
    when actuators, loads or joint forces act (their work is check's)."""
    if model.info.actuators or model.has_forces or not len(x):
        return None
    T, V = (np.asarray(v, dtype=float) for v in model.energy(x[:, :model.nq].T,
                                                            x[:, model.nq:].T))
    E = T + V + lost
    scale = max(float(T.max()), float(V.max() - V.min()), 1e-300)
    return float(np.abs(E - E[0]).max() / scale)


def _resolve(sim: Rigid, t: float, y: np.ndarray, hints: dict) -> tuple[Mode, tuple]:
    """The mode after an event (or at the start): the impact if a touching contact
    approaches, then the consistent mode; ((y after, impact events))."""
    state = y[:-1]
    kin = _Kinematics(sim.model, t, state)
    touching = [c for c in range(len(sim.names)) if kin.gap[c] <= GAP]
    state, impacts = sim.impact(t, state, kin, touching)
    if impacts:
        kin = _Kinematics(sim.model, t, state)
    mode = sim.select(t, state, kin, hints)
    return mode, (np.append(state, y[-1]), impacts)


def _contact_values(forces: np.ndarray, kin: _Kinematics, power: np.ndarray) -> np.ndarray:
    """(contacts, 9) at one row, as ``NumericModel.contacts`` gives them: f_n, f_t1,
    f_t2, the penetration -g, no spring energy, the dissipated power, J_n u, J_t u."""
    return np.column_stack([forces, -kin.gap, np.zeros(len(power)), -power, kin.vn, kin.vt])


def estimate_error(model, solution: Solution, rtol: float, atol: float) -> float:
    """``integrators.estimate_error`` for the rigid model: the run repeated by the same
    method at rtol * 1e-3 (not below 1e-13), the largest difference on the rows in
    ``state_error``'s norm (events included: a shifted impact shows); NaN if the
    re-run fails."""
    fine_rtol = max(rtol * ESTIMATE_FACTOR, ESTIMATE_FLOOR)
    fine = run(model, solution.t, solution.method, fine_rtol, atol * (fine_rtol / rtol))
    if not fine.solution.success or len(fine.solution.t) != len(solution.t):
        return math.nan
    return state_error(solution.x, fine.solution.x)[0]
