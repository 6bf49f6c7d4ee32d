"""The ``contacts`` section: spheres, points, capsules and boxes on bodies against
ground planes, under the compliant law (``model.contacts``).

    contacts:
      model: compliant                         # or rigid (friction, restitution only)
      ground: {normal: [0, 0, 1], height: 0}   # the default plane for every contact
      stiffness: 1e6                           # the law, for every contact ...
      damping: 0
      friction: 0.5
      geometry:
        - {body: ball, point: [0, 0, 0], radius: 0.1}
        - {name: toe, body: foot, point: [0.1, 0, 0], friction: 0.8}   # ... or per contact
        - {name: knock, body: a, radius: 0.1, against: {body: b, radius: 0.1}}   # two spheres
        - {name: leg, body: shin, shape: capsule, radius: 0.05, from: [0, 0, 0], to: [0, 0, -0.4]}
        - {name: crate, body: box, shape: box, size: [0.1, 0.2, 0.05], point: [0, 0, 0],
           rpy: [0, 0, 0]}                     # half-extents; R = Rz(yaw) Ry(pitch) Rx(roll)

``shape`` is ``point`` (no ``radius``; the default without one), ``sphere`` (the default
with one), ``capsule`` (``radius`` and the segment's ends ``from``, ``to``, body axes) or
``box`` (half-extents ``size``, centre ``point``, axes ``rpy``).  Against a ground a
capsule becomes two sphere contacts ``<name>_1`` (``from``) and ``<name>_2`` (``to``),
and a box eight point contacts at its corners, ``<name>_1`` ... ``<name>_8`` in the
order of the signs of its half-extents (-, -, -), (-, -, +), (-, +, -), ... (+, +, +)
(the last axis's sign changing fastest): the deepest point of either lies among them.
Against a sphere it stays one contact ``<name>`` (``model.contacts.Contact.spans``).

Every value is a constant (a number or an expression of the parameters).  Refused,
one line naming the place: a negative stiffness, damping or friction, a stiffness
missing, an exponent below 1, a friction velocity, a radius or a half-extent that is
not positive, a capsule whose ends coincide, a key its shape does not take,
a zero normal, a body that does not exist (or ``ground``), two contacts of one name, a
sphere against one on its own body or with both ``against`` and ``ground``, a
restitution outside [0, 1], a key of the other contact model (``MODEL_KEYS``: the
rigid model takes only ``friction`` and ``restitution``, default 0) and friction on a
rigid sphere pair.
"""
from __future__ import annotations

import difflib
import itertools

import sympy as sp

from ...errors import shorten
from ..contacts import (CONTACT_MODELS, DEFAULT_EXPONENT, DEFAULT_FRICTION_VELOCITY, Contact,
                        ContactLaw, Contacts, Ground, Partner)
from ..robot import Body
from ..yamlschema import describe_value as _kind
from .cursor import Cursor

#: the law's keys, with their units; given in the section (every contact) or per contact
LAW_KEYS = {"stiffness": "N/m^exponent", "damping": "s/m", "exponent": "",
            "friction": "", "friction_velocity": "m/s", "restitution": "",
            "static_friction": ""}
#: the keys each contact model takes (the others' are refused)
MODEL_KEYS = {"compliant": ("stiffness", "damping", "exponent", "friction",
                            "friction_velocity"),
              "rigid": ("friction", "static_friction", "restitution")}
SECTION_KEYS = ("model", "ground", *LAW_KEYS, "geometry")
#: the geometries' shapes -> the keys that place and size them (the first ones required)
SHAPES = {"point": ((), ("point",)), "sphere": (("radius",), ("point",)),
          "capsule": (("radius", "from", "to"), ()), "box": (("size",), ("point", "rpy"))}
GEOMETRY_KEYS = ("name", "body", "shape", "point", "radius", "from", "to", "size", "rpy",
                 "ground", "against", *LAW_KEYS)


