"""The ``bodies`` section: each body, its joint and inertia, the coordinates that
joints without a displacement take, and the tree order (parents first)."""
from __future__ import annotations

import difflib
import re

import numpy as np
import sympy as sp

from ...errors import shorten
from ..joints import COMPOUND_TYPES, JOINT_TYPES, Floating, Spherical
from ..names import GROUND, quaternion_names
from ..robot import Body, Joint, JointLimits
from ..yamlschema import describe_value as _kind
from .compound import POSITION
from .cursor import Cursor
from .forces import JOINT_FORCE_KEYS

# a guard against a runaway file, not a limit of the recursions (O(n)): loading checks
# M at several states, O(n^3); TIAGo dual (101 bodies, 101 coordinates) loads in 2-3 s,
# 1000 would take minutes; no published robot comes near (docs/how-to/urdf.md)
MAX_BODIES = 1000
#: the joint types that move, for messages: "revolute or prismatic"
MOVING_WORDS = " or ".join(word for word, kind in JOINT_TYPES.items() if kind.axial)


class _Bodies:
    """The builder's bodies and joints (part of ``builder._RobotBuilder``)."""

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
        carriers = {item.value.get("parent") for item in items          # names only: a bad
                    if isinstance(item.value, dict)                     # parent is refused
                    and isinstance(item.value.get("parent"), str)}      # in its own place
        for k, item in enumerate(items):
            for body in self.body(item, iter(defaults.get(k, ())), units, carriers):
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
            listed = joint.get("coordinates") if _word(joint) in COMPOUND_TYPES else None
            if isinstance(listed, list):
                claimed |= {name for name in listed if isinstance(name, str)}
            elif _word(joint) == Floating.word and isinstance(item.value.get("name"), str):
                claimed |= {f"{item.value['name']}_{part}" for part in POSITION}
            claimed |= set(quaternion_names(item.value))
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
             carriers: set) -> list[Body]:
        """The body, after the massless links of its joint's parts when the joint is
        compound (``compound``)."""
        fields = item.mapping(("name", "parent", "joint", "mass", "com", "inertia"),
                              required=("name", "joint", "mass"))
        name = fields["name"].identifier("body name")
        parent = GROUND
        if "parent" in fields:
            parent = fields["parent"].value
            if not isinstance(parent, str):
                raise fields["parent"].error(f"expected 'ground' or a body name, got "
                                             f"{_kind(parent)}")
        links = []
        if _word(fields["joint"].value) in COMPOUND_TYPES:
            *links, (_, parent, joint) = self.compound_bodies(fields, name, parent, units)
        elif _word(fields["joint"].value) == Spherical.word:
            joint = self.spherical_joint(fields["joint"], name, units)
        else:
            joint = self.joint(fields["joint"], free_coordinates, units)
        mass = self.constant(fields["mass"])
        # massless: a welded body, or a moving one that carries others (a virtual link
        # between joints, as URDF writes ball joints; M's check finds what moves nothing)
        if (joint.joint_type.moving and name not in carriers
                or self.check_numeric(fields["mass"], mass) != 0):
            self.positive(fields["mass"], mass, "a mass in kg")
        com = self.constant_vector(fields.get("com"))
        inertia = self.inertia(fields["inertia"]) if "inertia" in fields else sp.zeros(3, 3)
        massless = (sp.Integer(0), self.constant_vector(None), sp.ImmutableMatrix.zeros(3, 3))
        return [*(Body(link, above, part, *massless) for link, above, part in links),
                Body(name, parent, joint, mass, com, sp.ImmutableMatrix(inertia))]

    def joint(self, cursor: Cursor, free_coordinates, units: dict[str, str]) -> Joint:
        fields = cursor.mapping(("type", "axis", "origin", "rpy", "displacement", "limits",
                                 *JOINT_FORCE_KEYS),
                                required=("type",))
        word = fields["type"].choice((*JOINT_TYPES, *COMPOUND_TYPES))
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


def _word(joint: object) -> str | None:
    """The type word of ``joint`` (a value read from the file), if it has one."""
    word = joint.get("type") if isinstance(joint, dict) else None
    return word if isinstance(word, str) else None


def _moving(word: object) -> bool:
    """Whether ``word`` (a value read from the file, any type) names a joint type that
    moves: such a joint without a displacement takes a coordinate."""
    return isinstance(word, str) and word in JOINT_TYPES and JOINT_TYPES[word].axial


def _unit(axis, values) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """The axis scaled to unit length (exact when its components are exact)."""
    norm = sp.sqrt(sum(a ** 2 for a in axis))
    if norm.xreplace(values) == 1:
        return tuple(axis)
    return tuple(a / norm for a in axis)
