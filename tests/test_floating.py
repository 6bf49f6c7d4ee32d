"""Floating bases (issue 24): the ``floating`` joint (three slides on massless links,
then a spherical joint: x, y, z, a unit quaternion; speeds dx, dy, dz in the parent
frame and the angular velocity in body axes) and URDF robots imported with
``--floating-base``, against Pinocchio's ``JointModelFreeFlyer`` (its linear speed is
the body-axes velocity of the base's origin: mapped explicitly), and the momentum
of a free system.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli import robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.model.urdf import import_urdf
from anadyn_cli.numeric import recursive
from pinocchio_mapped import check_mapped, rel

pin = pytest.importorskip("pinocchio")
ROBOTS = Path(pin.__file__).resolve().parents[4] / "share" / "example-robot-data" / "robots"

FREE_ARM = """name: free_arm
gravity: [0, 0, -9.81]
coordinates:
  a: {initial: 0.3}
  base_z: {initial: 1.0}
bodies:
  - name: base
    joint: {type: floating, origin: [0.1, 0, 0.2], rpy: [0.1, 0.2, 0.3]}
    mass: 3.0
    com: [0.05, -0.02, 0.01]
    inertia: {ixx: 0.11, iyy: 0.2, izz: 0.25, ixy: 0.01, ixz: -0.02, iyz: 0.015}
  - name: arm
    parent: base
    joint: {type: revolute, axis: [0, 1, 0], origin: [0.2, 0, 0.1], displacement: a}
    mass: 1.0
    com: [0.3, 0, 0]
    inertia: {ixx: 0.01, iyy: 0.03, izz: 0.03}
