"""YAML robot file -> validated, frozen ``Robot``.

Every mistake raises ``ModelError`` naming the file, line, key path, what is
wrong and what is allowed; nothing else escapes (``tests/test_fuzz.py``).
The README documents each key read here.

Beyond the types and ranges of single values, the robot as a whole is
checked where that is cheap and certain:

- every displacement, its rates and every control law are finite real
  numbers at the initial state (else the first step of any run fails);
- the mass matrix is not singular everywhere (``massmatrix``): a coordinate,
  or a combination of coordinates, that moves no mass leaves M(q) q'' = ...
  without a solution.  M is computed numerically, by its own recursion,
  at the initial state and at two random states; the robot is refused only
  if M is singular at all three.
"""
from __future__ import annotations

import difflib
import hashlib
import math
import re
import warnings
from pathlib import Path
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import ModelError, shorten
from . import expressions
from . import massmatrix
from .names import GROUND, IDENTIFIER, RESERVED_NAMES, default_name
from .joints import JOINT_TYPES, JointType
from .robot import (Actuator, Body, Controller, Coordinate, Joint, JointLimits, Load, Robot,
                    Simulation, Trajectory, frozen_map)
from .info import METHODS
from .yamlschema import describe_value as _kind, load
from .yamlsource import read_text

TRAJECTORY_KINDS = ("cycloidal", "quintic", "expression", "waypoints", "spline")
# a guard against a runaway file, not a limit of the recursions (O(n)): loading checks
# M at several states, O(n^3); TIAGo dual (101 bodies, 101 coordinates) loads in 2-3 s,
# 1000 would take minutes; no published robot comes near (docs/how-to/urdf.md)
MAX_BODIES = 1000
MAX_COORDINATES = 1000
MAX_ROWS = 1_000_000      # simulation.t_end / simulation.output_step
# constants beyond these make SymPy's exact arithmetic crawl (300-digit rationals)
SMALLEST, LARGEST = 1e-30, 1e30
#: joint keys for the forces along the joint (robot.Joint), reaction on the parent
JOINT_FORCE_KEYS = ("damping", "friction", "friction_velocity", "stiffness", "rest")
LOAD_FRAMES = ("world", "body")
#: the joint types that move, for messages: "revolute or prismatic"
MOVING_WORDS = " or ".join(word for word, kind in JOINT_TYPES.items() if kind.moving)
TOP_KEYS = ("name", "description", "parameters", "gravity", "coordinates", "bodies",
            "actuators", "controller", "loads", "trajectory", "simulation", "loops",
            "constraints")


def load_robot(path: str | Path, parameters: Mapping[str, object] | None = None) -> Robot:
    """Read and validate a robot file (``parameters``: see ``robot_from_text``)."""
    text, source = read_text(path)
    return robot_from_text(text, source, parameters)


def robot_from_text(text: str, source: str = "<robot>",
                    parameters: Mapping[str, object] | None = None) -> Robot:
    """Validate YAML text describing a robot (``source`` names it in errors).

    ``parameters``: values (numbers, or expressions as the file writes them) that
    replace those of parameters the file defines, validated as if written there;
    the robot's digest covers them.

    Text that a URDF import produced (``urdf.place``) is reported at its place
    in the URDF (joint and link names), never at a line of the generated YAML."""
    try:
        data, lines = load(text, source)
        overrides = dict(parameters or {})
        keyed = text + (f"\n# parameters {sorted(overrides.items())!r}" if overrides else "")
        digest = hashlib.sha256(keyed.encode("utf-8", "surrogatepass")).hexdigest()
        return _RobotBuilder(Cursor(data, "", source, lines), digest,
                             default_name(source), overrides).build()
    except ModelError as err:
        from .urdf import place

        where = place(text, err.path)
        if where is None:
            raise
        raise ModelError(err.reason, source=err.source, path=where + (
            f" (imported as {err.path})" if err.path else "")) from None


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
            if not self.path:
                raise self.error(f"the file must be a YAML mapping of keys to values, got "
                                 f"{_kind(self.value)}")
            raise self.error(f"expected a mapping, got {_kind(self.value)}")
        if allowed is not None:
            for key in self.value:
                if key not in allowed:
                    close = difflib.get_close_matches(key, allowed, n=1)
                    hint = f"did you mean {close[0]!r}? " if close else ""
                    split = (" (a comma or colon inside {...} splits an expression: quote "
                             "it)" if re.search(r"[()*/+^]", key) else "")
                    raise self.child(key, None).error(
                        f"unknown key{split}; {hint}allowed: {', '.join(allowed)}")
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
            shown = repr(value) if not isinstance(value, str) or len(value) <= 40 else (
                f"{value[:37]!r}... ({len(value)} characters)")
            raise self.error(f"{what} must be a letter followed by up to 63 letters, digits "
                             f"or underscores, got {shown}")
        if value in RESERVED_NAMES:
            raise self.error(f"{value!r} is reserved; choose another {what}")
        return value

    def choice(self, options: tuple[str, ...]) -> str:
        if not isinstance(self.value, str) or self.value not in options:
            shown = repr(shorten(self.value)) if isinstance(self.value, str) else _kind(self.value)
            raise self.error(f"must be one of {', '.join(options)}, got {shown}")
        return self.value

    def expr(self, names: Mapping[str, sp.Expr], unavailable: Mapping[str, str] | None = None,
             smooth: bool = False) -> sp.Expr:
        try:
            return expressions.parse(self.value, names, unavailable, smooth)
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

    def vector(self, names: Mapping[str, sp.Expr], unavailable: Mapping[str, str] | None = None
               ) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        items = self.sequence()
        if len(items) != 3:
            raise self.error(f"expected a list of 3 components [x, y, z], got {len(items)}")
        return tuple(item.expr(names, unavailable) for item in items)


