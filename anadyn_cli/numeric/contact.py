"""Compliant contact forces in the traced recursions (``model.contacts``).

Per contact on body i, in body i's axes (n_i the ground's normal turned into them,
s_i = n . p_i the height of the body's origin along n, root to leaves
s_i = s_p + n_p . r_i), with c the sphere's centre and rho its radius:

    d   = rho + height - (s_i + n_i . c)              penetration (< 0: the gap)
    r   = c - rho n_i                                 the contact point
    v   = vo_i + w_i x r                              its material velocity
    d'  = -n_i . v,   v_t = v + d' n_i                (tangential part)
    f_n = max(0, d)^p max(0, k + c_d d')              Hunt-Crossley, never pulling
    F   = f_n n_i - mu f_n tanh(|v_t| / v_s) v_t / |v_t|

|v_t| is taken as sqrt(|v_t|^2 + (1e-6 v_s)^2), so that the friction is smooth
through v_t = 0 (it changes the force by less than 1e-12 of mu f_n).  The wrench
(F, r x F) joins the body's external loads (``Tracer.external``).  For ``check``
and the output, per contact: f_n, the friction's components along the ground's
tangents t1, t2 (``tangents``), d, the spring energy k max(0, d)^(p+1) / (p + 1)
and the power the contact dissipates, (f_n - k max(0, d)^p) d' (damping; or all
the spring's power while the clipped law lets go) + mu f_n tanh(|v_t|/v_s) |v_t|
(friction), both >= 0.

Between two spheres on bodies 1 and 2 (``_pair``), in world axes from the bodies'
world frames (R_i = R_p E_i^T, p_i = p_p + R_p r_i): n = (c1 - c2) / |c1 - c2|,
d = rho1 + rho2 - |c1 - c2|, the point c1 - (rho1 - d/2) n, v the relative velocity
of the two material points there; the same law, F on body 1 and -F on body 2
(reported: ft1 = |f_t|, ft2 = 0, their normal turning).

For the rigid model (``ContactPlan.rigid``) no force is traced: the contact gives only
its kinematics, d and the material velocity at the contact point along n (vn = -d',
the separating speed) and, against a ground, along t1 and t2 (vt1, vt2; a pair: 0),
from which ``numeric.impacts`` takes the contact Jacobian (they are linear in the
speeds).

A capsule or a box against a sphere (``spans`` e_k, body axes) uses for c1 the point
c1 + sum s_k R1 e_k nearest c2, s_k = clamp((R1 e_k) . (c2 - c1) / |e_k|^2, -1, 1)
(``_nearest``; the spans are orthogonal, so the clamps are independent): then n is
normal to the segment or the box face, and the law holds while c2 stays outside the
box.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from .ir import Ex, Program

#: |v_t| is regularized by this fraction of the friction velocity
SLIP_FLOOR = 1e-6


@dataclass
class ContactPlan:
    """One contact with its numbers folded (``plan.plan``): world normal, tangents."""
    name: str
    body: int
    centre: list[float]          # body axes, m
    radius: float
    normal: list[float]          # unit, world axes (a pair: [], its normal moves)
    tangents: list[list[float]]  # t1, t2: world axes, t2 = n x t1
    height: float
    stiffness: float
    damping: float
    exponent: float
    friction: float
    friction_velocity: float
    partner: int | None = None           # the other sphere's body (None: the ground)
    partner_centre: list[float] | None = None
    partner_radius: float = 0.0
    spans: list[list[float]] = field(default_factory=list)   # body axes (``_nearest``)
    restitution: float = 0.0             # the rigid model's (``numeric.impacts``)
    static_friction: float = 0.0         # the rigid model's sticking limit (>= friction)
    rigid: bool = False                  # rigid: no force traced, only the kinematics


def tangents(normal: list[float]) -> list[list[float]]:
    """t1: the world axis least along n (x first on a tie) with its part along n removed,
    made unit; t2 = n x t1 (for n = z: t1 = x, t2 = y)."""
    axis = min(range(3), key=lambda k: (abs(normal[k]), k))
    e = [float(k == axis) for k in range(3)]
    along = normal[axis]
    t1 = [e[k] - along * normal[k] for k in range(3)]
    length = sum(x * x for x in t1) ** 0.5
    t1 = [x / length for x in t1]
    n = normal
    t2 = [n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0]]
    return [t1, t2]


def contact_plans(robot, number, index: dict[str, int]) -> list[ContactPlan]:
    """The robot's contacts (none: []) with ``number`` (expression -> float, parameters
    folded) applied; ``index``: body name -> body index."""
    if robot.contacts is None:
        return []
    out = []
    for c in robot.contacts.items:
        law, pair = c.law, c.partner
        normal = [] if pair else [number(x) for x in c.ground.normal]      # a pair's moves
        out.append(ContactPlan(
            c.name, index[c.body], [number(x) for x in c.point], number(c.radius), normal,
            tangents(normal) if normal else [], number(c.ground.height) if normal else 0.0,
            number(law.stiffness), number(law.damping), number(law.exponent),
            number(law.friction), number(law.friction_velocity),
            *((index[pair.body], [number(x) for x in pair.point], number(pair.radius))
              if pair else ()), spans=[[number(x) for x in e] for e in c.spans],
            restitution=number(law.restitution), rigid=robot.contacts.model == "rigid",
            static_friction=number(law.static_friction)))
    return out


def _symbol(P: Program, value: Ex) -> sp.Expr:
    """``value`` as a SymPy term of one atom (emitted) or a number."""
    value = P.emit(value)
    c = value.constant()
    if c is not None:
        return sp.Float(c)
    (mono, coef), = value.terms.items()
    return sp.Float(coef) * sp.Symbol(mono[0], real=True) if coef != 1.0 else sp.Symbol(
        mono[0], real=True)


def _heights(T, normal: list[float]) -> list[tuple[list, Ex]]:
    """Per body: (n in its axes, n . p_i its origin's height along n)."""
    from .recursive.spatial import const_vec, dot, emitv, matvec
    P, out = T.P, []
    for i, b in enumerate(T.plan.bodies):
        E, r = T.frames()[i]
        n_p, s_p = (const_vec(normal), Ex()) if b.parent is None else out[b.parent]
        out.append((emitv(P, matvec(E, n_p)), P.emit(s_p + dot(n_p, r))))
    return out


def _law(P: Program, c: ContactPlan, depth: Ex, rate: Ex, slip: list) -> dict:
    """The compliant law at penetration ``depth``, its rate ``rate`` and the sliding
    velocity ``slip`` (any axes): ``fn``, the friction ``ft`` (slip's axes), the spring's
    ``energy`` and the ``dissipated`` power."""
    from .recursive.spatial import dot, emitv, scale
    if c.rigid:                                    # the forces are numeric.impacts'
        return {"fn": Ex(), "ft": [Ex(), Ex(), Ex()], "depth": depth, "dissipated": Ex(),
                "energy": Ex()}
    d, dd = _symbol(P, depth), _symbol(P, rate)
    k, p = c.stiffness, sp.Float(c.exponent)
    pressed = sp.Max(0, d) ** p
    law = k + c.damping * dd if c.damping else sp.Float(k)
    fn = P.sympy(pressed * sp.Max(0, law) if c.damping else pressed * law)
    dissipated = P.sympy((_symbol(P, fn) - k * pressed) * dd) if c.damping else Ex()
    ft = [Ex(), Ex(), Ex()]
    if c.friction:
        speed = P.call("sqrt", P.emit(dot(slip, slip) + (SLIP_FLOOR * c.friction_velocity)
                                      ** 2))
        ratio = P.emit(P.call("tanh", speed * (1.0 / c.friction_velocity)) *
                       P.call("recip", speed) * fn * c.friction)
        ft = emitv(P, scale(slip, -ratio))
        dissipated = dissipated + ratio * dot(slip, slip)
    return {"fn": fn, "ft": ft, "depth": depth, "dissipated": P.emit(dissipated),
            "energy": P.sympy(k * sp.Max(0, d) ** (p + 1) / (p + 1))}


def _ground(T, c: ContactPlan, heights: list) -> dict:
    """A sphere on body ``c.body`` against its ground plane, in the body's axes."""
    from .recursive.spatial import add, const_vec, cross, dot, emitv, scale, sub
    P = T.P
    n, s = heights[c.body]
    centre = const_vec(c.centre)
    depth = P.emit(s * -1.0 - dot(n, centre) + (c.radius + c.height))
    point = emitv(P, sub(centre, scale(n, c.radius)))
    w, vo = T.velocities()[c.body]
    v = emitv(P, add(vo, cross(w, point)))
    rate = P.emit(-dot(n, v))                      # d'
    out = _law(P, c, depth, rate, emitv(P, add(v, scale(n, rate))))
    force = emitv(P, add(scale(n, out["fn"]), out["ft"]))
    t1, t2 = (T.to_body(const_vec(t), c.body) for t in c.tangents)
    out.update(wrenches=[] if c.rigid else [(c.body, force, emitv(P, cross(point, force)))],
               ft1=P.emit(dot(out["ft"], t1)), ft2=P.emit(dot(out["ft"], t2)),
               vn=P.emit(rate * -1.0), vt1=P.emit(dot(v, t1)), vt2=P.emit(dot(v, t2)))
    return out


def _world(T) -> list:
    """Per body (R_i body axes -> world, p_i its origin, V_i, W_i its origin's velocity
    and its angular velocity in world axes): R_i = R_p E_i^T, p_i = p_p + R_p r_i."""
    from .recursive.spatial import add, emitv, matvec
    P, out = T.P, []
    for i, b in enumerate(T.plan.bodies):
        E, r = T.frames()[i]
        if b.parent is None:
            R, p = [[E[j][k] for j in range(3)] for k in range(3)], r
        else:
            Rp, pp = out[b.parent][:2]
            R = [[P.emit(sum((Rp[k][m] * E[j][m] for m in range(3)), Ex())) for j in range(3)]
                 for k in range(3)]
            p = emitv(P, add(pp, matvec(Rp, r)))
        w, vo = T.velocities()[i]
        out.append((R, p, emitv(P, matvec(R, vo)), emitv(P, matvec(R, w))))
    return out


def _pair(T, c: ContactPlan, world: list) -> dict:
    """Sphere (body 1, ``c.body``) against sphere (body 2, ``c.partner``) in world axes:
    n = (c1 - c2) / |c1 - c2|, d = rho1 + rho2 - |c1 - c2|, the force at the middle of the
    overlap, c1 - (rho1 - d/2) n, on body 1 and its reaction on body 2."""
    from .recursive.spatial import add, const_vec, cross, dot, emitv, matTvec, matvec, scale, sub
    P = T.P
    ends = []
    for body, centre in ((c.body, c.centre), (c.partner, c.partner_centre)):
        R, p, V, W = world[body]
        ends.append((R, p, V, W, emitv(P, add(p, matvec(R, const_vec(centre))))))
    if c.spans:
        ends[0] = (*ends[0][:4], _nearest(P, c, ends[0][0], ends[0][4], ends[1][4]))
    apart = emitv(P, sub(ends[0][4], ends[1][4]))
    distance = P.call("sqrt", P.emit(dot(apart, apart) + 1e-24))
    n = emitv(P, scale(apart, P.call("recip", distance)))
    depth = P.emit(distance * -1.0 + (c.radius + c.partner_radius))
    point = emitv(P, sub(ends[0][4], scale(n, P.emit(depth * -0.5 + c.radius))))
    arms = [emitv(P, sub(point, end[1])) for end in ends]
    v = emitv(P, sub(add(ends[0][2], cross(ends[0][3], arms[0])),
                     add(ends[1][2], cross(ends[1][3], arms[1]))))
    rate = P.emit(-dot(n, v))
    out = _law(P, c, depth, rate, emitv(P, add(v, scale(n, rate))))
    force = emitv(P, add(scale(n, out["fn"]), out["ft"]))
    wrenches = []
    for (R, _, _, _, _), arm, body, sign in zip(ends, arms, (c.body, c.partner), (1.0, -1.0)):
        F = emitv(P, scale(matTvec(R, force), sign))
        wrenches.append((body, F, emitv(P, cross(emitv(P, matTvec(R, arm)), F))))
    out.update(wrenches=[] if c.rigid else wrenches,
               ft1=P.call("sqrt", P.emit(dot(out["ft"], out["ft"]))), ft2=Ex(),
               vn=P.emit(rate * -1.0), vt1=Ex(), vt2=Ex())    # a pair: no tangents
    return out


def _nearest(P, c: ContactPlan, R, centre: list, target: list) -> list:
    """The point centre + sum s_k R e_k (|s_k| <= 1, e_k ``c.spans``) nearest ``target``,
    world axes."""
    from .recursive.spatial import add, const_vec, dot, emitv, matvec, scale, sub
    offset, point = emitv(P, sub(target, centre)), centre
    for span in c.spans:
        e = emitv(P, matvec(R, const_vec(span)))
        share = _symbol(P, P.emit(dot(e, offset) * (1.0 / sum(x * x for x in span))))
        point = add(point, scale(e, P.sympy(sp.Min(1, sp.Max(-1, share)))))
    return emitv(P, point)


def traced(T) -> list[dict]:
    """Per contact of ``T.plan``: its ``wrenches`` (body, force, moment about the body's
    origin, body axes: one per body it touches) and the reported quantities ``fn``,
    ``ft1``, ``ft2``, ``depth``, ``energy``, ``dissipated``, ``vn``, ``vt1``, ``vt2``
    (module docstring)."""
    if not T.plan.contacts:                        # nothing traced: other robots' code
        return []                                  # stays as it was
    heights: dict[tuple, list] = {}
    world = _world(T) if any(c.partner is not None for c in T.plan.contacts) else None
    out = []
    for c in T.plan.contacts:
        if c.partner is not None:
            out.append(_pair(T, c, world))
            continue
        key = tuple(c.normal)
        if key not in heights:
            heights[key] = _heights(T, c.normal)
        out.append(_ground(T, c, heights[key]))
    return out
