"""URDF -> an anadyn robot description (a plain dict in the YAML schema, and its text).

URDF is XML from strangers, so it is read with ``defusedxml`` (expat underneath,
with entity declarations and external references refused: no "billion laughs",
no file or network access) and capped at MAX_BYTES.  Numbers must be decimals
as written (DECIMAL: no ``1_0``, which float() reads as 10); names, however
odd, end up as identifiers, in double-quoted strings or in escaped comments,
never as YAML structure (``render``).  Every mistake is one
``ModelError`` line naming the file and the element, e.g.
``arm.urdf: joint 'elbow': <limit lower="1" upper="-1">: lower is above upper``.

The mapping, frames as in URDF (a link's frame is its joint frame after the
joint moves; the joint frame is the parent's frame moved by <origin xyz> and
turned by <origin rpy>, R = Rz(yaw) Ry(pitch) Rx(roll)), which is anadyn's own
convention, so joints carry over number for number:

- the root link, and every link fixed to it, is the base: the ``ground``;
- a revolute, continuous (a revolute without position limits) or prismatic
  joint is a body with that joint; its coordinate is named after the joint,
  and it gets one actuator ``tau_<joint>``;
- a <mimic joint="m" multiplier="k" offset="c"> joint is a body whose
  displacement is ``k*m + c`` (chains of mimics composed), with no coordinate
  and no actuator of its own;
- a link on a fixed joint is folded into the body it is fixed to: its mass,
  centre of mass and inertia are added exactly (``combine``), its name and
  pose are kept as a comment above that body in the YAML text;
- a locked joint (``lock``: joint -> value, Pinocchio's ``buildReducedModel``)
  folds its child in the same way, at the pose its joint type's ``transform``
  gives at that value; the mimics of a locked joint are locked with it;
- a link without mass between joints (URDF's ball joints: three revolute
  joints with virtual links) is a body of mass 0; a joint that moves no mass
  at all (none on its link or beyond) is refused, naming every such joint;
- <limit> -> joint ``limits: {lower, upper, velocity, effort}``;
  <dynamics damping friction> -> joint ``damping``, ``friction``;
- the child link's <inertial>: com = origin xyz, inertia = R I R^T with R
  the rotation of origin rpy (central inertia in body axes);
- gravity: 9.81 m/s^2 along -z of the root link, the URDF convention.

Floating and planar joints cannot be represented (``fix_base`` welds the one
that carries the root link to the world).  ``ReadingOptions`` gathers
``fix_base``, ``inertia`` and ``lock``; ``READING`` holds those a command reads
URDF files with, and ``link_bodies`` says where each link ends up.  Inertias that no rigid body has
(principal moments breaking I1 + I2 >= I3) are refused unless ``inertia`` is
"repair" (the nearest valid tensor, ``nearest_valid_moments``) or "accept";
both are stated in ``Imported.warnings``, never silent.
"""
from __future__ import annotations

import functools
import math
import re
import stat
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path
from types import MappingProxyType

import numpy as np

import yaml

from .. import __version__
from ..errors import ModelError, display_name, printable
from .joints import JOINT_TYPES, Fixed, JointType, Prismatic, Revolute
from .names import GROUND, IDENTIFIER, RESERVED_NAMES
from .yamlschema import Dumper

MAX_BYTES = 4 * 1024 * 1024       # expat reads this in ~0.1 s; URDFs are ~10-200 kB
GRAVITY = 9.81                    # m/s^2 along -z of the root link (URDF, ROS, Pinocchio)
#: URDF joint type -> the anadyn joint type it imports as (``model.joints``); None for the
#: joints of several degrees of freedom, which only ``fix_base`` can take (welded)
URDF_TYPES = MappingProxyType({
    Revolute.word: JOINT_TYPES[Revolute.word], "continuous": JOINT_TYPES[Revolute.word],
    Prismatic.word: JOINT_TYPES[Prismatic.word], Fixed.word: JOINT_TYPES[Fixed.word],
    "floating": None, "planar": None})
