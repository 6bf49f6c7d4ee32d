"""Recursive (Newton-Euler) dynamics of a robot, traced into straight-line code.

Nothing here builds closed forms: each step of the recursions below is
traced (``ir.Ex``) with the robot's numbers folded in and emitted as one
statement per scalar quantity, so the code grows like the recursions.

Conventions (those of ``anadyn_cli.symbolic.kinematics``).  Body i has the
moving-joint displacement theta_i = displacement_i(q), a unit axis a_i
(joint axes = body axes), E_i = R_local^T turning parent axes into body
axes (revolute: E = Rot(a, theta)^T C^T, otherwise C^T, C = Rz Ry Rx of
rpy) and r_i its origin in parent axes (prismatic: origin + C a theta).
Joint rates from coordinate rates, with J = d(theta)/dq and H_i the Hessian
of theta_i:

    dtheta = J dq,    ddtheta = J ddq + h,    h_i = dq^T H_i dq

Mass properties about the body origin: m, h = m c, I_O = I_c + m(|c|^2 1 - c c^T).

RNEA (Featherstone ch. 5, in body axes, classical accelerations of the
origin, gravity as the base acceleration a_0 = -g):

    w_i  = E w_p + a dtheta                                    (revolute)
    al_i = E al_p + a ddtheta + (E w_p) x a dtheta             (revolute)
    ao_i = E (ao_p + al_p x r + w_p x (w_p x r))
           [+ a ddtheta + 2 (E w_p) x a dtheta]                (prismatic)
    f_i  = m ao + al x h + w x (w x h) - F_ext + sum_children E_c^T f_c
    n_i  = I_O al + w x (I_O w) + h x ao - (p x F_ext + T_ext)
           + sum_children (E_c^T n_c + r_c x E_c^T f_c)
    tau_i = a . n_i (revolute) or a . f_i (prismatic)

Residual on the coordinates (``inverse dynamics``):

    ID(t, q, dq, ddq) = J^T (tau - tau_passive - tau_actuators) = M ddq - F - B tau
    tau_passive_i = -damping dtheta - friction tanh(dtheta / friction_velocity)
                    - stiffness (theta - rest)

CRBA: composite inertias from the leaves to the root, moved to the parent
origin with I_P = E^T I E + m(|r|^2 1 - r r^T) + 2 (r.h') 1 - r h'^T - h' r^T,
h_P = h' + m r (h' = E^T h); then for joint i, F = I_i S_i (S = (a, 0) or
(0, a)) carried to each ancestor j by n <- E^T n + r x E^T f, f <- E^T f
gives H_ij = S_j . F, and M = J^T H J.  Entries for bodies on different
branches are structurally zero.

Forward dynamics, whichever costs fewer operations for the robot at hand:
M ddq = G = -ID(t, q, dq, 0) with the actuators, solved by an unrolled
Cholesky factorization in an elimination order that takes leaves first
(greedy minimum fill), so that a tree's factor has no fill-in; or the
articulated-body algorithm (``Tracer.aba``, O(n)) in joint space, then
ddq = J^-1 (ddtheta - h), when J is constant and invertible.  Short chains and
bushy trees favour the first, long chains the second.

Jacobian: K = -d ID/d[q, dq] at fixed ddq (forward-mode differentiation of
the traced residual), so that d(ddq)/dx = M^-1 K.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..model.names import GROUND
from ..model.robot import Robot
from ..symbolic.kinematics import rpy_rotation
from .ir import ONE, ZERO, Counts, Ex, Program, as_expr, count, prune

Vec = list  # three Ex


# small vector algebra on Ex --------------------------------------------------

def cross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a: Vec, b: Vec) -> Ex:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def add(*vectors: Vec) -> Vec:
    return [sum((v[k] for v in vectors), ZERO) for k in range(3)]


def sub(a: Vec, b: Vec) -> Vec:
    return [a[k] - b[k] for k in range(3)]


def scale(a: Vec, s) -> Vec:
    return [x * s for x in a]


def matvec(E, v: Vec) -> Vec:
    return [E[i][0] * v[0] + E[i][1] * v[1] + E[i][2] * v[2] for i in range(3)]


def matTvec(E, v: Vec) -> Vec:
    return [E[0][i] * v[0] + E[1][i] * v[1] + E[2][i] * v[2] for i in range(3)]


def emitv(P: Program, v: Vec) -> Vec:
    return [P.emit(x) for x in v]


def const_vec(values) -> Vec:
    return [Ex.const(float(v)) for v in values]


# the robot's numbers ----------------------------------------------------------

@dataclass
class BodyPlan:
    name: str
    parent: int | None
    kind: str
    axis: list[float]
    C: list[list[float]]             # rpy rotation, joint axes -> parent axes
    C_identity: bool
    origin: list[float]
    mass: float
    h: list[float]                   # m c
    com: list[float]
    I_O: list[list[float]]           # inertia about the origin, body axes
    joint: int | None                # index among the moving joints
    displacement: sp.Expr | None     # in internal coordinate symbols
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
    """The robot with numbers folded, in internal symbols: _t, _q{k}, _u{k} (rates),
    _w{k} (accelerations)."""
    robot_name: str
    coordinates: tuple[str, ...]
    efforts: tuple[str, ...]
    bodies: list[BodyPlan]
    moving: list[int]                       # body index of each moving joint
    gravity: list[float]
    actuator_joint: list[int]               # moving-joint index of each actuator
    laws: list[sp.Expr]                     # tau_k(t, q, dq) (zeros without controller)
    loads: list[LoadPlan] = field(default_factory=list)

    @property
    def n(self) -> int:
        return len(self.coordinates)

    def joint_expressions(self):
        """Per moving joint: theta(q), dtheta/dq (one entry per coordinate) and
        h = dq^T (d^2 theta/dq^2) dq, as SymPy expressions (computed once)."""
        if not hasattr(self, "_joint_expressions"):
            qs = [sp.Symbol(f"_q{k}", real=True) for k in range(self.n)]
            us = [sp.Symbol(f"_u{k}", real=True) for k in range(self.n)]
            out = []
            for b in self.moving:
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


def plan(robot: Robot) -> Plan:
    """The robot's numbers (parameters substituted) and expressions in internal symbols."""
    values = robot.parameter_substitution()
    internal = {}
    for k, c in enumerate(robot.coordinates):
        internal[c.symbol] = sp.Symbol(f"_q{k}", real=True)
        internal[c.rate_symbol] = sp.Symbol(f"_u{k}", real=True)
    internal[sp.Symbol("t", real=True)] = sp.Symbol("_t", real=True)

    def expr(e):
        return as_expr(e).xreplace(values).xreplace(internal)

    index = {b.name: i for i, b in enumerate(robot.bodies)}
    bodies, moving = [], []
    for body in robot.bodies:
        joint = body.joint
        parent = None if body.parent == GROUND else index[body.parent]
        C = rpy_rotation([expr(a) for a in joint.rpy])
        Cf = [[_num(C[i, j]) for j in range(3)] for i in range(3)]
        mass = _num(expr(body.mass))
        com = [_num(expr(c)) for c in body.com]
        I_c = [[_num(expr(body.inertia[i, j])) for j in range(3)] for i in range(3)]
        c2 = sum(c * c for c in com)
        I_O = [[I_c[i][j] + mass * ((c2 if i == j else 0.0) - com[i] * com[j])
                for j in range(3)] for i in range(3)]
        kind = joint.type
        j_index = None
        if kind != "fixed":
            j_index = len(moving)
            moving.append(len(bodies))
        bodies.append(BodyPlan(
            name=body.name, parent=parent, kind=kind,
            axis=[_num(expr(a)) for a in joint.axis], C=Cf,
            C_identity=(C == sp.eye(3)),
            origin=[_num(expr(o)) for o in joint.origin], mass=mass,
            h=[mass * c for c in com], com=com, I_O=I_O, joint=j_index,
            displacement=expr(joint.displacement) if kind != "fixed" else None,
            damping=_num(expr(getattr(joint, "damping", 0))),
            friction=_num(expr(getattr(joint, "friction", 0))),
            friction_velocity=_num(expr(getattr(joint, "friction_velocity", 0.01))),
            stiffness=_num(expr(getattr(joint, "stiffness", 0))),
            rest=_num(expr(getattr(joint, "rest", 0)))))
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
                efforts=tuple(a.name for a in robot.actuators), bodies=bodies, moving=moving,
                gravity=[_num(expr(g)) for g in robot.gravity], actuator_joint=actuator_joint,
                laws=laws, loads=loads)


