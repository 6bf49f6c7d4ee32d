"""Compound joints (``planar``, ``universal``, ``cylindrical``, ``helical``,
``floating``): each becomes a chain of one-part joints on massless links
(``model.joints``: ``Compound.chain``), so that the rest of anadyn sees only
revolute, prismatic and spherical joints.

A body ``B`` whose joint is compound gets, for every part but the last, a link
``B__<coordinate>`` (``B__lead`` for a helical joint's slide, ``B__x``, ``B__y``,
``B__z`` for a floating joint's) with no mass,
whose joint is that part; the joint's ``origin`` and ``rpy`` place the first
part, and ``B`` itself carries the last.  An actuator on a part names its link
(``joint: B__x``); on the last part, the body (``joint: B``).

A floating joint's coordinates are ``[x, y, z, qw, qx, qy, qz]`` and its speeds
``[wx, wy, wz]`` (defaults ``B_x`` ... ``B_qw`` ... ``B_wx`` ...); x, y, z not
listed under ``coordinates`` start at 0, the quaternion as a spherical joint's.
"""
from __future__ import annotations

import sympy as sp

from ..joints import (COMPOUND_TYPES, JOINT_TYPES, Compound, Floating, Helical, Prismatic,
                      Universal)
from ..names import ANGULAR, QUATERNION
from ..robot import Coordinate, Joint, JointLimits
from .cursor import Cursor
from .forces import JOINT_FORCE_KEYS

#: the keys a compound joint takes (forces and limits: helical only, on its turn)
COMPOUND_KEYS = ("type", "axis", "axis2", "pitch", "origin", "rpy", "coordinates",
                 "speeds", "displacement", "limits", *JOINT_FORCE_KEYS)
#: a floating joint's position coordinates, by default <body>_x, <body>_y, <body>_z
POSITION = ("x", "y", "z")
#: the name of the link that carries a helical joint's slide
LEAD = "lead"


