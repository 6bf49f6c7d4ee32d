"""YAML robot file -> validated, frozen ``Robot``.

Every mistake raises ``ModelError`` naming the file, line, key path, what is
wrong and what is allowed.  The README documents each key read here.
"""
from __future__ import annotations

import difflib
import hashlib
import keyword
import math
import re
from pathlib import Path
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import ModelError
from . import expressions
from .robot import (GROUND, JOINT_TYPES, Actuator, Body, Controller, Coordinate, Joint,
                    Robot, Simulation, Trajectory, frozen_map)
from .yamlsource import load, read_text

IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}\Z")
# names also become Python identifiers in generated code and CSV columns
RESERVED_NAMES = (expressions.RESERVED | {"t", GROUND, "math", "numpy"}
                  | set(keyword.kwlist) | set(keyword.softkwlist))
TRAJECTORY_KINDS = ("cycloidal", "quintic", "expression")
TOP_KEYS = ("name", "description", "parameters", "gravity", "coordinates", "bodies",
            "actuators", "controller", "trajectory", "simulation")


def load_robot(path: str | Path) -> Robot:
    """Read and validate a robot file."""
    text, source = read_text(path)
    return robot_from_text(text, source)


def robot_from_text(text: str, source: str = "<robot>") -> Robot:
    """Validate YAML text describing a robot (``source`` names it in errors)."""
    data, lines = load(text, source)
    digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()
    default_name = Path(source).stem if source.endswith((".yaml", ".yml")) else "robot"
    return _RobotBuilder(Cursor(data, "", source, lines), digest, default_name).build()


class Cursor:
    """A value in the file together with its key path, for precise errors."""

    def __init__(self, value: object, path: str, source: str, lines: dict[str, int]):
        self.value, self.path, self.source, self.lines = value, path, source, lines

    def error(self, message: str) -> ModelError:
        path = self.path
        while path and path not in self.lines:
            path = re.sub(r"(\.[^.\[]*|\[\d+\])$", "", path)
        return ModelError(message, source=self.source, path=self.path or None,
                          line=self.lines.get(path))

    def child(self, key: str | int, value: object) -> "Cursor":
        path = f"{self.path}[{key}]" if isinstance(key, int) else (
            f"{self.path}.{key}" if self.path else key)
        return Cursor(value, path, self.source, self.lines)

    def mapping(self, allowed: tuple[str, ...] | None = None,
                required: tuple[str, ...] = ()) -> dict[str, "Cursor"]:
        """The children of a mapping; unknown keys (if ``allowed``) and missing required ones fail."""
        if not isinstance(self.value, dict):
            raise self.error(f"expected a mapping, got {_kind(self.value)}")
        if allowed is not None:
            for key in self.value:
                if key not in allowed:
                    close = difflib.get_close_matches(key, allowed, n=1)
                    hint = f"did you mean {close[0]!r}? " if close else ""
                    raise self.child(key, None).error(
                        f"unknown key; {hint}allowed: {', '.join(allowed)}")
        for key in required:
            if key not in self.value:
                raise self.error(f"missing required key {key!r}")
        return {key: self.child(key, value) for key, value in self.value.items()}

    def sequence(self) -> list["Cursor"]:
        if not isinstance(self.value, list):
            raise self.error(f"expected a list, got {_kind(self.value)}")
        return [self.child(i, v) for i, v in enumerate(self.value)]

    def text(self) -> str:
        if not isinstance(self.value, str):
            raise self.error(f"expected text, got {_kind(self.value)}")
        return self.value

    def identifier(self, what: str = "name") -> str:
        value = self.value
        if not isinstance(value, str) or not IDENTIFIER.match(value):
            raise self.error(f"{what} must be a letter followed by up to 63 letters, digits "
                             f"or underscores, got {value!r}")
        if value in RESERVED_NAMES:
            raise self.error(f"{value!r} is reserved; choose another {what}")
        return value

    def choice(self, options: tuple[str, ...]) -> str:
        if self.value not in options:
            raise self.error(f"must be one of {', '.join(options)}, got {self.value!r}")
        return self.value

    def expr(self, names: Mapping[str, sp.Expr]) -> sp.Expr:
        try:
            return expressions.parse(self.value, names)
        except expressions.ExpressionError as err:
            raise self.error(str(err)) from None

    def number(self, names: Mapping[str, sp.Expr], substitution: Mapping) -> float:
        """An expression that must evaluate to a finite real number."""
        expr = self.expr(names).xreplace(substitution)
        if expr.free_symbols:
            raise self.error(f"must be a number, depends on {sorted(map(str, expr.free_symbols))}")
        try:
            value = float(expr)
        except (TypeError, ValueError):
            raise self.error(f"must be a real number, got {expr}") from None
        if not math.isfinite(value):
            raise self.error(f"must be finite, got {value}")
        return value

    def vector(self, names: Mapping[str, sp.Expr]) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        items = self.sequence()
        if len(items) != 3:
            raise self.error(f"expected a list of 3 components [x, y, z], got {len(items)}")
        return tuple(item.expr(names) for item in items)


