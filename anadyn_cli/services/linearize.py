"""Linearization about an operating point: state-space matrices, modes, controllability.

With x = [q, dq], u = tau and M(q) ddq = F(t, q, dq) + B(q) tau:

    dx/dt = f(t, x, u) = [dq, M^-1 (F + B u)]
    A = df/dx = [[0, I], [M^-1 K]],   B = df/du = [[0], [M^-1 B]]
    K = d(F + B u - M a)/dx  at the point's accelerations a = ddq0

(differentiating M ddq = F + B u gives M d(ddq) = d(F + B u) - (dM) ddq, so M
is never inverted symbolically).  A holds the efforts u0 fixed (open loop);
A_closed_loop is the Jacobian of the file's closed loop u = tau_c(t, x),
K_cl = K(u = tau_c(x0)) + B d(tau_c)/dx, with zero efforts when the file has
no controller (the motion ``simulate`` integrates).

The operating point is the file's initial state at t = 0 unless ``at``
says otherwise; its efforts u0 are the given ones, else the controller's at
that state, else the static holding efforts u0 = pinv(B) (-F(t, q, 0))
(exact when B is square and invertible; their residual is reported); ``efforts``
chooses otherwise (holding efforts about a set point, for a controller design).
``equilibrium`` first solves F(t, q, 0) + B tau(q) = 0 for q near the given
one (scipy.optimize.root, analytic Jacobian), with tau the controller's law at
rest, the given efforts, or zero without either.

Eigenvalues of A and A_closed_loop with natural frequency |lambda| and
damping ratio -Re(lambda)/|lambda|.  The controllability rank of (A, B) is the
dimension of the controllable subspace, grown one orthonormal Krylov block at
a time (the staircase form; better conditioned than the rank of
[B, AB, ..., A^(2n-1) B]), and each mode gets the Popov-Belevitch-Hautus test.
"""
from __future__ import annotations

import csv
import io
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy as sp

from ..errors import NumericalError, SettingError
from ..model import expressions
from ..numeric.pointwise import Evaluator
from .. import files as output
from ..symbolic.derivative import Derivative

TIME = sp.Symbol("t", real=True)
#: max |ddq| (in the coordinates' units / s^2) for a state to count as an equilibrium
EQUILIBRIUM_TOL = 1e-9
#: relative size under which a Krylov direction or a PBH singular value counts as zero
RANK_TOL = 1e-9


@dataclass
class OperatingPoint:
    t: float
    q: np.ndarray
    dq: np.ndarray
    tau: np.ndarray
    ddq: np.ndarray
    efforts_from: str           # "given", "controller", "holding", "none"
    equilibrium: bool           # at rest with ddq = 0 (to EQUILIBRIUM_TOL)
    searched: bool = False      # found by the equilibrium search
    holding_residual: float | None = None    # |B u0 + F| left by holding efforts
    exact: dict = field(default_factory=dict)   # symbol -> SymPy value (for symbolic output)


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
    symbolic: dict | None = None              # the matrices below as text (linearize.json)
    symbolic_matrices: dict = field(default_factory=dict)   # name -> SymPy Matrix
    timings: dict = field(default_factory=dict)


# -- the operating point (at) ----------------------------------------------------------
def _split(text: str) -> list[str]:
    """Split at commas outside brackets and parentheses."""
    parts, depth, current = [], 0, ""
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
            if depth < 0:
                raise SettingError("at", f"{text!r}: unbalanced {ch!r}")
        if ch == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += ch
    if depth:
        raise SettingError("at", f"{text!r}: unbalanced brackets")
    return parts + [current]