# SymPy -> Ex ---------------------------------------------------------------------

_CALLS = {sp.sin: "sin", sp.cos: "cos", sp.tanh: "tanh"}


def to_ex(P: Program, e) -> Ex:
    """A SymPy expression of the internal symbols as an Ex: sums, products, integer
    powers, sin, cos, tanh and sqrt are traced; anything else is one SymPy statement."""
    e = as_expr(e)
    if e.is_number:
        return Ex.const(float(e))
    if isinstance(e, sp.Symbol):
        return Ex.atom(e.name)
    if isinstance(e, sp.Add):
        return sum((to_ex(P, a) for a in e.args), ZERO)
    if isinstance(e, sp.Mul):
        result = ONE
        for a in e.args:
            result = result * to_ex(P, a)
        return result
    if isinstance(e, sp.Pow) and e.exp.is_Integer and 1 <= int(e.exp) <= 4:
        base = P.emit(to_ex(P, e.base))
        result = base
        for _ in range(int(e.exp) - 1):
            result = P.emit(result * base)
        return result
    if isinstance(e, sp.Pow) and e.exp == -1:
        return P.call("recip", P.emit(to_ex(P, e.base)))
    if isinstance(e, sp.Pow) and e.exp == sp.Rational(1, 2):
        return P.call("sqrt", P.emit(to_ex(P, e.base)))
    if type(e) in _CALLS:
        return P.call(_CALLS[type(e)], P.emit(to_ex(P, e.args[0])))
    return P.sympy(e)


def _skew(v) -> list[list[float]]:
    return [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]


def _skew_ex(v: Vec) -> list[list[Ex]]:
    return [[ZERO, -v[2], v[1]], [v[2], ZERO, -v[0]], [-v[1], v[0], ZERO]]


def _congruence(P: Program, A, E, symmetric: bool):
    """E^T A E (entries emitted; symmetric: the upper triangle, mirrored)."""
    AE = [[P.emit(sum((A[r][k] * E[k][c] for k in range(3)), ZERO)) for c in range(3)]
          for r in range(3)]
    out = [[None] * 3 for _ in range(3)]
    for r in range(3):
        for c in range(3):
            if symmetric and c < r:
                out[r][c] = out[c][r]
            else:
                out[r][c] = P.emit(sum((E[k][r] * AE[k][c] for k in range(3)), ZERO))
    return out


# the recursions ---------------------------------------------------------------

