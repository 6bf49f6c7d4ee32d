"""The composite-rigid-body algorithm: the mass matrix M = J^T H J.

Composite inertias (mass m, h = m c and I about the origin, body axes) from
the leaves to the root, each moved to its parent's origin with h' = E^T h:

    I_P += E^T I E + m(|r|^2 1 - r r^T) + 2 (r.h') 1 - r h'^T - h' r^T
    h_P += h' + m r,   m_P += m

Then for joint speed i with motion subspace column (s, v) (``model.joints``),
the spatial force F = I_i S_i = (I s + h x v, m v + s x h) gives H_ik = S_k^T F
for the body's own earlier columns k (a spherical joint's three), and is carried
to each ancestor j by n <- E^T n + r x E^T f, f <- E^T f, with H_ij = S_j^T F =
s_j . n + v_j . f for each of its columns.  Entries for bodies on different
branches are structurally zero.
"""
from __future__ import annotations

from ..ir import ZERO, Ex
from .spatial import (add, columns, combine, const_vec, cross, dot, emitv, matTvec, matvec,
                      project, scale)
from .tracer import Tracer


def joint_mass_matrix(T: Tracer) -> dict[tuple[int, int], Ex]:
    """H_ij (joint speeds i >= j in body order; absent = structural zero)."""
    P, plan = T.P, T.plan
    frames = T.frames()
    comp = _composites(T)
    H: dict[tuple[int, int], Ex] = {}
    for row, i in enumerate(plan.moving):
        b = plan.bodies[i]
        m, h, I = comp[i]
        own = columns(b)
        s, v = own[row - b.joint]
        Fn = emitv(P, combine(matvec(I, s) if s is not None else None,
                              cross(h, v) if v is not None else None))
        Ff = emitv(P, combine(cross(s, h) if s is not None else None,
                              scale(v, m) if v is not None else None))
        for k in range(b.joint, row + 1):
            H[row, k] = P.emit(project(*own[k - b.joint], Fn, Ff))
        j = i
        while plan.bodies[j].parent is not None:
            E, rv = frames[j]
            Ff = emitv(P, matTvec(E, Ff))
            Fn = emitv(P, add(matTvec(E, Fn), cross(rv, Ff)))
            j = plan.bodies[j].parent
            bj = plan.bodies[j]
            for k, column in enumerate(columns(bj), start=bj.joint or 0):
                H[row, k] = P.emit(project(*column, Fn, Ff))
    return H


def _composites(T: Tracer) -> list[list]:
    """[m, h, I] of each body's subtree, about its origin in its axes."""
    P, plan = T.P, T.plan
    frames = T.frames()
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
    return comp


def mass_matrix(T: Tracer) -> list[list[Ex]]:
    """M = J^T H J on the coordinates (symmetric, Ex entries)."""
    P, plan = T.P, T.plan
    n, nj = plan.n, len(plan.moving)
    H = joint_mass_matrix(T)
    _, rows, _ = T.joint_maps()

    def Hij(i, j):
        return H.get((i, j)) if (i, j) in H else H.get((j, i), ZERO)

    HJ = [[P.emit(sum((Hij(i, j) * rows[j][s] for j in range(nj)), ZERO))
           for s in range(n)] for i in range(nj)]
    M = [[None] * n for _ in range(n)]
    for r in range(n):
        for s in range(r, n):
            M[r][s] = M[s][r] = P.emit(sum((rows[i][r] * HJ[i][s] for i in range(nj)), ZERO))
    return M
