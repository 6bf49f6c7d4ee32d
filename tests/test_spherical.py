"""Spherical joints (``model.joints.Spherical``: a unit quaternion, scalar first, and
the body's angular velocity in body axes as its speeds) against independent
sources:

- Pinocchio 4.1 (``JointModelSpherical``: q = (x, y, z, w), v the angular
  velocity in the joint's own frame), the same robots built by hand from the
  same numbers: the mass matrix (CRBA), inverse dynamics (RNEA) and forward
  dynamics (ABA, and CRBA with the sparse Cholesky solve) at 20 random states to
  1e-9 relative, on a spherical root and on a revolute -> spherical -> revolute
  chain with offsets, rpy and full inertias;
- closed forms: a torque-free asymmetric rigid body (energy and angular momentum
  in world axes conserved to 1e-9 over 100 s), the spherical pendulum's energy
  and vertical angular momentum, the quaternion norm kept at 1;
- the robot-file checks (one line, exit 2) and the commands that refuse.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli import load_robot, robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.errors import ModelError
from anadyn_cli.numeric import recursive
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.numeric.model import run_generated
from anadyn_cli.services.simulate import simulate

pin = pytest.importorskip("pinocchio")

REPO = Path(__file__).resolve().parent.parent

REL = 1e-9

# a revolute joint, a spherical joint off its axis with rpy, a revolute joint after it
CHAIN = """
name: chain
gravity: [0.3, -0.2, -9.81]
coordinates:
  q1: {initial: 0.1}
  q2: {initial: -0.2}
  qw: {initial: 1}
speeds:
  wz: {initial: 0.3}
bodies:
  - name: base
    joint: {type: revolute, axis: [0, 0, 1], origin: [0.1, 0, 0.2]}
    mass: 1.3
    com: [0.05, 0.02, 0.1]
    inertia: {ixx: 0.02, iyy: 0.03, izz: 0.025, ixy: 0.001, ixz: -0.002, iyz: 0.0015}
  - name: ball
    parent: base
    joint: {type: spherical, origin: [0.3, 0.1, -0.05], rpy: [0.2, -0.3, 0.5],
            coordinates: [qw, qx, qy, qz], speeds: [wx, wy, wz]}
    mass: 0.9
    com: [0.1, -0.05, 0.2]
    inertia: {ixx: 0.011, iyy: 0.014, izz: 0.009, ixy: 0.0007, ixz: 0.0004, iyz: -0.0011}
  - name: tip
    parent: ball
    joint: {type: revolute, axis: [0.6, 0, 0.8], origin: [0, 0.2, 0.3], rpy: [0.4, 0.1, -0.2],
            displacement: q2}
    mass: 0.5
    com: [0.02, 0.1, 0.03]
    inertia: {ixx: 0.004, iyy: 0.005, izz: 0.006, ixy: -0.0003, ixz: 0.0002, iyz: 0.0001}
"""

ROOT = """
name: root
gravity: [0, 0, -9.81]
coordinates:
  q1: {initial: 0}
  a: {initial: 0.5}
  b: {initial: 0.5}
  c: {initial: 0.5}
  d: {initial: 0.5}
bodies:
  - name: top
    joint: {type: spherical, origin: [0, 0, 1], coordinates: [a, b, c, d]}
    mass: 2.0
    com: [0.1, 0.2, -0.4]
    inertia: {ixx: 0.05, iyy: 0.07, izz: 0.03, ixy: 0.004, ixz: 0.002, iyz: -0.003}
  - name: arm
    parent: top
    joint: {type: revolute, axis: [0, 1, 0], origin: [0, 0, -0.8], displacement: q1}
    mass: 0.7
    com: [0.3, 0, 0]
    inertia: {ixx: 0.001, iyy: 0.02, izz: 0.02}
"""


# a floating base as the loader writes one: slides along the world's x, y, z on
# massless links, then a spherical joint; an arm on it
FLOATING = """
name: floating
gravity: [0, 0, -9.81]
coordinates:
  x: {initial: 0.1}
  y: {initial: -0.2}
  z: {initial: 0.5}
  q1: {initial: 0.3}
