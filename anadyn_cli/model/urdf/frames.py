"""Frames of the URDF import: poses (R, p), URDF's roll-pitch-yaw and round-off
residue of computed values."""
from __future__ import annotations

import math

import numpy as np

Pose = tuple[np.ndarray, np.ndarray]           # (R, p): rotation and origin, parent axes


def rpy_matrix(rpy) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) (URDF)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p),
                              math.cos(y), math.sin(y))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def matrix_rpy(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw with rpy_matrix(rpy) = R (pitch in [-pi/2, pi/2]; at
    pitch = +-pi/2, where only roll -+ yaw is defined, yaw = 0)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[2, 1], R[2, 2]))
    if math.hypot(R[0, 0], R[1, 0]) > 1e-12:
        return np.array([math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])])
    sign = 1.0 if R[2, 0] < 0 else -1.0
    return np.array([math.atan2(sign * R[0, 1], R[1, 1]), pitch, 0.0])


def compose(a: Pose, b: Pose) -> Pose:
    """Pose b (given in frame a's axes) seen from a's parent: (Ra Rb, pa + Ra pb)."""
    return a[0] @ b[0], a[1] + a[0] @ b[1]


IDENTITY: Pose = (np.eye(3), np.zeros(3))


def _snap(values: np.ndarray, scale: float | None = None) -> np.ndarray:
    """Computed values with the round-off residue of exact zeros (below 4 ulp of
    ``scale``, default the largest entry) set to 0, e.g. cos(pi/2) = 6e-17."""
    values = np.asarray(values, dtype=float)
    scale = np.abs(values).max(initial=0.0) if scale is None else scale
    return np.where(np.abs(values) <= 4 * np.spacing(scale), 0.0, values)