class Tracer:
    """Traces the recursions of one robot into one Program."""

    def __init__(self, plan: Plan, P: Program):
        self.plan, self.P = plan, P
        n = plan.n
        self.q = [Ex.atom(f"_q{k}") for k in range(n)]
        self.dq = [Ex.atom(f"_u{k}") for k in range(n)]
        self.t = Ex.atom("_t")
        self._frames = None
        self._joint = None
        #: the actuators' efforts as inputs (atoms _e0, _e1, ...) instead of their laws
        self.given_efforts: list[Ex] | None = None

    # joint maps --------------------------------------------------------------
    def joint_maps(self):
        """theta_j (Ex), J rows (list of Ex per coordinate), Hessian term h_j (Ex)."""
        if self._joint is None:
            P = self.P
            theta, rows, hterm = [], [], []
            for d, grad, hess in self.plan.joint_expressions():
                theta.append(P.emit(to_ex(P, d)))
                rows.append([P.emit(to_ex(P, g)) for g in grad])
                hterm.append(P.emit(to_ex(P, hess)) if hess != 0 else ZERO)
            self._joint = (theta, rows, hterm)
        return self._joint

    def joint_rates(self, rates: list[Ex]) -> list[Ex]:
        _, rows, _ = self.joint_maps()
        return [self.P.emit(sum((row[k] * rates[k] for k in range(self.plan.n)), ZERO))
                for row in rows]

    # frames ------------------------------------------------------------------
    def frames(self):
        """E_i (3x3 Ex, parent axes -> body axes) and r_i (origin in parent axes)."""
        if self._frames is None:
            P = self.P
            theta, _, _ = self.joint_maps()
            out = []
            for b in self.plan.bodies:
                CT = [[Ex.const(b.C[j][i]) for j in range(3)] for i in range(3)]
                r = const_vec(b.origin)
                if b.kind == "revolute":
                    th = theta[b.joint]
                    c, s = P.call("cos", th), P.call("sin", th)
                    a = b.axis
                    # Rot(a, th)^T = c I - s [a]x + (1 - c) a a^T
                    skew = [[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]]
                    RT = [[(c if i == j else ZERO) - s * skew[i][j] + (ONE - c) * (a[i] * a[j])
                           for j in range(3)] for i in range(3)]
                    RT = [[P.emit(x) for x in row] for row in RT]
                    if b.C_identity:
                        E = RT
                    else:
                        E = [[P.emit(sum((RT[i][k] * CT[k][j] for k in range(3)), ZERO))
                              for j in range(3)] for i in range(3)]
                else:
                    E = CT
                    if b.kind == "prismatic":
                        Ca = [sum(b.C[i][k] * b.axis[k] for k in range(3)) for i in range(3)]
                        th = theta[b.joint]
                        r = [P.emit(r[i] + th * Ca[i]) for i in range(3)]
                out.append((E, r))
            self._frames = out
        return self._frames

    # RNEA ----------------------------------------------------------------------
    def _to_body(self, vec: Vec, i: int) -> Vec:
        """A world-axes vector in body i's axes (E of every body on the way)."""
        b = self.plan.bodies[i]
        above = vec if b.parent is None else self._to_body(vec, b.parent)
        return emitv(self.P, matvec(self.frames()[i][0], above))

    def _external(self, P) -> dict:
        """Body index -> (force, moment about the origin) of its loads, body axes."""
        zero = [ZERO, ZERO, ZERO]
        external = {}
        for ld in self.plan.loads:
            Fv = [to_ex(P, x) for x in ld.force]
            Tv = [to_ex(P, x) for x in ld.torque]
            if ld.frame == "world":
                Fv = self._to_body(emitv(P, Fv), ld.body) if any(
                    not x.is_zero() for x in Fv) else zero
                Tv = self._to_body(emitv(P, Tv), ld.body) if any(
                    not x.is_zero() for x in Tv) else zero
            point = [to_ex(P, x) for x in ld.point]
            F0, N0 = external.get(ld.body, (zero, zero))
            external[ld.body] = (add(F0, Fv), add(N0, Tv, cross(point, Fv)))
        return external

    def passive(self) -> list[Ex]:
        """tau_passive_j = -damping dtheta - friction tanh(dtheta/v) - stiffness (theta - rest)."""
        P, plan = self.P, self.plan
        theta, _, _ = self.joint_maps()
        rates = None
        out = []
        for j, b in enumerate(plan.moving):
            bp = plan.bodies[b]
            value = ZERO
            if bp.damping or bp.friction:
                if rates is None:
                    rates = self.joint_rates(self.dq)
            if bp.damping:
                value = value - rates[j] * bp.damping
            if bp.friction:
                value = value - P.call("tanh", P.emit(rates[j] * (1.0 / bp.friction_velocity))
                                       ) * bp.friction
            if bp.stiffness:
                value = value - (theta[j] - bp.rest) * bp.stiffness
            out.append(value)
        return out

    def actuation(self) -> list[Ex]:
        """Joint efforts of the actuators: under the control laws, or
        ``given_efforts`` when set."""
        plan, P = self.plan, self.P
        out = [ZERO] * len(plan.moving)
        for k, j in enumerate(plan.actuator_joint):
            effort = (self.given_efforts[k] if self.given_efforts is not None
                      else P.emit(to_ex(P, plan.laws[k])))
            out[j] = out[j] + effort
        return out

    def efforts(self) -> list[Ex]:
        return [self.P.emit(to_ex(self.P, law)) for law in self.plan.laws]

    def rnea(self, ddq: list[Ex] | None, actuators: bool) -> list[Ex]:
        """ID(t, q, dq, ddq) = J^T (tau - tau_passive [- tau_actuators]); ddq None: zero."""
        P, plan = self.P, self.plan
        theta, rows, hterm = self.joint_maps()
        frames = self.frames()
        rate = self.joint_rates(self.dq)
        if ddq is None:
            acc = list(hterm)
        else:
            acc = [P.emit(x + h) for x, h in zip(self.joint_rates(ddq), hterm)]
        zero = [ZERO, ZERO, ZERO]
        w, al, ao = [], [], []
        external = self._external(P)
        forces = []
        for i, b in enumerate(plan.bodies):
            E, r = frames[i]
            if b.parent is None:
                wp, alp, aop = zero, zero, [Ex.const(-g) for g in plan.gravity]
            else:
                wp, alp, aop = w[b.parent], al[b.parent], ao[b.parent]
            wr = emitv(P, matvec(E, wp))
            a_lin = add(aop, cross(alp, r), cross(wp, emitv(P, cross(wp, r))))
            ao_i = matvec(E, a_lin)
            al_i = matvec(E, alp)
            w_i = wr
            if b.kind == "revolute":
                j = b.joint
                axis = const_vec(b.axis)
                w_i = add(wr, scale(axis, rate[j]))
                al_i = add(al_i, scale(axis, acc[j]), scale(cross(wr, axis), rate[j]))
            elif b.kind == "prismatic":
                j = b.joint
                axis = const_vec(b.axis)
                ao_i = add(ao_i, scale(axis, acc[j]), scale(cross(wr, axis), rate[j] * 2.0))
            w_i, al_i, ao_i = emitv(P, w_i), emitv(P, al_i), emitv(P, ao_i)
            w.append(w_i), al.append(al_i), ao.append(ao_i)
            h = const_vec(b.h)
            I = [[Ex.const(x) for x in row] for row in b.I_O]
            wh = emitv(P, cross(w_i, h))
            f = add(scale(ao_i, b.mass), cross(al_i, h), cross(w_i, wh))
            Iw = emitv(P, matvec(I, w_i))
            nn = add(matvec(I, al_i), cross(w_i, Iw), cross(h, ao_i))
            if i in external:
                Fe, Ne = external[i]
                f, nn = sub(f, Fe), sub(nn, Ne)
            forces.append([f, nn])
        tau = [ZERO] * len(plan.moving)
        for i in reversed(range(len(plan.bodies))):
            b = plan.bodies[i]
            f, nn = emitv(P, forces[i][0]), emitv(P, forces[i][1])
            if b.kind == "revolute":
                tau[b.joint] = P.emit(dot(const_vec(b.axis), nn))
            elif b.kind == "prismatic":
                tau[b.joint] = P.emit(dot(const_vec(b.axis), f))
            if b.parent is not None:
                E, r = frames[i]
                fp = emitv(P, matTvec(E, f))
                npar = add(matTvec(E, nn), cross(r, fp))
                forces[b.parent][0] = add(forces[b.parent][0], fp)
                forces[b.parent][1] = add(forces[b.parent][1], npar)
        passive = self.passive()
        act = self.actuation() if actuators else [ZERO] * len(tau)
        joint = [P.emit(tau[j] - passive[j] - act[j]) for j in range(len(tau))]
        return [P.emit(sum((rows[j][k] * joint[j] for j in range(len(joint))), ZERO))
                for k in range(plan.n)]

    # ABA -----------------------------------------------------------------------
    def joint_inverse(self):
        """J^-1 as floats when J = d(theta)/dq is constant, square and invertible
        (each coordinate a fixed combination of joint displacements), else None."""
        plan = self.plan
        if len(plan.moving) != plan.n:
            return None
        rows = [grad for _, grad, _ in plan.joint_expressions()]
        if any(g.free_symbols for row in rows for g in row):
            return None
        J = sp.Matrix(rows)
        if J.det() == 0:
            return None
        return [[float(x) for x in row] for row in J.inv().tolist()]

    def applied(self) -> list[Ex]:
        """Joint efforts: actuators under their laws plus springs, dampers, friction."""
        act, passive = self.actuation(), self.passive()
        return [self.P.emit(a + p) for a, p in zip(act, passive)]

    def aba(self) -> list[Ex] | None:
        """ddq by the articulated-body algorithm (Featherstone, Table 7.1), O(n):

            v_i = X_i v_p + S_i dtheta_i,  c_i = v_i x S_i dtheta_i,
            IA_i = I_i,  pA_i = v_i x* I_i v_i - f_ext_i;
            leaves to root: U = IA S, D = S^T U, u = tau - S^T pA,
              Ia = IA - U U^T / D,  pa = pA + Ia c + U u / D,
              IA_p += X^T Ia X,  pA_p += X^T pa;
            root to leaves: a_i = X_i a_p + c_i (a_0 = (0, -g)),
              ddtheta_i = (u - U^T a_i) / D,  a_i += S ddtheta_i;

        then ddq = J^-1 (ddtheta - h).  Spatial vectors (angular, linear) at the
        body origin in body axes; X^T Ia X = T^T (R^T Ia R) T with R = diag(E, E),
        T = [[1, 0], [-[r]x, 1]].  None when J is not constant and invertible."""
        Jinv = self.joint_inverse()
        if Jinv is None:
            return None
        P, plan = self.P, self.plan
        frames = self.frames()
        _, _, hterm = self.joint_maps()
        rate = self.joint_rates(self.dq)
        tau = self.applied()
        zero = [ZERO, ZERO, ZERO]
        external = self._external(P)
        nb = len(plan.bodies)
        v, c, IA, pA = [None] * nb, [None] * nb, [None] * nb, [None] * nb
        for i, b in enumerate(plan.bodies):
            E, r = frames[i]
            if b.parent is None:
                w, vo = zero, zero
            else:
                wp, vp = v[b.parent]
                w = emitv(P, matvec(E, wp))
                vo = emitv(P, matvec(E, add(vp, cross(wp, r))))
            cw, cv = zero, zero
            if b.kind != "fixed":
                axis = const_vec(b.axis)
                sv = scale(axis, rate[b.joint])
                if b.kind == "revolute":
                    cw, cv = emitv(P, cross(w, sv)), emitv(P, cross(vo, sv))
                    w = emitv(P, add(w, sv))
                else:
                    cv = emitv(P, cross(w, sv))
                    vo = emitv(P, add(vo, sv))
            v[i], c[i] = (w, vo), (cw, cv)
            h = const_vec(b.h)
            A = [[Ex.const(x) for x in row] for row in b.I_O]
            B = [[Ex.const(x) for x in row] for row in _skew(b.h)]
            C = [[Ex.const(b.mass if r_ == c_ else 0.0) for c_ in range(3)] for r_ in range(3)]
            IA[i] = [A, B, C]
            # p = v x* (I v): I v = (I_O w + h x vo, m vo - h x w)
            Iw = emitv(P, add(matvec(A, w), cross(h, vo)))
            Iv = emitv(P, sub(scale(vo, b.mass), cross(h, w)))
            pn = add(cross(w, Iw), cross(vo, Iv))
            pf = cross(w, Iv)
            if i in external:
                Fe, Ne = external[i]
                pn, pf = sub(pn, Ne), sub(pf, Fe)
            pA[i] = [pn, pf]
        U, Dinv, u = [None] * nb, [None] * nb, [None] * nb
        for i in reversed(range(nb)):
            b = plan.bodies[i]
            A, B, C = [[[P.emit(x) for x in row] for row in M_] for M_ in IA[i]]
            pn, pf = emitv(P, pA[i][0]), emitv(P, pA[i][1])
            cw, cv = c[i]
            if b.kind != "fixed":
                axis = const_vec(b.axis)
                if b.kind == "revolute":
                    Un, Uf = emitv(P, matvec(A, axis)), emitv(P, matTvec(B, axis))
                    D = dot(axis, Un)
                    ui = tau[b.joint] - dot(axis, pn)
                else:
                    Un, Uf = emitv(P, matvec(B, axis)), emitv(P, matvec(C, axis))
                    D = dot(axis, Uf)
                    ui = tau[b.joint] - dot(axis, pf)
                D = P.check_positive(P.emit(D), "mass matrix not positive definite "
                                                f"(articulated inertia of {b.name})")
                di = P.call("recip", D)
                ui = P.emit(ui)
                U[i], Dinv[i], u[i] = (Un, Uf), di, ui
                if b.parent is None:
                    continue
                Wn, Wf = emitv(P, scale(Un, di)), emitv(P, scale(Uf, di))
                A = [[P.emit(A[r_][c_] - Un[r_] * Wn[c_]) for c_ in range(3)] for r_ in range(3)]
                B = [[P.emit(B[r_][c_] - Un[r_] * Wf[c_]) for c_ in range(3)] for r_ in range(3)]
                C = [[P.emit(C[r_][c_] - Uf[r_] * Wf[c_]) for c_ in range(3)] for r_ in range(3)]
                k = P.emit(ui * di)
                pn = add(pn, matvec(A, cw), matvec(B, cv), scale(Un, k))
                pf = add(pf, matTvec(B, cw), matvec(C, cv), scale(Uf, k))
            elif b.parent is None:
                continue
            pn, pf = emitv(P, pn), emitv(P, pf)
            E, rv = frames[i]
            # rotate: E^T (.) E, then translate by r
            A1 = _congruence(P, A, E, symmetric=True)
            B1 = _congruence(P, B, E, symmetric=False)
            C1 = _congruence(P, C, E, symmetric=True)
            S = _skew_ex(rv)
            SB = [[sum((S[r_][k_] * B1[c_][k_] for k_ in range(3)), ZERO) for c_ in range(3)]
                  for r_ in range(3)]                                   # S B1^T
            SC = [[P.emit(sum((S[r_][k_] * C1[k_][c_] for k_ in range(3)), ZERO))
                   for c_ in range(3)] for r_ in range(3)]              # S C1
            parent = IA[b.parent]
            for r_ in range(3):
                for c_ in range(3):
                    # A'' = A1 + S B1^T - B1 S - S C1 S;  B'' = B1 + S C1
                    a2 = (A1[r_][c_] + SB[r_][c_]
                          - sum((B1[r_][k_] * S[k_][c_] for k_ in range(3)), ZERO)
                          - sum((SC[r_][k_] * S[k_][c_] for k_ in range(3)), ZERO))
                    parent[0][r_][c_] = parent[0][r_][c_] + a2
                    parent[1][r_][c_] = parent[1][r_][c_] + B1[r_][c_] + SC[r_][c_]
                    parent[2][r_][c_] = parent[2][r_][c_] + C1[r_][c_]
            ff = emitv(P, matTvec(E, pf))
            nn = add(matTvec(E, pn), cross(rv, ff))
            pA[b.parent] = [add(pA[b.parent][0], nn), add(pA[b.parent][1], ff)]
        acc = [None] * nb
        ddtheta = [None] * len(plan.moving)
        for i, b in enumerate(plan.bodies):
            E, rv = frames[i]
            if b.parent is None:
                al, ao = zero, [Ex.const(-g) for g in plan.gravity]
                al, ao = zero, emitv(P, matvec(E, ao))
            else:
                alp, aop = acc[b.parent]
                al = emitv(P, matvec(E, alp))
                ao = emitv(P, matvec(E, sub(aop, cross(rv, alp))))
            al, ao = emitv(P, add(al, c[i][0])), emitv(P, add(ao, c[i][1]))
            if b.kind != "fixed":
                Un, Uf = U[i]
                dd = P.emit((u[i] - dot(Un, al) - dot(Uf, ao)) * Dinv[i])
                ddtheta[b.joint] = dd
                axis = const_vec(b.axis)
                if b.kind == "revolute":
                    al = emitv(P, add(al, scale(axis, dd)))
                else:
                    ao = emitv(P, add(ao, scale(axis, dd)))
            acc[i] = (al, ao)
        rhs = [P.emit(ddtheta[j] - hterm[j]) for j in range(len(ddtheta))]
        return [P.emit(sum((rhs[j] * Jinv[k][j] for j in range(len(rhs))), ZERO))
                for k in range(plan.n)]

    # CRBA ----------------------------------------------------------------------
    def joint_mass_matrix(self) -> dict[tuple[int, int], Ex]:
        """H_ij (moving joints i >= j in body order; absent = structural zero)."""
        P, plan = self.P, self.plan
        frames = self.frames()
        comp = []
        for b in plan.bodies:
            comp.append([Ex.const(b.mass), const_vec(b.h),
                         [[Ex.const(x) for x in row] for row in b.I_O]])
        for i in reversed(range(len(plan.bodies))):
            b = plan.bodies[i]
            m, h, I = comp[i]
            h = emitv(P, h)
            I = [[P.emit(I[r][c]) if c >= r else None for c in range(3)] for r in range(3)]
            for r in range(3):
                for c in range(r):
                    I[r][c] = I[c][r]
            comp[i] = [m, h, I]
            if b.parent is None:
                continue
            E, rv = frames[i]
            hr = emitv(P, matTvec(E, h))                       # E^T h
            IE = [[P.emit(sum((I[r][k] * E[k][c] for k in range(3)), ZERO))
                   for c in range(3)] for r in range(3)]       # I E
            rh = dot(rv, hr) * 2.0
            rr = dot(rv, rv) * m
            Ip = comp[b.parent][2]
            for r in range(3):
                for c in range(r, 3):
                    value = sum((E[k][r] * IE[k][c] for k in range(3)), ZERO)
                    value = value + m * (-(rv[r] * rv[c])) - rv[r] * hr[c] - hr[r] * rv[c]
                    if r == c:
                        value = value + rr + rh
                    Ip[r][c] = Ip[r][c] + value
                    if r != c:
                        Ip[c][r] = Ip[r][c]
            comp[b.parent][0] = comp[b.parent][0] + m
            comp[b.parent][1] = add(comp[b.parent][1], hr, scale(rv, m))
        H: dict[tuple[int, int], Ex] = {}
        for i in plan.moving:
            b = plan.bodies[i]
            m, h, I = comp[i]
            axis = const_vec(b.axis)
            if b.kind == "revolute":
                Fn, Ff = emitv(P, matvec(I, axis)), emitv(P, cross(axis, h))
                H[b.joint, b.joint] = P.emit(dot(axis, Fn))
            else:
                Fn, Ff = emitv(P, cross(h, axis)), emitv(P, scale(axis, m))
                H[b.joint, b.joint] = P.emit(dot(axis, Ff))
            j = i
            while plan.bodies[j].parent is not None:
                E, rv = frames[j]
                Ff = emitv(P, matTvec(E, Ff))
                Fn = emitv(P, add(matTvec(E, Fn), cross(rv, Ff)))
                j = plan.bodies[j].parent
                bj = plan.bodies[j]
                if bj.kind == "revolute":
                    H[b.joint, bj.joint] = P.emit(dot(const_vec(bj.axis), Fn))
                elif bj.kind == "prismatic":
                    H[b.joint, bj.joint] = P.emit(dot(const_vec(bj.axis), Ff))
        return H

    def mass_matrix(self) -> list[list[Ex]]:
        """M = J^T H J on the coordinates (symmetric, Ex entries)."""
        P, plan = self.P, self.plan
        n, nj = plan.n, len(plan.moving)
        H = self.joint_mass_matrix()
        _, rows, _ = self.joint_maps()

        def Hij(i, j):
            return H.get((i, j)) if (i, j) in H else H.get((j, i), ZERO)

        HJ = [[P.emit(sum((Hij(i, j) * rows[j][s] for j in range(nj)), ZERO))
               for s in range(n)] for i in range(nj)]
        M = [[None] * n for _ in range(n)]
        for r in range(n):
            for s in range(r, n):
                M[r][s] = M[s][r] = P.emit(sum((rows[i][r] * HJ[i][s] for i in range(nj)), ZERO))
        return M

    # potential energy ----------------------------------------------------------
    def potential(self) -> Ex:
        """V = -sum m g . r_c + sum 1/2 k (theta - rest)^2, with g . p_i = g . p_p + g_p . r_i
        and g_i = E_i g_p (gravity in body axes)."""
        P, plan = self.P, self.plan
        frames = self.frames()
        theta, _, _ = self.joint_maps()
        g_axes, height = [], []
        V = ZERO
        for i, b in enumerate(plan.bodies):
            E, r = frames[i]
            if b.parent is None:
                gp, sp_ = const_vec(plan.gravity), ZERO
            else:
                gp, sp_ = g_axes[b.parent], height[b.parent]
            s_i = P.emit(sp_ + dot(gp, r))
            g_i = emitv(P, matvec(E, gp))
            g_axes.append(g_i), height.append(s_i)
            V = V - s_i * b.mass - dot(g_i, const_vec(b.h))
            if b.kind != "fixed" and b.stiffness:
                d = P.emit(theta[b.joint] - b.rest)
                V = V + d * d * (0.5 * b.stiffness)
        return P.emit(V)


