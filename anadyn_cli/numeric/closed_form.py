"""EquationsOfMotion + control laws -> source of the numeric functions.

Generated (see ``codegen``), for n coordinates and m actuators:

    accelerations(t, q, dq)          -> ddq solving M ddq = G, G = F + B tau(t, q, dq)
                                        (unrolled Cholesky; scalar)
    dynamics_jacobian(t, q, dq, ddq) -> M, K = [dG/dq - (dM/dq) ddq | dG/ddq] (scalar)
    efforts(t, q, dq)                -> tau under the control laws      (vectorized)
    mfb(t, q, dq)                    -> M, F, B (F of t through loads)   (vectorized)
    potential(q)                     -> V, gravity's and the springs'    (vectorized)
    powers(t, q, dq)                 -> [power of the loads, power dissipated by joint
                                        damping and friction]; only for a robot that
                                        has them                         (vectorized)

K gives the Jacobian of the state derivative without a symbolic inverse:
d(ddq)/dx = M^-1 K, since differentiating M ddq = G gives
M d(ddq) = dG - (dM) ddq.

With a spherical joint the state is x = [q, u] (nq coordinates, the quaternion's
included, and n speeds; ``EquationsOfMotion.kinematic``): dq above reads u, ddq
reads du, K is n x (nq + n), and the module adds

    rates(t, q, u)                   -> dq = W(q) u, the kinematic differential
                                        equations                       (vectorized)

``dynamics_jacobian`` returns R = d(W(q) u)/dx (nq x (nq + n)) after M and K, and
SPEEDS and QUATERNIONS name the speeds and each quaternion's coordinate indices
(as the recursive path's module does).

The powers feed ``check``'s energy balance, so they are computed from the
kinematics, not from F: the loads' power as f . d(r_p)/dt + T . w with r_p
the point's world position differentiated along the motion, the dissipated
power as c dtheta^2 + f dtheta tanh(dtheta / v) per joint.
"""
from __future__ import annotations

import sympy as sp

from .. import __version__
from ..symbolic import forces, kinematics
from .codegen import Function, module_source, solver_source
from ..symbolic.derivative import Derivative
from ..symbolic.eom import EquationsOfMotion
from ..model.robot import Robot


def control_laws(robot: Robot, symbolic: bool = False) -> sp.Matrix:
    """tau_c(t, q, dq), one row per actuator; zeros without a controller.  The
    parameters and gains are substituted (as numbers, or as the free symbols of a
    bindable copy), or stay symbols when ``symbolic`` (the export's choice)."""
    m = len(robot.actuators)
    if robot.controller is None:
        return sp.zeros(m, 1)
    values = robot.parameter_substitution(symbolic)
    if not symbolic:
        numeric = robot.parameter_substitution()
        values.update({sp.Symbol(k, real=True): v.xreplace(numeric)
                       for k, v in robot.controller.gains.items()})
    return sp.Matrix([robot.controller.laws[a.name].xreplace(values) for a in robot.actuators])


def powers(robot: Robot, kin: kinematics.Kinematics) -> list[sp.Expr] | None:
    """[P_loads, P_dissipated] from the kinematics (None: no loads, no joint forces)."""
    joints, loads = forces.joint_forces(robot, kin), forces.loads(robot, kin)
    if not joints and not loads:
        return None
    rate_of = Derivative(dict(zip(kin.q, kin.dq if kin.kinematic is None else kin.kinematic)))
    dq = sp.Matrix(kin.dq)
    loads_power = []
    for load in loads:
        b = kin.bodies[load.body]
        R = sp.Matrix(b.R)
        velocity = sp.Matrix(b.position + R * (load.point - b.com)).applyfunc(rate_of)
        force = load.force if load.frame == "world" else R * load.force
        torque = R.T * load.torque if load.frame == "world" else load.torque
        loads_power.append(sp.Matrix(force).dot(velocity) + sp.Matrix(torque).dot(b.W * dq))
    dissipated = []
    for joint in joints:
        rate = rate_of(kin.bodies[joint.body].displacement)
        dissipated.append(joint.damping * rate ** 2 + joint.friction * rate
                          * sp.tanh(rate / joint.friction_velocity))
    return [sp.Add(*loads_power), sp.Add(*dissipated)]


def forces_source(robot: Robot) -> str:
    """``powers(t, q, dq)`` (vectorized) for generated code that lacks it (the recursive
    path), from the kinematics: an independent check of that code's F in ``check``'s
    energy balance.  "" for a robot without loads or joint forces."""
    if not robot.loads and not any(b.joint.joint_type.moving and (
            b.joint.damping != 0 or b.joint.friction != 0 or b.joint.stiffness != 0)
            for b in robot.bodies):
        return ""                   # (without building the kinematics)
    kin = kinematics.build(robot)
    power = powers(robot, kin)
    if power is None:
        return ""
    t = sp.Symbol("t", real=True)
    function = Function("powers", (t, *kin.q, *kin.dq), (("P", power),), True,
                        "[power of the loads, power dissipated by joint damping and friction], "
                        "W.")
    return "\n" + module_source([function], "loads' power and dissipated power "
                                             "(anadyn closed_form.forces_source)")


