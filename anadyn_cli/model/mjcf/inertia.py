"""Mass properties of MJCF geoms, as MuJoCo's compiler computes them for
``inertiafromgeom``: sphere, capsule, cylinder, box and ellipsoid, solid, of the
geom's ``mass`` or ``density`` (1000 kg/m^3 by default) times its volume.

Central inertias in geom axes (r radius, h half-length along z, a b c half-sizes):

    sphere     V = 4/3 pi r^3          I = 2/5 m r^2 (each axis)
    cylinder   V = 2 pi r^2 h          Ixx = Iyy = m (3 r^2 + 4 h^2) / 12, Izz = m r^2 / 2
    capsule    a cylinder of 2h and two hemispheres of r, their masses in proportion
               to their volumes, the hemispheres' inertia taken about the capsule's
               centre as MuJoCo takes it (mjCGeom::SetInertia)
    box        V = 8 a b c             Ixx = m (b^2 + c^2) / 3, ...
    ellipsoid  V = 4/3 pi a b c        Ixx = m (b^2 + c^2) / 5, ...
"""
from __future__ import annotations

import math

import numpy as np

#: geom type -> how many size numbers it reads (MuJoCo's size attribute)
SIZES = {"sphere": 1, "capsule": 2, "cylinder": 2, "box": 3, "ellipsoid": 3}


def volume(kind: str, size) -> float:
    if kind == "sphere":
        return 4 / 3 * math.pi * size[0] ** 3
    if kind == "capsule":
        r, h = size[0], size[1]
        return math.pi * r * r * 2 * h + 4 / 3 * math.pi * r ** 3
    if kind == "cylinder":
        return math.pi * size[0] ** 2 * 2 * size[1]
    if kind == "box":
        return 8 * size[0] * size[1] * size[2]
    return 4 / 3 * math.pi * size[0] * size[1] * size[2]        # ellipsoid


def moments(kind: str, size, mass: float) -> np.ndarray:
    """The principal central moments (geom axes) of a solid geom of ``mass``."""
    if kind == "sphere":
        return np.full(3, 0.4 * mass * size[0] ** 2)
    if kind in ("capsule", "cylinder"):
        r, height = size[0], 2 * size[1]
        if kind == "cylinder":
            side = mass * (3 * r * r + height * height) / 12
            return np.array([side, side, mass * r * r / 2])
        sphere = mass * 4 * r / (4 * r + 3 * height)     # the two hemispheres' share
        rod = mass - sphere
        side = rod * (3 * r * r + height * height) / 12
        end = 2 * sphere * r * r / 5
        side += end + sphere * height * (3 * r + 2 * height) / 8
        return np.array([side, side, rod * r * r / 2 + end])
    a, b, c = (s * s for s in size[:3])
    share = 1 / 3 if kind == "box" else 1 / 5
    return mass * share * np.array([b + c, a + c, a + b])
