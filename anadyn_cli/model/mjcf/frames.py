"""Frames of the MJCF import: an element's orientation (quat, axisangle, euler with
the compiler's eulerseq, xyaxes, zaxis; one of them at most) as a rotation
matrix, computed as MuJoCo's compiler computes it."""
from __future__ import annotations

import math

import numpy as np

#: the orientation attributes of a body, geom, inertial or frame (MuJoCo's "frame
#: orientation"); ``fromto`` is a geom's alternative
ORIENTATIONS = ("quat", "axisangle", "euler", "xyaxes", "zaxis")
_MIN = 1e-15                       # MuJoCo's mjMINVAL
IDENTITY = np.eye(3)               # no orientation given
IDENTITY.flags.writeable = False


def quat_matrix(q) -> np.ndarray:
    """The rotation of the quaternion (w, x, y, z), made unit first."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def axis_angle(axis, angle: float) -> np.ndarray:
    """Rot(axis, angle), the axis made unit (Rodrigues)."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def z_to(vector) -> np.ndarray:
    """The smallest rotation taking z onto ``vector`` (MuJoCo's mju_quatZ2Vec: a half
    turn about x when it points down z)."""
    v = np.asarray(vector, dtype=float)
    v = v / np.linalg.norm(v)
    axis = np.cross([0.0, 0.0, 1.0], v)
    s = np.linalg.norm(axis)
    if s < _MIN:
        return np.diag([1.0, -1.0, -1.0]) if v[2] < 0 else np.eye(3)
    return axis_angle(axis / s, math.atan2(s, v[2]))


def euler(angles, sequence: str) -> np.ndarray:
    """The rotation of three angles (rad) about the axes of ``sequence``: lower case
    about the turned (intrinsic) axes, upper case about the fixed ones."""
    R = np.eye(3)
    for letter, angle in zip(sequence, angles):
        step = axis_angle(np.eye(3)["xyz".index(letter.lower())], angle)
        R = R @ step if letter.islower() else step @ R
    return R


def xyaxes(values) -> np.ndarray:
    """The rotation whose x axis is the first vector and y axis the second made
    orthogonal to it (Gram-Schmidt), z = x cross y."""
    x, y = np.asarray(values[:3], dtype=float), np.asarray(values[3:], dtype=float)
    x = x / np.linalg.norm(x)
    y = y - x * (x @ y)
    y = y / np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


def quaternion_of(R) -> list[float]:
    """The unit quaternion (w, x, y, z), w >= 0, of the rotation matrix R (Shepperd's
    method: from the largest of the four squared components)."""
    R = np.asarray(R, dtype=float)
    trace = np.trace(R)
    squares = [1 + trace, 1 + 2 * R[0, 0] - trace, 1 + 2 * R[1, 1] - trace,
               1 + 2 * R[2, 2] - trace]
    k = int(np.argmax(squares))
    root = math.sqrt(squares[k])
    pairs = (R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1],
             R[0, 1] + R[1, 0], R[0, 2] + R[2, 0], R[1, 2] + R[2, 1])
    if k == 0:
        q = [root, pairs[0] / root, pairs[1] / root, pairs[2] / root]
    elif k == 1:
        q = [pairs[0] / root, root, pairs[3] / root, pairs[4] / root]
    elif k == 2:
        q = [pairs[1] / root, pairs[3] / root, root, pairs[5] / root]
    else:
        q = [pairs[2] / root, pairs[4] / root, pairs[5] / root, root]
    q = np.array(q) / 2
    q = q / np.linalg.norm(q)
    return list(q if q[0] >= 0 else -q)