def state_partials(M: sp.Matrix, G: sp.Matrix, q: list, dq: list, ddq: list) -> sp.Matrix:
    """K = [dG/dq - (dM/dq) ddq | dG/d(dq)] (n x (nq + n)), so that d(ddq)/dx = M^-1 K
    for M ddq = G(t, q, dq) (differentiating it: M d(ddq) = dG - (dM) ddq); dq the
    speeds, nq = n unless a spherical joint adds its quaternion."""
    n, nq = len(dq), len(q)
    K = sp.zeros(n, nq + n)
    for k, variable in enumerate(q + dq):
        d = Derivative({variable: 1})
        column = sp.Matrix([d(g) for g in G])
        if k < nq:
            column -= M.applyfunc(d) * sp.Matrix(ddq)
        K[:, k] = column
    return K


def quaternions(robot: Robot) -> tuple:
    """The coordinate indices of each spherical joint's quaternion (qw, qx, qy, qz)."""
    names = [c.name for c in robot.coordinates]
    return tuple(tuple(names.index(c) for c in b.joint.coordinates) for b in robot.bodies
                 if b.joint.joint_type.orientation)


def source(robot: Robot, eom: EquationsOfMotion, jacobian: bool = True) -> str:
    """Python source of the numeric functions for ``robot``'s equations (without
    ``dynamics_jacobian`` unless ``jacobian``: its cse is most of the work)."""
    t = sp.Symbol("t", real=True)
    q, dq, ddq = list(eom.q), list(eom.dq), list(eom.ddq)
    tau = control_laws(robot)
    G = sp.Matrix(eom.F + eom.B * tau)
    M = sp.Matrix(eom.M)
    kin = kinematics.build(robot, symbolic=eom.symbolic)
    springs = forces.spring_energy(robot, kin)
    potential = kinematics.potential_energy(kin) + springs
    state = (t, *q, *dq)
    functions = [
        Function("efforts", state, (("tau", list(tau)),), True,
                 "Actuator efforts under the control laws."),
        Function("mfb", state, (("M", M), ("F", list(eom.F)), ("B", eom.B)), True,
                 "M, F and B of M ddq = F + B tau."),
        Function("potential", tuple(q), (("V", [potential]),), True,
                 "Potential energy of gravity, V = -sum m g . r." if springs == 0 else
                 "Potential energy of gravity and the joint springs, "
                 "V = -sum m g . r + sum k/2 (theta - rest)^2."),
    ]
    if jacobian:
        K = state_partials(M, G, q, dq, ddq)
        outputs = (("M", M), ("K", K))
        doc = "M and K = [dG/dq - (dM/dq) ddq | dG/d(dq)]; d(ddq)/dx = M^-1 K."
        if eom.kinematic is not None:
            outputs += (("R", sp.Matrix(eom.kinematic).jacobian(q + dq)),)
            doc += " R = d(W(q) u)/dx, the coordinates' rows."
        functions.insert(0, Function("dynamics_jacobian", (*state, *ddq), outputs, False, doc))
    if eom.kinematic is not None:
        functions.append(Function("rates", state, (("dq", list(eom.kinematic)),), True,
                                  "The coordinates' rates dq = W(q) u (a spherical joint's "
                                  "quaternion: 1/2 q (x) (0, w))."))
    power = powers(robot, kin)
    if power is not None:
        functions.append(Function("powers", state, (("P", power),), True,
                                  "[power of the loads, power dissipated by joint damping and "
                                  "friction], W."))
    solver = solver_source("accelerations", state, M, list(G),
                           "ddq solving M(q) ddq = G = F + B tau under the control laws.")
    header = (f"generated by anadyn {__version__} from {robot.source} ({eom.formulation})\n"
              f"robot {robot.name}: coordinates {', '.join(map(str, q))}; "
              f"efforts {', '.join(map(str, eom.efforts)) or 'none'}")
    names = (f"COORDINATES = {tuple(str(s) for s in q)!r}\n"
             f"EFFORTS = {tuple(str(s) for s in eom.efforts)!r}\n")
    if eom.kinematic is not None:          # speeds that are not rates: x = [q, u]
        names += (f"SPEEDS = {tuple(str(s) for s in dq)!r}\n"
                  f"QUATERNIONS = {quaternions(robot)!r}\n")
    return module_source(functions, header) + "\n".join(solver) + "\n\n" + names