def parse_at(text: str | None, robot) -> dict:
    """The operating point ``at`` as {"t": expr, "q": {i: expr}, "dq": {i: expr}, "tau": {k: expr}}.

    Items ``name=value`` separated by commas: ``t``, a coordinate ``q1``, a rate
    ``dq1``, an actuator ``T01z``, or a whole vector ``q=[..]``, ``dq=[..]``,
    ``tau=[..]``.  Values are expressions of numbers, ``pi``, the file's
    parameters and gains (``q1=pi/6``, ``q2=q2f``), parsed safely.
    """
    result: dict = {"t": None, "q": {}, "dq": {}, "tau": {}}
    if text is None:
        return result
    coordinates = [c.name for c in robot.coordinates]
    actuators = [a.name for a in robot.actuators]
    scalars = {name: ("q", i) for i, name in enumerate(coordinates)}
    scalars.update({"d" + name: ("dq", i) for i, name in enumerate(coordinates)})
    scalars.update({name: ("tau", k) for k, name in enumerate(actuators)})
    scalars["t"] = ("t", None)
    sizes = {"q": len(coordinates), "dq": len(coordinates), "tau": len(actuators)}
    values = robot.parameter_substitution()
    names = {s.name: v for s, v in values.items()}
    if robot.controller is not None:
        names.update({k: v.xreplace(values) for k, v in robot.controller.gains.items()})
    allowed = ", ".join(["t", *coordinates, *("d" + c for c in coordinates), *actuators]
                        + [f"{v}=[...]" for v in ("q", "dq", "tau")
                           if v not in scalars and sizes[v]])
    if not text.strip():
        raise SettingError("at", f"is empty; give name=value items separated by commas ({allowed})")

    def value(item: str, raw: str) -> sp.Expr:
        try:
            expr = expressions.parse(raw.strip(), names)
            number = expressions.approximate(expr)
        except expressions.ExpressionError as err:
            raise SettingError("at", f"{item.strip()!r}: {err}") from None
        if not (math.isfinite(number.real) and number.imag == 0):
            raise SettingError("at", f"{item.strip()!r}: not a finite real number")
        return expr

    seen: set[str] = set()
    for item in _split(text):
        if "=" not in item:
            raise SettingError("at", f"{item.strip()!r}: expected name=value ({allowed})")
        key, raw = (part.strip() for part in item.split("=", 1))
        if key in seen:
            raise SettingError("at", f"gives {key} twice")
        seen.add(key)
        if key in scalars:
            kind, index = scalars[key]
            if kind == "t":
                result["t"] = value(item, raw)
            else:
                result[kind][index] = value(item, raw)
        elif key in sizes and sizes[key]:
            if not (raw.startswith("[") and raw.endswith("]")):
                example = ", ".join(["0"] * sizes[key])
                raise SettingError("at", f"{item.strip()!r}: {key} takes a list of "
                                 f"{sizes[key]} values, e.g. {key}=[{example}]")
            entries = _split(raw[1:-1]) if raw[1:-1].strip() else []
            if len(entries) != sizes[key]:
                raise SettingError("at", f"{item.strip()!r}: {key} has {sizes[key]} entries, "
                                 f"got {len(entries)}")
            for index, entry in enumerate(entries):
                result[key][index] = value(item, entry)
        else:
            raise SettingError("at", f"{item.strip()!r}: unknown name {key!r}; use {allowed}")
    if result["tau"] and len(result["tau"]) != len(actuators):
        missing = [a for k, a in enumerate(actuators) if k not in result["tau"]]
        raise SettingError("at", f"gives some efforts but not {', '.join(missing)}; give all "
                         "efforts or none")
    return result