WELDED = JOINT_TYPES[Fixed.word]
INERTIA_POLICIES = ("refuse", "repair", "accept")
SMALLEST, LARGEST = 1e-30, 1e30   # anadyn's number range (model.loader); smaller -> 0
# the loader's thresholds for a valid inertia (model.loader.inertia)
PSD_TOLERANCE, TRIANGLE_TOLERANCE = 1e-12, 1e-9
XACRO = ("http://www.ros.org/wiki/xacro", "http://wiki.ros.org/xacro")
#: a URDF number as its text reads (xs:double's decimal form); Python's float()
#: would also take "1_0", "infinity" and " nan"
DECIMAL = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\Z")
Pose = tuple[np.ndarray, np.ndarray]           # (R, p): rotation and origin, parent axes


@dataclass
class Imported:
    """The robot description (``data``, anadyn's YAML schema), its YAML
    text (``text``, with comments), and what the import changed or dropped."""
    data: dict
    text: str
    warnings: list[str] = field(default_factory=list)


@dataclass
class MassProperties:
    """Mass, centre of mass and central inertia, all in one frame's axes."""
    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def moved(self, pose: Pose) -> "MassProperties":
        """The same body seen from the frame in which ``pose`` = (R, p) places
        this one: com' = p + R com, I' = R I R^T (a central inertia turns,
        it is not shifted)."""
        R, p = pose
        return MassProperties(self.mass, p + R @ self.com, R @ self.inertia @ R.T)


def combine(parts: list[MassProperties]) -> MassProperties:
    """Rigid union of bodies given in one frame (parallel-axis theorem):

        m = sum m_i,   c = sum m_i c_i / m,
        I = sum [ I_i + m_i (|d_i|^2 E - d_i d_i^T) ],   d_i = c_i - c.
    """
    parts = [p for p in parts if p.mass > 0 or np.any(p.inertia)]
    mass = sum(p.mass for p in parts)
    if mass <= 0:
        return MassProperties(0.0, np.zeros(3), sum((p.inertia for p in parts), np.zeros((3, 3))))
    if len(parts) == 1:
        return parts[0]
    com = sum(p.mass * p.com for p in parts) / mass
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.com - com
        inertia += p.inertia + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return MassProperties(mass, com, inertia)


def rpy_matrix(rpy) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) (URDF)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p),
                              math.cos(y), math.sin(y))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def matrix_rpy(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw with rpy_matrix(rpy) = R (pitch in [-pi/2, pi/2]; at
    pitch = +-pi/2, where only roll -+ yaw is defined, yaw = 0)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[2, 1], R[2, 2]))
    if math.hypot(R[0, 0], R[1, 0]) > 1e-12:
        return np.array([math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])])
    sign = 1.0 if R[2, 0] < 0 else -1.0
    return np.array([math.atan2(sign * R[0, 1], R[1, 1]), pitch, 0.0])


def compose(a: Pose, b: Pose) -> Pose:
    """Pose b (given in frame a's axes) seen from a's parent: (Ra Rb, pa + Ra pb)."""
    return a[0] @ b[0], a[1] + a[0] @ b[1]


IDENTITY: Pose = (np.eye(3), np.zeros(3))


def inertia_problem(moments) -> str | None:
    """Why principal moments a <= b <= c belong to no rigid body (None if they do):
    not positive semidefinite (a < 0), or a + b < c (triangle inequality).
    Thresholds are the YAML loader's, so what passes here loads there."""
    a, b, c = moments
    scale = max(1.0, abs(a), abs(c))
    if a < -PSD_TOLERANCE * scale:
        return "is not positive semidefinite"
    if a + b < c - TRIANGLE_TOLERANCE * scale:
        return "breaks the triangle inequality I1 + I2 >= I3"
    return None


