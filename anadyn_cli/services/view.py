"""The robot in 3-D in the browser: one self-contained HTML page (``anadyn view``).

``view(robot, run=...)`` builds a ``View``: the robot's shapes on its bodies,
and either a run to play or the data for live sliders.

- Shapes: a URDF's visuals (meshes STL, OBJ, COLLADA; boxes, cylinders,
  spheres; ``output.view.visuals`` finds the files, only inside the URDF's
  folder and its package roots); bodies without any get generated shapes,
  as every body of a YAML robot does: a cylinder from the body's origin to
  each child's joint (or to its link tip, twice its centre of mass), a
  sphere at a revolute joint, a box at a prismatic one.
- A run (``read_run``: simulate.csv or inverse.csv, columns t, the
  coordinates, then anything else) is played: at most MAX_FRAMES rows,
  evenly spaced, and for each every body's pose (3 x 4: rotation, origin;
  world axes) from ``numeric.frames``, the kinematics the dynamics are
  derived from.  The page does no kinematics.  Arrows, each 0.3 x the
  robot's size long at its largest size: every actuator whose effort column
  is in the run, along its joint axis at the joint (right-hand rule for a
  torque), red; every load's force at its point, from the file's expressions
  of t, q, dq at the run's rows (rates from its d<q> columns), purple;
  every contact's force (its ``<contact>_fn``, ``_ft1``, ``_ft2`` columns) where
  it acts, green.
- Contacts (a ``contacts`` section): each sphere on its body (a point: a small
  sphere), each ground plane a thin translucent box whose top face is the plane.
- Without a run, live mode: a slider per coordinate.  Each body's joint
  frame in its parent's frame, axis and displacement d = gains . q + offset
  go to the page, which turns the body by d.  This needs displacements
  affine in the coordinates and no loop constraints; for other robots the
  page shows the initial pose (``View.note`` says why).
"""
from __future__ import annotations

import math
import stat
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .. import files as output
from ..model.joints import JOINT_TYPES

MAX_FRAMES = 600
MAX_RUN_BYTES = 256 * 1024 * 1024
EFFORT_COLOR, LOAD_COLOR, CONTACT_FORCE_COLOR = "#d62728", "#9467bd", "#16a085"
CONTACT_COLOR = (0.09, 0.63, 0.52, 0.55)          # RGBA: the contact spheres
GROUND_COLOR = (0.55, 0.55, 0.55, 0.35)           # RGBA: the ground planes
PALETTE = ((0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.58, 0.4, 0.74),
           (0.55, 0.34, 0.29), (0.09, 0.75, 0.81), (0.74, 0.74, 0.13), (0.84, 0.15, 0.16))


@dataclass
class Run:
    """A run read from a CSV: times (N,), coordinates (N, n), and every column by name."""
    path: str
    t: np.ndarray
    q: np.ndarray
    columns: dict


@dataclass
class View:
    """What the page shows (``scene`` is its JSON) and what was left out (``warnings``)."""
    name: str
    title: str
    scene: dict
    warnings: list = field(default_factory=list)
    note: str = ""
    timings: dict = field(default_factory=dict)

    @property
    def playback(self) -> bool:
        return self.scene["live"] is None and len(self.scene["times"]) > 1

    def html(self) -> str:
        from ..output.view import page

        return page(self.scene, self.title, self.playback)

    def _repr_html_(self) -> str:
        """The page inline in a notebook (an iframe with the page as its srcdoc)."""
        import html

        return (f'<iframe srcdoc="{html.escape(self.html(), quote=True)}" '
                'style="width: 100%; height: 520px; border: 1px solid #ddd"></iframe>')

    def figures(self) -> dict:
        """Key figures (view.json)."""
        meshes = self.scene["meshes"]
        return {"robot": self.name, "frames": len(self.scene["times"]),
                "live": self.scene["live"] is not None, "shapes": len(self.scene["shapes"]),
                "meshes": len(meshes),
                "triangles": sum(p["triangles"] for m in meshes for p in m["parts"]),
                "arrows": [a["name"] for a in self.scene["arrows"]], "note": self.note,
                "warnings": self.warnings, "timings": self.timings}


