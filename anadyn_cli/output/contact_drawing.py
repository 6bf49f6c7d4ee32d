"""Contacts drawn (a ``contacts`` section): each sphere as its outline (in 3-D two great
circles), a point as a small diamond, each ground plane as a grey line in a projection
that cuts it (a translucent square in 3-D), and in an animation the contact forces as
red arrows from where each acts (``numeric.frames.Contact.force_point``), all on one
scale (``Frame.newton``, metres per newton)."""
from __future__ import annotations

import numpy as np

from ..numeric.frames import Poses, Skeleton

CONTACT, FORCE, GROUND = "#16a085", "#c0392b", "0.45"
CIRCLE = np.linspace(0.0, 2 * np.pi, 41)


def contact_extent(skeleton: Skeleton, poses: Poses) -> np.ndarray:
    """Rows of 3: each contact sphere's centre +- its radius along the world axes, at
    every configuration of ``poses``."""
    rows = []
    for c in skeleton.contact_list():
        centre = c.world_centre(poses).reshape(-1, 3)
        rows += [centre + c.radius * s * e for e in np.eye(3) for s in (-1, 1)]
    return np.concatenate(rows) if rows else np.zeros((0, 3))


def contact_forces(skeleton: Skeleton, poses: Poses, columns: dict) -> np.ndarray:
    """(..., contacts, 3): each contact's force in world axes, from the run's columns
    ``<name>_fn``, ``_ft1``, ``_ft2`` (``columns``: name -> values, one per
    configuration of ``poses``): f = fn n + ft1 t1 + ft2 t2 on a ground; between two
    spheres fn n alone (their friction column is a magnitude, its direction turns).
    A contact without its columns gets no force (zeros)."""
    out = np.zeros(poses.origin.shape[:-2] + (len(skeleton.contacts), 3))
    for k, c in enumerate(skeleton.contact_list()):
        if f"{c.name}_fn" not in columns:
            continue
        fn = np.asarray(columns[f"{c.name}_fn"], dtype=float)[..., None]
        out[..., k, :] = fn * c.normal_at(poses)
        if c.partner is None:
            for key, tangent in zip(("_ft1", "_ft2"), c.tangents):
                values = np.asarray(columns.get(c.name + key, 0.0), dtype=float)[..., None]
                out[..., k, :] += values * np.asarray(tangent, dtype=float)
    return out


class ContactArtist:
    """The contacts in one view of a ``drawing.RobotArtist`` (``owner``)."""

    def __init__(self, owner):
        self.owner, self.items = owner, owner.skeleton.contact_list()
        plot, nan = owner.ax.plot, [[np.nan]] * owner.dims
        self.spheres = plot(*nan, color=CONTACT, linewidth=1.4, zorder=6, label="contact")[0]
        self.points = plot(*nan, linestyle="none", marker="D", markersize=4, color=CONTACT,
                           zorder=6)[0]
        self.forces = plot(*nan, color=FORCE, linewidth=2.0, zorder=9,
                           label="contact force")[0]
        self.tips = plot(*nan, linestyle="none", marker="o", markersize=3.5, color=FORCE,
                         zorder=9)[0]
        self._grounds()

    def _grounds(self) -> None:
        """Each ground plane of the contacts, drawn once: its trace across a projection
        (none where the plane is parallel to it), a translucent square in 3-D."""
        f = self.owner.frame
        seen = set()
        for c in self.items:
            if c.partner is not None or (tuple(c.normal), c.height) in seen:
                continue
            seen.add((tuple(c.normal), c.height))
            n = np.asarray(c.normal, dtype=float)
            foot = f.center - (n @ f.center - c.height) * n     # the plane's point nearest
            if self.owner.three_d:
                from mpl_toolkits.mplot3d.art3d import Poly3DCollection

                t1, t2 = (np.asarray(v, dtype=float) * f.half for v in c.tangents)
                square = [foot + a * t1 + b * t2 for a, b in ((-1, -1), (1, -1), (1, 1),
                                                               (-1, 1))]
                self.owner.ax.add_collection3d(Poly3DCollection([square], facecolor=GROUND,
                                                          alpha=0.18, edgecolor="none"))
                continue
            h, v = self.owner.view.plane
            across = np.array([-n[v], n[h]])
            if np.linalg.norm(across) < 1e-9:
                continue
            across /= np.linalg.norm(across)
            spot = np.array([foot[h], foot[v]])
            ends = np.array([spot - 4 * f.half * across, spot + 4 * f.half * across])
            self.owner.ax.plot(ends[:, 0], ends[:, 1], color=GROUND, linewidth=2.0, zorder=1,
                         label="ground")
            below = 0.04 * f.size * np.array([n[h], n[v]])
            band = np.array([ends[0], ends[1], ends[1] - below, ends[0] - below])
            self.owner.ax.fill(band[:, 0], band[:, 1], color=GROUND, alpha=0.2, linewidth=0,
                         zorder=1)

    def _outline(self, centre: np.ndarray, radius: float, normal) -> list[np.ndarray]:
        """A sphere's outline: the circle in the view's plane, or in 3-D the circle about
        the ground's normal (z for a pair) and one across it."""
        if not self.owner.three_d:
            h, v = self.owner.view.plane
            e_h, e_v = np.eye(3)[h], np.eye(3)[v]
            return [centre + radius * (np.outer(np.cos(CIRCLE), e_h)
                                       + np.outer(np.sin(CIRCLE), e_v))]
        n = np.asarray(normal if len(normal) else (0.0, 0.0, 1.0), dtype=float)
        a = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
        a /= np.linalg.norm(a)
        b = np.cross(n, a)
        return [centre + radius * (np.outer(np.cos(CIRCLE), u) + np.outer(np.sin(CIRCLE), w))
                for u, w in ((a, b), (a, n))]

    def update(self, pose: Poses, forces) -> None:
        """Draw the contacts at ``pose`` and, given, their ``forces`` (contacts x 3, N)."""
        spheres, dots, arrows, tips = [], [], [], []
        for k, c in enumerate(self.items):
            centre = c.world_centre(pose)
            if c.radius > 0:
                spheres += self._outline(centre, c.radius, c.normal)
            else:
                dots.append(centre)
            if forces is not None and self.owner.frame.newton > 0:
                start = c.force_point(pose)
                end = start + self.owner.frame.newton * np.asarray(forces[k], dtype=float)
                if np.linalg.norm(end - start) > 1e-3 * self.owner.frame.size:
                    arrows.append(np.array([start, end]))
                    tips.append(end)
        self.owner.set_pieces(self.spheres, spheres)
        self.owner._set(self.points, np.array(dots).reshape(-1, 3))
        self.owner.set_pieces(self.forces, arrows)
        self.owner._set(self.tips, np.array(tips).reshape(-1, 3))

    def moving(self) -> list:
        return [self.spheres, self.points, self.forces, self.tips]

    def handles(self) -> list:
        return (([self.spheres] if any(c.radius > 0 for c in self.items) else [])
                + ([self.forces] if self.owner.frame.newton > 0 else []))
