"""Drives (``actuators[].drive``): gear ratio, rotor inertia, motor-side damping and
friction, torque constant, effort saturation; the URDF <transmission> import.

Independent checks: closed forms of one geared joint (I + N^2 J_r, N^2 b, N k_t),
Kane against Lagrange (``compare``), Pinocchio's ``armature`` and its kinematics for
the rotors' gyroscopic coupling on a UR5, and the identification regressor."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

import anadyn
from anadyn_cli.cli import main
from anadyn_cli.model import load_robot, robot_from_text
from anadyn_cli.model.urdf import import_file, import_urdf
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.studies.identification import estimate
from anadyn_cli.studies.identification.base import base_parameters
from anadyn_cli.symbolic.formulations import derive

REPO = Path(__file__).resolve().parent.parent
UR5 = REPO / "tests" / "data" / "urdf" / "ur5_robot.urdf"

# one link about a vertical axis: I_O = 0.05 + 2 * 0.5^2 = 0.55 about the joint
I_O, N, J_R, B_M, K_T, LIMIT = 0.55, 10.0, 0.002, 0.001, 0.2, 3.0
ONE = f"""\
name: one
parameters: {{N: {N}, Jr: {J_R}}}
gravity: [0, 0, -9.81]
coordinates:
  q: {{initial: 0.1}}
bodies:
  - name: link
    parent: ground
    joint: {{type: revolute, axis: [0, 0, 1], displacement: q}}
    mass: 2
    com: [0.5, 0, 0]
    inertia: {{ixx: 0.01, iyy: 0.05, izz: 0.05}}
actuators:
  m1:
    joint: link
    drive: {{gear: N, rotor_inertia: Jr, motor_damping: {B_M}, torque_constant: {K_T},
             effort_limit: {LIMIT}}}
controller:
  laws: {{m1: -50*q - 5*dq}}
simulation: {{t_end: 0.5, output_step: 0.01}}
"""


@pytest.fixture
def one(tmp_path):
    path = tmp_path / "one.yaml"
    path.write_text(ONE)
    return path


def test_one_geared_joint_closed_form_in_every_path(one):
    """M = I + N^2 J_r, F = -N^2 b dq, B = N k_t: Kane, Lagrange and the recursive path."""
    robot = load_robot(one)
    assert [b.name for b in robot.bodies] == ["link", "m1_rotor"]
    assert robot.actuators[0].unit == "A"
    for formulation in ("kane", "lagrange"):
        eom = derive(robot, formulation)
        dq = eom.dq[0]
        assert float(eom.M[0, 0]) == pytest.approx(I_O + N ** 2 * J_R, rel=1e-14)
        assert float(eom.F[0].diff(dq)) == pytest.approx(-N ** 2 * B_M, rel=1e-14)
        assert float(eom.B[0, 0]) == pytest.approx(N * K_T, rel=1e-14)
    for formulation, evaluator in ((None, "recursive"), ("kane", "closed-form"),
                                   ("lagrange", "closed-form")):
        model = numeric_model(robot, formulation, evaluator=evaluator)
        M, F, B = model.mfb(0.0, np.array([0.3]), np.array([0.5]))
        assert np.ravel(M) == pytest.approx([I_O + N ** 2 * J_R], rel=1e-13)
        assert np.ravel(F) == pytest.approx([-N ** 2 * B_M * 0.5], rel=1e-13)
        assert np.ravel(B) == pytest.approx([N * K_T], rel=1e-13)
        # the law -50 q - 5 dq = -17.5 A, saturated at -3 A
        assert np.ravel(model.efforts(0.0, np.array([0.3]), np.array([0.5]))) == [-LIMIT]


def test_a_gear_given_by_a_parameter_follows_it(one):
    """gear: N with N overridden (as sweeps do): the rotor and B both change."""
    robot = load_robot(one, parameters={"N": 20})
    for formulation, evaluator in ((None, "recursive"), ("kane", "closed-form")):
        M, _, B = numeric_model(robot, formulation, evaluator=evaluator).mfb(
            0.0, np.array([0.3]), np.array([0.0]))
        assert np.ravel(M) == pytest.approx([I_O + 20 ** 2 * J_R], rel=1e-13)
        assert np.ravel(B) == pytest.approx([20 * K_T], rel=1e-13)
    eom = derive(robot, "kane", symbolic=True)
    assert str(eom.B[0, 0]) == "N/5"                  # N k_t, k_t = 0.2 N*m/A

def test_motor_friction_is_smoothed_on_the_motor_rate(tmp_path):
    """Coulomb friction f on the motor side: N f tanh(N dq / v) on the joint."""
    path = tmp_path / "fric.yaml"
    path.write_text(ONE.replace(f"motor_damping: {B_M}", "motor_friction: 0.04, "
                                                         "friction_velocity: 0.5"))
    eom = derive(load_robot(path), "lagrange")
    value = float(eom.F[0].subs({eom.dq[0]: 0.01}))
    assert value == pytest.approx(-N * 0.04 * np.tanh(N * 0.01 / 0.5), rel=1e-13)


def test_compare_proves_kane_equals_lagrange_with_drives(tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", str(REPO / "robots" / "drives" / "rr_drives.yaml"),
                 "--out", str(out)]) == 0
    report = json.loads((out / "compare.json").read_text())
    assert report["mismatches"] == 0
    assert report["robots"]["rr_drives"]["symbolic"]["status"] == "zero"
    capsys.readouterr()


def _ur5_with_drives(gears: dict[str, float], inertias: dict[str, float]):
    data = import_file(UR5).data
    for name, gear in gears.items():
        data["actuators"][f"tau_{name}"]["drive"] = {"gear": gear,
                                                     "rotor_inertia": inertias[name]}
    return robot_from_text(yaml.safe_dump(data, sort_keys=False), "ur5_drives.yaml")


def _pinocchio_mass_matrix(q, armature):
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(UR5))
    model.armature = np.asarray(armature, float)
    data = model.createData()
    M = pin.crba(model, data, q)
    J = pin.computeJointJacobians(model, data, q)      # world frame: column k's angular
    return np.triu(M) + np.triu(M, 1).T, J[3:].T        # part is joint k's axis


def test_rotor_on_the_ground_is_pinocchios_armature():
    """The first joint's rotor sits on the fixed base: exactly Pinocchio's armature
    N^2 J_r added to M's diagonal."""
    names = ["shoulder_pan_joint"]
    robot = _ur5_with_drives({names[0]: 100.0}, {names[0]: 3e-5})
    model = numeric_model(robot, evaluator="recursive")
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, 6)
        ours = np.asarray(model.mfb(0.0, q, np.zeros(6))[0])
        theirs, _ = _pinocchio_mass_matrix(q, [100.0 ** 2 * 3e-5, 0, 0, 0, 0, 0])
        assert np.abs(ours - theirs).max() < 1e-12 * np.abs(theirs).max()


