"""`anadyn inverse` on robots with spherical and floating joints (nq != n): a
quaternion's path prescribed (trajectory expressions, or measured columns), the
body's angular velocity and its derivative from it, the efforts of the actuated
joints and the wrench the motion needs on the joints no actuator reaches.

Independent checks: a free robot simulated under its joint laws needs no base
wrench and the efforts it was simulated with (its own forward dynamics, an
articulated-body solve, against the inverse's Newton-Euler pass); Pinocchio's RNEA
on a free-flyer URDF robot (its first six entries, mapped); the closed form of a
conical pendulum's steady precession; the quaternion <-> speed maps against the
kinematic differential equation dq = 1/2 q (x) (0, w).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.numeric import measured
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services import inverse as service

FREE_ARM = """name: free_arm
gravity: [0, 0, 0]
coordinates:
  a: {initial: 0.3}
  b: {initial: -0.2}
speeds: {base_wx: {initial: 0.4}, base_wy: {initial: -0.3}, base_wz: {initial: 1.5}}
bodies:
  - name: base
    joint: {type: floating}
    mass: 3.0
    com: [0.05, -0.02, 0.01]
    inertia: {ixx: 0.11, iyy: 0.2, izz: 0.25, ixy: 0.01, ixz: -0.02, iyz: 0.015}
  - name: upper
    parent: base
    joint: {type: revolute, axis: [0, 1, 0], origin: [0.2, 0, 0.1], displacement: a}
    mass: 1.0
    com: [0.3, 0, 0]
    inertia: {ixx: 0.01, iyy: 0.03, izz: 0.03}
  - name: lower
    parent: upper
    joint: {type: revolute, axis: [0, 0, 1], origin: [0.6, 0, 0], displacement: b}
    mass: 0.5
    com: [0.2, 0, 0]
    inertia: {ixx: 0.005, iyy: 0.01, izz: 0.01}
actuators:
  Ta: {joint: upper}
  Tb: {joint: lower}
controller:
  laws:
    Ta: -20*(a - 0.3 - 0.5*sin(2*t)) - 4*da
    Tb: -10*(b + 0.2 - 0.4*sin(3*t)) - 2*db
simulation: {t_end: 1, output_step: 0.01}
"""
WRENCH = ["base_fx", "base_fy", "base_fz", "base_mx", "base_my", "base_mz"]

# a rod (mass m, length L) hung from a ball joint, tilted by a from the downward
# vertical and turned about the vertical at the rate W: q(t) = Rz(W t) (x) Rx(a)
CONICAL = """name: conical
parameters: {{L: 1.0, m: 1.0, g: 9.81, a: pi/6, W: {rate!r}}}
gravity: [0, 0, -g]
coordinates:
  qw: {{initial: cos(a/2)}}
  qx: {{initial: sin(a/2)}}
  qy: {{}}
  qz: {{}}
bodies:
  - name: rod
    joint: {{type: spherical, coordinates: [qw, qx, qy, qz], speeds: [wx, wy, wz]}}
    mass: m
    com: [0, 0, -L/2]
    inertia: {{ixx: m*L**2/12, iyy: m*L**2/12, izz: m*L**2/1200}}
trajectory:
  kind: expression
  duration: 2
  expressions:
    qw: cos(W*t/2)*cos(a/2)
    qx: cos(W*t/2)*sin(a/2)
    qy: sin(W*t/2)*sin(a/2)
    qz: sin(W*t/2)*cos(a/2)
