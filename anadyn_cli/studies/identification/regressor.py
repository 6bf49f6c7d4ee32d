"""The robot's dynamics linear in its parameters: Q = Y(q, dq, ddq) pi.

``ParametricModel`` is the robot's geometry with its numbers folded in and
``regressor`` the body-wise Newton-Euler regressor, vectorized over samples
(NumPy).  It is an implementation of its own: it shares with the recursive
evaluator (``numeric.recursive``) only the joint types' transforms and motion
subspaces (``model.joints``), and the tests check it against anadyn's inverse
dynamics and Pinocchio's RNEA.

Parameters pi, per body (fixed-joint bodies included), in Pinocchio's order
(``Inertia.toDynamicParameters``):

    m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz

with c the centre of mass and I the inertia about the body frame's origin, both
in body axes (I = I_c + m(|c|^2 1 - c c^T)); then, per moving joint, three
drive parameters that identification estimates (anadyn's dynamics has no
armature; the friction is the robot file's ``damping`` and ``friction``):

    Ia   armature, the effort Ia * ddtheta
    Fv   viscous friction, Fv * dtheta          (the file's damping)
    Fc   Coulomb friction, Fc * tanh(dtheta/v)  (the file's friction; v its
         friction_velocity, 0.01 by default: the sign of dtheta, smoothed as
         anadyn simulates it)

theta is a joint's displacement; the regressor takes displacements linear in
the coordinates, theta = J q + theta0 with J constant (one coordinate, or
coupled as rr's q2 - q1 or a URDF mimic), so dtheta = J dq, ddtheta = J ddq and
the generalized forces are Q = J^T (joint efforts).  Joint springs are a known
term (``spring_forces``), not parameters.  The actuator regressor is
B^{-1} Y: actuator efforts tau = B^{-1} (Y pi + springs), B = the actuators'
columns of J^T (one actuator per coordinate).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from ...errors import ModelError
from ...model.names import GROUND
from ...model.robot import Robot
from ...model.urdf.frames import rpy_matrix
from ...numeric.ir import as_expr

#: names of a body's ten standard parameters (suffix "_<body>")
INERTIAL = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
#: names of a moving joint's drive parameters (suffix "_<body>")
DRIVE = ("Ia", "Fv", "Fc")
#: (row, column) of the inertia matrix for each of the six inertia parameters
INERTIA_ENTRIES = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


@dataclass(frozen=True, eq=False)
class ParametricModel:
    """An open-tree robot as numbers: what ``regressor`` needs (arrays over bodies)."""
    name: str
    source: str
    coordinates: tuple[str, ...]
    units: tuple[str, ...]                 # "rad" or "m" per coordinate
    actuators: tuple[str, ...]
    bodies: tuple[str, ...]
    parents: tuple[int, ...]               # -1: ground
    joint_types: tuple                     # model.joints.JointType per body
    C: np.ndarray                          # (b, 3, 3) rpy rotation, joint -> parent axes
    origin: np.ndarray                     # (b, 3)
    axis: np.ndarray                       # (b, 3)
    joint_of_body: tuple[int, ...]         # moving-joint index, -1 for a fixed joint
    J: np.ndarray                          # (nj, n) d theta / d q
    theta0: np.ndarray                     # (nj,)
    friction_velocity: np.ndarray          # (nj,)
    stiffness: np.ndarray                  # (nj,)
    rest: np.ndarray                       # (nj,)
    gravity: np.ndarray                    # (3,) world axes
    B: np.ndarray                          # (n, m) actuator efforts -> generalized forces
    names: tuple[str, ...]                 # the parameters pi
    nominal: np.ndarray                    # pi of the robot file
    limits: tuple                          # model.robot.JointLimits per moving joint
    robot: Robot                           # what it was made from

    @property
    def moving(self) -> list[int]:
        """Body index of each moving joint."""
        return [i for i, j in enumerate(self.joint_of_body) if j >= 0]

    def regressor(self, q, dq, ddq) -> np.ndarray:
        """Y (N, n, p) with Q = Y pi the generalized forces, at N states (rows of q,
        dq, ddq; one state as 1-D arrays gives N = 1)."""
        q, dq, ddq = (np.atleast_2d(np.asarray(a, float)) for a in (q, dq, ddq))
        theta = q @ self.J.T + self.theta0
        rate, acc = dq @ self.J.T, ddq @ self.J.T
        joint = self._joint_regressor(theta, rate, acc)
        return np.einsum("jk,Njp->Nkp", self.J, joint)

    def actuator_regressor(self, q, dq, ddq) -> np.ndarray:
        """B^{-1} Y (N, m, p): actuator efforts tau = B^{-1} Y pi + ``spring_efforts``."""
        return np.einsum("ak,Nkp->Nap", self._B_inverse(), self.regressor(q, dq, ddq))

    def spring_efforts(self, q) -> np.ndarray:
        """Actuator efforts (N, m) that hold the joint springs, k (theta - rest)."""
        theta = np.atleast_2d(np.asarray(q, float)) @ self.J.T + self.theta0
        return (self.stiffness * (theta - self.rest)) @ self.J @ self._B_inverse().T

    def _B_inverse(self) -> np.ndarray:
        if self.B.shape[0] != self.B.shape[1] or np.linalg.matrix_rank(self.B) < len(self.B):
            raise ModelError(f"{len(self.actuators)} actuators for {len(self.coordinates)} "
                             "coordinates: identification needs one actuator per coordinate "
                             "(B square and invertible)", source=self.source)
        return np.linalg.inv(self.B)

    def _joint_regressor(self, theta, rate, acc) -> np.ndarray:
        """Joint efforts' regressor (N, nj, p) from joint displacements, rates and
        accelerations (N, nj)."""
        N, nb, nj = len(theta), len(self.bodies), self.J.shape[0]
        p = len(self.names)
        frames, blocks = [], []
        for i in range(nb):
            R, o = self._placement(i, theta)
            parent = self.parents[i]
            if parent < 0:
                w = dw = np.zeros((N, 3))
                a = np.broadcast_to(-self.gravity, (N, 3))
            else:
                w, dw, a = frames[parent][2:]
            a = _rotate_back(R, a + np.cross(dw, o) + np.cross(w, np.cross(w, o)))
            w, dw = _rotate_back(R, w), _rotate_back(R, dw)
            j = self.joint_of_body[i]
            if j >= 0:
                angular, linear = self.joint_types[i].subspace(self.axis[i])
                if angular is not None:
                    dw = dw + np.cross(w, angular) * rate[:, j, None] + angular * acc[:, j, None]
                    w = w + angular * rate[:, j, None]
                if linear is not None:
                    a = a + 2 * np.cross(w, linear) * rate[:, j, None] + linear * acc[:, j, None]
            frames.append((R, o, w, dw, a))
            blocks.append(body_block(w, dw, a))
        Y = np.zeros((N, nj, p))
        for k in range(nb):
            block, i = blocks[k], k
            while i >= 0:
                j = self.joint_of_body[i]
                if j >= 0:
                    Y[:, j, 10 * k:10 * k + 10] = self._project(i, block)
                R, o = frames[i][:2]
                force = np.einsum("nab,nbp->nap", R, block[:, :3])
                moment = np.einsum("nab,nbp->nap", R, block[:, 3:]) + np.cross(
                    o[:, :, None], force, axis=1)
                block, i = np.concatenate([force, moment], 1), self.parents[i]
        base = 10 * nb
        for j in range(nj):
            Y[:, j, base + 3 * j] = acc[:, j]
            Y[:, j, base + 3 * j + 1] = rate[:, j]
            Y[:, j, base + 3 * j + 2] = np.tanh(rate[:, j] / self.friction_velocity[j])
        return Y

    def _placement(self, i: int, theta) -> tuple[np.ndarray, np.ndarray]:
        """(R (N, 3, 3) body -> parent axes, o (N, 3) body origin in parent axes)."""
        N = len(theta)
        j = self.joint_of_body[i]
        d = theta[:, j][:, None, None] if j >= 0 else np.zeros((N, 1, 1))
        R, o = self.joint_types[i].transform(self.C[i], self.origin[i][:, None],
                                             self.axis[i][:, None], d, _rotation)
        return np.broadcast_to(R, (N, 3, 3)), np.broadcast_to(o, (N, 3, 1))[:, :, 0]

    def _project(self, i: int, block) -> np.ndarray:
        """The joint effort of body i's joint: its subspace against the wrench block."""
        angular, linear = self.joint_types[i].subspace(self.axis[i])
        out = 0
        if angular is not None:
            out = out + np.einsum("a,nap->np", angular, block[:, 3:])
        if linear is not None:
            out = out + np.einsum("a,nap->np", linear, block[:, :3])
        return out