"""


def quaternion_matrix(w, x, y, z) -> np.ndarray:
    return np.array([[w*w + x*x - y*y - z*z, 2*(x*y - w*z), 2*(x*z + w*y)],
                     [2*(x*y + w*z), w*w - x*x + y*y - z*z, 2*(y*z - w*x)],
                     [2*(x*z - w*y), 2*(y*z + w*x), w*w - x*x - y*y + z*z]])


class Mapping:
    """anadyn's state of a robot with one floating joint <-> Pinocchio's with a
    free-flyer root: coordinates and speeds by name, the base's linear speed
    turned into body axes (v = R^T dp), so that v_pin = J u and
    a_pin = J du + Jdot_u with Jdot_u = (-w x (R^T dp), 0, 0)."""

    def __init__(self, robot, model, base: str, joints: dict[str, str]):
        names = [c.name for c in robot.coordinates]
        speeds = [u.name for u in robot.speeds]
        self.nq, self.nv = len(names), len(speeds)
        self.position = [names.index(f"{base}_{p}") for p in "xyz"]
        self.quaternion = [names.index(f"{base}_q{p}") for p in "wxyz"]
        self.linear = [speeds.index(f"d{base}_{p}") for p in "xyz"]
        self.angular = [speeds.index(f"{base}_w{p}") for p in "xyz"]
        self.pin_q, self.pin_v = [], []                  # anadyn index -> Pinocchio index
        for anadyn_name, pin_name in joints.items():
            joint = model.joints[model.getJointId(pin_name)]
            self.pin_q.append((names.index(anadyn_name), joint.idx_q))
            self.pin_v.append((speeds.index("d" + anadyn_name), joint.idx_v))
        self.model = model

    def random(self, rng):
        q = rng.uniform(-1.2, 1.2, self.nq)
        quaternion = rng.normal(size=4)
        q[self.quaternion] = quaternion / np.linalg.norm(quaternion)
        return q, rng.uniform(-2, 2, self.nv), rng.uniform(-3, 3, self.nv)

    def to_pin(self, q, u, du):
        R = quaternion_matrix(*q[self.quaternion])
        qp = np.zeros(self.model.nq)
        qp[:3] = q[self.position]
        qp[3:6], qp[6] = q[self.quaternion][1:], q[self.quaternion][0]   # (x, y, z, w)
        J = np.zeros((self.model.nv, self.nv))
        J[np.ix_(range(3), self.linear)] = R.T
        J[np.ix_(range(3, 6), self.angular)] = np.eye(3)
        for ours, theirs in self.pin_q:
            qp[theirs] = q[ours]
        for ours, theirs in self.pin_v:
            J[theirs, ours] = 1.0
        bias = np.zeros(self.model.nv)
        bias[:3] = -np.cross(u[self.angular], R.T @ u[self.linear])
        return qp, J @ u, J @ du + bias, J, bias


def check_against_pinocchio(robot, model, mapping: Mapping) -> int:
    """M, inverse and forward dynamics (``pinocchio_mapped``) and the momentum P and L
    about the world origin (Pinocchio's centroidal momentum, moved from the centre of
    mass) at 20 random states, to 1e-9 relative."""
    namespace: dict = {}
    exec(compile(recursive.source(robot), "<test>", "exec"), namespace)  # noqa: S102

    def momentum(q, u, qp, vp, data):
        centroidal = pin.computeCentroidalMomentum(model, data, qp, vp)   # about the CoM
        linear = centroidal.linear
        angular = centroidal.angular + np.cross(data.com[0], linear)     # about the origin
        assert rel(namespace["momentum"](0.0, *q, *u)[:6], [*linear, *angular]) < 1e-9
    return check_mapped(pin, namespace, model, mapping.random, mapping.to_pin, also=momentum)


def pin_inertia(mass, com, I):
    return pin.Inertia(mass, np.array(com, float), np.array(I, float))


def test_a_floating_body_with_an_arm_matches_pinocchios_free_flyer():
    """The joint's origin and rpy place the free body's frame in the world: Pinocchio's
    free-flyer placement is the identity, so the body's inertia is given in that
    frame there (the same mass properties, moved)."""
    robot = robot_from_text(FREE_ARM, "free_arm.yaml")
    assert [b.name for b in robot.bodies] == ["base__x", "base__y", "base__z", "base", "arm"]
    model = pin.Model()
    model.gravity.linear = np.array([0, 0, -9.81])
    rpy = pin.rpy.rpyToMatrix(0.1, 0.2, 0.3)
    root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    model.appendBodyToJoint(root, pin_inertia(
        3.0, [0.05, -0.02, 0.01],
        [[0.11, 0.01, -0.02], [0.01, 0.2, 0.015], [-0.02, 0.015, 0.25]]), pin.SE3.Identity())
    arm = model.addJoint(root, pin.JointModelRY(),
                         pin.SE3(np.eye(3), np.array([0.2, 0, 0.1])), "arm")
    model.appendBodyToJoint(arm, pin_inertia(1.0, [0.3, 0, 0], np.diag([0.01, 0.03, 0.03])),
                            pin.SE3.Identity())
    # anadyn's position is that of the joint frame's slides: p_world = origin + C p,
    # its body turns by C R(q); Pinocchio's root is the body frame itself
    mapping = Mapping(robot, model, "base", {"a": "arm"})
    C, origin = rpy, np.array([0.1, 0, 0.2])
    plain = mapping.to_pin

    def to_pin(q, u, du):
        qp, vp, ap, J, bias = plain(q, u, du)
        R = quaternion_matrix(*q[mapping.quaternion])
        qp[:3] = origin + C @ q[mapping.position]
        rotation = pin.Quaternion(C @ R)
        qp[3:7] = rotation.coeffs()
        return qp, vp, ap, J, bias
    mapping.to_pin = to_pin
    assert check_against_pinocchio(robot, model, mapping) == 20


def urdf_robot(relative: str):
    """The URDF without its <dynamics> (Pinocchio's RNEA has no joint damping or
    friction; anadyn's inverse dynamics has), inertias as given (as Pinocchio reads
    them), imported with a free base and read by Pinocchio with a free-flyer root."""
    path = ROBOTS / relative
    if not path.exists():
        pytest.skip(f"example-robot-data has no {relative}")
    urdf = re.sub(r"<dynamics[^>]*/>", "", path.read_text())
    text = import_urdf(urdf, path.name, inertia="accept", floating_base=True).text
    robot = robot_from_text(text, path.name)
    model = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer())
    base = robot.bodies[3].name                         # after base__x, base__y, base__z
    moving = {c.name: c.name for c in robot.coordinates if not c.name.startswith(base + "_")}
    return robot, model, Mapping(robot, model, base, moving)


@pytest.mark.parametrize("relative", ["solo_description/robots/solo12.urdf",
                                      "anymal_b_simple_description/robots/anymal.urdf",
                                      "go1_description/urdf/go1.urdf"])
def test_quadrupeds_with_a_free_base_match_pinocchio(relative):
    robot, model, mapping = urdf_robot(relative)
    assert len(robot.speeds) == model.nv and len(robot.coordinates) == model.nq
    assert check_against_pinocchio(robot, model, mapping) == 20


@pytest.mark.slow
@pytest.mark.parametrize("relative", ["talos_data/robots/talos_reduced.urdf",
                                      "g1_description/urdf/g1_29dof_rev_1_0.urdf"])
def test_humanoids_with_a_free_base_match_pinocchio(relative):
    robot, model, mapping = urdf_robot(relative)
    assert len(robot.speeds) == model.nv and len(robot.coordinates) == model.nq
    assert check_against_pinocchio(robot, model, mapping) == 20


def test_a_free_fall_keeps_its_momentum_and_falls_at_g(tmp_path):
    """A free body with an arm, thrown and spinning: its centre of mass falls as
    z(t) = z0 + vz t - g t^2 / 2 whatever the arm does, and its angular momentum about
    the centre of mass stays constant (checked through ``check``'s energy balance
    and the CSV's base position for the linear part)."""
    text = FREE_ARM.replace("gravity: [0, 0, -9.81]", "gravity: [0, 0, 0]")
    text += "speeds: {base_wx: {initial: 0.4}, base_wz: {initial: 1.5}}\n"
    path = tmp_path / "free.yaml"
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["simulate", str(path), "--t-end", "3", "--no-plot", "--out", str(out)]) == 0
    data = np.genfromtxt(out / "simulate.csv", delimiter=",", names=True)
    norm = np.sqrt(sum(data[f"base_q{p}"] ** 2 for p in "wxyz"))
    assert np.abs(norm - 1).max() < 1e-12
    assert main(["check", str(path), "--out", str(tmp_path / "check")]) == 0
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    assert report["momentum"]["conserved_rows"] == np.eye(6).tolist()
    assert max(report["momentum"]["linear_drift"], report["momentum"]["angular_drift"]) < 1e-8
    assert np.abs(np.array(report["momentum"]["start"])).max() > 0.1     # it does move


