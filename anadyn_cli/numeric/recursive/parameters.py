"""The derivatives of the dynamics with respect to chosen parameters or gains of the
robot file, traced from the recursions: ``parameter_jacobian``

    P = dID/dp (n x k) at fixed (t, q, dq, ddq),   ID = M ddq - F - B e,

so that d(ddq)/dp = -M^-1 P at ddq = M^-1 (F + B e) (open loop: the efforts given,
not their control laws; a gain's column is zero), and ``law_slopes``: the efforts
under the control laws tau(t, q, dq) and L = B dtau/dp, so that in closed loop
(e = tau) d(ddq)/dp = M^-1 (L - P).  The robot's numbers are folded into the traced code, so
a parameter p reaches it in three ways, each differentiated exactly:

- joint placements (``origin``): each body whose origin moves with p gets a
  massless virtual prismatic joint before it, along do/dp, with the atom _p<k>
  as its displacement (zero, no rate, not in J); forward-mode differentiation of
  the traced Newton-Euler recursion in the seeds _p<k> gives dID/dp at fixed
  mass properties (``Program.derivatives``, as the state Jacobian);
- mass properties (m, h = m c, I_O), joint dampers, friction and springs, loads:
  ID is linear in each of them, so their share of dID/dp is the recursion run
  with dm/dp, dh/dp, dI_O/dp, d(damping)/dp, ... in their place, the loads'
  dF/dp and dT/dp as the only loads;
- gravity: the base acceleration -g is, for each body, the load m g at its
  centre of mass, so dg/dp enters as the loads m dg/dp in the same run.

A parameter is refused (``ModelError``) where it enters what this does not
differentiate: a joint's axis, rpy, displacement, spring rest position or
friction velocity, a load's point, an actuator's drive (gear, torque constant); and a
parameter defined by other parameters.
"""
from __future__ import annotations

from dataclasses import replace

import sympy as sp

from ...errors import ModelError
from ...model.joints import Prismatic
from ..ir import ZERO, Ex, Program, Statement, as_expr
from .plan import BodyPlan, LoadPlan, Plan
from .rnea import inverse_dynamics
from .spatial import to_ex
from .trace import Traced, _finish, state_args
from .tracer import Tracer

_ZERO3 = [0.0, 0.0, 0.0]


def chosen(robot, names) -> tuple[str, ...]:
    """The chosen names, each an independent parameter or a gain of ``robot``."""
    names = tuple(names)
    gains = robot.controller.gains if robot.controller is not None else {}
    for name in names:
        if name not in robot.parameters and name not in gains:
            raise ModelError(f"{robot.name} has no parameter or gain {name!r}; its parameters: "
                             f"{', '.join(sorted(robot.parameters)) or 'none'}; its gains: "
                             f"{', '.join(sorted(gains)) or 'none'}", robot.source, "parameters")
        if name in robot.parameters and as_expr(robot.parameters[name]).free_symbols:
            raise ModelError(f"{name} is defined by other parameters; differentiate with "
                             "respect to those", robot.source, "parameters")
    if len(set(names)) != len(names):
        raise ModelError("a parameter is named twice", robot.source, "parameters")
    return names


class _Slope:
    """d(expression)/dp at the robot's numbers, for one parameter p."""

    def __init__(self, robot, name: str):
        self.robot, self.name = robot, name
        self.symbol = sp.Symbol(name, real=True)
        self.definitions = robot.parameter_substitution(symbolic=True)
        self.values = robot.parameter_substitution()

    def expr(self, e) -> sp.Expr:
        d = sp.diff(as_expr(e).xreplace(self.definitions), self.symbol)
        return d.xreplace(self.values)

    def number(self, e) -> float:
        return float(self.expr(e).evalf(30))

    def none(self, e, where: str) -> None:
        """Refuse p where it enters ``where``."""
        if self.expr(e) != 0:
            raise ModelError(f"{self.name} enters {where}; the parameter derivatives cover "
                             "masses, centres of mass, inertias, joint origins, gravity, "
                             "joint damping, friction and stiffness, and load forces",
                             self.robot.source, "parameters")