class _RobotBuilder:
    """Validates one file section by section, growing the table of known names."""

    def __init__(self, root: Cursor, digest: str, default_name: str,
                 overrides: Mapping[str, object] | None = None):
        self.root, self.digest, self.default_name = root, digest, default_name
        self.overrides = dict(overrides or {})     # parameter values given by the caller
        self.symbols: dict[str, sp.Expr] = {}      # parameters
        self.owner: dict[str, str] = {}            # every name in the file -> what it is
        self.definitions: dict[str, sp.Expr] = {}
        self.values: dict[sp.Symbol, sp.Expr] = {}
        self.gain_values: dict[sp.Symbol, sp.Expr] = {}
        self.q: dict[str, sp.Symbol] = {}
        # what each name in the file is, to say why it cannot be used somewhere
        self.kinds: dict[str, str] = {"t": "time"}

    @staticmethod
    def key_name(item: Cursor, key: str, what: str) -> str:
        """A mapping key that names something must be an identifier."""
        return Cursor(key, item.path, item.source, item.lines).identifier(what)

    def claim(self, cursor: Cursor, name: str, what: str) -> None:
        if name in self.owner:
            raise cursor.error(f"name {name!r} is already used by {self.owner[name]}; "
                               "every name in a robot file must be different")
        self.owner[name] = what
        self.kinds[name] = what

    def unavailable(self, allowed: Mapping[str, object]) -> dict[str, str]:
        return {name: what for name, what in self.kinds.items() if name not in allowed}

    def build(self) -> Robot:
        top = self.root.mapping(TOP_KEYS, required=("coordinates", "bodies"))
        name = top["name"].identifier("robot name") if "name" in top else self.default_name
        description = top["description"].text() if "description" in top else ""
        self.prescan(top)
        if "parameters" in top:
            self.parameters(top["parameters"])
        unknown = sorted(set(self.overrides) - set(self.definitions))
        if unknown:
            raise self.root.error(f"parameters: the file defines no {', '.join(unknown)} (it "
                                  f"defines: {', '.join(self.definitions) or 'none'})")
        gravity = self.constant_vector(top.get("gravity"))
        coordinate_cursors = self.coordinate_names(top["coordinates"])
        bodies, units, body_cursors = self.bodies(top["bodies"])
        coordinates = self.coordinates(coordinate_cursors, units)
        self.check_displacements(bodies, body_cursors, coordinates)
        actuators = self.actuators(top["actuators"], bodies) if "actuators" in top else ()
        if "controller" in top:
            controller = self.controller(top["controller"], actuators, coordinates)
        else:
            controller = None
        loads = self.loads(top["loads"], bodies, coordinates) if "loads" in top else ()
        trajectory = self.trajectory(top["trajectory"]) if "trajectory" in top else None
        simulation = self.simulation(top["simulation"]) if "simulation" in top else Simulation()
        constraints = None
        from . import constraints as closing       # closed chains (issue 10)
        if closing.wanted(top, coordinate_cursors):
            constraints, coordinates = closing.build(self, top, coordinate_cursors, bodies,
                                                     coordinates)
        robot = Robot(name=name, source=self.root.source, digest=self.digest,
                      parameters=frozen_map(self.definitions), gravity=gravity,
                      coordinates=coordinates, bodies=bodies, actuators=actuators,
                      controller=controller, loads=loads, trajectory=trajectory,
                      simulation=simulation, description=description,
                      name_given="name" in top, constraints=constraints)
        self.check_mass_matrix(robot, top["coordinates"], coordinate_cursors)
        return robot

    def prescan(self, top: dict[str, Cursor]) -> None:
        """Names defined further down, so that using one too early gets a clear message."""
        def keys(cursor: Cursor | None) -> list[str]:
            value = cursor.value if cursor is not None else None
            return [k for k in value if isinstance(k, str)] if isinstance(value, dict) else []

        for key in keys(top.get("parameters")):
            self.kinds[key] = "a parameter defined further down"
        for key in keys(top.get("actuators")):
            self.kinds.setdefault(key, "an actuator")
        controller = top.get("controller")
        if controller is not None and isinstance(controller.value, dict):
            for key in keys(Cursor(controller.value.get("gains"), "", "", {})):
                self.kinds.setdefault(key, "a controller gain")
        bodies = top["bodies"].value
        if isinstance(bodies, list):
            for item in bodies:
                if isinstance(item, dict) and isinstance(item.get("name"), str):
                    self.kinds.setdefault(item["name"], "a body")

    # -- names and numbers -------------------------------------------------
    def parameters(self, cursor: Cursor) -> None:
        """name: number, or an expression of the parameters above it."""
        for key, item in cursor.mapping().items():
            name = self.key_name(item, key, "parameter name")
            if name in self.overrides:           # the caller's value, at the file's place
                item = Cursor(self.overrides[name], item.path, item.source, item.lines)
            self.claim(item, name, "a parameter")
            definition = item.expr(self.symbols, self.unavailable(self.symbols))
            self.check_numeric(item, definition)
            value = definition.xreplace(self.values)
            symbol = sp.Symbol(name, real=True)
            self.symbols[name] = symbol
            self.definitions[name] = definition
            self.values[symbol] = value

    def constant(self, cursor: Cursor) -> sp.Expr:
        """A number or an expression of the parameters."""
        return cursor.expr(self.symbols, self.unavailable(self.symbols))

    def check_numeric(self, cursor: Cursor, expr: sp.Expr) -> float:
        """The finite real value of a constant expression (ModelError otherwise)."""
        try:
            expressions.approximate(expr, {**self.values, **self.gain_values})
            value = expr.xreplace(self.values).xreplace(self.gain_values)
            if value.free_symbols:
                raise cursor.error("must be a number here, got an expression of "
                                   f"{', '.join(sorted(map(str, value.free_symbols)))}")
            number = complex(value.evalf())
        except ModelError:
            raise
        except expressions.ExpressionError as err:      # overflows: not evaluated exactly
            raise cursor.error(str(err)) from None
        except (RecursionError, MemoryError):
            raise cursor.error(expressions.TOO_DEEP) from None
        except (TypeError, ValueError, ArithmeticError):
            raise cursor.error(f"cannot evaluate {shorten(value)} to a number") from None
        if number.imag != 0 or not math.isfinite(number.real):
            raise cursor.error(f"must be a finite real number, got {shorten(value)}")
        if number.real != 0 and not SMALLEST <= abs(number.real) <= LARGEST:
            raise cursor.error(f"{number.real:g} is out of range: numbers in a robot file are 0 "
                               f"or between {SMALLEST:g} and {LARGEST:g} in size (SI units)")
        return number.real

    def constant_vector(self, cursor: Cursor | None) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """[x, y, z] of parameter expressions (zero when the key is absent)."""
        if cursor is None:
            return (sp.Integer(0),) * 3
        vector = cursor.vector(self.symbols, self.unavailable(self.symbols))
        for i, component in enumerate(vector):
            self.check_numeric(cursor.child(i, component), component)
        return vector

    def positive(self, cursor: Cursor, expr: sp.Expr, what: str) -> float:
        value = self.check_numeric(cursor, expr)
        if value <= 0:
            raise cursor.error(f"must be positive ({what}), got {value:g}")
        return value

    # -- coordinates ---------------------------------------------------------
    def coordinate_names(self, cursor: Cursor) -> dict[str, Cursor]:
        items = cursor.mapping()
        if not items:
            raise cursor.error("at least one coordinate is required, e.g. {q1: {initial: 0}}")
        if len(items) > MAX_COORDINATES:
            raise cursor.error(f"{len(items)} coordinates; anadyn handles at most "
                               f"{MAX_COORDINATES}")
        for key, item in items.items():
            self.key_name(item, key, "coordinate name")
            self.claim(item, key, "a coordinate")
            self.claim(item, "d" + key, f"the rate of coordinate {key!r}")
            self.claim(item, "dd" + key, f"the acceleration of coordinate {key!r}")
        self.q = {k: sp.Symbol(k, real=True) for k in items}
        return items

    def coordinates(self, items: dict[str, Cursor], units: dict[str, str]) -> tuple[Coordinate, ...]:
        result = []
        for key, item in items.items():
            fields = item.mapping(("initial", "rate", "dependent")) if item.value is not None else {}
            fields.pop("dependent", None)        # read by model.constraints
            if key not in units:
                raise item.error("no joint displacement uses this coordinate; every coordinate "
                                 "must move some joint")
            values = {}
            for name in ("initial", "rate"):
                if name in fields:
                    expr = self.constant(fields[name])
                    self.check_numeric(fields[name], expr)
                    values[name] = expr.xreplace(self.values)
                else:
                    values[name] = sp.Integer(0)
            result.append(Coordinate(key, values["initial"], values["rate"], units[key]))
        return tuple(result)

    # -- bodies --------------------------------------------------------------
    def bodies(self, cursor: Cursor) -> tuple[tuple[Body, ...], dict[str, str], dict[str, Cursor]]:
        items = cursor.sequence()
        if not items:
            raise cursor.error("at least one body is required")
        if len(items) > MAX_BODIES:
            raise cursor.error(f"{len(items)} bodies; anadyn handles at most {MAX_BODIES}")
        claimed = self.claimed_by_displacements(items)
        defaults = self.default_coordinates(items, [symbol for name, symbol in self.q.items()
                                                    if name not in claimed])
        bodies: dict[str, Body] = {}
        cursors: dict[str, Cursor] = {}
        units: dict[str, str] = {}
        carriers = {item.value.get("parent") for item in items if isinstance(item.value, dict)}
        for k, item in enumerate(items):
            body = self.body(item, iter(defaults.get(k, ())), units, carriers)
            if body.name in bodies:
                raise item.child("name", None).error(
                    f"duplicate body name {body.name!r}; every body needs its own name")
            bodies[body.name] = body
            cursors[body.name] = item
        return self.tree_order(bodies, cursors), units, cursors

    def claimed_by_displacements(self, items: list[Cursor]) -> set[str]:
        """Coordinates that an explicit displacement claims: one of a single
        coordinate (``q1``, ``2*q1 + 0.1``); a coupled one (``q2 - q1``) claims
        none.  A joint without a displacement takes the next unclaimed coordinate."""
        claimed: set[str] = set()
        for item in items:
            joint = item.value.get("joint") if isinstance(item.value, dict) else None
            text = joint.get("displacement") if isinstance(joint, dict) else None
            named = set(re.findall(r"[A-Za-z_]\w*", str(text))) & set(self.q)
            if isinstance(text, str) and len(named) == 1:
                claimed |= named
        return claimed

    def default_coordinates(self, items: list[Cursor], free: list) -> dict[int, list]:
        """Item index -> [its default coordinate] for the joints without a
        displacement, taken from ``free`` in the order of the tree (from the ground
        outwards), not of the file: listing the bodies in another order gives the
        same coordinates.  Such joints must lie on one chain from the ground;
        on separate branches their order would come from the file alone, and the
        file is refused.  (Names and parents are checked later; a body whose chain
        cannot be followed here keeps its place in the file.)"""
        raw = [item.value if isinstance(item.value, dict) else {} for item in items]
        index: dict[str, int] = {}
        for k, value in enumerate(raw):
            if isinstance(value.get("name"), str):
                index.setdefault(value["name"], k)

        def chain(k: int) -> list[int] | None:
            """Ancestors of item k (nearest first), None if they cannot be followed."""
            seen: list[int] = []
            parent = raw[k].get("parent", GROUND)
            while parent != GROUND:
                if not isinstance(parent, str) or parent not in index or index[parent] in seen \
                        or index[parent] == k:
                    return None
                seen.append(index[parent])
                parent = raw[index[parent]].get("parent", GROUND)
            return seen

        takers = []
        for k, value in enumerate(raw):
            joint = value.get("joint")
            if (isinstance(joint, dict) and _moving(joint.get("type"))
                    and "displacement" not in joint):
                takers.append(k)
        ancestors = {k: chain(k) for k in takers}
        if any(a is None for a in ancestors.values()):
            order = takers                                   # reported later, as it is
        else:
            order = sorted(takers, key=lambda k: len(ancestors[k]))
            for before, after in zip(order, order[1:]):
                if before not in ancestors[after]:
                    first, second = sorted((before, after))
                    names = [raw[j].get("name") for j in (first, second)]
                    hint = (f" (e.g. 'displacement: {free[order.index(after)]}')"
                            if order.index(after) < len(free) else "")
                    raise items[second].child("joint", raw[second].get("joint")).error(
                        f"bodies {names[0]!r} and {names[1]!r} both take a default "
                        "coordinate but lie on different branches of the tree, so which "
                        "coordinate each gets would depend on their order in the file; give "
                        f"them displacements{hint}")
        return {k: [free[j]] for j, k in enumerate(order) if j < len(free)}

    def body(self, item: Cursor, free_coordinates, units: dict[str, str],
             carriers: set) -> Body:
        fields = item.mapping(("name", "parent", "joint", "mass", "com", "inertia"),
                              required=("name", "joint", "mass"))
        name = fields["name"].identifier("body name")
        parent = GROUND
        if "parent" in fields:
            parent = fields["parent"].value
            if not isinstance(parent, str):
                raise fields["parent"].error(f"expected 'ground' or a body name, got "
                                             f"{_kind(parent)}")
        joint = self.joint(fields["joint"], free_coordinates, units)
        mass = self.constant(fields["mass"])
        # massless: a welded body, or a moving one that carries others (a virtual link
        # between joints, as URDF writes ball joints; M's check finds what moves nothing)
        if (joint.joint_type.moving and name not in carriers
                or self.check_numeric(fields["mass"], mass) != 0):
            self.positive(fields["mass"], mass, "a mass in kg")
        com = self.constant_vector(fields.get("com"))
        inertia = self.inertia(fields["inertia"]) if "inertia" in fields else sp.zeros(3, 3)
        return Body(name, parent, joint, mass, com, sp.ImmutableMatrix(inertia))

    def joint(self, cursor: Cursor, free_coordinates, units: dict[str, str]) -> Joint:
        fields = cursor.mapping(("type", "axis", "origin", "rpy", "displacement", "limits",
                                 *JOINT_FORCE_KEYS),
                                required=("type",))
        word = fields["type"].choice(tuple(JOINT_TYPES))
        kind = JOINT_TYPES[word]
        origin = self.constant_vector(fields.get("origin"))
        rpy = self.constant_vector(fields.get("rpy"))
        zero = self.constant_vector(None)
        if not kind.moving:
            for key in ("axis", "displacement"):
                if key in fields:
                    raise fields[key].error(f"a {word} joint has no axis or displacement; "
                                            f"remove it or make the joint {MOVING_WORDS}")
            if "limits" in fields:
                raise fields["limits"].error(f"a {word} joint has no limits; remove them or "
                                             f"make the joint {MOVING_WORDS}")
            for key in JOINT_FORCE_KEYS:
                if key in fields:
                    raise fields[key].error(f"a {word} joint does not move, so it has no "
                                            f"{key}; remove it or make the joint {MOVING_WORDS}")
            return Joint(word, zero, origin, rpy, sp.Integer(0))
        if "axis" not in fields:
            raise cursor.error(f"missing required key 'axis' for a {word} joint")
        axis = self.constant_vector(fields["axis"])
        numeric = np.array([self.check_numeric(fields["axis"], a) for a in axis])
        norm = float(np.linalg.norm(numeric))
        if not norm > 1e-12:
            raise fields["axis"].error("axis must not be the zero vector; give a direction "
                                       "such as [0, 0, 1]")
        axis = _unit(axis, self.values)
        if "displacement" in fields:
            names = {**self.symbols, **self.q}
            displacement = fields["displacement"].expr(names, self.unavailable(names),
                                                       smooth=True)
        else:
            displacement = next(free_coordinates, None)
            if displacement is None:
                raise cursor.error("no 'displacement' given and no coordinate left to default "
                                   "to (joints without one take the unused coordinates in "
                                   "order, from the ground outwards)")
        used = [s for s in displacement.free_symbols if s.name in self.q]
        if not used:
            raise (fields.get("displacement") or cursor).error(
                "the displacement must depend on at least one coordinate, e.g. q1 or q2 - q1")
        for symbol in sorted(used, key=str):
            units.setdefault(symbol.name, kind.unit)
        limits = self.limits(fields["limits"]) if "limits" in fields else JointLimits()
        return Joint(word, axis, origin, rpy, displacement, limits=limits,
                     **self.joint_forces(fields, kind))

    def joint_forces(self, fields: dict[str, Cursor], kind: JointType) -> dict[str, sp.Expr]:
        """damping, friction, friction_velocity, stiffness, rest: constants (expressions of
        the parameters); damping, friction and stiffness >= 0, friction_velocity > 0.  Their
        units follow from the joint type's: damping N*m*s/rad or N*s/m, friction N*m or N,
        friction_velocity rad/s or m/s, stiffness N*m/rad or N/m."""
        units = {"damping": f"{kind.effort_unit}*s/{kind.unit}",
                 "friction": kind.effort_unit,
                 "friction_velocity": f"{kind.unit}/s",
                 "stiffness": f"{kind.effort_unit}/{kind.unit}"}
        result: dict[str, sp.Expr] = {}
        for key in JOINT_FORCE_KEYS:
            if key not in fields:
                continue
            expr = self.constant(fields[key])
            value = self.check_numeric(fields[key], expr)
            if key == "friction_velocity" and value <= 0:
                raise fields[key].error(f"must be positive (the joint rate, in "
                                        f"{units[key]}, over which friction is smoothed), got "
                                        f"{value:g}")
            if key in ("damping", "friction", "stiffness") and value < 0:
                raise fields[key].error(f"must be 0 or positive ({units[key]}), got {value:g}")
            result[key] = expr
        return result

    def limits(self, cursor: Cursor) -> JointLimits:
        """Bounds a run is checked against: lower <= displacement <= upper (rad or m),
        |rate| <= velocity, |effort| <= effort; lower <= upper, velocity and effort > 0."""
        fields = cursor.mapping(("lower", "upper", "velocity", "effort"))
        exprs: dict[str, sp.Expr] = {}
        values: dict[str, float] = {}
        for key, item in fields.items():
            exprs[key] = self.constant(item)
            values[key] = self.check_numeric(item, exprs[key])
            if key in ("velocity", "effort") and values[key] <= 0:
                raise item.error(f"must be positive, got {values[key]:g}")
        if values.get("lower", -math.inf) > values.get("upper", math.inf):
            raise fields["upper"].error(f"upper limit {values['upper']:g} is below the lower "
                                        f"limit {values['lower']:g}")
        return JointLimits(**{k: e.xreplace(self.values) for k, e in exprs.items()})

    def inertia(self, cursor: Cursor) -> sp.Matrix:
        keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
        fields = cursor.mapping(keys + ("triangle_inequality",))
        # "ignore": an imported inertia kept as given (anadyn import --inertia accept)
        triangle = (fields.pop("triangle_inequality").choice(("check", "ignore"))
                    if "triangle_inequality" in fields else "check")
        value = {}
        numbers = {}
        for k in keys:
            if k in fields:
                value[k] = self.constant(fields[k])
                numbers[k] = self.check_numeric(fields[k], value[k])
            else:
                value[k], numbers[k] = sp.Integer(0), 0.0
        matrix = sp.Matrix([[value["ixx"], value["ixy"], value["ixz"]],
                            [value["ixy"], value["iyy"], value["iyz"]],
                            [value["ixz"], value["iyz"], value["izz"]]])
        numeric = np.array([[numbers["ixx"], numbers["ixy"], numbers["ixz"]],
                            [numbers["ixy"], numbers["iyy"], numbers["iyz"]],
                            [numbers["ixz"], numbers["iyz"], numbers["izz"]]])
        with np.errstate(all="ignore"):
            moments = np.linalg.eigvalsh(numeric) if np.isfinite(numeric).all() else None
        if moments is None or not np.isfinite(moments).all():
            raise cursor.error("inertia tensor entries are too large to check (at most "
                               "about 1e150)")
        scale = max(1.0, float(np.abs(moments).max()))
        if moments[0] < -1e-12 * scale:
            raise cursor.error(f"inertia tensor must be positive semidefinite; its principal "
                               f"moments are {', '.join(f'{m:g}' for m in moments)}")
        a, b, c = moments
        if triangle == "check" and a + b < c - 1e-9 * scale:
            raise cursor.error(f"principal moments {a:g}, {b:g}, {c:g} break the triangle "
                               "inequality (no rigid body has them: I1 + I2 >= I3)")
        return matrix

    def tree_order(self, bodies: dict[str, Body], cursors: dict[str, Cursor]) -> tuple[Body, ...]:
        """Parents before children (by depth, then file order); unknown parents and cycles fail."""
        for name, body in bodies.items():
            if body.parent != GROUND and body.parent not in bodies:
                options = [GROUND, *bodies]
                close = difflib.get_close_matches(body.parent, options, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise cursors[name].child("parent", None).error(
                    f"unknown parent {shorten(body.parent)!r}{hint}; use 'ground' or a body name")
        depth: dict[str, int] = {GROUND: 0}
        for name in bodies:
            chain = []
            current = name
            while current not in depth and current not in chain:
                chain.append(current)
                current = bodies[current].parent
            if current not in depth:            # walked into a loop
                cycle = sorted(set(bodies) - {n for n in depth if n != GROUND}
                               - {n for n in bodies if self._reaches_ground(n, bodies)})
                raise cursors[cycle[0]].child("parent", None).error(
                    f"bodies {', '.join(cycle)} form a cycle; every chain must start at ground")
            for offset, member in enumerate(reversed(chain)):
                depth[member] = depth[current] + offset + 1
        return tuple(sorted(bodies.values(), key=lambda b: depth[b.name]))

    @staticmethod
    def _reaches_ground(name: str, bodies: dict[str, Body]) -> bool:
        seen = set()
        while name != GROUND and name not in seen:
            seen.add(name)
            name = bodies[name].parent
        return name == GROUND

    # -- whole-robot checks --------------------------------------------------
    def initial_state(self, coordinates: tuple[Coordinate, ...]) -> dict[sp.Symbol, sp.Expr]:
        state: dict[sp.Symbol, sp.Expr] = {sp.Symbol("t", real=True): sp.Integer(0)}
        for c in coordinates:
            state[c.symbol] = c.initial
            state[c.rate_symbol] = c.rate
        return state

    def defined_at(self, cursor: Cursor, expr: sp.Expr, state: dict, what: str) -> None:
        """``expr`` (parameters and gains given their values here) must be a
        finite real number at ``state`` (the initial state), evaluated as the
        generated code will: in floating point, term by term (so sqrt(-1)*0
        fails as it will in a run)."""
        try:         # first in double precision: exact evaluation of a huge number hangs
            expressions.approximate(expr, {**self.values, **self.gain_values, **state})
            fine = True
        except expressions.ExpressionError:
            fine = False
        expr = expr.xreplace(self.values).xreplace(self.gain_values) if fine else expr
        used = sorted(expr.free_symbols & set(state), key=str)
        if fine and _defined(expr, used, [state[s] for s in used]):
            return
        where = ", ".join(f"{s} = {float(state[s]):.6g}" for s in used)
        raise cursor.error(f"{what} is not a finite real number at the initial state "
                           f"({where or 't = 0'}); it must be defined where the motion starts")

    def check_displacements(self, bodies: tuple[Body, ...], cursors: dict[str, Cursor],
                            coordinates: tuple[Coordinate, ...]) -> None:
        state = self.initial_state(coordinates)
        for body in bodies:
            joint = body.joint
            if not joint.joint_type.moving:
                continue
            joint_value = cursors[body.name].value["joint"]
            cursor = cursors[body.name].child("joint", joint_value)
            if "displacement" in joint_value:
                cursor = cursor.child("displacement", joint_value["displacement"])
            self.defined_at(cursor, joint.displacement, state, "the displacement")
            displacement = joint.displacement.xreplace(self.values)
            for symbol in sorted(displacement.free_symbols & set(self.q.values()), key=str):
                self.defined_at(cursor, sp.diff(displacement, symbol), state,
                                f"its rate d/d{symbol}")

    def check_mass_matrix(self, robot: Robot, cursor: Cursor,
                          items: dict[str, Cursor]) -> None:
        initial = [float(c.initial) for c in robot.coordinates]
        motion = massmatrix.singular_everywhere(robot, initial)
        if motion is None:
            return
        names = [c.name for c in robot.coordinates]
        moving = [(name, v) for name, v in zip(names, motion) if abs(v) > 1e-6]
        where = (f"the mass matrix is singular at the initial state and at "
                 f"{massmatrix.RANDOM_STATES} random states")
        if len(moving) == 1:
            name = moving[0][0]
            raise items[name].error(
                f"moving {name} moves no mass ({where}); every coordinate must move a body "
                "with mass off the joint axis or with inertia about it")
        ratio = " : ".join(f"{v:.3g}" for _, v in moving)
        raise cursor.error(
            f"moving {', '.join(n for n, _ in moving)} with rates in the ratio {ratio} moves "
            f"no mass ({where}); the coordinates must be independent: no combination of "
            "them may leave every body at rest")

    # -- actuators, controller, trajectory, simulation -----------------------
    def actuators(self, cursor: Cursor, bodies: tuple[Body, ...]) -> tuple[Actuator, ...]:
        by_name = {b.name: b for b in bodies}
        result = []
        for key, item in cursor.mapping().items():
            self.key_name(item, key, "actuator name")
            self.claim(item, key, "an actuator")
            fields = item.mapping(("joint",), required=("joint",))
            body_name = fields["joint"].value
            if not isinstance(body_name, str):
                raise fields["joint"].error(f"expected a body name, got {_kind(body_name)}")
            if body_name not in by_name:
                shown = repr(shorten(body_name))
                close = (difflib.get_close_matches(body_name, list(by_name), n=1)
                         if isinstance(body_name, str) else [])
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise fields["joint"].error(f"unknown body {shown}{hint}; actuators act on "
                                            f"the joint of one of: {', '.join(by_name)}")
            joint = by_name[body_name].joint
            if not joint.joint_type.moving:
                raise fields["joint"].error(f"body {body_name!r} has a {joint.type} joint; "
                                            f"nothing to drive (actuate a {MOVING_WORDS} joint)")
            result.append(Actuator(key, body_name, joint.joint_type.effort_unit))
        return tuple(result)

    def controller(self, cursor: Cursor, actuators: tuple[Actuator, ...],
                   coordinates: tuple[Coordinate, ...]) -> Controller:
        fields = cursor.mapping(("gains", "laws"), required=("laws",))
        gains: dict[str, sp.Expr] = {}
        names = dict(self.symbols)
        if "gains" in fields:
            for key, item in fields["gains"].mapping().items():
                self.key_name(item, key, "gain name")
                self.claim(item, key, "a controller gain")
                value = item.expr(names, self.unavailable(names))
                self.check_numeric(item, value)
                value = value.xreplace(self.values).xreplace(self.gain_values)
                gains[key] = value
                symbol = sp.Symbol(key, real=True)
                names[key] = symbol
                self.gain_values[symbol] = value
        t = sp.Symbol("t", real=True)
        names.update(self.q)
        names.update({"d" + k: sp.Symbol("d" + k, real=True) for k in self.q})
        names["t"] = t
        laws_cursor = fields["laws"]
        laws = {}
        actuator_names = [a.name for a in actuators]
        state = self.initial_state(coordinates)
        for key, item in laws_cursor.mapping().items():
            if key not in actuator_names:
                close = difflib.get_close_matches(key, actuator_names, n=1)
                hint = f"did you mean {close[0]!r}? " if close else ""
                raise item.error(f"law for unknown actuator; {hint}actuators: "
                                 f"{', '.join(actuator_names) or 'none'}")
            laws[key] = item.expr(names, self.unavailable(names))
            self.defined_at(item, laws[key], state, "the law")
        missing = [a for a in actuator_names if a not in laws]
        if missing:
            raise laws_cursor.error(f"no law for actuator(s) {', '.join(missing)}; "
                                    "every actuator needs one")
        return Controller(frozen_map(gains), frozen_map(laws))

    def loads(self, cursor: Cursor, bodies: tuple[Body, ...],
              coordinates: tuple[Coordinate, ...]) -> tuple[Load, ...]:
        """External forces and torques: ``body``, ``point`` (body axes, constants),
        ``force`` and/or ``torque`` (expressions of t, the coordinates and their rates),
        ``frame`` (world or body: the axes of the two vectors)."""
        by_name = {b.name: b for b in bodies}
        names = {**self.symbols, **self.q, "t": sp.Symbol("t", real=True)}
        names.update({"d" + k: sp.Symbol("d" + k, real=True) for k in self.q})
        state = self.initial_state(coordinates)
        result = []
        for item in cursor.sequence():
            fields = item.mapping(("body", "point", "force", "torque", "frame"),
                                  required=("body",))
            body = fields["body"].value
            if not isinstance(body, str):
                raise fields["body"].error(f"expected a body name, got {_kind(body)}")
            if body not in by_name:
                close = difflib.get_close_matches(body, list(by_name), n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise fields["body"].error(f"unknown body {shorten(body)!r}{hint}; loads act on "
                                           f"one of: {', '.join(by_name)}")
            if "force" not in fields and "torque" not in fields:
                raise item.error("a load needs a force, a torque or both, e.g. "
                                 "force: [0, 0, -50] (N) or torque: [0, 0, 2] (N*m)")
            if "point" in fields and "force" not in fields:
                raise fields["point"].error("only a force has a point of application (a "
                                            "torque acts on the whole body); remove the point "
                                            "or add a force")
            point = self.constant_vector(fields.get("point"))
            frame = fields["frame"].choice(LOAD_FRAMES) if "frame" in fields else "world"
            vectors = {}
            for key in ("force", "torque"):
                vectors[key] = (sp.Integer(0),) * 3
                if key in fields:
                    vectors[key] = fields[key].vector(names, self.unavailable(names))
                    for i, component in enumerate(vectors[key]):
                        self.defined_at(fields[key], component, state,
                                        f"the {'xyz'[i]} component")
            result.append(Load(body, point, vectors["force"], vectors["torque"], frame))
        return tuple(result)

    def trajectory(self, cursor: Cursor) -> Trajectory:
        fields = cursor.mapping(("kind", "duration", "from", "to", "expressions", "points",
                                 "durations", "shape", "times", "q", "dq", "ddq"),
                                required=("kind",))
        kind = fields["kind"].choice(TRAJECTORY_KINDS)
        if kind == "spline":                     # samples of q, dq, ddq (model.spline)
            from . import spline
            return spline.read(self, cursor, fields)
        for key in ("times", "q", "dq", "ddq"):
            if key in fields:
                raise fields[key].error(f"'{key}' belongs to kind 'spline'")
        if kind == "waypoints":                  # poses and durations (model.waypoints)
            from . import waypoints
            return waypoints.read(self, cursor, fields)
        for key in ("points", "durations", "shape"):
            if key in fields:
                raise fields[key].error(f"'{key}' belongs to kind 'waypoints'")
        if "duration" not in fields:
            raise cursor.error("missing required key 'duration'")
        duration = self.constant(fields["duration"])
        T = self.positive(fields["duration"], duration, "a duration in s")
        duration = duration.xreplace(self.values)
        ends = {}
        for key in ("from", "to"):
            ends[key] = {}
            if key in fields:
                if kind == "expression":
                    raise fields[key].error("'from' and 'to' belong to cycloidal and quintic "
                                            "trajectories; 'expression' takes 'expressions'")
                for name, item in fields[key].mapping().items():
                    self.known_coordinate(item, name)
                    value = self.constant(item)
                    self.check_numeric(item, value)
                    ends[key][name] = value.xreplace(self.values)
        expressions_ = {}
        if kind == "expression":
            if "expressions" not in fields:
                raise cursor.error("missing required key 'expressions' for kind 'expression'")
            t = sp.Symbol("t", real=True)
            names = {**self.symbols, "t": t}
            for name, item in fields["expressions"].mapping().items():
                self.known_coordinate(item, name)
                expression = item.expr(names, self.unavailable(names))
                for moment in (sp.Integer(0), sp.Float(T)):
                    try:   # in double precision first: exact evaluation of a huge number hangs
                        expressions.approximate(expression, {**self.values, t: moment})
                        value = complex(expression.xreplace(self.values).xreplace({t: moment})
                                        .evalf())
                    except (TypeError, ValueError, ArithmeticError, RecursionError):
                        value = complex("nan")
                    if value.imag != 0 or not math.isfinite(value.real):
                        raise item.error(f"not a finite real number at t = {float(moment):g} "
                                         f"s; q(t) must be defined for 0 <= t <= {T:g}")
                expressions_[name] = expression.xreplace(self.values)
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
            raise cursor.error(f"unknown coordinate {shorten(name)!r}{hint}; coordinates: "
                               f"{', '.join(self.q)}")

    def simulation(self, cursor: Cursor) -> Simulation:
        fields = cursor.mapping(("t_end", "output_step", "method", "rtol", "atol"))
        values: dict[str, object] = {}
        for key in ("t_end", "output_step", "rtol", "atol"):
            if key in fields:
                expr = self.constant(fields[key])
                value = self.check_numeric(fields[key], expr)
                if value <= 0:
                    raise fields[key].error(f"must be positive, got {value:g}")
                values[key] = value
        if "t_end" in values and "output_step" in values:
            if values["output_step"] > values["t_end"]:
                raise fields["output_step"].error(
                    f"output step {values['output_step']:g} s is longer than t_end "
                    f"{values['t_end']:g} s; it must be at most t_end")
            rows = values["t_end"] / values["output_step"]
            if rows > MAX_ROWS:
                raise fields["output_step"].error(
                    f"t_end / output_step = {rows:.3g} rows; at most {MAX_ROWS:,} "
                    "(raise output_step or shorten t_end)")
        if "method" in fields:
            values["method"] = fields["method"].choice(METHODS)
        return Simulation(**values)


def _defined(expr: sp.Expr, symbols: list, values: list) -> bool:
    """Whether ``expr`` at ``symbols = values`` is a finite real number, in
    floating point with ``math`` (as the generated code computes it)."""
    try:
        exact = expr.xreplace(dict(zip(symbols, values)))
        number = complex(exact.evalf())
    except (TypeError, ValueError, ArithmeticError, RecursionError):
        return False
    if number.imag != 0 or not math.isfinite(number.real):
        return False
    try:   # SymPy's own printer on an expression built from the whitelist: no file text
        function = sp.lambdify(symbols, expr, modules="math")
    except Exception:               # noqa: BLE001 (a form the printer lacks: exact check only)
        return True
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            number = complex(function(*(float(v) for v in values)))
    except (TypeError, ValueError, ArithmeticError, RecursionError):
        return False
    return number.imag == 0 and math.isfinite(number.real)


def _moving(word: object) -> bool:
    """Whether ``word`` (a value read from the file, any type) names a joint type that
    moves: such a joint without a displacement takes a coordinate."""
    return isinstance(word, str) and word in JOINT_TYPES and JOINT_TYPES[word].moving


def _unit(axis, values) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """The axis scaled to unit length (exact when its components are exact)."""
    norm = sp.sqrt(sum(a ** 2 for a in axis))
    if norm.xreplace(values) == 1:
        return tuple(axis)
    return tuple(a / norm for a in axis)
