"""Closed chains and constraints in a robot file: what they say, checked, and a
consistent start.

A closed chain is written as a tree (one joint of each loop cut) plus what
closes it; the coordinates marked ``dependent: true`` are solved for:

    coordinates.Q.dependent   true: Q follows from the constraints; its
                              ``initial`` is a guess (it picks the assembly mode)
    loops[i]                  {a: {body, point}, b: {body | ground, point},
                               directions: [x, y, z], name}: point a of body A
                              and point b of body B (or of the world) coincide
                              along the listed world axes
    constraints[i]            {position: f(q, t)}:  f = 0 (holonomic), or
                              {velocity: {dQ: a_Q, ..., t: a_0}}:
                              sum_k a_k dq_k + a_0 = 0 (nonholonomic, eq. 6.8),
                              with a_k, a_0 expressions of q and t; ``name``
                              optional in both

Holonomic equations f(q, t) = 0 (h of them): a loop gives
(r_a - r_b) . e for each listed world axis e, r the world position of the
point; a position entry gives its expression.  The degrees of freedom of the
configuration are n - h, and exactly h coordinates must be marked dependent.
Velocity entries (p of them) take further speeds away but no coordinate.

What is checked here, each with one line naming the file, line and key:
unknown bodies, coordinates and keys; loops joining a body to itself;
the count of dependent coordinates against the holonomic equations (the
message names both counts); redundant equations (rank of the constraint
Jacobian at random configurations; a direction along which the points never
move apart is named as such); inconsistent ones (a direction along which
they are apart whatever the coordinates; a loop that cannot close at the
start); a start at a dead point (dependent coordinates not determined by the
independent ones); initial rates that break the constraints; trajectories
that prescribe a dependent coordinate.

The consistent start: the dependent coordinates are solved from f(q, 0) = 0
by Newton's method from their guesses, the independent ones held (the
Jacobian by central differences; the residual itself is exact, so the result
is as accurate as f can be evaluated).  Then the rates: the dependent
coordinates' rates and, for each velocity constraint, one more (the rate
left out of the file, else given, with the largest coefficient) are solved
from A dq + a_0 = 0; a rate the file gives for one of them must agree.  The
robot then carries the solved values as the coordinates' initial values and
rates, so every run starts on the constraints.

This module computes positions by its own forward kinematics in floating
point (like ``massmatrix``), not by ``symbolic.kinematics``: the loader runs
before any symbolic work.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, replace
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import ModelError, shorten
from .names import GROUND
from .yamlschema import describe_value as _kind
from .robot import Body, Coordinate

DIRECTIONS = ("x", "y", "z")
LOOP_KEYS = ("a", "b", "directions", "name")
POINT_KEYS = ("body", "point")
CONSTRAINT_KEYS = ("position", "velocity", "name")
NEWTON_ITERATIONS = 100
CLOSED = 1e-10            # |f| at the start, relative to the mechanism's size
RANDOM_STATES = 3         # configurations at which redundancy is judged
RANK_TOL = 1e-8           # singular values below this times the largest: rank lost
DEAD_POINT = 1e6          # condition number of df/dq_dependent at the start: locked
RATE_TOL = 1e-9           # a given rate of a solved speed must agree to this (relative)
TIME = sp.Symbol("t", real=True)


@dataclass(frozen=True)
class LoopPoint:
    body: str                     # a body name or GROUND
    point: tuple                  # body axes (world axes for ground), m


@dataclass(frozen=True)
class Loop:
    a: LoopPoint
    b: LoopPoint
    directions: tuple[str, ...]   # world axes along which the points coincide
    name: str
    path: str                     # "loops[0]", for messages


@dataclass(frozen=True)
class PositionConstraint:
    expression: sp.Expr           # f(q, t), parameters as symbols
    name: str
    path: str


@dataclass(frozen=True)
class VelocityConstraint:
    coefficients: Mapping[str, sp.Expr]   # coordinate name -> a_k(q, t)
    constant: sp.Expr                     # a_0(q, t)
    name: str
    path: str


@dataclass(frozen=True)
class Row:
    """One constraint equation: its multiplier's CSV column, what it is, its unit."""
    column: str                   # e.g. lambda_loop1_x
    source: str                   # "loops[0]", "constraints[1]"
    kind: str                     # "loop", "position", "velocity"
    meaning: str
    unit: str                     # of the multiplier (N for a loop)


