"""Mass properties of URDF links: the rigid union of links folded into one body
(``combine``), the test for inertias no rigid body has (``inertia_problem``) and
the ``--inertia`` policy for them (refuse, repair to ``nearest_valid_moments``,
accept)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING

import numpy as np

from .frames import Pose

if TYPE_CHECKING:
    from .parse import _Link

# the loader's thresholds for a valid inertia (model.loader.bodies, _Bodies.inertia)
PSD_TOLERANCE, TRIANGLE_TOLERANCE = 1e-12, 1e-9


@dataclass
class MassProperties:
    """Mass, centre of mass and central inertia, all in one frame's axes."""
    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def moved(self, pose: Pose) -> "MassProperties":
        """The same body seen from the frame in which ``pose`` = (R, p) places
        this one: com' = p + R com, I' = R I R^T (a central inertia turns,
        it is not shifted)."""
        R, p = pose
        return MassProperties(self.mass, p + R @ self.com, R @ self.inertia @ R.T)


def combine(parts: list[MassProperties]) -> MassProperties:
    """Rigid union of bodies given in one frame (parallel-axis theorem):

        m = sum m_i,   c = sum m_i c_i / m,
        I = sum [ I_i + m_i (|d_i|^2 E - d_i d_i^T) ],   d_i = c_i - c.
    """
    parts = [p for p in parts if p.mass > 0 or np.any(p.inertia)]
    mass = sum(p.mass for p in parts)
    if mass <= 0:
        return MassProperties(0.0, np.zeros(3), sum((p.inertia for p in parts), np.zeros((3, 3))))
    if len(parts) == 1:
        return parts[0]
    com = sum(p.mass * p.com for p in parts) / mass
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.com - com
        inertia += p.inertia + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return MassProperties(mass, com, inertia)


def inertia_problem(moments) -> str | None:
    """Why principal moments a <= b <= c belong to no rigid body (None if they do):
    not positive semidefinite (a < 0), or a + b < c (triangle inequality).
    Thresholds are the YAML loader's, so what passes here loads there."""
    a, b, c = moments
    scale = max(1.0, abs(a), abs(c))
    if a < -PSD_TOLERANCE * scale:
        return "is not positive semidefinite"
    if a + b < c - TRIANGLE_TOLERANCE * scale:
        return "breaks the triangle inequality I1 + I2 >= I3"
    return None


def nearest_valid_moments(moments) -> np.ndarray:
    """The principal moments closest (Euclidean) to ``moments`` that satisfy
    l_i + l_j >= l_k for every ordering (which implies l >= 0).

    The set of valid inertia tensors depends on the eigenvalues only, so the
    nearest valid tensor in the Frobenius norm keeps the eigenvectors and
    projects the eigenvalues; the projection onto this polyhedral cone is
    found by trying every set of active constraints (3 constraints, 8 sets)
    and keeping the nearest feasible candidate.
    """
    x = np.asarray(moments, dtype=float)
    normals = np.array([[1, 1, -1], [1, -1, 1], [-1, 1, 1]], dtype=float)
    best, distance = None, math.inf
    for k in range(4):
        for active in combinations(range(3), k):
            N = normals[list(active)]
            y = x - N.T @ np.linalg.solve(N @ N.T, N @ x) if k else x
            if (normals @ y >= -1e-15 * max(1.0, np.abs(y).max())).all():
                d = float(np.linalg.norm(y - x))
                if d < distance:
                    best, distance = y, d
    return np.maximum(best, 0.0)


def _principal_axes(link: _Link) -> np.ndarray:
    """Eigenvectors of the link's inertia in body axes, in the order of link.moments."""
    _, vectors = np.linalg.eigh(link.inertial.inertia)
    return vectors


class _InertiaPolicy:
    """The importer's ``--inertia`` policy (part of ``importer._Importer``)."""

    def checked_inertial(self, link: _Link, where: str) -> MassProperties:
        """The link's mass properties after the inertia policy (refuse, repair, accept)."""
        problem = inertia_problem(link.moments)
        if problem is None:
            return link.inertial
        a, b, c = link.moments
        shown = f"principal moments {a:.6g}, {b:.6g}, {c:.6g} kg m^2"
        if self.policy == "refuse" or (self.policy == "accept" and problem.startswith("is not")):
            options = ("--inertia repair replaces it by the nearest valid one"
                       if problem.startswith("is not") else
                       "--inertia repair replaces it by the nearest valid one, --inertia accept "
                       "keeps it")
            raise self.error(f"link {link.name!r}",
                             f"<inertia>: {shown}: {problem}; no rigid body has this inertia "
                             f"(import with {options}, with a warning)")
        if self.policy == "accept":
            link.accepted = True
            self.warnings.append(f"{self.source}: link {link.name!r}: <inertia> with {shown} "
                                 f"{problem}; kept as given (--inertia accept)")
            return link.inertial
        fixed = nearest_valid_moments(link.moments)
        R = _principal_axes(link)
        repaired = R @ np.diag(fixed) @ R.T
        change = float(np.linalg.norm(repaired - link.inertial.inertia))
        self.warnings.append(
            f"{self.source}: link {link.name!r}: <inertia> with {shown} {problem}; repaired to "
            f"the nearest valid inertia, principal moments {', '.join(f'{m:.6g}' for m in fixed)}"
            f" (changed by {change:.3g} kg m^2, {change / max(abs(c), 1e-300):.2%} of the "
            "largest moment; --inertia repair)")
        return MassProperties(link.inertial.mass, link.inertial.com, repaired)
