"""The robot's momentum in world axes, for ``check`` on a free robot (one carried by
floating joints only: ``Plan.free``), from the body velocities (``Tracer.velocities``).

Body i's momentum about its origin, in body axes, with h_i = m_i c_i and I_O its
inertia about the origin:

    p_i = m_i vo_i + w_i x h_i,        l_i = I_O w_i + h_i x vo_i,

summed from the leaves to the root as the Newton-Euler recursion sums forces (a
parent's share in its own axes, about its origin: p += E^T p_i, l += E^T l_i +
r x E^T p_i), so the roots' sums are the world's: the linear momentum P and the
angular momentum L about the world origin.  Without external forces both are
constant; under gravity g alone, the components of P normal to g and L . g are.

Their scales, for a relative drift even where the total is zero (a satellite whose
wheel and bus turn against each other): sum_i |p_i| and sum_i (|l_i| + d_i |p_i|),
d_i the distance of body i's origin from the world origin (s_i = E_i (s_p + r_i),
the origin's position in body axes), bounds of |P| and |L| by the triangle
inequality.
"""
from __future__ import annotations

from ..ir import ZERO, Ex
from .spatial import add, const_vec, cross, emitv, matTvec, matvec
from .tracer import Tracer


def momentum(T: Tracer) -> list[Ex]:
    """[Px, Py, Pz, Lx, Ly, Lz] in world axes and the scales of P and L (module
    docstring)."""
    P, plan = T.P, T.plan
    frames = T.frames()
    own, at = [], []
    linear_scale = angular_scale = ZERO
    for b, (w, vo), (E, r) in zip(plan.bodies, T.velocities(), frames):
        h = const_vec(b.h)
        own.append([emitv(P, add([x * b.mass for x in vo], cross(w, h))),
                    emitv(P, add(matvec([[Ex.const(x) for x in row] for row in b.I_O], w),
                                 cross(h, vo)))])
        at.append(emitv(P, matvec(E, r if b.parent is None else add(at[b.parent], r))))
        size = _norm(P, own[-1][0])
        linear_scale = linear_scale + size
        angular_scale = angular_scale + _norm(P, own[-1][1]) + _norm(P, at[-1]) * size
    total = [ZERO] * 6
    for i in reversed(range(len(plan.bodies))):
        linear, angular = (emitv(P, v) for v in own[i])
        E, r = frames[i]
        moved = emitv(P, matTvec(E, linear))
        shares = [moved, add(matTvec(E, angular), cross(r, moved))]
        parent = plan.bodies[i].parent
        if parent is None:
            total = [a + b for a, b in zip(total, [*shares[0], *shares[1]])]
        else:
            own[parent] = [add(own[parent][0], shares[0]), add(own[parent][1], shares[1])]
    return [P.emit(x) for x in (*total, linear_scale, angular_scale)]


def _norm(P, v) -> Ex:
    return P.call("sqrt", P.emit(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
