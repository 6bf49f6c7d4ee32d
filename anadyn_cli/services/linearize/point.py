"""The operating point: ``at`` parsed (``parse_at``), the efforts' source checked
(``check_efforts``), the static equilibrium searched (``find_equilibrium``)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from ...errors import NumericalError, SettingError
from ...model import expressions
from ...model.text import split_items
from .equations import TIME, Road

#: max |ddq| (in the coordinates' units / s^2) for a state to count as an equilibrium
EQUILIBRIUM_TOL = 1e-9
EFFORTS = ("auto", "controller", "holding", "zero")


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
    for item in split_items(text, "at"):
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
            entries = split_items(raw[1:-1], "at") if raw[1:-1].strip() else []
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


def find_equilibrium(eq: Road, t0: float, q0: np.ndarray, fixed_tau, state) -> np.ndarray:
    """q near q0 with ddq(t0, q, 0, tau) = 0 (F + B tau = 0), tau the law at rest or
    ``fixed_tau``: Powell's hybrid method on ddq with its Jacobian d(ddq)/dq (+ M^-1 B
    d(tau)/dq under the laws)."""
    from scipy.optimize import root

    n = eq.n
    zeros = np.zeros(n)

    def residual(q):
        tau = fixed_tau if fixed_tau is not None else eq.law(t0, q, zeros)
        D, G = eq.slopes(t0, q, zeros, tau)
        J = D[:, :n] if fixed_tau is not None else D[:, :n] + G @ eq.law_slopes(t0, q, zeros)[:, :n]
        return eq.accelerations(t0, q, zeros, tau), J

    def accelerations(q) -> float:
        tau = fixed_tau if fixed_tau is not None else eq.law(t0, q, zeros)
        return float(np.max(np.abs(eq.accelerations(t0, q, zeros, tau))))

    try:
        if accelerations(q0) <= EQUILIBRIUM_TOL:
            return q0
        solution = root(residual, q0, jac=True, method="hybr", options={"xtol": 1e-14})
        q = np.asarray(solution.x, dtype=float)
        left = accelerations(q)
    except (ValueError, np.linalg.LinAlgError) as err:
        raise NumericalError(f"equilibrium search from {point_text(state[:n], q0, [])} "
                             f"failed: {str(err) or 'the mass matrix is not positive definite'}") \
            from None
    if not left <= EQUILIBRIUM_TOL:
        raise NumericalError(
            f"no static equilibrium found near {point_text(state[:n], q0, [])}: the search "
            f"stopped at {point_text(state[:n], q, [])} with max |ddq| = {left:.3g} "
            f"({' '.join(solution.message.split()).rstrip('.')}); try another starting state "
            "in 'at'")
    return q


def snapped(value: float) -> sp.Expr:
    """An equilibrium coordinate for the symbolic form: k pi/12 exactly when the search
    landed within 1e-12 of one (a pendulum hangs at -pi/2), else the float."""
    k = round(value / (math.pi / 12))
    if abs(k) <= 48 and abs(value - k * math.pi / 12) <= 1e-12 * max(1.0, abs(value)):
        return sp.pi * k / 12
    return sp.Float(value)


def point_text(names: list[str], q, dq) -> str:
    return "(" + ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, [*q, *dq])) + ")"


def start_point(robot, eq: Road, given: dict, efforts: str, equilibrium: bool,
                state: list[str]):
    """The point before its efforts are evaluated: (exact values by symbol, t0, q0, dq0,
    where the efforts come from, the fixed efforts (None: evaluated at the point),
    whether the equilibrium search ran); ``given``: ``parse_at``'s result."""
    n, m = eq.n, eq.m
    numeric = robot.parameter_substitution()
    exact: dict[sp.Symbol, sp.Expr] = {}
    for i, c in enumerate(robot.coordinates):
        exact[eq.q[i]] = given["q"].get(i, c.initial.xreplace(numeric))
    for i, u in enumerate(robot.speeds):       # the rates, then a spherical joint's speeds
        exact[eq.dq[i]] = given["dq"].get(i, u.initial.xreplace(numeric))
    exact[TIME] = given["t"] if given["t"] is not None else sp.Integer(0)
    t0 = float(exact[TIME])
    q0 = np.array([float(exact[s]) for s in eq.q])
    dq0 = np.array([float(exact[s]) for s in eq.dq])

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
        q0 = find_equilibrium(eq, t0, q0, fixed_tau, state)
        for s, v in zip(eq.q, q0):
            exact[s] = snapped(v)
        searched = True
    return exact, t0, q0, dq0, source, fixed_tau, searched
