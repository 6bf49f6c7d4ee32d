"""The articulated-body algorithm (Featherstone, Table 7.1), O(n), in joint space:

    v_i = X_i v_p + S_i dtheta_i,  c_i = v_i x S_i dtheta_i,
    IA_i = I_i,  pA_i = v_i x* I_i v_i - f_ext_i;
    leaves to root: U = IA S, D = S^T U, u = tau - S^T pA,
      Ia = IA - U D^-1 U^T,  pa = pA + Ia c + U D^-1 u,
      IA_p += X^T Ia X,  pA_p += X^T pa;
    root to leaves: a_i = X_i a_p + c_i (a_0 = (0, -g)),
      ddtheta_i = D^-1 (u - U^T a_i),  a_i += S ddtheta_i;

then ddq = J^-1 (ddtheta - h).  Spatial vectors (angular, linear) at the body
origin in body axes; a spatial inertia is [[A, B], [B^T, C]] (about the origin:
A = I_O, B = [h]x, C = m 1); X^T Ia X = T^T (R^T Ia R) T with R = diag(E, E),
T = [[1, 0], [-[r]x, 1]].  S = (s, v) is the joint's motion subspace
(``model.joints``), so that with the velocity (w, vo) before the joint's own,
c = (w x s dtheta, w x v dtheta + vo x s dtheta).  S has one column per joint
speed: D is 1 x 1 for an axial joint, 3 x 3 for a spherical one (inverted in
the traced code by its adjugate, its determinant checked positive).
"""
from __future__ import annotations

from ..ir import ZERO, Ex
from .spatial import (add, columns, combine, congruence, const_vec, cross, dot, emitv, matTvec,
                      matvec, project, scale, skew, skew_ex, sub)
from .tracer import Tracer


def accelerations(T: Tracer) -> list[Ex] | None:
    """ddq by the articulated-body algorithm (module docstring); None when J is not
    constant and invertible."""
    Jinv = T.joint_inverse()
    if Jinv is None:
        return None
    P, plan = T.P, T.plan
    T.frames()
    _, _, hterm = T.joint_maps()
    rate = T.joint_rates(T.dq)
    tau = T.applied()
    external = T.external()
    c, IA, pA = _velocities(T, rate, external)
    U, Dinv, u = _articulated(T, tau, c, IA, pA)
    ddtheta = _accelerations(T, c, U, Dinv, u)
    rhs = [P.emit(ddtheta[j] - hterm[j]) for j in range(len(ddtheta))]
    return [P.emit(sum((rhs[j] * Jinv[k][j] for j in range(len(rhs))), ZERO))
            for k in range(plan.n)]


def _velocities(T: Tracer, rate, external):
    """Root to leaves: the bias accelerations c_i, and IA_i = I_i, pA_i = v x* I v - f_ext."""
    P, plan = T.P, T.plan
    frames = T.frames()
    zero = [ZERO, ZERO, ZERO]
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
        if b.joint_type.moving:
            cols = list(enumerate(columns(b), start=b.joint))
            turn = [scale(s, rate[j]) for j, (s, _) in cols if s is not None]
            slide = [scale(lin, rate[j]) for j, (_, lin) in cols if lin is not None]
            ss = combine(*turn) if turn else None
            sv = combine(*slide) if slide else None
            if ss is not None:
                cw = emitv(P, cross(w, ss))
            cv = emitv(P, combine(cross(vo, ss) if ss is not None else None,
                                  cross(w, sv) if sv is not None else None))
            if ss is not None:
                w = emitv(P, add(w, ss))
            if sv is not None:
                vo = emitv(P, add(vo, sv))
        v[i], c[i] = (w, vo), (cw, cv)
        h = const_vec(b.h)
        A = [[Ex.const(x) for x in row] for row in b.I_O]
        B = [[Ex.const(x) for x in row] for row in skew(b.h)]
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
    return c, IA, pA


def _articulated(T: Tracer, tau, c, IA, pA):
    """Leaves to root: U = IA S, 1/D, u = tau - S^T pA of each moving joint; the
    articulated inertias and bias forces carried to the parents."""
    P, plan = T.P, T.plan
    nb = len(plan.bodies)
    U, Dinv, u = [None] * nb, [None] * nb, [None] * nb
    for i in reversed(range(nb)):
        b = plan.bodies[i]
        A, B, C = [[[P.emit(x) for x in row] for row in M_] for M_ in IA[i]]
        pn, pf = emitv(P, pA[i][0]), emitv(P, pA[i][1])
        cw, cv = c[i]
        if b.joint_type.moving:
            cols = columns(b)
            Us = [(emitv(P, combine(matvec(A, s) if s is not None else None,
                                    matvec(B, lin) if lin is not None else None)),
                   emitv(P, combine(matTvec(B, s) if s is not None else None,
                                    matvec(C, lin) if lin is not None else None)))
                  for s, lin in cols]
            D = [[project(*cols[a], *Us[c_]) for c_ in range(len(cols))]
                 for a in range(len(cols))]
            di = _inverse(P, D, b.name)
            ui = [P.emit(tau[j] - project(*col, pn, pf))
                  for j, col in enumerate(cols, start=b.joint)]
            U[i], Dinv[i], u[i] = Us, di, ui
            if b.parent is None:
                continue
            W = [(emitv(P, combine(*(scale(Us[c_][0], di[c_][a]) for c_ in range(len(cols))))),
                  emitv(P, combine(*(scale(Us[c_][1], di[c_][a]) for c_ in range(len(cols))))))
                 for a in range(len(cols))]

            def less(M_, left, right):
                return [[P.emit(M_[r_][c_] - sum((Us[a][left][r_] * W[a][right][c_]
                                                  for a in range(len(cols))), ZERO))
                         for c_ in range(3)] for r_ in range(3)]

            A, B, C = less(A, 0, 0), less(B, 0, 1), less(C, 1, 1)
            k = [P.emit(sum((ui[c_] * di[a][c_] for c_ in range(len(cols))), ZERO))
                 for a in range(len(cols))]
            pn = add(pn, matvec(A, cw), matvec(B, cv),
                     *(scale(Us[a][0], k[a]) for a in range(len(cols))))
            pf = add(pf, matTvec(B, cw), matvec(C, cv),
                     *(scale(Us[a][1], k[a]) for a in range(len(cols))))
        elif b.parent is None:
            continue
        _to_parent(T, i, (A, B, C), emitv(P, pn), emitv(P, pf), IA, pA)
    return U, Dinv, u


