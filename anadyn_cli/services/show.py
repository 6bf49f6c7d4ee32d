"""The robot drawn at one pose (``show``) and animated along a run (``animate``).

Positions come from ``numeric.frames``: the kinematics the equations of
motion are derived from, turned into a vectorized function.  ``show.json``
lists every drawn point, so a drawing can be checked by numbers too.

Animation: at most MAX_FRAMES frames, evenly spaced over the run, played in
real time when that stays between MIN_FRAME_MS per frame and MAX_PLAYBACK s
in all (faster otherwise, and the title says how much faster); the time is
in the title of every frame.  animate.gif is always written (Pillow, which
Matplotlib brings); animate.mp4 too when ``ffmpeg`` is on the PATH.  Frames
are 1280 x 720 pixels by default, the smallest text 9 points at 100 dpi (12
pixels).

Views that carry information: a robot whose every drawn point stays in one
world plane, at its initial pose and at PLANAR_SAMPLES random poses, is
drawn in that plane alone (``plane_normal``).
"""
from __future__ import annotations

import io
import math
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SettingError
from ..numeric.frames import Frames, Poses, Skeleton
from .. import progress
from ..output import contact_drawing, drawing, plots
from .. import files as output

MAX_FRAMES = 150
MIN_FRAME_MS = 40          # 25 frames per second at most
MAX_PLAYBACK = 20.0        # s: longer runs play faster than real time
PLANAR_SAMPLES = 8         # random poses that must stay in the plane of a planar robot
FRAME_SIZE = (12.8, 7.2)   # inches of an animation frame, at FRAME_DPI
FRAME_DPI = 100
FRAME_FONT = 10            # points, the frames' axis labels
DEGREE_SUFFIXES = ("deg", "°")


# -- poses ---------------------------------------------------------------------------
def parse_at(skeleton: Skeleton, items) -> np.ndarray:
    """The initial coordinates with ``items`` (``q1=0.3``, ``q2=pi/4``, ``q1=30deg``;
    several in one item separated by commas) put in; ModelError naming the item."""
    from ..model import expressions

    q = np.array(skeleton.initial, dtype=float)
    names = list(skeleton.coordinates)
    for item in items or ():
        for part in (p.strip() for p in str(item).split(",")):
            if not part:
                continue
            name, sign, text = part.partition("=")
            name, text = name.strip(), text.strip()
            if not sign or not name or not text:
                raise SettingError("at", f"{part}: expected COORDINATE=VALUE, e.g. "
                                 f"{names[0]}=0.5 or {names[0]}=30deg")
            if name not in names:
                raise SettingError("at", f"{part}: unknown coordinate {name!r}; coordinates: "
                                 f"{', '.join(names)}")
            i = names.index(name)
            degrees = text.endswith(DEGREE_SUFFIXES)
            if degrees:
                if skeleton.units[i] != "rad":
                    raise SettingError("at", f"{part}: {name} is a length in m; degrees apply "
                                     "to angles")
                text = text[:-3] if text.endswith("deg") else text[:-1]
            try:
                value = float(expressions.parse(text.strip(), {}))
            except (expressions.ExpressionError, TypeError, ValueError) as err:
                raise SettingError("at", f"{part}: {err}") from None
            if not math.isfinite(value):
                raise SettingError("at", f"{part}: not a finite number")
            q[i] = math.radians(value) if degrees else value
    return q


def pose_text(skeleton: Skeleton, q) -> str:
    """``q1 = -10°, q2 = 30°, q3 = 0.25 m``."""
    parts = []
    for name, unit, value in zip(skeleton.coordinates, skeleton.units, q):
        if unit == "rad":
            parts.append(f"{name} = {math.degrees(value) + 0.0:.4g}°")
        else:
            parts.append(f"{name} = {value + 0.0:.4g} {unit}")
    return ", ".join(parts)