bodies:
  - {name: slide_x, joint: {type: prismatic, axis: [1, 0, 0], displacement: x}, mass: 0}
  - {name: slide_y, parent: slide_x, joint: {type: prismatic, axis: [0, 1, 0],
     displacement: y}, mass: 0}
  - {name: slide_z, parent: slide_y, joint: {type: prismatic, axis: [0, 0, 1],
     displacement: z}, mass: 0}
  - name: base
    parent: slide_z
    joint: {type: spherical}
    mass: 5.0
    com: [0.02, -0.01, 0.03]
    inertia: {ixx: 0.1, iyy: 0.15, izz: 0.2, ixy: 0.01, ixz: -0.005, iyz: 0.002}
  - name: arm
    parent: base
    joint: {type: revolute, axis: [0, 1, 0], origin: [0.2, 0, 0.1], displacement: q1}
    mass: 1.0
    com: [0.25, 0, 0]
    inertia: {ixx: 0.001, iyy: 0.02, izz: 0.02}
"""


def _rpy(r, p, y):
    def rot(axis, angle):
        return pin.AngleAxis(angle, np.array(axis, dtype=float)).toRotationMatrix()
    return rot([0, 0, 1], y) @ rot([0, 1, 0], p) @ rot([1, 0, 0], r)


def _pinocchio(robot):
    """The robot as a Pinocchio model, and (joint kind, its q and v indices there)
    per body; anadyn's numbers (parameters substituted) rebuilt by hand."""
    values = robot.parameter_substitution()
    number = lambda e: float(e.xreplace(values))  # noqa: E731
    model = pin.Model()
    model.gravity.linear = np.array([number(g) for g in robot.gravity])
    ids = {"ground": 0}
    for body in robot.bodies:
        joint = body.joint
        placement = pin.SE3(_rpy(*(number(a) for a in joint.rpy)),
                            np.array([number(o) for o in joint.origin]))
        if joint.type == "spherical":
            jm = pin.JointModelSpherical()
        else:
            axis = np.array([number(a) for a in joint.axis])
            unaligned = (pin.JointModelRevoluteUnaligned if joint.type == "revolute"
                         else pin.JointModelPrismaticUnaligned)
            jm = unaligned(axis / np.linalg.norm(axis))
        jid = model.addJoint(ids[body.parent], jm, placement, body.name)
        inertia = np.array([[number(e) for e in row] for row in body.inertia.tolist()])
        model.appendBodyToJoint(jid, pin.Inertia(number(body.mass),
                                                 np.array([number(c) for c in body.com]),
                                                 inertia), pin.SE3.Identity())
        ids[body.name] = jid
    return model


def _maps(robot, model):
    """anadyn's state x = [q, u] <-> Pinocchio's (q, v): index arrays."""
    coordinates = [c.name for c in robot.coordinates]
    speeds = [u.name for u in robot.speeds]
    q_of, v_of = np.zeros(model.nq, int), np.zeros(model.nv, int)
    for body in robot.bodies:
        jm = model.joints[model.getJointId(body.name)]
        if body.joint.type == "spherical":
            w, x, y, z = (coordinates.index(n) for n in body.joint.coordinates)
            q_of[jm.idx_q:jm.idx_q + 4] = [x, y, z, w]        # Pinocchio: (x, y, z, w)
            v_of[jm.idx_v:jm.idx_v + 3] = [speeds.index(u.name) for u in body.joint.speeds]
        else:
            name = str(body.joint.displacement)
            q_of[jm.idx_q] = coordinates.index(name)
            v_of[jm.idx_v] = speeds.index("d" + name)
    return q_of, v_of