@dataclass(frozen=True)
class Constraints:
    """Everything that closes the chain; rows are ordered holonomic first (loops in
    file order, then position entries), then the velocity entries."""
    loops: tuple[Loop, ...]
    positions: tuple[PositionConstraint, ...]
    velocities: tuple[VelocityConstraint, ...]
    dependent: tuple[str, ...]            # coordinates solved from f = 0, file order
    dependent_speeds: tuple[str, ...]     # rates solved from A dq + a0 = 0: the dependent
    #                                       coordinates', then one per velocity constraint
    rows: tuple[Row, ...]

    @property
    def holonomic(self) -> int:
        return sum(len(loop.directions) for loop in self.loops) + len(self.positions)

    @property
    def count(self) -> int:
        return self.holonomic + len(self.velocities)


# ----------------------------------------------------------------------------
# reading the file
# ----------------------------------------------------------------------------
def wanted(top: dict, coordinate_cursors: dict) -> bool:
    """Whether the file uses any of the constraint keys."""
    marked = any(isinstance(c.value, dict) and "dependent" in c.value
                 for c in coordinate_cursors.values())
    return "loops" in top or "constraints" in top or marked


def build(builder, top: dict, coordinate_cursors: dict, bodies: tuple[Body, ...],
          coordinates: tuple[Coordinate, ...]) -> tuple[Constraints, tuple[Coordinate, ...]]:
    """Parse and check ``loops``, ``constraints`` and the ``dependent`` marks; solve the
    consistent start.  Returns the constraints and the coordinates with consistent
    initial values and rates."""
    body_names = [b.name for b in bodies]
    loops = tuple(_loop(builder, item, body_names, k)
                  for k, item in enumerate(top["loops"].sequence())) if "loops" in top else ()
    positions, velocities = [], []
    if "constraints" in top:
        for k, item in enumerate(top["constraints"].sequence()):
            entry = _constraint(builder, item, k)
            (velocities if isinstance(entry, VelocityConstraint) else positions).append(entry)
    dependent, marks = _dependent(coordinate_cursors)
    names = [c.name for c in coordinates]
    h = sum(len(loop.directions) for loop in loops) + len(positions)
    rows = _rows(builder, loops, positions, velocities, bodies)
    for row in rows:                  # a multiplier's column must not repeat another name
        if row.column in builder.owner:
            where = (top["loops"] if row.kind == "loop" else top["constraints"])
            raise where.error(f"the multiplier column {row.column!r} of {row.source} clashes "
                              f"with {builder.owner[row.column]}; give the constraint a name")
    geometry = Geometry(bodies, builder.values, [c.symbol for c in coordinates])
    system = _System(geometry, loops, positions, velocities, builder.values, coordinates)
    cursors = {**{loop.path: top["loops"].child(int(loop.path[6:-1]), None) for loop in loops},
               **{e.path: top["constraints"].child(int(e.path[12:-1]), None)
                  for e in (*positions, *velocities)}}
    _check_redundancy(system, cursors, coordinates)
    _check_count(top, coordinate_cursors, names, dependent, loops, positions, velocities, h)
    q0 = _closed_start(system, cursors, coordinates, dependent, coordinate_cursors)
    rates, speeds = _consistent_rates(system, cursors, coordinates, dependent, q0,
                                      coordinate_cursors)
    solved = tuple(replace(c, initial=sp.Float(float(q0[i]), 17) if c.name in dependent
                           else c.initial,
                           rate=sp.Float(float(rates[i]), 17) if c.name in speeds
                           else c.rate)
                   for i, c in enumerate(coordinates))
    if "trajectory" in top:
        _check_trajectory(top["trajectory"], dependent)
    return Constraints(loops, tuple(positions), tuple(velocities), tuple(dependent),
                       tuple(speeds), rows), solved


