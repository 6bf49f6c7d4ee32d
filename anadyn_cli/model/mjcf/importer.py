"""The MJCF import: ``import_file`` reads the model (``source``), walks the body
tree (``_Importer``: joints, mass properties, armature rotors, actuators) and
writes the robot as YAML text through the imports' safe writer
(``robottext.render``)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import __version__
from ...errors import ModelError, display_name
from ..joints import Floating, Prismatic, Revolute, Spherical
from ..names import ANGULAR, GROUND, QUATERNION
from ..robottext import SMALLEST, Numbers, _angle, _format, _Names, render
from ..urdf.frames import _snap, compose, matrix_rpy
from ..urdf.importer import Imported
from ..urdf.inertia import MassProperties, combine, inertia_problem
from . import equality, frames, inertia, source
from .actuators import Actuators
from .geoms import GEOM_TYPES, ContactGeoms
from .loops import Loops
from .source import _Reader

#: MJCF joint types anadyn represents -> its joint type word (``model.joints``)
JOINTS = {"hinge": Revolute.word, "slide": Prismatic.word}
#: the MJCF joints of several coordinates (``several_joint``)
SEVERAL = ("ball", "free")
#: elements inside a <body> that carry no dynamics here (drawn or sensed only)
IGNORED_IN_BODY = ("site", "camera", "light")
#: top-level elements that carry no rigid-body dynamics (<contact>'s pairs and excludes
#: are not read: contact geoms are, with ``contacts``)
IGNORED_TOP = ("compiler", "size", "visual", "statistic", "asset", "default", "sensor",
               "keyframe", "custom", "contact", "extension")


@dataclass
class _Body:
    """One anadyn body: an MJCF joint, the MJCF bodies it carries (parts, in its axes)."""
    name: str
    parent: str
    joint: dict
    mjcf_joint: str
    mjcf_body: str
    parts: list = field(default_factory=list)


def import_file(path: str | Path, fix_base: bool = False, inertia: str = "refuse",
                lock=(), floating_base: bool = False, contacts: bool = False) -> Imported:
    """Read and import the MJCF model at ``path``; ``fix_base`` welds a ``free`` joint
    of a body on the world body to the world where the body is placed; ``contacts``
    imports the sphere, capsule and box geoms that can touch a plane of the world as
    compliant contacts against it (``contact``; without it none).  ``inertia``,
    ``lock`` and ``floating_base`` (the URDF reading options) must keep their
    defaults: an MJCF model is imported whole (a free body has its free joint), and
    an inertia no rigid body has is refused."""
    shown = display_name(path)
    if inertia != "refuse" or lock or floating_base:
        flag = "--lock" if lock else "--floating-base" if floating_base else \
            f"--inertia {inertia}"
        raise ModelError(f"{flag}: this option says how a URDF file is read; MJCF models are "
                         "imported whole, their impossible inertias refused", source=shown)
    root, shown = source.load(Path(path))
    return _Importer(shown, root, fix_base, contacts).run(root)


class _Importer(Numbers, _Reader, ContactGeoms, Loops, Actuators):
    """One import; ``bodies`` are anadyn's bodies in tree order."""

    def __init__(self, source_name: str, root, fix_base: bool, contacts: bool = False):
        super().__init__(source_name, root)
        self.fix_base = fix_base
        #: with ``contacts``: the world's planes and the moving bodies' geoms
        #: (``collect``), each (anadyn body, geom, its class, pose in that body's axes)
        self.touching: list[tuple] | None = [] if contacts else None
        self.planes: list[tuple] = []
        self.names = _Names()
        self.bodies: list[_Body] = []
        self.coordinates: dict[str, tuple[str, float]] = {}   # MJCF joint -> (q, initial)
        self.kinds: dict[str, str] = {}                       # MJCF joint -> its type
        #: MJCF ball and free joint -> (their coordinates, initial values)
        self.several: dict[str, tuple[list[str], list[float]]] = {}
        self.rotors: list[dict] = []
        self.welded: list[str] = []                           # MJCF bodies on the world
        self.static_mass: list[MassProperties] = []
        self.warnings: list[str] = []
        self.disabled: set[str] = set()                        # <flag ...="disable">
        #: MJCF body / site -> (anadyn body, its frame in that body's axes), for equalities
        self.placed: dict[str, tuple] = {equality.WORLD: (GROUND, (np.eye(3), np.zeros(3)))}
        self.sites: dict[str, tuple] = {}
        self.equalities: list[equality.Equality] = []

    # -- the model ----------------------------------------------------------------------
    def run(self, root) -> Imported:
        for element in root:
            if element.tag in ("tendon", "deformable") and len(element):
                raise self.error(f"<{element.tag}>", f"<{element[0].tag}> "
                                 f"{element[0].get('name') or ''}".rstrip() + ": anadyn "
                                 f"imports no {element.tag} elements (the rigid-body tree, "
                                 "its joints and actuators only); remove them from a copy of "
                                 "the file")
            if element.tag not in IGNORED_TOP + ("option", "worldbody", "actuator", "tendon",
                                                 "equality", "deformable"):
                raise self.error(f"<{element.tag}>", "not an MJCF element anadyn knows")
        gravity = self.gravity(root)
        world = root.find("worldbody")
        if world is None:
            raise self.error(None, "no <worldbody>")
        members = list(self.members(world, "<worldbody>", "main"))
        self.collect(None, GROUND, (np.eye(3), np.zeros(3)), members)
        for child, frame, cls in members:
            if child.tag == "body":
                self.body(child, GROUND, frame or (np.eye(3), np.zeros(3)), cls)
        if not self.bodies:
            raise self.error("<worldbody>", "nothing moves: no body has a hinge or slide joint")
        for section in root.findall("equality"):
            self.equalities += equality.read(self, section, self.placed, self.sites)
        scale = self.total_mass_scale()
        actuators, laws, gains = self.actuators(root)
        return self.emit(root, gravity, scale, actuators, laws, gains)

    def gravity(self, root) -> list[float]:
        """<option gravity> (MuJoCo's default 0 0 -9.81), 0 when its flag is disabled;
        reads the disabled flags and warns of fluid forces."""
        vector, disabled = np.array([0, 0, -9.81]), set()
        for option in root.findall("option"):
            vector = self.numbers(option, "gravity", 3, "<option>", " ".join(map(str, vector)))
            for key in ("density", "viscosity"):
                if self.number(option, key, "<option>", "0") != 0:
                    self.warnings.append(f"{self.source}: <option {key}=...>: fluid forces are "
                                         "not modelled by anadyn; left out")
            for flag in option.findall("flag"):
                disabled |= {k for k, v in flag.attrib.items() if v == "disable"}
        self.disabled = disabled
        return [0.0, 0.0, 0.0] if "gravity" in disabled else [float(g) for g in vector]

    # -- bodies ---------------------------------------------------------------------------
    def orientation(self, element, where: str, cls: str) -> np.ndarray:
        """The rotation of the element's orientation attribute (its own or its class's)."""
        given = [k for k in frames.ORIENTATIONS if self.get(element, k, cls) is not None]
        if len(given) > 1:
            raise self.error(where, f"{' and '.join(given)}: give one orientation at most")
        if not given:
            return frames.IDENTITY
        key, scale = given[0], math.pi / 180 if self.compiler.degrees else 1.0
        if key == "quat":
            q = self.numbers(element, key, 4, where, cls=cls)
            if not np.linalg.norm(q) > 1e-12:
                raise self.error(where, f'quat="{element.get(key)}": a zero quaternion')
            return frames.quat_matrix(q)
        if key == "axisangle":
            v = self.numbers(element, key, 4, where, cls=cls)
            self.nonzero(v[:3], element, key, where)
            return frames.axis_angle(v[:3], v[3] * scale)
        if key == "euler":
            return frames.euler(self.numbers(element, key, 3, where, cls=cls) * scale,
                                self.compiler.eulerseq)
        if key == "xyaxes":
            v = self.numbers(element, key, 6, where, cls=cls)
            self.nonzero(v[:3], element, key, where)
            if not np.linalg.norm(np.cross(v[:3], v[3:])) > 1e-12:
                raise self.error(where, f'xyaxes="{element.get(key)}": the axes are parallel')
            return frames.xyaxes(v)
        v = self.numbers(element, key, 3, where, cls=cls)
        self.nonzero(v, element, key, where)
        return frames.z_to(v)

    def nonzero(self, vector, element, key: str, where: str) -> None:
        if not np.linalg.norm(vector) > 1e-12:
            raise self.error(where, f'{key}="{element.get(key)}": the vector is zero')

    def body(self, element, owner: str, pending, childclass: str) -> None:
        """Import the MJCF ``element`` whose parent's frame is ``pending`` = (R, t)
        in the frame of the anadyn body ``owner``: its joints become bodies, its mass
        is added to the last of them (or to ``owner`` when it has none)."""
        name = element.get("name") or f"body{len(self.bodies) + len(self.welded) + 1}"
        where = f"body {name!r}"
        cls = element.get("childclass", childclass)
        if cls not in self.defaults:
            raise self.error(where, f'childclass="{cls}": no <default> of this class')
        if element.get("mocap") == "true":
            raise self.error(where, 'mocap="true": a body moved by the user is not imported')
        if self.number(element, "gravcomp", where, "0", cls) != 0:
            raise self.error(where, f'gravcomp="{element.get("gravcomp")}": anadyn has no '
                                    "gravity compensation forces; remove it from a copy")
        pending = compose(pending, self.pose(element, where, cls))
        members = list(self.members(element, where, cls))
        joints = [m for m in members if m[0].tag in ("joint", "freejoint")]
        for k, (child, frame, inner) in enumerate(joints):
            owner, pending = self.joint(child, name, owner, pending, inner,
                                        k == len(joints) - 1, frame)
        self.place(name, owner, pending, members)
        self.collect(name, owner, pending, members)
        if owner == GROUND:
            self.welded.append(name)
            if self.compiler.settotalmass > 0:
                self.static_mass.append(self.mass(element, where, members))
        else:
            target = next(b for b in reversed(self.bodies) if b.name == owner)
            target.parts.append((name, self.mass(element, where, members).moved(pending)))
        for child, frame, inner in members:
            if child.tag == "body":
                self.body(child, owner, compose(pending, frame) if frame else pending, inner)

    def pose(self, element, where: str, cls: str):
        """(R, pos) of a body or frame in its parent's axes."""
        return (self.orientation(element, where, cls),
                self.numbers(element, "pos", 3, where, "0 0 0", cls))

    def members(self, element, where: str, cls: str, frame=None):
        """The elements of a body (or the world body), those inside <frame>s too, each
        with the pose of its frame in the body's axes (None: the body's own) and its
        class (a frame's childclass applies inside it)."""
        for child in element:
            if child.tag == "frame":
                inner = child.get("childclass", cls)
                if inner not in self.defaults:
                    raise self.error(f"{where}: <frame>",
                                     f'childclass="{inner}": no <default> of this class')
                placed = self.pose(child, f"{where}: <frame>", inner)
                yield from self.members(child, where, inner,
                                        compose(frame, placed) if frame else placed)
            elif child.tag in ("replicate", "composite", "flexcomp", "attach", "plugin"):
                raise self.error(f"{where}: <{child.tag}>", "not imported by anadyn (bodies, "
                                 "frames, joints, geoms and inertials only)")
            elif child.tag not in IGNORED_IN_BODY + ("body", "geom", "inertial", "joint",
                                                     "freejoint"):
                raise self.error(f"{where}: <{child.tag}>", "not an MJCF body element")
            else:
                yield child, frame, cls

    def joint(self, element, body: str, owner: str, pending, cls: str, last: bool, frame):
        """The anadyn body of one MJCF joint (in the <frame> of pose ``frame`` when not
        None); returns it as the new owner and the MJCF body's frame in its axes."""
        count = sum(b.mjcf_body == body for b in self.bodies)
        name = element.get("name") or f"{body}_joint{count + 1}"
        where = f"joint {name!r}"
        if name in self.coordinates:
            raise self.error(where, "a second joint of this name (MuJoCo's names are unique)")
        kind = "free" if element.tag == "freejoint" else self.word(
            element, "type", ("free", "ball", "slide", "hinge"), where, "hinge", cls)
        if kind == "free":
            if self.fix_base and owner == GROUND:
                self.warnings.append(f"{self.source}: {where}: free joint welded to the world "
                                     "(--fix-base)")
                return owner, pending
            if owner != GROUND:
                raise self.error(where, "a free joint on a body that is not on the world body "
                                        "(MuJoCo allows it only there)")
        if kind in SEVERAL:
            return self.several_joint(element, kind, name, body, owner, pending, cls, last,
                                      frame, where)
        R, t = pending
        p = self.numbers(element, "pos", 3, where, "0 0 0", cls)
        axis = self.numbers(element, "axis", 3, where, "0 0 1", cls)
        self.nonzero(axis, element, "axis", where)
        if frame is not None:
            p, axis = frame[1] + frame[0] @ p, _snap(frame[0] @ axis)
        unit = axis / np.linalg.norm(axis)
        angle = math.pi / 180 if kind == "hinge" and self.compiler.degrees else 1.0
        ref = self.number(element, "ref", where, "0", cls) * angle
        if kind == "hinge":
            origin, C, after = t + R @ p, R @ frames.axis_angle(unit, -ref), -p
        else:
            origin, C, after = t - R @ unit * ref, R, np.zeros(3)
        q = self.names.coordinate(name)
        self.coordinates[name] = (q, ref)
        self.kinds[name] = kind
        spec = {"type": JOINTS[kind]}
        origin = _snap(origin)
        if origin.any():
            spec["origin"] = self.vector(origin)
        rpy = _snap(matrix_rpy(C), math.pi)
        if rpy.any():
            spec["rpy"] = [_angle(self.value(a)) for a in rpy]
        spec["axis"] = self.vector(axis)
        spec["displacement"] = q
        if self.get(element, "springdamper", cls) is not None and self.numbers(
                element, "springdamper", 2, where, cls=cls).any():
            raise self.error(where, "springdamper: give stiffness and damping instead (anadyn "
                                    "imports them as they are)")
        spec.update(self.joint_forces(element, kind, angle, where, cls))
        armature = self.nonnegative(element, "armature", where, cls)
        if armature:
            self.rotors.append({"coordinate": q, "joint": name, "armature": armature})
        anadyn_name = self.names.body(body if last else f"{body}_{name}")
        self.bodies.append(_Body(anadyn_name, owner, spec, name, body))
        return anadyn_name, (np.eye(3), after)

    def several_joint(self, element, kind: str, name: str, body: str, owner: str, pending,
                      cls: str, last: bool, frame, where: str):
        """A ball joint (anadyn's spherical: the quaternion and the angular velocity in
        body axes, MuJoCo's qpos and qvel) turning about its ``pos`` in the body, or a
        free joint (anadyn's floating: x, y, z and the quaternion, MuJoCo's qpos, the
        body's placement at the start; speeds the origin's velocity in the world and
        the angular velocity in body axes, MuJoCo's qvel).  Neither takes forces,
        limits or actuators here."""
        for key in ("damping", "stiffness", "frictionloss", "armature"):
            if self.number(element, key, where, "0", cls):
                raise self.error(where, f'{key}="{self.get(element, key, cls)}" on a {kind} '
                                        "joint: not imported (anadyn's joint forces act along "
                                        "one coordinate)")
        R, t = pending
        stem = self.names.coordinate(name)
        if kind == "free":
            spec = {"type": Floating.word}
            initial = [*t, *frames.quaternion_of(R)]
            parts, after = ("x", "y", "z", *QUATERNION), (np.eye(3), np.zeros(3))
        else:
            p = self.numbers(element, "pos", 3, where, "0 0 0", cls)
            if frame is not None:
                p = frame[1] + frame[0] @ p
            spec, initial = {"type": Spherical.word}, [1, 0, 0, 0]
            parts, after = QUATERNION, (np.eye(3), -p)
            origin, rpy = _snap(t + R @ p), _snap(matrix_rpy(R), math.pi)
            if origin.any():
                spec["origin"] = self.vector(origin)
            if rpy.any():
                spec["rpy"] = [_angle(self.value(a)) for a in rpy]
        names = [self.names.coordinate(f"{stem}_{part}") for part in parts]
        speeds = [self.names.coordinate(f"{stem}_{part}") for part in ANGULAR]
        spec.update(coordinates=names, speeds=speeds)
        self.several[name] = (names, [self.value(v) for v in initial])
        self.kinds[name] = kind
        anadyn_name = self.names.body(body if last else f"{body}_{name}")
        self.bodies.append(_Body(anadyn_name, owner, spec, name, body))
        return anadyn_name, after

    def joint_forces(self, element, kind: str, angle: float, where: str, cls: str) -> dict:
        spec = {}
        limited = self.word(element, "limited", ("true", "false", "auto"), where, "auto", cls)
        has_range = self.get(element, "range", cls) is not None
        if limited == "true" or (limited == "auto" and self.compiler.autolimits and has_range):
            lower, upper = self.numbers(element, "range", 2, where, "0 0", cls) * angle
            if lower > upper:
                raise self.error(where, f'range="{self.get(element, "range", cls)}": the lower '
                                        "end is above the upper one")
            if lower < upper:
                spec["limits"] = {"lower": self.value(lower), "upper": self.value(upper)}
        damping = self.nonnegative(element, "damping", where, cls)
        if damping and "damper" not in self.disabled:
            spec["damping"] = self.value(damping)
        friction = self.nonnegative(element, "frictionloss", where, cls)
        if friction:
            spec["friction"] = self.value(friction)
            self.warnings.append(
                f"{self.source}: {where}: frictionloss {_format(friction)} becomes anadyn's "
                "smoothed Coulomb friction (friction * tanh(rate / 0.01)); MuJoCo's is a "
                "constraint, so the motions differ near rest")
        stiffness = self.nonnegative(element, "stiffness", where, cls)
        if stiffness and "spring" not in self.disabled:
            spec["stiffness"] = self.value(stiffness)
            rest = self.number(element, "springref", where, "0", cls) * angle
            if rest:
                spec["rest"] = self.value(rest)
        return spec

    def nonnegative(self, element, key: str, where: str, cls: str) -> float:
        value = self.number(element, key, where, "0", cls)
        if value < 0:
            raise self.error(where, f'{key}="{self.get(element, key, cls)}": cannot be negative')
        return value

    # -- mass properties ------------------------------------------------------------------
    def mass(self, element, where: str, members) -> MassProperties:
        """The body's mass properties in its MJCF frame: its <inertial>, or its geoms'
        (``compiler.inertiafromgeom``), raised to <compiler boundmass> and each
        principal moment to boundinertia, as MuJoCo's compiler raises them."""
        inertial = element.find("inertial")
        mode = self.compiler.inertiafromgeom
        if inertial is not None and mode != "true":
            found = self.inertial(inertial, where)
        elif mode == "false":
            found = MassProperties(0.0, np.zeros(3), np.zeros((3, 3)))
        else:
            geoms = [(child, frame, cls) for child, frame, cls in members if child.tag == "geom"]
            parts = [(self.geom(g, k, where, cls), frame)
                     for k, (g, frame, cls) in enumerate(geoms)]
            found = combine([p.moved(frame) if frame else p for p, frame in parts if p is not None])
        mass, floor = self.compiler.boundmass, self.compiler.boundinertia
        if found.mass >= mass and not floor:
            return found
        moments, axes = np.linalg.eigh(found.inertia)
        return MassProperties(max(found.mass, mass), found.com,
                              axes @ np.diag(np.maximum(moments, floor)) @ axes.T)

    def inertial(self, element, where: str) -> MassProperties:
        where = f"{where}: <inertial>"
        mass = self.number(element, "mass", where)
        if mass < 0:
            raise self.error(where, f'mass="{element.get("mass")}": cannot be negative')
        com = self.numbers(element, "pos", 3, where, "0 0 0")
        R = self.orientation(element, where, "main")
        if element.get("fullinertia") is not None:
            if element.get("diaginertia") is not None or R is not frames.IDENTITY:
                raise self.error(where, "fullinertia (in the body's axes) goes without "
                                        "diaginertia and without an orientation")
            xx, yy, zz, xy, xz, yz = self.numbers(element, "fullinertia", 6, where)
            tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:
            tensor = np.diag(self.numbers(element, "diaginertia", 3, where))
        problem = inertia_problem(np.linalg.eigvalsh(tensor))
        if problem:
            raise self.error(where, f"the inertia {problem}; no rigid body has it")
        return MassProperties(mass, com, R @ tensor @ R.T)

    def geom(self, element, index: int, where: str, cls: str) -> MassProperties | None:
        where = f"{where}: geom {element.get('name') or index + 1!r}"
        kind = self.word(element, "type", GEOM_TYPES, where, "sphere", cls)
        group = self.number(element, "group", where, "0", cls)
        lowest, highest = self.compiler.inertiagroups
        if not lowest <= group <= highest:
            return None
        if self.get(element, "shellinertia", cls) == "true":
            raise self.error(where, 'shellinertia="true": anadyn computes solid geoms\' '
                                    "inertias only; give the body an <inertial>")
        if kind not in inertia.SIZES:
            raise self.error(where, f"a {kind} geom: anadyn computes the inertia of sphere, "
                                    "capsule, cylinder, box and ellipsoid geoms; give the body "
                                    "an <inertial> (inertiafromgeom=\"auto\")")
        size, R, centre = self.shape(element, kind, where, cls)
        given = self.get(element, "mass", cls)
        if given is not None:
            mass = self.number(element, "mass", where, cls=cls)
        else:
            mass = self.number(element, "density", where, "1000", cls) * inertia.volume(kind, size)
        if mass < 0:
            raise self.error(where, "the mass cannot be negative")
        moments = inertia.moments(kind, size, mass)
        return MassProperties(mass, centre, R @ np.diag(moments) @ R.T)

    def shape(self, element, kind: str, where: str, cls: str):
        """(sizes, R, centre) of a sphere, capsule, cylinder, box or ellipsoid geom in its
        body's (or frame's) axes, as MuJoCo's compiler reads them (fromto: the axis z
        from one end to the other, the last size half its length)."""
        fromto = self.get(element, "fromto", cls)
        count = inertia.SIZES[kind]
        size = self.numbers(element, "size", (1 if fromto and count > 1 else count, 3),
                            where, None, cls)
        if fromto is not None:
            if kind == "sphere":
                raise self.error(where, "fromto is for capsule, cylinder, box and ellipsoid geoms")
            ends = self.numbers(element, "fromto", 6, where, cls=cls)
            along = ends[3:] - ends[:3]
            if not np.linalg.norm(along) > 1e-12:
                raise self.error(where, f'fromto="{fromto}": the two ends coincide')
            size = np.array(list(size[:count - 1]) + [0.0] * (count - 1 - len(size[:count - 1]))
                            + [np.linalg.norm(along) / 2])
            R, centre = frames.z_to(along), (ends[:3] + ends[3:]) / 2
        else:
            size = size[:count]
            if len(size) < count:
                raise self.error(where, f'size="{self.get(element, "size", cls)}": a {kind} '
                                        f"needs {count} numbers")
            R = self.orientation(element, where, cls)
            centre = self.numbers(element, "pos", 3, where, "0 0 0", cls)
        if any(s <= 0 for s in size):
            raise self.error(where, f'size="{self.get(element, "size", cls)}": sizes must be '
                                    "positive")
        return size, R, centre

    def total_mass_scale(self) -> float:
        """MuJoCo's settotalmass: every body's mass and inertia scaled by this."""
        wanted = self.compiler.settotalmass
        if wanted <= 0:
            return 1.0
        total = sum(m.mass for b in self.bodies for _, m in b.parts) + sum(
            m.mass for m in self.static_mass)
        if total <= 0:
            raise self.error("<compiler>", "settotalmass: the model has no mass to scale")
        return wanted / total

    # -- contacts ----------------------------------------------------------------------------
    # -- the YAML --------------------------------------------------------------------------------
    def emit(self, root, gravity, scale, actuators, laws, gains) -> Imported:
        bodies, comments = [], []
        carriers = {body.parent for body in self.bodies}
        for body in self.bodies:
            total = combine([m for _, m in body.parts])
            if not total.mass > 0 and body.name not in carriers:
                raise self.error(f"body {body.mjcf_body!r}", f"moves (joint {body.mjcf_joint!r}) "
                                 "but has no mass, nor any body beyond it; give it a geom or "
                                 "an <inertial> with a positive mass (MuJoCo refuses it too)")
            total = MassProperties(total.mass * scale, total.com, total.inertia * scale)
            entry = {"name": body.name, "parent": body.parent, "joint": body.joint,
                     "mass": self.value(total.mass)}
            com = _snap(total.com)
            if com.any():
                entry["com"] = self.vector(com)
            entry["inertia"] = self.inertia_entries(_snap(total.inertia))
            bodies.append(entry)
            names = ", ".join(name for name, _ in body.parts)
            comments.append([f"MJCF joint {body.mjcf_joint!r} ({self.kinds[body.mjcf_joint]}) "
                             + (f"carrying body {names}" if names else
                                f"of body {body.mjcf_body!r} (more joints follow)")])
        for rotor in self.rotors:
            a = self.value(rotor["armature"])
            bodies.append({"name": self.names.body(f"{rotor['coordinate']}_armature"),
                           "parent": GROUND,
                           "joint": {"type": Revolute.word, "axis": [0, 0, 1],
                                     "displacement": rotor["coordinate"]},
                           "mass": a, "inertia": {"ixx": a / 2, "iyy": a / 2, "izz": a}})
            comments.append([f"armature {_format(a)} of joint {rotor['joint']!r}: a rotor on "
                             "the ground turning with it, kinetic energy armature*rate^2/2 "
                             "(MuJoCo adds armature to the mass matrix's diagonal); its mass "
                             "stays on its fixed axis and does nothing"])
        coordinates = {q: {"initial": self.value(ref)} for q, ref in self.coordinates.values()}
        coordinates.update({q: {"initial": value} for names, values in self.several.values()
                            for q, value in zip(names, values)})
        model = root.get("model") or Path(self.source).stem
        data = {"name": self.names.robot(Path(self.source).stem),
                "description": f"MJCF model {model!r} from {Path(self.source).name}: "
                               f"{len(coordinates)} coordinates, {len(self.bodies)} bodies"
                               + (f", {len(self.rotors)} armature rotors" if self.rotors else ""),
                "gravity": [self.value(g) for g in gravity],
                "coordinates": coordinates,
                "bodies": bodies}
        if actuators:
            data["actuators"] = actuators
            data["controller"] = {"gains": gains, "laws": laws}
        contacts = self.contacts(gravity, scale)
        if contacts:
            data["contacts"] = contacts
        if self.equalities:
            self.close_loops(data, actuators)
        if self.flushed:
            self.warnings.append(f"{self.source}: {self.flushed} number(s) below {SMALLEST:g} "
                                 "in size written as 0")
        header = [f"Imported by anadyn {__version__} from {Path(self.source).name} "
                  f"(`anadyn import{' --fix-base' if self.fix_base else ''}`); edit freely.",
                  "MJCF joint -> coordinate (hinge: revolute, rad; slide: prismatic, m); a "
                  "joint's ref is the coordinate's initial value:"]
        header += [f"  {q}: {self.kinds[joint]} {joint!r}"
                   for joint, (q, _) in self.coordinates.items()]
        header += [f"  {', '.join(names)}: {self.kinds[joint]} {joint!r} (MuJoCo's qpos; "
                   "speeds: its qvel)" for joint, (names, _) in self.several.items()]
        if self.welded:
            header.append("Fixed to the world (their mass does not move): "
                          + ", ".join(self.welded) + ".")
        if actuators:
            header.append("Actuators: MuJoCo's control u_<actuator> is a gain (0), clamped to "
                          "ctrlrange; the force (motor: u; position: kp*(u - gear*q) - "
                          "kv*gear*dq; velocity: kv*(u - gear*dq)) clamped to forcerange "
                          "is the effort (MuJoCo's actuator_force); the drive's gear times "
                          "it acts on the joint.")
        header.append(f"Gravity ({', '.join(_format(self.value(g)) for g in gravity)}) m/s^2 "
                      "in world axes (<option gravity>).")
        header.extend(f"warning: {w.split(': ', 1)[1]}" for w in self.warnings)
        return Imported(data, render(data, header, comments), self.warnings)