# -- the equations, differentiated once ----------------------------------------
class _Equations:
    """R = F + B tau - M ddq with tau and ddq as symbols, its Jacobian in x, the laws'."""

    def __init__(self, robot, eom):
        self.q, self.dq = list(eom.q), list(eom.dq)
        self.ddq, self.tau = list(eom.ddq), list(eom.efforts)
        self.n, self.m = len(self.q), len(self.tau)
        self.M, self.F, self.B = sp.Matrix(eom.M), sp.Matrix(eom.F), sp.Matrix(eom.B)
        R = self.F - self.M * sp.Matrix(self.ddq)
        if self.m:
            R += self.B * sp.Matrix(self.tau)
        self.R = R
        self.laws = None
        if robot.controller is not None and self.m:
            from ..output.export.model import control_laws
            self.laws = control_laws(robot, eom.symbolic)
        self.Rx = self._jacobian(R)
        self.Lx = self._jacobian(self.laws) if self.laws is not None else None

    def _jacobian(self, exprs: sp.Matrix) -> sp.Matrix:
        columns = []
        for variable in self.q + self.dq:
            d = Derivative({variable: 1})
            columns.append([d(e) for e in exprs])
        return sp.Matrix(len(exprs), 2 * self.n, lambda i, j: columns[j][i])

    def values(self, t, q, dq, tau=None, ddq=None, constants=None) -> dict:
        values = dict(constants or {})
        values[TIME] = t
        values.update(zip(self.q, q))
        values.update(zip(self.dq, dq))
        if tau is not None:
            values.update(zip(self.tau, tau))
        if ddq is not None:
            values.update(zip(self.ddq, ddq))
        return values


def _evaluate(ev: Evaluator, what: str, function):
    try:
        return function()
    except ValueError as err:
        raise NumericalError(f"cannot evaluate the {what} at the operating point ({err})") \
            from None


def _solve_spd(M: np.ndarray, rhs: np.ndarray, where: str) -> np.ndarray:
    try:
        np.linalg.cholesky(M)
        return np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError:
        raise NumericalError(f"the mass matrix is singular or not positive definite at {where}") \
            from None


def _point_text(names: list[str], q, dq) -> str:
    return "(" + ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, [*q, *dq])) + ")"


# -- the linearization ----------------------------------------------------------
EFFORTS = ("auto", "controller", "holding", "zero")


