"""Analytic derivatives of the recursive Newton-Euler algorithm (Carpentier and
Mansard, "Analytical Derivatives of Rigid Body Dynamics Algorithms", RSS 2018;
Pinocchio's ``computeRNEADerivatives``), traced like ``rnea``: the open-loop
Jacobian K = -dID/d[q, dq, e] at fixed ddq of ID = A^T (tau - passive - B_theta e).

Covered: open trees of one-speed joints (revolute, prismatic, so compound joints
too) with an affine joint map theta = A q + c (``Plan.joint_expressions``: constant
rows, no Hessian term), without loads or contacts; ``jacobian`` returns None
otherwise and ``derivatives`` differentiates the traced RNEA in forward mode.

Spatial vectors at the state's instant, motions (linear v, angular w), forces (f,
n); m1 x m2 = (w1 x v2 + v1 x w2, w1 x w2), m x* f = (w x f, w x n + v x f).  Every
product below is unchanged by a change of axes and origin applied to all, so each
group (``groups``: the subtree of a first moving joint, no product joins two) is
resolved in the axes and about the origin of one of its bodies, the reference (or
the world's), whichever the generated code needs fewest operations for
(``recursive.derivatives``): the bodies near the reference keep constant inertias
and sparse rotations, as the forward mode in body axes does.  Body i (parent p,
rotation R_i and origin o_i relative to the reference: up from it R_p = R_c E_c,
o_p = o_c - R_p r_c, down R_i = R_p E_i^T, o_i = o_p + R_p r_i), with joint column
(s, v) in body axes, has

    S_i = (R_p C v + o_i x R_p C s, R_p C s)        (the joint turns about s)
    Y_i = (m, c_i = R_i h + m o_i, I_i = R_i I_O R_i^T - m [o]^2 - [o][R_i h] - [R_i h][o])
    Y (l, a) = (m l - c x a, c x l + I a)

Forward pass (v_0 = 0, a_0 = (-R_0 g, 0): gravity as the base acceleration, R_0 the
world's axes relative to the reference):

    v_i = v_p + S_i dtheta_i,   dVdq_i = v_p x S_i,
    a_i = a_p + S_i ddtheta_i + dVdq_i dtheta_i,
    dAdq_i = a_p x S_i + v_p x dVdq_i,   dAdv_i = 2 dVdq_i,
    h_i = Y_i v_i = (hl, ha),   f_i = Y_i a_i + v_i x* h_i,

and the variation of the body's inertia along its velocity plus the cross with its
momentum (Pinocchio's ``doYcrb``), which acts on the angular part u_a alone:

    dY_i u = v_i x* Y_i u - Y_i (v_i x u) + u x* h_i = (-2 hl x u_a, Sym_i u_a - ha x u_a),
    Sym_i = X + X^T + 2 (v . c) 1 - c v^T - v c^T,   X = [w] I   (v, w of v_i).

Backward pass, leaves to root, Y, f, h, Sym summed over the subtree of body j
(composite, ``c`` below):

    dFdq_j = Y_c dAdq_j + dY_c dVdq_j (+ S_j x* f_c for the ancestors' rows)
    dFdv_j = Y_c dAdv_j + dY_c S_j
    dtau_i/dq_j = S_i . dFdq_j,  dtau_i/ddtheta_j = S_i . dFdv_j   (i = j or an ancestor)
    M_ij = M_ji = S_i . Y_c S_j                                     (the CRBA's)
    dtau_k/dq_j = (Y_ck S_k) . dAdq_j + (S_k^T dY_ck) . dVdq_j      (k below j)
    dtau_k/ddtheta_j = (Y_ck S_k) . dAdv_j + (S_k^T dY_ck) . S_j

with S_k^T dY_c u = (2 hl x s_l + ha x s_a + Sym s_a) . u_a.  The springs, dampers
and friction are local: d(passive_j)/d(theta_j) = -stiffness,
d(passive_j)/d(dtheta_j) = -damping - friction (1 - tanh^2(dtheta_j / v)) / v; and
dID/de = -A^T B_theta.  So K = -[A^T (dtau/dtheta - dpassive/dtheta) A,
A^T (dtau/ddtheta - dpassive/ddtheta) A, -A^T B_theta].
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..ir import ZERO, Ex
from .plan import Plan
from .spatial import Vec, add, cross, dot, emitv, matTvec, matvec, product, scale, skew_ex
from .tracer import Tracer

Motion = tuple  # (linear Vec, angular Vec)


def covered(pl: Plan) -> bool:
    """Whether ``jacobian`` covers the robot (see the module docstring)."""
    if pl.loads or pl.contacts or pl.spherical:
        return False
    if any(b.joint is not None and len(b.joint_type.columns(b.axis)) != 1 for b in pl.bodies):
        return False
    for _, grad, hess in pl.joint_expressions():
        if hess != 0 or any(g.free_symbols for g in grad):
            return False
    return True


def _mcross(a: Motion, b: Motion) -> Motion:
    """a x b of two motions."""
    return add(cross(a[1], b[0]), cross(a[0], b[1])), cross(a[1], b[1])


def _fcross(m: Motion, f: Motion) -> Motion:
    """m x* f, a motion on a force."""
    return cross(m[1], f[0]), add(cross(m[1], f[1]), cross(m[0], f[0]))


def _madd(*ms: Motion) -> Motion:
    return add(*(m[0] for m in ms)), add(*(m[1] for m in ms))


def _mscale(m: Motion, s) -> Motion:
    return scale(m[0], s), scale(m[1], s)


def _dot6(a: Motion, b: Motion) -> Ex:
    return dot(a[0], b[0]) + dot(a[1], b[1])


def _emit6(P, m: Motion) -> Motion:
    return emitv(P, m[0]), emitv(P, m[1])


def _sym(S6) -> list[list[Ex]]:
    """The symmetric 3x3 matrix of its upper triangle (xx, xy, xz, yy, yz, zz)."""
    xx, xy, xz, yy, yz, zz = S6
    return [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]


def _upper(A) -> list[Ex]:
    return [A[0][0], A[0][1], A[0][2], A[1][1], A[1][2], A[2][2]]


class _Inertia:
    """A spatial inertia in the reference's axes, about its origin: mass m (float),
    first moment c, rotational inertia I (upper triangle, 6 Ex); additive."""

    def __init__(self, m: float, c: Vec, I: list[Ex]):
        self.m, self.c, self.I = m, c, I

    def apply(self, u: Motion) -> Motion:
        """Y u = (m l - c x a, c x l + I a)."""
        l, a = u
        return (add(scale(l, self.m), cross(a, self.c)),
                add(cross(self.c, l), matvec(_sym(self.I), a)))

    def plus(self, other: "_Inertia") -> "_Inertia":
        return _Inertia(self.m + other.m, add(self.c, other.c),
                        [x + y for x, y in zip(self.I, other.I)])


def _body_inertia(P, b, R: list[list[Ex]], o: Vec) -> _Inertia:
    """Y_i of the module docstring from the body's m, h, I_O (body axes), R and o its
    axes and origin relative to the reference."""
    m = b.mass
    hr = emitv(P, matvec(R, [Ex.const(x) for x in b.h]))
    IO = [[Ex.const(x) for x in row] for row in b.I_O]
    RI = product(P, R, IO)
    rot = [[sum((RI[r][k] * R[c][k] for k in range(3)), ZERO) for c in range(3)]
           for r in range(3)]
    # - m [o]^2 - [o][hr] - [hr][o] = o.(c + hr) 1 - o c^T - hr o^T, c = hr + m o
    c = emitv(P, add(hr, scale(o, m)))
    diag = P.emit(dot(o, add(c, hr)))
    shift = [[(diag if r == k else ZERO) - o[r] * c[k] - hr[r] * o[k] for k in range(3)]
             for r in range(3)]
    I = [P.emit(x + y) for x, y in zip(_upper(rot), _upper(shift))]
    return _Inertia(m, c, I)


def _variation(P, v: Motion, Y: _Inertia) -> list[Ex]:
    """Sym_i = X + X^T + 2 (v . c) 1 - c v^T - v c^T, X = [w] I (upper triangle)."""
    lin, w = v
    I, c = _sym(Y.I), Y.c
    X = [[cross(w, [I[0][k], I[1][k], I[2][k]])[r] for k in range(3)] for r in range(3)]
    vc = P.emit(dot(lin, c) * 2.0)
    return [P.emit(X[r][k] + X[k][r] + (vc if r == k else ZERO) - c[r] * lin[k] - lin[r] * c[k])
            for r, k in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))]


@dataclass
class _Pass:
    """The forward pass: per body of a group (dicts by body index) its spatial inertia
    Y, force f, momentum h and variation Sym (summed into composites by ``_backward``),
    per joint its column S, dVdq, dAdq and dAdv (dicts by joint index)."""
    Y: dict
    F: dict
    H: dict
    Sym: dict
    column: dict = field(default_factory=dict)
    dVdq: dict = field(default_factory=dict)
    dAdq: dict = field(default_factory=dict)
    dAdv: dict = field(default_factory=dict)


def groups(pl: Plan) -> dict[int, int]:
    """Body -> its group: the body of the first moving joint on its way down from the
    world (bodies with none are in no group: nothing they do enters K or M).  The
    groups are independent: no product of the passes joins two."""
    out: dict[int, int] = {}
    for i, b in enumerate(pl.bodies):
        if b.parent is not None and b.parent in out:
            out[i] = out[b.parent]
        elif b.joint is not None:
            out[i] = i
    return out


def reference_at(pl: Plan, depth: int | None) -> dict[int, int | None]:
    """Group -> the body ``depth`` joints below it, each step into the child with the
    most moving joints below it (None: the world's axes)."""
    below = [0] * len(pl.bodies)
    children: dict[int, list[int]] = {}
    for i in reversed(range(len(pl.bodies))):
        b = pl.bodies[i]
        below[i] += b.joint is not None
        if b.parent is not None:
            below[b.parent] += below[i]
            children.setdefault(b.parent, []).insert(0, i)
    out: dict[int, int | None] = {}
    for g in sorted(set(groups(pl).values())):
        body = None if depth is None else g
        for _ in range(depth or 0):
            if children.get(body):
                body = max(children[body], key=lambda c: below[c])
        out[g] = body
    return out


def _poses(T: Tracer, group: int, reference: int | None):
    """The axes R_i and origin o_i of each body of ``group`` and of its parent, in the
    axes and about the origin of body ``reference`` (None: the world's), and gravity's
    acceleration there: from the reference up to the group's parent (R_p = R_c E_c,
    o_p = o_c - R_p r_c), then down (R_i = R_p E_i^T, o_i = o_p + R_p r_i); above the
    group the joints are fixed, so that the parent's world axes W are constants."""
    P, bodies = T.P, T.plan.bodies
    frames = T.frames()
    eye = [[Ex.const(float(r == c)) for c in range(3)] for r in range(3)]
    zero = [ZERO, ZERO, ZERO]
    W, ow = eye, zero                       # the group's parent in world axes
    chain = []
    up = bodies[group].parent
    while up is not None:
        chain.append(up)
        up = bodies[up].parent
    for c in reversed(chain):
        E, r = frames[c]
        W, ow = product(P, W, E, True), emitv(P, add(ow, matvec(W, r)))
    minus_g = [Ex.const(-g) for g in T.plan.gravity]
    R, o = {}, {}
    parent = (W, ow)
    gravity = minus_g
    if reference is not None:
        R[reference], o[reference] = eye, zero
        c = reference
        while True:
            E, r = frames[c]
            Rp = product(P, R[c], E, False)
            op = emitv(P, [o[c][k] - x for k, x in enumerate(matvec(Rp, r))])
            if c == group:
                parent = (Rp, op)
                gravity = emitv(P, matvec(Rp, matTvec(W, minus_g)))
                break
            c = bodies[c].parent
            R[c], o[c] = Rp, op
    for i in range(group, len(bodies)):
        if i not in R and (i == group or bodies[i].parent in R):
            E, r = frames[i]
            Rp, op = parent if i == group else (R[bodies[i].parent], o[bodies[i].parent])
            R[i], o[i] = product(P, Rp, E, True), emitv(P, add(op, matvec(Rp, r)))
    return R, o, parent, gravity


def _forward(T: Tracer, rate: list[Ex], acc: list[Ex], references: dict) -> _Pass:
    """Root to leaves, each group in the axes and about the origin of its body
    ``references[group]`` (None: the world's; the scalars of K are the same in any:
    every product below is), the module docstring's forward pass."""
    P, pl = T.P, T.plan
    zero = [ZERO, ZERO, ZERO]
    group = groups(pl)
    R, o, start = {}, {}, {}
    for g, reference in references.items():
        Rg, og, parent, gravity = _poses(T, g, reference)
        R.update(Rg), o.update(og)
        start[g] = (parent[0], (zero, zero), (emitv(P, gravity), zero))
    vel, accel = {}, {}
    out = _Pass({}, {}, {}, {})
    for i, b in enumerate(pl.bodies):
        if i not in group:
            continue
        if i == group[i]:
            Rp, vp, ap = start[i]
        else:
            Rp, vp, ap = R[b.parent], vel[b.parent], accel[b.parent]
        Ri, oi = R[i], o[i]
        v, a = vp, ap
        if b.joint is not None:
            j = b.joint
            (s, lin), = b.joint_type.columns(b.axis)
            parts = []
            for part in (s, lin):                              # R_p C part (C the rpy turn)
                if part is None:
                    parts.append(zero)
                    continue
                Cp = [Ex.const(sum(b.C[r_][k] * part[k] for k in range(3))) for r_ in range(3)]
                parts.append(emitv(P, matvec(Rp, Cp)))
            sa = parts[0]
            Sj = (emitv(P, add(parts[1], cross(oi, sa))), sa)
            dv = _emit6(P, _mcross(vp, Sj))
            out.column[j], out.dVdq[j], out.dAdv[j] = Sj, dv, _emit6(P, _mscale(dv, 2.0))
            out.dAdq[j] = _emit6(P, _madd(_mcross(ap, Sj), _mcross(vp, dv)))
            v = _emit6(P, _madd(vp, _mscale(Sj, rate[j])))
            a = _emit6(P, _madd(ap, _mscale(Sj, acc[j]), _mscale(dv, rate[j])))
        vel[i], accel[i] = v, a
        Yi = _body_inertia(P, b, Ri, oi)
        h = _emit6(P, Yi.apply(v))
        out.Y[i], out.H[i] = Yi, h
        out.F[i] = _madd(Yi.apply(a), _fcross(v, h))
        out.Sym[i] = _variation(P, v, Yi)
    return out


def _backward(T: Tracer, fw: _Pass):
    """Leaves to root (the module docstring's backward pass): dtau/dtheta, dtau/d(dtheta)
    and dtau/d(ddtheta) = M_theta, nm x nm each."""
    P, pl = T.P, T.plan
    nm = len(pl.moving)
    Y, F, H, Sym = fw.Y, fw.F, fw.H, fw.Sym
    column, dAdq, dAdv = fw.column, fw.dAdq, fw.dAdv
    dtheta, drate, mass = ([[ZERO] * nm for _ in range(nm)] for _ in range(3))
    below: dict[int, list[int]] = {i: [] for i in Y}      # the moving joints below
    dFda, row_dY = {}, {}
    for i in sorted(Y, reverse=True):
        b = pl.bodies[i]
        Yc = _Inertia(Y[i].m, emitv(P, Y[i].c), [P.emit(x) for x in Y[i].I])
        Fc, Hc, Sc = _emit6(P, F[i]), _emit6(P, H[i]), [P.emit(x) for x in Sym[i]]
        if b.joint is not None:
            j = b.joint
            Sj, dv = column[j], fw.dVdq[j]
            hl2 = emitv(P, scale(Hc[0], 2.0))
            AA = [[P.emit(_sym(Sc)[r][k] - skew_ex(Hc[1])[r][k]) for k in range(3)]
                  for r in range(3)]              # Sym - [ha]

            def dY(u: Motion) -> Motion:
                """dY_c u = (-2 hl x u_a, (Sym - [ha]) u_a)."""
                return cross(u[1], hl2), matvec(AA, u[1])

            nrq = _emit6(P, _madd(Yc.apply(dAdq[j]), dY(dv)))
            dFdv = _emit6(P, _madd(Yc.apply(dAdv[j]), dY(Sj)))
            dFdq = _emit6(P, _madd(nrq, _fcross(Sj, Fc)))
            dFda[j] = _emit6(P, Yc.apply(Sj))
            sl, sa = Sj
            row_dY[j] = emitv(P, add(cross(hl2, sl), matTvec(AA, sa)))
            mass[j][j] = P.emit(_dot6(Sj, dFda[j]))
            dtheta[j][j] = P.emit(_dot6(Sj, nrq))
            drate[j][j] = P.emit(_dot6(Sj, dFdv))
            up = b.parent
            while up is not None:
                k = pl.bodies[up].joint
                if k is not None:
                    mass[k][j] = mass[j][k] = P.emit(_dot6(column[k], dFda[j]))
                    dtheta[k][j] = P.emit(_dot6(column[k], dFdq))
                    drate[k][j] = P.emit(_dot6(column[k], dFdv))
                up = pl.bodies[up].parent
            for k in below[i]:
                dtheta[k][j] = P.emit(_dot6(dFda[k], dAdq[j]) + dot(row_dY[k], dv[1]))
                drate[k][j] = P.emit(_dot6(dFda[k], dAdv[j]) + dot(row_dY[k], sa))
            below[i].append(j)
        if b.parent in Y:
            p = b.parent
            Y[p] = Y[p].plus(Yc)
            F[p], H[p] = _madd(F[p], Fc), _madd(H[p], Hc)
            Sym[p] = [x + y for x, y in zip(Sym[p], Sc)]
            below[p] += below[i]
    return dtheta, drate, mass


def _congruent(P, A: list[list[float]], D, sign: float) -> list[list[Ex]]:
    """sign A^T D A (A floats, nm x n; D nm x nm)."""
    nm, n = len(A), len(A[0]) if A else 0
    DA = [[P.emit(sum((D[j][l] * A[l][c] for l in range(nm) if A[l][c]), ZERO))
           for c in range(n)] for j in range(nm)]
    return [[P.emit(sum((DA[j][c] * A[j][r] for j in range(nm) if A[j][r]), ZERO) * sign)
             for c in range(n)] for r in range(n)]


def jacobian(T: Tracer, ddq: list[Ex], depth: int | None = None
             ) -> tuple[list[list[Ex]], list[list[Ex]]] | None:
    """M = A^T (S_i . Y_cj S_j) A and K = -dID/d[q, dq, e] at fixed ddq (n x (2n + m))
    traced into T.P, each group in the axes of the body ``depth`` joints below its
    first (``reference_at``; None: the world's axes), None where the robot is not
    ``covered``."""
    P, pl = T.P, T.plan
    if not covered(pl):
        return None
    n = pl.n
    _, rows, _ = T.joint_maps()
    A = [[row[k].constant() for k in range(n)] for row in rows]      # theta = A q + c
    rate, acc = T.joint_rates(T.dq), T.joint_rates(ddq)
    dtheta, drate, mass = _backward(T, _forward(T, rate, acc, reference_at(pl, depth)))
    for j, bi in enumerate(pl.moving):          # the springs, dampers and friction
        bp = pl.bodies[bi]
        if bp.stiffness:
            dtheta[j][j] = dtheta[j][j] + bp.stiffness
        slope = bp.damping
        if bp.friction:
            th = P.call("tanh", P.emit(rate[j] * (1.0 / bp.friction_velocity)))
            slope = (1.0 - th * th) * (bp.friction / bp.friction_velocity) + slope
        drate[j][j] = drate[j][j] + slope
    Kq, Kv = _congruent(P, A, dtheta, -1.0), _congruent(P, A, drate, -1.0)
    Ke = [[Ex.const(A[j][r] * s) for j, s in zip(pl.actuator_joint, pl.actuator_scale)]
          for r in range(n)]
    return _congruent(P, A, mass, 1.0), [Kq[r] + Kv[r] + Ke[r] for r in range(n)]