def read_run(path: Path, coordinates) -> Run:
    """A simulate.csv or inverse.csv: a header row with t and every coordinate, then
    rows of finite numbers with t increasing.  ModelError (one line) otherwise."""
    path = Path(path)
    name = str(path)
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):         # a pipe or a device may never end
            raise ModelError("is not a regular file, expected a CSV file", source=name)
        if info.st_size > MAX_RUN_BYTES:
            raise ModelError(f"file is over {MAX_RUN_BYTES} bytes", source=name)
        lines = path.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise ModelError("no such file; write one with `anadyn simulate` or `anadyn "
                         "inverse`", source=name) from None
    except (OSError, UnicodeDecodeError) as err:
        raise ModelError(f"cannot read: {getattr(err, 'strerror', None) or err}",
                         source=name) from None
    header = [h.strip() for h in (lines[0].split(",") if lines else [])]
    missing = [c for c in ["t", *coordinates] if c not in header]
    if missing:
        raise ModelError(f"header has no column {', '.join(missing)}; expected t, "
                         f"{', '.join(coordinates)}, ... (simulate.csv or inverse.csv of "
                         "this robot)", source=name, line=1)
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",")
        try:
            values = [float(c) for c in cells]
        except ValueError:
            raise ModelError(f"expected {len(header)} numbers separated by commas",
                             source=name, line=number) from None
        if len(values) != len(header) or not all(map(math.isfinite, values)):
            raise ModelError(f"expected {len(header)} finite numbers, got {len(values)}",
                             source=name, line=number)
        rows.append(values)
    if not rows:
        raise ModelError("no rows after the header", source=name)
    table = np.array(rows)
    t = table[:, header.index("t")]
    if np.any(np.diff(t) < 0):
        raise ModelError("t decreases; rows must be in time order", source=name)
    q = table[:, [header.index(c) for c in coordinates]]
    return Run(name, t, q, {h: table[:, k] for k, h in enumerate(header)})


def frame_rows(t: np.ndarray, most: int = MAX_FRAMES) -> np.ndarray:
    """At most ``most`` row indices, evenly spaced, first and last included."""
    return np.unique(np.rint(np.linspace(0, len(t) - 1, min(len(t), most))).astype(int))


def view(robot, run: Run | None = None, urdf: Path | None = None, package_paths=(),
         use_cache: bool = True) -> View:
    """The view of ``robot`` (a validated ``Robot``), playing ``run`` if given; ``urdf``:
    the URDF file it was imported from, for its visuals (default: ``robot.source`` when
    that is a URDF file)."""
    from ..numeric.frames import frames

    timings: dict = {}
    start = time.perf_counter()
    kinematics = frames(robot, use_cache=use_cache)
    sk = kinematics.skeleton
    timings["kinematics"] = time.perf_counter() - start
    if run is None:
        t, q = np.zeros(1), np.array([sk.initial])
    else:
        chosen = frame_rows(run.t)
        t, q = run.t[chosen], run.q[chosen]
    poses = kinematics(q)
    reference = kinematics(np.array(sk.initial))
    points = np.concatenate([poses.joint.reshape(-1, 3), poses.tip.reshape(-1, 3),
                             poses.origin.reshape(-1, 3), np.zeros((1, 3))])
    extent = max(float(np.abs(points).max()), 1e-3)
    start = time.perf_counter()
    if urdf is None and str(robot.source).lower().endswith(".urdf"):
        urdf = Path(robot.source)
    shapes, meshes, warnings = _shapes(sk, reference, extent, urdf, package_paths)
    shapes += _contact_shapes(sk, extent)
    timings["meshes"] = time.perf_counter() - start
    live, note = (None, "") if run is not None else _live(robot)
    arrows = _arrows(robot, run, chosen, poses, extent) if run is not None else []
    if run is not None and sk.contacts:
        arrows += _contact_arrows(sk, run, chosen, poses, extent)
    gravity = np.array(sk.gravity, dtype=float)
    up = -gravity / np.linalg.norm(gravity) if np.linalg.norm(gravity) > 0 else np.array([0, 0, 1.])
    matrices = np.concatenate([poses.R, poses.origin[..., None]], axis=-1)    # (F, b, 3, 4)
    span = float(t[-1] - t[0])
    from ..output.view import b64

    scene = {"name": sk.name, "coordinates": list(sk.coordinates), "units": list(sk.units),
             "initial": list(sk.initial), "bodies": list(sk.bodies), "extent": extent,
             "up": up.tolist(), "times": t.tolist(), "q": b64(q, "<f4"),
             "poses": b64(matrices, "<f4"), "shapes": shapes, "meshes": meshes,
             "arrows": arrows, "speed": max(1.0, span / 20.0),
             "live": live, **_slider_range(robot, sk, extent)}
    if run is None:
        title = f"{sk.name}: " + ("live, a slider per coordinate" if live else "initial pose")
    else:
        title = f"{sk.name}: {Path(run.path).name}, {len(t)} frames over {span:g} s"
    return View(sk.name, title, scene, warnings, note, timings)