def linearize(robot, formulation: str = "kane", at: str | None = None,
              equilibrium: bool = False, symbolic: bool = False,
              timings: dict | None = None, eom=None, efforts: str = "auto") -> Linearization:
    """Linearize ``robot`` (a validated Robot) about the operating point (see module doc).

    ``efforts``: where the point's efforts come from unless ``at`` gives them: "auto"
    (the controller, else holding, else zero), "controller", "holding" (static holding
    efforts, e.g. to design a controller about a set point), "zero"."""
    from ..symbolic.formulations import derive

    from ..model.constraints import refuse_closed_chain

    timings = {} if timings is None else timings
    refuse_closed_chain(robot, "linearize")
    given = parse_at(at, robot)
    n, m = len(robot.coordinates), len(robot.actuators)
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
    eq = _Equations(robot, eom)
    timings["differentiate"] = time.perf_counter() - start
    start = time.perf_counter()

    numeric = robot.parameter_substitution()
    exact: dict[sp.Symbol, sp.Expr] = {}
    for i, c in enumerate(robot.coordinates):
        exact[eq.q[i]] = given["q"].get(i, c.initial.xreplace(numeric))
        exact[eq.dq[i]] = given["dq"].get(i, c.rate.xreplace(numeric))
    exact[TIME] = given["t"] if given["t"] is not None else sp.Integer(0)
    t0 = float(exact[TIME])
    q0 = np.array([float(exact[s]) for s in eq.q])
    dq0 = np.array([float(exact[s]) for s in eq.dq])
    names = [c.name for c in robot.coordinates]
    state = names + ["d" + c for c in names]

    if given["tau"]:
        source = "given"
        fixed_tau = np.array([float(given["tau"][k]) for k in range(m)])
        for k in range(m):
            exact[eq.tau[k]] = given["tau"][k]
    elif m and eq.laws is not None and efforts in ("auto", "controller"):
        source, fixed_tau = "controller", None
    elif m and (efforts == "holding" or (efforts == "auto" and not equilibrium)):
        source, fixed_tau = "holding", None
    else:
        source, fixed_tau = "none", np.zeros(m)

    searched = False
    if equilibrium:
        if any(float(v) != 0 for v in given["dq"].values()):
            raise SettingError("equilibrium", "looks for a state at rest; leave the rates "
                                              "out of 'at' (or give them as 0)")
        dq0 = np.zeros(n)
        for s in eq.dq:
            exact[s] = sp.Integer(0)
        q0 = _find_equilibrium(eq, t0, q0, fixed_tau, state)
        for s, v in zip(eq.q, q0):
            exact[s] = _snapped(v)
        searched = True

    # efforts at the point
    ev = Evaluator(eq.values(t0, q0, dq0))
    M0 = _evaluate(ev, "mass matrix", lambda: ev.matrix(eq.M))
    F0 = _evaluate(ev, "forcing", lambda: ev.vector(eq.F))
    B0 = _evaluate(ev, "input matrix", lambda: ev.matrix(eq.B)) if m else np.zeros((n, 0))
    where = f"t = {t0:g} s, " + _point_text(state, q0, dq0)
    law0 = (_evaluate(ev, "control laws", lambda: ev.vector(eq.laws))
            if eq.laws is not None else np.zeros(m))
    holding_residual = None
    if source == "controller":
        tau0 = law0
    elif source == "holding":
        at_rest = Evaluator(eq.values(t0, q0, np.zeros(n)))
        F_rest = _evaluate(at_rest, "forcing", lambda: at_rest.vector(eq.F))
        tau0 = np.linalg.pinv(B0) @ -F_rest
        holding_residual = float(np.max(np.abs(B0 @ tau0 + F_rest)))
    else:
        tau0 = fixed_tau
    ddq0 = _solve_spd(M0, F0 + B0 @ tau0, where)
    is_equilibrium = bool(np.all(dq0 == 0) and np.max(np.abs(ddq0)) <= EQUILIBRIUM_TOL)

    # open loop: efforts held at tau0
    ev_open = Evaluator(eq.values(t0, q0, dq0, tau0, ddq0))
    K = _evaluate(ev_open, "derivatives", lambda: ev_open.matrix(eq.Rx))
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :] = np.linalg.solve(M0, K)
    Bss = np.zeros((2 * n, m))
    if m:
        Bss[n:, :] = np.linalg.solve(M0, B0)
    # closed loop: u = tau_c(t, x), zero without a controller
    ddq_c = _solve_spd(M0, F0 + B0 @ law0, where)
    ev_closed = Evaluator(eq.values(t0, q0, dq0, law0, ddq_c))
    K_c = _evaluate(ev_closed, "derivatives", lambda: ev_closed.matrix(eq.Rx))
    if eq.Lx is not None:
        K_c = K_c + B0 @ _evaluate(ev_closed, "control laws' derivatives",
                                   lambda: ev_closed.matrix(eq.Lx))
    A_cl = np.zeros((2 * n, 2 * n))
    A_cl[:n, n:] = np.eye(n)
    A_cl[n:, :] = np.linalg.solve(M0, K_c)
    timings["evaluate"] = time.perf_counter() - start

    point = OperatingPoint(t0, q0, dq0, tau0, ddq0, source, is_equilibrium, searched,
                           holding_residual, exact)
    units = ([c.unit for c in robot.coordinates] + [c.unit + "/s" for c in robot.coordinates])
    result = Linearization(
        robot=robot.name, source=robot.source, formulation=eom.formulation, state=state,
        inputs=[a.name for a in robot.actuators], units=units, point=point, A=A, B=Bss,
        A_closed_loop=A_cl, has_controller=eq.laws is not None,
        eigenvalues=modes(A, Bss), eigenvalues_closed_loop=modes(A_cl),
        controllability_rank=controllability_rank(A, Bss), timings=timings)
    if symbolic:
        start = time.perf_counter()
        result.symbolic_matrices = symbolic_form(robot, formulation, point)
        result.symbolic = {k: (_strings(v) if isinstance(v, sp.MatrixBase) else v)
                           for k, v in result.symbolic_matrices.items()}
        timings["symbolic"] = time.perf_counter() - start
    return result


