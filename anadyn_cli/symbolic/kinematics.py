"""Kinematics shared by both formulations.

Frames: each body frame is its joint frame after the joint moves.  With
R_l the rotation from body axes to parent axes and o the body origin in
parent axes, as the joint type gives them (``model.joints``: ``transform``):

    revolute:  R_l = C Rot(a, theta(q)),  o = origin
    prismatic: R_l = C,                   o = origin + C a d(q)
    fixed:     R_l = C,                   o = origin

where C = Rz(yaw) Ry(pitch) Rx(roll) and a is the unit axis in joint axes.
Velocities are linear in the generalized speeds u (``Robot.speeds``), so each
body carries its partial velocities as 3 x n matrices in its own axes (columns
r = d/du_r), with (s, v) the joint's motion subspace (``subspace``: (a, -)
revolute, (-, a) prismatic):

    W_i  = R_l^T W_p [+ s (d theta/dq)]          partial angular velocities
    Vo_i = R_l^T (Vo_p + W_p x o) [+ v (d theta/dq)]  partial velocities of the origin
    V_i  = Vo_i + W_i x c                        partial velocities of the mass centre

For every joint but a spherical one the speeds are the coordinates' rates.  A
spherical joint (R_l = C R(q), R(q) of its quaternion divided by |q|^2) adds
S = (1, 0): the unit columns E at its speeds (w, body axes), W_i = R_l^T W_p + E,
and ``kinematic`` holds dq = W(q) u (its quaternion's dq = 1/2 q (x) (0, w)).
``rates=True`` builds the partials over the coordinates' rates instead (all nq
of them, for Lagrange's equations in the quaternion's rates, which hold on the
unit sphere |q| = 1): there a spherical joint turns by the unit quaternion's
rotation R(q) |q|^2 (polynomial) and its columns at its quaternion's rates are
H(q) = 2 G(q), since w = 2 vec(conj(q) (x) dq) inverts dq = 1/2 q (x) (0, w) for a
unit quaternion (rows of G: (-x, w, z, -y), (-y, -z, w, x), (-z, y, -x, w)).

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
    dq: tuple[sp.Symbol, ...]  # the speeds the partials are over (columns)
    gravity: Matrix            # world axes (3 x 1)
    bodies: tuple[BodyKinematics, ...]
    symbolic: bool = False     # parameters left as symbols (else their numbers substituted)
    #: dq = W(q) u (nq x 1) when the speeds are not the coordinates' rates, else None
    kinematic: Matrix | None = None

    @property
    def rated(self) -> int:
        """How many coordinates have their rate among the speeds (they come first: the
        coordinates of every joint but a spherical one)."""
        return len(self.q) if self.kinematic is None else len(self.q) - 4 * sum(
            b.body.joint.joint_type.orientation for b in self.bodies)

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


def build(robot: Robot, symbolic: bool = False, rates: bool = False) -> Kinematics:
    """Kinematics of every body; parameters substituted unless ``symbolic``; partials
    over the speeds u, or over the coordinates' rates when ``rates`` (module docstring)."""
    values = robot.parameter_substitution(symbolic)

    def sub(expr):
        return expr.xreplace(values) if values else expr

    q, over_rates = robot.q, rates
    dq = robot.dq if rates or not robot.spherical else tuple(u.symbol for u in robot.speeds)
    n = len(dq)
    rated = n if rates else len(q) - 4 * sum(b.joint.joint_type.orientation
                                             for b in robot.bodies)
    column = {symbol: k for k, symbol in enumerate(q if rates else dq)}
    zero = Matrix.zeros(3, n)
    index = {b.name: i for i, b in enumerate(robot.bodies)}
    frames: list[tuple[Matrix, Matrix | None, sp.Expr]] = []   # (base, axis, angle)
    result: list[BodyKinematics] = []
    for body in robot.bodies:
        joint = body.joint
        parent = None if body.parent == GROUND else index[body.parent]
        P = result[parent] if parent is not None else None
        axis = Matrix([sub(a) for a in joint.axis])
        kind = joint.joint_type
        if kind.orientation:            # the quaternion; no displacement rate of its own
            displacement = tuple(sp.Symbol(name, real=True) for name in joint.coordinates)
            rates = Matrix.zeros(1, n)
        else:
            displacement = sub(joint.displacement)
            rates = Matrix([[sp.diff(displacement, qr) for qr in q[:rated]]
                            + [0] * (n - rated)])
        C = rpy_rotation([sub(a) for a in joint.rpy])
        R_local, origin = kind.transform(C, Matrix([sub(a) for a in joint.origin]), axis,
                                         displacement, rotation)
        if kind.orientation and over_rates:         # the unit quaternion's rotation
            R_local = C * Matrix(kind.rotation(*displacement))
        R_local, origin = Matrix(R_local), Matrix(origin)
        turns = kind.angular and not kind.linear        # a pure turn about the axis
        # world rotation, merging consecutive turns about one axis
        base, p_axis, p_angle = frames[parent] if P is not None else (Matrix.eye(3), None, 0)
        parent_R = P.R if P is not None else Matrix.eye(3)
        if kind.orientation:
            frame = (Matrix(parent_R * R_local), None, sp.Integer(0))
        elif turns and C == sp.eye(3) and p_axis == axis:
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
        if kind.orientation:
            W = Matrix(W + orientation_columns(
                displacement, [column[s] for s in (displacement if over_rates else
                                                   [u.symbol for u in joint.speeds])], n))
        else:
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
    return Kinematics(q=q, dq=dq, gravity=gravity, bodies=tuple(result), symbolic=symbolic,
                      kinematic=None if over_rates or not robot.spherical else
                      kinematic_equations(robot))


def orientation_columns(quaternion, columns: list[int], n: int) -> Matrix:
    """A spherical joint's partial angular velocities (3 x n): the unit columns E at
    its three speeds, or H(q) = 2 G(q) at its quaternion's four rates (module
    docstring), by how many ``columns`` are given."""
    result = sp.zeros(3, n)
    if len(columns) == 3:
        for k, c in enumerate(columns):
            result[k, c] = 1
        return Matrix(result)
    w, x, y, z = quaternion
    G = [[-x, w, z, -y], [-y, -z, w, x], [-z, y, -x, w]]
    for i in range(3):
        for k, c in enumerate(columns):
            result[i, c] = 2 * G[i][k]
    return Matrix(result)


def kinematic_equations(robot: Robot) -> Matrix:
    """dq = W(q) u (nq x 1) in the coordinates' order: the speed itself for a coordinate
    whose rate is a speed, 1/2 q (x) (0, w) for a quaternion's (``joints.Spherical``)."""
    speeds = [u.symbol for u in robot.speeds]
    rates = dict(zip(robot.dq, speeds))
    for b in robot.bodies:
        if b.joint.joint_type.orientation:
            quaternion = [sp.Symbol(name, real=True) for name in b.joint.coordinates]
            found = b.joint.joint_type.coordinate_rates(quaternion,
                                                        [u.symbol for u in b.joint.speeds])
            rates.update(zip([sp.Symbol("d" + name, real=True) for name in b.joint.coordinates],
                             [sp.expand(e.xreplace({f: sp.Rational(f) for f in  # its 0.5: 1/2
                                                    e.atoms(sp.Float)})) for e in found]))
    return Matrix([rates[r] for r in robot.dq])


def potential_energy(kin: Kinematics) -> sp.Expr:
    """V = -sum_i m_i g . r_i, gravity's potential with V = 0 at the world origin."""
    return sp.Add(*[-b.mass * kin.gravity.dot(b.position) for b in kin.bodies])