def _random_state(robot, rng):
    q = rng.uniform(-1.5, 1.5, len(robot.coordinates))
    for body in robot.bodies:
        if body.joint.type == "spherical":
            index = [[c.name for c in robot.coordinates].index(n) for n in body.joint.coordinates]
            quaternion = rng.normal(size=4)
            q[index] = quaternion / np.linalg.norm(quaternion)
    return q, rng.uniform(-2, 2, len(robot.speeds)), rng.uniform(-3, 3, len(robot.speeds))


def _aba(robot):
    """The articulated-body algorithm's traced code alone (``forward`` may choose
    CRBA + Cholesky for the model's accelerations)."""
    traced = recursive.trace_aba(recursive.plan(robot))
    assert traced is not None
    source = recursive.PY_HEADER + "\n".join(recursive._python_function(traced, False, ""))
    return run_generated(source)["accelerations"]


def _rel(a, b):
    return float(np.abs(np.asarray(a) - b).max() / max(1.0, np.abs(b).max()))


@pytest.mark.parametrize("text", [CHAIN, ROOT, FLOATING],
                         ids=["revolute-spherical-revolute", "root", "floating"])
def test_mass_matrix_inverse_and_forward_dynamics_match_pinocchio(text):
    robot = robot_from_text(text, "spherical.yaml")
    model = numeric_model(robot)
    pm = _pinocchio(robot)
    data = pm.createData()
    q_of, v_of = _maps(robot, pm)
    aba = _aba(robot)
    rng = np.random.default_rng(24)
    worst = {"M": 0.0, "ID": 0.0, "ABA": 0.0, "CRBA": 0.0}
    for _ in range(20):
        q, u, du = _random_state(robot, rng)
        pq, pv, pa = q[q_of], u[v_of], du[v_of]
        M_pin = pin.crba(pm, data, pq)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        M, _, _ = model.mfb(0.0, q, u)
        worst["M"] = max(worst["M"], _rel(M[np.ix_(v_of, v_of)], M_pin))
        ID, _ = model.demand(0.0, q, u, du)
        worst["ID"] = max(worst["ID"], _rel(np.asarray(ID)[v_of], pin.rnea(pm, data, pq, pv, pa)))
        expected = pin.aba(pm, data, pq, pv, np.zeros(pm.nv))
        ours = np.array(aba(0.0, *q, *u))
        worst["ABA"] = max(worst["ABA"], _rel(ours[v_of], expected))
        cholesky = model.driven_accelerations(0.0, np.concatenate([q, u]), [])
        worst["CRBA"] = max(worst["CRBA"], _rel(cholesky[v_of], expected))
    assert max(worst.values()) < REL, worst


def test_a_quaternion_of_any_norm_gives_the_same_motion():
    """R(q) is written for a quaternion of any norm (divided by |q|^2)."""
    robot = robot_from_text(CHAIN, "chain.yaml")
    model = numeric_model(robot)
    rng = np.random.default_rng(3)
    q, u, _ = _random_state(robot, rng)
    scaled = q.copy()
    scaled[-4:] *= 1.7
    a = np.array(model.accelerations(0.0, np.concatenate([q, u])))
    b = np.array(model.accelerations(0.0, np.concatenate([scaled, u])))
    assert _rel(a, b) < 1e-12


def _world_momentum(robot, x):
    """Angular momentum of a body on a spherical joint at its centre of mass, world
    axes: R(q) I w."""
    values = robot.parameter_substitution()
    inertia = np.array(robot.bodies[0].inertia.xreplace(values).tolist(), dtype=float)
    w, a, b, c = x[:4]
    R = np.array([[w*w + a*a - b*b - c*c, 2*(a*b - w*c), 2*(a*c + w*b)],
                  [2*(a*b + w*c), w*w - a*a + b*b - c*c, 2*(b*c - w*a)],
                  [2*(a*c - w*b), 2*(b*c + w*a), w*w - a*a - b*b + c*c]]) / (x[:4] @ x[:4])
    return R @ inertia @ x[4:7]