def _snapped(value: float) -> sp.Expr:
    """An equilibrium coordinate for the symbolic form: k pi/12 exactly when the search
    landed within 1e-12 of one (a pendulum hangs at -pi/2), else the float."""
    k = round(value / (math.pi / 12))
    if abs(k) <= 48 and abs(value - k * math.pi / 12) <= 1e-12 * max(1.0, abs(value)):
        return sp.pi * k / 12
    return sp.Float(value)


def check_efforts(robot, efforts: str, given: dict | None = None) -> None:
    """``efforts`` against the robot and ``at`` (SettingError, exit 2)."""
    if efforts not in EFFORTS:
        raise SettingError("efforts", f"{efforts!r} is unknown; choose one of "
                                      f"{', '.join(EFFORTS)}")
    if efforts == "controller" and robot.controller is None:
        raise SettingError("efforts", f"controller: {robot.name} has no controller; use holding "
                         "or zero")
    if efforts != "auto" and given is not None and given["tau"]:
        raise SettingError("efforts", f"{efforts} and efforts in 'at': give one or the other")
    if efforts in ("controller", "holding") and not robot.actuators:
        raise SettingError("efforts", f"{efforts}: {robot.name} has no actuators")


def _find_equilibrium(eq: _Equations, t0: float, q0: np.ndarray, fixed_tau, state) -> np.ndarray:
    """q near q0 with F(t0, q, 0) + B(q) tau = 0, tau the law at rest or ``fixed_tau``."""
    from scipy.optimize import root

    n = eq.n
    zeros = np.zeros(n)

    def residual(q):
        tau = (fixed_tau if fixed_tau is not None
               else Evaluator(eq.values(t0, q, zeros)).vector(eq.laws))
        ev = Evaluator(eq.values(t0, q, zeros, tau, zeros))
        r = ev.vector(eq.R)
        J = ev.matrix(eq.Rx)[:, :n]
        if fixed_tau is None:
            J = J + ev.matrix(eq.B) @ ev.matrix(eq.Lx)[:, :n]
        return r, J, ev.matrix(eq.M)

    def accelerations(q) -> float:
        r, _, M = residual(q)
        return float(np.max(np.abs(np.linalg.solve(M, r))))

    try:
        if accelerations(q0) <= EQUILIBRIUM_TOL:
            return q0
        solution = root(lambda q: residual(q)[:2], q0, jac=True, method="hybr",
                        options={"xtol": 1e-14})
        q = np.asarray(solution.x, dtype=float)
        left = accelerations(q)
    except (ValueError, np.linalg.LinAlgError) as err:
        raise NumericalError(f"equilibrium search from {_point_text(state[:n], q0, [])} "
                             f"failed: {err}") from None
    if not left <= EQUILIBRIUM_TOL:
        raise NumericalError(
            f"no static equilibrium found near {_point_text(state[:n], q0, [])}: the search "
            f"stopped at {_point_text(state[:n], q, [])} with max |ddq| = {left:.3g} "
            f"({' '.join(solution.message.split()).rstrip('.')}); try another starting state "
            "in 'at'")
    return q


# -- modes and controllability ---------------------------------------------------
def modes(A: np.ndarray, B: np.ndarray | None = None) -> list[dict]:
    """Eigenvalues with natural frequency, damping ratio, time constant; PBH test with B."""
    values = np.linalg.eigvals(A)
    order = np.lexsort((values.imag, np.abs(values)))
    scale = max(np.linalg.norm(A, 2), np.linalg.norm(B, 2) if B is not None and B.size else 0.0,
                1e-300)
    result = []
    for lam in values[order]:
        size = abs(lam)
        entry = {"real": float(lam.real), "imag": float(lam.imag),
                 "natural_frequency": float(size), "frequency_hz": float(size / (2 * math.pi)),
                 "damping_ratio": float(-lam.real / size) if size > 0 else None,
                 "time_constant": float(1 / abs(lam.real)) if lam.real != 0 else None}
        if B is not None:
            if B.size == 0:
                entry["controllable"] = False
            else:
                pbh = np.hstack([A - lam * np.eye(len(A)), B])
                smallest = np.linalg.svd(pbh, compute_uv=False)[-1]
                entry["controllable"] = bool(smallest > RANK_TOL * max(scale, size))
        result.append(entry)
    return result


