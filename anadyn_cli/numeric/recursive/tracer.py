"""What every recursion of one robot shares, traced once into one Program: the
joint maps (theta, J, h), the body frames, the external loads in body axes and
the joint efforts (actuators, springs, dampers, friction).

Body i has the moving-joint displacement theta_i = displacement_i(q), a unit
axis a_i (joint axes = body axes), E_i = R_l^T turning parent axes into body
axes and r_i its origin in parent axes, from its joint type's transform
(``model.joints``):

    E_i = Rot(a, theta)^T C^T   where the joint turns (revolute), else C^T
    r_i = origin [+ C a theta]  where the joint slides (prismatic)
    E_i = R(q)^T C^T            for a spherical joint's quaternion q (any norm:
                                R(q) = (|q|^2 R)(q) / |q|^2, ``joints.Spherical``)

with C = Rz Ry Rx of rpy.  Joint efforts, with tau_passive_j =
-damping dtheta - friction tanh(dtheta / friction_velocity) - stiffness (theta - rest).
"""
from __future__ import annotations

import sympy as sp

from ..contact import traced
from ..ir import ZERO, Ex, Program
from .plan import Plan
from .spatial import (Vec, add, columns, const_vec, cross, emitv, matvec, rotation_transpose,
                      scale, to_ex)


class Tracer:
    """The shared quantities of one robot, traced into the Program ``P``; the
    algorithms (``rnea``, ``crba``, ``aba``, ``potential``) take it."""

    def __init__(self, plan: Plan, P: Program):
        self.plan, self.P = plan, P
        self.dq = [Ex.atom(f"_u{k}") for k in range(plan.n)]     # the speeds
        self._frames = None
        self._joint = None
        self._velocities = None
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
        """dtheta = J rates (J: joint speeds from the speeds u)."""
        _, rows, _ = self.joint_maps()
        return [self.P.emit(sum((row[k] * rates[k] for k in range(self.plan.n)), ZERO))
                for row in rows]

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
                if b.quaternion is not None:
                    out.append((self._turned(self._quaternion_transpose(b), CT, b), r))
                    continue
                turn, slide = b.joint_type.subspace(b.axis)
                E = CT
                if turn is not None:
                    E = self._turned(rotation_transpose(P, turn, theta[b.joint]), CT, b)
                if slide is not None:
                    Ca = [sum(b.C[i][k] * slide[k] for k in range(3)) for i in range(3)]
                    th = theta[b.joint]
                    r = [P.emit(r[i] + th * Ca[i]) for i in range(3)]
                out.append((E, r))
            self._frames = out
        return self._frames

    def _turned(self, RT, CT, b):
        """RT C^T (RT when C is the identity), entries emitted."""
        return RT if b.C_identity else [
            [self.P.emit(sum((RT[i][k] * CT[k][j] for k in range(3)), ZERO))
             for j in range(3)] for i in range(3)]

    def _quaternion_transpose(self, b):
        """R(q)^T of a spherical joint's quaternion atoms (entries emitted)."""
        P = self.P
        q = [Ex.atom(f"_q{k}") for k in b.quaternion]
        scaled = b.joint_type.rotation(*q)                    # |q|^2 R(q)
        inverse = P.call("recip", P.emit(sum((x * x for x in q), ZERO)))
        return [[P.emit(scaled[j][i] * inverse) for j in range(3)] for i in range(3)]

    def to_body(self, vec: Vec, i: int) -> Vec:
        """A world-axes vector in body i's axes (E of every body on the way)."""
        b = self.plan.bodies[i]
        above = vec if b.parent is None else self.to_body(vec, b.parent)
        return emitv(self.P, matvec(self.frames()[i][0], above))

    def velocities(self) -> list:
        """Per body (w_i, vo_i), body axes, root to leaves: w_i = E w_p + sum s u,
        vo_i = E (vo_p + w_p x r) + sum v u ((s, v) the joint's subspace columns)."""
        if self._velocities is None:
            P, zero = self.P, [ZERO, ZERO, ZERO]
            rate = self.joint_rates(self.dq)
            out = []
            for i, b in enumerate(self.plan.bodies):
                E, r = self.frames()[i]
                w, vo = zero, zero
                if b.parent is not None:
                    wp, vp = out[b.parent]
                    w, vo = emitv(P, matvec(E, wp)), emitv(P, matvec(E, add(vp, cross(wp, r))))
                for j, (s, v) in enumerate(columns(b), start=b.joint or 0):
                    if s is not None:
                        w = emitv(P, add(w, scale(s, rate[j])))
                    if v is not None:
                        vo = emitv(P, add(vo, scale(v, rate[j])))
                out.append((w, vo))
            self._velocities = out
        return self._velocities

    def external(self, contacts: bool = True) -> dict:
        """Body index -> (force, moment about the origin) of its loads and (``contacts``)
        its contact forces (``numeric.contact``), body axes."""
        P = self.P
        zero = [ZERO, ZERO, ZERO]
        external = {}
        for ld in self.plan.loads:
            Fv = [to_ex(P, x) for x in ld.force]
            Tv = [to_ex(P, x) for x in ld.torque]
            if ld.frame == "world":
                Fv = self.to_body(emitv(P, Fv), ld.body) if any(
                    not x.is_zero() for x in Fv) else zero
                Tv = self.to_body(emitv(P, Tv), ld.body) if any(
                    not x.is_zero() for x in Tv) else zero
            point = [to_ex(P, x) for x in ld.point]
            F0, N0 = external.get(ld.body, (zero, zero))
            external[ld.body] = (add(F0, Fv), add(N0, Tv, cross(point, Fv)))
        for body, force, moment in (w for c in (traced(self) if contacts else ())
                                    for w in c["wrenches"]):
            F0, N0 = external.get(body, (zero, zero))
            external[body] = (add(F0, force), add(N0, moment))
        return external

    # joint efforts -------------------------------------------------------------
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
            out[j] = out[j] + effort * plan.actuator_scale[k]
        return out

    def efforts(self) -> list[Ex]:
        """The actuators' efforts under their control laws."""
        return [self.P.emit(to_ex(self.P, law)) for law in self.plan.laws]

    def applied(self) -> list[Ex]:
        """Joint efforts: actuators under their laws plus springs, dampers, friction."""
        act, passive = self.actuation(), self.passive()
        return [self.P.emit(a + p) for a, p in zip(act, passive)]
