"""Kinematics shared by both formulations.

Frames: each body frame is its joint frame after the joint moves.  With
R_l the rotation from body axes to parent axes and o the body origin in
parent axes, as the joint type gives them (``model.joints``: ``transform``):

    revolute:  R_l = C Rot(a, theta(q)),  o = origin
    prismatic: R_l = C,                   o = origin + C a d(q)
    fixed:     R_l = C,                   o = origin

where C = Rz(yaw) Ry(pitch) Rx(roll) and a is the unit axis in joint axes.
Velocities are linear in the rates dq, so each body carries its partial
velocities as 3 x n matrices in its own axes (columns r = d/d(dq_r)), with
(s, v) the joint's motion subspace (``subspace``: (a, -) revolute, (-, a)
prismatic):

    W_i  = R_l^T W_p [+ s (d theta/dq)]          partial angular velocities
    Vo_i = R_l^T (Vo_p + W_p x o) [+ v (d theta/dq)]  partial velocities of the origin
    V_i  = Vo_i + W_i x c                        partial velocities of the mass centre

World-frame rotation R_i = R_p R_l and mass-centre position
r_i = p_p + R_p o + R_i c.  Consecutive turns about one axis with no rpy
between them are merged into one angle, so a planar arm in absolute
angles gets cos(q2), not cos(q1) cos(q2 - q1) - sin(q1) sin(q2 - q1).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..model.names import GROUND
from ..model.robot import Body, Robot

Matrix = sp.ImmutableMatrix


@dataclass(frozen=True)
class BodyKinematics:
    body: Body                 # with parameters substituted as asked
    parent: int | None         # index into Kinematics.bodies, None for ground
    axis: Matrix               # unit joint axis, body axes (3 x 1)
    joint_rates: Matrix        # d(displacement)/dq (1 x n)
    displacement: sp.Expr
    R_local: Matrix            # body axes -> parent axes
    origin: Matrix             # body origin in parent axes
    R: Matrix                  # body axes -> world axes
    position: Matrix           # mass centre in world axes
    W: Matrix                  # partial angular velocities, body axes (3 x n)
    Vo: Matrix                 # partial velocities of the body origin, body axes
    V: Matrix                  # partial velocities of the mass centre, body axes
    com: Matrix
    inertia: Matrix            # central inertia, body axes
    mass: sp.Expr


@dataclass(frozen=True)
class Kinematics:
    q: tuple[sp.Symbol, ...]
    dq: tuple[sp.Symbol, ...]
    gravity: Matrix            # world axes (3 x 1)
    bodies: tuple[BodyKinematics, ...]
    symbolic: bool = False     # parameters left as symbols (else their numbers substituted)

    def angular_velocity(self, i: int) -> Matrix:
        return self.bodies[i].W * Matrix(self.dq)

    def velocity(self, i: int) -> Matrix:
        return self.bodies[i].V * Matrix(self.dq)


def rotation(axis: Matrix, angle: sp.Expr) -> Matrix:
    """Rodrigues: Rot(a, th) = cos(th) I + sin(th) [a]x + (1 - cos(th)) a a^T, |a| = 1."""
    if angle == 0:
        return Matrix.eye(3)
    c, s = sp.cos(angle), sp.sin(angle)
    x, y, z = axis
    skew = Matrix([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return Matrix(c * sp.eye(3) + s * skew + (1 - c) * (axis * axis.T))


def rpy_rotation(rpy) -> Matrix:
    """URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    roll, pitch, yaw = rpy
    e = [Matrix([1, 0, 0]), Matrix([0, 1, 0]), Matrix([0, 0, 1])]
    return Matrix(rotation(e[2], yaw) * rotation(e[1], pitch) * rotation(e[0], roll))


def cross_columns(W: Matrix, r: Matrix) -> Matrix:
    """Column-wise cross product W[:, k] x r."""
    return Matrix.hstack(*[W[:, k].cross(r) for k in range(W.shape[1])]) if W.shape[1] else W


def build(robot: Robot, symbolic: bool = False) -> Kinematics:
    """Kinematics of every body; parameters substituted unless ``symbolic``."""
    values = robot.parameter_substitution(symbolic)

    def sub(expr):
        return expr.xreplace(values) if values else expr

    q, dq = robot.q, robot.dq
    n = len(q)
    zero = Matrix.zeros(3, n)
    index = {b.name: i for i, b in enumerate(robot.bodies)}
    frames: list[tuple[Matrix, Matrix | None, sp.Expr]] = []   # (base, axis, angle)
    result: list[BodyKinematics] = []
    for body in robot.bodies:
        joint = body.joint
        parent = None if body.parent == GROUND else index[body.parent]
        P = result[parent] if parent is not None else None
        axis = Matrix([sub(a) for a in joint.axis])
        displacement = sub(joint.displacement)
        rates = Matrix([[sp.diff(displacement, qr) for qr in q]])
        C = rpy_rotation([sub(a) for a in joint.rpy])
        kind = joint.joint_type
        R_local, origin = kind.transform(C, Matrix([sub(a) for a in joint.origin]), axis,
                                         displacement, rotation)
        R_local, origin = Matrix(R_local), Matrix(origin)
        turns = kind.angular and not kind.linear        # a pure turn about the axis
        # world rotation, merging consecutive turns about one axis
        base, p_axis, p_angle = frames[parent] if P is not None else (Matrix.eye(3), None, 0)
        parent_R = P.R if P is not None else Matrix.eye(3)
        if turns and C == sp.eye(3) and p_axis == axis:
            frame = (base, axis, p_angle + displacement)
        elif turns:
            frame = (Matrix(parent_R * C), axis, displacement)
        else:
            frame = (Matrix(parent_R * C), None, sp.Integer(0))
        frames.append(frame)
        R = frame[0] if frame[1] is None else Matrix(frame[0] * rotation(frame[1], frame[2]))
        # partial velocities in body axes
        W_p, Vo_p = (P.W, P.Vo) if P is not None else (zero, zero)
        Rt = R_local.T
        W = Matrix(Rt * W_p)
        Vo = Matrix(Rt * (Vo_p + cross_columns(W_p, origin)))
        angular, linear = kind.subspace(axis)
        if angular is not None:
            W = Matrix(W + angular * rates)
        if linear is not None:
            Vo = Matrix(Vo + linear * rates)
        com = Matrix([sub(c) for c in body.com])
        V = Matrix(Vo + cross_columns(W, com))
        p_origin = (P.position - P.R * P.com + parent_R * origin) if P is not None else origin
        position = Matrix(p_origin + R * com)
        result.append(BodyKinematics(
            body=body, parent=parent, axis=axis, joint_rates=rates, displacement=displacement,
            R_local=R_local, origin=origin, R=R, position=position, W=W, Vo=Vo, V=V,
            com=com, inertia=Matrix(body.inertia.xreplace(values)), mass=sub(body.mass)))
    gravity = Matrix([sub(g) for g in robot.gravity])
    return Kinematics(q=q, dq=dq, gravity=gravity, bodies=tuple(result), symbolic=symbolic)


def potential_energy(kin: Kinematics) -> sp.Expr:
    """V = -sum_i m_i g . r_i, gravity's potential with V = 0 at the world origin."""
    return sp.Add(*[-b.mass * kin.gravity.dot(b.position) for b in kin.bodies])
