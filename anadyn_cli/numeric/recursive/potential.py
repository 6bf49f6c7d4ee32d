"""The potential energy of gravity and joint springs, root to leaves:

    V = -sum_i (m_i g . p_i + g_i . h_i) + sum_j 1/2 k_j (theta_j - rest_j)^2

with the height g . p_i = g . p_p + g_p . r_i of body i's origin and g_i = E_i g_p
gravity in body axes (h = m c).
"""
from __future__ import annotations

from ..ir import ZERO, Ex
from .spatial import const_vec, dot, emitv, matvec
from .tracer import Tracer


def potential(T: Tracer) -> Ex:
    """V (module docstring)."""
    P, plan = T.P, T.plan
    frames = T.frames()
    theta, _, _ = T.joint_maps()
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
        if b.joint_type.moving and b.stiffness:
            d = P.emit(theta[b.joint] - b.rest)
            V = V + d * d * (0.5 * b.stiffness)
    return P.emit(V)
