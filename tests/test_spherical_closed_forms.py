"""Closed forms of robots with a spherical joint (speeds u != dq): Kane's method in the
generalized speeds with dq = W(q) u, Lagrange's equations in the quaternion's rates
with the unit-norm constraint's multiplier projected out (``formulations.lagrange``),
against independent sources:

- each other, the recursive Newton-Euler path and Pinocchio 4.1 (``JointModelSpherical``,
  the robots and state maps of ``test_spherical``: a spherical root with an arm, a
  floating base, a revolute -> spherical -> revolute chain): M and the accelerations
  at 20 random states to 1e-9 relative;
- ``sympy.physics.mechanics.KanesMethod`` with a quaternion-parametrized body (the
  spherical pendulum written by hand): M and the forcing;
- the hanging spherical pendulum's small oscillations, sqrt(3 g / (2 L)) about both
  horizontal axes, from ``linearize`` on the tangent space;
- the torque-free body on the closed-form evaluator: energy and the angular momentum
  in world axes conserved, the quaternion's drift reported;
- ``compare`` and ``equations`` on the command line (``export``: ``test_export_floating``).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from anadyn_cli import load_robot, robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services.simulate import simulate
from anadyn_cli.symbolic.formulations import derive

REPO = Path(__file__).resolve().parent.parent
REL = 1e-9

HANGING = """
name: hanging
parameters: {L: 1.0, m: 1.0, g: 9.81}
gravity: [0, 0, -g]
coordinates:
  qw: {initial: 1}
bodies:
  - name: rod
    joint: {type: spherical, coordinates: [qw, qx, qy, qz], speeds: [wx, wy, wz]}
    mass: m
    com: [0, 0, -L/2]
    inertia: {ixx: m*L**2/12, iyy: m*L**2/12, izz: m*L**2/1200}
"""


def _states(model, count: int, seed: int):
    """x = [q, u] at ``count`` random states: unit quaternions, speeds in +-2."""
    rng = np.random.default_rng(seed)
    x0 = model.initial_state()
    states = []
    for _ in range(count):
        x = x0 + rng.uniform(-1.5, 1.5, x0.size)
        for index in model.quaternions:
            drawn = rng.normal(size=4)
            x[list(index)] = drawn / np.linalg.norm(drawn)
        states.append(x)
    return states


def _rel(a, b) -> float:
    return float(np.abs(np.asarray(a) - b).max() / max(1.0, np.abs(b).max()))


def _agree(robot, formulations=("kane", "lagrange")) -> dict:
    """Largest relative differences of M and the accelerations of the closed forms
    against the recursive path over 20 states; the closed forms' models."""
    recursive = numeric_model(robot)
    models = {f: numeric_model(robot, f, jacobian=False) for f in formulations}
    worst = {f: 0.0 for f in formulations}
    for x in _states(recursive, 20, 5):
        q, u = x[:recursive.nq, None], x[recursive.nq:, None]
        M_ref = recursive.mfb(0.0, q, u)[0][0]
        a_ref = np.array(recursive.accelerations(0.0, x))
        for f, model in models.items():
            M = model.mfb(0.0, q, u)[0][0]
            worst[f] = max(worst[f], _rel(M, M_ref),
                           _rel(model.accelerations(0.0, x), a_ref))
    return worst


ROBOTS = {"spherical_pendulum": REPO / "robots/spherical_pendulum.yaml",
          "tumbling_box": REPO / "robots/tumbling_box.yaml"}


@pytest.mark.parametrize("name", ROBOTS)
def test_kane_and_lagrange_match_the_recursive_path(name):
    worst = _agree(load_robot(ROBOTS[name]))
    assert max(worst.values()) < REL, worst                 # [~1e-15]


@pytest.mark.parametrize("which", ["ROOT", "FLOATING"])
def test_kane_and_lagrange_match_on_a_spherical_root_and_a_floating_base(which):
    """A spherical root with an arm; three slides on massless links, a spherical joint
    and an arm (a floating base as the loader writes one)."""
    import test_spherical

    worst = _agree(robot_from_text(getattr(test_spherical, which), "x.yaml"))
    assert max(worst.values()) < REL, worst


