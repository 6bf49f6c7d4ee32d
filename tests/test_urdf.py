"""URDF import against Pinocchio, an independent implementation, and every
class of bad input.

Oracle: Pinocchio loads the same file (``buildModelFromUrdf``; fixed joints
merged, mimic joints as independent joints).  anadyn's coordinates q map to
Pinocchio's joint displacements theta = J q + c (J = d theta / dq: the
identity for independent joints, the multipliers for mimic joints), so

    M_anadyn = J^T CRBA(theta) J,
    tau_anadyn(q, dq, ddq) = J^T RNEA(theta, J dq, J ddq)

(an actuator acts along its own joint only, so B = I and tau = M ddq - F).
Joint damping and friction are left out of that comparison (Pinocchio's
algorithms have none); the simulations add them to Pinocchio's side exactly
as anadyn's robot model states them, when the loaded joints carry them.
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
import yaml

from anadyn_cli.cli import main
from anadyn_cli.model import robot_from_text
from anadyn_cli.model.urdf import (combine, import_file, import_urdf, matrix_rpy,
                                   nearest_valid_moments, rpy_matrix, MassProperties)

pin = pytest.importorskip("pinocchio")

DATA = Path(__file__).parent / "data" / "urdf"
URDFS = sorted(DATA.glob("*.urdf"))
TOLERANCE = 1e-9            # relative agreement with Pinocchio
STATES = 20
MEASURED: dict[str, dict[str, float]] = {}


# -- the oracle ----------------------------------------------------------------------
class Oracle:
    """anadyn's numeric M, F, B for an imported URDF and Pinocchio's model of the file.

    ``method``: "recursive" is what the commands run on a tree (the Newton-Euler
    recursions, generated code); "kane" and "lagrange" are the closed forms derived
    symbolically by each formulation."""

    def __init__(self, path: Path, method: str = "recursive", joint_forces: bool = False):
        imported = import_file(path)
        data = imported.data
        if not joint_forces:           # rigid-body dynamics only (Pinocchio has no damping)
            for body in data["bodies"]:
                body["joint"].pop("damping", None)
                body["joint"].pop("friction", None)
        self.robot = robot_from_text(yaml.safe_dump(data, sort_keys=False), str(path))
        self.mfb = _anadyn_mfb(self.robot, method)
        self.demand = _anadyn_demand(self.robot) if method == "recursive" else None
        self.model = pin.buildModelFromUrdf(str(path))
        self.data = self.model.createData()
        self.theta, self.J = self.coupling(path)

    def coupling(self, path: Path):
        """theta(q) and J = d theta/dq, Pinocchio's joints (1..) in terms of anadyn's q,
        read from the loaded robot: URDF joint -> child link -> anadyn body -> displacement."""
        child = {j.get("name"): j.find("child").get("link")
                 for j in ET.parse(path).getroot().findall("joint")}
        self.bodies = [_identifier(child[name]) for name in self.model.names[1:]]
        q = self.robot.q
        rows, constants = [], []
        for name in self.bodies:
            body = self.robot.body(name)
            displacement = body.joint.displacement
            rows.append([float(sp.diff(displacement, s)) for s in q])
            constants.append(float(displacement.subs({s: 0 for s in q})))
        return (lambda x: np.array(rows) @ x + np.array(constants)), np.array(rows)

    def configuration(self, theta: np.ndarray) -> np.ndarray:
        """Pinocchio's q from joint displacements (continuous joints: cos, sin)."""
        config = np.zeros(self.model.nq)
        for j in range(1, self.model.njoints):
            joint, value = self.model.joints[j], theta[self.model.joints[j].idx_v]
            if joint.nq == 2:
                config[joint.idx_q:joint.idx_q + 2] = (math.cos(value), math.sin(value))
            else:
                config[joint.idx_q] = value
        return config

    def random_state(self, rng: np.random.Generator):
        n = len(self.robot.q)
        q = np.array([rng.uniform(-math.pi, math.pi) if c.unit == "rad" else rng.uniform(-0.2, 0.2)
                      for c in self.robot.coordinates])
        return q, rng.normal(0, 2, n), rng.normal(0, 5, n)

    def anadyn(self, q, dq, ddq):
        """M, and tau solving B tau = M ddq - F: by the recursive Newton-Euler algorithm
        (what ``inverse`` runs) on the recursive path, else from M, F and B."""
        M, F, B = (np.array(a, dtype=float) for a in self.mfb(q, dq))
        if self.demand is not None:
            demand, B = self.demand(q, dq, ddq)
            return M, np.linalg.solve(B, demand)
        return M, np.linalg.solve(B, M @ ddq - F.ravel())

    def pinocchio(self, q, dq, ddq):
        config = self.configuration(self.theta(q))
        J = self.J
        M = pin.crba(self.model, self.data, config)
        M = np.triu(M) + np.triu(M, 1).T
        tau = pin.rnea(self.model, self.data, config, J @ dq, J @ ddq)
        return J.T @ M @ J, J.T @ tau


def _anadyn_demand(robot):
    """(q, dq, ddq) -> (M ddq - F, B) of the recursive path's inverse dynamics."""
    from anadyn_cli.numeric.build import numeric_model

    model = numeric_model(robot, evaluator="recursive")
    assert model._inverse is not None              # the RNEA, not M ddq - F from mfb
    return lambda q, dq, ddq: model.demand(0.0, q, dq, ddq)


def _anadyn_mfb(robot, method: str):
    """(q, dq) -> M, F, B by anadyn's ``method``."""
    if method == "recursive":
        from anadyn_cli.numeric.build import numeric_model

        model = numeric_model(robot, evaluator="recursive")
        return lambda q, dq: model.mfb(0.0, q, dq)
    from anadyn_cli import derive

    eom = derive(robot, method)
    return sp.lambdify([robot.q, robot.dq], [eom.M, eom.F, eom.B], modules="numpy", cse=True)