def plane_normal(frames: Frames) -> int | None:
    """The world axis (0, 1, 2) along which no drawn point of the robot ever moves,
    over the initial pose and PLANAR_SAMPLES random ones (angles in -pi..pi,
    lengths within 0.5 m of the initial value): the robot is planar, in the plane
    across that axis.  None for a robot that moves in 3-D."""
    sk = frames.skeleton
    rng = np.random.default_rng(0)
    initial = np.array(sk.initial, dtype=float)
    spread = np.where(np.array(sk.units) == "rad", np.pi, 0.5)
    q = np.vstack([initial, initial + rng.uniform(-1, 1, (PLANAR_SAMPLES, len(initial)))
                   * spread])
    pts = drawing.points(frames(q))
    pts = pts[np.isfinite(pts).all(axis=1)]
    extent = np.ptp(pts, axis=0)
    flat = [k for k in range(3) if extent[k] <= 1e-9 * max(1.0, extent.max())]
    return flat[0] if len(flat) == 1 else None


@dataclass
class Drawing:
    skeleton: Skeleton
    q: np.ndarray
    pose: Poses
    initial: bool                        # the file's initial pose
    timings: dict = field(default_factory=dict)
    normal: int | None = None            # a planar robot: the world axis across its plane

    def title(self) -> str:
        where = "initial pose" if self.initial else "pose"
        return f"{self.skeleton.name}, {where}: {pose_text(self.skeleton, self.q)}"

    def figure(self, labels: bool = True):
        """The drawing as a Matplotlib Figure (the global backend is not touched),
        titled with the robot and the command (the pose is in show.json)."""
        return drawing.robot_figure(self.skeleton, self.pose, f"{self.skeleton.name}: show",
                                    labels=labels, normal=self.normal)


def draw(frames: Frames, at=()) -> Drawing:
    """The robot at its initial pose with ``at`` put in."""
    q = parse_at(frames.skeleton, at)
    return Drawing(frames.skeleton, q, frames(q), not at, normal=plane_normal(frames))


def contact_points(skeleton: Skeleton, pose: Poses) -> dict:
    """Each contact's sphere centre and radius, and its ground or partner (show.json)."""
    found = {}
    for c in skeleton.contact_list():
        found[c.name] = {"body": skeleton.bodies[c.body], "centre": c.world_centre(pose).tolist(),
                         "radius": c.radius}
        if c.partner is None:
            found[c.name]["ground"] = {"normal": list(c.normal), "height": c.height,
                                       "gap": float(np.dot(c.normal, c.world_centre(pose))
                                                    - c.height - c.radius)}
        else:
            found[c.name]["partner"] = {"body": skeleton.bodies[c.partner],
                                        "centre": c.partner_world_centre(pose).tolist(),
                                        "radius": c.partner_radius}
    return found


def points(d: Drawing) -> dict:
    """Every drawn point, body by body (show.json)."""
    pose, sk = d.pose, d.skeleton
    bodies = {}
    for i, name in enumerate(sk.bodies):
        bodies[name] = {"parent": sk.bodies[sk.parents[i]] if sk.parents[i] >= 0 else "ground",
                        "joint_type": sk.joint_types[i],
                        "displacement": sk.displacements[i],
                        "joint": pose.joint[i].tolist(), "origin": pose.origin[i].tolist(),
                        "axis": pose.axis[i].tolist(), "com": pose.com[i].tolist(),
                        "link_end": [pose.joint[k].tolist() for k in sk.children(i)]
                        or [pose.tip[i].tolist()],
                        "R": pose.R[i].tolist()}
    return bodies


@output.one_set
def write_drawing(d: Drawing, out: Path, plot_format: str = "png") -> list[Path]:
    """show.png (or .svg, .pdf) and show.json in ``out``."""
    out = output.prepare_dir(out)
    with progress.task(f"drawing {d.skeleton.name}"):
        start = time.perf_counter()
        written = [plots.plot_path(out, "show", plot_format)]
        plots.write_figure(written[0], d.figure())
        d.timings["draw"] = time.perf_counter() - start
    written.append(out / "show.json")
    output.write_json(written[-1], {
        "robot": d.skeleton.name, "initial_pose": d.initial,
        "pose": dict(zip(d.skeleton.coordinates, d.q.tolist())),
        "units": dict(zip(d.skeleton.coordinates, d.skeleton.units)),
        "bodies": points(d), **({"contacts": contact_points(d.skeleton, d.pose)}
                                if d.skeleton.contacts else {}),
        "timings": d.timings})
    return written