def test_kane_matches_in_the_middle_of_a_chain():
    from test_spherical import CHAIN
    worst = _agree(robot_from_text(CHAIN, "chain.yaml"), ("kane",))
    assert worst["kane"] < REL, worst


@pytest.mark.slow
def test_lagrange_matches_in_the_middle_of_a_chain():
    """About 40 s: the projected Lagrange equations of three bodies are large."""
    from test_spherical import CHAIN
    worst = _agree(robot_from_text(CHAIN, "chain.yaml"), ("lagrange",))
    assert worst["lagrange"] < REL, worst


@pytest.mark.parametrize("which", ["CHAIN", "ROOT", "FLOATING"])
def test_kane_matches_pinocchio(which):
    pin = pytest.importorskip("pinocchio")
    import test_spherical as ts

    robot = robot_from_text(getattr(ts, which), "x.yaml")
    model = ts._pinocchio(robot)
    data = model.createData()
    q_of, v_of = ts._maps(robot, model)
    kane = numeric_model(robot, "kane", jacobian=False)
    rng = np.random.default_rng(11)
    for _ in range(20):
        q, u, _ = ts._random_state(robot, rng)
        M = kane.mfb(0.0, q[:, None], u[:, None])[0][0]
        M_pin = pin.crba(model, data, q[q_of])
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        assert _rel(M[np.ix_(v_of, v_of)], M_pin) < REL
        a = np.array(kane.accelerations(0.0, np.concatenate([q, u])))
        a_pin = pin.aba(model, data, q[q_of], u[v_of], np.zeros(model.nv))
        assert _rel(a[v_of], a_pin) < REL


def test_the_kinematic_differential_equations_come_with_the_equations():
    robot = load_robot(ROBOTS["spherical_pendulum"])
    for formulation in ("kane", "lagrange"):
        eom = derive(robot, formulation)
        assert [s.name for s in eom.dq] == ["wx", "wy", "wz"]
        assert [s.name for s in eom.ddq] == ["dwx", "dwy", "dwz"]
        assert eom.M.shape == (3, 3) and eom.F.shape == (3, 1)
        qw, qx, qy, qz = eom.q
        wx, wy, wz = eom.dq
        assert sp.expand(eom.kinematic[0] + (qx * wx + qy * wy + qz * wz) / 2) == 0
        assert sp.expand(eom.kinematic[1] - (qw * wx + qy * wz - qz * wy) / 2) == 0


