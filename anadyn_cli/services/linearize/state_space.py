"""``linearize``: A, B and A_closed_loop at the operating point (the package
docstring), with the modes and the controllability rank."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from ...errors import SettingError
from . import recursive
from .equations import Equations, Road, at_point, spd_solve
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
    evaluator: str = "closed-form"            # what ran the numbers (numeric.build's words)
    code: str = ""                            # and which code (``Road.code``)


def linearize(robot, formulation: str | None = None, at: str | None = None,
              equilibrium: bool = False, symbolic: bool = False,
              timings: dict | None = None, eom=None, efforts: str = "auto",
              evaluator: str | None = None, use_cache: bool = False) -> Linearization:
    """Linearize ``robot`` (a validated Robot, or a ``recorded.RecordedRobot``) about
    the operating point (see module doc).

    ``efforts``: where the point's efforts come from unless ``at`` gives them: "auto"
    (the controller, else holding, else zero), "controller", "holding" (static holding
    efforts, e.g. to design a controller about a set point), "zero".  ``evaluator``
    and ``formulation`` choose the numbers' road as ``numeric.build`` does
    (``equations_of``); ``eom``: the closed forms to differentiate, when the caller
    has them.  ``use_cache``: on the generic kernel, its tables are kept beside the
    robot's cache entry for the next run (``recursive.road``)."""
    from ...model.constraints import refuse_closed_chain

    timings = {} if timings is None else timings
    refuse_closed_chain(robot, "linearize")
    robot.refuse_contacts("linearizations (linearize)")
    given = parse_at(at, robot)
    n = len(robot.speeds)
    check_efforts(robot, efforts, given)
    if equilibrium and efforts == "holding":
        raise SettingError("equilibrium", "with efforts 'holding': holding efforts make a "
                                          "state at rest an equilibrium by construction; give "
                                          "the state in 'at'")
    eq = equations_of(robot, formulation, evaluator, eom, timings, use_cache)
    start = time.perf_counter()

    names = [c.name for c in robot.coordinates]
    state = names + ["d" + c for c in names]
    if eq.kinematic is not None:        # the point is given in [q, u]; A on the tangent space
        refuse_on_sphere(robot, given, equilibrium, symbolic)
        state = names + [u.name for u in robot.speeds]
    exact, t0, q0, dq0, source, fixed_tau, searched = start_point(
        robot, eq, given, efforts, equilibrium, state)

    # efforts at the point
    where = f"t = {t0:g} s, " + point_text(state, q0, dq0)
    M0, F0, B0 = at_point(where, "mass matrix, forcing and input matrix",
                          lambda: eq.terms(t0, q0, dq0))
    law0 = (at_point(where, "control laws", lambda: eq.law(t0, q0, dq0))
            if eq.laws is not None else np.zeros(eq.m))
    holding_residual = None
    if source == "controller":
        tau0 = law0
    elif source == "holding":
        F_rest = at_point(where, "forcing", lambda: eq.terms(t0, q0, np.zeros(n))[1])
        tau0 = np.linalg.pinv(B0) @ -F_rest
        holding_residual = float(np.max(np.abs(B0 @ tau0 + F_rest)))
    else:
        tau0 = fixed_tau
    ddq0 = at_point(where, "accelerations", lambda: spd_solve(M0, F0 + B0 @ tau0))
    is_equilibrium = bool(np.all(dq0 == 0) and np.max(np.abs(ddq0)) <= EQUILIBRIUM_TOL)

    A, Bss, A_cl = at_point(where, "derivatives",
                            lambda: state_matrices(eq, (t0, q0, dq0), tau0))
    timings["evaluate"] = time.perf_counter() - start

    point = OperatingPoint(t0, q0, dq0, tau0, ddq0, source, is_equilibrium, searched,
                           holding_residual, exact)
    units = ([c.unit for c in robot.coordinates] + [c.unit + "/s" for c in robot.coordinates])
    point_state, point_units = [], []
    if eq.kinematic is not None:
        point_state = names + [u.name for u in robot.speeds]
        point_units = [c.unit for c in robot.coordinates] + [u.unit for u in robot.speeds]
        state, units = tangent_state(robot)
    result = Linearization(
        robot=robot.name, source=robot.source, formulation=eq.formulation, state=state,
        inputs=[a.name for a in robot.actuators], units=units, point=point, A=A, B=Bss,
        A_closed_loop=A_cl, has_controller=eq.laws is not None,
        eigenvalues=modes(A, Bss), eigenvalues_closed_loop=modes(A_cl),
        controllability_rank=controllability_rank(A, Bss), timings=timings,
        point_state=point_state, point_units=point_units, evaluator=eq.evaluator,
        code=eq.code)
    if symbolic:
        start = time.perf_counter()
        result.symbolic_matrices = symbolic_form(robot, formulation or "kane", point)
        result.symbolic = {k: (as_strings(v) if isinstance(v, sp.MatrixBase) else v)
                           for k, v in result.symbolic_matrices.items()}
        timings["symbolic"] = time.perf_counter() - start
    return result


