"""The URDF import: ``import_file`` / ``import_urdf`` (the steps of ``parse``,
``tree``, ``reduce``, ``inertia`` and ``emit`` in one ``_Importer``), ``link_bodies``
and ``place`` (where a key of an imported text comes from)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ...errors import display_name
from ..joints import Compound
from ..names import GROUND, nearest_key
from ..robottext import _format, _Names, render
from .emit import _Emit
from .frames import Pose
from .inertia import _InertiaPolicy
from .options import READING, ReadingOptions
from .parse import _Reader, _parsed, read_urdf
from .reduce import _Reduce
from . import transmission
from .tree import _Tree, _listed

GRAVITY = 9.81                    # m/s^2 along -z of the root link (URDF, ROS, Pinocchio)


@dataclass
class Imported:
    """The robot description (``data``, anadyn's YAML schema), its YAML
    text (``text``, with comments), and what the import changed or dropped."""
    data: dict
    text: str
    warnings: list[str] = field(default_factory=list)


#: YAML text an import in this process produced -> (its description, the URDF
#: place of its key paths), the last few imports: for ``place`` and ``description``
_IMPORTS: dict[str, tuple[dict, dict[str, str]]] = {}


def description(text: str) -> dict | None:
    """The description (anadyn's YAML schema, plain data) that an import in this
    process produced as ``text``: what reading ``text`` gives, without parsing it
    again (tests/test_urdf.py, tests/test_urdf_doors.py check they are equal); None otherwise."""
    known = _IMPORTS.get(text)
    return None if known is None else known[0]


def place(text: str, path: str | None) -> str | None:
    """Where in the URDF the key ``path`` of the robot ``text`` comes from, e.g.
    ``joint 'elbow' (child link 'forearm')`` for ``bodies[2].mass``, when an
    import in this process produced ``text``; None otherwise."""
    known = _IMPORTS.get(text)
    if known is None:
        return None
    places = known[1]
    return places[nearest_key(path or "", places)]


def import_file(path: str | Path, fix_base: bool = False, inertia: str = "refuse",
                lock=(), floating_base: bool = False) -> Imported:
    """Read and import the URDF file at ``path`` (named by ``display_name``)."""
    return import_urdf(read_urdf(path), display_name(path), fix_base=fix_base,
                       inertia=inertia, lock=lock, floating_base=floating_base)


def import_urdf(raw: bytes | str, source: str, fix_base: bool = False,
                inertia: str = "refuse", lock=(), floating_base: bool = False) -> Imported:
    """Import URDF text; ``source`` names it in messages and (its file name) in the
    header.  ``lock``: {joint: value} or ((joint, value), ...), the joints held at a
    value (number or expression text, e.g. ``pi/4``): a reduced robot, as
    Pinocchio's ``buildReducedModel`` makes it; ``floating_base``: the root link
    free, as Pinocchio's ``JointModelFreeFlyer`` root makes it (ReadingOptions)."""
    options = ReadingOptions(fix_base, inertia, tuple(dict(lock).items()), floating_base)
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


class _Importer(_Emit, _Reduce, _Tree, _InertiaPolicy, _Reader):
    """One import: reads (``_Reader``), builds the tree (``_Tree``), locks and folds
    (``_Reduce``, ``_InertiaPolicy``) and writes the robot (``_Emit``)."""

    def run(self, root) -> Imported:
        links, joints, base = self.tree(root)
        order = self.tree_order(base, joints)
        masters = self.resolve_mimics(joints)
        return self.build(root, base, order, links, joints, masters,
                          self.locks(joints, masters))

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
        coordinates = [j for j in moving if j.name not in masters
                       and not isinstance(j.kind, Compound)]
        q = {j.name: names.coordinate(j.name) for j in coordinates}
        body_name = {j.child: names.body(j.child) for j in moving}
        several = {j.name: self.several_names(j, body_name[j.child], names)
                   for j in moving if isinstance(j.kind, Compound)}
        bodies, comments = [], []
        for joint in moving:
            parts = [(joint.child, None)] + folded[joint.child]
            bodies.append(self.body(joint, owner, pose, parts, links, body_name, q, masters,
                                    several))
            comments.append(self.body_comment(joint, parts, pose, body_name))
        tau = {j.name: names.actuator(q[j.name]) for j in coordinates}
        gears = transmission.gears(root, self)        # <transmission>: drive gear ratios
        free = {name: {"initial": int(k == 3 and bool(speeds))}    # a quaternion's qw: 1
                for listed, speeds in several.values() for k, name in enumerate(listed)}
        data = {
            "name": robot_name,
            "description": self.description(root, coordinates, moving, masters, several),
            "gravity": [0, 0, -GRAVITY],
            "coordinates": {**{q[j.name]: {"initial": self.initial(j)} for j in coordinates},
                            **free},
            "bodies": bodies,
            "actuators": {tau[j.name]: {"joint": body_name[j.child], **gears.get(j.name, {})}
                          for j in coordinates},
        }
        if not data["actuators"]:
            del data["actuators"]
        places = {"": f"<robot name={root.get('name')!r}>",
                  "name": f"the file name {Path(self.source).name!r}",
                  **{f"bodies[{i}]": f"joint {j.name!r} (child link {j.child!r})"
                     for i, j in enumerate(moving)},
                  **{f"coordinates.{q[j.name]}": f"joint {j.name!r}" for j in coordinates},
                  **{f"actuators.{tau[j.name]}": f"joint {j.name!r}" for j in coordinates}}
        self.collect_notes()
        header = self.header(base, folded[GROUND], coordinates, masters, q, joints, locks,
                             several)
        footer = self.trajectory_hint(coordinates[0], q[coordinates[0].name]) \
            if coordinates else ""
        text = render(data, header, comments) + footer
        _IMPORTS[text] = (data, places)
        while len(_IMPORTS) > 8:
            del _IMPORTS[next(iter(_IMPORTS))]
        return Imported(data, text, self.warnings)