def test_the_torque_free_body_keeps_energy_and_angular_momentum():
    robot = load_robot(REPO / "robots/tumbling_box.yaml")
    model = numeric_model(robot)
    result = simulate(model, t_end=100.0, output_step=0.5, rtol=1e-12, atol=1e-14)
    assert result.solution.success
    x = result.x
    T, V = model.energy(x[:, :4].T, x[:, 4:].T)
    energy = T + V
    assert np.abs(energy - energy[0]).max() < 1e-9 * abs(energy[0])
    L = np.array([_world_momentum(robot, row) for row in x])
    assert np.abs(L - L[0]).max() < 1e-9 * np.linalg.norm(L[0])
    assert np.abs(np.linalg.norm(x[:, :4], axis=1) - 1).max() < 1e-12
    assert result.quaternion_drift < 1e-8        # the integrated norm [1.9e-9]
    # spun near the intermediate axis, it flips: wy changes sign during the run
    assert x[:, 5].min() < -1.5 and x[:, 5].max() > 1.5


def test_the_box_flips_at_the_period_of_the_elliptic_function_solution():
    """Euler's torque-free body (Landau and Lifshitz, Mechanics, section 37): with
    I1 < I2 < I3, 2E = I w.w, L^2 = |I w|^2 and L^2 < 2E I2 (else 1 and 3 swap), the
    speeds are Jacobi elliptic functions of lambda t with modulus k,

        lambda^2 = (I1 - I2)(L^2 - 2E I3) / (I1 I2 I3),
        k^2 = (I2 - I3)(2E I1 - L^2) / ((I1 - I2)(L^2 - 2E I3)),

    and w_y (~ sn) changes sign every 2 K(k) / lambda."""
    from fractions import Fraction
    from scipy.special import ellipkm1

    robot = load_robot(REPO / "robots/tumbling_box.yaml")
    result = simulate(numeric_model(robot), t_end=30.0, output_step=0.001, rtol=1e-12,
                      atol=1e-14)
    t, wy = result.t, result.x[:, 5]
    k = np.flatnonzero(np.sign(wy[1:]) != np.sign(wy[:-1]))
    flips = t[k] - wy[k] * (t[k + 1] - t[k]) / (wy[k + 1] - wy[k])
    values = {s.name: Fraction(str(float(v))) for s, v in robot.parameter_substitution().items()}
    m, a, b, c = (values[name] for name in "mabc")
    I = [m * (b * b + c * c) / 12, m * (a * a + c * c) / 12, m * (a * a + b * b) / 12]
    w = [Fraction(str(float(u.initial))) for u in robot.speeds]
    E2 = sum(i * x * x for i, x in zip(I, w))
    L2 = sum(i * i * x * x for i, x in zip(I, w))
    I1, I2, I3 = I if L2 < E2 * I[1] else I[::-1]
    denominator = (I1 - I2) * (L2 - E2 * I3)
    rate = math.sqrt(denominator / (I1 * I2 * I3))
    one_minus_k2 = float((denominator - (I2 - I3) * (E2 * I1 - L2)) / denominator)
    half_period = 2 * ellipkm1(one_minus_k2) / rate            # 5.1226 s
    assert len(flips) >= 5
    assert np.abs(np.diff(flips) / half_period - 1).max() < 1e-8       # [2.6e-11]


def test_the_spherical_pendulum_keeps_energy_and_vertical_momentum():
    robot = load_robot(REPO / "robots/spherical_pendulum.yaml")
    model = numeric_model(robot)
    result = simulate(model, rtol=1e-11, atol=1e-13)
    assert result.solution.success
    x = result.x
    T, V = model.energy(x[:, :4].T, x[:, 4:].T)
    assert np.abs(T + V - (T[0] + V[0])).max() < 1e-8
    # about the pivot (on the vertical through it) gravity has no moment: L_z constant
    values = robot.parameter_substitution()
    m, L = float(values[next(s for s in values if s.name == "m")]), 1.0
    inertia = np.diag([m * L**2 / 3, m * L**2 / 3, m * L**2 / 1200])   # about the pivot
    Lz = []
    for row in x:
        w, a, b, c = row[:4]
        R = np.array([[w*w + a*a - b*b - c*c, 2*(a*b - w*c), 2*(a*c + w*b)],
                      [2*(a*b + w*c), w*w - a*a + b*b - c*c, 2*(b*c - w*a)],
                      [2*(a*c - w*b), 2*(b*c + w*a), w*w - a*a - b*b + c*c]])
        Lz.append((R @ inertia @ row[4:7])[2])
    assert np.ptp(Lz) < 1e-8