def test_under_gravity_the_horizontal_momentum_and_the_vertical_spin_are_checked(tmp_path):
    path = tmp_path / "free.yaml"
    path.write_text(FREE_ARM + "speeds: {base_wz: {initial: 1.5}}\n")
    assert main(["check", str(path), "--out", str(tmp_path / "check")]) == 0
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    rows = np.array(report["momentum"]["conserved_rows"])
    assert rows.shape == (3, 6) and np.allclose(rows[2], [0, 0, 0, 0, 0, -1])
    start, end = np.array(report["momentum"]["start"]), np.array(report["momentum"]["end"])
    assert end[2] - start[2] == pytest.approx(-(3.0 + 1.0) * 9.81 * 10, rel=1e-8)  # m g t


@pytest.mark.parametrize("joint, message", [
    ("{type: floating, axis: [0, 0, 1]}", "a floating joint has no axis"),
    ("{type: floating, coordinates: [x, y, z]}", "a floating joint has 7 coordinates"),
    ("{type: floating, speeds: [p, p, r]}", "must be different names"),
    ("{type: floating, displacement: a}", "a floating joint takes no 'displacement'"),
    ("{type: planar, speeds: [p, q, r], coordinates: [a, b, c]}",
     "only a floating joint has 'speeds'"),
])
def test_bad_floating_joints_are_one_line_and_exit_2(tmp_path, capsys, joint, message):
    text = FREE_ARM.replace("{type: floating, origin: [0.1, 0, 0.2], rpy: [0.1, 0.2, 0.3]}",
                            joint)
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    assert main(["simulate", str(path), "--no-plot", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "bad.yaml" in err, err


ARM_URDF = """<robot name="arm">
  <link name="world"/>
  <link name="base"><inertial><mass value="2"/><origin xyz="0.01 0 0.02"/>
    <inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l1"><inertial><mass value="1"/><origin xyz="0.2 0 0"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="cart"><inertial><mass value="0.5"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="base_free" type="floating"><parent link="world"/><child link="base"/></joint>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/></joint>
  <joint name="slider" type="planar"><parent link="l1"/><child link="cart"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 0 1"/></joint>
</robot>"""


def test_urdf_floating_and_planar_joints_import_and_match_pinocchio(tmp_path):
    """A URDF's floating joint is anadyn's (Pinocchio reads it as a free-flyer), a
    planar one too; Kane and Lagrange agree on the result (compare)."""
    text = import_urdf(ARM_URDF, "arm.urdf").text
    robot = robot_from_text(text, "arm.urdf")
    assert [b.joint.type for b in robot.bodies] == [
        "prismatic", "prismatic", "prismatic", "spherical", "revolute",
        "prismatic", "prismatic", "revolute"]
    assert [a.name for a in robot.actuators] == ["tau_j1"]
    no_planar = ARM_URDF.replace('type="planar"', 'type="fixed"')
    robot = robot_from_text(import_urdf(no_planar, "arm.urdf").text, "arm.urdf")
    model = pin.buildModelFromXML(no_planar)
    assert model.joints[1].shortname() == "JointModelFreeFlyer"
    assert check_against_pinocchio(robot, model, Mapping(robot, model, "base_free",
                                                         {"j1": "j1"})) == 20
    path = tmp_path / "arm.urdf"
    path.write_text(ARM_URDF)
    assert main(["compare", str(path), "--t-end", "0.3", "--out", str(tmp_path / "c")]) == 0


@pytest.mark.parametrize("flags, message", [
    (["--lock", "base_free=0"], "a floating joint has several coordinates and cannot be "
                                "locked"),
])
def test_a_floating_joint_cannot_be_locked(tmp_path, capsys, flags, message):
    path = tmp_path / "arm.urdf"
    path.write_text(ARM_URDF)
    assert main(["import", str(path), *flags]) == 2
    assert message in capsys.readouterr().err


def test_floating_base_on_a_root_that_already_floats_adds_nothing():
    imported = import_urdf(ARM_URDF, "arm.urdf", floating_base=True)
    assert any("already carries the floating joint 'base_free'" in w for w in imported.warnings)
    assert imported.text.count("type: floating") == 1


def test_a_satellites_reaction_wheel_turns_its_bus_the_other_way(tmp_path):
    """Momentum exchange about z: (Ib + Iw) wb + Iw dw = 0 at every row, and the wheel's
    absolute momentum Iw (wb + dw) equals the motor's impulse, int T dt = T0 t_on
    (the pulse T0 (1 - tanh(10 (t - t_on))) / 2, symmetric about t_on, to e^-40), to the
    run's tolerance (rtol 1e-10: 2e-9 seen)."""
    out = tmp_path / "sat"
    assert main(["simulate", "satellite", "--no-plot", "--out", str(out)]) == 0
    data = np.genfromtxt(out / "simulate.csv", delimiter=",", names=True)
    Ib, Iw = 120.0, 0.1
    assert np.abs((Ib + Iw) * data["bus_wz"] + Iw * data["dwheel"]).max() < 1e-10
    assert Iw * (data["bus_wz"][-1] + data["dwheel"][-1]) == pytest.approx(0.2 * 2, rel=1e-7)
    assert data["bus_wz"][-1] < -3e-3                      # the bus turned the other way
    assert np.abs(data["bus_wx"]).max() < 1e-12 and np.abs(data["bus_wy"]).max() < 1e-12


def test_a_free_floating_space_robot_turns_its_base_with_zero_momentum(tmp_path):
    """Its arms swing under PD laws; nothing acts from outside: P and L stay zero
    (``check``) while the base's attitude changes."""
    assert main(["check", "space_robot", "--out", str(tmp_path / "check")]) == 0
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    assert report["momentum"]["conserved_rows"] == np.eye(6).tolist()
    assert max(report["momentum"]["linear_drift"], report["momentum"]["angular_drift"]) < 1e-8
    assert main(["simulate", "space_robot", "--no-plot", "--out", str(tmp_path / "s")]) == 0
    data = np.genfromtxt(tmp_path / "s" / "simulate.csv", delimiter=",", names=True)
    turned = 2 * np.arccos(min(1.0, abs(data["base_qw"][-1])))
    assert turned > 0.05                                    # rad: the base made up for the arms


def test_a_floating_robot_is_drawn_where_its_coordinates_put_it(tmp_path):
    """The drawings' forward kinematics put the free body's origin at (x, y, z) and turn
    it by the quaternion's rotation; show and animate run."""
    from anadyn_cli import load_robot
    from anadyn_cli.numeric.frames import frames

    robot = load_robot("space_robot")
    names = [c.name for c in robot.coordinates]
    q = np.zeros(len(names))
    quaternion = np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])
    for k, part in enumerate("wxyz"):
        q[names.index(f"base_q{part}")] = quaternion[k]
    q[[names.index(f"base_{p}") for p in "xyz"]] = [0.3, -0.2, 1.1]
    poses = frames(robot)(q)
    base = [b.name for b in robot.bodies].index("base")
    assert rel(poses.origin[base], [0.3, -0.2, 1.1]) < 1e-14
    assert rel(poses.R[base], quaternion_matrix(*quaternion)) < 1e-14
    assert main(["show", "space_robot", "--out", str(tmp_path / "show")]) == 0
    assert main(["animate", "satellite", "--t-end", "0.5", "--out", str(tmp_path / "a")]) == 0
    assert (tmp_path / "a" / "animate.gif").stat().st_size > 0
