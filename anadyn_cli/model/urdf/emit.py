"""The anadyn YAML text of an imported URDF: bodies, names made identifiers
(``_Names``), numbers as written back exactly (``_format``), comments, and
``render``, through which no URDF name can change the YAML structure."""
from __future__ import annotations

import functools
import math
import re
from pathlib import Path

import numpy as np

import yaml

from ... import __version__
from ...errors import printable
from ..joints import JOINT_TYPES
from ..names import GROUND, IDENTIFIER, RESERVED_NAMES
from ..yamlschema import Dumper
from .frames import IDENTITY, _snap, compose, matrix_rpy
from .inertia import combine
from .parse import SMALLEST, _Joint


class _Emit:
    """The importer's writing steps (part of ``importer._Importer``): a body's
    entries, the numbers, the header and comments."""

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

    def body(self, joint, owner, pose, parts, links, body_name, q, masters) -> dict:
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

    def inertia_entries(self, inertia: np.ndarray) -> dict:
        keys = {"ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2),
                "ixy": (0, 1), "ixz": (0, 2), "iyz": (1, 2)}
        entries = {k: self.value(inertia[i, j]) for k, (i, j) in keys.items()}
        return {k: v for k, v in entries.items() if v != 0} or {"ixx": 0}

    def value(self, x: float) -> float | int:
        """A number for the YAML: integral values as int, tiny ones (< SMALLEST) as 0."""
        x = float(x)
        if x != 0 and abs(x) < SMALLEST:
            self.flushed += 1
            return 0
        return int(x) if x.is_integer() and abs(x) < 1e15 else x

    def vector(self, v) -> list:
        return [self.value(x) for x in v]

    def description(self, root, coordinates, moving, masters) -> str:
        kinds = [(kind.word, sum(j.kind is kind for j in coordinates))
                 for kind in JOINT_TYPES.values()]
        counted = ", ".join(f"{n} {k}" for k, n in kinds if n)
        mimic = f", {len(masters)} mimic joint{'s' if len(masters) > 1 else ''}" if masters else ""
        return (f"URDF robot {root.get('name') or '?'!r} from {Path(self.source).name}: "
                f"{len(coordinates)} coordinates ({counted}){mimic}, {len(moving)} bodies")

    def header(self, base, base_links, coordinates, masters, q, joints, locks) -> list[str]:
        flags = self.options.flags()
        lines = [f"Imported by anadyn {__version__} from {Path(self.source).name} "
                 f"(`anadyn import{' ' + flags if flags else ''}`); edit freely.",
                 "URDF joint -> coordinate (revolute and continuous: rad, prismatic: m), "
                 "actuator tau_<coordinate> on it:"]
        for joint in coordinates:
            renamed = f" (URDF joint {joint.name!r})" if q[joint.name] != joint.name else ""
            lines.append(f"  {q[joint.name]}: {joint.type}{renamed}")
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


class _Names:
    """URDF names -> anadyn identifiers (letters, digits, _; a letter first; at
    most 64; not reserved), unique within their kind; coordinates, their
    rates d<q> and accelerations dd<q>, and actuators share one namespace."""

    def __init__(self):
        self.taken: set[str] = set()
        self.bodies: set[str] = set()

    @staticmethod
    def clean(name: str, prefix: str) -> str:
        text = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not text or not text[0].isalpha():
            text = prefix + text
        text = text[:60]
        return text + "_" if text in RESERVED_NAMES else text

    @staticmethod
    def unique(base: str, free) -> str:
        name, k = base, 2
        while not free(name):
            name, k = f"{base[:56]}_{k}", k + 1
        return name

    def robot(self, name: str) -> str:
        return self.clean(name, "robot_")

    def coordinate(self, name: str) -> str:
        triple = lambda n: {n, "d" + n, "dd" + n}                      # noqa: E731
        result = self.unique(self.clean(name, "q_"),
                             lambda n: not triple(n) & self.taken and IDENTIFIER.match("dd" + n))
        self.taken |= triple(result)
        return result

    def actuator(self, coordinate: str) -> str:
        result = self.unique(f"tau_{coordinate}"[:64], lambda n: n not in self.taken)
        self.taken.add(result)
        return result

    def body(self, name: str) -> str:
        result = self.unique(self.clean(name, "link_"), lambda n: n not in self.bodies)
        self.bodies.add(result)
        return result