def test_simulate_writes_the_quaternion_and_speeds_and_reports_the_drift(tmp_path):
    out = tmp_path / "run"
    assert main(["simulate", str(REPO / "robots/spherical_pendulum.yaml"), "--t-end", "1",
                 "--no-plot", "--out", str(out)]) == 0
    header = (out / "simulate.csv").read_text().splitlines()[0].split(",")
    assert header == ["t", "qw", "qx", "qy", "qz", "wx", "wy", "wz"]
    summary = json.loads((out / "simulate.json").read_text())
    assert 0 <= summary["quaternion_drift"] < 1e-8
    assert set(summary["final"]) == set(header[1:])


def _robot(tmp_path, joint: str, extra: str = "", coordinates: str = "qw: {initial: 1}"):
    path = tmp_path / "bad.yaml"
    path.write_text(f"""
coordinates:
  {coordinates}
{extra}
bodies:
  - name: ball
    joint: {joint}
    mass: 1
    com: [0, 0, -1]
    inertia: {{ixx: 0.1, iyy: 0.1, izz: 0.1}}
""")
    return str(path)


BAD = [
    ("{type: spherical, axis: [0, 0, 1]}", "", "qw: {initial: 1}",
     "bodies[0].joint.axis: a spherical joint takes no axis"),
    ("{type: spherical}", "", "ball_qw: {initial: 0}",
     "is zero"),
    ("{type: spherical}", "", "ball_qw: {initial: 0.9}",
     "has norm 0.9"),
    ("{type: spherical, coordinates: [a, b, c]}", "", "a: {initial: 1}",
     "a spherical joint has 4 coordinates (qw, qx, qy, qz), got 3"),
    ("{type: spherical, speeds: [g, wy, wz]}", "parameters: {g: 9.81}", "ball_qw: {initial: 1}",
     "name 'g' is already used by a parameter"),
    ("{type: spherical}", "speeds: {wx: {initial: 1}}", "ball_qw: {initial: 1}",
     "speeds.wx: 'wx' is not a speed of a spherical joint"),
    ("{type: spherical}", "", "ball_qw: {initial: 1, rate: 2}",
     "a quaternion coordinate has no rate of its own"),
]