def _inverse(P, D, name: str) -> list[list[Ex]]:
    """D^-1 of the articulated inertia D = S^T IA S (1 x 1, or 3 x 3 by its adjugate),
    entries emitted; the pivot, or the determinant, checked positive."""
    message = f"mass matrix not positive definite (articulated inertia of {name})"
    if len(D) == 1:
        return [[P.call("recip", P.check_positive(P.emit(D[0][0]), message))]]
    D = [[P.emit(D[min(r_, c_)][max(r_, c_)]) for c_ in range(3)] for r_ in range(3)]
    cof = [[P.emit(D[(r_ + 1) % 3][(c_ + 1) % 3] * D[(r_ + 2) % 3][(c_ + 2) % 3]
                   - D[(r_ + 1) % 3][(c_ + 2) % 3] * D[(r_ + 2) % 3][(c_ + 1) % 3])
            for c_ in range(3)] for r_ in range(3)]
    det = P.check_positive(P.emit(sum((D[0][c_] * cof[0][c_] for c_ in range(3)), ZERO)),
                           message)
    inv = P.call("recip", det)
    return [[P.emit(cof[c_][r_] * inv) for c_ in range(3)] for r_ in range(3)]


def _to_parent(T: Tracer, i: int, inertia, pn, pf, IA, pA) -> None:
    """IA_p += X^T Ia X and pA_p += X^T pa for body i: rotate (E^T . E), then
    translate by r."""
    P = T.P
    A, B, C = inertia
    parent = T.plan.bodies[i].parent
    E, rv = T.frames()[i]
    A1 = congruence(P, A, E, symmetric=True)
    B1 = congruence(P, B, E, symmetric=False)
    C1 = congruence(P, C, E, symmetric=True)
    S = skew_ex(rv)
    SB = [[sum((S[r_][k_] * B1[c_][k_] for k_ in range(3)), ZERO) for c_ in range(3)]
          for r_ in range(3)]                                   # S B1^T
    SC = [[P.emit(sum((S[r_][k_] * C1[k_][c_] for k_ in range(3)), ZERO))
           for c_ in range(3)] for r_ in range(3)]              # S C1
    to = IA[parent]
    for r_ in range(3):
        for c_ in range(3):
            # A'' = A1 + S B1^T - B1 S - S C1 S;  B'' = B1 + S C1
            a2 = (A1[r_][c_] + SB[r_][c_]
                  - sum((B1[r_][k_] * S[k_][c_] for k_ in range(3)), ZERO)
                  - sum((SC[r_][k_] * S[k_][c_] for k_ in range(3)), ZERO))
            to[0][r_][c_] = to[0][r_][c_] + a2
            to[1][r_][c_] = to[1][r_][c_] + B1[r_][c_] + SC[r_][c_]
            to[2][r_][c_] = to[2][r_][c_] + C1[r_][c_]
    ff = emitv(P, matTvec(E, pf))
    nn = add(matTvec(E, pn), cross(rv, ff))
    pA[parent] = [add(pA[parent][0], nn), add(pA[parent][1], ff)]


def _accelerations(T: Tracer, c, U, Dinv, u) -> list[Ex]:
    """Root to leaves: a_i = X_i a_p + c_i, ddtheta_i = (u - U^T a_i) / D,
    a_i += S ddtheta_i."""
    P, plan = T.P, T.plan
    frames = T.frames()
    zero = [ZERO, ZERO, ZERO]
    acc = [None] * len(plan.bodies)
    ddtheta = [None] * len(plan.moving)
    for i, b in enumerate(plan.bodies):
        E, rv = frames[i]
        if b.parent is None:
            al, ao = zero, emitv(P, matvec(E, [Ex.const(-g) for g in plan.gravity]))
        else:
            alp, aop = acc[b.parent]
            al = emitv(P, matvec(E, alp))
            ao = emitv(P, matvec(E, sub(aop, cross(rv, alp))))
        al, ao = emitv(P, add(al, c[i][0])), emitv(P, add(ao, c[i][1]))
        if b.joint_type.moving:
            cols = columns(b)
            r = [u[i][c_] - dot(Un, al) - dot(Uf, ao) for c_, (Un, Uf) in enumerate(U[i])]
            r = [P.emit(x) for x in r] if len(r) > 1 else r
            dd = [P.emit(sum((r[c_] * Dinv[i][a][c_] for c_ in range(len(r))), ZERO))
                  for a in range(len(r))]
            ddtheta[b.joint:b.joint + len(dd)] = dd
            turn = [scale(s, dd[a]) for a, (s, _) in enumerate(cols) if s is not None]
            slide = [scale(lin, dd[a]) for a, (_, lin) in enumerate(cols) if lin is not None]
            if turn:
                al = emitv(P, add(al, *turn))
            if slide:
                ao = emitv(P, add(ao, *slide))
        acc[i] = (al, ao)
    return ddtheta