def _inertia_slope(s: _Slope, body) -> tuple[float, list, list]:
    """dm/dp, dh/dp, dI_O/dp of one body (I_O = I_c + m(|c|^2 1 - c c^T))."""
    values = s.values
    m = float(as_expr(body.mass).xreplace(values).evalf(30))
    c = [float(as_expr(x).xreplace(values).evalf(30)) for x in body.com]
    dm = s.number(body.mass)
    dc = [s.number(x) for x in body.com]
    dI = [[s.number(body.inertia[i, j]) for j in range(3)] for i in range(3)]
    c2, cdc = sum(x * x for x in c), sum(x * y for x, y in zip(c, dc))
    dIO = [[dI[i][j] + dm * ((c2 if i == j else 0.0) - c[i] * c[j])
            + m * ((2.0 * cdc if i == j else 0.0) - dc[i] * c[j] - c[i] * dc[j])
            for j in range(3)] for i in range(3)]
    return dm, [dm * c[i] + m * dc[i] for i in range(3)], dIO


def _internal(robot) -> dict:
    """Robot symbols -> the plan's internal ones (``plan``'s mapping)."""
    internal = {sp.Symbol("t", real=True): sp.Symbol("_t", real=True)}
    for k, c in enumerate(robot.coordinates):
        internal[c.symbol] = sp.Symbol(f"_q{k}", real=True)
    for k, u in enumerate(robot.speeds):
        internal[u.symbol] = sp.Symbol(f"_u{k}", real=True)
    return internal


def _slopes(robot, pl: Plan, s: _Slope):
    """For one parameter: (body index -> d(origin)/dp where nonzero, the plan with
    every linear field replaced by its slope and the slope loads)."""
    index = {b.name: i for i, b in enumerate(pl.bodies)}
    internal = _internal(robot)
    moves, bodies, loads = {}, list(pl.bodies), []
    dg = [s.number(g) for g in robot.gravity]
    for actuator in robot.actuators:
        s.none(actuator.scale, f"actuator {actuator.name}'s drive (its gear and torque constant)")
    for body in robot.bodies:
        i, joint = index[body.name], body.joint
        for what, value in (("an axis", joint.axis), ("an rpy", joint.rpy)):
            for x in value:
                s.none(x, f"{body.name}'s joint {what}")
        for what in ("displacement", "rest", "friction_velocity"):
            if hasattr(joint, what):
                s.none(getattr(joint, what), f"{body.name}'s joint {what}")
        do = [s.number(x) for x in joint.origin]
        if any(do):
            moves[i] = do
        dm, dh, dIO = _inertia_slope(s, body)
        passive = {what: s.number(getattr(joint, what, 0))
                   for what in ("damping", "friction", "stiffness")}
        bodies[i] = replace(pl.bodies[i], mass=dm, h=dh, I_O=dIO, **passive)
        b = pl.bodies[i]
        if any(dg) and b.mass:
            loads.append(LoadPlan(i, [sp.Float(x) for x in b.com],
                                  [sp.Float(b.mass * g) for g in dg], [sp.Integer(0)] * 3,
                                  "world"))
    for ld in getattr(robot, "loads", ()):
        for x in ld.point:
            s.none(x, f"a load's point on {ld.body}")
        force = [s.expr(x).xreplace(internal) for x in ld.force]
        torque = [s.expr(x).xreplace(internal) for x in ld.torque]
        if any(x != 0 for x in force + torque):
            loads.append(LoadPlan(index[ld.body], [as_expr(x).xreplace(s.values).xreplace(
                internal) for x in ld.point], force, torque, ld.frame))
    return moves, replace(pl, bodies=bodies, loads=loads)


