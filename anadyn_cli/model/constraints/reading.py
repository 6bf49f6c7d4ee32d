"""Reading ``loops``, ``constraints`` and the ``dependent`` marks of a robot file, each
mistake one line naming the file, line and key, and the checked constraints with a
consistent start (``build``)."""
from __future__ import annotations

import difflib

import sympy as sp
from dataclasses import replace

from ...errors import shorten
from ..names import GROUND
from ..robot import Body, Coordinate
from ..yamlschema import describe_value as _kind
from .equations import (DIRECTIONS, TIME, Constraints, Loop, LoopPoint, PositionConstraint,
                        Row, VelocityConstraint)
from .geometry import Geometry, System, number
from .start import check_redundancy, closed_start, consistent_rates

LOOP_KEYS = ("a", "b", "directions", "name")
POINT_KEYS = ("body", "point")
CONSTRAINT_KEYS = ("position", "velocity", "name")


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
    system = System(geometry, loops, positions, velocities, builder.values, coordinates)
    cursors = {**{loop.path: top["loops"].child(int(loop.path[6:-1]), None) for loop in loops},
               **{e.path: top["constraints"].child(int(e.path[12:-1]), None)
                  for e in (*positions, *velocities)}}
    check_redundancy(system, cursors, coordinates)
    _check_count(top, coordinate_cursors, names, dependent, loops, positions, velocities, h)
    q0 = closed_start(system, cursors, coordinates, dependent, coordinate_cursors)
    rates, speeds = consistent_rates(system, cursors, coordinates, dependent, q0,
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
    return "[" + ", ".join(f"{number(v, values):g}" for v in vector) + "]"


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

