"""The robot with its numbers folded in, in the internal symbols the recursions
trace: _t, _q{k} (coordinates), _u{k} (speeds), _w{k} (speed rates).

The speeds u are the coordinates' rates dq for every joint but a spherical one,
whose three speeds are its angular velocity in body axes (``model.joints``,
``Robot.speeds``); a quaternion's coordinates come after the others, so that
speed k < nq - 4 * (spherical joints) is the rate of coordinate k.

Per joint speed (one per axial joint, three per spherical joint): its
displacement theta(q) (0 for a spherical joint's), the rows of J = d(theta)/du
and the Hessian term h = u^T (d^2 theta/dq^2) u, so that

    dtheta = J u,    ddtheta = J du + h

(a spherical joint's rows are unit rows, its h zero).

Mass properties about the body origin: m, h = m c, I_O = I_c + m(|c|^2 1 - c c^T).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ...model.joints import JointType
from ...model.names import GROUND
from ...model.robot import Robot
from ..contact import ContactPlan, contact_plans
from ..ir import as_expr


@dataclass
class BodyPlan:
    name: str
    parent: int | None
    joint_type: JointType            # what the joint does (``model.joints``)
    axis: list[float]
    C: list[list[float]]             # rpy rotation, joint axes -> parent axes
    C_identity: bool
    origin: list[float]
    mass: float
    h: list[float]                   # m c
    com: list[float]
    I_O: list[list[float]]           # inertia about the origin, body axes
    joint: int | None                # index of its first joint speed (``Plan.moving``)
    displacement: sp.Expr | None     # in internal coordinate symbols
    quaternion: list[int] | None = None   # a spherical joint's coordinates (indices)
    speed: int | None = None              # ... and the index of its first speed
    damping: float = 0.0
    friction: float = 0.0
    friction_velocity: float = 0.01
    stiffness: float = 0.0
    rest: float = 0.0


@dataclass
class LoadPlan:
    body: int
    point: list[sp.Expr]
    force: list[sp.Expr]
    torque: list[sp.Expr]
    frame: str


@dataclass
class Plan:
    """The robot with numbers folded, in internal symbols: _t, _q{k}, _u{k} (speeds),
    _w{k} (their rates)."""
    robot_name: str
    coordinates: tuple[str, ...]
    speeds: tuple[str, ...]                 # ``Robot.speeds``: d<q> for most joints
    efforts: tuple[str, ...]
    bodies: list[BodyPlan]
    moving: list[int]                       # body index of each joint speed
    gravity: list[float]
    actuator_joint: list[int]               # moving-joint index of each actuator
    laws: list[sp.Expr]                     # tau_k(t, q, dq) (zeros without controller)
    loads: list[LoadPlan] = field(default_factory=list)
    contacts: list[ContactPlan] = field(default_factory=list)   # ``numeric.contact``
    actuator_scale: list[float] = field(default_factory=list)  # generalized force / effort

    @property
    def n(self) -> int:
        """The number of speeds: the size of M, u and du."""
        return len(self.speeds)

    @property
    def nq(self) -> int:
        """The number of coordinates (n, or more with spherical joints)."""
        return len(self.coordinates)

    @property
    def free(self) -> bool:
        """Whether every root body is carried by a floating joint: massless slides along
        x, y and z, one on the other, then a spherical joint (``model.joints.Floating``),
        so that only the robot's loads and gravity act on it from outside."""
        children: dict[int | None, list[int]] = {}
        for i, b in enumerate(self.bodies):
            children.setdefault(b.parent, []).append(i)

        def slide(i: int, axis: int, first: bool) -> bool:
            b = self.bodies[i]
            return (b.joint_type.linear and not b.joint_type.angular and b.mass == 0
                    and [round(a, 15) for a in b.axis] == [float(k == axis) for k in range(3)]
                    and (first or (b.C_identity and not any(b.origin)))
                    and len(children.get(i, ())) == 1)

        def floating(root: int) -> bool:
            i = root
            for axis in range(3):
                if not slide(i, axis, axis == 0):
                    return False
                i = children[i][0]
            b = self.bodies[i]
            return b.quaternion is not None and b.C_identity and not any(b.origin)
        roots = children.get(None, [])
        return bool(roots) and all(floating(root) for root in roots)

    @property
    def spherical(self) -> bool:
        """Whether some speeds are not coordinate rates (nq != n)."""
        return any(b.quaternion for b in self.bodies)

    def joint_expressions(self):
        """Per joint speed: theta(q), dtheta/du (one entry per speed) and
        h = u^T (d^2 theta/dq^2) u, as SymPy expressions (computed once)."""
        if not hasattr(self, "_joint_expressions"):
            qs = [sp.Symbol(f"_q{k}", real=True) for k in range(self.n)]
            us = [sp.Symbol(f"_u{k}", real=True) for k in range(self.n)]
            out = []
            for j, b in enumerate(self.moving):
                if self.bodies[b].quaternion is not None:
                    speed = self.bodies[b].speed + j - self.bodies[b].joint
                    out.append((sp.Integer(0), [sp.Integer(int(k == speed))
                                                for k in range(self.n)], sp.Integer(0)))
                    continue
                d = self.bodies[b].displacement
                present = d.free_symbols
                grad = [sp.diff(d, qk) if qk in present else sp.Integer(0) for qk in qs]
                hess = sum((us[r] * us[s] * sp.diff(grad[r], qs[s])
                            for r in range(self.n) if grad[r].free_symbols
                            for s in range(self.n) if qs[s] in grad[r].free_symbols),
                           sp.Integer(0))
                out.append((d, grad, sp.expand(hess) if hess != 0 else hess))
            self._joint_expressions = out
        return self._joint_expressions


