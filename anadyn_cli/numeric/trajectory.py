"""Prescribed motion q(t) from a robot file's ``trajectory`` section.

For every coordinate, on 0 <= t <= T (T = ``duration``), with q0 the start
(``from``, else the coordinate's initial value) and qf the end (``to``, else
q0: a coordinate left out holds still):

    cycloidal   q0 + (qf - q0)/T * (t - T/(2 pi) sin(2 pi t/T))
    quintic     q0 + (qf - q0) * (10 s^3 - 15 s^4 + 6 s^5),   s = t/T
    expression  the file's expression of t (left out: the initial value)
    waypoints   rest-to-rest segments (cycloidal or quintic) from pose to pose,
                one duration each (``model.waypoints``)
    spline      quintics through samples of q, dq and ddq (``model.spline``)

The rest-to-rest kinds start and end (waypoints: reach every pose) with zero
rate and zero acceleration.
The rates and accelerations are SymPy's exact derivatives of these
expressions (never finite differences), compiled into one vectorized NumPy
function ``motion(t) -> q, dq, ddq`` (arrays of shape t.shape + (n,)).

``derivatives`` is the one generator of that motion: ``motion`` compiles it
with every parameter a number (a plain run), ``numeric.bindable`` with the
swept parameters left as free symbols, bound per run.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .codegen import Function, module_source
from ..errors import ModelError
from ..model import waypoints
from ..model.robot import Robot

T = sp.Symbol("t", real=True)


@dataclass(frozen=True)
class Motion:
    """q(t), dq(t), ddq(t) for the robot's coordinates, and the compiled function."""
    kind: str
    duration: float
    names: tuple[str, ...]
    q: tuple[sp.Expr, ...]
    dq: tuple[sp.Expr, ...]
    ddq: tuple[sp.Expr, ...]
    source: str                   # generated Python source of ``motion``
    function: object              # motion(t) -> (q, dq, ddq)

    def __call__(self, t):
        """q, dq, ddq at ``t`` (scalar or array): arrays of shape t.shape + (n,)."""
        return self.function(t)


def expressions(robot: Robot) -> list[sp.Expr]:
    """q(t) for every coordinate of ``robot``, exact (SymPy, in the Symbol ``t``)."""
    trajectory = robot.trajectory
    if trajectory is None:
        raise missing(robot)
    duration = trajectory.duration
    result = []
    for c in robot.coordinates:
        if trajectory.kind in ("expression", "spline"):
            result.append(trajectory.expressions.get(c.name, c.initial))
            continue
        if trajectory.kind == "waypoints":       # the first pose's gaps: initial values
            result.append(trajectory.expressions[c.name].xreplace({c.symbol: c.initial}))
            continue
        start = trajectory.start.get(c.name, c.initial)
        end = trajectory.end.get(c.name, start)
        if trajectory.kind not in waypoints.SHAPES:    # the loader admits only these kinds
            raise ModelError(f"unknown trajectory kind {trajectory.kind!r}",
                             source=robot.source, path="trajectory.kind")
        result.append(start + (end - start) * waypoints.shape(trajectory.kind, T / duration))
    return result


def missing(robot: Robot) -> ModelError:
    return ModelError("no trajectory section: inverse dynamics needs a prescribed motion "
                      "(trajectory: kind cycloidal, quintic, expression, waypoints or spline)",
                      source=robot.source)


def derivatives(robot: Robot, values: dict | None = None, free=frozenset()
                ) -> tuple[list[sp.Expr], list[sp.Expr], list[sp.Expr]]:
    """q(t), dq(t), ddq(t) of the robot's trajectory section, exact (SymPy, in ``T``).

    The parameters are the robot's: numbers after the loader, or the ``free``
    symbols a bindable copy keeps (``values``: its parameter substitution, applied
    to q(t)).  ModelError when q(t) depends on anything but ``t`` and ``free``, or
    is not twice differentiable."""
    q = expressions(robot)
    if values is not None:
        q = [e.xreplace(values) for e in q]
    names = [c.name for c in robot.coordinates]
    for name, expr in zip(names, q):
        stray = expr.free_symbols - {T} - set(free)
        if stray:
            raise ModelError(f"{name}(t) may depend only on t, found "
                             f"{', '.join(sorted(map(str, stray)))}",
                             source=robot.source, path=f"trajectory.expressions.{name}")
    dq = [sp.diff(e, T) for e in q]
    ddq = [sp.diff(e, T) for e in dq]
    for name, expr in zip(names, ddq):
        if expr.has(sp.DiracDelta, sp.Derivative, sp.Subs):
            raise ModelError(f"{name}(t) is not twice differentiable (its rate jumps); "
                             "inverse dynamics needs a finite acceleration",
                             source=robot.source, path=f"trajectory.expressions.{name}")
    return q, dq, ddq


def function(q: list, dq: list, ddq: list) -> Function:
    """The generated ``motion(t) -> q, dq, ddq`` (vectorized) of ``derivatives``' result."""
    return Function("motion", (T,), (("q", q), ("dq", dq), ("ddq", ddq)), True,
                    "Prescribed q(t), dq(t), ddq(t); arrays of shape t.shape + (n,).")


def motion(robot: Robot) -> Motion:
    """The robot's prescribed motion with exact derivatives, compiled for NumPy."""
    q, dq, ddq = derivatives(robot)
    names = tuple(c.name for c in robot.coordinates)
    source = module_source([function(q, dq, ddq)],
                           f"prescribed motion of {robot.name} "
                           f"({robot.trajectory.kind}), from {robot.source}")
    namespace: dict[str, object] = {}
    exec(compile(source, "<anadyn trajectory>", "exec"), namespace)   # noqa: S102
    return Motion(robot.trajectory.kind, float(robot.trajectory.duration), names,
                  tuple(q), tuple(dq), tuple(ddq), source, namespace["motion"])


def motion_source(robot: Robot) -> str:
    """Source defining ``motion(t)`` with TRAJECTORY = (kind, duration), appended to
    the robot's generated module; a trajectory that cannot be compiled defines
    MOTION_ERROR (its one-line message) instead, raised when inverse asks for it;
    no trajectory defines nothing."""
    if robot.trajectory is None:
        return ""
    try:
        prescribed = motion(robot)
    except ModelError as err:
        return f"\nMOTION_ERROR = {str(err)!r}\n"
    return (f"\n{prescribed.source}\n\n"
            f"TRAJECTORY = ({prescribed.kind!r}, {prescribed.duration!r})\n")