def _loop(builder, item, body_names: list[str], k: int) -> Loop:
    fields = item.mapping(LOOP_KEYS, required=("a", "b"))
    ends = []
    for key in ("a", "b"):
        point_fields = fields[key].mapping(POINT_KEYS, required=("body",))
        body = point_fields["body"].value
        if not isinstance(body, str):
            raise point_fields["body"].error(f"expected a body name or 'ground', got "
                                             f"{_kind(body)}")
        if body != GROUND and body not in body_names:
            close = difflib.get_close_matches(body, [GROUND, *body_names], n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise point_fields["body"].error(
                f"unknown body {shorten(body, 40)!r}{hint}; a loop joins points of two of: "
                f"{', '.join([*body_names, GROUND])}")
        point = builder.constant_vector(point_fields.get("point"))
        ends.append(LoopPoint(body, tuple(point)))
    if ends[0].body == ends[1].body:
        raise fields["b"].child("body", None).error(
            f"both ends of the loop are on {ends[0].body!r}; a loop joins two different "
            "bodies (or a body and the ground)")
    directions = DIRECTIONS
    if "directions" in fields:
        listed = fields["directions"].sequence()
        if not listed:
            raise fields["directions"].error("expected at least one of x, y, z")
        directions = []
        for entry in listed:
            axis = entry.choice(DIRECTIONS)
            if axis in directions:
                raise entry.error(f"direction {axis} is listed twice")
            directions.append(axis)
        directions = tuple(directions)
    name = _name(builder, fields, f"loop{k + 1}")
    return Loop(ends[0], ends[1], directions, name, f"loops[{k}]")


def _name(builder, fields: dict, default: str) -> str:
    if "name" not in fields:
        return default
    name = fields["name"].identifier("constraint name")
    builder.claim(fields["name"], name, "a constraint")
    return name


def _constraint(builder, item, k: int):
    fields = item.mapping(CONSTRAINT_KEYS)
    kinds = [key for key in ("position", "velocity") if key in fields]
    if len(kinds) != 1:
        raise item.error("a constraint is either {position: f(q, t)} (f = 0) or {velocity: "
                         "{dq1: a1, dq2: a2, t: a0}} (a1*dq1 + a2*dq2 + a0 = 0), "
                         f"got {'both' if kinds else 'neither'}")
    path = f"constraints[{k}]"
    names = {**builder.symbols, **builder.q, "t": TIME}
    if kinds[0] == "position":
        cursor = fields["position"]
        expression = cursor.expr(names, builder.unavailable(names), smooth=True)
        if not (expression.free_symbols & set(builder.q.values())):
            raise cursor.error("a position constraint must depend on at least one "
                               "coordinate, e.g. q3 - 2*q1")
        return PositionConstraint(expression, _name(builder, fields, f"c{k + 1}"), path)
    cursor = fields["velocity"]
    coefficients, constant = {}, sp.Integer(0)
    rates = {"d" + name: name for name in builder.q}
    for key, entry in cursor.mapping().items():
        if key == "t":
            constant = entry.expr(names, builder.unavailable(names), smooth=True)
            continue
        if key not in rates:
            options = [*rates, "t"]
            close = difflib.get_close_matches(str(key), options, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise entry.error(f"unknown rate; {hint}a velocity constraint takes coefficients "
                              f"of the rates {', '.join(rates)} and the constant term t")
        coefficients[rates[key]] = entry.expr(names, builder.unavailable(names), smooth=True)
    if not any(value != 0 for value in coefficients.values()):
        raise cursor.error("a velocity constraint needs a coefficient for at least one rate, "
                           "e.g. {dq1: cos(q3), dq2: sin(q3)}")
    return VelocityConstraint(coefficients, constant, _name(builder, fields, f"c{k + 1}"), path)


def _dependent(coordinate_cursors: dict) -> tuple[list[str], dict]:
    dependent, marks = [], {}
    for name, cursor in coordinate_cursors.items():
        if isinstance(cursor.value, dict) and "dependent" in cursor.value:
            mark = cursor.child("dependent", cursor.value["dependent"])
            if not isinstance(mark.value, bool):
                raise mark.error(f"expected true or false, got {_kind(mark.value)}")
            marks[name] = mark
            if mark.value:
                dependent.append(name)
    return dependent, marks


def _check_count(top, coordinate_cursors, names, dependent, loops, positions, velocities,
                 h: int) -> None:
    n = len(names)
    independent = [q for q in names if q not in dependent]
    if len(dependent) == h:
        if not independent and not any(TIME in p.expression.free_symbols for p in positions):
            raise top["coordinates"].error(
                f"{n} coordinate{'s' * (n != 1)} and {h} holonomic constraint equations leave "
                "no degree of freedom; a mechanism needs at least one independent coordinate")
        return
    equations = ", ".join([f"{loop.path}: {', '.join(loop.directions)}" for loop in loops]
                          + [p.path for p in positions]) or "none"
    dof = n - h
    if h == 0:
        raise coordinate_cursors[dependent[0]].child("dependent", True).error(
            f"{', '.join(dependent)} {'is' if len(dependent) == 1 else 'are'} marked dependent, "
            "but there are no loops or position constraints to solve "
            f"{'it' if len(dependent) == 1 else 'them'} from"
            + ("; velocity constraints take speeds, not coordinates" if velocities else ""))
    if dof < 0:
        raise top["coordinates"].error(
            f"{n} coordinates but {h} holonomic constraint equations ({equations}): more "
            "equations than coordinates; the constraints are redundant or inconsistent")
    marked = ", ".join(dependent) or "none"
    raise top["coordinates"].error(
        f"{n} coordinates and {h} holonomic constraint equations ({equations}) leave {dof} "
        f"degree{'s' * (dof != 1)} of freedom, so exactly {h} coordinate{'s' * (h != 1)} "
        f"must be marked dependent: true; marked: {marked}")


def _rows(builder, loops, positions, velocities, bodies) -> tuple[Row, ...]:
    rows = []
    for loop in loops:
        where = (f"point {_vector_text(loop.a.point, builder.values)} of {loop.a.body}")
        other = ("the ground" if loop.b.body == GROUND else loop.b.body)
        for axis in loop.directions:
            rows.append(Row(f"lambda_{loop.name}_{axis}", loop.path, "loop",
                            f"force on {loop.a.body} at {where.split(' of ')[0]}, world {axis} "
                            f"(the opposite on {other})", "N"))
    for entry in positions:
        rows.append(Row(f"lambda_{entry.name}", entry.path, "position",
                        f"multiplier of {entry.path}: generalized force -lambda df/dq", ""))
    for entry in velocities:
        rows.append(Row(f"lambda_{entry.name}", entry.path, "velocity",
                        f"multiplier of {entry.path}: generalized force lambda a_k", ""))
    return tuple(rows)


def _vector_text(vector, values) -> str:
    return "[" + ", ".join(f"{_number(v, values):g}" for v in vector) + "]"


def _check_trajectory(cursor, dependent: list[str]) -> None:
    if not isinstance(cursor.value, dict):
        return
    for key in ("from", "to", "expressions"):
        entries = cursor.value.get(key)
        if isinstance(entries, dict):
            for name in entries:
                if name in dependent:
                    raise cursor.child(key, entries).child(name, None).error(
                        f"{name} is dependent (solved from the constraints); prescribe only "
                        "independent coordinates")


# ----------------------------------------------------------------------------
# numbers: forward kinematics and the constraint functions
# ----------------------------------------------------------------------------
def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return (math.cos(angle) * np.eye(3) + math.sin(angle) * skew
            + (1 - math.cos(angle)) * np.outer(axis, axis))


def _number(expr, values) -> float:
    return float(expr.xreplace(values)) if isinstance(expr, sp.Basic) else float(expr)


class Geometry:
    """World poses of the body frames at numeric q (floating point)."""

    def __init__(self, bodies: tuple[Body, ...], values: dict, q_symbols: list):
        self.items = []
        e = np.eye(3)
        for body in bodies:
            joint = body.joint
            roll, pitch, yaw = (_number(a, values) for a in joint.rpy)
            C = _rotation(e[2], yaw) @ _rotation(e[1], pitch) @ _rotation(e[0], roll)
            axis = np.array([_number(a, values) for a in joint.axis])
            norm = np.linalg.norm(axis)
            axis = axis / norm if norm > 0 else axis
            origin = np.array([_number(a, values) for a in joint.origin])
            kind = joint.joint_type
            move = (sp.lambdify(q_symbols, joint.displacement.xreplace(values), modules="math")
                    if kind.moving else None)
            self.items.append((body.name, body.parent, kind, C, axis, origin, move))

    def poses(self, q) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Body name -> (R, p): body axes to world axes, body origin in world axes."""
        poses = {GROUND: (np.eye(3), np.zeros(3))}
        for name, parent, kind, C, axis, origin, move in self.items:
            R_p, p_p = poses[parent]
            R_l, o = kind.transform(C, origin, axis, float(move(*q)) if move else 0.0, _rotation)
            poses[name] = (R_p @ R_l, p_p + R_p @ o)
        return poses


class _System:
    """The constraint equations in numbers: holonomic f(q, t) and velocity rows."""

    def __init__(self, geometry: Geometry, loops, positions, velocities, values, coordinates):
        self.geometry, self.loops = geometry, loops
        symbols = [c.symbol for c in coordinates] + [TIME]
        self.n = len(coordinates)
        self.points = [(loop, np.array([_number(v, values) for v in loop.a.point]),
                        np.array([_number(v, values) for v in loop.b.point])) for loop in loops]
        self.positions = [sp.lambdify(symbols, p.expression.xreplace(values), modules="math")
                          for p in positions]
        def compiled(expr):
            return sp.lambdify(symbols, expr.xreplace(values), modules="math")

        self.velocities = [([compiled(v.coefficients.get(c.name, sp.Integer(0)))
                             for c in coordinates],
                            compiled(v.constant)) for v in velocities]
        self.paths = ([loop.path for loop in loops for _ in loop.directions]
                      + [p.path for p in positions] + [v.path for v in velocities])
        self.h = sum(len(loop.directions) for loop in loops) + len(positions)
        # a length scale for "closed": the largest distance in the file's geometry
        lengths = [np.abs(origin).sum() for *_, origin, _ in geometry.items]
        lengths += [np.abs(a).sum() + np.abs(b).sum() for _, a, b in self.points]
        self.scale = max(1.0, *lengths) if lengths else 1.0

    def f(self, q, t: float = 0.0) -> np.ndarray:
        q = [float(v) for v in q]
        out = []
        if self.points:
            poses = self.geometry.poses(q)
            for loop, a, b in self.points:
                R_a, p_a = poses[loop.a.body]
                R_b, p_b = poses[loop.b.body]
                gap = (p_a + R_a @ a) - (p_b + R_b @ b)
                out += [gap[DIRECTIONS.index(axis)] for axis in loop.directions]
        out += [float(function(*q, t)) for function in self.positions]
        return np.array(out, dtype=float)

    def jacobian(self, q, t: float = 0.0) -> np.ndarray:
        """df/dq by central differences (h x n)."""
        q = np.asarray(q, dtype=float)
        J = np.zeros((self.h, self.n))
        for k in range(self.n):
            step = 1e-6 * max(1.0, abs(q[k]))
            up, down = q.copy(), q.copy()
            up[k] += step
            down[k] -= step
            J[:, k] = (self.f(up, t) - self.f(down, t)) / (2 * step)
        return J

    def time_rate(self, q, t: float = 0.0) -> np.ndarray:
        step = 1e-6
        return (self.f(q, t + step) - self.f(q, t - step)) / (2 * step)

    def velocity_rows(self, q, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        q = [float(v) for v in q]
        A = np.array([[float(a(*q, t)) for a in row] for row, _ in self.velocities],
                     dtype=float).reshape(len(self.velocities), self.n)
        a0 = np.array([float(c(*q, t)) for _, c in self.velocities], dtype=float)
        return A, a0

    def pfaffian(self, q, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """A (c x n), a0 (c,): all constraints in velocity form, holonomic rows first."""
        A_nh, a_nh = self.velocity_rows(q, t)
        return (np.vstack([self.jacobian(q, t), A_nh]),
                np.concatenate([self.time_rate(q, t), a_nh]))


def _random_states(coordinates, rng) -> list[np.ndarray]:
    q0 = np.array([float(c.initial) for c in coordinates])
    spread = np.array([math.pi if c.unit == "rad" else max(0.1, abs(float(c.initial)))
                       for c in coordinates])
    return [q0 + spread * rng.uniform(-1, 1, len(q0)) for _ in range(RANDOM_STATES)]


def _check_redundancy(system: _System, cursors: dict, coordinates) -> None:
    """Constraint rows that are dependent at every random configuration: redundant (or,
    for a row that never changes and is not zero, inconsistent)."""
    c = system.h + len(system.velocities)
    if c == 0:
        return
    rng = np.random.default_rng(0)
    states = _random_states(coordinates, rng)
    matrices = [system.pfaffian(q, 0.0)[0] for q in states]
    if any(not np.isfinite(A).all() for A in matrices):
        return                                   # not evaluable there: judged at the start
    scale = max(1.0, max(float(np.abs(A).max(initial=0.0)) for A in matrices))
    for row in range(c):
        if all(np.abs(A[row]).max(initial=0.0) <= 1e-12 * scale for A in matrices):
            _refuse_constant_row(system, cursors, row, states)
    ranks = [np.linalg.matrix_rank(A, tol=RANK_TOL * max(1.0, np.abs(A).max())) for A in
             matrices]
    if max(ranks) == c:
        return
    A = matrices[int(np.argmax(ranks))]
    kept = np.zeros((0, system.n))
    for row in range(c):
        trial = np.vstack([kept, A[row]])
        if np.linalg.matrix_rank(trial, tol=RANK_TOL * max(1.0, np.abs(A).max())) == len(kept):
            path = system.paths[row]
            what = _describe_row(system, row)
            raise cursors[path].error(
                f"{what} is redundant: at every configuration tried it is a combination of "
                f"the constraint equations before it (rank {max(ranks)} of {c}); leave it out")
        kept = trial


def _describe_row(system: _System, row: int) -> str:
    if row < sum(len(loop.directions) for loop in system.loops):
        k = row
        for loop in system.loops:
            if k < len(loop.directions):
                return f"the loop's {loop.directions[k]} equation"
            k -= len(loop.directions)
    return "this constraint"


def _refuse_constant_row(system: _System, cursors: dict, row: int, states) -> None:
    path = system.paths[row]
    if row >= system.h:
        raise cursors[path].error("the velocity constraint's coefficients are zero at every "
                                  "configuration tried; it constrains no rate")
    value = float(system.f(states[0], 0.0)[row])
    if row < sum(len(loop.directions) for loop in system.loops):
        axis = _describe_row(system, row).split("'s ")[1].split()[0]
        if abs(value) <= CLOSED * system.scale:
            raise cursors[path].error(
                f"along {axis} the two points never move apart (they stay in one plane), so "
                f"that direction constrains nothing; list only the others, e.g. directions: "
                f"[{', '.join(d for d in DIRECTIONS if d != axis)}]")
        raise cursors[path].error(
            f"along {axis} the two points are {abs(value):.6g} m apart whatever the "
            "coordinates, so the loop can never close; check the points and the joint origins")
    if abs(value) <= CLOSED * system.scale:
        raise cursors[path].error("the position constraint is 0 whatever the coordinates; it "
                                  "constrains nothing")
    raise cursors[path].error(f"the position constraint stays {value:.6g} whatever the "
                              "coordinates, so it can never hold")


def _closed_start(system: _System, cursors: dict, coordinates, dependent: list[str],
                  coordinate_cursors: dict) -> np.ndarray:
    """q0 with the dependent coordinates solved from f(q, 0) = 0 (Newton, damped)."""
    names = [c.name for c in coordinates]
    q = np.array([float(c.initial) for c in coordinates])
    if system.h == 0:
        return q
    index = [names.index(name) for name in dependent]
    residual = system.f(q)
    if not np.isfinite(residual).all():
        raise cursors[system.paths[0]].error("the constraints cannot be evaluated at the "
                                             "initial state")
    norm = np.abs(residual).max()
    for _ in range(NEWTON_ITERATIONS):
        if norm <= CLOSED * system.scale * 1e-3:
            break
        J = system.jacobian(q)[:, index]
        step = np.linalg.lstsq(J, -residual, rcond=None)[0]
        scale = 1.0
        while scale > 1e-6:
            trial = q.copy()
            trial[index] += scale * step
            trial_residual = system.f(trial)
            trial_norm = np.abs(trial_residual).max()
            if np.isfinite(trial_norm) and trial_norm < norm:
                break
            scale /= 2
        else:
            break                                # no progress: the closest point found
        q, residual, norm = trial, trial_residual, trial_norm
    if norm > CLOSED * system.scale:
        row = int(np.argmax(np.abs(residual)))
        held = ", ".join(f"{names[i]} = {q[i]:.6g}" for i in range(len(names))
                         if names[i] not in dependent)
        path = system.paths[row]
        if row < sum(len(loop.directions) for loop in system.loops):
            loop_rows = [r for r in range(system.h) if system.paths[r] == path]
            gap = float(np.linalg.norm(residual[loop_rows]))
            what = (f"the loop cannot close at the start: with {held} held, its points stay "
                    f"{gap:.6g} m apart at the closest found ({_solved(q, names, dependent)})")
        else:
            what = (f"cannot be met at the start: with {held} held, it stays "
                    f"{residual[row]:.6g} at the closest found ({_solved(q, names, dependent)})")
        raise cursors[path].error(f"{what}; check the lengths, the points and the independent "
                                  "coordinates' initial values")
    J = system.jacobian(q)
    condition = np.linalg.cond(J[:, index]) if index else 1.0
    if not condition < DEAD_POINT:
        raise coordinate_cursors[dependent[0]].error(
            f"at the start the dependent coordinates {', '.join(dependent)} are not determined "
            f"by the independent ones (df/d({', '.join(dependent)}) has condition number "
            f"{condition:.3g}): the mechanism starts at a dead point, where it can lock or flip; "
            "move the independent coordinates' initial values or mark other coordinates "
            "dependent")
    return q


def _solved(q, names, dependent) -> str:
    return ", ".join(f"{name} = {q[names.index(name)]:.6g}" for name in dependent)


def _consistent_rates(system: _System, cursors: dict, coordinates, dependent: list[str],
                      q0: np.ndarray, coordinate_cursors: dict) -> tuple[np.ndarray, list[str]]:
    """dq0 solving A dq + a0 = 0 for the dependent speeds; (rates, dependent speeds)."""
    names = [c.name for c in coordinates]
    given = {name for name, cursor in coordinate_cursors.items()
             if isinstance(cursor.value, dict) and "rate" in cursor.value}
    rates = np.array([float(c.rate) for c in coordinates])
    c = system.h + len(system.velocities)
    if c == 0:
        return rates, []
    A, a0 = system.pfaffian(q0, 0.0)
    speeds = [names.index(name) for name in dependent]
    for row in range(system.h, c):
        candidates = [k for k in range(len(names)) if k not in speeds]
        best, best_size = None, -1.0
        for pool in ([k for k in candidates if names[k] not in given], candidates):
            for k in pool:
                size = np.linalg.svd(A[: row + 1, speeds + [k]], compute_uv=False).min()
                if size > best_size * (1 + 1e-12):
                    best, best_size = k, size
            if best is not None and best_size > 1e-9 * max(1.0, np.abs(A).max()):
                break
        if best is None or not best_size > 1e-9 * max(1.0, np.abs(A).max()):
            raise cursors[system.paths[row]].error(
                "at the start this velocity constraint fixes no rate the others leave free "
                "(its coefficients are zero or a combination of the constraints before it)")
        speeds.append(best)
    known = [k for k in range(len(names)) if k not in speeds]
    rhs = -(A[:, known] @ rates[known] + a0)
    try:
        solved = np.linalg.solve(A[:, speeds], rhs)
    except np.linalg.LinAlgError:
        raise cursors[system.paths[0]].error("the constraints do not determine the dependent "
                                             "rates at the start") from None
    for k, value in zip(speeds, solved):
        if names[k] in given:
            stated = rates[k]
            if abs(stated - value) > RATE_TOL * max(1.0, abs(value), abs(stated)):
                raise coordinate_cursors[names[k]].child("rate", None).error(
                    f"{stated:g} breaks the constraints at the start (they give {value + 0.0:.6g} "
                    f"for d{names[k]} with the other rates as given); leave it out to have it "
                    "solved, or make the rates consistent")
        rates[k] = value
    return rates, [names[k] for k in speeds]


def refuse_closed_chain(robot, command: str) -> None:
    """Closed chains are refused: their reduced equations are not M ddq = F + B tau in
    the coordinates, and exporting the cut tree would be silently wrong."""
    if getattr(robot, "constraints", None) is not None:
        raise ModelError(f"{robot.source}: {robot.name} has constraints (closed loops); "
                         f"{command} handles open chains only")