def nearest_valid_moments(moments) -> np.ndarray:
    """The principal moments closest (Euclidean) to ``moments`` that satisfy
    l_i + l_j >= l_k for every ordering (which implies l >= 0).

    The set of valid inertia tensors depends on the eigenvalues only, so the
    nearest valid tensor in the Frobenius norm keeps the eigenvectors and
    projects the eigenvalues; the projection onto this polyhedral cone is
    found by trying every set of active constraints (3 constraints, 8 sets)
    and keeping the nearest feasible candidate.
    """
    x = np.asarray(moments, dtype=float)
    normals = np.array([[1, 1, -1], [1, -1, 1], [-1, 1, 1]], dtype=float)
    best, distance = None, math.inf
    for k in range(4):
        for active in combinations(range(3), k):
            N = normals[list(active)]
            y = x - N.T @ np.linalg.solve(N @ N.T, N @ x) if k else x
            if (normals @ y >= -1e-15 * max(1.0, np.abs(y).max())).all():
                d = float(np.linalg.norm(y - x))
                if d < distance:
                    best, distance = y, d
    return np.maximum(best, 0.0)


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
        from .massmatrix import _rotation

        R, origin = self.pose
        axis = self.axis / np.linalg.norm(self.axis)
        return self.kind.transform(R, origin, axis, displacement, _rotation)


#: YAML text an import in this process produced -> the URDF place of its key
#: paths (the last few imports), for ``place``
_PLACES: dict[str, dict[str, str]] = {}


def place(text: str, path: str | None) -> str | None:
    """Where in the URDF the key ``path`` of the robot ``text`` comes from, e.g.
    ``joint 'elbow' (child link 'forearm')`` for ``bodies[2].mass``, when an
    import in this process produced ``text``; None otherwise."""
    places = _PLACES.get(text)
    if places is None:
        return None
    path = path or ""
    while path and path not in places:        # bodies[2].joint.axis -> bodies[2] -> ""
        shorter = re.sub(r"(\.[^.\[]*|\[\d+\])$", "", path)
        path = shorter if shorter != path else ""
    return places[path]


def read_urdf(path: str | Path) -> bytes:
    """The file's bytes; ModelError if it is missing, not a regular file or over MAX_BYTES."""
    path = Path(path)
    name = display_name(path)
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise ModelError("is not a regular file, expected a URDF file", source=name)
        if info.st_size > MAX_BYTES:
            raise ModelError(f"file is {info.st_size} bytes, the limit for URDF is {MAX_BYTES}",
                             source=name)
        with path.open("rb") as stream:
            raw = stream.read(MAX_BYTES + 1)
    except FileNotFoundError:
        raise ModelError("no such file", source=name) from None
    except OSError as err:
        raise ModelError(f"cannot read: {err.strerror}", source=name) from None
    if len(raw) > MAX_BYTES:
        raise ModelError(f"file is over {MAX_BYTES} bytes, the limit for URDF", source=name)
    return raw


@dataclass(frozen=True)
class ReadingOptions:
    """How a URDF is read (the flags of the same names): ``fix_base`` welds the
    floating or planar joint that carries the root link; ``inertia`` is the policy
    for impossible inertias (INERTIA_POLICIES); ``lock`` is ((joint, value), ...),
    the joints held at a value (a number, or its text: ``0.5``, ``pi/4``)."""
    fix_base: bool = False
    inertia: str = "refuse"
    lock: tuple[tuple[str, float | str], ...] = ()

    def flags(self) -> str:
        """The options as command-line flags ('' for the defaults)."""
        words = (["--fix-base"] if self.fix_base else []) + (
            [f"--inertia {self.inertia}"] if self.inertia != "refuse" else [])
        return " ".join(words + [f"--lock {name}={value}" for name, value in self.lock])


#: the options that ``yamlsource.read_text`` and ``link_bodies`` read a URDF with; a
#: command sets them for its run (``reading``, from ``commands.common``)
READING: ContextVar[ReadingOptions] = ContextVar("urdf_reading", default=ReadingOptions())