def _virtual(pl: Plan, moves: dict[int, list]) -> Plan:
    """``pl`` with massless prismatic joints before the bodies whose origin moves:
    moves[i] = [(k, do/dp_k), ...], displacement _p<k>."""
    prismatic = Prismatic()
    eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    new, bodies, virtual = {}, [], []
    moving = list(pl.moving)
    for i, b in enumerate(pl.bodies):
        parent = None if b.parent is None else new[b.parent]
        if i in moves:
            origin = b.origin
            for k, axis in moves[i]:
                virtual.append(len(bodies))
                bodies.append(BodyPlan(
                    name=f"{b.name}/_p{k}", parent=parent, joint_type=prismatic, axis=axis,
                    C=eye, C_identity=True, origin=origin, mass=0.0, h=_ZERO3, com=_ZERO3,
                    I_O=[_ZERO3] * 3, joint=len(pl.moving) + len(virtual) - 1,
                    displacement=sp.Symbol(f"_p{k}", real=True)))
                parent, origin = len(bodies) - 1, _ZERO3
            b = replace(b, origin=_ZERO3)
        new[i] = len(bodies)
        bodies.append(replace(b, parent=parent))
    moving = [new[i] for i in moving] + virtual
    loads = [replace(ld, body=new[ld.body]) for ld in pl.loads]
    return replace(pl, bodies=bodies, moving=moving, loads=loads)


def trace_law_slopes(robot, pl: Plan, names) -> Traced:
    """``law_slopes(t, q, dq)``: the actuators' efforts under the control laws, tau (m),
    and L = B dtau/dp (n x k), the generalized forces of the laws' slopes (a gain
    defined from parameters is taken as its number)."""
    n, k = pl.n, len(names)
    controller = robot.controller
    gains = {sp.Symbol(g, real=True): v for g, v in controller.gains.items()} if controller else {}
    internal = _internal(robot)
    P = Program()
    with P:
        T = Tracer(pl, P)
        tau = T.efforts()
        _, rows, _ = T.joint_maps()
        slopes = [[ZERO] * k for _ in range(n)]
        for j, name in enumerate(names):
            s = _Slope(robot, name)
            for a, actuator in enumerate(robot.actuators if controller else ()):
                d = s.expr(controller.laws[actuator.name]).xreplace(gains).xreplace(internal)
                if d != 0:
                    dtau = P.emit(to_ex(P, d) * pl.actuator_scale[a])
                    row = rows[pl.actuator_joint[a]]
                    for r in range(n):
                        slopes[r][j] = slopes[r][j] + row[r] * dtau
        L = [[P.emit(x) for x in row] for row in slopes]
    return _finish("law_slopes", state_args(pl), P, {"tau": tau, "L": L})


def trace_parameter_jacobian(robot, pl: Plan, names) -> Traced:
    """``parameter_jacobian(t, q, dq, ddq)``: P = dID/dp (n x k) for the parameters
    ``names`` (checked by ``chosen``)."""
    n, k = pl.n, len(names)
    slopes = [_slopes(robot, pl, _Slope(robot, name)) for name in names]
    moves: dict[int, list] = {}
    for j, (move, _) in enumerate(slopes):
        for i, do in move.items():
            moves.setdefault(i, []).append((j, do))
    w = [Ex.atom(f"_w{r}") for r in range(n)]
    P = Program()
    columns = [[ZERO] * k for _ in range(n)]
    with P:
        if moves:
            ID = inverse_dynamics(Tracer(_virtual(pl, moves), P), w, actuators=False)
            D = P.derivatives({f"_p{j}": j for j in range(k)})
            for r in range(n):
                for j, d in P.derivative_of(ID[r], D).items():
                    columns[r][j] = d
        for j, (_, linear) in enumerate(slopes):
            for r, x in enumerate(inverse_dynamics(Tracer(linear, P), w, actuators=False)):
                columns[r][j] = columns[r][j] + x
        out = [[P.emit(x) for x in row] for row in columns]
    # the virtual displacements are zero: one statement each, ahead of the rest
    P.statements[:0] = [Statement(f"_p{j}", "sum", {}) for j in range(k)]
    return _finish("parameter_jacobian", state_args(pl) + [f"_w{r}" for r in range(n)], P,
                   {"P": out})