class _Contacts:
    """The builder's ``contacts`` section (part of ``builder._RobotBuilder``)."""

    def contacts(self, cursor: Cursor, bodies: tuple[Body, ...]) -> Contacts:
        """The section (module docstring)."""
        fields = cursor.mapping(SECTION_KEYS, required=("geometry",))
        model = fields["model"].choice(CONTACT_MODELS) if "model" in fields else "compliant"
        ground = self._ground(fields.get("ground"))
        law = {key: fields[key] for key in LAW_KEYS if key in fields}
        names = {b.name for b in bodies}
        items, seen = [], {}
        for k, item in enumerate(fields["geometry"].sequence()):
            geometry = item.mapping(GEOMETRY_KEYS, required=("body",))
            name = (geometry["name"].identifier("contact name") if "name" in geometry
                    else f"contact{k + 1}")
            if name in seen:
                raise geometry.get("name", item).error(
                    f"contact name {name!r} is already used by geometry[{seen[name]}]; every "
                    "contact needs its own name (it names the output columns)")
            seen[name] = k
            body = self._contact_body(geometry["body"], names)
            local = self._ground(geometry["ground"]) if "ground" in geometry else ground
            partner = None
            if "against" in geometry:
                if "ground" in geometry:
                    raise geometry["ground"].error("a contact is against a ground plane or "
                                                   "against another body's sphere, not both")
                partner, local = self._partner(geometry["against"], names, body), None
            given = {**law, **{key: geometry[key] for key in LAW_KEYS if key in geometry}}
            contact_law = self._law(given, item, model)
            if (model == "rigid" and partner is not None and "friction" in given
                    and self.check_numeric(given["friction"], contact_law.friction)):
                raise given["friction"].error("the rigid model's sphere pairs are "
                                              "frictionless: give this contact friction: 0")
            for suffix, point, radius, spans in self._parts(geometry, item, partner is not None):
                if spans and model != "compliant":
                    raise geometry["shape"].error("a capsule or a box against a sphere is the "
                                                  "compliant model's; the rigid model's pairs "
                                                  "are two spheres")
                part = name + suffix
                if suffix and part in seen:
                    raise geometry.get("name", item).error(
                        f"contact name {part!r} is already used by geometry[{seen[part]}]; "
                        "every contact needs its own name (it names the output columns; a "
                        "capsule's ends and a box's corners are <name>_1, <name>_2, ...)")
                seen[part] = k
                items.append(Contact(part, body, point, radius, local, contact_law, partner,
                                     spans))
        if not items:
            raise fields["geometry"].error("expected at least one contact, e.g. "
                                           "- {body: ball, radius: 0.1}")
        return Contacts(model, tuple(items))

    def _parts(self, geometry: dict[str, Cursor], item: Cursor, against: bool) -> list:
        """The geometry's contacts as (name suffix, centre, radius, spans) (module
        docstring): one for a point or a sphere, and for a capsule or a box against a
        sphere; a capsule's two end spheres or a box's eight corners against a ground."""
        given = geometry["shape"].choice(tuple(SHAPES)) if "shape" in geometry else None
        shape = given or ("sphere" if "radius" in geometry else "point")
        required, optional = SHAPES[shape]
        for key in ("point", "radius", "from", "to", "size", "rpy"):
            if key in geometry and key not in required + optional:
                owners = [s for s, keys in SHAPES.items() if key in keys[0] + keys[1]]
                raise geometry[key].error(f"a {shape} takes no {key} ({key} is for shape: "
                                          f"{', '.join(owners)})")
        for key in required:
            if key not in geometry:
                raise geometry.get("shape", item).error(f"a {shape} needs {key} ("
                                                        f"{', '.join(required)})")
        radius = sp.Integer(0)
        if "radius" in geometry:
            radius = self.constant(geometry["radius"])
            self.positive(geometry["radius"], radius, f"the {shape}'s radius, m")
        if shape in ("point", "sphere"):
            return [("", self.constant_vector(geometry.get("point")), radius, ())]
        if shape == "capsule":
            start, end = (self.constant_vector(geometry[key]) for key in ("from", "to"))
            half = tuple((b - a) / 2 for a, b in zip(start, end))
            if not any(self.check_numeric(geometry["to"], x) for x in half):
                raise geometry["to"].error("a capsule's ends must differ (equal ends: give a "
                                           "sphere)")
            if against:
                return [("", tuple(a + h for a, h in zip(start, half)), radius, (half,))]
            return [("_1", start, radius, ()), ("_2", end, radius, ())]
        size = self.constant_vector(geometry["size"])
        for k, extent in enumerate(size):
            self.positive(geometry["size"].child(k, geometry["size"].value[k]), extent,
                          "a half-extent of the box, m")
        roll, pitch, yaw = self.constant_vector(geometry.get("rpy"))
        R = sp.rot_ccw_axis3(yaw) * sp.rot_ccw_axis2(pitch) * sp.rot_ccw_axis1(roll)
        spans = tuple(tuple(size[k] * R[j, k] for j in range(3)) for k in range(3))
        centre = self.constant_vector(geometry.get("point"))
        if against:
            return [("", centre, radius, spans)]
        return [(f"_{j + 1}", tuple(c + sum(s * e[i] for s, e in zip(signs, spans))
                                    for i, c in enumerate(centre)), radius, ())
                for j, signs in enumerate(itertools.product((-1, 1), repeat=3))]

    def _ground(self, cursor: Cursor | None) -> Ground:
        """``{normal: [x, y, z], height: h}``: the plane n . x = h, n made unit (default
        normal [0, 0, 1], height 0)."""
        if cursor is None:
            return Ground((sp.Integer(0), sp.Integer(0), sp.Integer(1)), sp.Integer(0))
        fields = cursor.mapping(("normal", "height"))
        normal = (sp.Integer(0), sp.Integer(0), sp.Integer(1))
        if "normal" in fields:
            normal = self.constant_vector(fields["normal"])
            values = [self.check_numeric(fields["normal"], c) for c in normal]
            if sum(v * v for v in values) == 0:
                raise fields["normal"].error("the ground's normal must not be zero (it points "
                                             "out of the ground, into the free space)")
            length = sp.sqrt(sum(c ** 2 for c in normal))
            normal = tuple(c / length for c in normal)
        height = sp.Integer(0)
        if "height" in fields:
            height = self.constant(fields["height"])
            self.check_numeric(fields["height"], height)
        return Ground(normal, height)

    def _partner(self, cursor: Cursor, names: set[str], body: str) -> Partner:
        """``against: {body, point, radius}``: a sphere on another body."""
        fields = cursor.mapping(("body", "point", "radius"), required=("body", "radius"))
        other = self._contact_body(fields["body"], names)
        if other == body:
            raise fields["body"].error(f"a body does not touch itself: the sphere must be on "
                                       f"another body than {body!r}")
        radius = self.constant(fields["radius"])
        self.positive(fields["radius"], radius, "the sphere's radius, m")
        return Partner(other, self.constant_vector(fields.get("point")), radius)

    def _contact_body(self, cursor: Cursor, names: set[str]) -> str:
        body = cursor.value
        if not isinstance(body, str):
            raise cursor.error(f"expected a body name, got {_kind(body)}")
        if body not in names:
            close = difflib.get_close_matches(body, sorted(names), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise cursor.error(f"unknown body {shorten(body)!r}{hint}; contacts sit on one of: "
                               f"{', '.join(sorted(names))}")
        return body

    def _law(self, given: dict[str, Cursor], item: Cursor, model: str) -> ContactLaw:
        """The law of ``model`` from the section's keys overridden by the contact's: the
        compliant one's (stiffness required) or the rigid one's (friction, restitution
        in [0, 1], default 0: a plastic impact); the other model's keys are refused."""
        if model == "compliant" and "stiffness" not in given:
            raise item.error("missing stiffness (N/m^exponent; give it in the contacts "
                             "section for every contact, or per contact)")
        values: dict[str, sp.Expr] = {"stiffness": sp.Integer(0), "damping": sp.Integer(0),
                                      "friction": sp.Integer(0), "restitution": sp.Integer(0),
                                      "exponent": sp.Float(DEFAULT_EXPONENT),
                                      "friction_velocity": sp.Float(DEFAULT_FRICTION_VELOCITY)}
        numbers: dict[str, float] = {}
        for key, cursor in given.items():
            expr = self.constant(cursor)
            value = self.check_numeric(cursor, expr)
            unit = f", {LAW_KEYS[key]}" if LAW_KEYS[key] else ""
            if key == "restitution" and not 0 <= value <= 1:
                raise cursor.error(f"a coefficient of restitution lies in [0, 1], got {value:g}")
            if key not in MODEL_KEYS[model]:
                raise cursor.error(
                    "restitution belongs to the rigid contact model (model: rigid); the "
                    "compliant model loses energy through its damping" if key == "restitution"
                    else "static_friction belongs to the rigid contact model (model: rigid); "
                    "the compliant model's regularized friction has one coefficient, "
                    "friction" if key == "static_friction"
                    else f"the rigid contact model has no {key}: contact is a constraint "
                    "there (the compliant model takes it)")
            if key == "exponent" and value < 1:
                raise cursor.error(f"must be 1 or more (1: linear spring, 1.5: Hertz), got "
                                   f"{value:g}")
            if key == "friction_velocity" and value <= 0:
                raise cursor.error(f"must be positive (the sliding speed over which friction "
                                   f"is smoothed, m/s), got {value:g}")
            if value < 0:
                raise cursor.error(f"must be 0 or positive{unit}, got {value:g}")
            values[key], numbers[key] = expr, value
        if "static_friction" in given:            # sticking needs at least sliding's mu
            static, kinetic = (numbers.get(k, 0.0) for k in ("static_friction", "friction"))
            if static < kinetic:
                raise given["static_friction"].error(
                    f"must be at least friction ({kinetic:g}, the kinetic coefficient), got "
                    f"{static:g}")
        else:
            values["static_friction"] = values["friction"]
        return ContactLaw(**values)
