"""The anadyn YAML text of an imported URDF: bodies, the header and comments,
written by ``robottext`` (names made identifiers by ``_Names``, numbers as
written back exactly by ``_format``, ``render``, through which no URDF name can
change the YAML structure)."""
from __future__ import annotations

import math
from pathlib import Path

from ... import __version__
from ..joints import COMPOUND_TYPES, JOINT_TYPES, Compound, Floating
from ..names import ANGULAR, GROUND, QUATERNION
from ..robottext import SMALLEST, Numbers, _angle, _format, _key
from .frames import IDENTITY, _snap, compose, matrix_rpy
from .inertia import combine
from .parse import _Joint
from .tree import WORLD

#: joint type -> the parts that name the coordinates and speeds of a floating or planar
#: joint (``several_names``)
COORDINATES = {Floating.word: (("x", "y", "z", *QUATERNION), ANGULAR),
               "planar": (("x", "y", "theta"), ())}


class _Emit(Numbers):
    """The importer's writing steps (part of ``importer._Importer``): a body's
    entries, the numbers (``robottext.Numbers``), the header and comments."""

    def collect_notes(self) -> None:
        if self.placeholders:
            shown = "; ".join(f"{where}: {', '.join(what)}"
                              for where, what in self.placeholders.items())
            self.warnings.append(
                f"{self.source}: <limit> values taken for unset placeholders and left out (a "
                f"moving joint with a zero range, velocity or effort limit cannot move): {shown}")
        if self.flushed:
            self.warnings.append(f"{self.source}: {self.flushed} number(s) below {SMALLEST:g} "
                                 "in size written as 0")

    def trajectory_hint(self, joint: _Joint, name: str) -> str:
        """A commented-out motion for ``anadyn inverse`` (a URDF has none): the first
        coordinate 0.5 rad or 0.05 m on from its start, within its limits."""
        start = self.initial(joint)
        target = start + (0.5 if joint.kind.angular else 0.05)
        if "upper" in joint.limit:
            target = min(target, joint.limit["upper"])
        return (f"# a motion for `anadyn inverse` (a URDF has none); uncomment and edit:\n"
                f"# trajectory: {{kind: quintic, duration: 2, to: {{{_key(name)}: "
                f"{_format(self.value(target))}}}}}\n")

    def initial(self, joint: _Joint) -> float:
        """0, or the middle of the joint's range when 0 is outside it."""
        lower, upper = joint.limit.get("lower"), joint.limit.get("upper")
        if lower is not None and not lower <= 0 <= upper:
            return self.value((lower + upper) / 2)
        return 0

    def body(self, joint, owner, pose, parts, links, body_name, q, masters, several) -> dict:
        where = f"joint {joint.name!r}"
        parent = owner[joint.parent]
        placement = pose[joint.parent]
        if placement is IDENTITY:
            origin, rpy = joint.origin, joint.rpy
        else:
            R, origin = compose(placement, joint.pose)
            origin, rpy = _snap(origin), _snap(matrix_rpy(R), math.pi)
        mass = combine([self.checked_inertial(links[name], where).moved(pose[name])
                        for name, _ in parts if links[name].inertial is not None])
        spec = {"type": joint.kind.word}
        if origin.any():
            spec["origin"] = self.vector(origin)
        if rpy.any():
            spec["rpy"] = [_angle(self.value(a)) for a in rpy]
        if joint.name in several:                      # a floating or planar joint
            names, speeds = several[joint.name]
            if joint.kind.word != Floating.word:
                spec["axis"] = self.vector(joint.axis)
            spec["coordinates"] = names
            if speeds:
                spec["speeds"] = speeds
        else:
            spec["axis"] = self.vector(joint.axis)
            spec["displacement"] = self.displacement(joint, q, masters)
        if joint.limit:
            spec["limits"] = {k: self.value(joint.limit[k])
                              for k in ("lower", "upper", "velocity", "effort") if k in joint.limit}
        spec.update({k: self.value(v) for k, v in joint.dynamics.items()})
        body = {"name": body_name[joint.child],
                "parent": GROUND if parent == GROUND else body_name[parent],
                "joint": spec, "mass": self.value(mass.mass)}
        com = _snap(mass.com)
        if com.any():
            body["com"] = self.vector(com)
        body["inertia"] = self.inertia_entries(_snap(mass.inertia))
        if any(links[name].accepted for name, _ in parts):
            body["inertia"]["triangle_inequality"] = "ignore"
        return body

    def displacement(self, joint: _Joint, q: dict[str, str], masters) -> str:
        if joint.name not in masters:
            return q[joint.name]
        master, k, c = masters[joint.name]
        term = q[master] if k == 1 else f"-{q[master]}" if k == -1 else \
            f"{_format(self.value(k))}*{q[master]}"
        if c == 0:
            return term
        offset = self.value(abs(c))
        return f"{term} {'+' if c > 0 else '-'} {_format(offset)}" if offset else term

    def several_names(self, joint: _Joint, body: str, names) -> tuple[list[str], list[str]]:
        """The coordinates and speeds of a floating or planar joint (``COORDINATES``),
        named after the joint (after its body for the one --floating-base adds)."""
        stem = joint.name or body
        coordinates, speeds = COORDINATES[joint.kind.word]
        return ([names.coordinate(f"{stem}_{part}") for part in coordinates],
                [names.coordinate(f"{stem}_{part}") for part in speeds])

    def description(self, root, coordinates, moving, masters, several) -> str:
        kinds = [(kind.word, sum(j.kind is kind for j in moving if j in coordinates
                                 or isinstance(j.kind, Compound)))
                 for kind in (*JOINT_TYPES.values(), *COMPOUND_TYPES.values())]
        counted = ", ".join(f"{n} {k}" for k, n in kinds if n)
        mimic = f", {len(masters)} mimic joint{'s' if len(masters) > 1 else ''}" if masters else ""
        count = len(coordinates) + sum(len(listed) for listed, _ in several.values())
        return (f"URDF robot {root.get('name') or '?'!r} from {Path(self.source).name}: "
                f"{count} coordinates ({counted}){mimic}, {len(moving)} bodies")

    def header(self, base, base_links, coordinates, masters, q, joints, locks,
               several) -> list[str]:
        flags = self.options.flags()
        lines = [f"Imported by anadyn {__version__} from {Path(self.source).name} "
                 f"(`anadyn import{' ' + flags if flags else ''}`); edit freely.",
                 "URDF joint -> coordinate (revolute and continuous: rad, prismatic: m), "
                 "actuator tau_<coordinate> on it:"]
        for joint in coordinates:
            renamed = f" (URDF joint {joint.name!r})" if q[joint.name] != joint.name else ""
            lines.append(f"  {q[joint.name]}: {joint.type}{renamed}")
        for name, (listed, speeds) in several.items():
            what = (f"URDF joint {name!r}" if name else
                    "added by --floating-base between the world and the root link")
            lines.append(f"  {', '.join(listed)}: {joints[name].type} ({what}; no actuator)"
                         + (f", speeds {', '.join(speeds)} (body axes)" if speeds else ""))
        for name in masters:
            lines.append(f"  mimic joint {name!r}: displacement "
                         f"{self.displacement(joints[name], q, masters)} (no coordinate, "
                         "no actuator)")
        if locks:
            lines.append("Locked joints (--lock), their child links folded into the body "
                         "before them at that displacement:")
            lines.extend(f"  {name}: {joints[name].type} at {_format(value)} "
                         f"{joints[name].kind.unit}" for name, value in locks.items())
        fixed = ", ".join(name for name, _ in base_links)
        if base == WORLD:
            lines.append(f"Base: link {joints[WORLD].child!r}, free (--floating-base).")
        else:
            lines.append(f"Base (fixed to the world, its mass does not move): link {base!r}"
                         + (f" and the links fixed to it: {fixed}" if fixed else "") + ".")
        lines.append("Gravity 9.81 m/s^2 along -z of the base (URDF convention).")
        lines.extend(f"warning: {w.split(': ', 1)[1]}" for w in self.warnings)
        return lines

    def body_comment(self, joint, parts, pose, body_name) -> list[str]:
        lines = []
        if body_name[joint.child] != joint.child:
            lines.append(f"URDF link {joint.child!r}")
        if len(parts) > 1:
            lines.append(f"links fixed to {body_name[joint.child]}, folded in (mass, centre of "
                         "mass, inertia added); their frames in its axes:")
            for name, via in parts[1:]:
                R, p = pose[name]
                origin = ", ".join(_format(x) for x in _snap(p))
                rpy = ", ".join(_format(_angle(float(a))) for a in _snap(matrix_rpy(R), math.pi))
                lines.append(f"  {name} (joint {via.name}): origin [{origin}], rpy [{rpy}]")
        return lines