@output.one_set
def write(result: View, out: Path, name: str = "view.html") -> list[Path]:
    """view.html (or ``name``) and view.json in ``out``."""
    out = output.prepare_dir(out)
    page = out / name
    html = result.html().encode("utf-8")
    output.write_bytes(page, html)
    output.write_json(out / "view.json", {**result.figures(), "page": str(page),
                                          "bytes": len(html)})
    return [page, out / "view.json"]


# -- shapes ---------------------------------------------------------------------------
def _shapes(sk, reference, extent: float, urdf: Path | None,
            package_paths) -> tuple[list, list, list]:
    shapes, meshes, warnings = [], [], []
    drawn = set()
    if urdf is not None and urdf.is_file():
        from ..output.view import pack
        from ..output.view.meshes import read_mesh
        from ..output.view.visuals import GREY, visuals

        found = visuals(urdf, package_paths)
        warnings += found.warnings
        loaded: dict = {}
        for item in found.items:
            shape = {"body": item.owner, "kind": item.kind, "matrix": _flat(item.matrix),
                     "size": list(item.size), "color": list(item.color or GREY)}
            if item.kind == "mesh":
                if item.path not in loaded:
                    loaded[item.path] = len(meshes)
                    meshes.append({"file": item.path.name,
                                   "parts": [pack(p) for p in read_mesh(item.path)]})
                shape["mesh"] = loaded[item.path]
            shapes.append(shape)
            drawn.add(item.owner)
    radius = 0.025 * extent
    for i in range(len(sk.bodies)):
        if i not in drawn:
            shapes += _generated(i, sk, reference, radius)
    return shapes, meshes, warnings


def _generated(i: int, sk, pose, radius: float) -> list[dict]:
    """Cylinders from body i's origin to its children's joints (or its tip), and a
    sphere (a joint that turns: revolute) or a box (one that slides: prismatic) at its
    origin, all in body axes."""
    color = list(PALETTE[i % len(PALETTE)]) + [1.0]
    R, origin = pose.R[i], pose.origin[i]
    ends = [pose.joint[k] for k in sk.children(i)] or [pose.tip[i]]
    shapes = []
    for end in ends:
        local = R.T @ (end - origin)
        length = float(np.linalg.norm(local))
        if length > radius:
            shapes.append({"body": i, "kind": "cylinder", "size": [0.6 * radius, length],
                           "matrix": _flat(_along(local)), "color": color})
    kind = JOINT_TYPES[sk.joint_types[i]]
    if kind.angular:
        shapes.append({"body": i, "kind": "sphere", "size": [radius * 1.3],
                       "matrix": _flat(np.eye(4)), "color": color})
    elif kind.linear:
        shapes.append({"body": i, "kind": "box", "size": [radius * 2.4] * 3,
                       "matrix": _flat(np.eye(4)), "color": color})
    return shapes


