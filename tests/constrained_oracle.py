"""Independent models of constrained systems, by ``sympy.physics.mechanics``
(KanesMethod with configuration and velocity constraints), built by hand
from the physics, not from anadyn's files or code.

* ``fourbar``: crank O2-A (length a, angle q1), coupler A-P (b, q2), rocker
  O4-P (c, q3), ground O2-O4 = d along x; absolute angles from x; uniform
  bars (mass centre mid-length, central moment m L^2 / 12 about z); gravity
  -g y; a torque T on the crank (reaction on the ground).  Configuration
  constraints: the coupler's end P and the rocker's end coincide in x and y;
  q1, u1 independent, q2, q3, u2, u3 dependent.
* ``knife_edge``: a blade of mass m, moment I about the vertical, its mass
  centre at the contact point (x, y), heading theta; two carriages of mass mc
  (one moving with x, one with x and y), as anadyn's tree needs them; gravity
  g' along +x in the plane; efforts Fx on the first carriage along x, Fy on
  the second along y (reaction on the first) and Tz on the blade about the
  vertical.  Velocity constraint: no sideways velocity of the
  contact point, -sin(theta) x' + cos(theta) y' = 0; u_x, u_theta
  independent, u_y dependent (so the oracle is used where cos(theta) != 0).

``accelerations(q, u, T)`` gives du/dt for all speeds (u = dq/dt, in the
order the model lists them), solving KanesMethod's mass matrix (dynamic
equations plus the differentiated velocity constraints) against its forcing.
"""
from __future__ import annotations

import numpy as np
import sympy as sp
from sympy.physics import mechanics as me


class Oracle:
    def __init__(self, kane, q, u, extra):
        mass, forcing = kane.mass_matrix, kane.forcing
        self.q, self.u = q, u
        order = list(kane.u)                      # independent speeds first, then dependent
        self.order = [order.index(s) for s in u]
        args = [*q, *u, *extra]
        self._mass = sp.lambdify(args, mass, "numpy")
        self._forcing = sp.lambdify(args, forcing, "numpy")

    def accelerations(self, q, u, *extra) -> np.ndarray:
        args = [*q, *u, *extra]
        solved = np.linalg.solve(np.asarray(self._mass(*args), dtype=float),
                                 np.asarray(self._forcing(*args), dtype=float).reshape(-1))
        return solved[self.order]


def fourbar(a, b, c, d, m1, m2, m3, g) -> Oracle:
    q1, q2, q3 = me.dynamicsymbols("q1:4")
    u1, u2, u3 = me.dynamicsymbols("u1:4")
    T = sp.Symbol("T")
    N = me.ReferenceFrame("N")
    crank = N.orientnew("crank", "Axis", [q1, N.z])
    coupler = N.orientnew("coupler", "Axis", [q2, N.z])
    rocker = N.orientnew("rocker", "Axis", [q3, N.z])
    crank.set_ang_vel(N, u1 * N.z)
    coupler.set_ang_vel(N, u2 * N.z)
    rocker.set_ang_vel(N, u3 * N.z)
    O2 = me.Point("O2")
    O2.set_vel(N, 0)
    O4 = O2.locatenew("O4", d * N.x)
    O4.set_vel(N, 0)
    A = O2.locatenew("A", a * crank.x)
    A.v2pt_theory(O2, N, crank)
    P = A.locatenew("P", b * coupler.x)
    P.v2pt_theory(A, N, coupler)
    R = O4.locatenew("R", c * rocker.x)
    R.v2pt_theory(O4, N, rocker)
    G1 = O2.locatenew("G1", a / 2 * crank.x)
    G1.v2pt_theory(O2, N, crank)
    G2 = A.locatenew("G2", b / 2 * coupler.x)
    G2.v2pt_theory(A, N, coupler)
    G3 = O4.locatenew("G3", c / 2 * rocker.x)
    G3.v2pt_theory(O4, N, rocker)
    bodies = [me.RigidBody("crank", G1, crank, m1, (me.inertia(crank, 0, 0, m1 * a**2 / 12), G1)),
              me.RigidBody("coupler", G2, coupler, m2,
                           (me.inertia(coupler, 0, 0, m2 * b**2 / 12), G2)),
              me.RigidBody("rocker", G3, rocker, m3,
                           (me.inertia(rocker, 0, 0, m3 * c**2 / 12), G3))]
    loads = [(G1, -m1 * g * N.y), (G2, -m2 * g * N.y), (G3, -m3 * g * N.y), (crank, T * N.z)]
    gap = P.pos_from(O2) - R.pos_from(O2)
    configuration = [gap.dot(N.x), gap.dot(N.y)]
    slip = P.vel(N) - R.vel(N)
    velocity = [slip.dot(N.x), slip.dot(N.y)]
    kane = me.KanesMethod(N, q_ind=[q1], u_ind=[u1], kd_eqs=[q1.diff() - u1, q2.diff() - u2,
                                                           q3.diff() - u3],
                          q_dependent=[q2, q3], configuration_constraints=configuration,
                          u_dependent=[u2, u3], velocity_constraints=velocity)
    kane.kanes_equations(bodies, loads)
    return Oracle(kane, [q1, q2, q3], [u1, u2, u3], [T])


def knife_edge(m, I, mc, g_plane) -> Oracle:
    x, y, theta = me.dynamicsymbols("x y theta")
    ux, uy, ut = me.dynamicsymbols("ux uy ut")
    N = me.ReferenceFrame("N")
    blade = N.orientnew("blade", "Axis", [theta, N.z])
    blade.set_ang_vel(N, ut * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x + y * N.y)
    C.set_vel(N, ux * N.x + uy * N.y)
    Cx = O.locatenew("Cx", x * N.x)
    Cx.set_vel(N, ux * N.x)
    Fx, Fy, Tz = sp.symbols("Fx Fy Tz")
    bodies = [me.RigidBody("blade", C, blade, m, (me.inertia(blade, I / 2, I / 2, I), C)),
              me.Particle("carriage_x", Cx, mc), me.Particle("carriage_y", C, mc)]
    loads = [(C, (m + mc) * g_plane * N.x), (Cx, mc * g_plane * N.x),
             (Cx, Fx * N.x), (C, Fy * N.y), (Cx, -Fy * N.y), (blade, Tz * N.z)]
    sideways = C.vel(N).dot(blade.y)
    kane = me.KanesMethod(N, q_ind=[x, y, theta], u_ind=[ux, ut],
                          kd_eqs=[x.diff() - ux, y.diff() - uy, theta.diff() - ut],
                          u_dependent=[uy], velocity_constraints=[sideways])
    kane.kanes_equations(bodies, loads)
    return Oracle(kane, [x, y, theta], [ux, uy, ut], [Fx, Fy, Tz])
