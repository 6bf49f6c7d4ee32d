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
  (dq = u for every type but ``spherical``);
- ``unit`` and ``effort_unit``: of its displacement and of an effort along it.

``JOINT_TYPES`` maps the type word of a robot file to its class.

    revolute:  R_l = C Rot(a, d), o = origin,        S = (a, 0)
    prismatic: R_l = C,           o = origin + C a d, S = (0, a)
    fixed:     R_l = C,           o = origin,        no S (no coordinate)
    spherical: R_l = C R(q),      o = origin,        S = (1, 0), 3 speeds w (body axes)
               coordinates the unit quaternion q = (qw, qx, qy, qz), dq = 1/2 q (x) (0, w)
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

    #: its coordinates are a unit quaternion turning the body (``Spherical``)
    orientation = False

    @property
    def moving(self) -> bool:
        """Whether the joint adds coordinates of its own."""
        return self.coordinates > 0

    @property
    def axial(self) -> bool:
        """Whether it moves about or along its axis by one displacement (revolute,
        prismatic): the joints that take an axis, a displacement, limits, joint
        forces and actuators."""
        return self.coordinates == 1

    def columns(self, axis):
        """S column by column, one (angular, linear) pair per speed (``subspace``)."""
        return [self.subspace(axis)] if self.moving else []

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

    def coordinate_rates(self, coordinates, speeds):
        """dq = W(q) u, the kinematic differential equations: dq = u here."""
        return list(speeds)

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


class Spherical(JointType):
    """Turns freely about the joint frame's origin (a ball joint).  Coordinates: a unit
    quaternion q = (qw, qx, qy, qz), scalar first, the body's attitude in the joint
    frame; speeds: the body's angular velocity relative to its parent in body axes
    w = (wx, wy, wz).  R_l = C R(q), o = origin, S = (1, 0) (constant, body axes),
    dq = 1/2 q (x) (0, w) (Hamilton product).  R(q) is written for any non-zero q
    (divided by |q|^2), so the motion does not depend on the quaternion's norm."""
    word = "spherical"
    coordinates, speeds = 4, 3
    angular = True
    orientation = True
    unit, effort_unit = "1", "N*m"
    #: speed units (the coordinates are numbers)
    speed_unit = "rad/s"
    #: S, one unit column per speed: (angular, linear) in body axes
    COLUMNS = (((1, 0, 0), None), ((0, 1, 0), None), ((0, 0, 1), None))

    def columns(self, axis):
        """S = (1, 0): the speed wx, wy, wz turns the body about its x, y, z axis."""
        return [(list(angular), linear) for angular, linear in self.COLUMNS]

    def subspace(self, axis):
        """One column does not describe it: TypeError (``columns`` does)."""
        raise TypeError("a spherical joint has three speeds; use columns()")

    @staticmethod
    def rotation(w, x, y, z):
        """|q|^2 R(q), rows, in the caller's number type (R = this / |q|^2)."""
        return [[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]]

    def transform(self, C, origin, axis, displacement, rotation):
        """(C R(q), origin) for the quaternion ``displacement`` (w, x, y, z); C a
        SymPy or NumPy matrix (the result is of its type)."""
        w, x, y, z = displacement
        norm = w * w + x * x + y * y + z * z
        R = [[entry / norm for entry in row] for row in self.rotation(w, x, y, z)]
        if hasattr(C, "is_Matrix"):
            import sympy
            return C @ sympy.Matrix(R), origin
        import numpy
        return C @ numpy.array(R, dtype=float), origin

    def coordinate_rates(self, coordinates, speeds):
        """dq = 1/2 q (x) (0, w) for q = (w, x, y, z) and speeds (a, b, c)."""
        w, x, y, z = coordinates
        a, b, c = speeds
        return [-(x * a + y * b + z * c) * 0.5, (w * a + y * c - z * b) * 0.5,
                (w * b + z * a - x * c) * 0.5, (w * c + x * b - y * a) * 0.5]


#: type word -> joint type, in the order the robot file's messages list them
JOINT_TYPES = MappingProxyType({kind.word: kind() for kind in
                                (Revolute, Prismatic, Fixed, Spherical)})


class Compound:
    """A joint of several one-coordinate parts, each a joint of ``JOINT_TYPES`` on a
    massless link of its own (named ``<body>__<its coordinate>``), the body itself
    carrying the last part.  The robot file's loader (``model.loader.compound``)
    makes the chain, so every formulation, recursion and service sees only one-part
    joints.  ``chain`` gives the parts in order from the parent: (type word, unit
    axis in the joint frame, index of the coordinate it takes, or ``None``: the
    first coordinate times ``pitch``; a spherical part takes four, from that index:
    its quaternion)."""
    word = ""
    coordinates = 0             # how many coordinates the robot file lists for it
    moving = True               # it has coordinates (as ``JointType.moving`` says)

    def chain(self, axis, axis2, basis):
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"Compound({self.word!r})"


class Planar(Compound):
    """Moves in the plane normal to ``axis`` n: slides x along e1 and y along e2, then
    turns by theta about n (coordinates x, y, theta; e1 the joint frame's x axis, or
    its y axis when n is along x, made normal to n; e2 = n x e1)."""
    word = "planar"
    coordinates = 3

    def chain(self, axis, axis2, basis):
        e1, e2 = basis(axis)
        return [(Prismatic.word, e1, 0), (Prismatic.word, e2, 1), (Revolute.word, axis, 2)]


class Universal(Compound):
    """Turns by theta1 about ``axis``, then by theta2 about ``axis2`` (given in the
    joint frame at theta1 = 0, turning with the first turn)."""
    word = "universal"
    coordinates = 2

    def chain(self, axis, axis2, basis):
        return [(Revolute.word, axis, 0), (Revolute.word, axis2, 1)]


class Cylindrical(Compound):
    """Slides by d along ``axis`` and turns by theta about it (coordinates theta, d)."""
    word = "cylindrical"
    coordinates = 2

    def chain(self, axis, axis2, basis):
        return [(Prismatic.word, axis, 1), (Revolute.word, axis, 0)]


class Helical(Compound):
    """A screw: turns by theta about ``axis`` and slides by pitch * theta along it
    (one coordinate; ``pitch`` in m/rad)."""
    word = "helical"
    coordinates = 1

    def chain(self, axis, axis2, basis):
        return [(Prismatic.word, axis, None), (Revolute.word, axis, 0)]


class Floating(Compound):
    """Moves freely: slides x, y, z along the joint frame's axes, then turns about its
    origin as a spherical joint does (coordinates x, y, z, qw, qx, qy, qz).  Its
    speeds are the rates dx, dy, dz (the origin's velocity in the joint frame, which
    is the world frame for a robot's base) and the body's angular velocity in body
    axes (wx, wy, wz): MuJoCo's free joint."""
    word = "floating"
    coordinates = 7

    def chain(self, axis, axis2, basis):
        return [(Prismatic.word, (1, 0, 0), 0), (Prismatic.word, (0, 1, 0), 1),
                (Prismatic.word, (0, 0, 1), 2), (Spherical.word, None, 3)]


#: type word -> compound joint type (expanded by the loader into ``JOINT_TYPES`` parts)
COMPOUND_TYPES = MappingProxyType({kind.word: kind() for kind in
                                   (Planar, Universal, Cylindrical, Helical, Floating)})