class _Compound:
    """The builder's compound joints (part of ``builder._RobotBuilder``)."""

    def compound_bodies(self, fields: dict[str, Cursor], name: str, parent: str,
                        units: dict[str, str]) -> list[tuple[str, str, Joint]]:
        """(link name, its parent, its joint) for every part of the compound joint of
        body ``name``, from the parent outwards; the last is the body itself."""
        cursor = fields["joint"]
        joint = cursor.mapping(COMPOUND_KEYS, required=("type",))
        kind: Compound = COMPOUND_TYPES[joint["type"].value]
        word = kind.word
        for key, allowed in (("axis2", Universal), ("pitch", Helical), ("speeds", Floating)):
            if key in joint and not isinstance(kind, allowed):
                raise joint[key].error(f"only a {allowed.word} joint has {key!r}; remove it")
        if isinstance(kind, Floating) and "axis" in joint:
            raise joint["axis"].error("a floating joint has no axis: it slides along and turns "
                                      "about every axis; remove it")
        if not isinstance(kind, Helical):
            for key in ("displacement", "limits", *JOINT_FORCE_KEYS):
                if key in joint:
                    raise joint[key].error(
                        f"a {word} joint takes no {key!r}: give its coordinates with "
                        f"'coordinates', and forces or limits on separate joints")
        axis = self.unit_axis(joint, "axis", cursor) if "axis" in joint else \
            (sp.Integer(0), sp.Integer(0), sp.Integer(1))
        axis2 = self.unit_axis(joint, "axis2", cursor) if "axis2" in joint else None
        if isinstance(kind, Universal):
            if axis2 is None:
                raise cursor.error("missing required key 'axis2' for a universal joint (the "
                                   "second turn's axis, e.g. [0, 1, 0])")
            cross = sp.Matrix(axis).cross(sp.Matrix(axis2)).xreplace(self.values)
            if float(cross.norm()) < 1e-6:
                raise joint["axis2"].error("axis2 must not be parallel to axis (a universal "
                                           "joint turns about two different axes)")
        coordinates = self.floating_coordinates(joint, name, cursor) \
            if isinstance(kind, Floating) else self.compound_coordinates(joint, kind, cursor)
        pitch = sp.Integer(0)
        if isinstance(kind, Helical):
            if "pitch" not in joint:
                raise cursor.error("missing required key 'pitch' for a helical joint (the "
                                   "slide per turn in m/rad, e.g. 0.001)")
            pitch = self.constant(joint["pitch"])
            if self.check_numeric(joint["pitch"], pitch) == 0:
                raise joint["pitch"].error("a helical joint's pitch must not be 0 (that is a "
                                           "revolute joint)")
        origin = self.constant_vector(joint.get("origin"))
        rpy = self.constant_vector(joint.get("rpy"))
        zero = self.constant_vector(None)
        parts = kind.chain(axis, axis2, _plane_basis(self.values))
        links, above = [], parent
        for k, (part, part_axis, taken) in enumerate(parts):
            last = k == len(parts) - 1
            if JOINT_TYPES[part].orientation:
                speeds = self.floating_speeds(joint, name)
                links.append((name, above, self.ball(
                    name, origin if k == 0 else zero, rpy if k == 0 else zero,
                    [str(c) for c in coordinates[taken:taken + 4]], speeds,
                    joint.get("coordinates") or cursor, joint.get("speeds") or cursor, units)))
                continue
            part_axis = tuple(sp.Integer(a) if isinstance(a, int) else a for a in part_axis)
            displacement = coordinates[taken] if taken is not None else pitch * coordinates[0]
            if taken is not None:
                for symbol in displacement.free_symbols & set(self.q.values()):
                    units.setdefault(symbol.name, JOINT_TYPES[part].unit)
            extra = {}
            if last and isinstance(kind, Helical):
                extra = self.joint_forces(joint, JOINT_TYPES[part])
                extra["limits"] = self.limits(joint["limits"]) if "limits" in joint \
                    else JointLimits()
            part_name = LEAD if taken is None else \
                POSITION[taken] if isinstance(kind, Floating) else coordinates[taken]
            link = name if last else f"{name}__{part_name}"
            if not last and link in self.kinds:
                raise cursor.error(f"the {word} joint of {name!r} needs a link named "
                                   f"{link!r}, which is already {self.kinds[link]}; rename it")
            links.append((link, above, Joint(part, part_axis, origin if k == 0 else zero,
                                             rpy if k == 0 else zero, displacement, **extra)))
            above = link
        return links

    def floating_coordinates(self, joint: dict[str, Cursor], body: str,
                             cursor: Cursor) -> list[sp.Expr]:
        """A floating joint's seven coordinates (given or default): x, y, z as
        coordinate symbols (those not declared under ``coordinates`` added here,
        starting at 0), then the quaternion's four names as symbols (the spherical
        part claims them)."""
        names = self.listed_names(joint.get("coordinates"), body, (*POSITION, *QUATERNION),
                                  "coordinates", Floating.word)
        place = joint.get("coordinates") or cursor
        for name in names[:3]:
            if name not in self.q:
                for claimed, what in ((name, "a coordinate"),
                                      ("d" + name, f"the rate of coordinate {name!r}"),
                                      ("dd" + name, f"the acceleration of coordinate {name!r}")):
                    self.claim(place, claimed, what)
                self.q[name] = sp.Symbol(name, real=True)
                self.added_coordinates.append(Coordinate(name, sp.Integer(0), sp.Integer(0),
                                                         Prismatic.unit))
        return [sp.Symbol(name, real=True) for name in names]

    def floating_speeds(self, joint: dict[str, Cursor], body: str) -> list[str]:
        """A floating joint's angular speeds (given or default <body>_wx ...)."""
        return self.listed_names(joint.get("speeds"), body, ANGULAR, "speeds", Floating.word)

    def compound_coordinates(self, joint: dict[str, Cursor], kind: Compound,
                             cursor: Cursor) -> list[sp.Expr]:
        """The coordinates a compound joint takes, in its type's order: a helical
        joint's displacement (an expression, as for a revolute joint), else the
        ``coordinates`` list of distinct coordinate names."""
        if isinstance(kind, Helical):
            if "coordinates" in joint:
                raise joint["coordinates"].error("a helical joint has one coordinate: give "
                                                 "it as 'displacement'")
            if "displacement" not in joint:
                raise cursor.error("missing required key 'displacement' for a helical joint "
                                   "(its angle, e.g. q1)")
            names = {**self.symbols, **self.q}
            expr = joint["displacement"].expr(names, self.unavailable(names), smooth=True)
            if not expr.free_symbols & set(self.q.values()):
                raise joint["displacement"].error("the displacement must depend on at least "
                                                  "one coordinate, e.g. q1")
            return [expr]
        if "coordinates" not in joint:
            raise cursor.error(f"missing required key 'coordinates' for a {kind.word} joint "
                               f"(the names of its {kind.coordinates} coordinates, declared "
                               "under 'coordinates')")
        items = joint["coordinates"].sequence()
        if len(items) != kind.coordinates:
            raise joint["coordinates"].error(f"a {kind.word} joint has {kind.coordinates} "
                                             f"coordinates, got {len(items)}")
        result = []
        for item in items:
            if not isinstance(item.value, str) or item.value not in self.q:
                raise item.error(f"must name a coordinate declared under 'coordinates' "
                                 f"({', '.join(self.q)})")
            if self.q[item.value] in result:
                raise item.error(f"coordinate {item.value!r} is listed twice")
            result.append(self.q[item.value])
        return result

    def unit_axis(self, joint: dict[str, Cursor], key: str, cursor: Cursor):
        """The non-zero vector ``joint[key]`` scaled to unit length."""
        vector = self.constant_vector(joint[key])
        numeric = [self.check_numeric(joint[key], a) for a in vector]
        if not sum(a * a for a in numeric) > 1e-24:
            raise joint[key].error(f"{key} must not be the zero vector; give a direction "
                                   "such as [0, 0, 1]")
        norm = sp.sqrt(sum(a ** 2 for a in vector))
        return tuple(vector) if norm.xreplace(self.values) == 1 else \
            tuple(a / norm for a in vector)


def _plane_basis(values):
    """``basis(n)``: (e1, e2), unit vectors spanning the plane normal to the unit n:
    e1 the x axis (the y axis when n is nearly along x) made normal to n, e2 = n x e1."""
    def basis(n):
        n = sp.Matrix(n)
        start = sp.Matrix([1, 0, 0]) if abs(float(n[0].xreplace(values))) < 0.9 \
            else sp.Matrix([0, 1, 0])
        e1 = start - n.dot(start) * n
        e1 = sp.simplify(e1 / sp.sqrt(e1.dot(e1)))
        e2 = sp.simplify(n.cross(e1))
        return tuple(e1), tuple(e2)
    return basis
