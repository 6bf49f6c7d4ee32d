"""What the chapter shows besides the equations: the energies, and Kane's terms.

Energies of each body i, from the shared kinematics (mass centre r_i and
velocity v_i, angular velocity w_i, central inertia I_i in body axes):

    T_i = 1/2 m_i v_i . v_i + 1/2 w_i . (I_i w_i)        V_i = -m_i g . r_i

(V = 0 at the world origin), plus the springs' k/2 (theta - rest)^2 of the
joints that have one; T = sum T_i, V = sum V_i + V_springs.

Kane's equations, in the chapter's words Q_r + K_in,r = 0 (Kane's own
Fr + Fr* = 0), r = 1..n, with u_r = dq_r:

    Q_r    = sum_i (dv_i/du_r) . m_i g  +  sum_k B_rk tau_k  +  Q_r(joint forces, loads)
    K_in,r = -sum_i [ (dv_i/du_r) . m_i a_i + (dw_i/du_r) . (I_i alpha_i + w_i x I_i w_i) ]

the generalized active forces (gravity on every mass centre, each actuator
on its body with the reaction on its parent) and the generalized inertia
forces.  a_i and alpha_i are found here by differentiating v_i (world axes)
and w_i (body axes) along the motion, q' = dq, dq' = ddq, not by the
acceleration recursion of ``formulations.kane``: Q + K_in = -(M ddq - F - B tau)
is then a check of the formulation, not a restatement of it.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from . import kinematics
from .canonical import canonical, fits
from .derivative import Derivative
from .eom import EquationsOfMotion
from ..model.robot import Robot

Matrix = sp.ImmutableMatrix


@dataclass(frozen=True)
class Energies:
    bodies: tuple[str, ...]
    kinetic: tuple[sp.Expr, ...]        # T_i
    potential: tuple[sp.Expr, ...]      # V_i (gravity)
    springs: sp.Expr                    # the joints' springs (0 without)
    symbolic: bool

    @property
    def T(self) -> sp.Expr:
        return sp.Add(*self.kinetic)

    @property
    def V(self) -> sp.Expr:
        return sp.Add(*self.potential, self.springs)


@dataclass(frozen=True)
class KaneTerms:
    q: tuple[sp.Symbol, ...]
    dq: tuple[sp.Symbol, ...]
    ddq: tuple[sp.Symbol, ...]
    efforts: tuple[sp.Symbol, ...]
    active: tuple[sp.Expr, ...]         # Q_r (Fr)
    inertia: tuple[sp.Expr, ...]        # K_in,r (Fr*)
    symbolic: bool


def _tidy(exprs: list[sp.Expr]) -> list[sp.Expr]:
    """Canonical form (identically zero terms vanish) when small enough."""
    return [canonical(e) for e in exprs] if fits(exprs) else exprs


def energies(robot: Robot, symbolic: bool = False) -> Energies:
    """T_i and V_i of every body, and the springs' energy."""
    kin = kinematics.build(robot, symbolic=symbolic)
    kinetic, potential = [], []
    for i, b in enumerate(kin.bodies):
        v, w = kin.velocity(i), kin.angular_velocity(i)
        kinetic.append(b.mass * v.dot(v) / 2 + (w.T * b.inertia * w)[0] / 2)
        potential.append(-b.mass * kin.gravity.dot(b.position))
    springs = sp.Integer(0)
    try:
        from . import forces
        springs = sp.Add(*[j.energy(kin.bodies[j.body].displacement)
                           for j in forces.joint_forces(robot, kin)])
    except (ImportError, AttributeError):      # a robot model without joint forces
        pass
    tidy = _tidy(kinetic + potential + [springs])
    b = len(kin.bodies)
    return Energies(tuple(x.body.name for x in kin.bodies), tuple(tidy[:b]),
                    tuple(tidy[b:2 * b]), tidy[-1], symbolic)