def equations_of(robot, formulation: str | None, evaluator: str | None, eom,
                 timings: dict, use_cache: bool = False) -> Road:
    """The road to the numbers: the closed forms of ``eom``, or of ``formulation``
    ("kane", "lagrange") when it is named or ``evaluator`` is "closed-form" (Kane's
    then), else the recursive evaluator (``recursive.road``: the generic kernel, else
    the generated derivatives) when it covers the robot, else Kane's closed forms;
    SettingError for a wrong choice (``evaluator`` "recursive" with a formulation, or
    on a robot it does not cover)."""
    from ...numeric.build import EVALUATORS, FORMULATIONS

    if evaluator is not None and evaluator not in EVALUATORS:
        raise SettingError("evaluator", f"must be {' or '.join(EVALUATORS)}, got {evaluator!r}")
    if formulation is not None and formulation not in FORMULATIONS:
        raise SettingError("formulation", f"must be {' or '.join(FORMULATIONS)}, "
                                          f"got {formulation!r}")
    if evaluator == "recursive" and (formulation is not None or eom is not None):
        raise SettingError("evaluator", f"recursive derives no symbolic equations; drop the "
                                        f"formulation ({formulation or eom.formulation}) or "
                                        "use closed-form")
    if evaluator == "recursive" and not recursive.covers(robot):
        raise SettingError("evaluator", f"recursive linearizes revolute and prismatic joints; "
                                        f"{robot.name} has a spherical joint: use closed-form, "
                                        "the default there")
    start = time.perf_counter()
    if eom is None and formulation is None and evaluator != "closed-form" \
            and recursive.covers(robot):
        eq = recursive.road(robot, timings, use_cache)
        timings["derive"] = (time.perf_counter() - start          # the plan and tables, or
                             - timings.get("native_compile", 0.0))  # the generated derivatives
        return eq
    if eom is None:
        from ...symbolic.formulations import derive

        eom = derive(robot, formulation or "kane")
    timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    eq = Equations(robot, eom)
    timings["differentiate"] = time.perf_counter() - start
    return eq


def state_matrices(eq: Road, x0, tau0):
    """(A, B, A_closed_loop) at x0 = (t0, q0, dq0) with the point's efforts ``tau0``
    held (A, B) or the laws' (A_closed_loop; zero efforts without a controller)."""
    t0, q0, dq0 = x0
    n, m = eq.n, eq.m
    rows, to_tangent = tangent_rows(eq, q0, dq0)
    D, G = eq.slopes(t0, q0, dq0, tau0)
    A = np.zeros((2 * n, 2 * n))
    A[:n] = rows
    A[n:, :] = D @ to_tangent
    Bss = np.zeros((2 * n, m))
    Bss[n:, :] = G
    A_cl = np.zeros((2 * n, 2 * n))
    A_cl[:n] = rows
    A_cl[n:, :] = eq.closed_loop_slopes(t0, q0, dq0) @ to_tangent
    return A, Bss, A_cl


def tangent_rows(eq: Road, q0, dq0) -> tuple[np.ndarray, np.ndarray]:
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
