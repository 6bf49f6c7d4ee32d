"""The joint forces and external loads of a robot, as both formulations see them.

A joint force acts along the joint's displacement theta(q) (a torque about
a revolute joint's axis, a force along a prismatic joint's axis) on the
body, with the reaction on its parent, like an actuator:

    tau = -c dtheta - f tanh(dtheta / v) - k (theta - rest)

c damping, f the Coulomb friction magnitude smoothed over the joint rate v
(``friction_velocity``: tanh(dtheta / v) is 0.76 at dtheta = v and 0.995 at
3 v), k stiffness.  The spring is conservative, with energy
k/2 (theta - rest)^2; damping and friction dissipate the power
c dtheta^2 + f dtheta tanh(dtheta / v) >= 0.

A load is a force at a point fixed in a body plus a torque on that body,
each three expressions of t, q and dq in world or body axes.

This module says only *what* the forces are, with the parameters substituted
as the kinematics substituted them; how they enter the equations is each
formulation's own business (Kane: projected on its partial velocities;
Lagrange: springs from their potential, the rest by virtual work).  Joints
and loads with nothing to add are left out, so a robot without them derives
exactly the equations it derived before.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..model.robot import Robot
from .kinematics import Kinematics
from ..model.expressions import as_expr

Matrix = sp.ImmutableMatrix


@dataclass(frozen=True)
class JointForce:
    body: int                  # index into Kinematics.bodies
    damping: sp.Expr           # c: N*m*s/rad or N*s/m
    friction: sp.Expr          # f: N*m or N
    friction_velocity: sp.Expr  # v: rad/s or m/s
    stiffness: sp.Expr         # k: N*m/rad or N/m
    rest: sp.Expr              # rad or m

    def dissipative(self, rate: sp.Expr) -> sp.Expr:
        """-c dtheta - f tanh(dtheta / v): damping and smoothed Coulomb friction."""
        terms = []
        if self.damping != 0:
            terms.append(-self.damping * rate)
        if self.friction != 0:
            terms.append(-self.friction * sp.tanh(rate / self.friction_velocity))
        return sp.Add(*terms)

    def spring(self, theta: sp.Expr) -> sp.Expr:
        """-k (theta - rest)."""
        return -self.stiffness * (theta - self.rest) if self.stiffness != 0 else sp.Integer(0)

    def energy(self, theta: sp.Expr) -> sp.Expr:
        """k/2 (theta - rest)^2, the spring's potential energy."""
        if self.stiffness == 0:
            return sp.Integer(0)
        return self.stiffness * (theta - self.rest) ** 2 / 2

    def law(self, theta: sp.Expr, rate: sp.Expr) -> sp.Expr:
        """tau along the joint at displacement theta and rate dtheta."""
        return self.dissipative(rate) + self.spring(theta)


@dataclass(frozen=True)
class LoadValues:
    body: int                  # index into Kinematics.bodies
    point: Matrix              # body axes, m (3 x 1)
    force: Matrix              # N, in ``frame`` axes (3 x 1)
    torque: Matrix             # N*m, in ``frame`` axes
    frame: str                 # "world" or "body"


def _substitution(robot: Robot, kin: Kinematics):
    values = robot.parameter_substitution(kin.symbolic)
    return lambda expr: as_expr(expr).xreplace(values) if values else as_expr(expr)


def joint_forces(robot: Robot, kin: Kinematics) -> tuple[JointForce, ...]:
    """The joints with damping, friction or a spring, in the order of the bodies."""
    sub = _substitution(robot, kin)
    found = []
    for i, b in enumerate(kin.bodies):
        joint = b.body.joint
        if not joint.joint_type.moving:
            continue
        velocity = sub(joint.friction_velocity)
        if isinstance(velocity, sp.Float):      # the default 0.01: exact, as the file's are
            velocity = sp.Rational(str(float(velocity)))
        force = JointForce(i, sub(joint.damping), sub(joint.friction), velocity,
                           sub(joint.stiffness), sub(joint.rest))
        if force.damping != 0 or force.friction != 0 or force.stiffness != 0:
            found.append(force)
    return tuple(found)


def loads(robot: Robot, kin: Kinematics) -> tuple[LoadValues, ...]:
    """The loads with a nonzero force or torque, in file order."""
    sub = _substitution(robot, kin)
    index = {b.body.name: i for i, b in enumerate(kin.bodies)}
    found = []
    for load in robot.loads:
        values = LoadValues(index[load.body], Matrix([sub(c) for c in load.point]),
                            Matrix([sub(c) for c in load.force]),
                            Matrix([sub(c) for c in load.torque]), load.frame)
        if values.force != Matrix.zeros(3, 1) or values.torque != Matrix.zeros(3, 1):
            found.append(values)
    return tuple(found)


def spring_energy(robot: Robot, kin: Kinematics) -> sp.Expr:
    """sum over the joints of k/2 (theta - rest)^2."""
    return sp.Add(*[f.energy(kin.bodies[f.body].displacement)
                    for f in joint_forces(robot, kin)])
