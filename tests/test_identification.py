"""Identification (issue 28, items 2-7) against independent sources:

- the regressor Y pi against Pinocchio's RNEA (with armature: RNEA + armature * a)
  on every URDF of the test data at 20 random states, to 1e-10 relative, and
  against anadyn's own inverse dynamics (the closed-form evaluator: joint friction
  and springs included) on the shipped robot files (tests/test_regressor.py: Y
  itself against Pinocchio's regressor, and the exported Y);
- the number of base parameters against the rank of Pinocchio's
  ``computeJointTorqueRegressor`` stacked over random states (with the drive
  columns, computed here);
- the exact base-parameter coefficients (Kane, rationals) against the numeric QR;
- identification from data made with Pinocchio: noise-free the base parameters
  come back to 1e-8; with Gaussian noise of 1 % of the largest effort they lie
  within four of their standard deviations and the held-out residual is the noise;
- one joint with a geared rotor: the effective inertia I + N^2 J_r;
- bad data files: one line, exit 2, nothing written.
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import anadyn
from anadyn_cli.cli import main
from anadyn_cli.output.csv_table import write_csv
from anadyn_cli.studies.identification import estimate
from anadyn_cli.studies.identification.base import base_parameters, random_states
from anadyn_cli.studies.identification.regressor import parametric_model

pin = pytest.importorskip("pinocchio")

REPO = Path(__file__).resolve().parent.parent
URDFS = sorted((REPO / "tests" / "data" / "urdf").glob("*.urdf"))
TOL = 1e-10


class Pinocchio:
    """Pinocchio's model of a URDF and the map from anadyn's coordinates q to its
    joints: theta = J q + theta0 (anadyn's moving joints), read through the URDF
    joint -> child link -> anadyn body."""

    def __init__(self, path: Path):
        self.robot = anadyn.load(path)
        self.model = parametric_model(self.robot)
        self.pin = pin.buildModelFromUrdf(str(path))
        self.data = self.pin.createData()
        child = {j.get("name"): j.find("child").get("link")
                 for j in ET.parse(path).getroot().findall("joint")}
        bodies = [re.sub(r"[^A-Za-z0-9_]", "_", child[n]) for n in self.pin.names[1:]]
        self.rows = [self.model.joint_of_body[self.model.bodies.index(b)] for b in bodies]

    def joints(self, q, dq, ddq):
        m = self.model
        return ((q @ m.J.T + m.theta0)[self.rows], (dq @ m.J.T)[self.rows],
                (ddq @ m.J.T)[self.rows])

    def configuration(self, theta):
        config = np.zeros(self.pin.nq)
        for j in range(1, self.pin.njoints):
            joint = self.pin.joints[j]
            value = theta[joint.idx_v]
            if joint.nq == 2:
                config[joint.idx_q:joint.idx_q + 2] = (math.cos(value), math.sin(value))
            else:
                config[joint.idx_q] = value
        return config

    def generalized(self, tau):
        """Joint efforts (Pinocchio's order) as generalized forces of anadyn's q."""
        return self.model.J[self.rows].T @ tau

    def rnea(self, q, dq, ddq, armature=None):
        if armature is not None:
            self.pin.armature = armature
        theta, rate, acc = self.joints(q, dq, ddq)
        return self.generalized(pin.rnea(self.pin, self.data, self.configuration(theta),
                                         rate, acc).copy())

    def regressor(self, q, dq, ddq):
        theta, rate, acc = self.joints(q, dq, ddq)
        Y = pin.computeJointTorqueRegressor(self.pin, self.data, self.configuration(theta),
                                            rate, acc)
        return self.model.J[self.rows].T @ Y


def _states(model, count, seed):
    q, dq, ddq = random_states(model, count, seed)
    return q, 2 * dq, 5 * ddq


def _rigid(model, armature=None):
    """The file's parameters with Pinocchio's drive: armature (per Pinocchio joint, in
    anadyn's joint order) and no friction."""
    pi = model.nominal.copy()
    drive = 10 * len(model.bodies)
    pi[drive:] = 0.0
    if armature is not None:
        pi[drive::3] = armature
    return pi


@pytest.mark.parametrize("path", URDFS, ids=lambda p: p.stem)
def test_regressor_matches_pinocchio_rnea(path):
    oracle = Pinocchio(path)
    model = oracle.model
    rng = np.random.default_rng(3)
    armature_pin = rng.uniform(0.01, 0.5, oracle.pin.nv)
    armature = np.zeros(model.J.shape[0])
    armature[oracle.rows] = armature_pin
    worst = {"rnea": 0.0, "with armature": 0.0}
    for q, dq, ddq in zip(*_states(model, 20, 11)):
        Y = model.regressor(q, dq, ddq)[0]
        for key, pi, arm in (("rnea", _rigid(model), np.zeros_like(armature_pin)),
                             ("with armature", _rigid(model, armature), armature_pin)):
            expected = oracle.rnea(q, dq, ddq, arm)
            error = np.abs(Y @ pi - expected).max() / np.abs(expected).max()
            worst[key] = max(worst[key], error)
    print(f"{path.stem}: max relative |Y pi - RNEA| {worst}")
    assert max(worst.values()) < TOL, worst


def test_parameters_are_pinocchios_dynamic_parameters():
    """The stated order and convention (m, m c, inertia about the body origin: Ixx, Ixy,
    Iyy, Ixz, Iyz, Izz): each UR5 body's ten equal Pinocchio's ``toDynamicParameters``."""
    oracle = Pinocchio(REPO / "tests" / "data" / "urdf" / "ur5_robot.urdf")
    model = oracle.model
    for j in range(1, oracle.pin.njoints):
        b = model.moving[oracle.rows[j - 1]]
        expected = oracle.pin.inertias[j].toDynamicParameters()
        assert np.abs(model.nominal[10 * b:10 * b + 10] - expected).max() < 1e-14


def test_the_pinocchio_check_sees_a_wrong_parameter():
    oracle = Pinocchio(REPO / "tests" / "data" / "urdf" / "ur5_robot.urdf")
    model = oracle.model
    pi = _rigid(model)
    pi[10 * 3] *= 1 + 1e-6                          # the mass of the fourth body
    q, dq, ddq = (a[0] for a in _states(model, 1, 0))
    expected = oracle.rnea(q, dq, ddq, np.zeros(oracle.pin.nv))
    assert np.abs(model.regressor(q, dq, ddq)[0] @ pi - expected).max() > 1e-10 * np.abs(
        expected).max()


@pytest.mark.parametrize("name", ["rr", "rrt", "rrt_friction", "configs/chain6.yaml"])
def test_regressor_matches_anadyns_inverse_dynamics(name):
    """Against the closed forms (Kane's equations: not the RNEA that Y is traced from);
    friction (the file's damping and friction: Fv, Fc) and springs included; rr's
    joint 2 turns by q2 - q1."""
    import dataclasses

    from anadyn_cli.numeric.build import numeric_model

    robot = anadyn.load(REPO / name if "/" in name else name)
    robot = dataclasses.replace(robot, loads=(), controller=None)
    model = parametric_model(robot)
    evaluator = numeric_model(robot, evaluator="closed-form")
    q, dq, ddq = _states(model, 10, 5)
    Y = model.actuator_regressor(q, dq, ddq)
    for k in range(len(q)):
        demand, B = evaluator.demand(0.0, q[k], dq[k], ddq[k])
        tau = np.linalg.solve(np.asarray(B, float), np.asarray(demand, float).ravel())
        ours = Y[k] @ model.nominal + model.spring_efforts(q[k])[0]
        assert np.abs(ours - tau).max() < TOL * max(1.0, np.abs(tau).max())


def test_a_robot_with_loads_or_loops_is_refused():
    with pytest.raises(anadyn.ModelError, match="no external loads"):
        anadyn.parametric_model("rrt_friction")
    underactuated = anadyn.parametric_model(REPO / "robots" / "optimize" / "cartpole.yaml")
    with pytest.raises(anadyn.ModelError, match="1 actuators for 2 coordinates: "
                                                "identification needs one actuator per"):
        underactuated.actuator_regressor([0, 0], [0, 0], [0, 0])
    assert main(["equations", "fourbar", "--base-parameters"]) == 2


@pytest.mark.parametrize("path", URDFS, ids=lambda p: p.stem)
def test_base_parameter_count_is_the_rank_of_pinocchios_regressor(path):
    oracle = Pinocchio(path)
    model = oracle.model
    base = base_parameters(model, exact=False)
    q, dq, ddq = _states(model, 40, 21)
    blocks = []
    for k in range(len(q)):
        theta, rate, acc = (model.J @ x + c for x, c in ((q[k], model.theta0), (dq[k], 0),
                                                          (ddq[k], 0)))
        drive = np.zeros((len(model.J), 3 * len(model.J)))
        for j in range(len(model.J)):
            drive[j, 3 * j:3 * j + 3] = (acc[j], rate[j],
                                         np.tanh(rate[j] / model.friction_velocity[j]))
        blocks.append(np.hstack([oracle.regressor(q[k], dq[k], ddq[k]),
                                 model.J.T @ drive]))
    stacked = np.vstack(blocks)
    norms = np.linalg.norm(stacked, axis=0)
    acting = norms > 1e-12 * norms.max()          # zero columns but for round-off
    scaled = stacked[:, acting] / norms[acting]
    rank = np.linalg.matrix_rank(scaled, tol=1e-9 * np.linalg.norm(scaled, 2))
    print(f"{path.stem}: {base.rank} base parameters of {len(model.names)}; "
          f"Pinocchio's stacked regressor (+ drive columns) has rank {rank}")
    assert base.rank == rank


@pytest.mark.parametrize("name, count", [("rr", 11), ("rrt", 19)])
def test_exact_and_numeric_base_parameters_agree(name, count):
    base = anadyn.base_parameters(name)
    assert base.rank == count and base.exact is not None
    assert base.exact_difference < 1e-9
    if name == "rr":              # L1 = 1: m2 regroups into bar 1's first moment and Izz
        assert "Izz_bar1R = Izz_bar1 + m_bar2 + Ia_bar1" in base.expressions()
        assert "mx_bar1R = mx_bar1 + m_bar2" in base.expressions()
    # the base parameters reproduce Y pi for any pi
    model = anadyn.parametric_model(name)
    pi = np.random.default_rng(0).normal(size=len(model.names))
    Y = np.concatenate(model.regressor(*_states(model, 5, 9)))
    assert np.allclose(Y @ pi, Y[:, list(base.independent)] @ base.of(pi), atol=1e-10)


def test_base_parameters_printed(capsys):
    assert main(["equations", "rr", "--base-parameters"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("rr: 11 base parameters of 26")
    assert "exact coefficients (Kane, rational): numeric ones agree to" in out


# -- identification ---------------------------------------------------------------------
def fourier_motion(n, t, seed, amplitude=0.3, period=10.0, harmonics=5):
    rng = np.random.default_rng(seed)
    w = 2 * math.pi / period
    q, dq, ddq = (np.zeros((len(t), n)) for _ in range(3))
    for l in range(1, harmonics + 1):
        a, b = rng.normal(0, amplitude, n) / l, rng.normal(0, amplitude, n) / l
        s, c = np.sin(w * l * t)[:, None], np.cos(w * l * t)[:, None]
        q += (s * a - c * b) / (w * l)
        dq += c * a + s * b
        ddq += w * l * (-s * a + c * b)
    return q, dq, ddq


def pinocchio_data(oracle, t, seed, armature, viscous, coulomb):
    """Actuator efforts by Pinocchio's RNEA with armature, plus friction."""
    model = oracle.model
    q, dq, ddq = fourier_motion(len(model.coordinates), t, seed)
    B_inv = np.linalg.inv(model.B)
    efforts = np.empty((len(t), len(model.actuators)))
    for k in range(len(t)):
        rate = model.J @ dq[k]
        friction = model.J.T @ (viscous * rate + coulomb * np.tanh(
            rate / model.friction_velocity))
        efforts[k] = B_inv @ (oracle.rnea(q[k], dq[k], ddq[k], armature[oracle.rows])
                              + friction)
    return q, dq, ddq, efforts


def _truth(model, armature, viscous, coulomb):
    pi = model.nominal.copy()
    drive = 10 * len(model.bodies)
    pi[drive::3], pi[drive + 1::3], pi[drive + 2::3] = armature, viscous, coulomb
    return pi


def _write_data(path, model, t, q, dq, ddq, efforts, rates=True):
    names = list(model.coordinates)
    header = ["t", *names] + ([f"d{c}" for c in names] + [f"dd{c}" for c in names]
                              if rates else []) + list(model.actuators)
    columns = [t, *q.T] + ([*dq.T, *ddq.T] if rates else []) + [*efforts.T]
    write_csv(path, header, columns)


def test_identification_from_pinocchio_data(tmp_path, capsys):
    """UR5: noise-free through the command line, then with noise."""
    oracle = Pinocchio(REPO / "tests" / "data" / "urdf" / "ur5_robot.urdf")
    model = oracle.model
    nj = len(model.J)
    rng = np.random.default_rng(1)
    armature, viscous, coulomb = (rng.uniform(0.05, 0.5, nj), rng.uniform(0.1, 2, nj),
                                  rng.uniform(0.1, 2, nj))
    t = np.linspace(0, 10, 1001)
    q, dq, ddq, efforts = pinocchio_data(oracle, t, 4, armature, viscous, coulomb)
    data = tmp_path / "ur5.csv"
    _write_data(data, model, t, q, dq, ddq, efforts)
    out = tmp_path / "out"
    assert main(["identify", str(REPO / "tests/data/urdf/ur5_robot.urdf"), str(data),
                 "--out", str(out), "--no-plot"]) == 0
    capsys.readouterr()
    report = __import__("json").loads((out / "identify.json").read_text())
    base = base_parameters(model)
    truth = base.of(_truth(model, armature, viscous, coulomb))
    found = np.array([report["base_parameters"][name]["estimate"] for name in base.base_names])
    error = np.abs(found - truth) / np.maximum(np.abs(truth), 1e-3 * np.abs(truth).max())
    print(f"ur5 noise-free: max relative error of the {base.rank} base parameters "
          f"{error.max():.1e}, condition number {report['condition_number']:.3g}")
    assert error.max() < 1e-8

    sigma = 0.01 * np.abs(efforts).max()
    noisy = efforts + np.random.default_rng(2).normal(0, sigma, efforts.shape)
    result = estimate.identify(model, estimate.Measurements(
        "noisy", t, q, dq, ddq, noisy, "given"), base)
    ratio = np.abs(result.estimate - truth) / result.std
    held = result.rms(True)
    print(f"ur5, noise {sigma:.3g}: |error|/std max {ratio.max():.2f}, "
          f"{np.mean(ratio < 2):.0%} within 2 std; held-out RMS / noise "
          f"{held.min() / sigma:.3f}..{held.max() / sigma:.3f}")
    assert ratio.max() < 4 and np.mean(ratio < 2) > 0.85
    assert np.all(np.abs(held / sigma - 1) < 0.2)
    assert np.all(np.abs(result.sigma / sigma - 1) < 0.1)


def test_identified_robot_file_has_the_estimate(tmp_path, capsys):
    """rr (joint 2 turns by q2 - q1): data from anadyn's inverse dynamics of a heavier
    rr, rates given; the written robot file loads and has the estimated base
    parameters; with --physical too."""
    truth_text = (REPO / "robots" / "rr.yaml").read_text().replace(
        "m1: 1.0, m2: 1.0", "m1: 1.5, m2: 0.7")
    truth = tmp_path / "truth.yaml"
    truth.write_text(truth_text)
    model = anadyn.parametric_model(truth)
    t = np.linspace(0, 10, 801)
    q, dq, ddq = fourier_motion(2, t, 8, amplitude=0.5)
    motion = tmp_path / "motion.csv"
    _write_data(motion, model, t, q, dq, ddq, np.zeros((len(t), 2)))
    assert main(["inverse", str(truth), "--motion", str(motion), "--no-roundtrip",
                 "--no-plot", "--out", str(tmp_path / "measured")]) == 0
    measured = str(tmp_path / "measured" / "inverse.csv")
    # rr's bars are slender (ixx = 0): the nearest parameters with the estimate leave
    # the rigid bodies' range, so no robot file without --physical
    assert main(["identify", "rr", measured, "--out", str(tmp_path / "plain")]) == 0
    assert "no robot file: the estimate is not a valid robot" in capsys.readouterr().out
    assert not (tmp_path / "plain" / "rr_identified.yaml").exists()
    out = tmp_path / "physical"
    assert main(["identify", "rr", measured, "--out", str(out), "--physical"]) == 0
    written = out / "rr_identified.yaml"
    assert written.is_file() and (out / "identify.png").is_file()
    again = parametric_model(anadyn.load(written))
    base = base_parameters(model, exact=False)
    difference = base.of(again.nominal) - base.of(model.nominal)
    print(f"rr --physical: largest |base parameter of the file - truth| "
          f"{np.abs(difference).max():.1e}")
    # the fit stops at least_squares' default tolerances: round-off in the data or in Y
    # moves its end point between 1.5e-5 and 2e-5 (measured), not beyond
    assert np.abs(difference).max() < 5e-5
    capsys.readouterr()


def test_one_geared_joint_has_inertia_I_plus_N2_Jr(tmp_path):
    """A wheel turning about z (no gravity torque), rotor inertia J_r behind a gear of
    ratio N: tau = (I + N^2 J_r) ddq + Fv dq.  The regressor with Ia = N^2 J_r gives
    it; identification finds I + N^2 J_r as one base parameter (Izz and Ia regroup)."""
    I, N, J_r, Fv = 0.02, 50.0, 3e-5, 0.1
    text = ("name: wheel\ncoordinates: {q: {initial: 0}}\nbodies:\n"
            "  - name: disc\n    parent: ground\n"
            "    joint: {type: revolute, axis: [0, 0, 1], displacement: q}\n"
            f"    mass: 2\n    inertia: {{ixx: 0.01, iyy: 0.01, izz: {I}}}\n"
            "actuators:\n  tau: {joint: disc}\n")
    (tmp_path / "wheel.yaml").write_text(text)
    model = anadyn.parametric_model(tmp_path / "wheel.yaml")
    pi = model.nominal.copy()
    pi[model.names.index("Ia_disc")] = N ** 2 * J_r
    pi[model.names.index("Fv_disc")] = Fv
    Y = model.regressor([0.3], [0.0], [1.0])[0]
    assert Y @ pi == pytest.approx([I + N ** 2 * J_r], rel=1e-14)
    t = np.linspace(0, 5, 401)
    q, dq, ddq = fourier_motion(1, t, 3)
    tau = (I + N ** 2 * J_r) * ddq + Fv * dq
    base = base_parameters(model)
    result = estimate.identify(model, estimate.Measurements("wheel", t, q, dq, ddq, tau,
                                                            "given"), base)
    values = dict(zip(base.base_names, result.estimate))
    assert base.expressions()[0] == "Izz_discR = Izz_disc + Ia_disc"
    assert values["Izz_discR"] == pytest.approx(I + N ** 2 * J_r, rel=1e-10)
    assert values["Fv_disc"] == pytest.approx(Fv, rel=1e-10)


# -- excite -----------------------------------------------------------------------------
def test_excite_writes_a_motion_that_inverse_and_identify_take(tmp_path, capsys):
    out = tmp_path / "excite"
    assert main(["excite", "rr", "--harmonics", "2", "--iterations", "5", "--period", "4",
                 "--out", str(out)]) == 0
    assert main(["inverse", str(out / "rr_excite.yaml"), "--no-plot", "--no-roundtrip",
                 "--out", str(tmp_path / "inv")]) == 0
    assert main(["inverse", "rr", "--motion", str(out / "excite.csv"), "--no-plot",
                 "--no-roundtrip", "--out", str(tmp_path / "inv2")]) == 0
    header = (tmp_path / "inv" / "inverse.csv").read_text().splitlines()[0].split(",")
    ours = np.loadtxt(tmp_path / "inv" / "inverse.csv", delimiter=",", skiprows=1)
    csv = np.loadtxt(out / "excite.csv", delimiter=",", skiprows=1)
    # the robot file's trajectory is the CSV's motion; the CSV's efforts are anadyn's
    assert np.abs(ours[:, 1:3] - csv[:len(ours), 1:3]).max() < 1e-9
    efforts = [header.index(a) for a in ("T01z", "T12z")]
    assert np.abs(ours[:, efforts] - csv[:len(ours), -2:]).max() < 1e-7
    capsys.readouterr()


@pytest.mark.slow
def test_excite_keeps_the_ur5_limits():
    result = anadyn.excite("ur5", harmonics=3, iterations=15, period=8)
    model = result.model
    limits = [(float(lim.velocity), float(lim.effort)) for lim in model.limits]
    assert np.all(np.abs(result.dq) <= [v for v, _ in limits])
    assert np.all(np.abs(result.efforts) <= [e for _, e in limits])
    assert result.condition < 1e4


# -- bad input --------------------------------------------------------------------------
def _rr_data(tmp_path, rows=50):
    model = anadyn.parametric_model("rr")
    t = np.linspace(0, 2, rows)
    q, dq, ddq = fourier_motion(2, t, 1)
    tau = np.einsum("nap,p->na", model.actuator_regressor(q, dq, ddq), model.nominal)
    path = tmp_path / "data.csv"
    _write_data(path, model, t, q, dq, ddq, tau)
    return path


def _non_numeric(text):
    lines = text.splitlines()
    fields = lines[3].split(",")
    fields[1] = "fast"
    lines[3] = ",".join(fields)
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("change, message", [
    (lambda text: text.replace(",T12z", ",other", 1),
     r"data\.csv:1: no column T12z: expected t, q1, q2, T01z, T12z \(the robot's "
     r"coordinates and actuators"),
    (_non_numeric, r"data\.csv:4: column q1: must be a finite number, got 'fast'"),
    (lambda text: text.replace("t,q1,q2", "t,shoulder,elbow", 1),
     r"data\.csv:1: no column q1, q2: expected t, q1, q2"),
    (lambda text: "\n".join(text.splitlines()[:4]) + "\n",
     r"data\.csv: 3 samples give 6 equations for 11 base parameters: give at least 6 "
     r"samples"),
], ids=["missing-column", "non-numeric", "other-robot", "too-few-samples"])
def test_bad_data_one_line_exit_2_nothing_written(tmp_path, capsys, change, message):
    path = _rr_data(tmp_path)
    path.write_text(change(path.read_text()))
    out = tmp_path / "out"
    assert main(["identify", "rr", str(path), "--out", str(out), "--holdout", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len([line for line in err if line.startswith("anadyn: error:")]) == 1
    assert re.search(message, err[-1]), err[-1]
    assert not out.exists()


def test_unexcited_motion_is_refused(tmp_path, capsys):
    model = anadyn.parametric_model("rr")
    t = np.linspace(0, 2, 100)
    q = np.zeros((100, 2))
    q[:, 0] = 0.3 * np.sin(t)                             # q2 still: bar 2's not excited
    path = tmp_path / "data.csv"
    dq, ddq = np.gradient(q, t, axis=0), np.gradient(np.gradient(q, t, axis=0), t, axis=0)
    _write_data(path, model, t, q, dq, ddq, np.ones((100, 2)))
    assert main(["identify", "rr", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "does not excite every base parameter" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, message", [
    (["identify", "rr", "DATA", "--holdout", "1"], "--holdout must be at least 0 and below 1"),
    (["excite", "rr", "--harmonics", "0"], "--harmonics must be above 0, got 0"),
    (["excite", "rr", "--margin", "1.5"], "--margin must be above 0 and at most 1"),
])
def test_wrong_settings_name_their_flag(tmp_path, capsys, argv, message):
    data = str(_rr_data(tmp_path))
    out = tmp_path / "out"
    assert main([data if a == "DATA" else a for a in argv] + ["--out", str(out)]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1] == f"anadyn: error: {message}" + (
        ", got 1.0" if "holdout" in message else ", got 1.5" if "margin" in message else "")
    assert not out.exists()


def test_physically_consistent_estimate_is_a_rigid_body_and_fits():
    """rrt from its own regressor with noise: the least-squares parameters nearest the
    file's leave the rigid bodies' range; the consistent ones have every pseudo-inertia
    positive semidefinite (to round-off: rrt's first link is a slender rod, on the
    boundary) and fit the data as well (training RMS within 1 %)."""
    model = anadyn.parametric_model("rrt")
    t = np.linspace(0, 10, 1001)
    q, dq, ddq = fourier_motion(3, t, 6, amplitude=0.4)
    tau = np.einsum("nap,p->na", model.actuator_regressor(q, dq, ddq), model.nominal)
    tau += np.random.default_rng(0).normal(0, 0.05, tau.shape)
    data = estimate.Measurements("rrt", t, q, dq, ddq, tau, "given")
    plain = estimate.identify(model, data)
    consistent = estimate.identify(model, data, base=plain.base, physical=True)
    assert not plain.consistent and plain.robot_text is None
    assert consistent.consistent and consistent.robot_text is not None
    for b in range(len(model.bodies)):
        eigenvalues = np.linalg.eigvalsh(estimate.pseudo_inertia(consistent.pi[10 * b:10 * b + 10]))
        assert eigenvalues[0] >= -1e-12 * eigenvalues[-1]
    assert not all(estimate.realizable(plain.pi[10 * b:10 * b + 10]) for b in range(3))
    assert np.all(consistent.file_rms <= 1.01 * plain.rms())