# the Cholesky solve -----------------------------------------------------------

def elimination_order(pattern: list[set[int]]) -> list[int]:
    """Greedy minimum-fill order (ties: fewest neighbours, then last index first):
    on a tree's mass matrix it takes leaves first and adds no fill-in."""
    n = len(pattern)
    graph = {i: set(pattern[i]) - {i} for i in range(n)}
    order = []
    while graph:
        def fill(v):
            nb = list(graph[v])
            return sum(1 for x in range(len(nb)) for y in range(x) if nb[y] not in graph[nb[x]])
        v = min(graph, key=lambda v: (fill(v), len(graph[v]), -v))
        nb = graph.pop(v)
        for x in nb:
            graph[x] |= nb - {x}
            graph[x].discard(v)
        order.append(v)
    return order


@dataclass
class Factor:
    order: list[int]                      # elimination order (coordinate indices)
    inv: list[Ex]                         # 1 / L_jj
    L: dict[tuple[int, int], Ex]          # L_ij, i > j, positions in the order


def cholesky(P: Program, M: list[list[Ex]]) -> Factor:
    """P M P^T = L L^T unrolled, L_jj = sqrt(d_j), d_j = A_jj - sum_k L_jk^2 checked > 0,
    L_ij = (A_ij - sum_k L_ik L_jk) / L_jj; entries that are structurally zero skipped."""
    n = len(M)
    pattern = [{s for s in range(n) if not M[r][s].is_zero()} for r in range(n)]
    order = elimination_order(pattern)
    A = [[M[order[i]][order[j]] for j in range(n)] for i in range(n)]
    L: dict[tuple[int, int], Ex] = {}
    inv: list[Ex] = []
    for j in range(n):
        d = A[j][j] - sum((L[j, k] * L[j, k] for k in range(j) if (j, k) in L), ZERO)
        d = P.check_positive(P.emit(d), f"mass matrix not positive definite (pivot {j})")
        inv_j = P.call("recip", P.call("sqrt", d))
        inv.append(inv_j)
        for i in range(j + 1, n):
            value = A[i][j] - sum((L[i, k] * L[j, k] for k in range(j)
                                   if (i, k) in L and (j, k) in L), ZERO)
            if not value.is_zero():
                L[i, j] = P.emit(value * inv_j)
    return Factor(order, inv, L)