def _sympy_pendulum():
    """The spherical pendulum by sympy.physics.mechanics: its frame turned by the
    quaternion (orient_quaternion), w its angular velocity in its own axes,
    dq = 1/2 q (x) (0, w) as the kinematic differential equations."""
    from sympy.physics import mechanics as me

    qw, qx, qy, qz = me.dynamicsymbols("qw qx qy qz")
    wx, wy, wz = me.dynamicsymbols("wx wy wz")
    m, L, g = 1, 1, sp.Rational(981, 100)
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Quaternion", [qw, qx, qy, qz])
    B.set_ang_vel(N, wx * B.x + wy * B.y + wz * B.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", -L / 2 * B.z)
    P.v2pt_theory(O, N, B)
    rod = me.RigidBody("rod", P, B, m, (me.inertia(B, sp.Rational(1, 12), sp.Rational(1, 12),
                                                   sp.Rational(1, 1200)), P))
    t = me.dynamicsymbols._t
    rates = [-(qx * wx + qy * wy + qz * wz) / 2, (qw * wx + qy * wz - qz * wy) / 2,
             (qw * wy + qz * wx - qx * wz) / 2, (qw * wz + qx * wy - qy * wx) / 2]
    kd = [c.diff(t) - r for c, r in zip((qw, qx, qy, qz), rates)]
    km = me.KanesMethod(N, q_ind=[qw, qx, qy, qz], u_ind=[wx, wy, wz], kd_eqs=kd)
    km.kanes_equations([rod], [(P, -m * g * N.z)])
    return km, (qw, qx, qy, qz, wx, wy, wz)


def test_kane_matches_sympy_mechanics_with_a_quaternion_parametrized_body():
    km, symbols = _sympy_pendulum()
    M_oracle = km.mass_matrix
    F_oracle = km.forcing
    robot = load_robot(ROBOTS["spherical_pendulum"])
    eom = derive(robot, "kane")
    ours = [*eom.q, *eom.dq]
    rng = np.random.default_rng(2)
    for _ in range(20):
        quaternion = rng.normal(size=4)
        values = [*(quaternion / np.linalg.norm(quaternion)), *rng.uniform(-2, 2, 3)]
        theirs = dict(zip(symbols, values))
        mine = dict(zip(ours, values))
        # (the kinematic equations in the forcing are substituted by the oracle)
        M_ref = np.array(M_oracle.subs(theirs).evalf(), dtype=float)
        F_ref = np.array(F_oracle.subs(theirs).evalf(), dtype=float).ravel()
        M = np.array(eom.M.xreplace(mine).evalf(), dtype=float)
        F = np.array(eom.F.xreplace(mine).evalf(), dtype=float).ravel()
        assert _rel(M, M_ref) < REL and _rel(F, F_ref) < REL


def test_linearize_the_hanging_pendulum_on_the_tangent_space():
    """Small oscillations of a rod (centre at L/2, inertia m L^2/3 about the pivot):
    omega^2 = (m g L/2) / (m L^2/3) = 3 g / (2 L) about x and about y; about its own
    axis (z) nothing restores it.  The state is [dtheta (3), w (3)]: 6, not 7 + 3."""
    from anadyn_cli.services.linearize import linearize

    robot = robot_from_text(HANGING, "hanging.yaml")
    expected = 3 * 9.81 / 2
    for formulation in ("kane", "lagrange"):
        result = linearize(robot, formulation)
        assert result.state == ["theta_wx", "theta_wy", "theta_wz", "wx", "wy", "wz"]
        A = result.A
        assert A.shape == (6, 6)
        assert np.allclose(A[:3, 3:], np.eye(3)) and np.allclose(A[:3, :3], 0)
        assert abs(A[3, 0] + expected) < 1e-9 and abs(A[4, 1] + expected) < 1e-9
        assert np.allclose(A[5], 0)
        frequencies = sorted(abs(e["imag"]) for e in result.eigenvalues)
        assert np.allclose(frequencies[-4:], math.sqrt(expected), rtol=1e-12)


def test_linearize_refuses_an_equilibrium_search_with_a_spherical_joint(capsys):
    code = main(["linearize", str(ROBOTS["spherical_pendulum"]), "--equilibrium"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "spherical" in err, err


@pytest.mark.parametrize("formulation", ["kane", "lagrange"])
def test_the_torque_free_body_on_the_closed_forms_keeps_energy_and_momentum(formulation):
    from test_spherical import _world_momentum          # R(q) I w, world axes

    robot = load_robot(ROBOTS["tumbling_box"])
    model = numeric_model(robot, formulation)
    assert model.evaluator == "closed-form"
    result = simulate(model, t_end=20.0, output_step=0.5, rtol=1e-12, atol=1e-14)
    assert result.solution.success
    x = result.x
    T, V = model.energy(x[:, :4].T, x[:, 4:].T)
    assert np.abs(T + V - T[0] - V[0]).max() < 1e-9 * abs(T[0])
    L = np.array([_world_momentum(robot, row) for row in x])
    assert np.abs(L - L[0]).max() < 1e-9 * np.linalg.norm(L[0])
    assert 0 < result.quaternion_drift < 1e-8
    assert x[:, 5].min() < -1.5                         # it flipped


def test_compare_proves_kane_equal_to_lagrange_on_the_spherical_pendulum(tmp_path, capsys):
    out = tmp_path / "cmp"
    code = main(["compare", str(ROBOTS["spherical_pendulum"]), "--t-end", "1", "--samples",
                 "20", "--no-cache", "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert (out / "compare.json").exists()


def test_equations_print_the_kinematic_differential_equations(capsys):
    assert main(["equations", str(ROBOTS["spherical_pendulum"])]) == 0
    text = capsys.readouterr().out
    assert "wx: " in text and "dwx" in text
    assert "# kinematic differential equations" in text
    assert "dqw = -0.5*qx*wx - 0.5*qy*wy - 0.5*qz*wz" in text
