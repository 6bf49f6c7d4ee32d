"""The generated functions of one robot, each traced into one Program and pruned
to what its outputs need: the forward dynamics (CRBA + sparse Cholesky, or the
articulated-body algorithm, whichever costs fewer operations), the Jacobian
K = -dID/d[q, dq] at fixed ddq (forward-mode differentiation of the traced
residual, so that d(ddq)/dx = M^-1 K), the driven accelerations, M F B, the
efforts, the inverse dynamics, the actuation matrix and the potential.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...model.robot import Robot
from .. import contact
from ..ir import ZERO, Counts, Ex, Program, count, prune
from . import aba
from .crba import mass_matrix
from .factor import Factor, cholesky, solve
from .plan import Plan, plan
from .potential import potential
from .momentum import momentum
from .power import powers
from .rnea import inverse_dynamics
from .tracer import Tracer


@dataclass
class Traced:
    """One generated function: its inputs, statements and outputs."""
    name: str
    args: list[str]
    statements: list
    outputs: dict[str, list]              # name -> list of Ex (vector) or list of lists (matrix)
    counts: Counts


def _flat(outputs: dict) -> list[Ex]:
    flat = []
    for value in outputs.values():
        for x in value:
            flat.extend(x if isinstance(x, list) else [x])
    return flat


def _finish(name, args, P, outputs) -> Traced:
    statements = prune(P.statements, _flat(outputs))
    return Traced(name, args, statements, outputs, count(statements, _flat(outputs)))


def state_args(pl: Plan) -> list[str]:
    """t, the coordinates (nq), the speeds (n)."""
    return ["_t"] + [f"_q{k}" for k in range(pl.nq)] + [f"_u{k}" for k in range(pl.n)]


def trace_accelerations(pl: Plan, with_factor: bool = False):
    """ddq solving M ddq = -ID(t, q, dq, 0) (actuators under their laws)."""
    P = Program()
    with P:
        T = Tracer(pl, P)
        M = mass_matrix(T)
        G = [P.emit(-x) for x in inverse_dynamics(T, None, actuators=True)]
        fac = cholesky(P, M)
        ddq = solve(P, fac, G)
    outputs = {"ddq": ddq}
    if with_factor:
        outputs["inv"] = fac.inv
        outputs["L"] = [fac.L[key] for key in sorted(fac.L)]
    traced = _finish("accelerations", state_args(pl), P, outputs)
    return (traced, fac) if with_factor else traced


def trace_driven(pl: Plan) -> Traced:
    """ddq solving M ddq = F + B e for given actuator efforts e (atoms _e0, ...):
    the direct dynamics that ``inverse``'s round trip drives with its efforts
    (CRBA + sparse Cholesky)."""
    m = len(pl.actuator_joint)
    P = Program()
    with P:
        T = Tracer(pl, P)
        T.given_efforts = [Ex.atom(f"_e{k}") for k in range(m)]
        M = mass_matrix(T)
        G = [P.emit(-x) for x in inverse_dynamics(T, None, actuators=True)]
        ddq = solve(P, cholesky(P, M), G)
    return _finish("driven_accelerations", state_args(pl) + [f"_e{k}" for k in range(m)],
                   P, {"ddq": ddq})


def trace_aba(pl: Plan) -> Traced | None:
    """ddq by the articulated-body algorithm (None: J not constant and invertible)."""
    P = Program()
    with P:
        ddq = aba.accelerations(Tracer(pl, P))
    if ddq is None:
        return None
    return _finish("accelerations", state_args(pl), P, {"ddq": ddq})


def trace_jacobian(pl: Plan, with_M: bool = True) -> Traced:
    """M and K = -dID/d[q, u] at fixed du (actuators included), forward mode
    (``with_M`` False: K alone, for native code that reuses the factor of M); with a
    spherical joint also R = d(W(q) u)/d[q, u], the coordinates' rows of the state
    Jacobian (without, they are [0, 1])."""
    n, nq = pl.n, pl.nq
    P = Program()
    with P:
        T = Tracer(pl, P)
        M = mass_matrix(T) if with_M else None
        ddq = [Ex.atom(f"_w{k}") for k in range(n)]
        res = inverse_dynamics(T, ddq, actuators=True)
        rates = _rates(pl, P) if pl.spherical else []
        seeds = {f"_q{k}": k for k in range(nq)}
        seeds.update({f"_u{k}": nq + k for k in range(n)})
        D = P.derivatives(seeds)
        K = []
        for r in range(n):
            d = P.derivative_of(res[r], D)
            K.append([P.emit(-d[k]) if k in d else ZERO for k in range(nq + n)])
        R = []
        for value in rates:
            d = P.derivative_of(value, D)
            R.append([P.emit(d[k]) if k in d else ZERO for k in range(nq + n)])
    outputs = {"M": M, "K": K} if with_M else {"K": K}
    return _finish("dynamics_jacobian", state_args(pl) + [f"_w{k}" for k in range(n)], P,
                   {**outputs, "R": R} if R else outputs)


def trace_mfb(pl: Plan) -> Traced:
    n = pl.n
    P = Program()
    with P:
        T = Tracer(pl, P)
        M = mass_matrix(T)
        F = [P.emit(-x) for x in inverse_dynamics(T, None, actuators=False)]
        _, rows, _ = T.joint_maps()
        B = [[rows[j][r] * s for j, s in zip(pl.actuator_joint, pl.actuator_scale)]
             for r in range(n)]
    return _finish("mfb", state_args(pl), P, {"M": M, "F": F, "B": B})


def trace_inverse(pl: Plan) -> Traced:
    n = pl.n
    P = Program()
    with P:
        T = Tracer(pl, P)
        res = inverse_dynamics(T, [Ex.atom(f"_w{k}") for k in range(n)], actuators=False)
    return _finish("inverse_dynamics", state_args(pl) + [f"_w{k}" for k in range(n)], P,
                   {"ID": res})


def trace_actuation(pl: Plan) -> Traced:
    """B(t, q) (n x m): column k is d(theta_j)/dq for actuator k's joint j, so that
    the generalized forces of the efforts are B tau (with ``inverse_dynamics``:
    B tau = M ddq - F, the RNEA's O(n) inverse dynamics)."""
    n = pl.n
    P = Program()
    with P:
        _, rows, _ = Tracer(pl, P).joint_maps()
        B = [[rows[j][r] * s for j, s in zip(pl.actuator_joint, pl.actuator_scale)]
             for r in range(n)]
    return _finish("actuation", state_args(pl), P, {"B": B})


def _rates(pl: Plan, P: Program) -> list[Ex]:
    """dq = W(q) u: the speeds for the coordinates whose rates they are (the first
    ones), each spherical joint's kinematic differential equations for its
    quaternion (``joints.Spherical.coordinate_rates``)."""
    q = [Ex.atom(f"_q{k}") for k in range(pl.nq)]
    u = [Ex.atom(f"_u{k}") for k in range(pl.n)]
    rates = list(u[:pl.nq - 4 * sum(1 for b in pl.bodies if b.quaternion)])
    for b in pl.bodies:
        if b.quaternion:
            rates += [P.emit(x) for x in b.joint_type.coordinate_rates(
                [q[k] for k in b.quaternion], u[b.speed:b.speed + 3])]
    return rates


def trace_rates(pl: Plan) -> Traced:
    """dq = W(q) u (``_rates``)."""
    P = Program()
    with P:
        rates = _rates(pl, P)
    return _finish("rates", state_args(pl), P, {"dq": rates})


def _spherical(pl: Plan) -> dict[str, Traced]:
    """What a robot with a spherical joint adds: its coordinates' rates, its momentum
    when it is free (``Plan.free``) and, with loads or joint damping or friction, their
    powers (for ``check``; the other robots take them from the kinematics' closed
    forms, ``closed_form.forces_source``)."""
    functions = {"rates": trace_rates(pl)}
    if pl.free:
        P = Program()
        with P:
            world = momentum(Tracer(pl, P))
        functions["momentum"] = _finish("momentum", state_args(pl), P, {"H": world})
    if pl.loads or any(b.damping or b.friction for b in pl.bodies):
        P = Program()
        with P:
            power = powers(Tracer(pl, P))
        functions["powers"] = _finish("powers", state_args(pl), P, {"P": power})
    return functions


def trace_contacts(pl: Plan) -> Traced:
    """Per contact (``numeric.contact``): its normal force, the friction along the
    ground's tangents, the penetration, the spring energy, the dissipated power and
    the contact point's velocity along n, t1, t2."""
    P = Program()
    with P:
        rows = [[c[key] for key in ("fn", "ft1", "ft2", "depth", "energy", "dissipated",
                                    "vn", "vt1", "vt2")]
                for c in contact.traced(Tracer(pl, P))]
    return _finish("contacts", state_args(pl), P, {"C": rows})


def trace_efforts(pl: Plan) -> Traced:
    P = Program()
    with P:
        tau = Tracer(pl, P).efforts()
    return _finish("efforts", state_args(pl), P, {"tau": tau})


def trace_potential(pl: Plan) -> Traced:
    P = Program()
    with P:
        V = potential(Tracer(pl, P))
    return _finish("potential", [f"_q{k}" for k in range(pl.nq)], P, {"V": [V]})


@dataclass
class Generated:
    """The functions of one robot, traced."""
    plan: Plan
    functions: dict[str, Traced]
    factor: Factor

    def counts(self, name: str) -> Counts:
        return self.functions[name].counts


def forward(pl: Plan) -> Generated:
    """The forward dynamics alone (``accelerations`` and ``factor``): all a quick
    native build needs (``native.c_source`` of it has no Jacobian).  The
    accelerations come from the cheaper (in operations) of CRBA + sparse
    Cholesky and the articulated-body algorithm; the Jacobian always uses the
    Cholesky factor (``factor``)."""
    factor, fac = trace_accelerations(pl, with_factor=True)
    factor.name = "factor"
    acc = Traced("accelerations", factor.args, factor.statements, {"ddq": factor.outputs["ddq"]},
                 factor.counts)
    aba = trace_aba(pl)
    if aba is not None and aba.counts.total < acc.counts.total:
        acc = aba
    return Generated(pl, {"accelerations": acc, "factor": factor}, fac)


def complete(gen: Generated) -> Generated:
    """``gen`` (from ``forward``) with the Jacobian, the driven accelerations, M F B,
    the efforts, the inverse dynamics, the actuation matrix, the potential and, with a
    spherical joint, the coordinates' rates dq = W(q) u and the powers (``_spherical``)."""
    pl = gen.plan
    functions = {**gen.functions, "dynamics_jacobian": trace_jacobian(pl),
                 "driven_accelerations": trace_driven(pl), "mfb": trace_mfb(pl),
                 "efforts": trace_efforts(pl),
                 "inverse_dynamics": trace_inverse(pl), "actuation": trace_actuation(pl),
                 "potential": trace_potential(pl),
                 **(_spherical(pl) if pl.spherical else {}),
                 **({"contacts": trace_contacts(pl)} if pl.contacts else {})}
    return Generated(pl, functions, gen.factor)


def generate(robot: Robot) -> Generated:
    """Every function of ``robot`` (``forward``, then ``complete``)."""
    return complete(forward(plan(robot)))
