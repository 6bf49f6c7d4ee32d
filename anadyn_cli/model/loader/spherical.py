"""Spherical joints: their quaternion coordinates, their speeds and the ``speeds``
section (``model.joints.Spherical``).

    joint: {type: spherical, origin: [...], rpy: [...],
            coordinates: [qw, qx, qy, qz], speeds: [wx, wy, wz]}

The names are optional (``<body>_qw`` ... and ``<body>_wx`` ...).  The quaternion's
coordinates may be listed under ``coordinates`` for their ``initial`` values
(default the identity 1, 0, 0, 0; no ``rate``: the speeds give the motion); the
speeds take theirs from the top-level ``speeds`` section (default 0).  A
quaternion that is zero, or whose norm is off 1 by more than NORM_TOLERANCE, is
refused; a nearer one is normalized, with a warning.  The quaternion's
coordinates come after the other coordinates, in body order, as the speeds do
(``Robot.speeds``).
"""
from __future__ import annotations

import math

import sympy as sp

from ..joints import JOINT_TYPES
from ..library import announce
from ..names import ANGULAR, QUATERNION
from ..robot import Body, Coordinate, Joint, Speed
from .cursor import Cursor
from .forces import JOINT_FORCE_KEYS

#: |norm - 1| of an initial quaternion above this is refused, below it normalized
NORM_TOLERANCE = 1e-6
#: ... and kept as given within rounding of 1
ROUNDING = 1e-14
#: the keys a spherical joint takes
SPHERICAL_KEYS = ("type", "origin", "rpy", "coordinates", "speeds")


