"""A URDF's <visual> elements, placed on anadyn's bodies, with their mesh files found.

The importer (``model.urdf``) folds every link on a fixed (or locked, or
welded) joint into the body it is fixed to, and the root link and the links
fixed to it into the ground.  ``visuals`` takes where each link ends up from
the importer (``urdf.link_bodies``), so each visual knows its owner (body
index in the robot, -1 for the ground) and its pose in the owner's frame:
owner <- link (the fixed joints' origins composed) <- visual
(``<visual><origin>``).

Mesh paths: ``package://PKG/rest`` is looked up in the package roots (a
folder named PKG above the URDF, the ``--package-path`` folders, then
ROS_PACKAGE_PATH, AMENT_PREFIX_PATH's share/ and the share/ of pip's cmeel
prefix, where the example-robot-data package installs); ``file://`` and plain
paths are relative to the URDF's folder, and may reach into the ROS package
that holds the URDF (the nearest folder above it with a package.xml).  A path
that resolves (symbolic links followed) outside these roots is refused
(``ModelError``): a robot file from a stranger cannot make ``view`` read,
and put into a web page, any other file.  A mesh that is not there, or a
package that is not found, is a warning: that body is drawn with generated
shapes.
"""
from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import ModelError

GREY = (0.7, 0.7, 0.72, 1.0)


@dataclass
class Visual:
    link: str                       # the URDF link it belongs to
    owner: int                      # body index, -1 for the ground
    matrix: np.ndarray              # 4 x 4: visual frame in the owner's frame
    kind: str                       # mesh, box, cylinder, sphere
    size: tuple = ()                # box: x y z; cylinder: radius, length; sphere: radius;
    path: Path | None = None        # mesh: the file found       mesh: scale x y z
    color: tuple | None = None      # rgba from <material>, None: the mesh's own


@dataclass
class Visuals:
    items: list[Visual] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def visuals(urdf: Path, package_paths=()) -> Visuals:
    """The visuals of the URDF file ``urdf`` on the bodies anadyn imports from it (read
    with the current ``urdf.READING`` options, as the robot was)."""
    from ...model.urdf import link_bodies

    bodies = link_bodies(urdf)
    root, parser = bodies.root, bodies.reader
    materials = {m.get("name"): _rgba(m) for m in root.findall("material")}
    finder = _Finder(urdf, package_paths)
    result = Visuals()
    for element in root.findall("link"):
        name = element.get("name")
        if name not in bodies.places:
            continue
        owner, (R, origin) = bodies.places[name]
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = R, origin
        for visual in element.findall("visual"):
            where = f"link {name!r}: <visual>"
            xyz, rpy = parser.origin(visual, where)
            item = _geometry(parser, visual, where, finder, result.warnings)
            if item is None:
                continue
            item.link, item.owner = name, owner
            item.matrix = pose @ _matrix(xyz, rpy)
            material = visual.find("material")
            if material is not None:
                item.color = _rgba(material) or materials.get(material.get("name"))
            result.items.append(item)
    return result


def _geometry(parser, visual, where: str, finder: "_Finder", warnings: list) -> Visual | None:
    geometry = visual.find("geometry")
    shape = next(iter(geometry), None) if geometry is not None else None
    if shape is None:
        return None
    if shape.tag == "box":
        return Visual("", 0, np.eye(4), "box", tuple(parser.numbers(shape, "size", 3, where)))
    if shape.tag == "cylinder":
        return Visual("", 0, np.eye(4), "cylinder", (parser.number(shape, "radius", where),
                                                      parser.number(shape, "length", where)))
    if shape.tag == "sphere":
        return Visual("", 0, np.eye(4), "sphere", (parser.number(shape, "radius", where),))
    if shape.tag == "mesh":
        filename = shape.get("filename") or ""
        path = finder.find(filename, f"{where} <mesh filename=\"{filename}\">", warnings)
        if path is None:
            return None
        scale = tuple(parser.numbers(shape, "scale", 3, where, "1 1 1"))
        return Visual("", 0, np.eye(4), "mesh", scale, path)
    warnings.append(f"{finder.urdf}: {where}: <{shape.tag}> is not drawn")
    return None


class _Finder:
    """Mesh file names -> files inside the permitted roots."""

    def __init__(self, urdf: Path, package_paths):
        self.urdf = urdf
        self.folder = urdf.resolve().parent
        self.home = [p for p in self.folder.parents if (p / "package.xml").is_file()][:1]
        self.package_paths = [Path(p) for p in package_paths]
        self.missing_packages: set[str] = set()

    def find(self, filename: str, where: str, warnings: list) -> Path | None:
        if filename.startswith("package://"):
            package, _, rest = filename[len("package://"):].partition("/")
            root = self.package(package)
            roots = [root]
            if root is None:
                if package not in self.missing_packages:
                    self.missing_packages.add(package)
                    hint = (", or pip install example-robot-data"
                            if package == "example-robot-data" else "")
                    warnings.append(
                        f"{self.urdf}: package {package!r} not found (give its parent folder "
                        f"with --package-path{hint}); its meshes are drawn as generated shapes")
                return None
        else:
            root, roots = self.folder, [self.folder, *self.home]
            rest = filename[len("file://"):] if filename.startswith("file://") else filename
        path = (root / rest).resolve()
        if not any(path.is_relative_to(r) for r in roots):
            raise ModelError(f"{where}: the file is outside the URDF's folder and its package "
                             "roots; meshes must be inside them", source=str(self.urdf))
        if not path.is_file():
            warnings.append(f"{self.urdf}: {where}: no such file; drawn as generated shapes")
            return None
        return path

    def package(self, name: str) -> Path | None:
        """The folder of package ``name``, resolved, or None."""
        if not name or name in (".", "..") or "/" in name or "\\" in name:
            return None
        candidates = [p for p in self.folder.parents if p.name == name]
        if self.folder.name == name:
            candidates.insert(0, self.folder)
        for folder in self.package_paths + _environment_roots():
            candidates += [folder / name, folder] if folder.name == name else [folder / name]
        return next((c.resolve() for c in candidates if c.is_dir()), None)


def _environment_roots() -> list[Path]:
    roots = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    roots += [Path(p) / "share" for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)
              if p]
    roots += [Path(p) / "cmeel.prefix" / "share" for p in sys.path if p.endswith("site-packages")]
    return roots


def _rgba(element) -> tuple | None:
    color = element.find("color") if element is not None else None
    if color is None or not color.get("rgba"):
        return None
    try:
        values = tuple(float(v) for v in color.get("rgba").split())
    except ValueError:
        return None
    return values if len(values) == 4 and all(0 <= v <= 1 for v in values) else None


def _matrix(xyz, rpy) -> np.ndarray:
    from ...model.urdf import rpy_matrix

    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = rpy_matrix(rpy), xyz
    return matrix
