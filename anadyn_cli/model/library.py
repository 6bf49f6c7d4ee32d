"""The robot library: the robots shipped with anadyn, found by name.

The library is two folders of the source tree, installed as package data
(pyproject.toml maps them onto ``anadyn_cli/robots`` and ``anadyn_cli/scenes``):

    robots/   the chapter's arms (rr.yaml, rrt.yaml), real arms as URDF
              (ur5, panda, so101, ...) and MuJoCo models as MJCF (cartpole,
              reacher, hopper: .xml files whose root is <mujoco>), their
              licences beside them
    configs/  the extreme scenes (every robot file there; batch files such as
              ci.yaml are not robots and are left out)

A ROBOT argument that names no existing file and has no folder part is looked
up here by name: ``rrt``, ``rrt.yaml`` and ``RRT`` all find robots/rrt.yaml,
``ur5`` finds robots/ur5.urdf.  A local file always wins.  Light on purpose
(no SymPy): the cached fast path resolves names through it.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from .joints import JOINT_TYPES
from .names import quaternion_names

PACKAGE = Path(__file__).resolve().parents[1]          # anadyn_cli/
#: (installed package folder, source-tree folder), searched in this order
FOLDERS = (("robots", "robots"), ("scenes", "configs"))
SUFFIXES = (".yaml", ".yml", ".urdf", ".xml")
#: one-line descriptions of the shipped URDF and MJCF files (YAML files carry their own)
DESCRIPTIONS = {
    "ur5": "Universal Robots UR5, 6-axis industrial arm (URDF, example-robot-data)",
    "panda": "Franka Emika Panda, 7-axis arm with a two-finger gripper, one finger a "
             "<mimic> of the other (URDF, example-robot-data)",
    "so101": "SO-101 low-cost 6-axis arm with gripper (URDF, example-robot-data)",
    "double_pendulum": "Double pendulum, two revolute joints (URDF, example-robot-data)",
    "twodofs": "Two-link arm with a rotated base (URDF, example-robot-data)",
    "cartpole": "Cart-pole, a slide and a hinge, motor on the cart (MJCF, DeepMind Control)",
    "hopper": "Planar hopper: slides x, z and four hinges, with armature (MJCF, Gymnasium)",
    "reacher": "Two-link planar reacher, two motors (MJCF, DeepMind Control)",
}
_announced: set[str] = set()


def folders() -> list[Path]:
    """The library's folders: the installed package data, else (a source checkout
    or an editable install) the repository's robots/ and configs/."""
    found = []
    for installed, source in FOLDERS:
        for candidate in (PACKAGE / installed, PACKAGE.parent / source):
            if candidate.is_dir():
                found.append(candidate)
                break
    return found


def entries() -> dict[str, Path]:
    """Library name (the file name's stem, lower case) -> file, robots/ first."""
    result: dict[str, Path] = {}
    for folder in folders():
        for path in sorted(folder.iterdir(), key=lambda p: p.name.lower()):
            if path.suffix.lower() in SUFFIXES and path.is_file() and _is_robot(path):
                result.setdefault(path.stem.lower(), path)
    return result


def _data(path: Path):
    """A shipped file's content as plain data (a URDF or MJCF imported), for the listing."""
    if imports(path):
        from .urdf import ReadingOptions

        return import_robot(path, ReadingOptions()).data
    import yaml

    return yaml.safe_load(path.read_text(encoding="utf-8"))


def imports(path: Path) -> bool:
    """Whether ``path`` is a file anadyn imports rather than reads: URDF (.urdf) or
    MJCF (.xml, MuJoCo's format)."""
    return path.suffix.lower() in (".urdf", ".xml")


def import_robot(path: Path, options=None):
    """``urdf.import_file`` or ``mjcf.import_file`` of ``path`` with the reading
    options (--fix-base, --floating-base, --inertia, --lock; default: the current
    ``urdf.READING``)."""
    from . import urdf

    options = urdf.READING.get() if options is None else options
    if path.suffix.lower() == ".urdf":
        if options.contacts:
            from ..errors import ModelError, display_name
            raise ModelError("--contacts: imports an MJCF model's contact geoms; anadyn reads "
                             "no contacts from a URDF", source=display_name(path))
        return urdf.import_file(path, options.fix_base, options.inertia, options.lock,
                                options.floating_base)
    from . import mjcf                            # (read only for an MJCF file)

    return mjcf.import_file(path, options.fix_base, options.inertia, options.lock,
                            options.floating_base, options.contacts)


def shipped_yaml() -> list[Path]:
    """The library's robots/*.yaml: what ``anadyn compare`` checks by default."""
    folders_ = folders()
    return sorted(folders_[0].glob("*.yaml")) if folders_ else []