def _kind(value: object) -> str:
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the text {value!r}" if len(value) < 40 else "text"
    return {dict: "a mapping", list: "a list"}.get(type(value), f"a {type(value).__name__}")


class _RobotBuilder:
    """Validates one file section by section, growing the table of known names."""

    def __init__(self, root: Cursor, digest: str, default_name: str):
        self.root, self.digest, self.default_name = root, digest, default_name
        self.symbols: dict[str, sp.Expr] = {}      # parameters
        self.owner: dict[str, str] = {}            # every name in the file -> what it is
        self.definitions: dict[str, sp.Expr] = {}
        self.values: dict[sp.Symbol, sp.Expr] = {}

    @staticmethod
    def key_name(item: Cursor, key: str, what: str) -> str:
        """A mapping key that names something must be an identifier."""
        return Cursor(key, item.path, item.source, item.lines).identifier(what)

    def claim(self, cursor: Cursor, name: str, what: str) -> None:
        if name in self.owner:
            raise cursor.error(f"name {name!r} is already used by {self.owner[name]}")
        self.owner[name] = what

    def build(self) -> Robot:
        top = self.root.mapping(TOP_KEYS, required=("coordinates", "bodies"))
        name = top["name"].identifier("robot name") if "name" in top else self.default_name
        description = top["description"].text() if "description" in top else ""
        if "parameters" in top:
            self.parameters(top["parameters"])
        gravity = self.constant_vector(top.get("gravity"))
        coordinate_cursors = self.coordinate_names(top["coordinates"])
        bodies, units = self.bodies(top["bodies"])
        coordinates = self.coordinates(coordinate_cursors, units)
        actuators = self.actuators(top["actuators"], bodies) if "actuators" in top else ()
        controller = (self.controller(top["controller"], actuators)
                      if "controller" in top else None)
        trajectory = self.trajectory(top["trajectory"]) if "trajectory" in top else None
        simulation = self.simulation(top["simulation"]) if "simulation" in top else Simulation()
        return Robot(name=name, source=self.root.source, digest=self.digest,
                     parameters=frozen_map(self.definitions), gravity=gravity,
                     coordinates=coordinates, bodies=bodies, actuators=actuators,
                     controller=controller, trajectory=trajectory, simulation=simulation,
                     description=description)

    # -- names and numbers -------------------------------------------------
    def parameters(self, cursor: Cursor) -> None:
        """name: number, or an expression of the parameters above it."""
        for key, item in cursor.mapping().items():
            name = self.key_name(item, key, "parameter name")
            self.claim(item, name, "a parameter")
            definition = item.expr(self.symbols)
            value = definition.xreplace(self.values)
            self.check_numeric(item, value)
            symbol = sp.Symbol(name, real=True)
            self.symbols[name] = symbol
            self.definitions[name] = definition
            self.values[symbol] = value

    def check_numeric(self, cursor: Cursor, expr: sp.Expr) -> float:
        value = expr.xreplace(self.values)
        if value.free_symbols:
            raise cursor.error("must not depend on coordinates or time here")
        number = complex(value.evalf())
        if number.imag != 0 or not math.isfinite(number.real):
            raise cursor.error(f"must be a finite real number, got {value}")
        return number.real

    def constant_vector(self, cursor: Cursor | None) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """[x, y, z] of parameter expressions (zero when the key is absent)."""
        if cursor is None:
            return (sp.Integer(0),) * 3
        vector = cursor.vector(self.symbols)
        for component in vector:
            self.check_numeric(cursor, component)
        return vector

    def positive(self, cursor: Cursor, expr: sp.Expr, what: str) -> None:
        if self.check_numeric(cursor, expr) <= 0:
            raise cursor.error(f"{what} must be positive, got {float(expr.xreplace(self.values)):g}")

    # -- coordinates ---------------------------------------------------------
    def coordinate_names(self, cursor: Cursor) -> dict[str, Cursor]:
        items = cursor.mapping()
        if not items:
            raise cursor.error("at least one coordinate is required")
        for key, item in items.items():
            self.key_name(item, key, "coordinate name")
            self.claim(item, key, "a coordinate")
            for derived in ("d" + key, "dd" + key):
                self.claim(item, derived, f"the rates of coordinate {key!r}")
        self.q = {k: sp.Symbol(k, real=True) for k in items}
        return items

    def coordinates(self, items: dict[str, Cursor], units: dict[str, str]) -> tuple[Coordinate, ...]:
        result = []
        for key, item in items.items():
            fields = item.mapping(("initial", "rate")) if item.value is not None else {}
            if key not in units:
                raise item.error("no joint displacement uses this coordinate; every coordinate "
                                 "must move some joint")
            initial = fields["initial"].expr(self.symbols) if "initial" in fields else sp.Integer(0)
            rate = fields["rate"].expr(self.symbols) if "rate" in fields else sp.Integer(0)
            for name in ("initial", "rate"):
                if name in fields:
                    self.check_numeric(fields[name], initial if name == "initial" else rate)
            result.append(Coordinate(key, initial.xreplace(self.values),
                                     rate.xreplace(self.values), units[key]))
        return tuple(result)

    # -- bodies --------------------------------------------------------------
    def bodies(self, cursor: Cursor) -> tuple[tuple[Body, ...], dict[str, str]]:
        items = cursor.sequence()
        if not items:
            raise cursor.error("at least one body is required")
        free_coordinates = iter(self.q.values())
        bodies: dict[str, Body] = {}
        cursors: dict[str, Cursor] = {}
        units: dict[str, str] = {}
        for item in items:
            body = self.body(item, free_coordinates, units)
            if body.name in bodies:
                raise item.child("name", None).error(f"duplicate body name {body.name!r}")
            bodies[body.name] = body
            cursors[body.name] = item
        return self.tree_order(bodies, cursors), units

    def body(self, item: Cursor, free_coordinates, units: dict[str, str]) -> Body:
        fields = item.mapping(("name", "parent", "joint", "mass", "com", "inertia"),
                              required=("name", "joint", "mass"))
        name = fields["name"].identifier("body name")
        parent = fields["parent"].text() if "parent" in fields else GROUND
        joint = self.joint(fields["joint"], free_coordinates, units)
        mass = fields["mass"].expr(self.symbols)
        self.positive(fields["mass"], mass, "mass")
        com = self.constant_vector(fields.get("com"))
        inertia = self.inertia(fields["inertia"]) if "inertia" in fields else sp.zeros(3, 3)
        return Body(name, parent, joint, mass, com, sp.ImmutableMatrix(inertia))

    def joint(self, cursor: Cursor, free_coordinates, units: dict[str, str]) -> Joint:
        fields = cursor.mapping(("type", "axis", "origin", "rpy", "displacement"),
                                required=("type",))
        kind = fields["type"].choice(JOINT_TYPES)
        origin = self.constant_vector(fields.get("origin"))
        rpy = self.constant_vector(fields.get("rpy"))
        zero = self.constant_vector(None)
        if kind == "fixed":
            for key in ("axis", "displacement"):
                if key in fields:
                    raise fields[key].error("a fixed joint has no axis or displacement")
            return Joint(kind, zero, origin, rpy, sp.Integer(0))
        if "axis" not in fields:
            raise cursor.error(f"missing required key 'axis' for a {kind} joint")
        axis = fields["axis"].vector(self.symbols)
        numeric = np.array([self.check_numeric(fields["axis"], a) for a in axis])
        norm = float(np.linalg.norm(numeric))
        if norm < 1e-12:
            raise fields["axis"].error("axis must not be the zero vector")
        axis = _unit(axis, self.values)
        if "displacement" in fields:
            displacement = fields["displacement"].expr({**self.symbols, **self.q})
        else:
            displacement = next(free_coordinates, None)
            if displacement is None:
                raise cursor.error("no 'displacement' given and no coordinate left to default "
                                   "to (joints without one take the coordinates in order)")
        used = [s for s in displacement.free_symbols if s.name in self.q]
        if not used:
            raise (fields.get("displacement") or cursor).error(
                "the displacement must depend on at least one coordinate")
        for symbol in sorted(used, key=str):
            units.setdefault(symbol.name, "rad" if kind == "revolute" else "m")
        return Joint(kind, axis, origin, rpy, displacement)

    def inertia(self, cursor: Cursor) -> sp.Matrix:
        keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
        fields = cursor.mapping(keys)
        value = {k: fields[k].expr(self.symbols) if k in fields else sp.Integer(0) for k in keys}
        matrix = sp.Matrix([[value["ixx"], value["ixy"], value["ixz"]],
                            [value["ixy"], value["iyy"], value["iyz"]],
                            [value["ixz"], value["iyz"], value["izz"]]])
        numeric = np.array([[self.check_numeric(cursor, e) for e in row]
                            for row in matrix.tolist()])
        moments = np.linalg.eigvalsh(numeric)
        scale = max(1.0, float(np.abs(moments).max()))
        if moments[0] < -1e-12 * scale:
            raise cursor.error(f"inertia tensor must be positive semidefinite; its principal "
                               f"moments are {', '.join(f'{m:g}' for m in moments)}")
        a, b, c = moments
        if a + b < c - 1e-9 * scale:
            raise cursor.error(f"principal moments {a:g}, {b:g}, {c:g} break the triangle "
                               "inequality (no rigid body has them: I1 + I2 >= I3)")
        return matrix

    def tree_order(self, bodies: dict[str, Body], cursors: dict[str, Cursor]) -> tuple[Body, ...]:
        """Parents before children; unknown parents and cycles fail."""
        for name, body in bodies.items():
            if body.parent != GROUND and body.parent not in bodies:
                options = [GROUND, *bodies]
                close = difflib.get_close_matches(body.parent, options, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise cursors[name].child("parent", None).error(
                    f"unknown parent {body.parent!r}{hint}; use 'ground' or a body name")
        ordered: list[Body] = []
        placed = {GROUND}
        remaining = dict(bodies)
        while remaining:
            ready = [b for b in remaining.values() if b.parent in placed]
            if not ready:
                cycle = sorted(remaining)
                raise cursors[cycle[0]].child("parent", None).error(
                    f"bodies {', '.join(cycle)} form a cycle; every chain must start at ground")
            for body in ready:
                ordered.append(body)
                placed.add(body.name)
                del remaining[body.name]
        return tuple(ordered)

    # -- actuators, controller, trajectory, simulation -----------------------
    def actuators(self, cursor: Cursor, bodies: tuple[Body, ...]) -> tuple[Actuator, ...]:
        by_name = {b.name: b for b in bodies}
        result = []
        for key, item in cursor.mapping().items():
            self.key_name(item, key, "actuator name")
            self.claim(item, key, "an actuator")
            fields = item.mapping(("joint",), required=("joint",))
            body_name = fields["joint"].text()
            if body_name not in by_name:
                raise fields["joint"].error(f"unknown body {body_name!r}; actuators act on the "
                                            f"joint of one of: {', '.join(by_name)}")
            kind = by_name[body_name].joint.type
            if kind == "fixed":
                raise fields["joint"].error(f"body {body_name!r} has a fixed joint; nothing to drive")
            result.append(Actuator(key, body_name, "N*m" if kind == "revolute" else "N"))
        return tuple(result)

    def controller(self, cursor: Cursor, actuators: tuple[Actuator, ...]) -> Controller:
        fields = cursor.mapping(("gains", "laws"), required=("laws",))
        gains: dict[str, sp.Expr] = {}
        names = dict(self.symbols)
        if "gains" in fields:
            for key, item in fields["gains"].mapping().items():
                self.key_name(item, key, "gain name")
                self.claim(item, key, "a gain")
                value = item.expr(names).xreplace(self.values)
                self.check_numeric(item, value)
                gains[key] = value
                names[key] = sp.Symbol(key, real=True)
        t = sp.Symbol("t", real=True)
        names.update(self.q)
        names.update({"d" + k: sp.Symbol("d" + k, real=True) for k in self.q})
        names["t"] = t
        laws_cursor = fields["laws"]
        laws = {}
        actuator_names = [a.name for a in actuators]
        for key, item in laws_cursor.mapping().items():
            if key not in actuator_names:
                close = difflib.get_close_matches(key, actuator_names, n=1)
                hint = f"did you mean {close[0]!r}? " if close else ""
                raise item.error(f"law for unknown actuator; {hint}actuators: "
                                 f"{', '.join(actuator_names) or 'none'}")
            laws[key] = item.expr(names)
        missing = [a for a in actuator_names if a not in laws]
        if missing:
            raise laws_cursor.error(f"no law for actuator(s) {', '.join(missing)}; "
                                    "every actuator needs one")
        return Controller(frozen_map(gains), frozen_map(laws))

    def trajectory(self, cursor: Cursor) -> Trajectory:
        fields = cursor.mapping(("kind", "duration", "from", "to", "expressions"),
                                required=("kind", "duration"))
        kind = fields["kind"].choice(TRAJECTORY_KINDS)
        duration = fields["duration"].expr(self.symbols).xreplace(self.values)
        self.positive(fields["duration"], duration, "duration")
        ends = {}
        for key in ("from", "to"):
            ends[key] = {}
            if key in fields:
                if kind == "expression":
                    raise fields[key].error("'from' and 'to' belong to cycloidal and quintic "
                                            "trajectories; 'expression' takes 'expressions'")
                for name, item in fields[key].mapping().items():
                    self.known_coordinate(item, name)
                    value = item.expr(self.symbols).xreplace(self.values)
                    self.check_numeric(item, value)
                    ends[key][name] = value
        expressions_ = {}
        if kind == "expression":
            if "expressions" not in fields:
                raise cursor.error("missing required key 'expressions' for kind 'expression'")
            names = {**self.symbols, "t": sp.Symbol("t", real=True)}
            for name, item in fields["expressions"].mapping().items():
                self.known_coordinate(item, name)
                expressions_[name] = item.expr(names).xreplace(self.values)
        elif "expressions" in fields:
            raise fields["expressions"].error("'expressions' belongs to kind 'expression'")
        elif "to" not in fields:
            raise cursor.error(f"missing required key 'to' for a {kind} trajectory")
        return Trajectory(kind, duration, frozen_map(ends["from"]), frozen_map(ends["to"]),
                          frozen_map(expressions_))

    def known_coordinate(self, cursor: Cursor, name: str) -> None:
        if name not in self.q:
            close = difflib.get_close_matches(name, list(self.q), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise cursor.error(f"unknown coordinate {name!r}{hint}; coordinates: "
                               f"{', '.join(self.q)}")

    def simulation(self, cursor: Cursor) -> Simulation:
        fields = cursor.mapping(("t_end", "output_step", "method", "rtol", "atol"))
        values: dict[str, object] = {}
        for key in ("t_end", "output_step", "rtol", "atol"):
            if key in fields:
                value = fields[key].number(self.symbols, self.values)
                if value <= 0:
                    raise fields[key].error(f"must be positive, got {value:g}")
                values[key] = value
        if "method" in fields:
            values["method"] = fields["method"].text()
        return Simulation(**values)


def _unit(axis, values) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """The axis scaled to unit length (exact when its components are exact)."""
    norm = sp.sqrt(sum(a ** 2 for a in axis))
    if norm.xreplace(values) == 1:
        return tuple(axis)
    return tuple(a / norm for a in axis)