@contextmanager
def reading(options: ReadingOptions):
    """Read URDF files with ``options`` inside the block (``READING``)."""
    token = READING.set(options)
    try:
        yield options
    finally:
        READING.reset(token)


def parse_lock(option: str) -> tuple[str, str]:
    """``JOINT=VALUE`` of a ``--lock`` -> (joint, value text); ModelError if malformed."""
    name, equals, value = option.partition("=")
    if not equals or not name.strip() or not value.strip():
        raise ModelError(f"--lock {option!r}: expected JOINT=VALUE, e.g. --lock elbow=pi/4 "
                         "(rad for a revolute joint, m for a prismatic one)")
    return name.strip(), value.strip()


def import_file(path: str | Path, fix_base: bool = False, inertia: str = "refuse",
                lock=()) -> Imported:
    """Read and import the URDF file at ``path`` (named by ``display_name``)."""
    return import_urdf(read_urdf(path), display_name(path), fix_base=fix_base,
                       inertia=inertia, lock=lock)


def import_urdf(raw: bytes | str, source: str, fix_base: bool = False,
                inertia: str = "refuse", lock=()) -> Imported:
    """Import URDF text; ``source`` names it in messages and (its file name) in the
    header.  ``lock``: {joint: value} or ((joint, value), ...), the joints held at a
    value (number or expression text, e.g. ``pi/4``): a reduced robot, as
    Pinocchio's ``buildReducedModel`` makes it (ReadingOptions)."""
    options = ReadingOptions(fix_base, inertia, tuple(dict(lock).items()))
    return _Importer(source, options).run(_parsed(raw, source, options))


def link_bodies(path: str | Path, options: ReadingOptions | None = None) -> "LinkBodies":
    """Where each link of the URDF file at ``path`` ends up in the robot that
    ``import_file`` makes of it with ``options`` (default: the current ``READING``)."""
    options = READING.get() if options is None else options
    source = display_name(path)
    root = _parsed(read_urdf(path), source, options)
    importer = _Importer(source, options)
    links, joints, base = importer.tree(root)
    order = importer.tree_order(base, joints)
    locks = importer.locks(joints, importer.resolve_mimics(joints))
    owner, pose, _, moving = importer.placement(base, order, locks)
    index = {joint.child: k for k, joint in enumerate(moving)}
    return LinkBodies(root, {name: (index.get(owner[name], -1), pose[name]) for name in owner},
                      importer)


@dataclass
class LinkBodies:
    """``link_bodies``: the parsed ``<robot>`` element; ``places``, link name ->
    (index of the body it belongs to in the robot's bodies, -1 for the ground; the
    link's frame in that body's frame as (R, p)); ``reader``, whose ``numbers``,
    ``number`` and ``origin`` read more of the file as the importer does."""
    root: object
    places: dict[str, tuple[int, Pose]]
    reader: "_Importer"


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
    import defusedxml
    from defusedxml import ElementTree

    try:
        root = ElementTree.fromstring(raw, forbid_dtd=False, forbid_entities=True,
                                      forbid_external=True)
    except ElementTree.ParseError as err:
        line, column = getattr(err, "position", (None, None))
        reason = str(err).split(":")[0]
        raise ModelError(f"not well-formed XML: {reason} (column {column})", source=source,
                         line=line) from None
    except defusedxml.EntitiesForbidden:
        raise ModelError("XML entity declarations are refused (entity expansion is a "
                         "classic attack and no URDF needs it)", source=source) from None
    except defusedxml.DefusedXmlException as err:
        raise ModelError(f"refused XML: {type(err).__name__} (external references and "
                         "entities are not read)", source=source) from None
    if root.tag != "robot":
        raise ModelError(f"the root element is <{root.tag}>, expected <robot>: not a URDF file",
                         source=source)
    for element in root.iter():
        if isinstance(element.tag, str) and element.tag.startswith(tuple(f"{{{x}}}" for x in XACRO)):
            raise ModelError("a xacro file (it has <xacro:...> elements): expand it first, "
                             "e.g. `xacro FILE.urdf.xacro > FILE.urdf`", source=source)
    return root


