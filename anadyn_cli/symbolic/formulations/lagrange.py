"""Lagrange's equations: d/dt(dT/d(dq_r)) - dT/dq_r + dV/dq_r = Q_r.

Kinetic energy from mass-centre velocities, angular velocities and central
inertia tensors, and potential energy of gravity:

    T = sum_i 1/2 m_i v_i . v_i + 1/2 w_i . I_i w_i,   V = -sum_i m_i g . r_i

With p_r = dT/d(dq_r), T having no explicit time dependence:

    M_rs = d p_r / d(dq_s)
    F_r  = -sum_s (d p_r / dq_s) dq_s + dT/dq_r - dV/dq_r

Actuators enter by virtual work: an effort tau_k along a joint whose
displacement is theta_k(q) does tau_k * d theta_k, so B_rk = d theta_k / dq_r.

Joint forces and loads (``symbolic.forces``) make Q, part of F and kept
apart for the printout.  Springs come from their potential
V_s = sum_j k_j/2 (theta_j - rest_j)^2; damping and friction, with
dtheta_j = sum_s (d theta_j / dq_s) dq_s, and loads by virtual work, a
force f (world axes) at a point whose world position is r_p(q) and a torque
T (body axes) on a body of partial angular velocities W:

    Q_r = -dV_s/dq_r + sum_j (-c_j dtheta_j - f_j tanh(dtheta_j / v_j)) d theta_j/dq_r
          + sum_loads f . d r_p/dq_r + T . W[:, r]

A spherical joint's speeds are not rates (``kinematics``): the equations are
written in the quaternion's rates, with the unit quaternion's rotation and
w = 2 G(q) dq (``kinematics.build(rates=True)``), and its unit-norm constraint
|q|^2 = 1 adds a multiplier, M_q ddq = F_q + B_q tau + 2 lambda q (the
constraint's gradient 2 q).  With the kinematic differential equations
dq = W(q) u, ddq = W du + (dW/dt) u, and W(q)^T q = 0 (1/2 q (x) (0, w) is
normal to q), projecting on the speeds removes every multiplier:

    W^T M_q W du = W^T (F_q - M_q (dW/dt) u) + W^T B_q tau

(``on_speeds``; the null-space form of Lagrange's equations with multipliers,
as ``formulations.constrained`` does for closed loops).  These hold on the unit
sphere; the result is then evaluated at q / |q|, so that, as on every other path,
the motion does not depend on the quaternion's norm.
"""
from __future__ import annotations

import sympy as sp

from .. import forces, kinematics
from ..eom import EquationsOfMotion
from ..kinematics import Kinematics
from .kane import accelerations
from ...model.robot import Robot
from ..derivative import Derivative

Matrix = sp.ImmutableMatrix


def body_energies(kin: Kinematics, i: int) -> tuple[sp.Expr, sp.Expr]:
    """(T_i, V_i) = (1/2 m v.v + 1/2 w.I w, -m g.r) of body i."""
    b = kin.bodies[i]
    v, w = kin.velocity(i), kin.angular_velocity(i)
    kinetic = b.mass * v.dot(v) / 2 + (w.T * b.inertia * w)[0] / 2
    return kinetic, -b.mass * kin.gravity.dot(b.position)


def energies(kin: Kinematics) -> tuple[sp.Expr, sp.Expr]:
    """(T, V) of the whole robot."""
    parts = [body_energies(kin, i) for i in range(len(kin.bodies))]
    return sp.Add(*[p[0] for p in parts]), sp.Add(*[p[1] for p in parts])


