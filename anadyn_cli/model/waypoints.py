"""Rest-to-rest shapes, and trajectories through a sequence of poses (waypoints).

    trajectory:
      kind: waypoints
      points: [{q1: 0, q2: 0}, {q1: 1, q2: 0.5}, {q1: 0}]
      durations: [2, 3]                # s, one per segment: len(points) - 1
      shape: cycloidal                 # or quintic [default: cycloidal]

Segment k goes from pose k to pose k + 1 in ``durations[k]`` seconds,

    q(t) = p_k + (p_{k+1} - p_k) s(u),   u = (t - t_k) / d_k,   t_k = d_0 + ... + d_{k-1}

with a rest-to-rest shape s: cycloidal s(u) = u - sin(2 pi u)/(2 pi) (the
chapter's) or quintic s(u) = 10 u^3 - 15 u^4 + 6 u^5.  Both have s' = s'' = 0
at u = 0 and 1, so the robot stops at every pose and q, dq and ddq are
continuous at the poses (the jerk is not: a smooth path *through* poses
without stopping would need a spline).  A coordinate a pose leaves out keeps
its value from the pose before; the first pose's missing coordinates are
their initial values.  The trajectory's duration is the sum of the
durations; q(t) is stored as one piecewise expression per coordinate.
"""
from __future__ import annotations

import sympy as sp

from .robot import Trajectory, frozen_map

SHAPES = ("cycloidal", "quintic")


def shape(kind: str, u: sp.Expr) -> sp.Expr:
    """The rest-to-rest shape s(u), 0 <= u <= 1, s(0) = 0, s(1) = 1."""
    if kind == "cycloidal":
        return u - sp.sin(2 * sp.pi * u) / (2 * sp.pi)
    return 10 * u**3 - 15 * u**4 + 6 * u**5


def path(t: sp.Symbol, kind: str, durations: list[sp.Expr], values: list[sp.Expr]) -> sp.Expr:
    """q(t) through ``values`` (one per pose) in ``durations`` (one per segment)."""
    pieces, start = [], sp.Integer(0)
    for k, duration in enumerate(durations):
        a, b = values[k], values[k + 1]
        piece = a if a == b else a + (b - a) * shape(kind, (t - start) / duration)
        start = start + duration
        pieces.append((piece, t < start if k < len(durations) - 1 else True))
    return pieces[0][0] if len(pieces) == 1 else sp.Piecewise(*pieces)


def read(loader, cursor, fields: dict) -> Trajectory:
    """The ``waypoints`` trajectory of ``fields`` (the loader's cursors of the section),
    checked: at least two poses of known coordinates with finite values, one positive
    duration per segment.  A pose's missing coordinate is written as the coordinate's
    own symbol for its initial value (``numeric.trajectory`` puts the value in)."""
    for key in ("duration", "from", "to", "expressions"):
        if key in fields:
            raise fields[key].error(f"'{key}' does not belong to a waypoints trajectory; it "
                                    "takes points, durations and shape")
    for key in ("points", "durations"):
        if key not in fields:
            raise cursor.error(f"missing required key {key!r} for kind 'waypoints', e.g. "
                               "points: [{q1: 0}, {q1: 1}], durations: [2]")
    kind = fields["shape"].choice(SHAPES) if "shape" in fields else "cycloidal"
    poses = fields["points"].sequence()
    if len(poses) < 2:
        raise fields["points"].error(f"at least two poses are needed, got {len(poses)}")
    steps = fields["durations"].sequence()
    if len(steps) != len(poses) - 1:
        raise fields["durations"].error(f"one duration per segment: {len(poses)} points "
                                        f"need {len(poses) - 1}, got {len(steps)}")
    durations = []
    for item in steps:
        loader.positive(item, loader.constant(item), "a duration in s")
        durations.append(loader.constant(item).xreplace(loader.values))
    current = dict(loader.q)                # the first pose's default: the initial values
    values: dict[str, list[sp.Expr]] = {name: [] for name in loader.q}
    for pose in poses:
        for name, item in (pose.mapping().items() if pose.value is not None else ()):
            loader.known_coordinate(item, name)
            value = loader.constant(item)
            loader.check_numeric(item, value)
            current[name] = value.xreplace(loader.values)
        for name in values:
            values[name].append(current[name])
    t = sp.Symbol("t", real=True)
    total = sum(durations, sp.Integer(0))
    return Trajectory("waypoints", total, frozen_map({}), frozen_map({}),
                      frozen_map({n: path(t, kind, durations, v) for n, v in values.items()}))