class _Importer:
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

    # -- notes --------------------------------------------------------------------
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

    # -- the tree -----------------------------------------------------------------
    def run(self, root) -> Imported:
        links, joints, base = self.tree(root)
        order = self.tree_order(base, joints)
        masters = self.resolve_mimics(joints)
        return self.build(root, base, order, links, joints, masters,
                          self.locks(joints, masters))

    def tree(self, root) -> tuple[dict[str, _Link], dict[str, _Joint], str]:
        """The links and joints of the file and its root link (floating and planar
        joints welded or refused: ``free_joints``)."""
        links: dict[str, _Link] = {}
        for i, element in enumerate(root.findall("link")):
            link = self.link(element, i)
            if link.name in links:
                raise self.error(f"link {link.name!r}", "defined twice")
            links[link.name] = link
        if not links:
            raise self.error(None, "no <link> elements: nothing to import")
        joints: dict[str, _Joint] = {}
        parent_joint: dict[str, _Joint] = {}
        for i, element in enumerate(root.findall("joint")):
            joint = self.joint(element, links, i)
            if joint.name in joints:
                raise self.error(f"joint {joint.name!r}", "defined twice")
            if joint.child in parent_joint:
                raise self.error(f"link {joint.child!r}",
                                 f"child of two joints, {parent_joint[joint.child].name!r} and "
                                 f"{joint.name!r}: a closed loop (anadyn's robots are trees)")
            joints[joint.name] = joint
            parent_joint[joint.child] = joint
        base = self.root(links, joints, parent_joint)
        self.free_joints(joints, base)
        return links, joints, base

    def root(self, links, joints, parent_joint) -> str:
        roots = [name for name in links if name not in parent_joint]
        if not roots:
            raise self.error(None, "no root link: every link is the child of a joint, so the "
                                   f"joints form a cycle ({_listed(joints)})")
        if len(roots) > 1:
            raise self.error(None, f"{len(roots)} root links ({_listed(roots)}): links that no "
                                   "joint has as child; a robot must be one tree joined by joints")
        return roots[0]

    def free_joints(self, joints: dict[str, _Joint], base: str) -> None:
        """Floating and planar joints: the one that carries the root link welded by
        fix_base, every other refused."""
        carrying = [j.name for j in joints.values() if j.kind is None and j.parent == base]
        if self.fix_base and not carrying:
            self.warnings.append(f"{self.source}: --fix-base: no floating or planar joint "
                                 f"carries the root link {base!r}; nothing welded (the root "
                                 "link is fixed to the world in every import)")
        for joint in joints.values():
            if joint.kind is not None:
                continue
            where = f"joint {joint.name!r}"
            if self.fix_base and len(carrying) > 1 and joint.parent == base:
                raise self.error(where, f"--fix-base welds the one joint that carries the root "
                                        f"link; {base!r} carries {len(carrying)} floating or "
                                        f"planar joints ({_listed(carrying)})")
            if joint.parent == base and self.fix_base:
                self.warnings.append(f"{self.source}: {where}: {joint.type} joint of the base "
                                     f"welded: link {joint.child!r} fixed to {base!r} where "
                                     "the joint's origin puts it (--fix-base)")
                joint.kind = WELDED
                continue
            hint = (f"; to simulate the robot on a fixed base, import it with --fix-base "
                    f"(welds link {joint.child!r} to {base!r} where the joint's origin puts it)"
                    if joint.parent == base else
                    "; anadyn's joints are revolute, prismatic and fixed")
            raise self.error(where, f"{joint.type} joints (several degrees of freedom in one "
                                    f"joint) cannot be imported{hint}")

    def tree_order(self, base: str, joints) -> list[_Joint]:
        """Joints from the root out, depth first, children in file order; cycles refused."""
        children: dict[str, list[_Joint]] = {}
        for joint in joints.values():
            children.setdefault(joint.parent, []).append(joint)
        order: list[_Joint] = []
        stack = list(reversed(children.get(base, [])))
        while stack:
            joint = stack.pop()
            order.append(joint)
            stack.extend(reversed(children.get(joint.child, [])))
        if len(order) < len(joints):
            reached = {j.name for j in order}
            loop = [name for name in joints if name not in reached]
            raise self.error(f"joint {loop[0]!r}", f"joints {_listed(loop)} form a cycle not "
                                                   f"connected to the root link {base!r}")
        return order

    def resolve_mimics(self, joints: dict[str, _Joint]) -> dict[str, tuple[str, float, float]]:
        """Mimic joint -> (independent joint, multiplier, offset), chains composed:
        theta_j = k_j theta_m + c_j with theta_m = k_m theta_i + c_m gives
        theta_j = k_j k_m theta_i + (k_j c_m + c_j)."""
        result = {}
        for joint in joints.values():
            if joint.mimic is None or not joint.moving:
                continue
            where = f"joint {joint.name!r}"
            master, k, c = joint.mimic
            seen = [joint.name]
            while True:
                if master not in joints:
                    raise self.error(where, f'<mimic joint="{master}">: no such joint')
                other = joints[master]
                if not other.moving:
                    raise self.error(where, f'<mimic joint="{master}">: that joint is '
                                            f"{other.type}; it must move")
                if master in seen:
                    raise self.error(where, f"mimic joints {', '.join(map(repr, seen))} mimic "
                                            "each other in a cycle")
                if other.mimic is None:
                    break
                seen.append(master)
                master, k, c = other.mimic[0], k * other.mimic[1], k * other.mimic[2] + c
            if k == 0:
                raise self.error(where, "<mimic multiplier=\"0\">: the joint would not move; "
                                        "make it fixed")
            result[joint.name] = (master, k, c)
        return result

    def locks(self, joints: dict[str, _Joint], masters) -> dict[str, float]:
        """Joint -> the displacement it is held at: each ``--lock`` joint (a moving
        joint, not a mimic, within its limits) and the mimics of a locked joint."""
        result: dict[str, float] = {}
        for name, given in self.options.lock:
            shown = f"--lock {name}={given}"
            joint = joints.get(name)
            if joint is None or not joint.moving:
                movable = [j.name for j in joints.values() if j.moving and j.name not in masters]
                what = "no such joint" if joint is None else f"joint {name!r} is {joint.type}"
                raise self.error(None, f"{shown}: {what}; the joints that can be locked are "
                                       f"{_listed(movable, 8)}")
            where = f"joint {name!r}"
            if name in masters:
                raise self.error(where, f"{shown}: the joint mimics {masters[name][0]!r}; lock "
                                        "that joint (its mimics follow it)")
            if name in result:
                raise self.error(where, f"{shown}: the joint is locked twice")
            try:
                value = _lock_value(given, shown)
            except ModelError as err:
                raise self.error(where, err.reason) from None
            lower, upper = joint.limit.get("lower"), joint.limit.get("upper")
            if lower is not None and not lower <= value <= upper:
                raise self.error(where, f"{shown}: {value:.6g} is outside the joint's <limit> "
                                        f"[{lower:g}, {upper:g}]")
            result[name] = value
        for name, (master, k, c) in masters.items():
            if master in result:
                result[name] = k * result[master] + c
        return result

    # -- the robot ------------------------------------------------------------------
    def placement(self, base: str, order: list[_Joint], locks: dict[str, float]):
        """(owner, pose, folded, moving): link -> the link whose body it belongs to
        (the child of a moving joint) or GROUND; link -> its frame in that body's
        axes; body -> [(link, joint)] folded into it; the moving joints (the bodies)
        in tree order.  A fixed or locked joint folds its child into its parent's
        body, a locked one at its displacement."""
        owner = {base: GROUND}
        pose = {base: IDENTITY}
        folded: dict[str, list[tuple[str, _Joint]]] = {GROUND: []}
        moving: list[_Joint] = []
        for joint in order:
            if joint.moving and joint.name not in locks:
                owner[joint.child] = joint.child
                pose[joint.child] = IDENTITY
                folded[joint.child] = []
                moving.append(joint)
                continue
            owner[joint.child] = owner[joint.parent]
            relative = joint.moved(locks[joint.name]) if joint.name in locks else joint.pose
            pose[joint.child] = compose(pose[joint.parent], relative)
            folded[owner[joint.child]].append((joint.child, joint))
        return owner, pose, folded, moving

    def motionless(self, moving: list[_Joint], owner, folded, links) -> list[_Joint]:
        """The moving joints that move nothing: no link on their body or beyond it
        has mass (anadyn's moving bodies have mass, but for a massless body that
        carries others); their speeds would leave M singular.  A massless link
        between joints (URDF's ball joints written as three revolute joints with
        virtual links) moves the massive links beyond it: that is fine."""
        heavy = {j.child: any(links[name].inertial is not None and links[name].inertial.mass > 0
                              for name, _ in [(j.child, None)] + folded[j.child])
                 for j in moving}
        for joint in reversed(moving):           # children before parents
            parent = owner[joint.parent]
            if parent != GROUND:
                heavy[parent] = heavy[parent] or heavy[joint.child]
        return [j for j in moving if not heavy[j.child]]

    def build(self, root, base, order, links, joints, masters, locks) -> Imported:
        owner, pose, folded, moving = self.placement(base, order, locks)
        masters = {name: m for name, m in masters.items() if name not in locks}
        if not moving:
            raise self.error(None, "nothing moves: the URDF has no revolute, continuous or "
                                   "prismatic joint" + (" that is not locked" if locks else ""))
        idle = self.motionless(moving, owner, folded, links)
        if idle:
            one = len(idle) == 1
            lockable = [j for j in idle if j.name not in masters]
            fix = " ".join(f"--lock {j.name}={_format(self.initial(j))}" for j in lockable[:4])
            raise self.error(None, (
                f"joint {idle[0].name!r} moves nothing" if one else
                f"joints {_listed([j.name for j in idle], 8)} move nothing") + (
                f": no link {'it moves' if one else 'they move'} (link "
                f"{idle[0].child!r} and beyond) has mass, so the mass matrix would be "
                f"singular; give one of those links an <inertial> with a "
                f"positive <mass>, or lock {'it' if one else 'them'}") + (
                f" ({fix}{' ...' if len(lockable) > 4 else ''})" if lockable else ""))
        names = _Names()
        robot_name = names.robot(Path(self.source).stem)     # results/NAME, as for YAML
        coordinates = [j for j in moving if j.name not in masters]
        q = {j.name: names.coordinate(j.name) for j in coordinates}
        body_name = {j.child: names.body(j.child) for j in moving}
        bodies, comments = [], []
        for joint in moving:
            parts = [(joint.child, None)] + folded[joint.child]
            bodies.append(self.body(joint, owner, pose, parts, links, body_name, q, masters))
            comments.append(self.body_comment(joint, parts, pose, body_name))
        tau = {j.name: names.actuator(q[j.name]) for j in coordinates}
        data = {
            "name": robot_name,
            "description": self.description(root, coordinates, moving, masters),
            "gravity": [0, 0, -GRAVITY],
            "coordinates": {q[j.name]: {"initial": self.initial(j)} for j in coordinates},
            "bodies": bodies,
            "actuators": {tau[j.name]: {"joint": body_name[j.child]} for j in coordinates},
        }
        places = {"": f"<robot name={root.get('name')!r}>",
                  "name": f"the file name {Path(self.source).name!r}",
                  **{f"bodies[{i}]": f"joint {j.name!r} (child link {j.child!r})"
                     for i, j in enumerate(moving)},
                  **{f"coordinates.{q[j.name]}": f"joint {j.name!r}" for j in coordinates},
                  **{f"actuators.{tau[j.name]}": f"joint {j.name!r}" for j in coordinates}}
        self.collect_notes()
        header = self.header(base, folded[GROUND], coordinates, masters, q, joints, locks)
        footer = self.trajectory_hint(coordinates[0], q[coordinates[0].name])
        text = render(data, header, comments) + footer
        _PLACES[text] = places
        while len(_PLACES) > 8:
            del _PLACES[next(iter(_PLACES))]
        return Imported(data, text, self.warnings)

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

    def checked_inertial(self, link: _Link, where: str) -> MassProperties:
        """The link's mass properties after the inertia policy (refuse, repair, accept)."""
        problem = inertia_problem(link.moments)
        if problem is None:
            return link.inertial
        a, b, c = link.moments
        shown = f"principal moments {a:.6g}, {b:.6g}, {c:.6g} kg m^2"
        if self.policy == "refuse" or (self.policy == "accept" and problem.startswith("is not")):
            options = ("--inertia repair replaces it by the nearest valid one"
                       if problem.startswith("is not") else
                       "--inertia repair replaces it by the nearest valid one, --inertia accept "
                       "keeps it")
            raise self.error(f"link {link.name!r}",
                             f"<inertia>: {shown}: {problem}; no rigid body has this inertia "
                             f"(import with {options}, with a warning)")
        if self.policy == "accept":
            link.accepted = True
            self.warnings.append(f"{self.source}: link {link.name!r}: <inertia> with {shown} "
                                 f"{problem}; kept as given (--inertia accept)")
            return link.inertial
        fixed = nearest_valid_moments(link.moments)
        R = _principal_axes(link)
        repaired = R @ np.diag(fixed) @ R.T
        change = float(np.linalg.norm(repaired - link.inertial.inertia))
        self.warnings.append(
            f"{self.source}: link {link.name!r}: <inertia> with {shown} {problem}; repaired to "
            f"the nearest valid inertia, principal moments {', '.join(f'{m:.6g}' for m in fixed)}"
            f" (changed by {change:.3g} kg m^2, {change / max(abs(c), 1e-300):.2%} of the "
            "largest moment; --inertia repair)")
        return MassProperties(link.inertial.mass, link.inertial.com, repaired)

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

    # -- comments -------------------------------------------------------------------
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