def test_rotors_on_moving_links_add_their_gyroscopic_coupling():
    """A rotor on a moving parent p turns at w_p.a + N dtheta: M = Pinocchio's M with
    armature N^2 J_r plus J_r [N (e_k c^T + c e_k^T) + c c^T], c_i = a_k.a_i for the
    joints i before k (the parent's angular velocity along the rotor's axis).  On the
    UR5 the shoulder-lift, elbow and wrist-1 axes are parallel: their rotors couple."""
    names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
             "wrist_2_joint", "wrist_3_joint"]
    gears = dict(zip(names, [100.0, 100.0, 80.0, 50.0, -50.0, 30.0]))
    inertias = dict(zip(names, [3e-5, 3e-5, 2e-5, 1e-5, 1e-5, 5e-6]))
    model = numeric_model(_ur5_with_drives(gears, inertias), evaluator="recursive")
    rng = np.random.default_rng(2)
    coupled = 0.0
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, 6)
        ours = np.asarray(model.mfb(0.0, q, np.zeros(6))[0])
        armature = [gears[n] ** 2 * inertias[n] for n in names]
        M, axes = _pinocchio_mass_matrix(q, armature)
        expected = M.copy()
        for k, name in enumerate(names):
            c = np.array([axes[k] @ axes[i] if i < k else 0.0 for i in range(6)])
            e = np.eye(6)[k]
            extra = inertias[name] * (gears[name] * (np.outer(e, c) + np.outer(c, e))
                                      + np.outer(c, c))
            expected += extra
            coupled = max(coupled, np.abs(extra).max())
        assert np.abs(ours - expected).max() < 1e-12 * np.abs(M).max()
        assert np.abs(ours - M).max() > 1e-3          # the armature alone is not it
    assert coupled > 1e-3