def solve(P: Program, fac: Factor, G: list[Ex]) -> list[Ex]:
    """x with M x = G: L y = P G, L^T z = y, x = P^T z."""
    n = len(G)
    y = []
    for i in range(n):
        value = G[fac.order[i]] - sum((fac.L[i, k] * y[k] for k in range(i) if (i, k) in fac.L),
                                      ZERO)
        y.append(P.emit(value * fac.inv[i]))
    z = [None] * n
    for i in reversed(range(n)):
        value = y[i] - sum((fac.L[k, i] * z[k] for k in range(i + 1, n) if (k, i) in fac.L), ZERO)
        z[i] = P.emit(value * fac.inv[i])
    x = [None] * n
    for i in range(n):
        x[fac.order[i]] = z[i]
    return x


# the programs of the generated functions ----------------------------------------

@dataclass
class Traced:
    """One generated function: its inputs, statements and outputs."""
    name: str
    args: list[str]
    statements: list
    outputs: dict[str, list]              # name -> list of Ex (vector) or list of lists (matrix)
    counts: Counts


def _flat(outputs: dict) -> list[Ex]:
    flat = []
    for value in outputs.values():
        for x in value:
            flat.extend(x if isinstance(x, list) else [x])
    return flat


def _finish(name, args, P, outputs) -> Traced:
    statements = prune(P.statements, _flat(outputs))
    return Traced(name, args, statements, outputs, count(statements, _flat(outputs)))