def _python_float(word: str) -> bool:
    """Whether Python's float() reads ``word`` (which DECIMAL refuses, e.g. 1_0)."""
    try:
        float(word)
    except ValueError:
        return False
    return True


def _lock_value(value: float | str, shown: str) -> float:
    """A --lock value: a number, or an expression of numbers and pi (``pi/4``) read by
    ``expressions.parse`` and evaluated in double precision by ``approximate`` (no
    names, never run as code); finite and real."""
    from . import expressions

    try:
        number = expressions.approximate(expressions.parse(value, {}))
    except expressions.ExpressionError as err:
        raise ModelError(f"{shown}: {err}") from None
    if number.imag != 0 or not math.isfinite(number.real):
        raise ModelError(f"{shown}: {value!r} is not a finite real number")
    return number.real


def _listed(names, most: int = 5) -> str:
    """'a', 'b', 'c', ... (at most ``most`` names shown)."""
    names = list(names)
    return ", ".join(map(repr, names[:most])) + (", ..." if len(names) > most else "")


def _snap(values: np.ndarray, scale: float | None = None) -> np.ndarray:
    """Computed values with the round-off residue of exact zeros (below 4 ulp of
    ``scale``, default the largest entry) set to 0, e.g. cos(pi/2) = 6e-17."""
    values = np.asarray(values, dtype=float)
    scale = np.abs(values).max(initial=0.0) if scale is None else scale
    return np.where(np.abs(values) <= 4 * np.spacing(scale), 0.0, values)


def _principal_axes(link: _Link) -> np.ndarray:
    """Eigenvectors of the link's inertia in body axes, in the order of link.moments."""
    _, vectors = np.linalg.eigh(link.inertial.inertia)
    return vectors


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