@pytest.mark.parametrize("joint, extra, coordinates, message", BAD)
def test_bad_spherical_joints_get_one_line(tmp_path, capsys, joint, extra, coordinates, message):
    path = _robot(tmp_path, joint, extra, coordinates)
    assert main(["simulate", path, "--no-plot", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert "bad.yaml" in err and message in err, err
    assert not (tmp_path / "o").exists()


def test_a_nearly_unit_quaternion_is_made_unit_with_a_warning(tmp_path, capsys):
    path = _robot(tmp_path, "{type: spherical}", "", "ball_qw: {initial: 1.0000001}")
    assert main(["simulate", path, "--t-end", "0.1", "--no-plot",
                 "--out", str(tmp_path / "o")]) == 0
    assert "norm 1.0000001; made unit" in capsys.readouterr().err
    path = _robot(tmp_path, "{type: spherical}", "", "ball_qw: {initial: 0.9999998}")
    with pytest.warns(UserWarning, match="made unit"):      # the library: a Python warning
        robot = load_robot(path)
    assert math.isclose(sum(float(c.initial) ** 2 for c in robot.coordinates), 1.0,
                        rel_tol=1e-15)


def test_default_names_and_a_colliding_quaternion_name(tmp_path):
    robot = load_robot(_robot(tmp_path, "{type: spherical}", "", "ball_qx: {initial: 0}"))
    assert [c.name for c in robot.coordinates] == ["ball_qw", "ball_qx", "ball_qy", "ball_qz"]
    assert [u.name for u in robot.speeds] == ["ball_wx", "ball_wy", "ball_wz"]
    with pytest.raises(ModelError, match="already used by a parameter"):
        robot_from_text("parameters: {a: 1}\ncoordinates: {q: {initial: 0}}\nbodies:\n"
                        "  - {name: b, joint: {type: spherical, coordinates: [a, x, y, z]},"
                        " mass: 1}\n", "x.yaml")


def test_a_robot_without_spherical_joints_keeps_its_rates_as_speeds():
    robot = load_robot(REPO / "robots/rr.yaml")
    assert [u.name for u in robot.speeds] == ["dq1", "dq2"]
    assert not robot.spherical
    model = numeric_model(robot)
    assert model.speeds == ("dq1", "dq2") and model.nq == model.n == 2


REFUSED = [["export", "--lang", "c", "--derivatives"], ["export", "--lang", "casadi"],
           ["optimize", "--duration", "1", "--to", "qw=1"]]


@pytest.mark.parametrize("command", REFUSED, ids=lambda c: " ".join(c))
def test_what_needs_closed_forms_or_coordinate_rates_refuses_a_spherical_joint(
        tmp_path, monkeypatch, capsys, command):
    robot = str(REPO / "robots/spherical_pendulum.yaml")
    monkeypatch.chdir(tmp_path)
    code = main([command[0], robot, *command[1:]])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "spherical joint" in err, err
    assert "spherical_pendulum.yaml" in err
    assert not (tmp_path / "results").exists() or not any((tmp_path / "results").rglob("*.*"))


def test_the_c_library_gives_the_generated_pythons_bits(tmp_path, monkeypatch):
    """x = [q, u] in C too: rhs = [W(q) u, du] (``native.emit``: the traced rates)."""
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import native

    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path))
    robot = robot_from_text(CHAIN, "chain.yaml")
    generated = recursive.generate(robot)
    c_text = native.c_source(generated)
    assert "#define NQ 6" in c_text and "rates(t, x, out)" in c_text
    model = native.recursive_model(RobotInfo.from_robot(robot), recursive.module_source(generated),
                                   c_text, None, {}, how="wait")
    if not isinstance(model, native.NativeModel):
        pytest.skip(f"no C library: {model.native_note}")
    python = numeric_model(robot)
    assert type(python).__name__ == "RecursiveModel"
    rng = np.random.default_rng(5)
    for _ in range(5):
        q, u, _ = _random_state(robot, rng)
        x = np.concatenate([q, u])
        assert np.array_equal(model.rhs(0.0, x), python.rhs(0.0, x))
    assert model.jacobian(0.0, x).shape == (len(x), len(x))


BALL = """
name: ball
gravity: [0.5, -0.3, -9.81]
coordinates:
  qw: {initial: 1}
bodies:
  - name: bob
    joint: {type: spherical, origin: [0.1, 0.2, 1.0], rpy: [0.3, -0.4, 0.7],
            coordinates: [qw, qx, qy, qz], speeds: [wx, wy, wz]}
    mass: 1.7
    com: [0.2, -0.1, -0.6]
    inertia: {ixx: 0.05, iyy: 0.07, izz: 0.03, ixy: 0.004, ixz: -0.002, iyz: 0.003}
"""


