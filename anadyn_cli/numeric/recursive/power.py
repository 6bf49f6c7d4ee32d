"""The loads' power and the power joint damping and friction dissipate, for
``check``'s energy balance of a robot whose closed forms do not exist (a spherical
joint): body velocities root to leaves, in body axes,

    w_i = E w_p + sum s u,   vo_i = E (vo_p + w_p x r) + sum v u

((s, v) the joint's motion subspace columns, u its joint speeds), then

    P_loads = sum_i F_i . vo_i + N_i . w_i      (F, N: the loads on body i, force and
                                                 moment about its origin, body axes)
    P_dissipated = sum_j c_j dtheta_j^2 + f_j dtheta_j tanh(dtheta_j / v_j)
"""
from __future__ import annotations

from ..ir import ZERO, Ex
from .spatial import add, columns, cross, dot, emitv, matvec, scale
from .tracer import Tracer


def powers(T: Tracer) -> list[Ex]:
    """[P_loads, P_dissipated] (module docstring)."""
    P, plan = T.P, T.plan
    frames = T.frames()
    rate = T.joint_rates(T.dq)
    external = T.external()
    zero = [ZERO, ZERO, ZERO]
    velocity = []
    loads = ZERO
    for i, b in enumerate(plan.bodies):
        E, r = frames[i]
        w, vo = zero, zero
        if b.parent is not None:
            wp, vp = velocity[b.parent]
            w, vo = emitv(P, matvec(E, wp)), emitv(P, matvec(E, add(vp, cross(wp, r))))
        for j, (s, v) in enumerate(columns(b), start=b.joint or 0):
            if s is not None:
                w = emitv(P, add(w, scale(s, rate[j])))
            if v is not None:
                vo = emitv(P, add(vo, scale(v, rate[j])))
        velocity.append((w, vo))
        if i in external:
            force, moment = external[i]
            loads = loads + dot(force, vo) + dot(moment, w)
    dissipated = ZERO
    for j, i in enumerate(plan.moving):
        b = plan.bodies[i]
        if b.damping:
            dissipated = dissipated + rate[j] * rate[j] * b.damping
        if b.friction:
            dissipated = dissipated + rate[j] * P.call(
                "tanh", P.emit(rate[j] * (1.0 / b.friction_velocity))) * b.friction
    return [P.emit(loads), P.emit(dissipated)]
