"""Planar, universal, cylindrical and helical joints (issue 24, item 1), which the
loader makes into chains of one-part joints on massless links
(``anadyn_cli.model.loader.compound``), against independent models:

- Pinocchio's own ``JointModelPlanar`` (q = x, y, cos, sin; its linear speeds in
  the moving frame, mapped explicitly), ``JointModelUniversal`` and
  ``JointModelHelicalUnaligned``: mass matrix, inverse and forward dynamics at
  20 random states to 1e-9 relative;
- a body on a cylindrical joint against its closed form;
- Kane's and Lagrange's closed forms against each other (``compare``);
- bad input: one line, exit 2.
"""
from __future__ import annotations

import numpy as np
import pytest

from anadyn_cli import robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.numeric import recursive
from pinocchio_mapped import check_mapped, rel

pin = pytest.importorskip("pinocchio")

G = 9.81
BODY = """    mass: 2.0
    com: [0.1, 0.05, -0.02]
    inertia: {ixx: 0.11, iyy: 0.2, izz: 0.25, ixy: 0.01, ixz: -0.02, iyz: 0.015}"""
TIP = """  - name: tip
    parent: base
    joint: {type: revolute, axis: [0, 1, 0], origin: [0.2, 0, 0.1], displacement: a}
    mass: 1.0
    com: [0.3, 0, 0]
    inertia: {ixx: 0.01, iyy: 0.03, izz: 0.03}"""


def robot_text(joint: str, coordinates: list[str]) -> str:
    listed = "".join(f"  {c}: {{initial: 0}}\n" for c in coordinates)
    return (f"name: compound\ngravity: [0, 0, -{G}]\ncoordinates:\n{listed}  a: {{initial: 0}}\n"
            f"bodies:\n  - name: base\n    joint: {joint}\n{BODY}\n{TIP}\n")


def pin_inertia(mass, com, I):
    return pin.Inertia(mass, np.array(com, float), np.array(I, float))


def pin_chain(base_joint) -> pin.Model:
    """ground -> base_joint -> base -> revolute y -> tip, the bodies of ``robot_text``."""
    model = pin.Model()
    model.gravity.linear = np.array([0, 0, -G])
    j0 = model.addJoint(0, base_joint, pin.SE3.Identity(), "base")
    model.appendBodyToJoint(j0, pin_inertia(
        2.0, [0.1, 0.05, -0.02],
        [[0.11, 0.01, -0.02], [0.01, 0.2, 0.015], [-0.02, 0.015, 0.25]]), pin.SE3.Identity())
    j1 = model.addJoint(j0, pin.JointModelRY(),
                        pin.SE3(np.eye(3), np.array([0.2, 0, 0.1])), "tip")
    model.appendBodyToJoint(j1, pin_inertia(1.0, [0.3, 0, 0], np.diag([0.01, 0.03, 0.03])),
                            pin.SE3.Identity())
    return model


def generated(text: str) -> dict:
    namespace: dict = {}
    exec(compile(recursive.source(robot_from_text(text, "compound.yaml")), "<test>", "exec"),
         namespace)  # noqa: S102
    return namespace


def check(ns, model, n, to_pin):
    """``to_pin(q, u, du)`` -> (q_pin, v_pin, a_pin, J, Jdot_u) (``pinocchio_mapped``)."""
    def draw(rng):
        return rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n), rng.uniform(-3, 3, n)
    assert check_mapped(pin, ns, model, draw, to_pin) == 20


def test_planar_matches_pinocchios_planar_joint():
    ns = generated(robot_text("{type: planar, axis: [0, 0, 1], coordinates: [x, y, th]}",
                              ["x", "y", "th"]))

    def to_pin(q, u, du):
        x, y, th, a = q
        c, s = np.cos(th), np.sin(th)
        J = np.eye(4)
        J[:2, :2] = [[c, s], [-s, c]]                  # its (vx, vy) = R(th)^T (dx, dy)
        Jdot_u = np.zeros(4)
        Jdot_u[:2] = u[2] * np.array([[-s, c], [-c, -s]]) @ u[:2]
        return (np.array([x, y, c, s, a]), J @ u, J @ du + Jdot_u, J, Jdot_u)
    check(ns, pin_chain(pin.JointModelPlanar()), 4, to_pin)


def test_universal_matches_pinocchios_universal_joint():
    ns = generated(robot_text("{type: universal, axis: [1, 0, 0], axis2: [0, 1, 0], "
                              "coordinates: [b1, b2]}", ["b1", "b2"]))

    def to_pin(q, u, du):
        return q, u, du, np.eye(3), np.zeros(3)
    check(ns, pin_chain(pin.JointModelUniversal(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))),
          3, to_pin)


def test_helical_matches_pinocchios_helical_joint():
    axis = np.array([1.0, 2.0, 2.0]) / 3
    ns = generated(robot_text("{type: helical, axis: [1, 2, 2], pitch: 0.05, "
                              "displacement: th}", ["th"]))

    def to_pin(q, u, du):
        return q, u, du, np.eye(2), np.zeros(2)
    check(ns, pin_chain(pin.JointModelHelicalUnaligned(axis, 0.05)), 2, to_pin)


