"""``linearize``: A, B and A_closed_loop at the operating point (the package
docstring), with the modes and the controllability rank."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from ...errors import SettingError
from ...numeric.pointwise import Evaluator
from .equations import Equations, evaluate, solve_spd
from .modes import controllability_rank, modes
from .parametric import as_strings, symbolic_form
from .point import (EQUILIBRIUM_TOL, OperatingPoint, check_efforts, parse_at, point_text,
                    start_point)


@dataclass
class Linearization:
    robot: str
    source: str
    formulation: str
    state: list[str]
    inputs: list[str]
    units: list[str]            # of the states
    point: OperatingPoint
    A: np.ndarray
    B: np.ndarray
    A_closed_loop: np.ndarray
    has_controller: bool
    eigenvalues: list[dict]
    eigenvalues_closed_loop: list[dict]
    controllability_rank: int
    #: names and units of the point's [q, u] when they are not the state's (a
    #: spherical joint: the state is on the tangent space); empty otherwise
    point_state: list[str] = field(default_factory=list)
    point_units: list[str] = field(default_factory=list)
    symbolic: dict | None = None              # the matrices below as text (linearize.json)
    symbolic_matrices: dict = field(default_factory=dict)   # name -> SymPy Matrix
    timings: dict = field(default_factory=dict)


def linearize(robot, formulation: str = "kane", at: str | None = None,
              equilibrium: bool = False, symbolic: bool = False,
              timings: dict | None = None, eom=None, efforts: str = "auto") -> Linearization:
    """Linearize ``robot`` (a validated Robot) about the operating point (see module doc).

    ``efforts``: where the point's efforts come from unless ``at`` gives them: "auto"
    (the controller, else holding, else zero), "controller", "holding" (static holding
    efforts, e.g. to design a controller about a set point), "zero"."""
    from ...symbolic.formulations import derive

    from ...model.constraints import refuse_closed_chain

    timings = {} if timings is None else timings
    refuse_closed_chain(robot, "linearize")
    robot.refuse_contacts("linearizations (linearize)")
    given = parse_at(at, robot)
    n, m = len(robot.speeds), len(robot.actuators)
    check_efforts(robot, efforts, given)
    if equilibrium and efforts == "holding":
        raise SettingError("equilibrium", "with efforts 'holding': holding efforts make a "
                                          "state at rest an equilibrium by construction; give "
                                          "the state in 'at'")
    start = time.perf_counter()
    if eom is None:
        eom = derive(robot, formulation)
    timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    eq = Equations(robot, eom)
    timings["differentiate"] = time.perf_counter() - start
    start = time.perf_counter()

    names = [c.name for c in robot.coordinates]
    state = names + ["d" + c for c in names]
    if eom.kinematic is not None:       # the point is given in [q, u]; A on the tangent space
        refuse_on_sphere(robot, given, equilibrium, symbolic)
        state = names + [u.name for u in robot.speeds]
    exact, t0, q0, dq0, source, fixed_tau, searched = start_point(
        robot, eq, given, efforts, equilibrium, state)

    # efforts at the point
    ev = Evaluator(eq.values(t0, q0, dq0))
    M0 = evaluate(ev, "mass matrix", lambda: ev.matrix(eq.M))
    F0 = evaluate(ev, "forcing", lambda: ev.vector(eq.F))
    B0 = evaluate(ev, "input matrix", lambda: ev.matrix(eq.B)) if m else np.zeros((n, 0))
    where = f"t = {t0:g} s, " + point_text(state, q0, dq0)
    law0 = (evaluate(ev, "control laws", lambda: ev.vector(eq.laws))
            if eq.laws is not None else np.zeros(m))
    holding_residual = None
    if source == "controller":
        tau0 = law0
    elif source == "holding":
        at_rest = Evaluator(eq.values(t0, q0, np.zeros(n)))
        F_rest = evaluate(at_rest, "forcing", lambda: at_rest.vector(eq.F))
        tau0 = np.linalg.pinv(B0) @ -F_rest
        holding_residual = float(np.max(np.abs(B0 @ tau0 + F_rest)))
    else:
        tau0 = fixed_tau
    ddq0 = solve_spd(M0, F0 + B0 @ tau0, where)
    is_equilibrium = bool(np.all(dq0 == 0) and np.max(np.abs(ddq0)) <= EQUILIBRIUM_TOL)

    A, Bss, A_cl = state_matrices(eq, (t0, q0, dq0), tau0, ddq0, law0, (M0, F0, B0), where)
    timings["evaluate"] = time.perf_counter() - start

    point = OperatingPoint(t0, q0, dq0, tau0, ddq0, source, is_equilibrium, searched,
                           holding_residual, exact)
    units = ([c.unit for c in robot.coordinates] + [c.unit + "/s" for c in robot.coordinates])
    point_state, point_units = [], []
    if eom.kinematic is not None:
        point_state = names + [u.name for u in robot.speeds]
        point_units = [c.unit for c in robot.coordinates] + [u.unit for u in robot.speeds]
        state, units = tangent_state(robot)
    result = Linearization(
        robot=robot.name, source=robot.source, formulation=eom.formulation, state=state,
        inputs=[a.name for a in robot.actuators], units=units, point=point, A=A, B=Bss,
        A_closed_loop=A_cl, has_controller=eq.laws is not None,
        eigenvalues=modes(A, Bss), eigenvalues_closed_loop=modes(A_cl),
        controllability_rank=controllability_rank(A, Bss), timings=timings,
        point_state=point_state, point_units=point_units)
    if symbolic:
        start = time.perf_counter()
        result.symbolic_matrices = symbolic_form(robot, formulation, point)
        result.symbolic = {k: (as_strings(v) if isinstance(v, sp.MatrixBase) else v)
                           for k, v in result.symbolic_matrices.items()}
        timings["symbolic"] = time.perf_counter() - start
    return result


def state_matrices(eq: Equations, x0, tau0, ddq0, law0, terms, where: str):
    """(A, B, A_closed_loop) at x0 = (t0, q0, dq0) with the point's efforts ``tau0``
    and accelerations ``ddq0``, the laws' efforts ``law0`` and terms = (M, F, B) there
    (the package docstring)."""
    t0, q0, dq0 = x0
    M0, F0, B0 = terms
    n, m = eq.n, eq.m
    rows, to_tangent = tangent_rows(eq, q0, dq0)
    # open loop: efforts held at tau0
    ev_open = Evaluator(eq.values(t0, q0, dq0, tau0, ddq0))
    K = evaluate(ev_open, "derivatives", lambda: ev_open.matrix(eq.Rx)) @ to_tangent
    A = np.zeros((2 * n, 2 * n))
    A[:n] = rows
    A[n:, :] = np.linalg.solve(M0, K)
    Bss = np.zeros((2 * n, m))
    if m:
        Bss[n:, :] = np.linalg.solve(M0, B0)
    # closed loop: u = tau_c(t, x), zero without a controller
    ddq_c = solve_spd(M0, F0 + B0 @ law0, where)
    ev_closed = Evaluator(eq.values(t0, q0, dq0, law0, ddq_c))
    K_c = evaluate(ev_closed, "derivatives", lambda: ev_closed.matrix(eq.Rx))
    if eq.Lx is not None:
        K_c = K_c + B0 @ evaluate(ev_closed, "control laws' derivatives",
                                   lambda: ev_closed.matrix(eq.Lx))
    A_cl = np.zeros((2 * n, 2 * n))
    A_cl[:n] = rows
    A_cl[n:, :] = np.linalg.solve(M0, K_c @ to_tangent)
    return A, Bss, A_cl


def tangent_rows(eq: Equations, q0, dq0) -> tuple[np.ndarray, np.ndarray]:
    """(the first n rows of A, T = dx/d(dx_tangent) ((nq + n) x 2n)).  Without a
    spherical joint: [0, I] and the identity.  With one, each quaternion's
    perturbation is a rotation vector dtheta in body axes, q = q0 (x) (1, dtheta/2):
    T maps it by dq = W(q0) dtheta (W of dq = W(q) u), and its rows are
    d(dtheta)/dt = du - w0 x dtheta (w0 the point's speeds)."""
    n, nq = eq.n, eq.nq
    rows = np.hstack([np.zeros((n, n)), np.eye(n)])
    if eq.kinematic is None:
        return rows, np.eye(2 * n)
    W = np.array(sp.Matrix(eq.kinematic).jacobian(eq.dq).xreplace(dict(zip(eq.q, q0)))
                 .evalf(), dtype=float)
    T = np.zeros((nq + n, 2 * n))
    T[:nq, :n], T[nq:, n:] = W, np.eye(n)
    for k in range(n - 3 * (nq - n), n, 3):             # each spherical joint's speeds
        wx, wy, wz = dq0[k:k + 3]
        rows[k:k + 3, k:k + 3] = -np.array([[0, -wz, wy], [wz, 0, -wx], [-wy, wx, 0]])
    return rows, T


def tangent_state(robot) -> tuple[list[str], list[str]]:
    """The names and units of the tangent state [coordinates, dtheta, speeds]: a
    spherical joint's rotation vector named theta_<its speed> (rad)."""
    quaternions = {name for b in robot.bodies for name in b.joint.coordinates}
    plain = [c for c in robot.coordinates if c.name not in quaternions]
    turns = [u for b in robot.bodies for u in b.joint.speeds]
    return ([c.name for c in plain] + [f"theta_{u.name}" for u in turns]
            + [u.name for u in robot.speeds],
            [c.unit for c in plain] + ["rad"] * len(turns) + [u.unit for u in robot.speeds])


def refuse_on_sphere(robot, given: dict, equilibrium: bool, symbolic: bool) -> None:
    """What the tangent-space linearization does not do with a spherical joint: one line."""
    n, nq = len(robot.speeds), len(robot.coordinates)
    what = ("equilibrium" if equilibrium else "symbolic" if symbolic else
            "at" if any(i >= n - 3 * (nq - n) for i in given["dq"]) else None)
    if what is not None:
        raise SettingError(what, "is not available for a robot with a spherical joint "
                                 "(linearize it at a given state: its file's or 'at' with "
                                 "coordinates and the rates of the other joints)")