def equations(robot: Robot, kin: Kinematics) -> EquationsOfMotion:
    """Lagrange's equations of ``robot`` from ``kin``, built over the coordinates' rates
    (``kinematics.build(rates=True)``); projected on the speeds with a spherical joint."""
    q, dq = kin.q, kin.dq
    n = len(q)
    T, V = energies(kin)
    momenta = [Derivative({dq[r]: 1})(T) for r in range(n)]
    M = sp.zeros(n, n)
    for r in range(n):
        for s in range(r, n):
            M[r, s] = M[s, r] = Derivative({dq[s]: 1})(momenta[r])
    rate_of_change = Derivative(dict(zip(q, dq)))     # d/dt along q with ddq = 0
    L = T - V
    F = Matrix([-rate_of_change(momenta[r]) + Derivative({q[r]: 1})(L) for r in range(n)])
    index = {b.body.name: i for i, b in enumerate(kin.bodies)}
    B = sp.zeros(n, len(robot.actuators))
    for k, actuator in enumerate(robot.actuators):
        theta = kin.bodies[index[actuator.body]].displacement
        for r in range(n):
            B[r, k] = actuator.scale.xreplace(robot.parameter_substitution(kin.symbolic)
                                              ) * sp.diff(theta, q[r])
    Q = generalized_forces(robot, kin)
    eom = EquationsOfMotion(
        formulation="lagrange", q=q, dq=dq, ddq=tuple(sp.Symbol("dd" + s.name, real=True) for s in q),
        efforts=tuple(sp.Symbol(a.name, real=True) for a in robot.actuators),
        M=Matrix(M), F=Matrix(F + Q) if Q is not None else F, B=Matrix(B), Q=Q)
    return on_speeds(robot, eom) if robot.spherical else eom


def on_speeds(robot: Robot, eom: EquationsOfMotion) -> EquationsOfMotion:
    """``eom`` in the coordinates' rates projected on the speeds (module docstring):
    W^T M W du = W^T (F - M (dW/dt) u) + W^T B tau, with dq = W(q) u put in F."""
    kinematic = kinematics.kinematic_equations(robot)
    speeds = tuple(u.symbol for u in robot.speeds)
    W = kinematic.jacobian(speeds)
    along = Derivative(dict(zip(eom.q, kinematic)))      # d/dt along dq = W u, du = 0
    drift = Matrix([along(e) for e in kinematic])         # (dW/dt) u
    rates = dict(zip(eom.dq, kinematic))

    unit = {}                                             # q -> q / |q|, per quaternion
    for b in robot.bodies:
        if b.joint.joint_type.orientation:
            quaternion = [sp.Symbol(name, real=True) for name in b.joint.coordinates]
            norm = sp.sqrt(sp.Add(*[c ** 2 for c in quaternion]))
            unit.update({c: c / norm for c in quaternion})

    def project(matrix):
        return Matrix((W.T * Matrix(matrix).xreplace(rates)).xreplace(unit))

    Q = None if eom.Q is None else project(eom.Q)
    return EquationsOfMotion(
        formulation="lagrange", q=eom.q, dq=speeds, ddq=accelerations(speeds),
        efforts=eom.efforts, M=project(eom.M * W), F=project(eom.F - eom.M * drift),
        B=project(eom.B), Q=Q, kinematic=kinematic)


def generalized_forces(robot: Robot, kin: Kinematics) -> Matrix | None:
    """Q: springs from their potential, the rest by virtual work (None: no such forces)."""
    joints, loads = forces.joint_forces(robot, kin), forces.loads(robot, kin)
    if not joints and not loads:
        return None
    q, dq = kin.q, kin.dq
    n = len(q)
    along = [Derivative({q[r]: 1}) for r in range(n)]
    rate_of = Derivative(dict(zip(q, dq)))
    Q = sp.zeros(n, 1)
    spring = sp.Add(*[j.energy(kin.bodies[j.body].displacement) for j in joints])
    for r in range(n):
        Q[r] -= along[r](spring)
    for joint in joints:
        theta = kin.bodies[joint.body].displacement
        force = joint.dissipative(rate_of(theta))
        if force != 0:
            for r in range(n):
                Q[r] += force * along[r](theta)
    for load in loads:
        b = kin.bodies[load.body]
        if load.force != Matrix.zeros(3, 1):
            point = Matrix(b.position + b.R * (load.point - b.com))      # world axes
            force = load.force if load.frame == "world" else Matrix(b.R * load.force)
            for r in range(n):
                Q[r] += force.dot(point.applyfunc(along[r]))
        if load.torque != Matrix.zeros(3, 1):
            torque = load.torque if load.frame == "body" else Matrix(b.R.T * load.torque)
            for r in range(n):
                Q[r] += torque.dot(b.W[:, r])
    return Matrix(Q)