def test_cylindrical_matches_its_closed_form():
    """A body on a vertical cylindrical joint, its centre of mass r off the axis:
    M = diag(Izz + m r^2, m), and gravity along the axis pulls d down: F_d = -m g."""
    text = ("name: cyl\ngravity: [0, 0, -9.81]\ncoordinates: {th: {initial: 0.3}, "
            "d: {initial: 0.1}}\nbodies:\n  - name: sleeve\n    joint: {type: cylindrical, "
            "axis: [0, 0, 1], coordinates: [th, d]}\n    mass: 3.0\n    com: [0.2, 0, 0]\n"
            "    inertia: {ixx: 0.05, iyy: 0.05, izz: 0.04}\n")
    ns = generated(text)
    for th, d, dth, dd in [(0.3, 0.1, 1.2, -0.4), (-2.0, 0.5, -0.7, 2.0)]:
        M, F, _ = ns["mfb"](0.0, th, d, dth, dd)
        assert rel(M, np.diag([0.04 + 3.0 * 0.2 ** 2, 3.0])) < 1e-12
        assert rel(F, [0.0, -3.0 * 9.81]) < 1e-12


@pytest.mark.parametrize("joint, names", [
    ("{type: planar, axis: [1, 1, 0], coordinates: [x, y, th]}", ["x", "y", "th"]),
    ("{type: universal, axis: [0, 0, 1], axis2: [1, 0, 0], coordinates: [b1, b2]}",
     ["b1", "b2"]),
    ("{type: cylindrical, axis: [0, 1, 0], coordinates: [th, d]}", ["th", "d"]),
    ("{type: helical, axis: [0, 0, 1], pitch: -0.2, displacement: th}", ["th"])])
def test_kane_and_lagrange_agree_on_compound_joints(tmp_path, joint, names):
    path = tmp_path / "compound.yaml"
    path.write_text(robot_text(joint, names))
    assert main(["compare", str(path), "--t-end", "0.5", "--out", str(tmp_path / "out")]) == 0


def test_parts_are_links_an_actuator_can_name():
    """A planar joint's slides are links ``puck__x`` and ``puck__y``, massless; a force
    on ``puck__x`` pushes a puck whose centre of mass is on its origin along x:
    ddx = f / m, ddy = ddth = 0."""
    text = ("name: puck\ncoordinates: {x: {initial: 0}, y: {initial: 0}, th: {initial: 0.7}}\n"
            "bodies:\n  - name: puck\n    joint: {type: planar, coordinates: [x, y, th]}\n"
            "    mass: 2.0\n    inertia: {ixx: 0.1, iyy: 0.1, izz: 0.2}\n"
            "actuators:\n  fx: {joint: puck__x}\n")
    robot = robot_from_text(text, "puck.yaml")
    assert [b.name for b in robot.bodies] == ["puck__x", "puck__y", "puck"]
    assert [float(b.mass) for b in robot.bodies[:2]] == [0.0, 0.0]
    M, F, B = generated(text)["mfb"](0.0, 0, 0, 0.7, 0, 0, 0)
    assert rel(np.linalg.solve(M, F + B @ [6.0]), [3.0, 0.0, 0.0]) < 1e-12


@pytest.mark.parametrize("joint, message", [
    ("{type: planar, axis: [0, 0, 1]}", "missing required key 'coordinates' for a planar"),
    ("{type: planar, coordinates: [x, y]}", "a planar joint has 3 coordinates, got 2"),
    ("{type: planar, coordinates: [x, x, y]}", "coordinate 'x' is listed twice"),
    ("{type: planar, coordinates: [x, y, nope]}", "must name a coordinate declared"),
    ("{type: planar, coordinates: [x, y, th], damping: 1}", "a planar joint takes no 'damping'"),
    ("{type: universal, axis: [1, 0, 0], coordinates: [x, y]}", "missing required key 'axis2'"),
    ("{type: universal, axis: [1, 0, 0], axis2: [2, 0, 0], coordinates: [x, y]}",
     "axis2 must not be parallel to axis"),
    ("{type: helical, axis: [0, 0, 1], displacement: x}", "missing required key 'pitch'"),
    ("{type: helical, axis: [0, 0, 1], pitch: 0, displacement: x}", "pitch must not be 0"),
    ("{type: helical, pitch: 0.1, coordinates: [x]}", "give it as 'displacement'"),
    ("{type: cylindrical, pitch: 0.1, coordinates: [x, y]}", "only a helical joint has 'pitch'"),
    ("{type: planar, axis: [0, 0, 0], coordinates: [x, y, th]}", "must not be the zero vector"),
])
def test_bad_compound_joints_are_one_line_and_exit_2(tmp_path, capsys, joint, message):
    path = tmp_path / "bad.yaml"
    path.write_text(robot_text(joint, ["x", "y", "th"]))
    out = tmp_path / "out"
    assert main(["simulate", str(path), "--no-plot", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "bad.yaml" in err, err
    assert not out.exists()


def test_a_link_name_that_is_taken_is_refused(tmp_path, capsys):
    text = robot_text("{type: universal, axis: [1, 0, 0], axis2: [0, 1, 0], "
                      "coordinates: [b1, b2]}", ["b1", "b2"]).replace("name: tip", "name: base__b1")
    path = tmp_path / "taken.yaml"
    path.write_text(text)
    assert main(["simulate", str(path), "--no-plot", "--out", str(tmp_path / "o")]) == 2
    assert "needs a link named 'base__b1', which is already a body" in capsys.readouterr().err