simulation: {{output_step: 0.02}}
"""


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))


def read(path: Path) -> dict:
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def run(*argv) -> int:
    return main([*map(str, argv)])


# -- the maps between the coordinates' rates and the speeds ---------------------------------
def test_speed_map_inverts_the_kinematic_differential_equation():
    """dq = 1/2 q (x) (0, w) written out (docs/reference/joints.md) against
    ``SpeedMap.rates``; ``speeds`` inverts it for any norm of q; the turn between two
    attitudes is their relative rotation's angle."""
    rng = np.random.default_rng(3)
    speed_map = measured.SpeedMap(5, ((1, 2, 3, 4),))
    q = rng.normal(size=(6, 5))
    u, du = rng.normal(size=(6, 4)), rng.normal(size=(6, 4))
    dq, ddq = speed_map.rates(q, u, du)
    w, x, y, z = q[:, 1:].T
    wx, wy, wz = u[:, 1:].T
    written = np.stack([-(x * wx + y * wy + z * wz), w * wx + y * wz - z * wy,
                        w * wy + z * wx - x * wz, w * wz + x * wy - y * wx], 1) / 2
    assert np.abs(dq[:, 1:] - written).max() < 1e-15
    assert np.array_equal(dq[:, 0], u[:, 0]) and np.array_equal(ddq[:, 0], du[:, 0])
    back = speed_map.speeds(q, dq, ddq)
    assert max(np.abs(back[0] - u).max(), np.abs(back[1] - du).max()) < 1e-12
    scaled = q.copy()
    scaled[:, 1:] *= 2.5                        # the direction is the attitude
    assert np.abs(speed_map.speeds(scaled, *speed_map.rates(scaled, u, du))[0] - u).max() < 1e-12
    turn = np.array([0.0, math.cos(0.35), math.sin(0.35), 0.0, 0.0])   # 0.7 rad about x
    start = np.array([0.1, 0.5, 0.5, 0.5, 0.5])
    after = np.concatenate([[0.1], measured.product(start[1:], turn[1:])])
    assert abs(speed_map.deviations(after, start)[1] - 0.7) < 1e-15


# -- (a) a free robot: simulate, then invert its motion ---------------------------------------
@pytest.fixture(scope="module")
def free_run(tmp_path_factory):
    """simulate.csv of the free arm (1 s, every 0.01 s), and the same rows with the
    exact derivatives of the speeds added (``d<speed>``: the forward dynamics at
    each row, M^-1 (F + B tau), an articulated-body solve)."""
    folder = tmp_path_factory.mktemp("free")
    path = folder / "free_arm.yaml"
    path.write_text(FREE_ARM)
    assert run("simulate", path, "--no-plot", "--out", folder / "sim") == 0
    rows = read(folder / "sim" / "simulate.csv")
    model = numeric_model(path)
    x = np.array([[rows[s][k] for s in model.state_names()] for k in range(len(rows["t"]))])
    du = np.array([model.rhs(t, state)[model.nq:] for t, state in zip(rows["t"], x)])
    exact = folder / "exact.csv"
    header = [*rows, *("d" + u for u in model.speeds)]
    table = np.column_stack([*rows.values(), du])
    exact.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                                         for r in table) + "\n")
    return path, rows, exact, du, model, folder / "sim" / "simulate.csv"


def test_a_free_robot_needs_no_base_wrench_for_its_own_motion(free_run, tmp_path):
    """With the speeds' exact derivatives in the file, inverse returns the efforts
    simulate applied (1e-10 relative: the CSV's 17 digits) and a base wrench of
    zero (1e-12 of the efforts' scale), and its round trip follows the motion
    (quaternion error as an angle)."""
    path, rows, exact, _, _, _ = free_run
    out = tmp_path / "inv"
    assert run("inverse", path, "--motion", exact, "--no-plot", "--out", out) == 0
    result = read(out / "inverse.csv")
    scale = max(np.abs(rows["Ta"]).max(), np.abs(rows["Tb"]).max())
    for name in ("Ta", "Tb"):
        assert np.abs(result[name] - rows[name]).max() < 1e-10 * scale
    assert max(np.abs(result[name]).max() for name in WRENCH) < 1e-12 * scale
    summary = json.loads((out / "inverse.json").read_text())
    assert list(summary["wrench"]["columns"]) == WRENCH
    assert "zero for a motion a free robot makes with its joints alone" in \
        summary["wrench"]["convention"]
    trip = summary["roundtrip"]
    assert trip["passed"] and trip["max_error"] < 1e-8
    assert "base_qw..base_qz turn" in trip["errors"]