# -- animation -----------------------------------------------------------------------
def read_run(path: Path, skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray, dict]:
    """(t, q rows x n, the contact force columns there: name -> values) from a run's CSV
    (simulate.csv, inverse.csv: a ``t`` column and one per coordinate of ``skeleton``);
    ModelError naming the file otherwise."""
    import csv

    from ..errors import ModelError

    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise ModelError(f"cannot read it: {err}", source=str(path)) from None
    header = rows[0] if rows else []
    wanted = ["t", *skeleton.coordinates]
    missing = [name for name in wanted if name not in header]
    if missing:
        raise ModelError(f"no column {missing[0]!r}: a simulate.csv or inverse.csv of "
                         f"{skeleton.name} has {', '.join(wanted)}", source=str(path))
    forces = [f"{c['name']}{part}" for c in skeleton.contacts
              for part in ("_fn", "_ft1", "_ft2") if f"{c['name']}{part}" in header]
    columns = [header.index(name) for name in [*wanted, *forces]]
    try:
        data = np.array([[float(row[k]) for k in columns] for row in rows[1:]])
    except (ValueError, IndexError):
        raise ModelError("a row that is not numbers in every column", source=str(path)) \
            from None
    if len(data) < 2 or not np.isfinite(data).all() or (np.diff(data[:, 0]) <= 0).any():
        raise ModelError("expected two or more rows of finite numbers with t increasing",
                         source=str(path))
    n = len(wanted)
    return data[:, 0], data[:, 1:n], {name: data[:, n + k] for k, name in enumerate(forces)}


@dataclass
class Plan:
    """Which rows become frames and how fast they play."""
    rows: np.ndarray          # indices into the run's rows
    frame_ms: int             # display time of one frame
    speed: float              # simulated seconds per real second

    @property
    def note(self) -> str:
        return "" if abs(self.speed - 1) < 0.05 else f"  ({self.speed:.3g}x speed)"


def plan(t: np.ndarray, max_frames: int = MAX_FRAMES) -> Plan:
    """Frames evenly spaced in time over the run (real time when it fits)."""
    span = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    if span <= 0:
        return Plan(np.zeros(1, dtype=int), 1000, 1.0)
    count = int(min(max_frames, len(t), math.floor(span * 1000 / MIN_FRAME_MS) + 1))
    count = max(count, 2)
    wanted = np.linspace(t[0], t[-1], count)
    rows = np.unique(np.clip(np.searchsorted(t, wanted - 1e-12 * max(1.0, span)), 0,
                             len(t) - 1))
    playback = min(span, MAX_PLAYBACK)
    frame_ms = max(MIN_FRAME_MS, int(round(playback * 1000 / (len(rows) - 1) / 10)) * 10)
    speed = span / (frame_ms * (len(rows) - 1) / 1000)
    return Plan(rows, frame_ms, speed)


@dataclass
class Animation:
    skeleton: Skeleton
    times: np.ndarray
    plan: Plan
    images: list                      # uint8 arrays, rows x columns x 3
    title: str
    timings: dict = field(default_factory=dict)
    computation: dict = field(default_factory=dict)   # the simulation's (numeric.build)


def animate(frames: Frames, t: np.ndarray, q: np.ndarray, title: str,
            max_frames: int = MAX_FRAMES, size=FRAME_SIZE, font: float = FRAME_FONT,
            dpi: int = FRAME_DPI, columns: dict | None = None) -> Animation:
    """Frames of the robot moving through ``q`` (rows x n) at times ``t``: ``size``
    in inches at ``dpi``, ``font`` the axis labels' size in points; the contact forces
    drawn from the run's ``columns`` (name -> values per row: ``<contact>_fn``, ...)."""
    start = time.perf_counter()
    chosen = plan(t, max_frames)
    poses = frames(q[chosen.rows])
    forces = None
    if columns and frames.skeleton.contacts:
        forces = contact_drawing.contact_forces(frames.skeleton, poses, {
            name: np.asarray(values)[chosen.rows] for name, values in columns.items()})
    largest = float(np.linalg.norm(forces, axis=-1).max()) if forces is not None else 0.0
    box = drawing.Frame.around(poses, frames.skeleton, largest)
    movie = drawing.Animation(frames.skeleton, box, title, size=size, dpi=dpi,
                              normal=plane_normal(frames), font=font)
    images = []
    with progress.task(f"drawing {len(chosen.rows)} frames of {frames.skeleton.name}",
                       total=len(chosen.rows)) as step:
        for j, k in enumerate(chosen.rows):
            images.append(movie.frame(poses.at(j), float(t[k]), chosen.note,
                                      None if forces is None else forces[j]))
            step.advance()
    return Animation(frames.skeleton, t[chosen.rows], chosen, images, title,
                     {"frames": time.perf_counter() - start})


