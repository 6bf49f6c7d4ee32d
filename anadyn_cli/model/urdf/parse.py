"""Reading URDF XML: the file (capped at MAX_BYTES), defusedxml's parse (no
entities, no external references, no xacro) and ``_Reader``, which reads the
<link> and <joint> elements, their numbers as written (DECIMAL), into ``_Link``
and ``_Joint``."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from ...errors import ModelError, display_name
from ..importing import parse_xml, read_capped
from ..joints import JOINT_TYPES, Fixed, JointType, Prismatic, Revolute
from .frames import Pose, rpy_matrix
from .inertia import MassProperties
from .options import INERTIA_POLICIES, ReadingOptions

MAX_BYTES = 4 * 1024 * 1024       # expat reads this in ~0.1 s; URDFs are ~10-200 kB
#: URDF joint type -> the anadyn joint type it imports as (``model.joints``); None for the
#: joints of several degrees of freedom, which only ``fix_base`` can take (welded)
URDF_TYPES = MappingProxyType({
    Revolute.word: JOINT_TYPES[Revolute.word], "continuous": JOINT_TYPES[Revolute.word],
    Prismatic.word: JOINT_TYPES[Prismatic.word], Fixed.word: JOINT_TYPES[Fixed.word],
    "floating": None, "planar": None})
WELDED = JOINT_TYPES[Fixed.word]
LARGEST = 1e30                    # anadyn's number range (model.loader; robottext.SMALLEST)
XACRO = ("http://www.ros.org/wiki/xacro", "http://wiki.ros.org/xacro")
#: a URDF number as its text reads (xs:double's decimal form); Python's float()
#: would also take "1_0", "infinity" and " nan"
DECIMAL = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\Z")


@dataclass
class _Link:
    name: str
    inertial: MassProperties | None       # in link axes
    moments: np.ndarray | None            # principal moments as given (before any repair)
    accepted: bool = False                # an impossible inertia kept (--inertia accept)


@dataclass
class _Joint:
    name: str
    type: str                             # the URDF word
    kind: JointType | None                # what it imports as (URDF_TYPES; WELDED by fix_base)
    parent: str
    child: str
    origin: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    limit: dict                           # lower, upper, velocity, effort (those given)
    dynamics: dict                        # damping, friction (those given, non-zero)
    mimic: tuple[str, float, float] | None

    @property
    def pose(self) -> Pose:
        return rpy_matrix(self.rpy), self.origin

    @property
    def moving(self) -> bool:
        """Whether the joint adds a displacement (revolute, continuous, prismatic)."""
        return self.kind is not None and self.kind.moving

    def moved(self, displacement: float) -> Pose:
        """The child link's frame in the parent's at this displacement (the joint
        type's ``transform``, the axis made unit as the loader makes it)."""
        from ..massmatrix import _rotation

        R, origin = self.pose
        axis = self.axis / np.linalg.norm(self.axis)
        return self.kind.transform(R, origin, axis, displacement, _rotation)


def read_urdf(path: str | Path) -> bytes:
    """The file's bytes; ModelError if it is missing, not a regular file or over MAX_BYTES."""
    return read_capped(Path(path), display_name(path), MAX_BYTES, "URDF", "a URDF file")


def _parsed(raw: bytes | str, source: str, options: ReadingOptions):
    if options.inertia not in INERTIA_POLICIES:
        raise ModelError(f"--inertia must be one of {', '.join(INERTIA_POLICIES)}, "
                         f"got {options.inertia!r}")
    if isinstance(raw, str):
        raw = raw.encode("utf-8")
    if len(raw) > MAX_BYTES:
        raise ModelError(f"text is over {MAX_BYTES} bytes, the limit for URDF", source=source)
    return _parse_xml(raw, source)


def _parse_xml(raw: bytes, source: str):
    root = parse_xml(raw, source, "URDF")
    if root.tag != "robot":
        raise ModelError(f"the root element is <{root.tag}>, expected <robot>: not a URDF file",
                         source=source)
    for element in root.iter():
        if isinstance(element.tag, str) and element.tag.startswith(tuple(f"{{{x}}}" for x in XACRO)):
            raise ModelError("a xacro file (it has <xacro:...> elements): expand it first, "
                             "e.g. `xacro FILE.urdf.xacro > FILE.urdf`", source=source)
    return root


class _Reader:
    """Reads the elements of one URDF (``source`` in messages) into ``_Link`` and
    ``_Joint``; the state the importer collects (warnings, placeholders, numbers
    flushed to 0) starts here."""

    def __init__(self, source: str, options: ReadingOptions):
        self.source, self.options = source, options
        self.fix_base, self.policy = options.fix_base, options.inertia
        self.warnings: list[str] = []
        self.placeholders: dict[str, list[str]] = {}   # joint -> <limit> values ignored
        self.flushed = 0                      # numbers below SMALLEST written as 0

    def error(self, where: str | None, message: str) -> ModelError:
        return ModelError(message, source=self.source, path=where)

    # -- reading elements -------------------------------------------------------
    def numbers(self, element, attribute: str, count: int, where: str,
                default: str | None = None) -> np.ndarray:
        text = element.get(attribute, default) if element is not None else default
        shown = f'<{element.tag if element is not None else "?"} {attribute}="{text}">'
        if text is None:
            raise self.error(where, f"<{element.tag}> needs the attribute {attribute}")
        if "${" in text or "$(" in text:
            raise self.error(where, f"{shown}: an unexpanded xacro expression; expand the "
                                    "file with xacro first")
        words = text.split()
        if any(word.lower().lstrip("+-") in ("inf", "infinity", "nan") for word in words):
            raise self.error(where, f"{shown}: numbers must be finite")
        odd = next((word for word in words if not DECIMAL.match(word)), None)
        if odd is not None:
            plural = "s" if count > 1 else ""
            raise self.error(where, f"{shown}: expected {count} number{plural}" + (
                f"; {odd!r} is not a decimal number such as -1.5e-3 (digits, a point, an "
                "exponent: no underscores)" if _python_float(odd) else ""))
        values = [float(word) for word in words]
        if len(values) != count:
            raise self.error(where, f"{shown}: expected {count} number{'s' if count > 1 else ''}"
                                    f", got {len(values)}")
        if not all(math.isfinite(v) for v in values):        # e.g. 1e999
            raise self.error(where, f"{shown}: numbers must be finite")
        if any(abs(v) > LARGEST for v in values):
            raise self.error(where, f"{shown}: out of range (at most {LARGEST:g} in size, "
                                    "SI units)")
        return np.array(values)

    def number(self, element, attribute: str, where: str, default: str | None = None) -> float:
        return float(self.numbers(element, attribute, 1, where, default)[0])

    def origin(self, parent, where: str) -> tuple[np.ndarray, np.ndarray]:
        element = parent.find("origin")
        if element is None:
            return np.zeros(3), np.zeros(3)
        return (self.numbers(element, "xyz", 3, where, "0 0 0"),
                self.numbers(element, "rpy", 3, where, "0 0 0"))

    def link(self, element, index: int) -> _Link:
        name = element.get("name")
        if not name:
            raise self.error(None, f"<link> number {index + 1} has no name")
        where = f"link {name!r}"
        inertial = element.find("inertial")
        if inertial is None:
            return _Link(name, None, None)
        mass_element = inertial.find("mass")
        if mass_element is None:
            raise self.error(where, "<inertial> has no <mass>")
        mass = self.number(mass_element, "value", where)
        if mass < 0:
            raise self.error(where, f'<mass value="{mass_element.get("value")}">: a mass '
                                    "cannot be negative")
        xyz, rpy = self.origin(inertial, where)
        tensor = inertial.find("inertia")
        values = {k: self.number(tensor, k, where, "0") if tensor is not None else 0.0
                  for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
        inertia = np.array([[values["ixx"], values["ixy"], values["ixz"]],
                            [values["ixy"], values["iyy"], values["iyz"]],
                            [values["ixz"], values["iyz"], values["izz"]]])
        moments = np.linalg.eigvalsh(inertia)
        central = MassProperties(mass, np.zeros(3), inertia).moved((rpy_matrix(rpy), xyz)) \
            if rpy.any() else MassProperties(mass, xyz, inertia)
        return _Link(name, central, moments)

    def joint(self, element, links: dict[str, _Link], index: int) -> _Joint:
        name = element.get("name")
        if not name:
            raise self.error(None, f"<joint> number {index + 1} has no name")
        where = f"joint {name!r}"
        kind = element.get("type")
        if kind not in URDF_TYPES:
            *words, last = URDF_TYPES
            raise self.error(where, f"type {kind!r} is not a URDF joint type; expected "
                                    f"{', '.join(words)} or {last}")
        ends = {}
        for end in ("parent", "child"):
            tag = element.find(end)
            if tag is None or not tag.get("link"):
                raise self.error(where, f'missing <{end} link="...">')
            if tag.get("link") not in links:
                raise self.error(where, f'<{end} link="{tag.get("link")}">: no such link')
            ends[end] = tag.get("link")
        if ends["parent"] == ends["child"]:
            raise self.error(where, f"link {ends['child']!r} is its own parent")
        xyz, rpy = self.origin(element, where)
        axis = self.numbers(element.find("axis"), "xyz", 3, where, "1 0 0")
        moving = URDF_TYPES[kind] is not None and URDF_TYPES[kind].moving
        if moving and not np.linalg.norm(axis) > 1e-12:
            raise self.error(where, f'<axis xyz="{element.find("axis").get("xyz")}">: the axis '
                                    "of a moving joint cannot be zero")
        return _Joint(name, kind, URDF_TYPES[kind], ends["parent"], ends["child"], xyz, rpy,
                      axis, self.limit(element, kind, moving, where),
                      self.dynamics(element, where), self.mimic(element, where))

    def limit(self, element, kind: str, moving: bool, where: str) -> dict:
        tag = element.find("limit")
        if tag is None or not moving:
            return {}
        limit = {}
        for key in ("velocity", "effort"):
            value = self.nonnegative(tag, key, where)
            if value:
                limit[key] = value
            elif value == 0:
                self.placeholders.setdefault(where, []).append(f"{key} 0")
        if kind != "continuous" and (tag.get("lower") is not None or tag.get("upper") is not None):
            lower, upper = (self.number(tag, k, where, "0") for k in ("lower", "upper"))
            if lower > upper:
                raise self.error(where, f'<limit lower="{tag.get("lower")}" upper='
                                        f'"{tag.get("upper")}">: lower is above upper')
            if lower < upper:
                limit.update(lower=lower, upper=upper)
            else:
                self.placeholders.setdefault(where, []).append("lower = upper")
        return limit

    def dynamics(self, element, where: str) -> dict:
        tag = element.find("dynamics")
        values = {key: self.nonnegative(tag, key, where) for key in ("damping", "friction")}
        return {key: value for key, value in values.items() if value}

    def nonnegative(self, tag, key: str, where: str) -> float | None:
        """The attribute's number (None when absent); a negative one is refused."""
        if tag is None or tag.get(key) is None:
            return None
        value = self.number(tag, key, where)
        if value < 0:
            raise self.error(where, f'<{tag.tag} {key}="{tag.get(key)}">: cannot be negative')
        return value

    def mimic(self, element, where: str) -> tuple[str, float, float] | None:
        tag = element.find("mimic")
        if tag is None:
            return None
        if not tag.get("joint"):
            raise self.error(where, '<mimic> needs joint="..."')
        return (tag.get("joint"), self.number(tag, "multiplier", where, "1"),
                self.number(tag, "offset", where, "0"))


def _python_float(word: str) -> bool:
    """Whether Python's float() reads ``word`` (which DECIMAL refuses, e.g. 1_0)."""
    try:
        float(word)
    except ValueError:
        return False
    return True