def body_block(w, dw, a) -> np.ndarray:
    """(N, 6, 10): body wrench [f; n] about the origin, body axes, per unit parameter:
    f = m a + dw x h + w x (w x h), n = I dw + w x (I w) + h x a."""
    N = len(w)
    out = np.zeros((N, 6, 10))
    out[:, :3, 0] = a
    out[:, :3, 1:4] = _skew(dw) + _skew(w) @ _skew(w)
    out[:, 3:, 1:4] = -_skew(a)
    out[:, 3:, 4:] = _lin(dw) + _skew(w) @ _lin(w)
    return out


def _skew(v) -> np.ndarray:
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    zero = np.zeros_like(x)
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1),
                     np.stack([-y, x, zero], -1)], 1)


def _lin(v) -> np.ndarray:
    """L(v) (N, 3, 6) with I v = L(v) [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]."""
    out = np.zeros((len(v), 3, 6))
    for col, (r, c) in enumerate(INERTIA_ENTRIES):
        out[:, r, col] += v[:, c]
        if r != c:
            out[:, c, col] += v[:, r]
    return out


def _rotate_back(R, v) -> np.ndarray:
    """R^T v for rows v (N, 3)."""
    return np.einsum("nba,nb->na", R, v)


def _rotation(axis, angle) -> np.ndarray:
    """Rodrigues for a column ``axis`` (3, 1) and angles (N, 1, 1): (N, 3, 3)."""
    a = axis[:, 0]
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.cos(angle) * np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * np.outer(a, a)