def state_args(n: int) -> list[str]:
    return ["_t"] + [f"_q{k}" for k in range(n)] + [f"_u{k}" for k in range(n)]


def trace_accelerations(pl: Plan, with_factor: bool = False):
    """ddq solving M ddq = -ID(t, q, dq, 0) (actuators under their laws)."""
    P = Program()
    with P:
        T = Tracer(pl, P)
        M = T.mass_matrix()
        G = [P.emit(-x) for x in T.rnea(None, actuators=True)]
        fac = cholesky(P, M)
        ddq = solve(P, fac, G)
    outputs = {"ddq": ddq}
    if with_factor:
        outputs["inv"] = fac.inv
        outputs["L"] = [fac.L[key] for key in sorted(fac.L)]
    traced = _finish("accelerations", state_args(pl.n), P, outputs)
    return (traced, fac) if with_factor else traced


def trace_driven(pl: Plan) -> Traced:
    """ddq solving M ddq = F + B e for given actuator efforts e (atoms _e0, ...):
    the direct dynamics that ``inverse``'s round trip drives with its efforts
    (CRBA + sparse Cholesky)."""
    m = len(pl.actuator_joint)
    P = Program()
    with P:
        T = Tracer(pl, P)
        T.given_efforts = [Ex.atom(f"_e{k}") for k in range(m)]
        M = T.mass_matrix()
        G = [P.emit(-x) for x in T.rnea(None, actuators=True)]
        ddq = solve(P, cholesky(P, M), G)
    return _finish("driven_accelerations", state_args(pl.n) + [f"_e{k}" for k in range(m)],
                   P, {"ddq": ddq})