def _identifier(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", name)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


#: closed forms whose symbolic expressions take long to derive and compile (so101: ~2e6
#: operations in M; panda: 30-50 s a formulation): the slow set checks them
LARGE = ("so101", "panda")


@pytest.mark.parametrize("path, method", [
    pytest.param(path, method, id=f"{path.stem}-{method}",
                 marks=[pytest.mark.slow] if path.stem in LARGE and method != "recursive" else [])
    for path in URDFS for method in ("recursive", "kane", "lagrange")])
def test_mass_matrix_and_inverse_dynamics_agree_with_pinocchio(path, method):
    oracle = Oracle(path, method)
    rng = np.random.default_rng(17)
    worst = {"M": 0.0, "RNEA": 0.0}
    for _ in range(STATES):
        q, dq, ddq = oracle.random_state(rng)
        (M, tau), (M_pin, tau_pin) = oracle.anadyn(q, dq, ddq), oracle.pinocchio(q, dq, ddq)
        worst["M"] = max(worst["M"], _relative(M, M_pin))
        worst["RNEA"] = max(worst["RNEA"], _relative(tau, tau_pin))
    MEASURED[f"{path.stem}/{method}"] = worst
    print(f"{path.stem} {method}: max relative error M {worst['M']:.1e}, "
          f"RNEA {worst['RNEA']:.1e}")
    assert worst["M"] <= TOLERANCE and worst["RNEA"] <= TOLERANCE, worst


def test_the_oracle_sees_a_wrong_model(tmp_path):
    """A test that cannot fail is a defect: a 1e-6 change of one link's mass is seen."""
    path = DATA / "ur5_robot.urdf"
    wrong = tmp_path / "ur5_robot.urdf"
    wrong.write_text(path.read_text().replace('<mass value="2.275"/>',
                                              '<mass value="2.2750023"/>'))
    oracle = Oracle(wrong)
    oracle.model = pin.buildModelFromUrdf(str(path))      # the right file
    oracle.data = oracle.model.createData()
    q, dq, ddq = oracle.random_state(np.random.default_rng(0))
    assert _relative(oracle.anadyn(q, dq, ddq)[1], oracle.pinocchio(q, dq, ddq)[1]) > 1e-8


# -- simulation against Pinocchio's ABA ---------------------------------------------------
def _pinocchio_motion(oracle: Oracle, x0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Pinocchio's forward dynamics, integrated by DOP853 at rtol 1e-12, atol 1e-14: ABA without
    mimic joints, else the coupled equations J^T M J ddq = J^T (tau_joint - nle)."""
    from scipy.integrate import solve_ivp

    n = len(oracle.robot.q)
    J, model, data = oracle.J, oracle.model, oracle.data
    damping, friction, scale = _joint_forces(oracle)
    mimic = J.shape[0] != n           # else J is a permutation: ddq = J^T ddtheta

    def rhs(_, x):
        theta, rate = oracle.theta(x[:n]), J @ x[n:]
        config = oracle.configuration(theta)
        tau = -damping * rate - friction * np.tanh(rate / scale)
        if not mimic:
            return np.concatenate([x[n:], J.T @ pin.aba(model, data, config, rate, tau)])
        M = pin.crba(model, data, config)
        M = np.triu(M) + np.triu(M, 1).T
        bias = pin.nonLinearEffects(model, data, config, rate)
        return np.concatenate([x[n:], np.linalg.solve(J.T @ M @ J, J.T @ (tau - bias))])

    solution = solve_ivp(rhs, (0, t[-1]), x0, method="DOP853", rtol=1e-12, atol=1e-14,
                         t_eval=t)
    assert solution.success
    return solution.y.T


def _joint_forces(oracle: Oracle):
    """Per Pinocchio joint: damping, friction and friction velocity of anadyn's loaded joints
    (zero where the robot model does not carry them)."""
    values = []
    for body_name in oracle.bodies:
        joint = oracle.robot.body(body_name).joint
        values.append([float(getattr(joint, k, 0)) for k in ("damping", "friction")]
                      + [float(getattr(joint, "friction_velocity", 1))])
    return tuple(np.array(v) for v in zip(*values))


def _simulate_and_compare(path: Path, tmp_path, state: dict | None = None,
                          t_end: float = 1.0) -> float:
    """Largest difference between anadyn's simulation (the CLI, DOP853 at rtol 1e-12, atol 1e-14) and
    Pinocchio's, each state scaled by max(1, its largest value).  Without ``state`` the
    URDF file itself is simulated; with it (coordinate -> (q0, dq0)) the imported file,
    written as YAML with that initial state and without joint friction."""
    robot_file = path
    if state is not None:
        data = import_file(path).data
        for name, (q0, dq0) in state.items():
            data["coordinates"][name] = {"initial": q0, "rate": dq0}
        for body in data["bodies"]:
            body["joint"].pop("friction", None)
        robot_file = tmp_path / f"{path.stem}.yaml"
        robot_file.write_text(yaml.safe_dump(data, sort_keys=False))
    out = tmp_path / "out"
    code = main(["simulate", str(robot_file), "--method", "DOP853", "--rtol", "1e-12",
                 "--atol", "1e-14", "--t-end", str(t_end), "--dt", "0.01", "--no-plot",
                 "--out", str(out), "--no-cache"])
    assert code == 0
    table = np.loadtxt(out / "simulate.csv", delimiter=",", skiprows=1)
    oracle = Oracle(path, joint_forces=True)
    if state is not None:
        oracle.robot = robot_from_text(robot_file.read_text(), str(robot_file))
    n = len(oracle.robot.q)
    x0 = np.array([float(c.initial) for c in oracle.robot.coordinates]
                  + [float(c.rate) for c in oracle.robot.coordinates])
    expected = _pinocchio_motion(oracle, x0, table[:, 0])
    scale = np.maximum(1.0, np.abs(expected).max(axis=0))
    error = float((np.abs(table[:, 1:2 * n + 1] - expected) / scale).max())
    MEASURED[f"{path.stem}/trajectory"] = {"max_scaled_error": error,
                                           "largest_state": float(np.abs(expected).max())}
    print(f"{path.stem}: simulated {t_end} s, max |x - x_pinocchio| / max(1, |x|max) = "
          f"{error:.1e} (states up to {np.abs(expected).max():.3g})")
    assert np.abs(expected - expected[0]).max() > 1e-3          # it moved
    return error


#: initial states away from rest (TwoDofs moves in a horizontal plane: gravity alone
#: would leave it at rest)
MOVING = {"TwoDofs": {"J1": (0.3, 2.0), "J2": (-0.5, -1.0)},
          "anadyn_features": {"j1": (0.2, 1.0), "j2": (0.5, -1.0), "j3": (0.1, 0.2),
                              "j_4": (-0.3, 1.5)},
          "panda": {"panda_joint2": (0.4, 0.5), "panda_joint4": (-1.5, 0.5),
                    "panda_finger_joint1": (0.02, 0.01)}}


@pytest.mark.parametrize("name", ["ur5_robot", "double_pendulum", "TwoDofs", "anadyn_features"])
def test_imported_arm_simulates_as_pinocchio(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _simulate_and_compare(DATA / f"{name}.urdf", tmp_path, MOVING.get(name)) < 1e-8


@pytest.mark.slow
@pytest.mark.parametrize("name", ["so101", "panda"])
def test_imported_arm_simulates_as_pinocchio_slow(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _simulate_and_compare(DATA / f"{name}.urdf", tmp_path, MOVING.get(name)) < 1e-8


# -- round trip ------------------------------------------------------------------------------
@pytest.mark.parametrize("path", URDFS, ids=[p.stem for p in URDFS])
def test_text_is_the_data(path):
    """The text reads back, by safe_load and by anadyn's reader, as the description
    the import made, which the loader takes without parsing the text again."""
    from anadyn_cli.model.urdf import description
    from anadyn_cli.model.yamlschema import load

    imported = import_file(path)
    assert yaml.safe_load(imported.text) == imported.data
    assert load(imported.text, path.name)[0] == imported.data
    assert description(imported.text) is imported.data
    assert description(imported.text + " ") is None
    assert imported.text.startswith("# Imported by anadyn")
    assert path.name in imported.text.splitlines()[0]


def test_round_trip_import_write_load_gives_the_same_equations(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    source = DATA / "anadyn_features.urdf"
    assert main(["import", str(source), "-o", "features.yaml"]) == 0
    capsys.readouterr()
    assert main(["equations", "features.yaml", "--matrices"]) == 0
    written = capsys.readouterr().out
    assert main(["equations", str(source), "--matrices"]) == 0
    direct = capsys.readouterr().out
    assert written == direct and "j_4" in written
    # and another serialization of the same data (PyYAML's) derives the same M, F, B
    from anadyn_cli import derive
    source = DATA / "panda.urdf"
    imported = import_file(source)
    a = derive(robot_from_text(imported.text, "a"))
    b = derive(robot_from_text(yaml.safe_dump(imported.data, sort_keys=False), "b"))
    assert a.M == b.M and a.F == b.F and a.B == b.B


def test_import_to_stdout(capsys):
    assert main(["import", str(DATA / "ur5_robot.urdf")]) == 0
    captured = capsys.readouterr()
    assert captured.out == import_file(DATA / "ur5_robot.urdf").text
    assert captured.err.startswith("anadyn: imported ")


# -- what the file says, carried over ---------------------------------------------------------
def test_panda_mapping():
    data = import_file(DATA / "panda.urdf").data
    bodies = {b["name"]: b for b in data["bodies"]}
    assert list(data["coordinates"]) == [f"panda_joint{i}" for i in range(1, 8)] + [
        "panda_finger_joint1"]
    assert list(data["actuators"]) == [f"tau_{q}" for q in data["coordinates"]]
    assert "panda_hand" not in bodies and "panda_link8" not in bodies       # folded
    right = bodies["panda_rightfinger"]["joint"]
    assert right["displacement"] == "panda_finger_joint1" and right["axis"] == [0, -1, 0]
    assert right["limits"] == {"lower": 0, "upper": 0.04, "velocity": 0.2, "effort": 100}
    assert right["damping"] == 0.3
    assert bodies["panda_link2"]["joint"]["rpy"] == ["-pi/2", 0, 0]
    # the hand (0.73 kg) is folded into link 7 (0.735522 kg)
    assert bodies["panda_link7"]["mass"] == pytest.approx(0.735522 + 0.73, abs=1e-15)
    # panda_joint4's range is [-3.0718, -0.0698]: it starts in the middle
    assert data["coordinates"]["panda_joint4"]["initial"] == pytest.approx(-1.5708)
    text = import_file(DATA / "panda.urdf").text
    assert "panda_hand_tcp (joint panda_hand_tcp_joint): origin [0, 0, 0.2104], rpy [0, 0, -pi/4]" \
        in text


def test_limits_reach_the_loaded_robot():
    robot = robot_from_text(import_file(DATA / "ur5_robot.urdf").text, "ur5")
    limits = robot.body("shoulder_link").joint.limits
    assert (float(limits.lower), float(limits.upper), float(limits.velocity),
            float(limits.effort)) == (-6.28318530718, 6.28318530718, 3.15, 150.0)


def test_continuous_joint_has_no_position_limits():
    data = import_file(DATA / "anadyn_features.urdf").data
    assert data["bodies"][0]["joint"]["limits"] == {"velocity": 3, "effort": 50}
    assert data["bodies"][0]["joint"]["damping"] == 0.2
    assert data["bodies"][0]["joint"]["friction"] == 0.1


def test_mimic_chain_is_composed():
    data = import_file(DATA / "anadyn_features.urdf").data
    bodies = {b["name"]: b for b in data["bodies"]}
    assert bodies["link5"]["joint"]["displacement"] == "-2*j_4 + 0.3"
    # j6 = 0.05 * j5 - 0.01 = -0.1 j_4 + 0.005
    k, c = re.fullmatch(r"(\S+)\*j_4 \+ (\S+)", bodies["link6"]["joint"]["displacement"]).groups()
    assert float(k) == -0.1 and float(c) == pytest.approx(0.005, abs=1e-17)
    assert "j5" not in data["coordinates"] and "tau_j5" not in data["actuators"]


def test_placeholder_limits_are_left_out_with_a_warning():
    imported = import_file(DATA / "double_pendulum.urdf")
    assert all("limits" not in b["joint"] for b in imported.data["bodies"])
    (warning,) = imported.warnings
    assert "joint 'joint1': velocity 0, effort 0, lower = upper" in warning


# -- the mechanics of folding and frames ------------------------------------------------------
def test_combine_is_the_parallel_axis_theorem():
    """Two 1 kg points at x = +-1 m: m = 2, c = 0, I = diag(0, 2, 2)."""
    zero = np.zeros((3, 3))
    total = combine([MassProperties(1.0, np.array([1.0, 0, 0]), zero),
                     MassProperties(1.0, np.array([-1.0, 0, 0]), zero)])
    assert total.mass == 2 and not total.com.any()
    assert np.array_equal(total.inertia, np.diag([0.0, 2.0, 2.0]))


def test_folding_a_split_link_gives_the_whole_link():
    """A uniform 2 m, 2 kg rod along x is the same body as its two 1 m halves fixed
    together: I about its centre = m L^2 / 12 = 2/3 kg m^2 about y and z."""
    half = 1 * 1 ** 2 / 12
    urdf = f"""<robot name="rod">
      <link name="base"/>
      <joint name="hinge" type="revolute"><parent link="base"/><child link="a"/>
        <axis xyz="0 0 1"/><limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
      <link name="a"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
        <inertia ixx="0" iyy="{half}" izz="{half}"/></inertial></link>
      <joint name="weld" type="fixed"><origin xyz="1 0 0" rpy="0 0 3.141592653589793"/>
        <parent link="a"/><child link="b"/></joint>
      <link name="b"><inertial><origin xyz="-0.5 0 0"/><mass value="1"/>
        <inertia ixx="0" iyy="{half}" izz="{half}"/></inertial></link>
    </robot>"""
    (body,) = import_urdf(urdf, "rod.urdf").data["bodies"]
    assert body["mass"] == 2 and body["com"] == [1, 0, 0]
    assert body["inertia"] == pytest.approx({"iyy": 2 / 3, "izz": 2 / 3}, rel=1e-15)


def test_rpy_round_trip():
    rng = np.random.default_rng(3)
    angles = [rng.uniform(-math.pi, math.pi, 3) for _ in range(200)]
    angles += [np.array([0.3, math.pi / 2, 0.2]), np.array([-0.7, -math.pi / 2, 1.1])]
    for rpy in angles:
        R = rpy_matrix(rpy)
        assert np.abs(rpy_matrix(matrix_rpy(R)) - R).max() < 1e-14


def test_nearest_valid_moments_is_valid_and_nearest():
    from scipy.optimize import minimize

    rng = np.random.default_rng(5)
    for _ in range(50):
        x = np.sort(rng.normal(1, 1, 3))
        y = nearest_valid_moments(x)
        assert y[0] + y[1] >= y[2] - 1e-12 and y.min() >= 0
        constraints = [{"type": "ineq", "fun": lambda v, i=i: v[i] + v[(i + 1) % 3]
                        - v[(i + 2) % 3]} for i in range(3)]
        best = minimize(lambda v: np.sum((v - x) ** 2), np.abs(x) + 1, constraints=constraints,
                        method="SLSQP", options={"ftol": 1e-14})
        assert np.linalg.norm(y - x) <= np.linalg.norm(best.x - x) + 1e-7
    assert np.array_equal(nearest_valid_moments([1.0, 2.0, 2.5]), [1.0, 2.0, 2.5])


# -- imperfect inertias: refuse, repair, accept ----------------------------------------------
BAD_INERTIA = """<robot name="bad">
  <link name="base"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <origin xyz="0 0 0.1"/><limit effort="1" velocity="1" lower="-1" upper="1"/></joint>
  <link name="arm"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.003"/></inertial></link>
</robot>
"""


def _write(tmp_path, text: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_impossible_inertia_refused_by_default(tmp_path, capsys):
    path = _write(tmp_path, BAD_INERTIA)
    assert main(["import", str(path), "-o", str(tmp_path / "out.yaml")]) == 2
    err = capsys.readouterr().err
    assert err == (f"anadyn: error: {path}: link 'arm': <inertia>: principal moments 0.001, "
                   "0.001, 0.003 kg m^2: breaks the triangle inequality I1 + I2 >= I3; no rigid "
                   "body has this inertia (import with --inertia repair replaces it by the "
                   "nearest valid one, --inertia accept keeps it, with a warning)\n")
    assert not (tmp_path / "out.yaml").exists()
    assert main(["equations", str(path)]) == 2


def test_impossible_inertia_repaired_on_request(tmp_path, capsys):
    path = _write(tmp_path, BAD_INERTIA)
    assert main(["import", str(path), "--inertia", "repair", "-o", str(tmp_path / "r.yaml")]) == 0
    err = capsys.readouterr().err
    # (a, b, c) projected on a + b = c: minus (a + b - c)/3 (1, 1, -1)
    assert "repaired to the nearest valid inertia, principal moments 0.00133333, 0.00133333, " \
           "0.00266667 (changed by 0.000577 kg m^2" in err
    inertia = yaml.safe_load((tmp_path / "r.yaml").read_text())["bodies"][0]["inertia"]
    assert inertia == pytest.approx({"ixx": 0.004 / 3, "iyy": 0.004 / 3, "izz": 0.008 / 3},
                                    rel=1e-12)


def test_impossible_inertia_accepted_on_request(tmp_path, capsys):
    path = _write(tmp_path, BAD_INERTIA)
    assert main(["import", str(path), "--inertia", "accept", "-o", str(tmp_path / "a.yaml")]) == 0
    assert "kept as given (--inertia accept)" in capsys.readouterr().err
    text = (tmp_path / "a.yaml").read_text()
    assert "triangle_inequality: ignore" in text
    robot = robot_from_text(text, "a.yaml")
    assert float(robot.bodies[0].inertia[2, 2]) == 0.003


def test_inertia_of_the_base_is_not_checked():
    """The root's own mass never moves: an impossible inertia there is irrelevant."""
    urdf = BAD_INERTIA.replace('<link name="base"/>', '<link name="base"><inertial><mass '
                               'value="1"/><inertia ixx="1" iyy="1" izz="5"/></inertial></link>'
                               ).replace('izz="0.003"', 'izz="0.002"')
    assert import_urdf(urdf, "x.urdf").warnings == []


# -- every class of bad input: one line, exit 2, nothing written -----------------------------
ARM = """<robot name="arm">
  <link name="base"/>
  <joint name="j1" type="{type}"><parent link="base"/><child link="l1"/>{extra}
    <axis xyz="{axis}"/><origin xyz="{xyz}"/><limit effort="1" velocity="1" lower="{lower}" upper="1"/></joint>
  <link name="l1"><inertial><mass value="{mass}"/><origin xyz="0.1 0 0"/>
    <inertia ixx="{ixx}" iyy="0.01" izz="0.01"/></inertial></link>
</robot>
"""
DEFAULTS = dict(type="revolute", extra="", axis="0 0 1", xyz="0 0 0", lower="-1", mass="1",
                ixx="0.01")


def _arm(**changes) -> str:
    return ARM.format(**{**DEFAULTS, **changes})


BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">]>
<robot name="&lol2;"><link name="a"/></robot>
"""
EXTERNAL = """<?xml version="1.0"?>
<!DOCTYPE robot [<!ENTITY secret SYSTEM "file:///etc/passwd">]>
<robot name="x"><link name="&secret;"/></robot>
"""
TWO = """<robot name="t">
  <link name="a"/><link name="b"><inertial><mass value="1"/></inertial></link>
  <link name="c"><inertial><mass value="1"/></inertial></link>
  {joints}
</robot>"""


def _joint(name, parent, child, kind="revolute", extra=""):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<axis xyz="0 0 1"/>{extra}</joint>')


BAD = {
    "not-xml": ("<robot name='x'><link name='a'></robot>",
                r"{f}:1: not well-formed XML: mismatched tag \(column 33\)"),
    "billion-laughs": (BILLION_LAUGHS, r"{f}: XML entity declarations are refused \(entity "
                                       r"expansion is a classic attack and no URDF needs it\)"),
    "external-entity": (EXTERNAL, r"{f}: XML entity declarations are refused .*"),
    "not-urdf": ("<sdf version='1.6'/>", r"{f}: the root element is <sdf>, expected <robot>: "
                                         r"not a URDF file"),
    "xacro": ("<robot xmlns:xacro='http://www.ros.org/wiki/xacro'><xacro:property name='a' "
              "value='1'/></robot>", r"{f}: a xacro file .*expand it first.*"),
    "ball": (_arm(type="ball"), r"{f}: joint 'j1': type 'ball' is not a URDF joint type; "
                                r"expected revolute, continuous, prismatic, fixed, floating or "
                                r"planar"),
    "no-mass": (_arm(mass="0"), r"{f}: joint 'j1' moves nothing: no link it moves \(link 'l1' "
                                r"and beyond\) has mass, so the mass matrix would be singular; "
                                r"give one of those links an <inertial> with a positive <mass>, "
                                r"or lock it \(--lock j1=0\)"),
    "missing-inertial": (_arm().replace('<inertial><mass value="1"/><origin xyz="0.1 0 0"/>\n'
                                        '    <inertia ixx="0.01" iyy="0.01" izz="0.01"/>'
                                        '</inertial>', ""),
                         r"{f}: joint 'j1' moves nothing: no link it moves .*"),
    "negative-mass": (_arm(mass="-2"), r"{f}: link 'l1': <mass value=\"-2\">: a mass cannot be "
                                       r"negative"),
    "nan": (_arm(xyz="0 nan 0"), r"{f}: joint 'j1': <origin xyz=\"0 nan 0\">: numbers must be "
                                 r"finite"),
    "not-a-number": (_arm(xyz="0 x 0"), r"{f}: joint 'j1': <origin xyz=\"0 x 0\">: expected 3 "
                                        r"numbers"),
    "two-numbers": (_arm(xyz="0 0"), r"{f}: joint 'j1': <origin xyz=\"0 0\">: expected 3 "
                                     r"numbers, got 2"),
    "huge": (_arm(xyz="0 1e40 0"), r"{f}: joint 'j1': <origin xyz=\"0 1e40 0\">: out of range .*"),
    "not-psd": (_arm(ixx="-0.01"), r"{f}: link 'l1': <inertia>: principal moments -0.01, 0.01, "
                                   r"0.01 kg m\^2: is not positive semidefinite; no rigid body "
                                   r"has this inertia \(import with --inertia repair replaces "
                                   r"it by the nearest valid one, with a warning\)"),
    "zero-axis": (_arm(axis="0 0 0"), r"{f}: joint 'j1': <axis xyz=\"0 0 0\">: the axis of a "
                                      r"moving joint cannot be zero"),
    "lower-above-upper": (_arm(lower="2"), r"{f}: joint 'j1': <limit lower=\"2\" upper=\"1\">: "
                                           r"lower is above upper"),
    "negative-velocity": (_arm().replace('velocity="1"', 'velocity="-1"'),
                          r"{f}: joint 'j1': <limit velocity=\"-1\">: cannot be negative"),
    "unknown-link": (_arm().replace('<child link="l1"/>', '<child link="l9"/>'),
                     r"{f}: joint 'j1': <child link=\"l9\">: no such link"),
    "missing-parent": (_arm().replace('<parent link="base"/>', ''),
                       r"{f}: joint 'j1': missing <parent link=\"...\">"),
    "duplicate-link": (_arm().replace('<link name="base"/>', '<link name="base"/><link '
                                      'name="base"/>'), r"{f}: link 'base': defined twice"),
    "two-parents": (TWO.format(joints=_joint("x", "a", "b") + _joint("y", "a", "c")
                               + _joint("z", "b", "c")),
                    r"{f}: link 'c': child of two joints, 'y' and 'z': a closed loop \(anadyn's "
                    r"robots are trees\)"),
    "two-roots": (TWO.format(joints=_joint("x", "a", "b")),
                  r"{f}: 2 root links \('a', 'c'\): links that no joint has as child; a robot "
                  r"must be one tree joined by joints"),
    "no-root": (TWO.format(joints=_joint("x", "a", "b") + _joint("y", "b", "c")
                           + _joint("z", "c", "a")),
                r"{f}: no root link: every link is the child of a joint, so the joints form a "
                r"cycle \('x', 'y', 'z'\)"),
    "cycle": (TWO.format(joints=_joint("x", "b", "c") + _joint("y", "c", "b")).replace(
        '<link name="a"/>', '<link name="a"/><link name="d"/>') .replace(
        "</robot>", _joint("w", "a", "d", "fixed") + "</robot>"),
        r"{f}: joint 'x': joints 'x', 'y' form a cycle not connected to the root link 'a'"),
    "mimic-unknown": (_arm(extra='<mimic joint="j9"/>'),
                      r"{f}: joint 'j1': <mimic joint=\"j9\">: no such joint"),
    "mimic-cycle": (TWO.format(joints=_joint("x", "a", "b", extra='<mimic joint="y"/>')
                               + _joint("y", "b", "c", extra='<mimic joint="x"/>')),
                    r"{f}: joint 'x': mimic joints 'x', 'y' mimic each other in a cycle"),
    "negative-damping": (_arm(extra='<dynamics damping="-1"/>'),
                         r"{f}: joint 'j1': <dynamics damping=\"-1\">: cannot be negative"),
    "inertial-without-mass": (_arm().replace('<mass value="1"/>', ''),
                              r"{f}: link 'l1': <inertial> has no <mass>"),
    "own-parent": (_arm().replace('<child link="l1"/>', '<child link="base"/>'),
                   r"{f}: joint 'j1': link 'base' is its own parent"),
    "nothing-moves": (_arm(type="fixed"), r"{f}: nothing moves: the URDF has no revolute, "
                                          r"continuous or prismatic joint"),
    "no-links": ("<robot name='x'/>", r"{f}: no <link> elements: nothing to import"),
}


@pytest.mark.parametrize("case", list(BAD))
@pytest.mark.parametrize("command", ["import", "simulate"])
def test_bad_urdf_is_one_line_exit_2_nothing_written(case, command, tmp_path, capsys,
                                                     monkeypatch):
    monkeypatch.chdir(tmp_path)
    text, pattern = BAD[case]
    path = _write(tmp_path, text, "bad.urdf")
    before = sorted(p.name for p in tmp_path.iterdir())
    args = (["import", str(path), "-o", "out.yaml"] if command == "import"
            else ["simulate", str(path), "--no-cache", "--no-plot"])
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert re.fullmatch("anadyn: error: " + pattern.format(f=re.escape(str(path))) + "\n",
                        captured.err), captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_fix_base_welds_a_floating_root_joint(tmp_path, capsys):
    path = _write(tmp_path, _arm(type="floating").replace(
        "</robot>", '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
                    '<axis xyz="0 1 0"/><origin xyz="0.3 0 0"/></joint><link name="l2"><inertial>'
                    '<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>'
                    '</link></robot>'))
    assert main(["import", str(path), "--fix-base", "-o", str(tmp_path / "f.yaml")]) == 0
    assert "floating joint of the base welded" in capsys.readouterr().err
    data = yaml.safe_load((tmp_path / "f.yaml").read_text())
    assert list(data["coordinates"]) == ["j2"]
    assert data["bodies"][0]["parent"] == "ground"


def test_size_cap(tmp_path, capsys):
    path = tmp_path / "big.urdf"
    path.write_bytes(b"<robot name='x'>" + b" " * (4 * 1024 * 1024) + b"</robot>")
    assert main(["import", str(path)]) == 2
    assert capsys.readouterr().err == (f"anadyn: error: {path}: file is {path.stat().st_size} "
                                       "bytes, the limit for URDF is 4194304\n")


def test_names_become_identifiers():
    data = import_file(DATA / "anadyn_features.urdf").data
    assert "j_4" in data["coordinates"]
    assert [b["name"] for b in data["bodies"]] == ["link1", "link2", "link3", "link_4", "link5",
                                                   "link6"]
    urdf = _arm().replace('name="j1"', 'name="lambda"').replace('"l1"', '"2nd link"')
    data = import_urdf(urdf, "x.urdf").data
    assert list(data["coordinates"]) == ["lambda_"]
    assert data["bodies"][0]["name"] == "link_2nd_link"


def test_shipped_real_arms_warn_only_where_they_should():
    for path in URDFS:
        imported = import_file(path)
        assert imported.warnings == [] or path.stem == "double_pendulum", imported.warnings


# -- limits: simulate and inverse report the bounds of the file that a run passes ------------
PENDULUM = """name: pendulum
gravity: [0, 0, -9.81]
coordinates:
  a: {initial: 0.2}
  b: {initial: 0}
bodies:
  - name: upper
    joint: {type: revolute, axis: [0, 1, 0], displacement: a,
            limits: {lower: -0.3, upper: 0.5, velocity: 1.5, effort: 2}}
    mass: 1
    com: [0.5, 0, 0]
    inertia: {iyy: 0.02, izz: 0.02}
  - name: lower
    parent: upper
    joint: {type: revolute, axis: [0, 1, 0], origin: [1, 0, 0], displacement: b - 0.5*a,
            limits: {lower: -2, upper: 2, velocity: 50}}
    mass: 0.5
    com: [0.4, 0, 0]
    inertia: {iyy: 0.01, izz: 0.01}
actuators:
  motor: {joint: upper}
  elbow: {joint: lower}
controller:
  laws: {motor: -3*da, elbow: 0}
trajectory: {kind: cycloidal, duration: 1, to: {a: 0.9, b: 0.1}}
"""


def _expected_limits(robot_text: str, table: np.ndarray, efforts_from: int) -> set:
    """(name, quantity, bound, first time) of every bound the rows pass, computed here
    with SymPy from the file (independently of anadyn's numeric.limits)."""
    robot = robot_from_text(robot_text, "x")
    n = len(robot.q)
    t, q, dq = table[:, 0], table[:, 1:n + 1], table[:, n + 1:2 * n + 1]
    found = set()

    def first(name, quantity, bound, over):
        if over.any():
            found.add((name, quantity, bound, float(t[np.argmax(over)])))

    for body in robot.bodies:
        limits, theta = body.joint.limits, body.joint.displacement
        name = next((c.name for c in robot.coordinates if theta == c.symbol),
                    f"{body.name} ({theta.evalf(6)})")
        value = sp.lambdify(robot.q, theta)(*q.T) * np.ones(len(t))
        rate = sp.lambdify([robot.q, robot.dq],
                           sum(sp.diff(theta, s) * r for s, r in zip(robot.q, robot.dq)))(q.T, dq.T)
        if limits.lower is not None:
            first(name, "position", "lower", value < float(limits.lower) - 1e-9)
            first(name, "position", "upper", value > float(limits.upper) + 1e-9)
        if limits.velocity is not None:
            first(name, "rate", "magnitude", np.abs(rate) > float(limits.velocity) + 1e-9)
        for k, actuator in enumerate(robot.actuators):
            if actuator.body == body.name and limits.effort is not None:
                first(actuator.name, "effort", "magnitude",
                      np.abs(table[:, efforts_from + k]) > float(limits.effort) + 1e-9)
    return found


def _reported(figures: dict) -> set:
    return {(e["name"], e["quantity"], e["bound"], e["first_time"])
            for e in figures["limits"]["exceeded"]}


def test_simulate_reports_the_limits_it_passes(tmp_path, capsys, monkeypatch):
    import json

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    (tmp_path / "pendulum.yaml").write_text(PENDULUM)
    for run in ("miss", "hit"):            # the cached robot info carries the limits too
        assert main(["simulate", "pendulum.yaml", "--t-end", "2", "--no-plot"]) == 0
        err = capsys.readouterr().err.splitlines()
        figures = json.loads((tmp_path / "results/pendulum/simulate.json").read_text())
        table = np.loadtxt(tmp_path / "results/pendulum/simulate.csv", delimiter=",",
                           skiprows=1)
        expected = _expected_limits(PENDULUM, table, 5)
        assert _reported(figures) == expected
        assert {e[:3] for e in expected} >= {("a", "position", "upper"), ("motor", "effort",
                                                                          "magnitude")}
        assert figures["limits"]["bounds"] == 7 and figures["limits"]["count"] == len(expected)
        assert len(err) == len(expected)
        upper = next(e for e in figures["limits"]["exceeded"] if e["bound"] == "upper")
        assert upper["worst"] == table[:, 1].max()
        assert (f"anadyn: warning: limit exceeded: a: position above its upper limit 0.5 rad "
                f"from t = {upper['first_time']:g} s (up to {upper['worst']:.6g} rad at t = "
                f"{upper['worst_time']:g} s, {int((table[:, 1] > 0.5).sum())} rows)") in err


def test_inverse_reports_the_limits_it_passes(tmp_path, capsys, monkeypatch):
    import json

    monkeypatch.chdir(tmp_path)
    (tmp_path / "pendulum.yaml").write_text(PENDULUM)
    assert main(["inverse", "pendulum.yaml", "--no-plot", "--no-cache", "--no-roundtrip"]) == 0
    err = capsys.readouterr().err
    figures = json.loads((tmp_path / "results/pendulum/inverse.json").read_text())
    table = np.loadtxt(tmp_path / "results/pendulum/inverse.csv", delimiter=",", skiprows=1)
    expected = _expected_limits(PENDULUM, table, 7)
    assert _reported(figures) == expected
    names = {e[:3] for e in expected}
    assert ("a", "position", "upper") in names and ("lower (-0.5*a + b)", "position", "upper") \
        not in names and ("motor", "effort", "magnitude") in names
    assert err.count("anadyn: warning: limit exceeded: ") == len(expected)


def test_a_coupled_joint_is_checked_on_its_displacement(tmp_path, capsys, monkeypatch):
    """b - 0.5 a must stay within +-0.1 here: the coupled joint's own bound."""
    import json

    monkeypatch.chdir(tmp_path)
    text = PENDULUM.replace("limits: {lower: -2, upper: 2, velocity: 50}",
                            "limits: {lower: -0.1, upper: 0.1}")
    (tmp_path / "pendulum.yaml").write_text(text)
    assert main(["simulate", "pendulum.yaml", "--t-end", "1", "--no-plot", "--no-cache"]) == 0
    figures = json.loads((tmp_path / "results/pendulum/simulate.json").read_text())
    table = np.loadtxt(tmp_path / "results/pendulum/simulate.csv", delimiter=",", skiprows=1)
    assert _reported(figures) == _expected_limits(text, table, 5)
    assert any(e["name"] == "lower (-0.5*a + b)" for e in figures["limits"]["exceeded"])
    capsys.readouterr()


def test_no_limits_no_warning(tmp_path, capsys, monkeypatch):
    import json

    monkeypatch.chdir(tmp_path)
    assert main(["simulate", str(Path(__file__).parents[1] / "robots" / "rr.yaml"),
                 "--t-end", "0.5", "--no-plot", "--no-cache", "--out", "rr"]) == 0
    assert "warning" not in capsys.readouterr().err
    figures = json.loads((tmp_path / "rr/simulate.json").read_text())
    assert figures["limits"] == {"bounds": 0, "count": 0, "exceeded": []}


def test_limits_of_a_nonlinear_displacement_are_evaluated_exactly():
    """The expression trees that carry a joint's displacement into the cached robot info
    evaluate as SymPy does, functions included."""
    from anadyn_cli.model.info import expression_tree
    from anadyn_cli.numeric.limits import _evaluate

    a, b = sp.symbols("a b", real=True)
    theta = sp.asin(sp.sin(a) / 2) + sp.Max(b, a) ** 2 - sp.exp(-b) * sp.atan2(b, 1 + a ** 2) \
        + sp.sqrt(2 + sp.cos(b)) - sp.Abs(a) * sp.sign(b) + sp.log(3 + sp.tanh(a))
    rng = np.random.default_rng(2)
    values = {"a": rng.normal(size=50), "b": rng.normal(size=50)}
    expected = sp.lambdify([a, b], theta, "numpy")(values["a"], values["b"])
    assert np.abs(_evaluate(expression_tree(theta), values, 50) - expected).max() < 1e-14


def test_unexpanded_xacro_expression_is_named(tmp_path, capsys):
    path = _write(tmp_path, _arm(xyz="${length} 0 0"))
    assert main(["import", str(path)]) == 2
    assert capsys.readouterr().err == (f"anadyn: error: {path}: joint 'j1': <origin xyz=\"${{length}}"
                                       f" 0 0\">: an unexpanded xacro expression; expand the "
                                       "file with xacro first\n")


def test_inertia_on_a_link_fixed_to_a_massless_moving_link_counts():
    """URDFs often put a moving link's mass on a child fixed to it (e.g. *_inertia links)."""
    urdf = _arm(mass="0", ixx="0").replace(
        "</robot>", '<joint name="w" type="fixed"><parent link="l1"/><child link="l1_mass"/>'
                    '<origin xyz="0.3 0 0"/></joint><link name="l1_mass"><inertial><mass '
                    'value="2"/><inertia ixx="0.01" iyy="0.02" izz="0.02"/></inertial></link>'
                    '</robot>').replace('<inertia ixx="0" iyy="0.01" izz="0.01"/>',
                                        '<inertia ixx="0" iyy="0" izz="0"/>')
    (body,) = import_urdf(urdf, "x.urdf").data["bodies"]
    assert body["mass"] == 2 and body["com"] == [0.3, 0, 0]
    assert body["inertia"] == {"ixx": 0.01, "iyy": 0.02, "izz": 0.02}


def test_a_commented_trajectory_is_offered_for_inverse():
    text = import_file(DATA / "panda.urdf").text
    assert text.endswith("# trajectory: {kind: quintic, duration: 2, to: {panda_joint1: 0.5}}\n")
    line = text.splitlines()[-1][2:]
    robot = robot_from_text(text + line + "\n", "panda.yaml")
    assert robot.trajectory.kind == "quintic"


def test_import_warnings_reach_the_user_once(capsys, monkeypatch):
    """On the command line one stderr line; from Python a warning (nothing printed)."""
    from anadyn_cli.model import library

    monkeypatch.setattr(library, "_announced", set())
    path = DATA / "double_pendulum.urdf"
    assert main(["equations", str(path)]) == 0
    err = capsys.readouterr().err
    assert err.count("anadyn: warning: ") == 1 and "<limit> values taken for unset" in err
    import anadyn

    monkeypatch.setattr(library, "_announced", set())
    with pytest.warns(UserWarning, match="<limit> values taken for unset placeholders"):
        anadyn.load(path)
    assert capsys.readouterr().err == ""