def _is_robot(path: Path) -> bool:
    """URDF and MJCF files are robots; a YAML file is one when it has ``bodies`` (batch
    files have ``jobs``)."""
    if imports(path):
        if path.suffix.lower() == ".urdf":
            return True
        from .mjcf import is_mjcf

        return is_mjcf(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return any(line.startswith("bodies:") for line in text.splitlines())


def find(name: str) -> Path | None:
    """The library file for ``name`` (with or without its suffix, any case), or None."""
    stem = Path(name).stem if Path(name).suffix.lower() in SUFFIXES else name
    return entries().get(stem.lower())


def resolve(path: str | Path) -> Path:
    """The file a ROBOT argument names: ``path`` if it exists; for a bare name
    (no folder part) that does not, NAME.yaml, NAME.yml, NAME.urdf or NAME.xml in the current
    folder, else the library robot of that name; else ``path`` unchanged (the caller
    reports it missing).  A local file always wins; whenever a library name could
    be meant, one line on stderr says which file is used."""
    path = Path(path)
    bare = len(path.parts) == 1 and path.name not in (".", "..")
    if not bare:
        return path
    local = path if path.exists() else next(
        (p for p in (path.with_name(path.name + s) for s in SUFFIXES) if p.is_file()), None)
    found = find(path.name)
    if local is not None:
        if found is not None:
            announce(f"{path}: the local file {local}, not the library's {found}")
        return local
    if found is None:
        return path
    announce(f"{path}: the library's robot, {found}")
    return found


def missing_hint(path: str | Path) -> str:
    """What to add to 'no such file' for a bare name that is not in the library either."""
    path = Path(path)
    if len(path.parts) != 1:
        return ""
    import difflib

    close = difflib.get_close_matches(path.stem.lower(), list(entries()), n=1)
    return (f" and no library robot of that name{f' (did you mean {close[0]!r}?)' if close else ''}"
            "; `anadyn robots` lists the library")


def announce(line: str, warning: bool = False) -> None:
    """One line on stderr, ``anadyn: LINE``, once per process, when anadyn runs as a
    command; as a library it prints nothing (a ``warning`` becomes a Python warning)."""
    from .. import progress

    if line in _announced:
        return
    _announced.add(line)
    if progress.active():
        print(f"anadyn: {line}", file=sys.stderr)
    elif warning:
        import warnings

        warnings.warn(f"anadyn: {line}", stacklevel=3)


@dataclass(frozen=True)
class Entry:
    name: str
    path: Path
    dof: int | None            # coordinates not dependent (None: the file does not load)
    joints: str                # e.g. "7 revolute, 1 prismatic, 1 mimic"
    description: str


def listing() -> list[Entry]:
    """Every library robot with its degrees of freedom, joint types and description."""
    return [describe(name, path) for name, path in entries().items()]


def describe(name: str, path: Path) -> Entry:
    import yaml

    from ..errors import ModelError

    try:
        data = _data(path)
    except (ModelError, OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        return Entry(name, path, None, "", f"does not load: {err}")
    if not isinstance(data, dict):
        return Entry(name, path, None, "", "does not load: not a mapping")
    coordinates = data.get("coordinates") or {}
    kinds: dict[str, int] = {}
    coupled, used = 0, set()
    for body in data.get("bodies", []):
        joint = body.get("joint", {}) if isinstance(body, dict) else {}
        kind = joint.get("type", "?")
        kinds[kind] = kinds.get(kind, 0) + 1
        displacement = joint.get("displacement")
        if displacement is not None and kind in JOINT_TYPES and JOINT_TYPES[kind].moving:
            # a function of other coordinates, or one shared with another joint
            coupled += displacement not in coordinates or displacement in used
            used.add(displacement)
    joints = ", ".join(f"{n} {k}" for k, n in kinds.items())
    if coupled:
        joints += f" ({coupled} {'mimic' if path.suffix.lower() == '.urdf' else 'coupled'})"
    # closed chains: the dependent coordinates are no degrees of freedom (model.constraints)
    dependent = sum(isinstance(c, dict) and c.get("dependent") is True
                    for c in coordinates.values())
    loops = data.get("loops") if isinstance(data.get("loops"), list) else []
    listed = data.get("constraints") if isinstance(data.get("constraints"), list) else []
    velocity = sum(isinstance(c, dict) and "velocity" in c for c in listed)
    closing = [f"{n} {what}{'s' * (n != 1)}" for n, what in
               ((len(loops), "loop"), (velocity, "velocity constraint")) if n]
    if closing:
        joints += "; " + ", ".join(closing)
    description = DESCRIPTIONS.get(name) or str(data.get("description", "")).strip()
    # a spherical joint: 3 degrees of freedom, its quaternion's 4 coordinates aside
    balls = [quaternion_names(body) for body in data.get("bodies", [])]
    free = (len(set(coordinates) - {n for names in balls for n in names}) - dependent
            + 3 * sum(1 for names in balls if names))
    return Entry(name, path, free, joints, description.splitlines()[0] if description else "")