def test_differentiated_measurements_leave_only_the_filters_error(free_run, tmp_path):
    """From simulate.csv alone (speeds given, their derivatives by the Savitzky-Golay
    filter, 9 samples of degree 4 at 0.01 s), the base wrench is exactly what the
    filter's acceleration error Δdu asks of the free joints, (M Δdu) on the base rows,
    and the efforts are off by (M Δdu) on the joints' rows (both to 1e-9 relative).
    The size of that error, stated: away from the first and last 10 samples (the
    filter's one-sided end fits) the wrench stays below 1e-4 N or N·m, 2e-4 of the
    efforts' peak (measured: 4e-5)."""
    path, rows, _, du, model, simulated = free_run
    out = tmp_path / "inv"
    assert run("inverse", path, "--motion", simulated, "--no-plot", "--out", out,
               "--no-roundtrip", "--smoothing-window", "9", "--smoothing-order", "4") == 0
    result = read(out / "inverse.csv")
    estimated = np.stack([result["d" + u] for u in model.speeds], 1)
    q = np.stack([rows[c] for c in model.coordinates])
    u = np.stack([rows[s] for s in model.speeds])
    M = model.mfb(rows["t"], q, u)[0]
    needed = np.einsum("kij,kj->ki", M, estimated - du)
    wrench = np.stack([result[name] for name in WRENCH], 1)
    scale = np.abs(needed).max()
    assert np.abs(wrench - needed[:, -6:]).max() < 1e-9 * scale
    assert np.abs(result["Ta"] - rows["Ta"] - needed[:, 0]).max() < 1e-9 * scale
    assert np.abs(wrench[10:-10]).max() < 1e-4


# -- (b) the base wrench against Pinocchio's RNEA -------------------------------------------
def test_base_wrench_and_efforts_match_pinocchios_free_flyer_rnea():
    """Solo12 with a free base (``import --floating-base``) at 20 random states (q, u,
    du): the service's efforts and base wrench (``free_rows``, ``split``) against
    tau = rnea(q, v, a) of Pinocchio's free-flyer model (``test_floating.Mapping``:
    v = J u, a = J du + Jdot u).  Pinocchio's first six entries are the force f and
    moment n on the base in its own axes (about its origin); anadyn reports the force
    in world axes, R f, and the same moment.  Agreement to 1e-9 relative."""
    pin = pytest.importorskip("pinocchio")
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import native, recursive
    from test_floating import quaternion_matrix, urdf_robot

    robot, pin_model, mapping = urdf_robot("solo_description/robots/solo12.urdf")
    model = native.RecursiveModel(RobotInfo.from_robot(robot), recursive.source(robot))
    rng = np.random.default_rng(7)
    states = [mapping.random(rng) for _ in range(20)]
    q, u, du = (np.array(v) for v in zip(*states))
    demand, B = service.InverseDynamics(model, None).demand(0.0, q, u, du)
    B = np.broadcast_to(B, (len(q), model.n, len(model.effort_names)))
    free, columns = service.free_rows(model, B)
    assert [name for name, _ in columns] == [f"base_link_{p}" for p in
                                             ("fx", "fy", "fz", "mx", "my", "mz")]
    tau, wrench = service.InverseDynamics(model, None, free).apportion(demand, B)
    data = pin_model.createData()
    worst = 0.0
    for k in range(len(q)):
        qp, vp, ap, _, _ = mapping.to_pin(q[k], u[k], du[k])
        expected = pin.rnea(pin_model, data, qp, vp, ap)
        R = quaternion_matrix(*q[k][mapping.quaternion])
        base = np.concatenate([R @ expected[:3], expected[3:6]])
        joints = [expected[pin_model.joints[pin_model.getJointId(name[4:])].idx_v]
                  for name in model.effort_names]             # tau_<joint>
        scale = max(1.0, np.abs(expected).max())
        worst = max(worst, np.abs(wrench[k] - base).max() / scale,
                    np.abs(tau[k] - joints).max() / scale)
    assert worst < 1e-9