def controllability_rank(A: np.ndarray, B: np.ndarray) -> int:
    """Dimension of the controllable subspace of (A, B): orthonormal Krylov blocks."""
    size = len(A)
    if B.size == 0:
        return 0
    scale = max(np.linalg.norm(A, 2), np.linalg.norm(B, 2))
    U, s, _ = np.linalg.svd(B, full_matrices=False)
    basis = U[:, s > RANK_TOL * scale]
    new = basis
    while new.shape[1] and basis.shape[1] < size:
        W = A @ new
        for _ in range(2):                      # project out twice (Gram-Schmidt, again)
            W = W - basis @ (basis.T @ W)
        U, s, _ = np.linalg.svd(W, full_matrices=False)
        new = U[:, s > RANK_TOL * scale]
        basis = np.hstack([basis, new])
    return int(min(basis.shape[1], size))


# -- symbolic form ---------------------------------------------------------------
def symbolic_form(robot, formulation: str, point: OperatingPoint) -> dict:
    """E dx = A_bar dx + B_bar du at the point, parameters (and gains) as symbols.

    E = diag(I, M(q0)); A_bar = [[0, I], [K]]; B_bar = [[0], [B(q0)]].  K
    holds the point's efforts (the actuator symbols) and accelerations (the
    ddq symbols) unless the point is an equilibrium (ddq = 0) or passive
    (tau = 0).  Explicit A = E^-1 A_bar and B for n <= 2.
    """
    from ..symbolic.formulations import derive

    eom = derive(robot, formulation, symbolic=True)
    eq = _Equations(robot, eom)
    n, m = eq.n, eq.m
    values = {TIME: point.exact[TIME]}
    for s in eq.q + eq.dq:
        values[s] = point.exact[s]
    if point.equilibrium:
        values.update({a: sp.Integer(0) for a in eq.ddq})
    if point.efforts_from == "none":
        values.update({u: sp.Integer(0) for u in eq.tau})

    def at(expr: sp.Expr) -> sp.Expr:
        """The expression at the point, functions of plain numbers (sin(3/10)) as floats."""
        expr = expr.xreplace(values)
        numbers = {f: f.evalf(17) for f in expr.atoms(sp.Function) if not f.free_symbols}
        return expr.xreplace(numbers) if numbers else expr

    M = eq.M.applyfunc(at)
    K = eq.Rx.applyfunc(at)
    B = eq.B.applyfunc(at) if m else sp.zeros(n, 0)
    eye, zero = sp.eye(n), sp.zeros(n, n)
    E = sp.diag(eye, M)
    A_bar = sp.Matrix(sp.BlockMatrix([[zero, eye], [K[:, :n], K[:, n:]]]))
    B_bar = sp.Matrix.vstack(sp.zeros(n, m), B) if m else sp.zeros(2 * n, 0)
    result = {"parameters": sorted(str(s) for s in (E.free_symbols | A_bar.free_symbols
                                                     | B_bar.free_symbols)
                                   - set(eq.tau) - set(eq.ddq)),
              "form": "E dx/dt = A_bar dx + B_bar du", "E": E, "A_bar": A_bar, "B_bar": B_bar}
    closed = None
    if eq.laws is not None:
        laws = eq.laws.applyfunc(at)
        K_c = K.xreplace(dict(zip(eq.tau, laws))) + B * eq.Lx.applyfunc(at)
        closed = sp.Matrix(sp.BlockMatrix([[zero, eye], [K_c[:, :n], K_c[:, n:]]]))
        result["A_bar_closed_loop"] = closed
    if n <= 2:
        Minv = M.inv()
        lower = (Minv * K).applyfunc(_tidy)
        result["A"] = sp.Matrix(sp.BlockMatrix([[zero, eye], [lower[:, :n], lower[:, n:]]]))
        result["B"] = (sp.Matrix.vstack(sp.zeros(n, m), (Minv * B).applyfunc(_tidy)) if m
                       else sp.zeros(2 * n, 0))
        if closed is not None:
            lower = (Minv * closed[n:, :]).applyfunc(_tidy)
            result["A_closed_loop"] = sp.Matrix.vstack(closed[:n, :], lower)
    note = []
    if not point.equilibrium:
        note.append("ddq symbols are the accelerations at the point")
    if m and point.efforts_from != "none":
        note.append("actuator symbols are the efforts at the point")
    result["note"] = "; ".join(note) or "at an equilibrium"
    return result


