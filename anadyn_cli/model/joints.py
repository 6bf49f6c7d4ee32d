"""Joint types: one class per type, the one place that says what a joint does.

A joint moves its body's frame relative to the joint frame (the parent frame
moved by ``origin`` and turned by C = Rz(yaw) Ry(pitch) Rx(roll)) by its
displacement d (an expression of the generalized coordinates) along its unit
``axis`` a.  Each type owns:

- ``coordinates`` and ``speeds``: how many displacements and speeds it adds
  (the speeds are the displacement rates for every type here);
- ``transform``: the body frame in the parent frame as a function of d,
  (R_l, o) with R_l body axes -> parent axes and o the body origin in
  parent axes;
- ``subspace``: the motion subspace S, the body's spatial velocity relative to
  its parent per unit speed, as (angular part, linear part) in body axes, a part
  None where the joint allows no motion of that kind; every recursion (the
  partial velocities of ``symbolic.kinematics``, Kane's accelerations, the
  Newton-Euler, composite-body and articulated-body recursions of
  ``numeric.recursive``) reads the joint through it;
- ``coordinate_rates``: its kinematic differential equations, dq = W(q) u
  (dq = u for every type here);
- ``unit`` and ``effort_unit``: of its displacement and of an effort along it.

``JOINT_TYPES`` maps the type word of a robot file to its class.

    revolute:  R_l = C Rot(a, d), o = origin,        S = (a, 0)
    prismatic: R_l = C,           o = origin + C a d, S = (0, a)
    fixed:     R_l = C,           o = origin,        no S (no coordinate)
"""
from __future__ import annotations

from types import MappingProxyType


class JointType:
    """A joint type (see the module docstring).  ``angular`` / ``linear``: whether S
    has an angular / a linear part; the transform turns about the axis where it is
    angular and slides along it where it is linear."""
    word = ""
    coordinates = 0
    speeds = 0
    angular = False
    linear = False
    unit: str | None = None
    effort_unit: str | None = None

    @property
    def moving(self) -> bool:
        """Whether the joint adds a displacement (a coordinate of its own)."""
        return self.coordinates > 0

    def transform(self, C, origin, axis, displacement, rotation):
        """(R_l, o) for the rpy rotation ``C``, the ``origin`` and ``axis`` (column
        vectors of SymPy or NumPy) and the displacement; ``rotation(axis, angle)``
        is Rot(a, angle) in the caller's number type."""
        if self.angular:
            return C @ rotation(axis, displacement), origin
        if self.linear:
            return C, origin + C @ axis * displacement
        return C, origin

    def subspace(self, axis):
        """(angular, linear) parts of S for the unit ``axis`` (body axes); None where
        the joint allows no motion."""
        return (axis if self.angular else None), (axis if self.linear else None)

    def coordinate_rates(self, speeds):
        """dq = W(q) u, the kinematic differential equations: dq = u here."""
        return speeds

    def __repr__(self) -> str:
        return f"JointType({self.word!r})"


class Revolute(JointType):
    """Turns about the axis by the angle d (rad): R_l = C Rot(a, d), S = (a, 0)."""
    word = "revolute"
    coordinates = speeds = 1
    angular = True
    unit, effort_unit = "rad", "N*m"


class Prismatic(JointType):
    """Slides along the axis by d (m): o = origin + C a d, S = (0, a)."""
    word = "prismatic"
    coordinates = speeds = 1
    linear = True
    unit, effort_unit = "m", "N"


class Fixed(JointType):
    """Welds the body to its parent: R_l = C, o = origin; no coordinate."""
    word = "fixed"


#: type word -> joint type, in the order the robot file's messages list them
JOINT_TYPES = MappingProxyType({kind.word: kind() for kind in (Revolute, Prismatic, Fixed)})