# -- (c) a prescribed orientation path: the conical pendulum ----------------------------------
def conical_moment(rate: float, L=1.0, m=1.0, g=9.81, a=math.pi / 6) -> float:
    """The moment about the rod's x axis that keeps it turning about the vertical at
    ``rate`` tilted by ``a``: H = I_O w about the pivot with w = rate z (world) turns
    with it, dH/dt = w x H, so n + r_c x (-m g z) = rate^2 z x (I_O z); in body axes
    z = (0, sin a, cos a), I_O = diag(m L^2/3, m L^2/3, m L^2/1200):
    n_x = m g L/2 sin a - rate^2 (m L^2/3 - m L^2/1200) sin a cos a, n_y = n_z = 0."""
    return m * g * L / 2 * math.sin(a) - rate ** 2 * (m * L ** 2 / 3 - m * L ** 2 / 1200) * \
        math.sin(a) * math.cos(a)


STEADY = math.sqrt(9.81 / 2 / ((1 / 3 - 1 / 1200) * math.cos(math.pi / 6)))   # 4.127 rad/s


@pytest.mark.parametrize("formulation", [None, "kane", "lagrange"])
@pytest.mark.parametrize("rate", [2.0, STEADY])
def test_conical_pendulum_needs_the_closed_form_moment(tmp_path, rate, formulation):
    """The moment the prescribed precession needs equals the closed form (1e-12), zero at
    the steady rate sqrt(g L/2 / ((I_O - I_axis) cos a)); by the recursive Newton-Euler
    pass and by Kane's and Lagrange's closed forms; the round trip (the moment applied)
    follows the attitude to 1e-8 rad."""
    path = tmp_path / "conical.yaml"
    path.write_text(CONICAL.format(rate=rate))
    out = tmp_path / "out"
    argv = ["inverse", path, "--no-plot", "--out", out]
    assert run(*argv, *(["--formulation", formulation] if formulation else [])) == 0
    rows = read(out / "inverse.csv")
    assert np.abs(rows["mx"] - conical_moment(rate)).max() < 1e-12
    assert max(np.abs(rows["my"]).max(), np.abs(rows["mz"]).max()) < 1e-12
    assert np.allclose(rows["wz"], rate * math.cos(math.pi / 6), atol=1e-14)
    assert json.loads((out / "inverse.json").read_text())["roundtrip"]["max_error"] < 1e-8


def test_the_round_trip_measures_the_attitude_and_catches_a_wrong_moment(monkeypatch):
    """A moment off by 1e-6 relative turns the rod away from its path by more than the
    1e-6 rad tolerance within 2 s: the round trip fails on the quaternion's angle."""
    from anadyn_cli import robot_from_text

    model = numeric_model(robot_from_text(CONICAL.format(rate=2.0), "conical.yaml"))
    assert service.inverse(model).roundtrip.passed
    exact = service.InverseDynamics.applied_at
    monkeypatch.setattr(service.InverseDynamics, "applied_at",
                        lambda self, t: (exact(self, t)[0], exact(self, t)[1] * (1 + 1e-6)))
    trip = service.inverse(model).roundtrip
    assert not trip.passed and trip.coordinate == "qw..qz turn" and trip.max_error > 1e-6


FLOATING_PATH = FREE_ARM.replace("gravity: [0, 0, 0]", "gravity: [0, 0, -9.81]") + """\
trajectory:
  kind: expression
  duration: 1
  expressions:
    a: 0.3 + 0.5*sin(2*t)
    b: -0.2 + 0.4*sin(3*t)
    base_x: 0.2*t**2
    base_z: 1 + 0.1*sin(t)
    base_qw: cos(0.4*t)
    base_qx: sin(0.4*t)*0.6
    base_qz: sin(0.4*t)*0.8
"""


