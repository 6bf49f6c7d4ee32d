"""anadyn against the closed forms printed in the textbook chapter."""
import pytest
import sympy as sp

from anadyn_cli import derive, load_robot
from anadyn_cli.symbolic.canonical import canonical
from anadyn_cli.symbolic.formulations import lagrange
from anadyn_cli.symbolic import kinematics

METHODS = ["kane", "lagrange"]
S = {name: sp.Symbol(name, real=True) for name in
     "q1 q2 q3 dq1 dq2 dq3 ddq1 ddq2 ddq3 m L g m1 m2 m3 L1 L2 I3x I3y I3z "
     "T01z T12z T01x T12y F23z".split()}


def same(a: sp.Expr, b: sp.Expr) -> bool:
    return canonical(sp.expand(a - b)) == 0


@pytest.mark.parametrize("method", METHODS)
def test_rr_equations_are_the_chapters_6_23(method):
    """(6.23) with m1 = m2 = m, L1 = L2 = L, absolute angles q1, q2."""
    eom = derive(load_robot("robots/rr.yaml"), method, symbolic=True)
    s = S
    equal = {s["m1"]: s["m"], s["m2"]: s["m"], s["L1"]: s["L"], s["L2"]: s["L"]}
    m, L, g = s["m"], s["L"], s["g"]
    c21, s21 = sp.cos(s["q2"] - s["q1"]), sp.sin(s["q2"] - s["q1"])
    chapter = [
        sp.Rational(4, 3) * m * L**2 * s["ddq1"] + m * L**2 / 2 * s["ddq2"] * c21
        - m * L**2 / 2 * s["dq2"]**2 * s21 + sp.Rational(3, 2) * m * g * L * sp.cos(s["q1"])
        - s["T01z"] + s["T12z"],
        m * L**2 / 2 * s["ddq1"] * c21 + m * L**2 / 3 * s["ddq2"]
        + m * L**2 / 2 * s["dq1"]**2 * s21 + m * g * L / 2 * sp.cos(s["q2"]) - s["T12z"],
    ]
    for ours, theirs in zip(eom.residuals, chapter):
        assert same(ours.xreplace(equal), theirs)


@pytest.mark.parametrize("method", METHODS)
def test_rrt_generalized_active_forces_are_the_chapters_6_41(method):
    """At rest the equations reduce to M ddq = Q, and Q is (6.41)."""
    eom = derive(load_robot("robots/rrt.yaml"), method, symbolic=True)
    s = S
    rest = {s["dq1"]: 0, s["dq2"]: 0, s["dq3"]: 0}
    Q = (eom.F + eom.B * sp.Matrix(eom.efforts)).xreplace(rest)
    c2, s2 = sp.cos(s["q2"]), sp.sin(s["q2"])
    chapter = [s["T01x"],
               s["T12y"] - s["g"] * s["m2"] * s["L2"] * c2 - s["g"] * s["m3"] * c2 * (s["L2"] + s["q3"]),
               s["F23z"] - s["g"] * s["m3"] * s2]
    for ours, theirs in zip(Q, chapter):
        assert same(ours, theirs)


def test_rrt_link_kinetic_energies_are_the_chapters():
    """T1 (with the chapter's missing square restored), T2 and T3."""
    kin = kinematics.build(load_robot("robots/rrt.yaml"), symbolic=True)
    s = S
    L1, L2, q2, q3 = s["L1"], s["L2"], s["q2"], s["q3"]
    d1, d2, d3 = s["dq1"], s["dq2"], s["dq3"]
    c2, s2 = sp.cos(q2), sp.sin(q2)
    chapter = [
        sp.Rational(2, 3) * s["m1"] * L1**2 * d1**2,
        s["m2"] / 3 * ((6 * L1**2 + L2**2 + 6 * L1 * L2 * c2 + L2**2 * sp.cos(2 * q2)) * d1**2
                       + 2 * L2**2 * d2**2),
        (s["I3x"] * c2**2 * d1**2 + s["I3z"] * s2**2 * d1**2 + s["I3y"] * d2**2
         + s["m3"] * ((2 * L1 + L2 * c2 + c2 * q3)**2 * d1**2 + (L2 + q3)**2 * d2**2 + d3**2)) / 2,
    ]
    for i, theirs in enumerate(chapter):
        ours, _ = lagrange.body_energies(kin, i)
        assert same(ours, theirs), f"T{i + 1}"


def test_rr_potential_energy_is_gravity_times_height():
    kin = kinematics.build(load_robot("robots/rr.yaml"), symbolic=True)
    s = S
    V = sum(lagrange.body_energies(kin, i)[1] for i in range(2))
    expected = s["g"] * (s["m1"] * s["L1"] / 2 * sp.sin(s["q1"])
                         + s["m2"] * (s["L1"] * sp.sin(s["q1"]) + s["L2"] / 2 * sp.sin(s["q2"])))
    assert same(V, expected)