def _contact_shapes(sk, extent: float) -> list[dict]:
    """Each contact's sphere (a point: a small one) on its body, and each ground plane as
    a thin translucent box on the ground, 4 ``extent`` across, its top face the plane
    (a backdrop: the camera frames the robot without it)."""
    shapes, seen = [], set()
    for c in sk.contact_list():
        place = np.eye(4)
        place[:3, 3] = c.centre
        shapes.append({"body": c.body, "kind": "sphere",
                       "size": [c.radius if c.radius > 0 else 0.01 * extent],
                       "matrix": _flat(place), "color": list(CONTACT_COLOR)})
        if c.partner is not None or (tuple(c.normal), c.height) in seen:
            continue
        seen.add((tuple(c.normal), c.height))
        n = np.asarray(c.normal, dtype=float)
        thickness = 0.01 * extent
        plane = np.eye(4)
        plane[:3, :3] = np.column_stack([*(np.asarray(v, dtype=float) for v in c.tangents), n])
        plane[:3, 3] = (c.height - thickness / 2) * n
        shapes.append({"body": -1, "kind": "box", "size": [4 * extent, 4 * extent, thickness],
                       "matrix": _flat(plane), "color": list(GROUND_COLOR), "backdrop": True})
    return shapes


def _contact_arrows(sk, run: Run, chosen: np.ndarray, poses, extent: float) -> list[dict]:
    """The contact forces of the run (its ``<contact>_fn``, ``_ft1``, ``_ft2`` columns)
    where each acts (``numeric.frames.Contact.force_point``), green."""
    from ..output.contact_drawing import contact_forces

    forces = contact_forces(sk, poses, {name: values[chosen]
                                        for name, values in run.columns.items()})
    arrows = []
    for k, c in enumerate(sk.contact_list()):
        if f"{c.name}_fn" in run.columns:
            arrows.append(_arrow(f"contact {c.name}", "N", c.force_point(poses),
                                 forces[:, k], extent, CONTACT_FORCE_COLOR))
    return [a for a in arrows if a is not None]