def test_a_prescribed_floating_base_motion_and_its_round_trip(tmp_path, capsys):
    """Base and arm both prescribed (a turn about the fixed axis (0.6, 0, 0.8) at 0.8
    rad/s): inverse.csv has the speeds, their derivatives, the efforts and the base
    wrench; the round trip, driven by efforts and wrench, follows the motion."""
    path = tmp_path / "floating.yaml"
    path.write_text(FLOATING_PATH)
    out = tmp_path / "out"
    assert run("inverse", path, "--out", out, "--rates") == 0
    text = capsys.readouterr().out
    assert "base_fz (N)" in text and "round trip: largest tracking error" in text
    header = (out / "inverse.csv").read_text().splitlines()[0].split(",")
    assert header == ["t", "a", "b", "base_x", "base_y", "base_z", "base_qw", "base_qx",
                      "base_qy", "base_qz", "da", "db", "dbase_x", "dbase_y", "dbase_z",
                      "base_wx", "base_wy", "base_wz", "dda", "ddb", "ddbase_x", "ddbase_y",
                      "ddbase_z", "dbase_wx", "dbase_wy", "dbase_wz", "Ta", "Tb", *WRENCH]
    rows = read(out / "inverse.csv")
    assert np.allclose(np.stack([rows[f"base_w{p}"] for p in "xyz"], 1), [0.48, 0, 0.64],
                       atol=1e-14)
    assert json.loads((out / "inverse.json").read_text())["roundtrip"]["passed"]
    assert (out / "inverse.png").exists()


# -- measured quaternions: made unit, signs made continuous, differentiated --------------------
def write_columns(path: Path, rows: dict, names: list[str], change=None) -> Path:
    data = {name: rows[name].copy() for name in names}
    if change is not None:
        change(data)
    path.write_text(",".join(names) + "\n" + "\n".join(
        ",".join(repr(float(data[n][k])) for n in names) for k in range(len(rows["t"]))) + "\n")
    return path


def test_positions_only_angular_velocity_from_the_differentiated_quaternion(free_run, tmp_path,
                                                                           capsys):
    """Only t and the coordinates: w = 2 vec(conj(q) (x) dq) with dq the Savitzky-Golay
    derivative of the quaternion's columns (scipy's savgol_filter and the product
    written out here: 1e-12), within 5e-3 rad/s of the simulated w away from the ends
    (the filter's bias: the other rates miss by as much, 4e-3).  The same rows 1e-4 off
    unit and with their sign flipped on 30 rows give the same result, with a warning."""
    from scipy.signal import savgol_filter

    path, rows, _, _, model, _ = free_run
    names = ["t", *model.coordinates]
    clean = write_columns(tmp_path / "clean.csv", rows, names)
    quaternion = [f"base_q{p}" for p in "wxyz"]

    def spoil(data):
        for name in quaternion:
            data[name] *= 1 + 1e-4
            data[name][30:60] *= -1
    spoiled = write_columns(tmp_path / "spoiled.csv", rows, names, spoil)
    for source, out in ((clean, "clean"), (spoiled, "spoiled")):
        assert run("inverse", path, "--motion", source, "--no-plot", "--no-roundtrip",
                   "--out", tmp_path / out) == 0
    assert capsys.readouterr().err == (
        f"anadyn: {spoiled}: the quaternion (base_qw, base_qx, base_qy, base_qz) has norm "
        "1.0001 at t = 0 s (off 1 by up to 0.0001); made unit\n")
    first, second = read(tmp_path / "clean" / "inverse.csv"), read(tmp_path / "spoiled" /
                                                                    "inverse.csv")
    for name in ("base_wx", "base_wy", "base_wz", "Ta", *WRENCH):
        assert np.abs(first[name] - second[name]).max() < 1e-9 * max(1, np.abs(first[name]).max())
    w, x, y, z = (rows[name] for name in quaternion)
    dw, dx, dy, dz = (savgol_filter(rows[name], 21, 3, deriv=1, delta=0.01, mode="interp")
                      for name in quaternion)
    expected = 2 * np.stack([w * dx - x * dw - y * dz + z * dy,       # vec(conj(q) (x) dq)
                             w * dy - y * dw - z * dx + x * dz,
                             w * dz - z * dw - x * dy + y * dx], 1)
    found = np.stack([first[f"base_w{p}"] for p in "xyz"], 1)
    assert np.abs(found - expected).max() < 1e-12
    simulated = np.stack([rows[f"base_w{p}"] for p in "xyz"], 1)
    assert np.abs(found - simulated)[10:-10].max() < 5e-3