def test_kanes_method_with_a_quaternion_agrees():
    """sympy.physics.mechanics as an oracle: a rigid body oriented by a quaternion in a
    frame turned by the joint's rpy, its angular velocity in body axes as the speeds,
    q' = 1/2 q (x) (0, w) as the kinematic differential equations (KanesMethod)."""
    import sympy as sp
    from sympy.physics.mechanics import (KanesMethod, Point, ReferenceFrame, RigidBody,
                                         dynamicsymbols, inertia)

    from anadyn_cli.symbolic.kinematics import rpy_rotation

    q = dynamicsymbols("q0:4")
    u = dynamicsymbols("u0:3")
    N = ReferenceFrame("N")
    J = ReferenceFrame("J")
    J.orient_body_fixed(N, (0.7, -0.4, 0.3), "ZYX")        # Rz(yaw) Ry(pitch) Rx(roll)
    assert np.allclose(np.array(N.dcm(J), float),
                       np.array(rpy_rotation([0.3, -0.4, 0.7]), float))
    B = ReferenceFrame("B")
    B.orient_quaternion(J, q)
    B.set_ang_vel(N, u[0] * B.x + u[1] * B.y + u[2] * B.z)
    pivot = Point("P")
    pivot.set_vel(N, 0)
    G = pivot.locatenew("G", 0.2 * B.x - 0.1 * B.y - 0.6 * B.z)
    G.v2pt_theory(pivot, N, B)
    body = RigidBody("bob", G, B, 1.7, (inertia(B, 0.05, 0.07, 0.03, 0.004, 0.003, -0.002), G))
    w, x, y, z = q
    a, b, c = u
    rates = [-(x * a + y * b + z * c) / 2, (w * a + y * c - z * b) / 2,
             (w * b + z * a - x * c) / 2, (w * c + x * b - y * a) / 2]
    kane = KanesMethod(N, q_ind=q, u_ind=u,
                       kd_eqs=[qi.diff() - r for qi, r in zip(q, rates)])
    gravity = 1.7 * (0.5 * N.x - 0.3 * N.y - 9.81 * N.z)
    kane.kanes_equations([body], [(G, gravity)])
    symbols = sp.symbols("q0:4 u0:3")
    plain = dict(zip([*q, *u], symbols))
    mass = sp.lambdify(symbols, kane.mass_matrix.xreplace(plain))
    forcing = sp.lambdify(symbols, kane.forcing.xreplace(plain))

    model = numeric_model(robot_from_text(BALL, "ball.yaml"))
    rng = np.random.default_rng(11)
    for _ in range(10):
        quaternion = rng.normal(size=4)
        quaternion /= np.linalg.norm(quaternion)
        speeds = rng.uniform(-2, 2, 3)
        state = (*quaternion, *speeds)
        M = np.array(mass(*state), float)
        expected = np.linalg.solve(M, np.array(forcing(*state), float).ravel())
        ours = model.accelerations(0.0, np.array(state))
        assert _rel(ours, expected) < REL
        assert _rel(model.mfb(0.0, quaternion, speeds)[0], M) < REL


ACTUATED = """
gravity: [0, 0, -9.81]
coordinates:
  q1: {initial: 0.2}
  qw: {initial: 1}
speeds:
  ball_wx: {initial: 0.3}
bodies:
  - name: arm
    joint: {type: revolute, axis: [0, 0, 1], displacement: q1, damping: 0.05,
            friction: 0.02}
    mass: 1
    com: [0.3, 0, 0]
    inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}
  - name: ball
    parent: arm
    joint: {type: spherical, origin: [0.6, 0, 0], coordinates: [qw, qx, qy, qz]}
    mass: 1
    com: [0, 0, -0.5]
    inertia: {ixx: 0.02, iyy: 0.03, izz: 0.01}
actuators:
  drive: {joint: arm}
controller:
  laws:
    drive: -2*dq1 - 5*q1 + 0.1*ball_wx + qz
loads:
  - {body: ball, point: [0, 0, -0.5], force: [0.1*ball_wy, 0, 0.2*sin(t)], torque: [0, 0.05, 0],
     frame: body}
simulation: {t_end: 2, output_step: 0.01}
"""