def _along(v: np.ndarray) -> np.ndarray:
    """A frame at v/2 whose z axis points along v (for a cylinder from 0 to v)."""
    z = v / np.linalg.norm(v)
    helper = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    matrix = np.eye(4)
    matrix[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    matrix[:3, 3] = v / 2
    return matrix


def _flat(matrix: np.ndarray) -> list:
    """A 4 x 4 matrix as 16 numbers, row by row."""
    return [float(x) for x in np.asarray(matrix, dtype=float).reshape(-1)]


# -- arrows and live mode -------------------------------------------------------------
def _arrows(robot, run: Run, chosen: np.ndarray, poses, extent: float) -> list[dict]:
    """Actuator efforts along their joint axes at the joints (red), then the loads'
    forces at their points (purple), each 0.3 x ``extent`` long at its largest size."""
    index = {b.name: i for i, b in enumerate(robot.bodies)}
    arrows = []
    for actuator in robot.actuators:
        if actuator.name in run.columns:
            i = index[actuator.body]
            effort = run.columns[actuator.name][chosen]
            arrows.append(_arrow(actuator.name, actuator.unit, poses.joint[:, i],
                                 poses.axis[:, i] * effort[:, None], extent, EFFORT_COLOR))
    for k, load in enumerate(robot.loads):
        values = _load_values(robot, load, run, chosen)
        if values is not None:
            i = index[load.body]
            point, force = values
            origins = poses.origin[:, i] + np.einsum("fij,fj->fi", poses.R[:, i], point)
            if load.frame == "body":
                force = np.einsum("fij,fj->fi", poses.R[:, i], force)
            arrows.append(_arrow(f"load {k + 1} on {load.body}", "N", origins, force, extent,
                                 LOAD_COLOR))
    return [a for a in arrows if a is not None]


def _arrow(name: str, unit: str, origins, vectors, extent: float, color: str) -> dict | None:
    from ..output.view import b64

    peak = float(np.linalg.norm(vectors, axis=1).max())
    if peak == 0:
        return None
    return {"name": name, "unit": unit, "peak": peak, "color": color,
            "origins": b64(origins, "<f4"), "vectors": b64(vectors / peak * 0.3 * extent, "<f4")}


def _load_values(robot, load, run: Run, chosen: np.ndarray):
    """(point, force), each (frames, 3): the load's expressions of t, q, dq evaluated at
    the run's rows (rates from its d<q> columns); None when the run lacks one."""
    values = robot.parameter_substitution()
    columns = {"t": run.t[chosen]}
    for c in robot.coordinates:
        for name in (c.name, "d" + c.name):
            if name in run.columns:
                columns[name] = run.columns[name][chosen]
    rows = []
    for expression in (*load.point, *load.force):
        e = expression.xreplace(values)
        if any(s.name not in columns for s in e.free_symbols):
            return None
        symbols = sorted(e.free_symbols, key=lambda s: s.name)
        rows.append([float(e.xreplace(dict(zip(symbols, row))))
                     for row in zip(*(columns[s.name] for s in symbols))] if symbols
                    else [float(e)] * len(chosen))
    table = np.array(rows).T
    return table[:, :3], table[:, 3:]


def _live(robot) -> tuple[list | None, str]:
    """Per body: parent, joint frame in the parent's frame (4 x 4), axis, type and
    d = gains . q + offset; or None and why when some displacement is not affine
    in the coordinates or the robot has loop constraints."""
    from ..model.urdf import rpy_matrix

    if robot.constraints is not None:
        return None, "loop constraints: the coordinates are not independent; the initial " \
                     "pose is shown (give a run to play)"
    values = robot.parameter_substitution()
    names = {b.name: i for i, b in enumerate(robot.bodies)}
    joints = []
    for body in robot.bodies:
        joint = body.joint
        d = joint.displacement.xreplace(values)
        gains = [d.diff(s) for s in robot.q]
        if any(g.free_symbols for g in gains):
            return None, f"{body.name}'s displacement {joint.displacement} is not affine in " \
                         "the coordinates; the initial pose is shown (give a run to play)"
        offset = d.xreplace({s: 0 for s in robot.q})
        matrix = np.eye(4)
        matrix[:3, :3] = rpy_matrix([float(a.xreplace(values)) for a in joint.rpy])
        matrix[:3, 3] = [float(a.xreplace(values)) for a in joint.origin]
        joints.append({"parent": names.get(body.parent, -1), "type": joint.type,
                       "matrix": _flat(matrix),
                       "axis": [float(a.xreplace(values)) for a in joint.axis],
                       "gains": [float(g) for g in gains], "offset": float(offset)})
    return joints, ""


def _slider_range(robot, sk, extent: float) -> dict:
    """Slider ends per coordinate: the limits of the joint it drives, else its
    initial value +- pi (angles) or +- the robot's size (lengths)."""
    values = robot.parameter_substitution()
    lower, upper = [], []
    for c, unit, initial in zip(robot.coordinates, sk.units, sk.initial):
        span = math.pi if unit == "rad" else extent
        low, high = initial - span, initial + span
        for body in robot.bodies:
            limits = body.joint.limits
            if body.joint.displacement == c.symbol and limits.lower is not None \
                    and limits.upper is not None:
                low, high = (float(v.xreplace(values)) for v in (limits.lower, limits.upper))
                break
        lower.append(low)
        upper.append(high)
    return {"lower": lower, "upper": upper}