class _Spherical:
    """The builder's spherical joints (part of ``builder._RobotBuilder``)."""

    def speed_section(self, cursor: Cursor | None) -> None:
        """The ``speeds`` section: name -> {initial}; checked against the joints later
        (``spherical_state``)."""
        self.speed_items: dict[str, Cursor] = {}
        self.quaternion_owner: dict[str, str] = {}
        self.speed_initial: dict[sp.Symbol, sp.Expr] = {}      # the spherical joints' u(0)
        if cursor is None:
            return
        for key, item in cursor.mapping().items():
            self.key_name(item, key, "speed name")
            self.speed_items[key] = item

    def speed_names(self) -> dict[str, sp.Symbol]:
        """The speeds' names for the expressions of the state (control laws, loads):
        d<q> for the coordinates that are no quaternion's, then the spherical joints'."""
        rates = {"d" + k: sp.Symbol("d" + k, real=True) for k in self.q
                 if k not in self.quaternion_owner}
        return {**rates, **{symbol.name: symbol for symbol in self.speed_initial}}

    def spherical_joint(self, cursor: Cursor, body: str, units: dict[str, str]) -> Joint:
        """A spherical joint of body ``body`` (module docstring)."""
        fields = cursor.mapping()
        for key in fields:
            if key in ("axis", "displacement", "limits", *JOINT_FORCE_KEYS):
                raise fields[key].error(f"a spherical joint takes no {key}: it turns about "
                                        "every axis, its coordinates a quaternion; allowed: "
                                        f"{', '.join(SPHERICAL_KEYS)}")
            if key not in SPHERICAL_KEYS:
                raise fields[key].error(f"unknown key for a spherical joint; allowed: "
                                        f"{', '.join(SPHERICAL_KEYS)}")
        names = self.listed_names(fields.get("coordinates"), body, QUATERNION, "coordinates")
        speeds = self.listed_names(fields.get("speeds"), body, ANGULAR, "speeds")
        return self.ball(body, self.constant_vector(fields.get("origin")),
                         self.constant_vector(fields.get("rpy")), names, speeds,
                         fields.get("coordinates") or cursor, fields.get("speeds") or cursor,
                         units)

    def ball(self, body: str, origin, rpy, names: list[str], speeds: list[str],
             names_place: Cursor, speeds_place: Cursor, units: dict[str, str]) -> Joint:
        """The spherical joint of ``body`` at ``origin``, ``rpy`` with the quaternion's
        coordinates ``names`` and the ``speeds`` (claimed here, errors at the places
        given; the speeds' initial values from the ``speeds`` section): for the robot
        file's spherical joints and the joints made with one."""
        for name in names:
            if name in self.quaternion_owner or (name in self.owner and name not in self.q):
                raise names_place.error(f"name {name!r} is already used by "
                                        f"{self.quaternion_owner.get(name) or self.owner[name]}"
                                        "; every name in a robot file must be different")
            if name not in self.q:
                self.claim(names_place, name, "a coordinate")
                self.q[name] = sp.Symbol(name, real=True)
            self.quaternion_owner[name] = f"the spherical joint of {body!r}"
            units[name] = JOINT_TYPES["spherical"].unit
        for name in speeds:
            self.claim(speeds_place, name, f"a speed of the spherical joint of {body!r}")
        initial = {}
        for name in speeds:
            item = self.speed_items.get(name)
            value = sp.Integer(0)
            if item is not None:
                given = item.mapping(("initial",)) if item.value is not None else {}
                if "initial" in given:
                    value = self.constant(given["initial"])
                    self.check_numeric(given["initial"], value)
                    value = value.xreplace(self.values)
            initial[name] = value
            self.speed_initial[sp.Symbol(name, real=True)] = value
        kind = JOINT_TYPES["spherical"]
        return Joint(kind.word, self.constant_vector(None), origin, rpy, sp.Integer(0),
                     coordinates=tuple(names),
                     speeds=tuple(Speed(n, initial[n], kind.speed_unit) for n in speeds))

    def listed_names(self, cursor: Cursor | None, body: str, parts: tuple[str, ...],
                     key: str, word: str = "spherical") -> list[str]:
        """The ``key`` names of body ``body``'s ``word`` joint (``parts`` many, distinct
        identifiers), or the defaults <body>_<part>."""
        if cursor is None:
            return [f"{body}_{part}" for part in parts]
        items = cursor.sequence()
        if len(items) != len(parts):
            raise cursor.error(f"a {word} joint has {len(parts)} {key} "
                               f"({', '.join(parts)}), got {len(items)}")
        names = [item.identifier(f"{key[:-1]} name") for item in items]
        if len(set(names)) != len(names):
            raise cursor.error(f"the {key} of a {word} joint must be different names")
        return names

    def spherical_state(self, top: dict[str, Cursor], bodies: tuple[Body, ...],
                        coordinates: tuple[Coordinate, ...], items: dict[str, Cursor],
                        body_cursors: dict[str, Cursor]) -> tuple[Coordinate, ...]:
        """The coordinates with each spherical joint's quaternion after the others (body
        order), its initial value checked (zero or far from unit: refused; near: made
        unit, with a warning); the ``speeds`` section checked against the joints."""
        joints = [b for b in bodies if b.joint.joint_type.orientation]
        known = {u.name for b in joints for u in b.joint.speeds}
        for name, item in self.speed_items.items():
            if name not in known:
                raise item.error(f"{name!r} is not a speed of a spherical joint; the "
                                 f"speeds section gives their initial values "
                                 f"({', '.join(sorted(known)) or 'this robot has none'}; "
                                 "a coordinate's rate goes under coordinates as 'rate')")
        if not joints:
            return coordinates
        for key in ("loops", "constraints"):
            if key in top:
                raise top[key].error("closed loops with a spherical joint are not supported "
                                     "yet; open the loop or use revolute joints")
        given = {c.name: c for c in coordinates}
        quaternion = {name for b in joints for name in b.joint.coordinates}
        for c in coordinates:
            if c.name in quaternion and c.rate != 0:
                raise items[c.name].child("rate", None).error(
                    "a quaternion coordinate has no rate of its own: give the spherical "
                    "joint's angular velocity under the top-level 'speeds' section")
        for b in bodies:
            used = b.joint.displacement.free_symbols & {sp.Symbol(n, real=True)
                                                         for n in quaternion}
            if used:
                item = body_cursors[b.name]
                raise item.child("joint", item.value.get("joint")).error(
                    f"uses the quaternion coordinate {sorted(map(str, used))[0]!r}; a "
                    "quaternion turns its spherical joint only")
        result = [c for c in coordinates if c.name not in quaternion]
        for b in joints:
            values = [float(given[n].initial) if n in given
                      else float(n == b.joint.coordinates[0]) for n in b.joint.coordinates]
            norm = math.sqrt(sum(v * v for v in values))
            place = items.get(b.joint.coordinates[0]) or top["coordinates"]
            if norm == 0:
                raise place.error(f"the quaternion ({', '.join(b.joint.coordinates)}) of the "
                                  f"spherical joint of {b.name!r} is zero; give a unit "
                                  "quaternion (the identity is 1, 0, 0, 0)")
            if abs(norm - 1) > NORM_TOLERANCE:
                raise place.error(f"the quaternion ({', '.join(b.joint.coordinates)}) of the "
                                  f"spherical joint of {b.name!r} has norm {norm:.9g}; it must "
                                  f"be a unit quaternion (within {NORM_TOLERANCE:g})")
            if abs(norm - 1) > ROUNDING:
                announce(f"{top['coordinates'].source}: the quaternion of the spherical joint "
                         f"of {b.name!r} has norm {norm:.12g}; made unit", warning=True)
            result += [Coordinate(n, _initial(given.get(n), v, norm), sp.Integer(0),
                                  JOINT_TYPES["spherical"].unit)
                       for n, v in zip(b.joint.coordinates, values)]
        return tuple(result)


def _initial(given: Coordinate | None, value: float, norm: float) -> sp.Expr:
    """A quaternion coordinate's initial value: as given (or the identity's) when the
    quaternion is unit, else ``value`` made unit."""
    if abs(norm - 1) > ROUNDING:
        return sp.Float(value / norm, 17)
    return given.initial if given is not None else sp.Integer(int(value))
