"""The loads' power and the power joint damping and friction dissipate, for
``check``'s energy balance of a robot whose closed forms do not exist (a spherical
joint), from the body velocities (``Tracer.velocities``), in body axes:

    P_loads = sum_i F_i . vo_i + N_i . w_i      (F, N: the loads on body i, force and
                                                 moment about its origin, body axes)
    P_dissipated = sum_j c_j dtheta_j^2 + f_j dtheta_j tanh(dtheta_j / v_j)
"""
from __future__ import annotations

from ..ir import ZERO, Ex
from .spatial import dot
from .tracer import Tracer


def powers(T: Tracer) -> list[Ex]:
    """[P_loads, P_dissipated] (module docstring)."""
    P, plan = T.P, T.plan
    rate = T.joint_rates(T.dq)
    external = T.external(contacts=False)      # contact: ``numeric.contact``'s own terms
    loads = ZERO
    for i, (w, vo) in enumerate(T.velocities()):
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