def test_laws_and_loads_of_the_speeds_balance_the_energy(tmp_path, capsys):
    """Control laws and loads may use the speeds; check's energy balance (the loads'
    power and the dissipated power traced by ``recursive.power``) closes."""
    path = tmp_path / "actuated.yaml"
    path.write_text(ACTUATED)
    assert main(["check", str(path), "--out", str(tmp_path / "c")]) == 0, capsys.readouterr().err
    report = json.loads((tmp_path / "c" / "check.json").read_text())
    assert report["passed"] and report["energy_error"] < 1e-8
    path.write_text(ACTUATED.replace("0.1*ball_wx + qz", "dqz"))     # no rate of a quaternion
    assert main(["simulate", str(path), "--out", str(tmp_path / "s")]) == 2
    assert "unknown name 'dqz'" in capsys.readouterr().err


def test_the_columns_are_the_velocity_of_the_transform_along_the_kinematic_equations():
    """``joints.Spherical``: moving q along dq = W(q) e_k (``coordinate_rates``) turns
    the body's frame (``transform``) at the body-axes angular velocity S e_k
    (``columns``): the three places that define the joint agree, in NumPy and SymPy."""
    import sympy as sp

    from anadyn_cli.model.joints import JOINT_TYPES
    from anadyn_cli.symbolic.kinematics import rpy_rotation

    kind = JOINT_TYPES["spherical"]
    C = np.array(rpy_rotation([0.3, -0.2, 0.9]), dtype=float)
    origin = np.array([0.1, 0.2, 0.3])
    quaternion = np.array([0.4, -0.3, 0.8, 0.2])
    quaternion /= np.linalg.norm(quaternion)
    eps = 1e-6
    for k, (angular, linear) in enumerate(kind.columns(None)):
        rate = np.array(kind.coordinate_rates(quaternion, np.eye(3)[k]))
        (R0, o0), (R1, _), (R2, _) = (kind.transform(C, origin, None, quaternion + h * rate,
                                                     None) for h in (0.0, -eps, eps))
        S = R0.T @ (R2 - R1) / (2 * eps)
        assert np.allclose([S[2, 1], S[0, 2], S[1, 0]], angular, atol=1e-9) and linear is None
        assert np.allclose(R0.T @ R0, np.eye(3)) and np.array_equal(o0, origin)
    assert abs(rate @ quaternion) < 1e-15                  # the norm does not change
    symbols = sp.symbols("w x y z", real=True)
    R, _ = kind.transform(sp.Matrix(C), sp.Matrix(origin), None, symbols, None)
    values = dict(zip(symbols, 2.5 * quaternion))           # any norm: the same rotation
    assert np.allclose(np.array(R.xreplace(values), dtype=float), R0)


@pytest.mark.parametrize("text", [CHAIN, FLOATING], ids=["chain", "floating"])
def test_the_state_jacobian_is_the_derivative_of_the_state_derivative(text):
    """The analytic d(x')/dx (``dynamics_jacobian``: K, and R = d(W(q) u)/dx for the
    quaternion's rows) against central differences of rhs."""
    robot = robot_from_text(text, "spherical.yaml")
    model = numeric_model(robot)
    rng = np.random.default_rng(8)
    q, u, _ = _random_state(robot, rng)
    x = np.concatenate([q, u])
    J = model.jacobian(0.0, x)
    h = 1e-6
    columns = [(model.rhs(0.0, x + h * e) - model.rhs(0.0, x - h * e)) / (2 * h)
               for e in np.eye(len(x))]
    assert _rel(J, np.array(columns).T) < 1e-7
    assert model.problem().jacobian is not None


def test_a_quaternion_coordinate_moves_no_other_joint():
    text = """
coordinates:
  q1: {}
bodies:
  - {name: ball, joint: {type: spherical}, mass: 1, com: [0, 0, -1],
     inertia: {ixx: 0.1, iyy: 0.1, izz: 0.1}}
  - {name: arm, parent: ball, joint: {type: revolute, axis: [0, 0, 1],
     displacement: q1 + ball_qx}, mass: 1, com: [1, 0, 0]}
"""
    with pytest.raises(ModelError, match=r"bodies\[1\]\.joint: uses the quaternion coordinate "
                                         r"'ball_qx'"):
        robot_from_text(text, "x.yaml")