def value_of(expr, values) -> float:
    """The number of a robot file's expression (or number), parameters ``values`` put in."""
    return float(as_expr(expr).xreplace(values))


def parameter_names(bodies, moving) -> tuple[str, ...]:
    return tuple([f"{p}_{b}" for b in bodies for p in INERTIAL]
                 + [f"{p}_{bodies[i]}" for i in moving for p in DRIVE])


def inertial_parameters(mass: float, com, inertia) -> np.ndarray:
    """The ten standard parameters of a body of ``mass``, centre ``com`` and central
    ``inertia`` (3 x 3)."""
    c = np.asarray(com, float)
    I_O = np.asarray(inertia, float) + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([mass, *(mass * c), *(I_O[r, k] for r, k in INERTIA_ENTRIES)])


def parametric_model(robot: Robot) -> ParametricModel:
    """The robot as numbers for the regressor; ModelError for what it does not take
    (a closed chain, external loads, a joint type with several coordinates or a
    displacement not linear in the coordinates)."""
    where = robot.source
    if robot.constraints is not None:
        raise ModelError("the regressor takes open trees; this robot has loops or "
                         "constraints", source=where)
    if robot.loads:
        raise ModelError("the regressor models no external loads; this robot has "
                         f"{len(robot.loads)} (remove its loads: section)", source=where)
    robot.refuse_contacts("identification (excite, identify)")
    values = robot.parameter_substitution()

    def num(e) -> float:
        return value_of(e, values)

    qs = robot.q
    index = {b.name: i for i, b in enumerate(robot.bodies)}
    rows, offsets, kinds, joint_of_body, limits, drive = [], [], [], [], [], []
    C, origin, axis, nominal = [], [], [], []
    for body in robot.bodies:
        joint, kind = body.joint, body.joint.joint_type
        if kind.coordinates > 1 or kind.speeds != kind.coordinates:
            raise ModelError(f"joint of {body.name}: the regressor takes joints of one "
                             "coordinate (and fixed ones)", source=where, path="bodies")
        C.append(rpy_matrix([num(a) for a in joint.rpy]))
        origin.append([num(a) for a in joint.origin])
        axis.append([num(a) for a in joint.axis])
        kinds.append(kind)
        nominal.append(inertial_parameters(num(body.mass), [num(c) for c in body.com],
                                           [[num(body.inertia[r, k]) for k in range(3)]
                                            for r in range(3)]))
        if not kind.moving:
            joint_of_body.append(-1)
            continue
        d = as_expr(joint.displacement).xreplace(values)
        grad = [sp.diff(d, s) for s in qs]
        if any(g.free_symbols for g in grad):
            raise ModelError(f"joint of {body.name}: displacement {joint.displacement} is not "
                             "linear in the coordinates; the regressor takes "
                             "a1*q1 + ... + c with constant a and c", source=where,
                             path="bodies")
        joint_of_body.append(len(rows))
        rows.append([float(g) for g in grad])
        offsets.append(float(d.xreplace({s: 0 for s in qs})))
        limits.append(joint.limits)
        drive.append((num(joint.damping), num(joint.friction), num(joint.friction_velocity),
                      num(joint.stiffness), num(joint.rest)))
    J = np.array(rows).reshape(len(rows), len(qs))
    drive = np.array(drive).reshape(len(rows), 5)
    B = np.zeros((len(qs), len(robot.actuators)))
    for a, actuator in enumerate(robot.actuators):
        B[:, a] = num(actuator.scale) * J[joint_of_body[index[actuator.body]]]
    moving = [i for i, j in enumerate(joint_of_body) if j >= 0]
    bodies = tuple(b.name for b in robot.bodies)
    pi = np.concatenate([*nominal, *([0.0, fv, fc] for fv, fc in drive[:, :2])])
    return ParametricModel(
        name=robot.name, source=where, coordinates=tuple(c.name for c in robot.coordinates),
        units=tuple(c.unit for c in robot.coordinates),
        actuators=tuple(a.name for a in robot.actuators), bodies=bodies,
        parents=tuple(-1 if b.parent == GROUND else index[b.parent] for b in robot.bodies),
        joint_types=tuple(kinds), C=np.array(C), origin=np.array(origin), axis=np.array(axis),
        joint_of_body=tuple(joint_of_body), J=J, theta0=np.array(offsets),
        friction_velocity=drive[:, 2], stiffness=drive[:, 3], rest=drive[:, 4],
        gravity=np.array([num(g) for g in robot.gravity]), B=B,
        names=parameter_names(bodies, moving), nominal=pi, limits=tuple(limits), robot=robot)
