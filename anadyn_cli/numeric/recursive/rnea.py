"""The recursive Newton-Euler algorithm (Featherstone ch. 5): inverse dynamics

    ID(t, q, dq, ddq) = J^T (tau - tau_passive [- tau_actuators]) = M ddq - F [- B tau]

in body axes, with classical accelerations of the origin and gravity as the base
acceleration a_0 = -g.  Forward pass, root to leaves, with (s, v) the joint's
motion subspace (``model.joints``; (a, -) revolute, (-, a) prismatic, three
columns (e_k, -) spherical: sums over the columns, constant in body axes):

    w_i  = E w_p [+ s dtheta]
    al_i = E al_p [+ s ddtheta + (E w_p) x s dtheta]
    ao_i = E (ao_p + al_p x r + w_p x (w_p x r)) [+ v ddtheta + 2 (E w_p) x v dtheta]

body forces about the origin (h = m c, I_O, F_ext and T_ext the loads):

    f_i = m ao + al x h + w x (w x h) - F_ext
    n_i = I_O al + w x (I_O w) + h x ao - (p x F_ext + T_ext)

backward pass, leaves to root: the joint force is tau_i = S^T (n_i, f_i) =
s . n_i + v . f_i, and the parent collects f_p += E^T f_i,
n_p += E^T n_i + r x E^T f_i.
"""
from __future__ import annotations

from ..ir import ZERO, Ex
from .spatial import add, columns, const_vec, cross, emitv, matTvec, matvec, project, scale, sub
from .tracer import Tracer


def inverse_dynamics(T: Tracer, ddq: list[Ex] | None, actuators: bool) -> list[Ex]:
    """ID(t, q, dq, ddq) = J^T (tau - tau_passive [- tau_actuators]); ddq None: zero."""
    P, plan = T.P, T.plan
    _, rows, hterm = T.joint_maps()
    T.frames()
    rate = T.joint_rates(T.dq)
    if ddq is None:
        acc = list(hterm)
    else:
        acc = [P.emit(x + h) for x, h in zip(T.joint_rates(ddq), hterm)]
    forces = _forward(T, rate, acc)
    tau = _backward(T, forces)
    passive = T.passive()
    act = T.actuation() if actuators else [ZERO] * len(tau)
    joint = [P.emit(tau[j] - passive[j] - act[j]) for j in range(len(tau))]
    return [P.emit(sum((rows[j][k] * joint[j] for j in range(len(joint))), ZERO))
            for k in range(plan.n)]


def _forward(T: Tracer, rate: list[Ex], acc: list[Ex]) -> list[list]:
    """Root to leaves: each body's velocities, accelerations and force [f, n]
    (loads subtracted), given the joint rates and accelerations."""
    P, plan = T.P, T.plan
    frames = T.frames()
    zero = [ZERO, ZERO, ZERO]
    w, al, ao = [], [], []
    external = T.external()
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
        cols = list(enumerate(columns(b), start=b.joint or 0))
        turn = [(s, j) for j, (s, _) in cols if s is not None]
        slide = [(v, j) for j, (_, v) in cols if v is not None]
        if turn:
            w_i = add(wr, *(scale(s, rate[j]) for s, j in turn))
            al_i = add(al_i, *(scale(s, acc[j]) for s, j in turn),
                       *(scale(cross(wr, s), rate[j]) for s, j in turn))
        if slide:
            ao_i = add(ao_i, *(scale(v, acc[j]) for v, j in slide),
                       *(scale(cross(wr, v), rate[j] * 2.0) for v, j in slide))
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
    return forces


def _backward(T: Tracer, forces: list[list]) -> list[Ex]:
    """Leaves to root: the joint forces tau = S^T (n, f), each body's force
    carried to its parent."""
    P, plan = T.P, T.plan
    frames = T.frames()
    tau = [ZERO] * len(plan.moving)
    for i in reversed(range(len(plan.bodies))):
        b = plan.bodies[i]
        f, nn = emitv(P, forces[i][0]), emitv(P, forces[i][1])
        for j, (s, v) in enumerate(columns(b), start=b.joint or 0):
            tau[j] = P.emit(project(s, v, nn, f))
        if b.parent is not None:
            E, r = frames[i]
            fp = emitv(P, matTvec(E, f))
            npar = add(matTvec(E, nn), cross(r, fp))
            forces[b.parent][0] = add(forces[b.parent][0], fp)
            forces[b.parent][1] = add(forces[b.parent][1], npar)
    return tau