def gif_bytes(animation: Animation) -> bytes:
    """The frames as a looping GIF (one palette for all frames, from the last one,
    which has every colour, the whole tip trace included: no flicker)."""
    from PIL import Image

    last = Image.fromarray(animation.images[-1]).quantize(colors=128,
                                                          method=Image.Quantize.MEDIANCUT)
    images = [Image.fromarray(a).quantize(palette=last, dither=Image.Dither.NONE)
              for a in animation.images]
    buffer = io.BytesIO()
    images[0].save(buffer, format="GIF", save_all=True, append_images=images[1:],
                   duration=animation.plan.frame_ms, loop=0, disposal=1)
    return buffer.getvalue()


def mp4_writer() -> str | None:
    """The ffmpeg executable, if there is one."""
    return shutil.which("ffmpeg")


def write_mp4(animation: Animation, path: Path, ffmpeg: str) -> None:
    """The frames as H.264 MP4 through ffmpeg, written to a temporary file in the
    same folder and renamed into place (whole or not at all)."""
    height, width = animation.images[0].shape[:2]
    fps = 1000.0 / animation.plan.frame_ms
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".mp4")
    os.close(handle)
    try:
        command = [ffmpeg, "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24",
                   "-s", f"{width}x{height}", "-r", f"{fps:.6g}", "-i", "-",
                   "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p",
                   "-c:v", "libx264", "-movflags", "+faststart", temporary]
        data = b"".join(np.ascontiguousarray(a).tobytes() for a in animation.images)
        done = subprocess.run(command, input=data, capture_output=True, timeout=600)
        if done.returncode != 0 or not os.path.getsize(temporary):
            message = done.stderr.decode(errors="replace").strip().splitlines()
            raise OSError(f"ffmpeg failed: {message[-1] if message else done.returncode}")
        os.chmod(temporary, output.file_mode())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


@output.one_set
def write_animation(animation: Animation, out: Path, mp4: bool = True) -> tuple[list[Path], str]:
    """animate.gif (+ animate.mp4 when ffmpeg is there) and animate.json; the second
    value says what happened to the MP4."""
    out = output.prepare_dir(out)
    start = time.perf_counter()
    with progress.task(f"writing animate.gif ({len(animation.images)} frames)"):
        written = [out / "animate.gif"]
        output.write_bytes(written[0], gif_bytes(animation))
    mp4_note = "mp4: not asked for"
    if mp4:
        ffmpeg = mp4_writer()
        if ffmpeg is None:
            mp4_note = "mp4: no ffmpeg on the PATH, GIF only"
        else:
            try:
                with progress.task("writing animate.mp4 (ffmpeg)"):
                    write_mp4(animation, out / "animate.mp4", ffmpeg)
                written.append(out / "animate.mp4")
                mp4_note = "mp4: written by ffmpeg"
            except (OSError, subprocess.SubprocessError) as err:
                mp4_note = f"mp4: not written ({err})"
    animation.timings["write"] = time.perf_counter() - start
    written.append(out / "animate.json")
    height, width = animation.images[0].shape[:2]
    output.write_json(written[-1], {
        "robot": animation.skeleton.name, **animation.computation,
        "frames": len(animation.images),
        "frame_ms": animation.plan.frame_ms, "speed": animation.plan.speed,
        "t_first": float(animation.times[0]), "t_last": float(animation.times[-1]),
        "width": width, "height": height, "mp4": mp4_note, "timings": animation.timings})
    return written, mp4_note