def test_saturation_shows_in_simulate(one, tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", str(one), "--no-plot", "--out", str(out)]) == 0
    with open(out / "simulate.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    effort = np.array([float(r["m1"]) for r in rows])
    q = np.array([float(r["q"]) for r in rows])
    dq = np.array([float(r["dq"]) for r in rows])
    law = -50 * q - 5 * dq
    assert np.abs(effort).max() == pytest.approx(LIMIT, rel=1e-12)
    assert np.abs(law).max() > LIMIT                      # the law asked for more
    assert np.allclose(effort, np.clip(law, -LIMIT, LIMIT), rtol=0, atol=1e-9)
    capsys.readouterr()


TRANSMISSION = """<robot name="geared">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/><origin xyz="0.5 0 0"/>
    <inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <transmission name="t1">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="motor1"><mechanicalReduction>RATIO</mechanicalReduction></actuator>
  </transmission>
</robot>
"""


def test_urdf_transmission_imports_the_gear(tmp_path, capsys):
    imported = import_urdf(TRANSMISSION.replace("RATIO", "50"), "geared.urdf")
    assert imported.data["actuators"] == {"tau_j1": {"joint": "arm",
                                                     "drive": {"gear": 50.0}}}
    robot = robot_from_text(imported.text, "geared.yaml")
    assert float(robot.actuators[0].scale) == 50.0
    unit = import_urdf(TRANSMISSION.replace("RATIO", "1"), "geared.urdf")
    assert "drive" not in unit.data["actuators"]["tau_j1"]      # ratio 1: no drive
    path = tmp_path / "zero.urdf"
    path.write_text(TRANSMISSION.replace("RATIO", "0"))
    assert main(["import", str(path), "--output", str(tmp_path / "z.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "zero.urdf" in err and "<transmission name='t1'>" in err and "non-zero" in err


@pytest.mark.parametrize("key, value, message", [
    ("gear", 0, "must not be 0"),
    ("rotor_inertia", -1, "must be 0 or positive (kg*m^2)"),
    ("motor_damping", -1, "must be 0 or positive (N*m*s/rad)"),
    ("motor_friction", -0.1, "must be 0 or positive (N*m)"),
    ("torque_constant", 0, "must be positive (N*m/A)"),
    ("effort_limit", -2, "must be positive (in the effort's unit)"),
    ("ratio", 2, "unknown key"),
])
def test_bad_drive_is_one_line(tmp_path, capsys, key, value, message):
    path = tmp_path / "bad.yaml"
    start, end = ONE.index("drive: {"), ONE.index("}", ONE.index("effort_limit")) + 1
    path.write_text(ONE[:start] + f"drive: {{{key}: {value}}}" + ONE[end:])
    assert main(["equations", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.yaml" in err
    assert f"actuators.m1.drive.{key}" in err and message in err


def test_identification_finds_the_armature(one):
    """Efforts from anadyn's inverse dynamics of the geared joint (recursive path),
    identified with the regressor (independent code): the joint's inertia base
    parameter is I + N^2 J_r and its viscous one N^2 b (efforts in A: divided by N k_t)."""
    robot = load_robot(one)
    model = anadyn.parametric_model(robot)
    numeric = numeric_model(robot, evaluator="recursive")
    t = np.linspace(0, 4, 201)
    q = 0.5 * np.sin(2 * t) + 0.2 * np.sin(5 * t)
    dq = np.cos(2 * t) + np.cos(5 * t)
    ddq = -2 * np.sin(2 * t) - 5 * np.sin(5 * t)
    tau = []
    for k in range(len(t)):
        M, F, B = (np.asarray(x, float).reshape(1, -1) for x in
                   numeric.mfb(t[k], q[k:k + 1], dq[k:k + 1]))
        tau.append(np.linalg.solve(B, M @ ddq[k:k + 1] - F.ravel()))
    tau = np.array(tau)
    assert tau[:, 0] == pytest.approx(((I_O + N ** 2 * J_R) * ddq + N ** 2 * B_M * dq)
                                      / (N * K_T), rel=1e-12)
    base = base_parameters(model)
    result = estimate.identify(model, estimate.Measurements(
        "one", t, q[:, None], dq[:, None], ddq[:, None], tau, "given"), base)
    values = dict(zip(base.base_names, result.estimate))
    inertia = next(v for name, v in values.items() if name.startswith("Izz_link"))
    viscous = next(v for name, v in values.items() if name.startswith("Fv_link"))
    assert inertia == pytest.approx(I_O + N ** 2 * J_R, rel=1e-9)
    assert viscous == pytest.approx(N ** 2 * B_M, rel=1e-9)


def test_without_the_rotor_body_identification_sees_N_times_N_minus_1():
    """rr's joint 2 with a rotor J_r behind gear N (on bar 1, a parallel axis), identified
    with rr.yaml (no drive): Ia_bar2 = N(N-1) J_r, Izz_bar2 + N J_r, Izz_bar1R + (1-N) J_r
    (the rotor's energy J_r (N dtheta2 + dtheta1)^2 / 2 split over the base parameters)."""
    N2, J2 = 10.0, 2e-4
    text = (REPO / "robots" / "rr.yaml").read_text().replace(
        "T12z: {joint: bar2}", f"T12z: {{joint: bar2, drive: {{gear: {N2}, "
                               f"rotor_inertia: {J2}}}}}")
    geared = numeric_model(robot_from_text(text, "rr_geared.yaml"), evaluator="recursive")
    model = anadyn.parametric_model("rr")
    t = np.linspace(0, 6, 301)
    q = np.stack([0.5 * np.sin(1.3 * t) + 0.3 * np.sin(3.1 * t),
                  0.7 * np.sin(2.1 * t) - 0.2 * np.cos(4.3 * t)], 1)
    dq = np.stack([0.65 * np.cos(1.3 * t) + 0.93 * np.cos(3.1 * t),
                   1.47 * np.cos(2.1 * t) + 0.86 * np.sin(4.3 * t)], 1)
    ddq = np.stack([-0.845 * np.sin(1.3 * t) - 2.883 * np.sin(3.1 * t),
                    -3.087 * np.sin(2.1 * t) + 3.698 * np.cos(4.3 * t)], 1)
    forces = np.array([np.asarray(M, float).reshape(2, 2) @ ddq[k] - np.ravel(F)
                       for k in range(len(t))
                       for M, F, _ in [geared.mfb(t[k], q[k], dq[k])]])
    tau = np.linalg.solve(model.B, forces.T).T              # rr's efforts, no drive
    base = base_parameters(model)
    result = estimate.identify(model, estimate.Measurements("rr", t, q, dq, ddq, tau,
                                                            "given"), base)
    found = dict(zip(base.base_names, result.estimate - base.of(model.nominal)))
    assert found["Ia_bar2"] == pytest.approx(N2 * (N2 - 1) * J2, rel=1e-9)
    assert found["Izz_bar2"] == pytest.approx(N2 * J2, rel=1e-9)
    assert found["Izz_bar1R"] == pytest.approx((1 - N2) * J2, rel=1e-9)


def test_mjcf_gear_is_the_drives_gear():
    """MuJoCo's gear: the law is the actuator force, the joint gets gear times it."""
    from anadyn_cli.model.mjcf import import_file as import_mjcf

    imported = import_mjcf(REPO / "robots" / "cartpole.xml")
    assert imported.data["actuators"]["slide"] == {"joint": "cart", "drive": {"gear": 10}}
    assert imported.data["controller"]["laws"]["slide"] == "min(max(u_slide, -1), 1)"
    robot = robot_from_text(imported.text, "cartpole.yaml")
    assert robot.actuators[0].unit == "N"                   # a linear motor: no rotor
    B = derive(robot, "kane").B
    assert [float(b) for b in B] == [10.0, 0.0]


def test_excite_keeps_the_drives_effort_limit_and_lets_the_rotors_turn():
    """excite bounds each actuator's effort by its drive's effort_limit (10 A, 5 N*m,
    times the margin 0.9) and lets a rotor turn N times a joint's default span: joint 1
    (gear 20) moves beyond pi/20."""
    result = anadyn.excite(REPO / "robots" / "drives" / "rr_drives.yaml", harmonics=2,
                           iterations=3, period=4)
    assert np.all(np.abs(result.efforts) <= np.array([10, 5]) * 0.9 + 1e-9)
    assert np.ptp(result.q[:, 0]) > 2 * np.pi / 20


def test_gain_derivatives_go_through_the_drive():
    """d(ddq)/d(gain) under the laws (recursive path) carries N k_t: against central
    differences; a parameter in the drive's scale (kt1) is refused, one ModelError."""
    path = REPO / "robots" / "drives" / "rr_drives.yaml"
    text = path.read_text()
    q, dq = np.array([0.52, 1.04]), np.array([0.01, -0.02])       # unsaturated
    got = np.ravel(anadyn.derivatives(path, native=False, parameters=["g01"])
                   .closed_loop_parameter_derivatives(0.0, q, dq))

    def ddq(value):
        robot = robot_from_text(text.replace("g01: 300", f"g01: {value!r}"), "g.yaml")
        return numeric_model(robot, evaluator="recursive").rhs(0.0, np.r_[q, dq])[2:]

    assert got == pytest.approx((ddq(300 + 1e-4) - ddq(300 - 1e-4)) / 2e-4, rel=1e-6)
    with pytest.raises(anadyn.ModelError, match="kt1 enters actuator T01z's drive"):
        anadyn.derivatives(path, native=False, parameters=["kt1"]) \
            .closed_loop_parameter_derivatives(0.0, q, dq)
