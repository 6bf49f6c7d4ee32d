"""The MJCF import: ``import_file`` reads the model (``source``), walks the body
tree (``_Importer``: joints (``joints.Joints``), mass properties (``masses.Masses``),
armature rotors, actuators (``actuators.Actuators``)) and
writes the robot as YAML text through the imports' safe writer
(``robottext.render``)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ... import __version__
from ...errors import ModelError, display_name
from ..joints import Revolute
from ..names import GROUND
from ..robottext import SMALLEST, Numbers, _format, _Names, render
from ..urdf.frames import _snap, compose
from ..urdf.importer import Imported
from ..urdf.inertia import MassProperties, combine
from . import equality, frames, source
from .actuators import Actuators
from .geoms import ContactGeoms
from .joints import Joints, _Body
from .loops import Loops
from .masses import Masses
from .source import _Reader

#: elements inside a <body> that carry no dynamics here (drawn or sensed only)
IGNORED_IN_BODY = ("site", "camera", "light")
#: top-level elements that carry no rigid-body dynamics (<contact>'s pairs and excludes
#: are not read: contact geoms are, with ``contacts``)
IGNORED_TOP = ("compiler", "size", "visual", "statistic", "asset", "default", "sensor",
               "keyframe", "custom", "contact", "extension")


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


class _Importer(Numbers, _Reader, Joints, Masses, ContactGeoms, Loops, Actuators):
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