# -- (d) bad input: one line, exit 2, nothing written ------------------------------------------
def test_bad_floating_input_is_one_line(free_run, tmp_path, capsys):
    path, rows, _, _, model, _ = free_run
    names = ["t", *model.coordinates]
    quaternion = [f"base_q{p}" for p in "wxyz"]

    def scale(data):
        for name in quaternion:
            data[name] *= 1.1
    long = write_columns(tmp_path / "long.csv", rows, names, scale)
    partial = write_columns(tmp_path / "partial.csv", rows, [*names, "base_wx"])
    flip = tmp_path / "flip.yaml"
    flip.write_text(CONICAL.format(rate=1.0).split("trajectory:")[0]     # q to -q
                    + "trajectory: {kind: cycloidal, duration: 1, to: {qw: -cos(a/2), "
                    "qx: -sin(a/2)}}\n")
    lame = tmp_path / "lame.yaml"
    lame.write_text(FLOATING_PATH.replace("  Tb: {joint: lower}\n", "")
                    .replace("    Tb: -10*(b + 0.2 - 0.4*sin(3*t)) - 2*db\n", ""))
    named = tmp_path / "named.yaml"
    named.write_text(FREE_ARM.replace("{type: floating}", "{type: floating, coordinates: [px, py, "
                                      "pz, e0, e1, e2, e3], speeds: [p, q, r]}")
                     .replace("speeds: {base_wx: {initial: 0.4}, base_wy: {initial: -0.3}, "
                              "base_wz: {initial: 1.5}}", "speeds: {p: {initial: 0.4}}")
                     + "trajectory: {kind: cycloidal, duration: 1, to: {a: 1}}\n")
    cases = [
        ([path, "--motion", long], f"{long}: the quaternion (base_qw, base_qx, base_qy, "
         "base_qz) has norm 1.1 at t = 0 s; it must be a unit quaternion (within 0.01)"),
        ([path, "--motion", partial], f"{partial}: has base_wx but not da, db, dbase_x, "
         "dbase_y, dbase_z, base_wy, base_wz: give every speed column or none"),
        ([flip], f"{flip}: trajectory: the prescribed quaternion (qw, qx, qy, qz) is zero at "
         "t = 0.5 s (it must give an attitude all along: a path from q to -q passes through "
         "zero)"),
        ([lame], f"{lame}: actuators: 2 coordinates, 1 actuator: inverse dynamics needs one "
         "independent actuator per coordinate (B square and non-singular); not actuated: b"),
        ([named], f"{named}: actuators: 5 coordinates, 2 actuators: inverse dynamics needs one "
         "independent actuator per coordinate (B square and non-singular); not actuated: px, "
         "py, pz (a floating joint's slides get the base wrench when named <stem>_x, <stem>_y, "
         "<stem>_z beside its quaternion <stem>_qw, ...)"),
    ]
    for k, (argv, message) in enumerate(cases):
        out = tmp_path / f"out{k}"
        assert run("inverse", *argv, "--out", out) == 2, message
        assert capsys.readouterr().err == f"anadyn: error: {message}\n"
        assert not out.exists()