def _tidy(expr: sp.Expr) -> sp.Expr:
    """A rational function of the parameters in lowest terms (cheap; no simplify)."""
    return sp.factor_terms(sp.cancel(expr)) if sp.count_ops(expr) < 2000 else expr


def _strings(matrix: sp.Matrix) -> list[list[str]]:
    return [[sp.sstr(matrix[i, j]) for j in range(matrix.cols)] for i in range(matrix.rows)]


# -- output ------------------------------------------------------------------------
def summary(result: Linearization) -> dict:
    p = result.point
    names = result.state[:len(p.q)]
    return {
        "robot": result.robot, "formulation": result.formulation, "evaluator": "closed-form",
        "state": result.state, "inputs": result.inputs, "units": result.units,
        "x0": [*map(float, p.q), *map(float, p.dq)], "u0": list(map(float, p.tau)),
        "operating_point": {
            "t": p.t, "q": dict(zip(names, map(float, p.q))),
            "dq": dict(zip(names, map(float, p.dq))),
            "tau": dict(zip(result.inputs, map(float, p.tau))),
            "ddq": dict(zip(names, map(float, p.ddq))),
            "efforts_from": p.efforts_from, "equilibrium": p.equilibrium,
            "searched_equilibrium": p.searched, "holding_residual": p.holding_residual},
        "A": result.A.tolist(), "B": result.B.tolist(),
        "A_closed_loop": result.A_closed_loop.tolist(), "controller": result.has_controller,
        "eigenvalues": result.eigenvalues,
        "eigenvalues_closed_loop": result.eigenvalues_closed_loop,
        "controllability_rank": result.controllability_rank,
        "controllable": result.controllability_rank == len(result.state),
        "stable_open_loop": all(e["real"] < 0 for e in result.eigenvalues),
        "stable_closed_loop": all(e["real"] < 0 for e in result.eigenvalues_closed_loop),
        **({"symbolic": result.symbolic} if result.symbolic is not None else {}),
        "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
    }