def kane_terms(robot: Robot, eom: EquationsOfMotion) -> KaneTerms:
    """Q_r and K_in,r for every coordinate (``eom``: the robot's equations by either
    method, with the same ``symbolic`` setting: they give B and the joint forces)."""
    kin = kinematics.build(robot, symbolic=eom.symbolic)
    q, dq, ddq = kin.q, kin.dq, eom.ddq
    n = len(dq)
    rates = dq if kin.kinematic is None else kin.kinematic          # dq = W(q) u
    along = Derivative({**dict(zip(q, rates)), **dict(zip(dq, ddq))})   # d/dt
    tau = Matrix(len(eom.efforts), 1, list(eom.efforts))
    active = sp.Matrix(eom.B * tau + eom.joint_forces_and_loads)
    inertia = sp.zeros(n, 1)
    dq_vec = Matrix(dq)
    for b in kin.bodies:
        gravity = Matrix(b.R.T * kin.gravity)                  # body axes
        active += b.V.T * (b.mass * gravity)
        velocity = Matrix(b.R * b.V * dq_vec)                   # world axes
        acceleration = Matrix(b.R.T * velocity.applyfunc(along))   # body axes
        w = Matrix(b.W * dq_vec)                                # body axes
        alpha = w.applyfunc(along)           # = the world derivative, as w x w = 0
        moment = b.inertia * alpha + w.cross(b.inertia * w)
        inertia -= b.V.T * (b.mass * acceleration) + b.W.T * moment
    tidy = _tidy(list(active) + list(inertia))
    return KaneTerms(q, dq, tuple(ddq), tuple(eom.efforts), tuple(tidy[:n]), tuple(tidy[n:]),
                     eom.symbolic)


def render_energies(e: Energies, fmt: str, coordinates, printer) -> str:
    """``T_bar1 = ...``, ``V_bar1 = ...`` per body, then T and V."""
    show = printer(fmt, e.symbolic, coordinates)
    latex = fmt == "latex"

    def name(letter: str, body: str) -> str:
        return rf"{letter}_{{\mathrm{{{_latex_name(body)}}}}}" if latex else f"{letter}_{body}"

    lines = ["# energies: T kinetic, V potential of gravity (V = 0 at the world origin)"]
    for body, T, V in zip(e.bodies, e.kinetic, e.potential):
        lines.append(f"{name('T', body)} = {show(_readable(T))}")
        lines.append(f"{name('V', body)} = {show(_readable(V))}")
    if e.springs != 0:
        lines.append(f"{name('V', 'springs')} = {show(_readable(e.springs))}")
    lines.append(f"T = {show(_readable(e.T))}")
    lines.append(f"V = {show(_readable(e.V))}")
    return "\n".join(lines)


def render_kane_terms(k: KaneTerms, fmt: str, printer) -> str:
    """``Q1 = ...`` (generalized active force) and ``Kin1 = ...`` (generalized
    inertia force) per coordinate, as the chapter names them."""
    show = printer(fmt, k.symbolic, k.q)
    latex = fmt == "latex"
    lines = ["# Kane's equations Q_r + Kin_r = 0: Q_r generalized active force (Fr), "
             "Kin_r generalized inertia force (Fr*)"]
    for r, (Q, K) in enumerate(zip(k.active, k.inertia), start=1):
        q_name, k_name = (f"Q_{{{r}}}", rf"K_{{\mathrm{{in}},{r}}}") if latex else (f"Q{r}",
                                                                                 f"Kin{r}")
        lines.append(f"{q_name} = {show(_readable(Q, [*k.efforts]))}")
        lines.append(f"{k_name} = {show(_readable(K, [*k.ddq]))}")
    return "\n".join(lines)


def _readable(expr: sp.Expr, collect=()) -> sp.Expr:
    """Trigonometric terms recombined and collected (small expressions only)."""
    if not fits([expr]):
        return expr
    expr = sp.trigsimp(expr)
    return sp.collect(expr, list(collect)) if collect else expr


def _latex_name(name: str) -> str:
    return name.replace("_", r"\_")
