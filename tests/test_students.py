"""For students: the energies and Kane's terms as the chapter writes them, and
LaTeX that compiles as printed.

Closed forms from the chapter (section 6.3 and 6.5), with its T1 slip for the
RRT arm corrected (T1 = 2/3 m1 L1^2 dq1^2, the chapter drops the square).
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from anadyn_cli.cli import main
from anadyn_cli.model import load_robot, robot_from_text
from anadyn_cli.symbolic import terms
from anadyn_cli.symbolic.formulations import derive

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
sys.path.insert(0, str(Path(__file__).parent))

S = {name: sp.Symbol(name, real=True) for name in
     "q1 q2 q3 dq1 dq2 dq3 L1 L2 m1 m2 m3 g I3x I3y I3z T01x T12y F23z".split()}


def zero(expr) -> bool:
    return sp.simplify(sp.expand_trig(sp.expand(expr))) == 0


def test_rrt_energies_are_the_chapters():
    e = terms.energies(load_robot(ROBOTS / "rrt.yaml"), symbolic=True)
    q2, q3, dq1, dq2, dq3 = (S[k] for k in ("q2", "q3", "dq1", "dq2", "dq3"))
    L1, L2, m1, m2, m3, g = (S[k] for k in ("L1", "L2", "m1", "m2", "m3", "g"))
    c2, s2 = sp.cos(q2), sp.sin(q2)
    T1 = sp.Rational(2, 3) * m1 * L1**2 * dq1**2
    T2 = m2 / 3 * ((6 * L1**2 + L2**2 + 6 * L1 * L2 * c2 + L2**2 * sp.cos(2 * q2)) * dq1**2
                   + 2 * L2**2 * dq2**2)
    T3 = sp.Rational(1, 2) * (S["I3x"] * c2**2 * dq1**2 + S["I3z"] * s2**2 * dq1**2
                              + S["I3y"] * dq2**2
                              + m3 * ((2 * L1 + L2 * c2 + c2 * q3)**2 * dq1**2
                                      + (L2 + q3)**2 * dq2**2 + dq3**2))
    assert e.bodies == ("link1", "link2", "link3")
    for found, chapter in zip(e.kinetic, (T1, T2, T3)):
        assert zero(found - chapter)
    # gravity along -i0: V_i = m_i g (height along i0)
    assert zero(e.V - g * (m2 * L2 + m3 * (L2 + q3)) * s2)


def test_rr_energies_are_the_chapters():
    e = terms.energies(load_robot(ROBOTS / "rr.yaml"), symbolic=True)
    L, m = S["L1"], S["m1"]
    q1, q2, dq1, dq2 = (S[k] for k in ("q1", "q2", "dq1", "dq2"))
    same = {S["L2"]: L, S["m2"]: m}
    chapter_T1 = m * L**2 / 6 * dq1**2
    chapter_T = m * L**2 / 6 * (4 * dq1**2 + 3 * dq1 * dq2 * sp.cos(q2 - q1) + dq2**2)
    assert zero(e.kinetic[0].xreplace(same) - chapter_T1)
    assert zero(e.T.xreplace(same) - chapter_T)


@pytest.mark.parametrize("name", ["rr", "rrt"])
def test_total_kinetic_energy_is_half_dq_M_dq(name):
    robot = load_robot(ROBOTS / f"{name}.yaml")
    eom = derive(robot, "lagrange", symbolic=True)
    dq = sp.Matrix(eom.dq)
    assert zero(terms.energies(robot, symbolic=True).T - (dq.T * eom.M * dq)[0] / 2)


def test_rrt_generalized_active_forces_are_the_chapters():
    """(6.41): Q1 = T01x, Q2 = T12y - g m2 L2 c2 - g m3 c2 (L2 + q3), Q3 = F23z - g m3 s2."""
    robot = load_robot(ROBOTS / "rrt.yaml")
    k = terms.kane_terms(robot, derive(robot, "kane", symbolic=True))
    q2, q3 = S["q2"], S["q3"]
    g, L2, m2, m3 = S["g"], S["L2"], S["m2"], S["m3"]
    chapter = [S["T01x"],
               S["T12y"] - g * m2 * L2 * sp.cos(q2) - g * m3 * sp.cos(q2) * (L2 + q3),
               S["F23z"] - g * m3 * sp.sin(q2)]
    for found, expected in zip(k.active, chapter):
        assert zero(found - expected)


@pytest.mark.parametrize("name", ["rr", "rrt"])
@pytest.mark.parametrize("formulation", ["kane", "lagrange"])
def test_kanes_equations_are_the_equations_of_motion(name, formulation):
    """Q_r + Kin_r = -(M ddq - F - B tau)_r exactly: Kin is computed from the
    kinematics by differentiation, independently of either formulation."""
    robot = load_robot(ROBOTS / f"{name}.yaml")
    eom = derive(robot, formulation, symbolic=True)
    k = terms.kane_terms(robot, eom)
    for Q, K, residual in zip(k.active, k.inertia, eom.residuals):
        assert zero(Q + K + residual)


@pytest.mark.parametrize("seed", [4, pytest.param(17, marks=pytest.mark.slow)])   # 17: ~170 s
def test_kanes_terms_with_joint_forces_and_loads(seed):
    """A random robot with damping, friction, springs and loads, numerically at
    random states: Q + Kin + residual = 0."""
    from random_robots import random_robot_yaml

    robot = robot_from_text(random_robot_yaml(seed, forces=True), f"random{seed}.yaml")
    eom = derive(robot, "kane")
    k = terms.kane_terms(robot, eom)
    symbols = [*eom.q, *eom.dq, *eom.ddq, *eom.efforts, eom.t]
    check = sp.lambdify(symbols, [Q + K + r for Q, K, r in zip(k.active, k.inertia,
                                                              eom.residuals)], "numpy")
    rng = np.random.default_rng(seed)
    for _ in range(5):
        values = rng.uniform(-1.5, 1.5, len(symbols))
        assert np.allclose(check(*values), 0, atol=1e-9)


def test_equations_energies_and_kane_terms_on_the_command_line(capsys):
    assert main(["equations", str(ROBOTS / "rr.yaml"), "--energies", "--kane-terms"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "# energies: T kinetic, V potential of gravity (V = 0 at the world origin)",
        "T_bar1 = 0.16666667*dq1**2",
        "V_bar1 = 4.905*sin(q1)",
        "T_bar2 = 0.5*dq1**2 + 0.5*dq1*dq2*cos(q1 - q2) + 0.16666667*dq2**2",
        "V_bar2 = 9.81*sin(q1) + 4.905*sin(q2)",
        "T = 0.66666667*dq1**2 + 0.5*dq1*dq2*cos(q1 - q2) + 0.16666667*dq2**2",
        "V = 14.715*sin(q1) + 4.905*sin(q2)",
        "# Kane's equations Q_r + Kin_r = 0: Q_r generalized active force (Fr), Kin_r "
        "generalized inertia force (Fr*)",
        "Q1 = T01z - T12z - 14.715*cos(q1)",
        "Kin1 = -1.3333333*ddq1 - 0.5*ddq2*cos(q1 - q2) - 0.5*dq2**2*sin(q1 - q2)",
        "Q2 = T12z - 4.905*cos(q2)",
        "Kin2 = -0.5*ddq1*cos(q1 - q2) - 0.33333333*ddq2 + 0.5*dq1**2*sin(q1 - q2)"]


def test_latex_writes_rates_and_accelerations_with_dots(capsys):
    assert main(["equations", str(ROBOTS / "rr.yaml"), "--format", "latex"]) == 0
    out = capsys.readouterr().out
    assert r"\ddot{q}_{1}" in out and r"\dot{q}_{2}^{2}" in out
    assert "ddq" not in out and "dq_" not in out
    assert out.startswith("% rr: kane, numeric parameters (anadyn)\n\\documentclass")
    assert out.rstrip().endswith(r"\end{document}")
    assert r"&= 0 \tag*{$(q_{1})$} \\" in out


@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="no pdflatex on this machine")
@pytest.mark.parametrize("args", [
    ["robots/rr.yaml"],
    ["robots/rrt.yaml", "--symbolic", "--matrices", "--energies", "--kane-terms"],
    ["robots/rr.yaml", "--formulation", "lagrange", "--energies"],
])
def test_latex_compiles_as_printed(tmp_path, capsys, args):
    path = ROBOTS.parent / args[0]
    assert main(["equations", str(path), *args[1:], "--format", "latex"]) == 0
    (tmp_path / "equations.tex").write_text(capsys.readouterr().out)
    done = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error",
                           "equations.tex"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stdout[-2000:]
    assert (tmp_path / "equations.pdf").read_bytes()[:4] == b"%PDF"