def _csv(rows: list[list]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    for row in rows:
        writer.writerow([f"{v:.17g}" if isinstance(v, float) else
                         "" if v is None else v for v in row])
    return buffer.getvalue()


def write(result: Linearization, out: Path) -> list[Path]:
    """linearize.json and the CSVs: A, B, A_closed_loop (a row per state derivative,
    header d/dt then the states or inputs) and the eigenvalues."""
    out = output.prepare_dir(out)
    written = []
    for name, matrix, columns in (("A", result.A, result.state), ("B", result.B, result.inputs),
                                  ("A_closed_loop", result.A_closed_loop, result.state)):
        rows = [["d/dt", *columns]] + [[s, *map(float, row)]
                                       for s, row in zip(result.state, matrix)]
        written.append(out / f"linearize_{name}.csv")
        output.write_text(written[-1], _csv(rows))
    keys = ["real", "imag", "natural_frequency", "frequency_hz", "damping_ratio",
            "time_constant"]
    rows = [["system", *keys, "controllable"]]
    for system, entries in (("open_loop", result.eigenvalues),
                            ("closed_loop", result.eigenvalues_closed_loop)):
        for e in entries:
            rows.append([system, *(e[k] for k in keys),
                         "" if "controllable" not in e else str(e["controllable"]).lower()])
    written.append(out / "linearize_eigenvalues.csv")
    output.write_text(written[-1], _csv(rows))
    written.append(out / "linearize.json")
    output.write_json(written[-1], summary(result))
    return written


def _matrix_text(matrix: np.ndarray, rows: list[str], columns: list[str]) -> list[str]:
    width = max([10, *map(len, columns)]) + 2
    label = max([4, *map(len, rows)])
    lines = [" " * label + "".join(f"{c:>{width}}" for c in columns)]
    for name, row in zip(rows, matrix):
        lines.append(f"{name:>{label}}" + "".join(f"{v:>{width}.6g}" for v in row))
    return lines


def report(result: Linearization) -> str:
    p = result.point
    n = len(p.q)
    units = result.units
    state = ", ".join(f"{s} = {v:.6g} {u}" for s, v, u in
                      zip(result.state, [*p.q, *p.dq], units))
    lines = [f"{result.robot} ({result.formulation}) at t = {p.t:g} s: {state}"]
    source = {"given": "given", "controller": "the controller's", "none": "zero",
              "holding": "static holding"}[p.efforts_from]
    if result.inputs:
        lines.append(f"efforts ({source}): " + ", ".join(
            f"{a} = {v:.6g}" for a, v in zip(result.inputs, p.tau))
            + ("" if p.holding_residual is None or p.holding_residual < 1e-9 else
               f" (they cannot hold the state: residual generalized force "
               f"{p.holding_residual:.3g})"))
    lines.append(("static equilibrium" + (" (found by the equilibrium search)" if p.searched else ""))
                 if p.equilibrium else
                 f"not an equilibrium: ddq = ({', '.join(f'{v:.4g}' for v in p.ddq)})")
    derivative = [f"d{s}" if i < n else f"dd{s[1:]}" for i, s in enumerate(result.state)]
    lines += ["", "A = d(dx/dt)/dx, efforts held:"]
    lines += _matrix_text(result.A, derivative, result.state)
    if result.inputs:
        lines += ["", "B = d(dx/dt)/d(tau):"]
        lines += _matrix_text(result.B, derivative, result.inputs)
    lines += ["", "A_closed_loop, " + ("under the file's control laws:" if result.has_controller
                                       else "zero efforts (no controller):")]
    lines += _matrix_text(result.A_closed_loop, derivative, result.state)
    lines += ["", f"{'eigenvalues':>28}  {'wn (rad/s)':>11}  {'zeta':>8}   "
                  f"{'closed loop':>28}  {'wn (rad/s)':>11}  {'zeta':>8}"]
    for a, b in zip(result.eigenvalues, result.eigenvalues_closed_loop):
        lines.append(f"{_complex(a):>28}  {a['natural_frequency']:>11.5g}  {_zeta(a):>8}   "
                     f"{_complex(b):>28}  {b['natural_frequency']:>11.5g}  {_zeta(b):>8}")
    size = len(result.state)
    rank = result.controllability_rank
    uncontrollable = [e for e in result.eigenvalues if not e.get("controllable", True)]
    lines += ["", f"controllability rank {rank} of {size}"
              + (" (controllable)" if rank == size else
                 f" (not controllable; modes failing the PBH test: "
                 f"{', '.join(_complex(e).strip() for e in uncontrollable) or 'none'})")]
    if result.symbolic is not None:
        s = result.symbolic
        lines += ["", f"symbolic ({s['form']}; parameters {', '.join(s['parameters']) or 'none'};"
                      f" {s['note']}):"]
        for key in ("A", "B", "A_closed_loop") if "A" in s else ("E", "A_bar", "B_bar"):
            if key in s:
                lines.append(f"  {key} = {s[key]}")
    return "\n".join(lines)


def _complex(e: dict) -> str:
    if e["imag"] == 0:
        return f"{e['real']:.6g}"
    return f"{e['real']:.6g} {'+' if e['imag'] > 0 else '-'} {abs(e['imag']):.6g}i"


def _zeta(e: dict) -> str:
    return "-" if e["damping_ratio"] is None else f"{e['damping_ratio']:.4g}"
