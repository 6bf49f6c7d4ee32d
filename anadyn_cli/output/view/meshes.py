"""Mesh files -> triangles: STL (binary and ASCII), Wavefront OBJ and COLLADA (.dae).

Meshes come from strangers' URDF packages, so they are read as data only:
numbers and indices, never code; XML through ``defusedxml`` (no entities, no
external references); every file capped at MAX_BYTES.  A mesh is returned as
``Part``s (one per colour): vertex positions (v, 3) in the file's frame, in
metres after the file's own unit (COLLADA ``<unit meter>``), and triangle
vertex indices (t, 3).  Polygons are split into fans.  Anything the reader
cannot use is one ``ModelError`` naming the file and what is wrong.

COLLADA: the nodes of the visual scene are walked with their ``<matrix>``,
``<translate>``, ``<rotate>`` and ``<scale>`` transforms; ``<triangles>``,
``<polylist>`` and ``<polygons>`` are read; a primitive's colour is its
material's diffuse colour.  ``<up_axis>`` is not applied: the vertices are
taken in the link frame as written, as ROS tools (rviz, Gazebo) and Pinocchio
do for URDF meshes.
"""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import ModelError

MAX_BYTES = 64 * 1024 * 1024
SUFFIXES = (".stl", ".obj", ".dae")


@dataclass
class Part:
    """Triangles of one colour: ``positions`` (v, 3) float, ``triangles`` (t, 3) int;
    ``color`` (r, g, b, a) in 0..1, or None for the visual's own colour."""
    positions: np.ndarray
    triangles: np.ndarray
    color: tuple | None = None


def read_mesh(path: Path) -> list[Part]:
    """The parts of the mesh file at ``path`` (by its suffix)."""
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ModelError(f"mesh format {suffix or '(none)'} is not read; meshes may be "
                         f"{', '.join(s[1:].upper() for s in SUFFIXES)}", source=str(path))
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise ModelError(f"mesh is {size} bytes, the limit is {MAX_BYTES}", source=str(path))
        raw = path.read_bytes()
    except OSError as err:
        raise ModelError(f"cannot read the mesh: {err.strerror or err}", source=str(path)) from None
    reader = {".stl": stl, ".obj": obj, ".dae": collada}[suffix]
    try:
        parts = reader(raw)
    except (ValueError, IndexError, KeyError, TypeError, AttributeError, StopIteration,
            struct.error) as err:            # any malformed file is one line, never a traceback
        raise ModelError(f"not a readable {suffix[1:].upper()} mesh ({err})",
                         source=str(path)) from None
    parts = [p for p in parts if len(p.triangles)]
    for p in parts:
        if not np.isfinite(p.positions).all():
            raise ModelError("mesh has non-finite vertex coordinates", source=str(path))
        if p.triangles.min() < 0 or p.triangles.max() >= len(p.positions):
            raise ModelError("mesh has a vertex index out of range", source=str(path))
    return parts


# -- STL -------------------------------------------------------------------------------
def stl(raw: bytes) -> list[Part]:
    """Binary STL (80-byte header, count, 50 bytes a triangle) or ASCII STL."""
    if len(raw) >= 84:
        count = struct.unpack_from("<I", raw, 80)[0]
        if len(raw) == 84 + 50 * count:
            record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            triangles = np.frombuffer(raw, record, count, 84)["v"].reshape(-1, 3)
            return [_indexed(triangles.astype(float))]
    text = raw.decode("ascii", errors="strict")
    if not text.lstrip().startswith("solid"):
        raise ValueError("neither binary STL (size does not match its triangle count) nor "
                         "ASCII STL (no 'solid')")
    numbers = re.findall(r"^\s*vertex\s+(\S+)\s+(\S+)\s+(\S+)", text, re.MULTILINE)
    if len(numbers) % 3:
        raise ValueError(f"{len(numbers)} vertices, not a multiple of 3")
    return [_indexed(np.array(numbers, dtype=float).reshape(-1, 3))]


def _indexed(corners: np.ndarray) -> Part:
    """Triangle corners (3t, 3) -> shared vertices and indices."""
    positions, index = np.unique(corners, axis=0, return_inverse=True)
    return Part(positions, index.reshape(-1, 3))


# -- OBJ -------------------------------------------------------------------------------
def obj(raw: bytes) -> list[Part]:
    """``v x y z`` and ``f a b c ...`` lines (``a/t/n`` forms, negative indices)."""
    vertices, faces = [], []
    for line in raw.decode("utf-8", errors="replace").splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "v":
            vertices.append([float(w) for w in words[1:4]])
        elif words[0] == "f":
            corners = []
            for word in words[1:]:
                k = int(word.split("/")[0])
                corners.append(k - 1 if k > 0 else len(vertices) + k)
            faces += [(corners[0], corners[i], corners[i + 1]) for i in range(1, len(corners) - 1)]
    if not vertices or not faces:
        raise ValueError("no 'v' or no 'f' lines")
    return [Part(np.array(vertices, dtype=float), np.array(faces, dtype=np.int64))]


# -- COLLADA ---------------------------------------------------------------------------
def collada(raw: bytes) -> list[Part]:
    """The triangles of the default visual scene, in the file's root frame."""
    import defusedxml
    from defusedxml import ElementTree

    try:
        root = ElementTree.fromstring(raw, forbid_dtd=True, forbid_entities=True,
                                      forbid_external=True)
    except (ElementTree.ParseError, defusedxml.DefusedXmlException) as err:
        raise ValueError(f"XML refused: {err}") from None
    ns = root.tag[:root.tag.index("}") + 1] if root.tag.startswith("{") else ""
    return _Collada(root, ns).parts()