def trace_aba(pl: Plan) -> Traced | None:
    """ddq by the articulated-body algorithm (None: J not constant and invertible)."""
    P = Program()
    with P:
        ddq = Tracer(pl, P).aba()
    if ddq is None:
        return None
    return _finish("accelerations", state_args(pl.n), P, {"ddq": ddq})


def trace_jacobian(pl: Plan, with_M: bool = True) -> Traced:
    """M and K = -dID/d[q, dq] at fixed ddq (actuators included), forward mode
    (``with_M`` False: K alone, for native code that reuses the factor of M)."""
    n = pl.n
    P = Program()
    with P:
        T = Tracer(pl, P)
        M = T.mass_matrix() if with_M else None
        ddq = [Ex.atom(f"_w{k}") for k in range(n)]
        res = T.rnea(ddq, actuators=True)
        seeds = {f"_q{k}": k for k in range(n)}
        seeds.update({f"_u{k}": n + k for k in range(n)})
        D = P.derivatives(seeds)
        K = []
        for r in range(n):
            d = P.derivative_of(res[r], D)
            K.append([P.emit(-d[k]) if k in d else ZERO for k in range(2 * n)])
    return _finish("dynamics_jacobian", state_args(n) + [f"_w{k}" for k in range(n)], P,
                   {"M": M, "K": K} if with_M else {"K": K})


def trace_mfb(pl: Plan) -> Traced:
    n = pl.n
    P = Program()
    with P:
        T = Tracer(pl, P)
        M = T.mass_matrix()
        F = [P.emit(-x) for x in T.rnea(None, actuators=False)]
        _, rows, _ = T.joint_maps()
        B = [[rows[j][r] for j in pl.actuator_joint] for r in range(n)]
    return _finish("mfb", state_args(n), P, {"M": M, "F": F, "B": B})


def trace_inverse(pl: Plan) -> Traced:
    n = pl.n
    P = Program()
    with P:
        T = Tracer(pl, P)
        res = T.rnea([Ex.atom(f"_w{k}") for k in range(n)], actuators=False)
    return _finish("inverse_dynamics", state_args(n) + [f"_w{k}" for k in range(n)], P,
                   {"ID": res})


def trace_actuation(pl: Plan) -> Traced:
    """B(t, q) (n x m): column k is d(theta_j)/dq for actuator k's joint j, so that
    the generalized forces of the efforts are B tau (with ``inverse_dynamics``:
    B tau = M ddq - F, the RNEA's O(n) inverse dynamics)."""
    n = pl.n
    P = Program()
    with P:
        _, rows, _ = Tracer(pl, P).joint_maps()
        B = [[rows[j][r] for j in pl.actuator_joint] for r in range(n)]
    return _finish("actuation", state_args(n), P, {"B": B})


def trace_efforts(pl: Plan) -> Traced:
    P = Program()
    with P:
        tau = Tracer(pl, P).efforts()
    return _finish("efforts", state_args(pl.n), P, {"tau": tau})


def trace_potential(pl: Plan) -> Traced:
    P = Program()
    with P:
        V = Tracer(pl, P).potential()
    return _finish("potential", [f"_q{k}" for k in range(pl.n)], P, {"V": [V]})


def factor_tables(fac: Factor, n: int):
    """(order, rows, cols): the elimination order; for each position i the
    entries (k, index into factor()'s L list) of row i (k < i) and of column i
    (k > i) of L."""
    keys = sorted(fac.L)
    index = {key: k for k, key in enumerate(keys)}
    rows = [[(k, index[i, k]) for k in range(i) if (i, k) in fac.L] for i in range(n)]
    cols = [[(k, index[k, i]) for k in range(i + 1, n) if (k, i) in fac.L] for i in range(n)]
    return (list(fac.order), rows, cols)


# the generated Python module ---------------------------------------------------

def _matrix_output(value) -> bool:
    return bool(value) and isinstance(value[0], list)


def _python_function(tr: Traced, vectorized: bool, doc: str) -> list[str]:
    from .ir import python_expr, python_lines
    lines = [f"def {tr.name}({', '.join(tr.args)}):", f'    """{doc}"""']
    if vectorized:
        shapes = ", ".join(f"numpy.shape({a})" for a in tr.args)
        lines.append(f"    _shape = numpy.broadcast_shapes({shapes})")
    lines += python_lines(tr.statements, vectorized)
    returned = []
    for name, value in tr.outputs.items():
        out = f"_out_{name}"
        if not vectorized:
            if _matrix_output(value):
                rows = ", ".join("[" + ", ".join(python_expr(x) for x in row) + "]" for row in value)
                lines.append(f"    {out} = numpy.array([{rows}])")
            else:
                lines.append(f"    {out} = [{', '.join(python_expr(x) for x in value)}]")
        else:
            matrix = _matrix_output(value)
            dims = f"{len(value)}, {len(value[0]) if value else 0}" if matrix else f"{len(value)},"
            if matrix and not value:
                dims = "0, 0"
            lines.append(f"    {out} = numpy.zeros(_shape + ({dims}))")
            cells = ([((i, j), x) for i, row in enumerate(value) for j, x in enumerate(row)]
                     if matrix else [((i,), x) for i, x in enumerate(value)])
            for index, x in cells:
                if not x.is_zero():
                    lines.append(f"    {out}[..., {', '.join(map(str, index))}] = {python_expr(x)}")
        returned.append(out)
    lines.append(f"    return {', '.join(returned)}")
    return lines


