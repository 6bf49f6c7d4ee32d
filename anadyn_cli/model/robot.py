"""The validated robot description: frozen dataclasses, SymPy-valued.

Every length is in m, angle in rad, mass in kg, inertia in kg*m^2, time in s.
Quantities that the file gives as expressions stay SymPy expressions in the
parameter symbols; ``Robot.parameter_values`` maps each symbol to its number.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Mapping

import sympy as sp

from .info import Simulation
from .joints import JOINT_TYPES as _JOINT_TYPES, JointType

if TYPE_CHECKING:
    from .constraints import Constraints
    from .contacts import Contacts

Vector = tuple[sp.Expr, sp.Expr, sp.Expr]
#: the type words a robot file accepts (``joints.JOINT_TYPES``)
JOINT_TYPES = tuple(_JOINT_TYPES)


def frozen_map(items) -> Mapping:
    """A read-only dict (keeps insertion order)."""
    return MappingProxyType(dict(items))


@dataclass(frozen=True)
class Coordinate:
    """A generalized coordinate q, its rate dq and its acceleration ddq."""
    name: str
    initial: sp.Expr          # q(0)
    rate: sp.Expr             # dq(0)
    unit: str                 # "rad" or "m", from the first joint that uses it

    @property
    def symbol(self) -> sp.Symbol:
        return sp.Symbol(self.name, real=True)

    @property
    def rate_symbol(self) -> sp.Symbol:
        return sp.Symbol("d" + self.name, real=True)


@dataclass(frozen=True)
class Speed:
    """A generalized speed u: the rate d<q> of a coordinate q (every joint but a
    spherical one), or a component of a spherical joint's angular velocity relative
    to its parent, in body axes (rad/s).  State x = [q, u], dq = W(q) u."""
    name: str
    initial: sp.Expr          # u(0)
    unit: str                 # "rad/s" or "m/s"

    @property
    def symbol(self) -> sp.Symbol:
        return sp.Symbol(self.name, real=True)


@dataclass(frozen=True)
class Joint:
    """Joint frame = parent frame moved by ``origin`` and turned by ``rpy``
    (R = Rz(yaw) Ry(pitch) Rx(roll)); the body frame is the joint frame turned
    about (revolute) or slid along (prismatic) ``axis`` by ``displacement``."""
    type: str
    axis: Vector              # unit vector in the joint frame (zero for fixed)
    origin: Vector
    rpy: Vector
    displacement: sp.Expr     # expression of the coordinates (0 for fixed)
    # forces along the joint (theta = displacement), reaction on the parent:
    #   -damping*dtheta - friction*tanh(dtheta/friction_velocity) - stiffness*(theta - rest)
    damping: sp.Expr = sp.Integer(0)
    friction: sp.Expr = sp.Integer(0)
    friction_velocity: sp.Expr = sp.Float(0.01)
    stiffness: sp.Expr = sp.Integer(0)
    rest: sp.Expr = sp.Integer(0)
    limits: "JointLimits" = field(default_factory=lambda: JointLimits())
    # a spherical joint: its quaternion's coordinates (qw, qx, qy, qz) and its speeds
    # (wx, wy, wz); empty for the joints whose speed is the displacement's rate
    coordinates: tuple[str, ...] = ()
    speeds: tuple[Speed, ...] = ()

    @property
    def joint_type(self) -> JointType:
        """What the type does: transform, motion subspace, coordinates (``joints``)."""
        return _JOINT_TYPES[self.type]


@dataclass(frozen=True)
class JointLimits:
    """Bounds a run is checked against (None: no bound): displacement
    lower..upper (rad or m), |rate| <= velocity, |effort| <= effort for an
    actuator on this joint."""
    lower: sp.Expr | None = None
    upper: sp.Expr | None = None
    velocity: sp.Expr | None = None
    effort: sp.Expr | None = None


@dataclass(frozen=True)
class Body:
    name: str
    parent: str               # GROUND or an earlier body's name
    joint: Joint
    mass: sp.Expr
    com: Vector               # centre of mass in body axes
    inertia: sp.ImmutableMatrix   # central inertia tensor in body axes


@dataclass(frozen=True)
class Actuator:
    """An effort along ``body``'s joint axis acting on ``body``, with the equal
    and opposite reaction on its parent: a torque (N*m) for a revolute joint,
    a force (N) for a prismatic one; through a drive (``actuators[].drive``) the
    generalized force is ``scale`` times the effort (scale = N*k_t: gear ratio N, torque
    constant k_t when the effort is a current in A)."""
    name: str
    body: str
    unit: str                 # "N*m" or "N"; "N*m" (motor torque) or "A" behind a drive
    scale: sp.Expr = sp.Integer(1)
    #: |effort| <= effort_limit (its unit): the drive's effort_limit, else the joint's
    #: limits.effort / |scale|; None: no bound
    effort_limit: sp.Expr | None = None


@dataclass(frozen=True)
class Load:
    """An external force and/or torque on ``body``: the force acts at ``point``
    (body axes, m); both vectors are expressions of t, q, dq in world axes
    (``frame`` "world") or body axes ("body"), zero when absent."""
    body: str
    point: Vector
    force: Vector
    torque: Vector
    frame: str = "world"


@dataclass(frozen=True)
class Controller:
    gains: Mapping[str, sp.Expr]      # gain name -> number
    laws: Mapping[str, sp.Expr]       # actuator name -> expression of t, q, dq


@dataclass(frozen=True)
class Trajectory:
    """Prescribed motion q(t) for 0 <= t <= duration.

    kind "cycloidal": q0 + (qf - q0)/T * (t - T/(2 pi) sin(2 pi t/T));
    kind "quintic":   q0 + (qf - q0) * (10 s^3 - 15 s^4 + 6 s^5), s = t/T;
    kind "expression": the given expressions of t (``expressions``).
    """
    kind: str
    duration: sp.Expr
    start: Mapping[str, sp.Expr]
    end: Mapping[str, sp.Expr]
    expressions: Mapping[str, sp.Expr]


@dataclass(frozen=True)
class Robot:
    name: str
    source: str                            # file the robot came from
    digest: str                            # sha256 of the file's bytes
    parameters: Mapping[str, sp.Expr]      # name -> number, or expression of earlier ones
    gravity: Vector                        # world frame, m/s^2
    coordinates: tuple[Coordinate, ...]
    bodies: tuple[Body, ...]               # parents before children
    actuators: tuple[Actuator, ...]
    controller: Controller | None = None
    loads: tuple[Load, ...] = ()
    trajectory: Trajectory | None = None
    simulation: Simulation = field(default_factory=Simulation)
    description: str = ""
    name_given: bool = True                # False: named after its file
    constraints: "Constraints | None" = None   # loops and constraints (model.constraints)
    contacts: "Contacts | None" = None         # contacts with ground planes (model.contacts)

    def parameter_substitution(self, symbolic: bool = False) -> dict[sp.Symbol, sp.Expr]:
        """Parameter symbol -> value, for ``xreplace``.

        Numeric (default): every parameter -> its number.  Symbolic: only the
        parameters defined by other parameters are replaced (by their
        definitions), so the result is in the independent parameters.
        """
        resolved: dict[sp.Symbol, sp.Expr] = {}
        for name, definition in self.parameters.items():
            value = definition.xreplace(resolved)
            if not symbolic or definition.free_symbols:
                resolved[sp.Symbol(name, real=True)] = value
        return resolved

    @property
    def q(self) -> tuple[sp.Symbol, ...]:
        return tuple(c.symbol for c in self.coordinates)

    @property
    def dq(self) -> tuple[sp.Symbol, ...]:
        return tuple(c.rate_symbol for c in self.coordinates)

    @property
    def speeds(self) -> tuple[Speed, ...]:
        """The generalized speeds u, in state order: the rates d<q> of the coordinates
        that are not a quaternion's (those come first among the coordinates, so rate k
        is speed k), then each spherical joint's (wx, wy, wz) in body order.  Without
        spherical joints, exactly the coordinates' rates."""
        quaternions = {name for b in self.bodies for name in b.joint.coordinates}
        rates = tuple(Speed(c.rate_symbol.name, c.rate, f"{c.unit}/s")
                      for c in self.coordinates if c.name not in quaternions)
        return rates + tuple(u for b in self.bodies for u in b.joint.speeds)

    @property
    def spherical(self) -> bool:
        """Whether a joint's speeds are not its coordinates' rates (a spherical joint)."""
        return any(b.joint.joint_type.orientation for b in self.bodies)

    def refuse_spherical(self, what: str) -> None:
        """ModelError (one line, exit 2) when the robot has a spherical joint: ``what``
        (closed forms, derivatives) knows only speeds that are coordinate rates."""
        if self.spherical:
            from ..errors import ModelError

            raise ModelError(f"{what} of a robot with a spherical joint are not supported "
                             "yet (its speeds are not its coordinates' rates); simulate, "
                             "check and accuracy run it", source=self.source)

    def refuse_contacts(self, what: str) -> None:
        """ModelError (one line, exit 2) when the robot has contacts (``model.contacts``):
        their forces exist only in the recursive dynamics, which ``what`` does not run."""
        if self.contacts is not None:
            from ..errors import ModelError

            raise ModelError(f"{what} of a robot with contacts are not supported yet (the "
                             "contact forces exist only in the recursive dynamics); simulate, "
                             "check and accuracy run it", source=self.source)

    def body(self, name: str) -> Body:
        return next(b for b in self.bodies if b.name == name)

    def __repr__(self) -> str:
        """One line: ``<Robot rr: 2 DOF (q1, q2), 2 bodies, 2 actuators; robots/rr.yaml>``
        (the degrees of freedom are the speeds; the coordinates are listed)."""
        names = ", ".join(c.name for c in self.coordinates[:6])
        more = ", ..." if len(self.coordinates) > 6 else ""
        return (f"<Robot {self.name}: {len(self.speeds)} DOF ({names}{more}), "
                f"{len(self.bodies)} bodies, {len(self.actuators)} actuators; {self.source}>")

    def _repr_html_(self) -> str:
        """Jupyter: the one-line summary and a table of the bodies and their joints."""
        from html import escape

        values = self.parameter_substitution()
        rows = "".join(
            f"<tr><td>{escape(b.name)}</td><td>{escape(b.parent)}</td><td>{b.joint.type}</td>"
            f"<td>{escape(str(b.joint.displacement))}</td>"
            f"<td>{float(b.mass.xreplace(values)):.6g}</td></tr>" for b in self.bodies)
        return (f"<p>{escape(repr(self))}</p><table><tr><th>body</th><th>parent</th>"
                f"<th>joint</th><th>displacement</th><th>mass (kg)</th></tr>{rows}</table>")
