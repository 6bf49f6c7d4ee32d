"""Trajectories given as samples: q, dq and ddq at increasing times (``kind: spline``).

    trajectory:
      kind: spline
      times: [0, 0.5, 1]                   # s, from 0, increasing
      q:   {q1: [0, 0.4, 1]}               # one value per time, plain numbers
      dq:  {q1: [0, 1.1, 0]}
      ddq: {q1: [2, 0, -2]}

Between two samples q(t) is the quintic that matches q, dq and ddq at both,
so q, dq and ddq are continuous and equal the samples at the sample times
(``anadyn optimize`` writes its motion this way).  A coordinate left out holds
its initial value.  The duration is the last time; q(t) is stored as one
piecewise polynomial per coordinate.
"""
from __future__ import annotations

import math

import sympy as sp

from .robot import Trajectory, frozen_map

KEYS = ("times", "q", "dq", "ddq")


def quintic(t: sp.Symbol, start: float, h: float, a: tuple, b: tuple) -> sp.Expr:
    """The quintic in t on [start, start + h] through (q, dq, ddq) = ``a`` at start and
    ``b`` at start + h."""
    q0, v0, a0 = a
    q1, v1, a1 = b
    c3 = (20 * (q1 - q0) - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h**2) / (2 * h**3)
    c4 = (30 * (q0 - q1) + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h**2) / (2 * h**4)
    c5 = (12 * (q1 - q0) - 6 * (v1 + v0) * h - (a0 - a1) * h**2) / (2 * h**5)
    s = t - sp.Float(start)
    return sum((sp.Float(c) * s**k for k, c in enumerate((q0, v0, a0 / 2, c3, c4, c5))
                if c != 0), sp.Integer(0))


def path(t: sp.Symbol, times: list[float], q: list[float], dq: list[float],
         ddq: list[float]) -> sp.Expr:
    """q(t) through the samples, one quintic per interval."""
    pieces = []
    for k in range(len(times) - 1):
        piece = quintic(t, times[k], times[k + 1] - times[k], (q[k], dq[k], ddq[k]),
                        (q[k + 1], dq[k + 1], ddq[k + 1]))
        pieces.append((piece, t < sp.Float(times[k + 1]) if k < len(times) - 2 else True))
    return pieces[0][0] if len(pieces) == 1 else sp.Piecewise(*pieces)


def _numbers(cursor, count: int | None) -> list[float]:
    items = cursor.sequence()
    values = []
    for item in items:
        if isinstance(item.value, bool) or not isinstance(item.value, (int, float)) \
                or not math.isfinite(item.value):
            raise item.error(f"expected a finite number, got {item.value!r}")
        values.append(float(item.value))
    if count is not None and len(values) != count:
        raise cursor.error(f"one value per time: {count} times, got {len(values)} values")
    return values


def read(loader, cursor, fields: dict) -> Trajectory:
    """The ``spline`` trajectory of ``fields`` (the loader's cursors of the section),
    checked: at least two times from 0, increasing, and for every coordinate given one
    finite number per time in each of q, dq and ddq."""
    for key in fields:
        if key not in ("kind", *KEYS):
            raise fields[key].error(f"'{key}' does not belong to a spline trajectory; it "
                                    "takes times, q, dq and ddq")
    for key in KEYS:
        if key not in fields:
            raise cursor.error(f"missing required key {key!r} for kind 'spline'")
    times = _numbers(fields["times"], None)
    if len(times) < 2 or times[0] != 0.0:
        raise fields["times"].error("at least two times, the first 0")
    if any(b <= a for a, b in zip(times, times[1:])):
        raise fields["times"].error("times must increase")
    samples: dict[str, dict[str, list[float]]] = {}
    for key in ("q", "dq", "ddq"):
        for name, item in fields[key].mapping().items():
            loader.known_coordinate(item, name)
            samples.setdefault(name, {})[key] = _numbers(item, len(times))
    t = sp.Symbol("t", real=True)
    expressions = {}
    for name, given in samples.items():
        missing = [key for key in ("q", "dq", "ddq") if key not in given]
        if missing:
            raise fields[missing[0]].error(f"{name} has q, dq and ddq or none of them; "
                                           f"{missing[0]} is missing")
        expressions[name] = path(t, times, given["q"], given["dq"], given["ddq"])
    return Trajectory("spline", sp.Float(times[-1]), frozen_map({}), frozen_map({}),
                      frozen_map(expressions))