class _Collada:
    def __init__(self, root, ns: str):
        self.root, self.ns = root, ns
        self.ids = {e.get("id"): e for e in root.iter() if e.get("id")}
        unit = root.find(f"{ns}asset/{ns}unit")
        self.meter = float(unit.get("meter", "1")) if unit is not None else 1.0

    def tag(self, element) -> str:
        return element.tag[len(self.ns):]

    def find(self, url: str | None):
        if not url or not url.startswith("#") or url[1:] not in self.ids:
            raise ValueError(f"reference {url!r} not found in the file")
        return self.ids[url[1:]]

    def parts(self) -> list[Part]:
        ns = self.ns
        scene = self.root.find(f"{ns}scene/{ns}instance_visual_scene")
        if scene is not None:
            roots = [self.find(scene.get("url"))]
        else:
            roots = self.root.findall(f"{ns}library_visual_scenes/{ns}visual_scene")
        parts: list[Part] = []
        for visual_scene in roots:
            for node in visual_scene.findall(f"{ns}node"):
                self.node(node, np.eye(4), parts, 0)
        scale = np.diag([self.meter] * 3 + [1.0])
        for p in parts:
            p.positions = _apply(scale, p.positions)
        return parts

    def node(self, node, parent: np.ndarray, parts: list, depth: int) -> None:
        if depth > 64:
            raise ValueError("nodes nested over 64 deep")
        matrix = parent @ self.transform(node)
        for child in node:
            kind = self.tag(child)
            if kind == "instance_geometry":
                colors = self.bound_colors(child)
                for part in self.geometry(self.find(child.get("url")), colors):
                    part.positions = _apply(matrix, part.positions)
                    parts.append(part)
            elif kind == "node":
                self.node(child, matrix, parts, depth + 1)
            elif kind == "instance_node":
                self.node(self.find(child.get("url")), matrix, parts, depth + 1)

    def transform(self, node) -> np.ndarray:
        """The node's transforms, composed in document order."""
        result = np.eye(4)
        for child in node:
            kind = self.tag(child)
            if kind not in ("matrix", "translate", "rotate", "scale"):
                continue
            values = [float(v) for v in (child.text or "").split()]
            step = np.eye(4)
            if kind == "matrix":
                step = np.array(values, dtype=float).reshape(4, 4)
            elif kind == "translate":
                step[:3, 3] = values[:3]
            elif kind == "scale":
                step = np.diag(values[:3] + [1.0])
            else:
                axis, angle = np.array(values[:3]), np.radians(values[3])
                step[:3, :3] = _axis_angle(axis / np.linalg.norm(axis), angle)
            result = result @ step
        return result

    def bound_colors(self, instance) -> dict:
        """Material symbol -> diffuse colour, from the instance's <bind_material>."""
        colors = {}
        for bound in instance.iter(f"{self.ns}instance_material"):
            try:
                material = self.find(bound.get("target"))
                effect = self.find(material.find(f"{self.ns}instance_effect").get("url"))
            except (ValueError, AttributeError):
                continue
            diffuse = effect.find(f".//{self.ns}diffuse/{self.ns}color")
            if diffuse is not None and diffuse.text:
                rgba = [float(v) for v in diffuse.text.split()][:4]
                colors[bound.get("symbol")] = tuple(rgba + [1.0] * (4 - len(rgba)))
        return colors

    def geometry(self, geometry, colors: dict) -> list[Part]:
        ns = self.ns
        mesh = geometry.find(f"{ns}mesh")
        if mesh is None:
            return []
        parts = []
        for primitive in mesh:
            kind = self.tag(primitive)
            if kind not in ("triangles", "polylist", "polygons"):
                continue
            inputs = primitive.findall(f"{ns}input")
            vertex = next((i for i in inputs if i.get("semantic") == "VERTEX"), None)
            if vertex is None:
                continue
            stride = max(int(i.get("offset", "0")) for i in inputs) + 1
            offset = int(vertex.get("offset", "0"))
            positions = self.positions(self.find(vertex.get("source")))
            if kind == "polygons":
                polygons = [np.array((p.text or "").split(), dtype=np.int64)[offset::stride]
                            for p in primitive.findall(f"{ns}p")]
            else:
                p = primitive.find(f"{ns}p")
                indices = np.array((p.text if p is not None and p.text else "").split(),
                                   dtype=np.int64)[offset::stride]
                if kind == "triangles":
                    polygons = [indices]
                else:
                    counts = np.array(primitive.find(f"{ns}vcount").text.split(), dtype=np.int64)
                    polygons = np.split(indices, np.cumsum(counts)[:-1])
            triangles = _fans(polygons, kind == "triangles")
            parts.append(Part(positions, triangles, colors.get(primitive.get("material"))))
        return parts

    def positions(self, vertices) -> np.ndarray:
        """The POSITION source of a <vertices> element as (v, 3)."""
        ns = self.ns
        source = vertices
        if self.tag(vertices) == "vertices":
            position = next(i for i in vertices.findall(f"{ns}input")
                            if i.get("semantic") == "POSITION")
            source = self.find(position.get("source"))
        array = source.find(f"{ns}float_array")
        accessor = source.find(f"{ns}technique_common/{ns}accessor")
        stride = int(accessor.get("stride", "3")) if accessor is not None else 3
        values = np.array((array.text or "").split(), dtype=float)
        return values.reshape(-1, stride)[:, :3]


def _fans(polygons, triangles_only: bool) -> np.ndarray:
    if triangles_only:
        return polygons[0].reshape(-1, 3)
    out = [np.stack([np.full(len(p) - 2, p[0]), p[1:-1], p[2:]], axis=1)
           for p in polygons if len(p) >= 3]
    return np.concatenate(out) if out else np.zeros((0, 3), dtype=np.int64)


def _apply(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
