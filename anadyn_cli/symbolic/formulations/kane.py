"""Kane's method: Fr + Fr* = 0 for r = 1..n, in the generalized speeds u
(``Robot.speeds``): u = dq for every joint but a spherical one, whose speeds are
its angular velocity w relative to its parent in body axes.

Generalized active forces, from gravity on each mass centre and each
actuator's effort on its body with the reaction on the parent:

    Fr  = sum_i m_i V_i[:, r] . g_i + sum_k tau_k a_k . (J_child - J_parent)[:, r]

where g_i is gravity in body axes and J is the partial angular velocity
(revolute) or the partial velocity of the coincident points (prismatic).
Joint forces (``symbolic.forces``) act like actuators, with the joint rate
measured by the same partials, dtheta = a . (J_child - J_parent) dq; a load,
force f at point p of body i and torque T, both in body axes, adds

    Q_r = (Vo_i + W_i x p)[:, r] . f + W_i[:, r] . T

(Q is part of F, and kept apart for the printout).
Generalized inertia forces, with a_i, alpha_i the mass-centre and angular
accelerations:

    Fr* = -sum_i [ m_i V_i[:, r] . a_i + W_i[:, r] . (I_i alpha_i + w_i x I_i w_i) ]

Splitting a_i = V_i ddq + a_i(vp), alpha_i = W_i ddq + alpha_i(vp) gives
M = sum_i m V^T V + W^T I W and the velocity-product part of F.  The
velocity-product accelerations are propagated from parent to child, so no
expression is differentiated: a spherical joint's S = (1, 0) is constant in
body axes, so it adds w_p x (S w) to alpha_i (w_p the parent's angular velocity
in the body's axes) and nothing to the origin's acceleration.  With a spherical
joint the result is M(q) du = F(t, q, u) + B tau, and the kinematic
differential equations dq = W(q) u come with it (``EquationsOfMotion.kinematic``).
"""
from __future__ import annotations

import sympy as sp

from .. import forces
from ..eom import EquationsOfMotion
from ..kinematics import BodyKinematics, Kinematics, cross_columns
from ...model.robot import Robot

Matrix = sp.ImmutableMatrix


def equations(robot: Robot, kin: Kinematics) -> EquationsOfMotion:
    q, dq = kin.q, kin.dq
    n, rated = len(dq), kin.rated
    dq_vec = Matrix(dq)
    rates_vec = Matrix(dq[:rated])              # the speeds that are coordinates' rates
    zero3 = Matrix.zeros(3, 1)
    M = sp.zeros(n, n)
    F = sp.zeros(n, 1)
    omega, alpha, acc_origin = [], [], []
    for b in kin.bodies:
        Rt = b.R_local.T
        if b.parent is None:
            w_p, al_p, ao_p = zero3, zero3, zero3
        else:
            w_p, al_p, ao_p = omega[b.parent], alpha[b.parent], acc_origin[b.parent]
        w = Matrix(b.W * dq_vec)
        w_p_here = Matrix(Rt * w_p)                              # parent's w, body axes
        # velocity-product accelerations, body axes
        al = Matrix(Rt * al_p)
        ao = Matrix(Rt * (ao_p + al_p.cross(b.origin) + w_p.cross(w_p.cross(b.origin))))
        if b.body.joint.joint_type.orientation:                  # S w: w relative, body axes
            al = Matrix(al + w_p_here.cross(Matrix([u.symbol for u in b.body.joint.speeds])))
        else:
            rate = (b.joint_rates * dq_vec)[0]                   # theta-dot or d-dot
            rate2 = (rates_vec.T * sp.hessian(b.displacement, q[:rated]) * rates_vec)[0]
            angular, linear = b.body.joint.joint_type.subspace(b.axis)
            if angular is not None:
                al = Matrix(al + angular * rate2 + w_p_here.cross(angular * rate))
            if linear is not None:
                ao = Matrix(ao + 2 * w_p_here.cross(linear * rate) + linear * rate2)
        ac = Matrix(ao + al.cross(b.com) + w.cross(w.cross(b.com)))
        g = Matrix(b.R.T * kin.gravity)                        # gravity, body axes
        omega.append(w), alpha.append(al), acc_origin.append(ao)
        # projections on the partial velocities
        I, m = b.inertia, b.mass
        M += m * b.V.T * b.V + b.W.T * I * b.W
        F += b.V.T * (m * g - m * ac) - b.W.T * (I * al + w.cross(I * w))
    B = sp.zeros(n, len(robot.actuators))
    index = {kb.body.name: i for i, kb in enumerate(kin.bodies)}
    for k, actuator in enumerate(robot.actuators):
        scale = actuator.scale.xreplace(robot.parameter_substitution(kin.symbolic))
        B[:, k] = scale * joint_partials(kin, kin.bodies[index[actuator.body]]).T
    Q = generalized_forces(robot, kin)
    return EquationsOfMotion(
        formulation="kane", q=q, dq=dq, ddq=accelerations(dq),
        efforts=tuple(sp.Symbol(a.name, real=True) for a in robot.actuators),
        M=Matrix(M), F=Matrix(F + Q) if Q is not None else Matrix(F), B=Matrix(B), Q=Q,
        kinematic=kin.kinematic)


def accelerations(speeds) -> tuple[sp.Symbol, ...]:
    """The speeds' rates: d<u> (ddq for a coordinate's rate dq, dwx for a speed wx)."""
    return tuple(sp.Symbol("d" + s.name, real=True) for s in speeds)


def joint_partials(kin: Kinematics, b: BodyKinematics) -> Matrix:
    """a . (J_child - J_parent) (1 x n): the partial rates along the joint of ``b``,
    where an effort along the joint, with its reaction on the parent, does work."""
    n = len(kin.dq)
    parent = kin.bodies[b.parent] if b.parent is not None else None
    Rt = b.R_local.T
    if b.body.joint.joint_type.angular:      # torque on child, reaction on parent
        child, carried = b.W, (Rt * parent.W if parent else Matrix.zeros(3, n))
    else:                                    # force at coincident points
        child = b.Vo
        carried = (Rt * (parent.Vo + cross_columns(parent.W, b.origin))
                   if parent else Matrix.zeros(3, n))
    return Matrix(b.axis.T * (child - carried))


def generalized_forces(robot: Robot, kin: Kinematics) -> Matrix | None:
    """Q: the joint forces and loads projected on the partial velocities (None: none)."""
    joints, loads = forces.joint_forces(robot, kin), forces.loads(robot, kin)
    if not joints and not loads:
        return None
    dq_vec = Matrix(kin.dq)
    Q = sp.zeros(len(kin.dq), 1)
    for joint in joints:
        b = kin.bodies[joint.body]
        partials = joint_partials(kin, b)
        rate = (partials * dq_vec)[0]
        Q += partials.T * joint.law(b.displacement, rate)
    for load in loads:
        b = kin.bodies[load.body]
        to_body = (lambda v: v) if load.frame == "body" else (lambda v: Matrix(b.R.T * v))
        if load.force != Matrix.zeros(3, 1):
            Q += (b.Vo + cross_columns(b.W, load.point)).T * to_body(load.force)
        if load.torque != Matrix.zeros(3, 1):
            Q += b.W.T * to_body(load.torque)
    return Matrix(Q)
