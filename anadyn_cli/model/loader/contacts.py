"""The ``contacts`` section: spheres and points on bodies against ground planes, under
the compliant law (``model.contacts``).

    contacts:
      model: compliant                         # the only one implemented
      ground: {normal: [0, 0, 1], height: 0}   # the default plane for every contact
      stiffness: 1e6                           # the law, for every contact ...
      damping: 0
      friction: 0.5
      geometry:
        - {body: ball, point: [0, 0, 0], radius: 0.1}
        - {name: toe, body: foot, point: [0.1, 0, 0], friction: 0.8}   # ... or per contact
        - {name: knock, body: a, radius: 0.1, against: {body: b, radius: 0.1}}   # two spheres

Every value is a constant (a number or an expression of the parameters).  Refused,
one line naming the place: a negative stiffness, damping or friction, a stiffness
missing, an exponent below 1, a friction velocity or a radius that is not positive,
a zero normal, a body that does not exist (or ``ground``), two contacts of one name, a
sphere against one on its own body or with both ``against`` and ``ground``,
and the rigid model's keys (``model: rigid``, ``restitution``, checked to lie in
[0, 1] first): the rigid model is not implemented.
"""
from __future__ import annotations

import difflib

import sympy as sp

from ...errors import shorten
from ..contacts import (CONTACT_MODELS, DEFAULT_EXPONENT, DEFAULT_FRICTION_VELOCITY, Contact,
                        ContactLaw, Contacts, Ground, Partner)
from ..robot import Body
from ..yamlschema import describe_value as _kind
from .cursor import Cursor

#: the law's keys, with their units; given in the section (every contact) or per contact
LAW_KEYS = {"stiffness": "N/m^exponent", "damping": "s/m", "exponent": "",
            "friction": "", "friction_velocity": "m/s"}
SECTION_KEYS = ("model", "ground", "restitution", *LAW_KEYS, "geometry")
GEOMETRY_KEYS = ("name", "body", "point", "radius", "ground", "against", "restitution",
                 *LAW_KEYS)


class _Contacts:
    """The builder's ``contacts`` section (part of ``builder._RobotBuilder``)."""

    def contacts(self, cursor: Cursor, bodies: tuple[Body, ...]) -> Contacts:
        """The section (module docstring)."""
        fields = cursor.mapping(SECTION_KEYS, required=("geometry",))
        model = fields["model"].choice(("compliant", "rigid")) if "model" in fields else (
            "compliant")
        self._restitution(fields.get("restitution"))
        if model not in CONTACT_MODELS:
            raise fields["model"].error("the rigid contact model (impacts with restitution, "
                                        "unilateral constraints) is not implemented yet; use "
                                        "model: compliant")
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
            self._restitution(geometry.get("restitution"))
            body = self._contact_body(geometry["body"], names)
            radius = sp.Integer(0)
            if "radius" in geometry:
                radius = self.constant(geometry["radius"])
                self.positive(geometry["radius"], radius, "the sphere's radius, m; a point "
                              "contact has no radius")
            local = self._ground(geometry["ground"]) if "ground" in geometry else ground
            partner = None
            if "against" in geometry:
                if "ground" in geometry:
                    raise geometry["ground"].error("a contact is against a ground plane or "
                                                   "against another body's sphere, not both")
                partner, local = self._partner(geometry["against"], names, body), None
            items.append(Contact(name, body, self.constant_vector(geometry.get("point")),
                                 radius, local, self._law({**law, **{
                                     key: geometry[key] for key in LAW_KEYS if key in geometry
                                 }}, item), partner))
        if not items:
            raise fields["geometry"].error("expected at least one contact, e.g. "
                                           "- {body: ball, radius: 0.1}")
        return Contacts(model, tuple(items))

    def _restitution(self, cursor: Cursor | None) -> None:
        """A restitution is the rigid model's: checked to lie in [0, 1], then refused."""
        if cursor is None:
            return
        value = self.check_numeric(cursor, self.constant(cursor))
        if not 0 <= value <= 1:
            raise cursor.error(f"a coefficient of restitution lies in [0, 1], got {value:g}")
        raise cursor.error("restitution belongs to the rigid contact model, which is not "
                           "implemented yet; the compliant model loses energy through its "
                           "damping")

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

    def _law(self, given: dict[str, Cursor], item: Cursor) -> ContactLaw:
        """The compliant law from the section's keys overridden by the contact's."""
        if "stiffness" not in given:
            raise item.error("missing stiffness (N/m^exponent; give it in the contacts "
                             "section for every contact, or per contact)")
        values: dict[str, sp.Expr] = {"damping": sp.Integer(0), "friction": sp.Integer(0),
                                      "exponent": sp.Float(DEFAULT_EXPONENT),
                                      "friction_velocity": sp.Float(DEFAULT_FRICTION_VELOCITY)}
        for key, cursor in given.items():
            expr = self.constant(cursor)
            value = self.check_numeric(cursor, expr)
            unit = f", {LAW_KEYS[key]}" if LAW_KEYS[key] else ""
            if key == "exponent" and value < 1:
                raise cursor.error(f"must be 1 or more (1: linear spring, 1.5: Hertz), got "
                                   f"{value:g}")
            if key == "friction_velocity" and value <= 0:
                raise cursor.error(f"must be positive (the sliding speed over which friction "
                                   f"is smoothed, m/s), got {value:g}")
            if value < 0:
                raise cursor.error(f"must be 0 or positive{unit}, got {value:g}")
            values[key] = expr
        return ContactLaw(**values)
