"""Equations carry only what the scene needs."""
import pytest
import sympy as sp

from anadyn_cli import derive, load_robot, robot_from_text
from anadyn_cli.symbolic import kinematics
from anadyn_cli.symbolic.canonical import canonical

RR = open("robots/rr.yaml").read()
METHODS = ["kane", "lagrange"]


@pytest.mark.parametrize("method", METHODS)
def test_rr_equations_have_no_identically_zero_term(method):
    eom = derive(load_robot("robots/rr.yaml"), method)
    for entry in [*eom.M, *eom.F, *eom.B]:
        terms = sp.Add.make_args(sp.expand(entry))
        for term in terms:
            assert term == 0 or canonical(term) != 0
        # nothing cancels further: the entry is already in canonical form
        assert canonical(entry) == sp.expand(entry)
    # and the count is what the chapter's (6.23) has: 2 + 2 + 2 terms in M,
    # 2 in each F entry (velocity product, gravity)
    assert [len(sp.Add.make_args(e)) for e in eom.F] == [3, 3]   # dq^2 sin(q1 - q2) splits in 2


@pytest.mark.parametrize("method", METHODS)
def test_numeric_parameters_are_substituted_before_differentiation(method):
    eom = derive(load_robot("robots/rr.yaml"), method)
    assert eom.parameters == set()
    symbolic = derive(load_robot("robots/rr.yaml"), method, symbolic=True)
    assert {str(p) for p in symbolic.parameters} == {"L1", "L2", "m1", "m2", "g"}


def test_a_planar_scene_has_no_out_of_plane_terms():
    kin = kinematics.build(load_robot("robots/rr.yaml"))
    for body in kin.bodies:
        assert body.W[:2, :] == sp.zeros(2, 2)         # turns about z only
        assert body.V[2, :] == sp.zeros(1, 2)          # moves in x-y only
        assert body.position[2] == 0


@pytest.mark.parametrize("method", METHODS)
def test_inertia_about_an_axis_the_body_never_turns_about_adds_nothing(method):
    heavier = RR.replace("inertia: {iyy: m2*L2**2/12,", "inertia: {ixx: 0.1, ixy: 0.01, iyy: m2*L2**2/12,")
    heavier = heavier.replace("inertia: {iyy: m1*L1**2/12,", "inertia: {ixx: 0.1, ixy: 0.01, iyy: m1*L1**2/12,")
    assert heavier != RR
    a = derive(robot_from_text(RR, "rr.yaml"), method, tidy=False)
    b = derive(robot_from_text(heavier, "rr.yaml"), method, tidy=False)
    assert (a.M, a.F, a.B) == (b.M, b.F, b.B)          # structurally identical


@pytest.mark.parametrize("method", METHODS)
def test_absent_gravity_adds_no_terms(method):
    weightless = RR.replace("gravity: [0, -g, 0]\n", "")
    eom = derive(robot_from_text(weightless, "rr.yaml"), method)
    at_rest = eom.F.xreplace({dq: 0 for dq in eom.dq})
    assert at_rest == sp.zeros(2, 1)
    assert all(not entry.has(sp.Rational(981, 100)) for entry in eom.F)