def _angle(x: float):
    """An angle as ``k*pi/4`` text when x is that multiple of pi to the last bit, else x."""
    for k in range(-8, 9):
        if k and abs(x - k * math.pi / 4) <= 4 * np.spacing(abs(x)):
            g = math.gcd(abs(k), 4)
            num, den = k // g, 4 // g
            head = "-" if num < 0 else ""
            text = f"{head}{'' if abs(num) == 1 else f'{abs(num)}*'}pi"
            return text if den == 1 else f"{text}/{den}"
    return x


# -- YAML text ---------------------------------------------------------------------
def _format(x) -> str:
    """A number as text that Python and YAML read back as the same value (floats
    keep a '.' before an exponent, as yaml's own dumper writes them); text as is."""
    if isinstance(x, (np.floating, np.integer)):
        x = x.item()
    if isinstance(x, bool) or x is None:
        raise TypeError(x)
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        if x.is_integer() and abs(x) < 1e15:
            return str(int(x))
        text = repr(x)
        if "e" in text and "." not in text.split("e")[0]:
            mantissa, exponent = text.split("e")
            text = f"{mantissa}.0e{exponent}"
        return text
    return str(x)


#: text written plain when the dumper finds it unambiguous (names, expressions)
PLAIN_TEXT = re.compile(r"[A-Za-z0-9_.*/+-](?:[A-Za-z0-9_.*/+ -]*[A-Za-z0-9_.*/+-])?\Z")


class _Quoted(Dumper):
    """The loader's dumper with every string but names and expressions
    (PLAIN_TEXT) double-quoted: escapes, one line."""


_Quoted.add_representer(str, lambda dumper, text: dumper.represent_scalar(
    "tag:yaml.org,2002:str", text, style=None if PLAIN_TEXT.match(text) else '"'))


def _scalar(value, dumper: type = _Quoted) -> str:
    """One scalar as YAML: a number by ``_format`` (its repr), text by ``_text``."""
    if isinstance(value, str):
        return _text(value, dumper)
    return _format(value)


@functools.lru_cache(maxsize=4096)
def _text(value: str, dumper: type) -> str:
    """Text as YAML written by ``dumper``: by default double-quoted but for names
    and expressions, which are plain where the loader reads them back as the
    same text (``yes`` or ``010`` are quoted)."""
    text = yaml.dump([value], Dumper=dumper, default_flow_style=True, width=math.inf,
                     allow_unicode=True)
    return text.strip()[1:-1]


def _key(name: str) -> str:
    """A mapping key: plain when the loader reads it back as this text, else quoted."""
    return _scalar(name, Dumper)


def _flow(value) -> str:
    """A value in flow style: keys by ``_key``, scalars by ``_scalar``."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)}: {_flow(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_flow(v) for v in value) + "]"
    return _scalar(value)


def _comment(line: str, indent: str = "") -> str:
    """A comment line; line breaks and controls in ``line`` escaped (``printable``)."""
    return f"{indent}# {printable(line)}".rstrip()


def render(data: dict, header: list[str], body_comments: list[list[str]]) -> str:
    """The YAML text of ``data`` (block style, leaves in flow style), with
    ``header`` comment lines on top and each body's comment lines above it.

    Every string is written by yaml's own dumper (``_text``: free text
    double-quoted, with escapes), every key by the loader's (quoted when it
    would not read back as text), every number by its repr and every comment
    line made ``printable``, so no name or file name from the URDF can change
    the structure: the text loads back to ``data`` (tests/test_import_trust.py)."""
    out = [_comment(line) for line in header]
    for key, value in data.items():
        if key == "bodies":
            out.append("bodies:")
            for body, comment in zip(value, body_comments):
                out.extend(_comment(line, "  ") for line in comment)
                lead = "  - "
                for k, v in body.items():
                    if k == "joint":
                        out.append(f"{lead}joint:")
                        out.extend(f"      {_key(jk)}: {_flow(jv)}" for jk, jv in v.items())
                    else:
                        out.append(f"{lead}{_key(k)}: {_flow(v)}")
                    lead = "    "
        elif isinstance(value, dict):
            out.append(f"{_key(key)}:")
            out.extend(f"  {_key(k)}: {_flow(v)}" for k, v in value.items())
        else:
            out.append(f"{_key(key)}: {_flow(value)}")
    return "\n".join(out) + "\n"
