"""The robot's dynamics linear in its parameters: Q = Y(q, dq, ddq) pi.

``ParametricModel`` is the robot as identification needs it (the joint maps, the
actuators, the file's parameters, the limits) and ``regressor`` its Y: the
generated function of ``numeric.recursive.regressor`` (traced from the recursive
Newton-Euler algorithm, native C over the rows of states, or its generated
Python without a compiler), which states the parameters pi and their order:
ten per body (``INERTIAL``), then per moving joint Ia (armature), Fv (viscous
friction: the file's damping) and Fc (Coulomb friction: the file's friction).

theta is a joint's displacement; the regressor takes displacements linear in
the coordinates, theta = J q + theta0 with J constant (one coordinate, or
coupled as rr's q2 - q1 or a URDF mimic), so dtheta = J dq, ddtheta = J ddq and
the generalized forces are Q = J^T (joint efforts).  Joint springs are a known
term (``spring_efforts``), not parameters.  The actuator regressor is
B^{-1} Y: actuator efforts tau = B^{-1} (Y pi + springs), B = the actuators'
columns of J^T (one actuator per coordinate).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import sympy as sp

from ...errors import ModelError
from ...model.robot import Robot
from ...numeric.ir import as_expr
from ...numeric.recursive import plan as recursive_plan
from ...numeric.recursive.regressor import (DRIVE, INERTIA_ENTRIES, INERTIAL, Regressor,
                                            nominal, parameter_names, refuse)

__all__ = ["DRIVE", "INERTIAL", "INERTIA_ENTRIES", "ParametricModel", "parametric_model",
           "value_of"]


@dataclass(frozen=True, eq=False)
class ParametricModel:
    """An open-tree robot as identification needs it (arrays over its moving joints)
    and its regressor."""
    name: str
    source: str
    coordinates: tuple[str, ...]
    units: tuple[str, ...]                 # "rad" or "m" per coordinate
    actuators: tuple[str, ...]
    bodies: tuple[str, ...]
    joint_types: tuple                     # model.joints.JointType per body
    joint_of_body: tuple[int, ...]         # moving-joint index, -1 for a fixed joint
    J: np.ndarray                          # (nj, n) d theta / d q
    theta0: np.ndarray                     # (nj,)
    friction_velocity: np.ndarray          # (nj,)
    stiffness: np.ndarray                  # (nj,)
    rest: np.ndarray                       # (nj,)
    B: np.ndarray                          # (n, m) actuator efforts -> generalized forces
    names: tuple[str, ...]                 # the parameters pi
    nominal: np.ndarray                    # pi of the robot file
    limits: tuple                          # model.robot.JointLimits per moving joint
    robot: Robot                           # what it was made from
    plan: object                           # numeric.recursive.Plan of the robot

    @property
    def moving(self) -> list[int]:
        """Body index of each moving joint."""
        return [i for i, j in enumerate(self.joint_of_body) if j >= 0]

    @cached_property
    def generated(self) -> Regressor:
        """The generated regressor (traced, and compiled, on first use)."""
        return Regressor(self.plan)

    def regressor(self, q, dq, ddq) -> np.ndarray:
        """Y (N, n, p) with Q = Y pi the generalized forces, at N states (rows of q,
        dq, ddq; one state as 1-D arrays gives N = 1)."""
        return self.generated(*(np.atleast_2d(np.asarray(a, float)) for a in (q, dq, ddq)))

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


def value_of(expr, values) -> float:
    """The number of a robot file's expression (or number), parameters ``values`` put in."""
    return float(as_expr(expr).xreplace(values))


def parametric_model(robot: Robot) -> ParametricModel:
    """The robot as numbers for the regressor; ModelError for what it does not take
    (``numeric.recursive.regressor.refuse``: a closed chain, external loads, contacts,
    a joint type with several coordinates or a displacement not linear in the
    coordinates)."""
    refuse(robot)
    values = robot.parameter_substitution()

    def num(e) -> float:
        return value_of(e, values)

    qs = robot.q
    index = {b.name: i for i, b in enumerate(robot.bodies)}
    rows, offsets, joint_of_body, limits, drive = [], [], [], [], []
    for body in robot.bodies:
        joint = body.joint
        if not joint.joint_type.moving:
            joint_of_body.append(-1)
            continue
        d = as_expr(joint.displacement).xreplace(values)
        joint_of_body.append(len(rows))
        rows.append([float(sp.diff(d, s)) for s in qs])
        offsets.append(float(d.xreplace({s: 0 for s in qs})))
        limits.append(joint.limits)
        drive.append((num(joint.friction_velocity), num(joint.stiffness), num(joint.rest)))
    J = np.array(rows).reshape(len(rows), len(qs))
    drive = np.array(drive).reshape(len(rows), 3)
    B = np.zeros((len(qs), len(robot.actuators)))
    for a, actuator in enumerate(robot.actuators):
        B[:, a] = num(actuator.scale) * J[joint_of_body[index[actuator.body]]]
    pl = recursive_plan(robot)
    return ParametricModel(
        name=robot.name, source=robot.source,
        coordinates=tuple(c.name for c in robot.coordinates),
        units=tuple(c.unit for c in robot.coordinates),
        actuators=tuple(a.name for a in robot.actuators),
        bodies=tuple(b.name for b in robot.bodies),
        joint_types=tuple(b.joint.joint_type for b in robot.bodies),
        joint_of_body=tuple(joint_of_body), J=J, theta0=np.array(offsets),
        friction_velocity=drive[:, 0], stiffness=drive[:, 1], rest=drive[:, 2], B=B,
        names=parameter_names(pl), nominal=nominal(pl), limits=tuple(limits), robot=robot,
        plan=pl)