def _num(expr) -> float:
    return float(as_expr(expr).evalf(30))


#: bits of the arithmetic of ``_rotation_numbers``, and the size under which one of
#: its entries is an exact zero (cos(pi/2)): far below a double's resolution of 1
_PRECISION, _ZERO = 128, 1e-30


def _rotation_numbers(rpy) -> tuple[list[list[float]], bool]:
    """(R = Rz(yaw) Ry(pitch) Rx(roll) as doubles, whether those are 1) for the
    numeric angles ``rpy``: each angle to 40 digits, its cosine, sine and the
    products in 128-bit arithmetic (mpmath), each entry rounded once to a double,
    as the exact matrix's entries evaluated to 30 digits are, at a quarter of the
    cost (tests/test_recursive.py compares the two)."""
    import mpmath

    with mpmath.workprec(_PRECISION):
        c, s = [], []
        for a in rpy:
            angle = mpmath.mpf(sp.Float(as_expr(a).evalf(40), 40)._mpf_)
            c.append(mpmath.cos(angle))
            s.append(mpmath.sin(angle))
        (cr, cp, cy), (sr, sp_, sy) = c, s
        R = [[cy * cp, cy * sp_ * sr - sy * cr, cy * sp_ * cr + sy * sr],
             [sy * cp, sy * sp_ * sr + cy * cr, sy * sp_ * cr - cy * sr],
             [-sp_, cp * sr, cp * cr]]
        numbers = [[0.0 if abs(e) < _ZERO else float(e) for e in row] for row in R]
    return numbers, numbers == [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def plan(robot: Robot) -> Plan:
    """The robot's numbers (parameters substituted) and expressions in internal symbols."""
    values = robot.parameter_substitution()
    internal = {}
    for k, c in enumerate(robot.coordinates):
        internal[c.symbol] = sp.Symbol(f"_q{k}", real=True)
    speeds = robot.speeds
    for k, u in enumerate(speeds):
        internal[u.symbol] = sp.Symbol(f"_u{k}", real=True)
    coordinate_index = {c.name: k for k, c in enumerate(robot.coordinates)}
    speed_index = {u.name: k for k, u in enumerate(speeds)}
    internal[sp.Symbol("t", real=True)] = sp.Symbol("_t", real=True)

    def expr(e):
        return as_expr(e).xreplace(values).xreplace(internal)

    index = {b.name: i for i, b in enumerate(robot.bodies)}
    bodies, moving = [], []
    for body in robot.bodies:
        joint = body.joint
        parent = None if body.parent == GROUND else index[body.parent]
        Cf, C_identity = _rotation_numbers([expr(a) for a in joint.rpy])
        mass = _num(expr(body.mass))
        com = [_num(expr(c)) for c in body.com]
        I_c = [[_num(expr(body.inertia[i, j])) for j in range(3)] for i in range(3)]
        c2 = sum(c * c for c in com)
        I_O = [[I_c[i][j] + mass * ((c2 if i == j else 0.0) - com[i] * com[j])
                for j in range(3)] for i in range(3)]
        kind = joint.joint_type
        j_index = None
        if kind.moving:
            j_index = len(moving)
            moving += [len(bodies)] * kind.speeds
        bodies.append(BodyPlan(
            name=body.name, parent=parent, joint_type=kind,
            axis=[_num(expr(a)) for a in joint.axis], C=Cf,
            C_identity=C_identity,
            origin=[_num(expr(o)) for o in joint.origin], mass=mass,
            h=[mass * c for c in com], com=com, I_O=I_O, joint=j_index,
            displacement=expr(joint.displacement) if kind.moving else None,
            damping=_num(expr(getattr(joint, "damping", 0))),
            friction=_num(expr(getattr(joint, "friction", 0))),
            friction_velocity=_num(expr(getattr(joint, "friction_velocity", 0.01))),
            stiffness=_num(expr(getattr(joint, "stiffness", 0))),
            rest=_num(expr(getattr(joint, "rest", 0))),
            quaternion=[coordinate_index[c] for c in joint.coordinates] or None,
            speed=speed_index[joint.speeds[0].name] if joint.speeds else None))
    joint_of_body = {b: j for j, b in enumerate(moving)}
    actuator_joint = [joint_of_body[index[a.body]] for a in robot.actuators]
    if robot.controller is None:
        laws = [sp.Integer(0)] * len(robot.actuators)
    else:
        gains = {sp.Symbol(k, real=True): v for k, v in robot.controller.gains.items()}
        laws = [expr(robot.controller.laws[a.name].xreplace(values).xreplace(gains))
                for a in robot.actuators]
    loads = [LoadPlan(index[ld.body], [expr(p) for p in ld.point], [expr(f) for f in ld.force],
                      [expr(m) for m in ld.torque], ld.frame)
             for ld in getattr(robot, "loads", ())]
    return Plan(robot_name=robot.name, coordinates=tuple(c.name for c in robot.coordinates),
                speeds=tuple(u.name for u in speeds),
                efforts=tuple(a.name for a in robot.actuators), bodies=bodies, moving=moving,
                gravity=[_num(expr(g)) for g in robot.gravity], actuator_joint=actuator_joint,
                laws=laws, loads=loads,
                actuator_scale=[_num(expr(a.scale)) for a in robot.actuators],
                contacts=contact_plans(robot, lambda e: _num(expr(e)), index))
