"""The robot drawn: links, joints and their axes, body frames, mass centres, names.

Every position comes from ``numeric.frames`` (the kinematics the equations
are derived from).  What is drawn, for each body:

- its **link**: a line from its frame origin to the joint of each child, or,
  for a body without children, to its tip (twice its centre of mass, the far
  end of a uniform bar); a prismatic body's travel from its joint to its
  origin is drawn as a wide translucent sleeve;
- its **joint**: a circle (revolute), square (prismatic) or cross (fixed) at
  the joint's location, with the **joint axis** as a purple arrow labelled
  with the displacement it measures (``q2 - q1``); an axis pointing out of a
  view's plane is a dot in a ring;
- its **frame**: x, y, z in red, green, blue at the frame origin;
- its **centre of mass**: a black-and-white disc, labelled with the body's name;
- its **contacts** and their forces (``contact_drawing``; ``Frame.newton``, metres
  per newton: the largest force of the run is drawn 0.3 of the robot's size long).

Views: a 3-D view and three projections on the world planes, oriented so
that "up" is against gravity (z when there is none): front (the first other
axis across, up), side (the second other axis across, up) and top.  A planar
robot (no drawn point ever leaves one world plane) gets that plane alone.
Every view keeps true proportions (equal scale on its two axes), fits the
robot with a margin, and shows gravity as an arrow.  An animation can draw
the path of each end of the chain (its tips) as a trace.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.joints import JOINT_TYPES
from ..numeric.frames import Poses, Skeleton
from .contact_drawing import ContactArtist

AXES = "xyz"
LINK, SLEEVE, AXIS, COM, TRACE = "#1f4e79", "#7fa7d1", "#8e44ad", "black", "#e67e22"
FRAME_COLORS = ("#d62728", "#2ca02c", "#1f77b4")
#: a joint's marker: a cross where it is welded, a square where it slides, a disc where it turns
JOINT_MARKERS = {word: ("X" if not kind.moving else "s" if kind.linear else "o")
                 for word, kind in JOINT_TYPES.items()}


@dataclass(frozen=True)
class View:
    title: str
    plane: tuple[int, int] | None      # world axes (horizontal, vertical); None: 3-D


def up_axis(gravity) -> int:
    """The world axis most nearly against gravity (z without gravity)."""
    g = np.asarray(gravity, dtype=float)
    return int(np.argmax(np.abs(g))) if np.abs(g).max() > 0 else 2


def views(gravity, normal: int | None = None) -> list[View]:
    """3-D, front, side and top, with "up" against gravity; for a robot that moves in
    the plane across world axis ``normal``, that plane alone (up against gravity
    when gravity lies in it)."""
    up = up_axis(gravity)
    name = {k: AXES[k] for k in range(3)}
    if normal is not None:
        h, v = (k for k in range(3) if k != normal)
        if h == up:
            h, v = v, h
        return [View(f"{name[h]}-{name[v]} plane (the robot moves in it)", (h, v))]
    h1, h2 = (k for k in range(3) if k != up)        # x before y before z
    return [View("3-D", None),
            View(f"front ({name[h1]}-{name[up]} plane)", (h1, up)),
            View(f"side ({name[h2]}-{name[up]} plane)", (h2, up)),
            View(f"top ({name[h1]}-{name[h2]} plane)", (h1, h2))]


def points(poses: Poses) -> np.ndarray:
    """Every drawn point of ``poses`` (any leading shape) as rows of 3."""
    return np.concatenate([a.reshape(-1, 3) for a in
                           (poses.origin, poses.joint, poses.tip, poses.com)]
                          + [np.zeros((1, 3))])


@dataclass(frozen=True)
class Frame:
    """The region the views show: the box ``low``..``high`` around every drawn
    point (a cube of half-size ``half`` around ``center`` in 3-D), and the
    lengths of the drawn axis arrows and frame triads."""
    low: np.ndarray
    high: np.ndarray
    arrow: float
    triad: float
    newton: float = 0.0          # m per N of a drawn contact force (0: none drawn)

    @property
    def center(self) -> np.ndarray:
        return (self.low + self.high) / 2

    @property
    def half(self) -> float:
        return float((self.high - self.low).max()) / 2 + self.arrow + 0.05 * self.size

    @property
    def size(self) -> float:
        return max(float((self.high - self.low).max()), 0.05)

    @classmethod
    def around(cls, poses: Poses, skeleton: Skeleton | None = None,
               largest_force: float = 0.0) -> "Frame":
        """The box around every drawn point of ``poses`` (and the spheres of the
        ``skeleton``'s contacts); forces up to ``largest_force`` N drawn 0.3 of its size."""
        pts = points(poses)
        if skeleton is not None and skeleton.contacts:
            from .contact_drawing import contact_extent

            pts = np.concatenate([pts, contact_extent(skeleton, poses)])
        pts = pts[np.isfinite(pts).all(axis=1)]
        low, high = pts.min(axis=0), pts.max(axis=0)
        size = max(float((high - low).max()), 0.05)
        newton = 0.3 * size / largest_force if largest_force > 0 else 0.0
        return cls(low, high, 0.22 * size, 0.12 * size, newton)


def link_path(skeleton: Skeleton, pose: Poses, i: int) -> np.ndarray:
    """The polyline of body i's link (NaN rows separate pieces)."""
    children = skeleton.children(i)
    ends = [pose.joint[k] for k in children] if children else [pose.tip[i]]
    rows = []
    for end in ends:
        rows += [pose.origin[i], end, np.full(3, np.nan)]
    return np.array(rows)


def _joined(pieces: list[np.ndarray]) -> np.ndarray:
    """Rows of pieces separated by NaN rows (one artist draws them all)."""
    if not pieces:
        return np.full((1, 3), np.nan)
    rows = []
    for piece in pieces:
        rows += [*piece, np.full(3, np.nan)]
    return np.array(rows)


class RobotArtist:
    """The robot in one view of one axes; ``update`` moves it to another pose."""

    def __init__(self, ax, view: View, skeleton: Skeleton, frame: Frame, labels: bool = True,
                 font: float = 8):
        self.ax, self.view, self.skeleton, self.frame = ax, view, skeleton, frame
        self.labels, self.font = labels, font
        self.three_d = view.plane is None
        plot = ax.plot
        nan = [np.nan]
        self.sleeves = plot(*([nan] * self.dims), color=SLEEVE, linewidth=7, alpha=0.55,
                            solid_capstyle="butt", zorder=2)[0]
        self.links = plot(*([nan] * self.dims), color=LINK, linewidth=3.2,
                          solid_capstyle="round", zorder=3, label="link")[0]
        self.triads = [plot(*([nan] * self.dims), color=c, linewidth=1.3, zorder=4,
                            label=f"frame {AXES[k]}")[0] for k, c in enumerate(FRAME_COLORS)]
        self.axes_lines = plot(*([nan] * self.dims), color=AXIS, linewidth=1.6, zorder=5,
                               label="joint axis")[0]
        self.axis_tips = plot(*([nan] * self.dims), linestyle="none", marker="o", markersize=2.5,
                              color=AXIS, zorder=5)[0]
        self.out_of_plane = plot(*([nan] * self.dims), linestyle="none", marker="o",
                                 markersize=13, markerfacecolor="none", markeredgecolor=AXIS,
                                 markeredgewidth=1.4, zorder=8)[0]
        self.joints = {kind: plot(*([nan] * self.dims), linestyle="none", marker=marker,
                                  markersize=8, markerfacecolor="white", markeredgecolor=LINK,
                                  markeredgewidth=1.6, zorder=7, label=f"{kind} joint")[0]
                       for kind, marker in JOINT_MARKERS.items()
                       if kind in skeleton.joint_types}
        self.coms = plot(*([nan] * self.dims), linestyle="none", marker="o", markersize=7,
                         markerfacecolor="white", markeredgecolor=COM, markeredgewidth=1.2,
                         zorder=8, label="centre of mass")[0]
        self.com_cores = plot(*([nan] * self.dims), linestyle="none", marker=".",
                              markersize=5, color=COM, zorder=9)[0]
        self.base = plot(*self._xy(np.zeros((1, 3))), linestyle="none", marker="^",
                         markersize=10, color="0.45", zorder=1, label="ground")[0]
        self.mounts = plot(*([nan] * self.dims), color="0.55", linewidth=2.4, zorder=1,
                           solid_capstyle="round")[0]      # ground to the first joints
        moving = [i for i, kind in enumerate(skeleton.joint_types) if JOINT_TYPES[kind].moving]
        self.names = []
        self.joint_names = []
        if labels:
            self.names = [self._text(name, fontsize=font - 1, color="black")
                          for name in skeleton.bodies]
            self.joint_names = [(i, self._text(skeleton.displacements[i], fontsize=font - 1,
                                               color=AXIS,
                                               style="italic")) for i in moving]
        if not self.three_d:
            self._static_2d()
        else:
            self._static_3d()
        self.contacts = ContactArtist(self) if skeleton.contacts else None

    @property
    def dims(self) -> int:
        return 3 if self.view.plane is None else 2

    def _xy(self, rows: np.ndarray):
        rows = np.asarray(rows, dtype=float).reshape(-1, 3)
        if self.three_d:
            return rows[:, 0], rows[:, 1], rows[:, 2]
        h, v = self.view.plane
        return rows[:, h], rows[:, v]

    def _text(self, text: str, **style):
        if self.three_d:
            return self.ax.text(np.nan, np.nan, np.nan, text, zorder=10, **style)
        return self.ax.text(np.nan, np.nan, text, zorder=10, ha="left", va="bottom",
                            clip_on=True, **style)

    def _set(self, line, rows) -> None:
        coords = self._xy(rows)
        if self.three_d:
            line.set_data_3d(*coords)
        else:
            line.set_data(*coords)

    def set_pieces(self, line, pieces: list[np.ndarray]) -> None:
        """Draw ``pieces`` (rows of points each) with the one artist ``line``."""
        self._set(line, _joined(pieces))

    def _place(self, text, xyz) -> None:
        if self.three_d:
            text.set_position_3d(tuple(xyz))
        else:
            h, v = self.view.plane
            text.set_position((xyz[h], xyz[v]))

    def _static_2d(self) -> None:
        ax, (h, v), f = self.ax, self.view.plane, self.frame
        half = max(f.high[h] - f.low[h], f.high[v] - f.low[v]) / 2 + f.arrow + 0.05 * f.size
        ax.set_xlim(f.center[h] - half, f.center[h] + half)     # square, around this
        ax.set_ylim(f.center[v] - half, f.center[v] + half)     # view's own content
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel(f"{AXES[h]} (m)", fontsize=self.font)
        ax.set_ylabel(f"{AXES[v]} (m)", fontsize=self.font)
        ax.tick_params(labelsize=self.font - 1)
        ax.grid(True, alpha=0.25, linewidth=0.5)
        ax.set_title(self.view.title, fontsize=self.font + 1)
        g = np.asarray(self.skeleton.gravity, dtype=float)[[h, v]]
        if np.linalg.norm(g) > 1e-9 * max(1.0, np.linalg.norm(self.skeleton.gravity)):
            d = 0.09 * g / np.linalg.norm(g)
            ax.annotate("", xy=(0.9 + d[0] / 2, 0.88 + d[1] / 2),
                        xytext=(0.9 - d[0] / 2, 0.88 - d[1] / 2), xycoords="axes fraction",
                        arrowprops={"arrowstyle": "-|>", "color": "0.3", "linewidth": 1.2})
            ax.annotate("g", (0.93, 0.93), xycoords="axes fraction", fontsize=self.font,
                        color="0.3")

    def _static_3d(self) -> None:
        ax, f = self.ax, self.frame
        for k, setter in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
            setter(f.center[k] - f.half, f.center[k] + f.half)
        ax.set_box_aspect((1, 1, 1))
        for k, setter in enumerate((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel)):
            setter(f"{AXES[k]} (m)", fontsize=self.font, labelpad=-2)
        ax.tick_params(labelsize=self.font - 1, pad=0)
        ax.view_init(elev=22, azim=-58, vertical_axis=AXES[up_axis(self.skeleton.gravity)])
        ax.set_title(self.view.title, fontsize=self.font + 1)

    def update(self, pose: Poses, forces=None) -> None:
        """Draw ``pose`` (one configuration) and, given, the contact ``forces``
        (contacts x 3, world axes, N)."""
        sk, f = self.skeleton, self.frame
        b = len(sk.bodies)
        self._set(self.links, _joined([link_path(sk, pose, i)[:-1] for i in range(b)]))
        self._set(self.mounts, _joined([np.array([np.zeros(3), pose.joint[i]])
                                        for i in range(b) if sk.parents[i] < 0]))
        sliding = [i for i in range(b) if JOINT_TYPES[sk.joint_types[i]].linear]
        self._set(self.sleeves, _joined([np.array([pose.joint[i], pose.origin[i]])
                                         for i in sliding]))
        for k, line in enumerate(self.triads):
            self._set(line, _joined([np.array([pose.origin[i],
                                               pose.origin[i] + f.triad * pose.R[i][:, k]])
                                     for i in range(b)]
                                    + [np.array([np.zeros(3), f.triad * np.eye(3)[k]])]))
        moving = [i for i in range(b) if JOINT_TYPES[sk.joint_types[i]].moving]
        in_plane, out = [], []
        for i in moving:
            a = pose.axis[i]
            if not self.three_d and np.hypot(*a[list(self.view.plane)]) < 0.25:
                out.append(i)
            else:
                in_plane.append(i)
        self._set(self.axes_lines, _joined([np.array([pose.joint[i],
                                                      pose.joint[i] + f.arrow * pose.axis[i]])
                                            for i in in_plane]))
        self._set(self.axis_tips, np.array([pose.joint[i] + f.arrow * pose.axis[i]
                                            for i in in_plane]).reshape(-1, 3))
        self._set(self.out_of_plane, np.array([pose.joint[i] for i in out]).reshape(-1, 3))
        for kind, line in self.joints.items():
            self._set(line, np.array([pose.joint[i] for i in range(b)
                                      if sk.joint_types[i] == kind]).reshape(-1, 3))
        self._set(self.coms, pose.com)
        self._set(self.com_cores, pose.com)
        offset = 0.03 * f.half
        for i, text in enumerate(self.names):
            self._place(text, pose.com[i] + offset)
        for i, text in self.joint_names:
            spot = pose.joint[i] + (f.arrow * pose.axis[i] if i in in_plane else 0)
            self._place(text, spot + offset)
        if self.contacts is not None:
            self.contacts.update(pose, forces)

    def moving(self) -> list:
        """The artists ``update`` changes (redrawn alone in an animation)."""
        return [self.sleeves, self.links, self.mounts, *self.triads, self.axes_lines,
                self.axis_tips,
                self.out_of_plane, *self.joints.values(), self.coms, self.com_cores,
                *(self.contacts.moving() if self.contacts is not None else ()),
                *self.names, *(text for _, text in self.joint_names)]

    def handles(self) -> list:
        """The artists worth a legend entry."""
        return [self.links, self.axes_lines, *self.joints.values(), self.coms, *self.triads,
                self.base, *(self.contacts.handles() if self.contacts is not None else ())]


def declutter(figure, artists: list["RobotArtist"]) -> None:
    """Hide the labels that would overlap one shown before them (body names first,
    then joint labels, view by view), so a 7-joint arm stays legible."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = figure.canvas if isinstance(figure.canvas, FigureCanvasAgg) else \
        FigureCanvasAgg(figure)
    from matplotlib.transforms import Bbox
    from mpl_toolkits.mplot3d import proj3d

    canvas.draw()                                    # lays the figure out
    renderer = canvas.get_renderer()
    for artist in artists:
        kept = []
        for text in [*artist.names, *(t for _, t in artist.joint_names)]:
            if not text.get_visible() or not text.get_text():
                continue
            if artist.three_d:        # where the projection puts it; its size estimated
                x, y, _ = proj3d.proj_transform(*text.get_position_3d(), artist.ax.get_proj())
                px, py = artist.ax.transData.transform((x, y))
                size = text.get_fontsize() * figure.dpi / 72
                box = Bbox.from_bounds(px, py, 0.62 * size * len(text.get_text()), 1.2 * size)
            else:
                box = text.get_window_extent(renderer).padded(1)
            if any(box.overlaps(other) for other in kept):
                text.set_visible(False)
            else:
                kept.append(box)


def robot_figure(skeleton: Skeleton, pose: Poses, title: str, frame: Frame | None = None,
                 labels: bool = True, normal: int | None = None):
    """The robot at ``pose`` in a 3-D view and the three projections, or in its plane
    alone when it moves in the plane across world axis ``normal`` (a Figure)."""
    import textwrap

    from matplotlib.figure import Figure

    frame = frame or Frame.around(pose, skeleton)
    chosen = views(skeleton.gravity, normal)
    single = len(chosen) == 1
    figure = Figure(figsize=(7.5, 7.2) if single else (10, 9.4), layout="constrained")
    artists = []
    for k, view in enumerate(chosen):
        ax = (figure.add_subplot(1, 1, 1) if single else
              figure.add_subplot(2, 2, k + 1, **({"projection": "3d"} if view.plane is None
                                                 else {})))
        artist = RobotArtist(ax, view, skeleton, frame, labels)
        artist.update(pose)
        artists.append(artist)
    handles = next(a for a in artists if not a.three_d).handles()
    figure.legend(handles=handles, labels=[h.get_label() for h in handles],
                  loc="outside lower center", ncols=min(5, len(handles)), fontsize=8,
                  frameon=False)
    figure.suptitle("\n".join(textwrap.wrap(title, 110)), fontsize=11)
    if labels:
        declutter(figure, artists)
    return figure


class Animation:
    """One figure redrawn pose after pose: a 3-D view and the front view (a planar
    robot: its plane), the path of every tip so far as a trace, the time above.

    The axes, ticks and grids are drawn once; each frame restores them and
    draws only the moving artists and the clock (blitting: ~10x faster than
    drawing the whole figure, whose layout alone costs more than a frame).
    ``size`` in inches at ``dpi`` (12.8 x 7.2 at 100: 1280 x 720 pixels);
    ``font``: the axis labels' size in points (names 1 less, the title 2 more).
    """

    def __init__(self, skeleton: Skeleton, frame: Frame, title: str, size=(12.8, 7.2),
                 dpi: int = 100, normal: int | None = None, font: float = 10):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.figure = Figure(figsize=size, dpi=dpi, layout="constrained")
        self.canvas = FigureCanvasAgg(self.figure)
        chosen = views(skeleton.gravity, normal)[:2]
        self.artists = []
        for k, view in enumerate(chosen):
            ax = self.figure.add_subplot(1, len(chosen), k + 1,
                                         **({"projection": "3d"} if view.plane is None else {}))
            self.artists.append(RobotArtist(ax, view, skeleton, frame, labels=True, font=font))
        self.tips = [i for i in range(len(skeleton.bodies)) if not skeleton.children(i)]
        self.path: list[np.ndarray] = []
        self.traces = [artist.ax.plot(*([[np.nan]] * artist.dims), color=TRACE, linewidth=1.4,
                                      alpha=0.85, zorder=6)[0] for artist in self.artists]
        self.title = title
        self.clock = self.figure.suptitle(f"{title}    t = 0000.00 s", fontsize=font + 2)
        self.background = None

    def _prepare(self) -> None:
        """Draw what never moves, once, and keep it."""
        for artist, trace in zip(self.artists, self.traces):
            for moving in [trace, *artist.moving()]:
                moving.set_animated(True)
        self.clock.set_animated(True)
        self.canvas.draw()                                   # runs the layout once
        self.figure.set_layout_engine("none")
        self.background = self.canvas.copy_from_bbox(self.figure.bbox)

    def frame(self, pose: Poses, t: float, note: str = "", forces=None) -> np.ndarray:
        """The image (rows x columns x RGB, uint8) of ``pose`` at time ``t`` (with the
        contact ``forces``, contacts x 3, when given)."""
        if self.background is None:
            self._prepare()
        self.canvas.restore_region(self.background)
        self.path.append(np.asarray(pose.tip)[self.tips])
        path = _joined([np.array([tips[j] for tips in self.path])
                        for j in range(len(self.tips))])
        for artist, trace in zip(self.artists, self.traces):
            artist.update(pose, forces)
            artist._set(trace, path)
            for moving in [trace, *artist.moving()]:
                artist.ax.draw_artist(moving)
        self.clock.set_text(f"{self.title}    t = {t:6.2f} s{note}")
        self.figure.draw_artist(self.clock)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()