PY_HEADER = """\
import functools
import math
import numpy
from math import sin as _sin, cos as _cos, sqrt as _sqrt, tanh as _tanh
_singular = numpy.linalg.LinAlgError
"""

VEC_HEADER = """\
_vsin, _vcos, _vsqrt, _vtanh = numpy.sin, numpy.cos, numpy.sqrt, numpy.tanh
"""


@dataclass
class Generated:
    """The functions of one robot, traced."""
    plan: Plan
    functions: dict[str, Traced]
    factor: Factor

    def counts(self, name: str) -> Counts:
        return self.functions[name].counts


def forward(pl: Plan) -> Generated:
    """The forward dynamics alone (``accelerations`` and ``factor``): all a quick
    native build needs (``native.c_source`` of it has no Jacobian).  The
    accelerations come from the cheaper (in operations) of CRBA + sparse
    Cholesky and the articulated-body algorithm; the Jacobian always uses the
    Cholesky factor (``factor``)."""
    factor, fac = trace_accelerations(pl, with_factor=True)
    factor.name = "factor"
    acc = Traced("accelerations", factor.args, factor.statements, {"ddq": factor.outputs["ddq"]},
                 factor.counts)
    aba = trace_aba(pl)
    if aba is not None and aba.counts.total < acc.counts.total:
        acc = aba
    return Generated(pl, {"accelerations": acc, "factor": factor}, fac)


def complete(gen: Generated) -> Generated:
    """``gen`` (from ``forward``) with the Jacobian, the driven accelerations,
    M F B, the efforts, the inverse dynamics, the actuation matrix and the
    potential."""
    pl = gen.plan
    functions = {**gen.functions, "dynamics_jacobian": trace_jacobian(pl),
                 "driven_accelerations": trace_driven(pl), "mfb": trace_mfb(pl), "efforts": trace_efforts(pl),
                 "inverse_dynamics": trace_inverse(pl), "actuation": trace_actuation(pl),
                 "potential": trace_potential(pl)}
    return Generated(pl, functions, gen.factor)


def generate(robot: Robot) -> Generated:
    """Every function of ``robot`` (``forward``, then ``complete``)."""
    return complete(forward(plan(robot)))


DOCS = {
    "factor": "ddq, 1/L_jj and L_ij (i > j) of P M P^T = L L^T (CRBA, sparse Cholesky; "
              "positions in FACTOR) for the Jacobian.",
    "accelerations": "ddq solving M(q) ddq = F + B tau(t, q, dq) (recursive: CRBA with an "
                     "unrolled sparse Cholesky, or the articulated-body algorithm, whichever "
                     "costs fewer operations; scalar floats).",
    "dynamics_jacobian": "M and K = -dID/d[q, dq] at fixed ddq = [dG/dq - (dM/dq) ddq | dG/ddq]; "
                         "d(ddq)/dx = M^-1 K (scalar).",
    "driven_accelerations": "ddq solving M(q) ddq = F + B e for given actuator efforts e "
                            "(CRBA, sparse Cholesky; scalar floats).",
    "efforts": "Actuator efforts under the control laws (vectorized).",
    "mfb": "M, F and B of M ddq = F + B tau (vectorized).",
    "inverse_dynamics": "ID = M ddq - F by the recursive Newton-Euler algorithm, O(n) "
                        "(vectorized).",
    "actuation": "B of M ddq = F + B tau (vectorized).",
    "potential": "Potential energy V of gravity and joint springs (vectorized).",
}

VECTORIZED = {"efforts", "mfb", "inverse_dynamics", "actuation", "potential"}
from .native import VECTOR_MARK  # noqa: E402  (the split a native model uses)


def module_source(gen: Generated, header: str = "") -> str:
    """Python source with COORDINATES, EFFORTS and the six functions."""
    pl = gen.plan
    names = {f"_q{k}": c for k, c in enumerate(pl.coordinates)}
    names.update({f"_u{k}": "d" + c for k, c in enumerate(pl.coordinates)})
    names.update({f"_w{k}": "dd" + c for k, c in enumerate(pl.coordinates)})
    names.update({f"_e{k}": e for k, e in enumerate(pl.efforts)})
    names["_t"] = "t"
    lines = [f"# {line}" for line in header.splitlines()] + [PY_HEADER, VEC_HEADER]
    for name, tr in gen.functions.items():
        vectorized = name in VECTORIZED
        if name == "mfb":
            lines.append(VECTOR_MARK)
        c = tr.counts
        doc = (f"{DOCS[name]}\n\n    Arguments: {', '.join(names[a] for a in tr.args)}.\n"
               f"    Operations: {c.mul} multiplications, {c.add} additions, {c.div} divisions, "
               f"{c.calls} calls, {c.other} in expressions.\n    ")
        body = _python_function(tr, vectorized, doc)
        if vectorized:
            body = [line.replace("_sin(", "_vsin(").replace("_cos(", "_vcos(")
                    .replace("_sqrt(", "_vsqrt(").replace("_tanh(", "_vtanh(")
                    for line in body]
        lines += body + [""]
    lines.append(f"FACTOR = {factor_tables(gen.factor, pl.n)!r}")
    B = gen.functions["actuation"].outputs["B"]
    lines.append(f"CONSTANT_ACTUATION = {all(x.constant() is not None for row in B for x in row)}")
    lines.append(f"COORDINATES = {tuple(pl.coordinates)!r}")
    lines.append(f"EFFORTS = {tuple(pl.efforts)!r}")
    return "\n".join(lines) + "\n"


def source(robot: Robot) -> str:
    """The generated module's source for ``robot``."""
    from .. import __version__
    header = (f"generated by anadyn {__version__} from {robot.source} (recursive)\n"
              f"robot {robot.name}: coordinates {', '.join(c.name for c in robot.coordinates)}; "
              f"efforts {', '.join(a.name for a in robot.actuators) or 'none'}")
    return module_source(generate(robot), header)
