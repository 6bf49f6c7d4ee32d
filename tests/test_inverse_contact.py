"""`anadyn inverse` on robots in contact (``numeric.contact_inverse``): the contact
forces a prescribed motion needs, the rows no actuator reaches resolved by the
minimum-norm forces of the active contacts.

Independent checks: statics in closed form (a ball resting on the floor carries m g;
the quadruped standing still: the four normal forces carry m g split by the lever rule
about its mass centre, no friction, and each knee and hip torque is the moment of the
foot force and the links' weights about the joint, feet touching or sunk into the
floor); Newton's second law on the quadruped's trunk accelerated sideways (the friction
forces sum to m a); the simulation (a block braking on an incline simulated, either
model, its run fed back as measured data: the forces the law or the multipliers gave are
the forces the motion needs).
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from anadyn_cli.cli import main

ROBOTS = Path(__file__).resolve().parents[1] / "robots" / "contact"
QUAD = yaml.safe_load((ROBOTS / "quadruped_standing.yaml").read_text())
P = QUAD["parameters"]
MASS = P["mt"] + 4 * (P["ml"] + P["ms"])          # 16 kg
G = P["g"]
FEET = ["fl_foot", "fr_foot", "hl_foot", "hr_foot"]


def _rows(path: Path) -> list[dict]:
    return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(open(path))]


def _quadruped(tmp_path: Path, sideways: str = "0", sink: float = 0.0) -> Path:
    """The shipped quadruped held at its standing pose, the feet just touching the floor
    (trunk height 2 L cos(hip0) + foot radius: the legs are symmetric, hip0 = -knee0/2)
    or sunk into it by ``sink`` (m), its trunk moving sideways as ``sideways`` (an
    expression of t)."""
    scene = dict(QUAD)
    poses = {name: ("hip0" if name.endswith("hip") else "knee0")
             for name in QUAD["coordinates"] if name != "trunk_z"}
    scene["trajectory"] = {"kind": "expression", "duration": 1, "expressions": {
        **poses, "trunk_z": f"0.02 + 2*L*cos(hip0) - {sink}", "trunk_x": "0", "trunk_y": sideways,
        "trunk_qw": "1", "trunk_qx": "0", "trunk_qy": "0", "trunk_qz": "0"}}
    path = tmp_path / "quad.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    return path


def _run(tmp_path: Path, scene: Path, *extra: str) -> tuple[list[dict], dict]:
    out = tmp_path / "out"
    assert main(["inverse", str(scene), "--no-plot", "--out", str(out), *extra]) == 0
    return _rows(out / "inverse.csv"), json.loads((out / "inverse.json").read_text())


@pytest.mark.parametrize("sink", [0.0, 0.005])
def test_quadruped_standing_still_statics(tmp_path, sink):
    """Sunk 5 mm the compliant law would push 35.4 N on every foot: the forces are the
    motion's, not the law's."""
    rows, summary = _run(tmp_path, _quadruped(tmp_path, sink=sink), "--dt", "0.5",
                         "--no-roundtrip")
    # mass centre along x: each leg's thigh and shank centres lie L/2 sin(hip0) behind
    # the hip (the knee bent back by knee0 = -2 hip0), the trunk's at its origin
    s = math.sin(P["hip0"])
    xc = 4 * (P["ml"] + P["ms"]) * (-P["L"] / 2 * s) / MASS
    front = MASS * G * (0.2 + xc) / (4 * 0.2)       # the lever rule, feet at x = +-0.2
    hind = MASS * G / 2 - front
    for r in rows:
        assert sum(r[f"{f}_fn"] for f in FEET) == pytest.approx(MASS * G, abs=1e-9)
        assert r["fl_foot_fn"] == pytest.approx(front, abs=1e-9)
        assert r["fr_foot_fn"] == pytest.approx(front, abs=1e-9)
        assert r["hl_foot_fn"] == pytest.approx(hind, abs=1e-9)
        assert r["hr_foot_fn"] == pytest.approx(hind, abs=1e-9)
        assert max(abs(r[f"{f}_{k}"]) for f in FEET for k in ("ft1", "ft2")) < 1e-9
        assert all(r[f"{f}_active"] == 1.0 for f in FEET)
        wrench = ("trunk_fx", "trunk_fy", "trunk_fz", "trunk_mx", "trunk_my", "trunk_mz")
        assert max(abs(r[w]) for w in wrench) < 1e-9         # the contacts carry it all
        # about the knee: the foot force (lever L sin(hip0)) against the shank's weight;
        # about the hip: the thigh's and the shank's weights (the foot is under the hip)
        for leg, fn in (("fl", front), ("fr", front), ("hl", hind), ("hr", hind)):
            knee = P["L"] * s * fn - P["ms"] * G * P["L"] / 2 * s
            hip = (P["ml"] + P["ms"]) * G * P["L"] / 2 * s
            assert r[f"{leg}_knee_torque"] == pytest.approx(knee, abs=1e-9)
            assert r[f"{leg}_hip_torque"] == pytest.approx(hip, abs=1e-9)
    contact = summary["contact"]
    assert contact["model"] == "compliant" and contact["resolution"] == "least-norm"
    assert contact["unsupported"]["samples"] == 0


def test_quadruped_accelerated_sideways_friction_sums_to_m_a(tmp_path):
    a = 2.0
    rows, summary = _run(tmp_path, _quadruped(tmp_path, f"{a / 2}*t**2"), "--dt", "0.25",
                         "--no-roundtrip")
    for r in rows:
        assert sum(r[f"{f}_ft2"] for f in FEET) == pytest.approx(MASS * a, abs=1e-9)
        assert sum(r[f"{f}_ft1"] for f in FEET) == pytest.approx(0.0, abs=1e-9)
        assert sum(r[f"{f}_fn"] for f in FEET) == pytest.approx(MASS * G, abs=1e-9)
    assert summary["contact"]["unsupported"]["samples"] == 0     # 2 m/s^2 < mu g


def _ball(tmp_path: Path, z: str = "r", x: str = "0", extra: dict | None = None) -> Path:
    scene = yaml.safe_load((ROBOTS / "bouncing_ball.yaml").read_text())
    scene["trajectory"] = {"kind": "expression", "duration": 1,
                           "expressions": {"x": x, "z": z, "spin": "0"}}
    scene.update(extra or {})
    path = tmp_path / "ball.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    return path


@pytest.mark.parametrize("model", ["compliant", "rigid"])
def test_ball_resting_on_the_floor_carries_its_weight(tmp_path, model):
    extra = {}
    if model == "rigid":
        extra["contacts"] = {"model": "rigid", "restitution": 0.5, "friction": 0.5,
                             "geometry": [{"name": "floor", "body": "ball", "radius": "r"}]}
    rows, summary = _run(tmp_path, _ball(tmp_path, extra=extra), "--dt", "0.5")
    for r in rows:
        assert r["floor_fn"] == pytest.approx(0.5 * 9.81, abs=1e-12)
        assert (r["floor_ft1"], r["floor_ft2"], r["floor_active"]) == (0.0, 0.0, 1.0)
        assert (r["f_x"], r["f_z"], r["m_spin"]) == (0.0, 0.0, 0.0)
    assert summary["contact"]["model"] == model
    assert summary["roundtrip"]["passed"]


def test_motions_the_contacts_cannot_support_are_flagged(tmp_path, capsys):
    # lifted off the floor: the contact lets go, the ball's weight is a residual
    rows, summary = _run(tmp_path, _ball(tmp_path, z="r + 0.001*t**2"), "--dt", "0.5",
                         "--no-roundtrip")
    assert [r["floor_active"] for r in rows] == [1.0, 0.0, 0.0]
    assert rows[-1]["f_z"] == pytest.approx(0.5 * (9.81 + 0.002), abs=1e-12)
    unsupported = summary["contact"]["unsupported"]
    assert unsupported["samples"] == 2 and set(unsupported["reasons"]) == {"residual"}
    # the quadruped's trunk pushed sideways at 10 m/s^2 > mu g = 7.85 m/s^2: its feet
    # must give m a, outside their friction cone; and it would tip over (above
    # g w / (2 h) = 4 m/s^2, w = 0.3 m between its feet, h = 0.37 m): one side pulls
    rows, summary = _run(tmp_path, _quadruped(tmp_path, "5*t**2"), "--dt", "0.5",
                         "--no-roundtrip")
    assert sum(rows[0][f"{f}_ft2"] for f in FEET) == pytest.approx(MASS * 10, abs=1e-9)
    reasons = summary["contact"]["unsupported"]["reasons"]
    assert set(reasons) == {"outside_cone", "pulling"}
    assert reasons["outside_cone"]["samples"] == reasons["pulling"]["samples"] == 3
    assert rows[0]["fl_foot_fn"] < 0 < rows[0]["fr_foot_fn"]    # the left feet lift
    # gravity upwards: resting needs the floor to pull
    scene = _ball(tmp_path, extra={"gravity": [0, 0, "g"]})
    rows, summary = _run(tmp_path, scene, "--dt", "0.5", "--no-roundtrip")
    assert rows[0]["floor_fn"] == pytest.approx(-0.5 * 9.81)
    assert summary["contact"]["unsupported"]["reasons"]["pulling"]["samples"] == 3
    err = capsys.readouterr().err
    assert err.count("anadyn: warning: the contacts cannot support") == 3


@pytest.mark.parametrize("model, settled, tolerance", [("compliant", 0.2, 1e-7),
                                                         ("rigid", 0.02, 1e-9)])
def test_a_simulated_run_fed_back_gives_its_forces(tmp_path, model, settled, tolerance):
    """block_incline braking (mu = 0.7 > tan 30): the contact forces simulate wrote
    (the compliant law's, or the rigid model's multipliers) against what its run needs
    (the rows every 2 ms, accelerations by the Savitzky-Golay filter)."""
    scene = yaml.safe_load((ROBOTS / "block_incline.yaml").read_text())
    if model == "rigid":
        scene["contacts"] = {"model": "rigid", "restitution": 0, "friction": 0.7,
                             "ground": scene["contacts"]["ground"],
                             "geometry": scene["contacts"]["geometry"]}
    path = tmp_path / "block.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    sim = tmp_path / "sim"
    assert main(["simulate", str(path), "--no-plot", "--t-end", "0.6", "--dt", "0.002",
                 "--out", str(sim)]) == 0
    rows, summary = _run(tmp_path, path, "--motion", str(sim / "simulate.csv"),
                         "--no-roundtrip")
    simulated = _rows(sim / "simulate.csv")
    # past the filter's one-sided end fits (10 rows) and the compliant sole's settling
    # (a damped oscillation too quick for the filter: 0.03 N at 0.05 s)
    window = [k for k, r in enumerate(rows) if settled <= r["t"] <= 0.58]
    for name in ("sole_fn", "sole_ft1", "sole_ft2"):
        gap = max(abs(rows[k][name] - simulated[k][name]) for k in window)
        assert gap < tolerance, name
    fn = np.array([rows[k]["sole_fn"] for k in window])
    assert fn == pytest.approx(9.81 * math.cos(math.pi / 6), abs=1e-7)   # m g cos(theta)
    assert summary["contact"]["model"] == model
    assert summary["contact"]["unsupported"]["samples"] == 0


def test_every_row_actuated_needs_no_contact_force(tmp_path):
    """A fixed-base arm resting its tip on the floor: the actuators can give the whole
    motion, so the least-norm contact force is zero (the dynamics cannot tell how hard
    it pushes)."""
    scene = tmp_path / "arm.yaml"
    scene.write_text("""name: arm
parameters: {g: 9.81}
gravity: [0, 0, -g]
coordinates:
  q: {}
bodies:
  - name: link
    joint: {type: revolute, axis: [0, 1, 0]}
    mass: 1
    com: [0.5, 0, 0]
    inertia: {ixx: 0.01, iyy: 0.08, izz: 0.08}
actuators:
  T: {joint: link}
contacts:
  stiffness: 1e5
  geometry:
    - {name: tip, body: link, point: [1, 0, 0]}
trajectory: {kind: expression, duration: 1, expressions: {q: '0'}}
""")
    rows, _ = _run(tmp_path, scene, "--dt", "0.5")
    for r in rows:
        assert (r["tip_fn"], r["tip_active"]) == (0.0, 1.0)
        assert r["T"] == pytest.approx(-9.81 * 0.5, abs=1e-12)    # holds the link's weight


@pytest.mark.parametrize("argv, message", [
    (["--contact-gap", "0"], "--contact-gap must be a positive number"),
    (["--contact-gap", "-1e-3"], "--contact-gap must be a positive number"),
    (["--contact-resolution", "bogus"], "--contact-resolution is one of least-norm, cone"),
])
def test_bad_settings_get_one_line(tmp_path, capsys, argv, message):
    scene = _ball(tmp_path)
    assert main(["inverse", str(scene), "--no-plot", "--out", str(tmp_path / "o"), *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("anadyn: error:") and message in err
    assert not (tmp_path / "o").exists()


def test_friction_between_two_bodies_spheres_is_refused(tmp_path, capsys):
    """The gripper's pads (a box against a sphere, friction 0.5): the friction's
    direction is not traced, so the law's forces cannot be taken out of F."""
    sim = tmp_path / "sim"
    assert main(["simulate", str(ROBOTS / "gripper.yaml"), "--no-plot", "--t-end", "0.05",
                 "--out", str(sim)]) == 0
    capsys.readouterr()
    assert main(["inverse", str(ROBOTS / "gripper.yaml"), "--motion",
                 str(sim / "simulate.csv"), "--no-plot", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("anadyn: error: ")
    assert "contact left_pad: its friction acts but its direction is not traced" in err
    assert not (tmp_path / "o").exists()


def test_cone_resolution_keeps_the_forces_in_their_cones(tmp_path):
    """Trunk accelerated sideways at 3 m/s^2: the least-norm forces ask the lightly
    loaded left feet for more friction than mu f_n; inside the cones (a 16-sided
    polygon) there are forces that do it, the same rows given.  Against an independent
    solver: SLSQP on min |lambda|^2 with the same rows and polygon."""
    from scipy.optimize import minimize

    from anadyn_cli.numeric.build import numeric_model
    from anadyn_cli.numeric.contact_inverse import SIDES
    from anadyn_cli.services import inverse as service

    scene, a, mu = _quadruped(tmp_path, "1.5*t**2"), 3.0, QUAD["contacts"]["friction"]
    rows, summary = _run(tmp_path, scene, "--dt", "0.5", "--no-roundtrip")
    assert set(summary["contact"]["unsupported"]["reasons"]) == {"outside_cone"}
    least = rows[0]
    rows, summary = _run(tmp_path, scene, "--dt", "0.5", "--no-roundtrip",
                         "--contact-resolution", "cone")
    assert summary["contact"]["unsupported"]["samples"] == 0
    assert summary["contact"]["resolution"] == "cone"
    for r in rows:
        assert sum(r[f"{f}_fn"] for f in FEET) == pytest.approx(MASS * G, abs=1e-9)
        assert sum(r[f"{f}_ft2"] for f in FEET) == pytest.approx(MASS * a, abs=1e-9)
        for f in FEET:
            assert math.hypot(r[f"{f}_ft1"], r[f"{f}_ft2"]) <= mu * r[f"{f}_fn"] + 1e-9
    norm = [sum(r[f"{f}_{k}"] ** 2 for f in FEET for k in ("fn", "ft1", "ft2"))
            for r in (least, rows[0])]
    assert norm[0] < norm[1]                         # the least-norm ones were outside
    # the oracle: the rows (the base's six) from the model, the polygon, SLSQP
    model = numeric_model(scene)
    result = service.inverse(model, step=0.5, roundtrip=False, friction=(mu,) * 4,
                             contact_resolution="cone")
    support, t = result.dynamics.support, result.t[:1]
    q, u, du = result.q[:1], result.dq[:1], result.ddq[:1]
    _, J, law = support.kinematics(t, q, u)
    demand = np.asarray(model.demand(t, q.T, u.T, du.T)[0]).reshape(1, -1) + law
    base = support.rows
    A = np.transpose(J[0][..., base], (2, 0, 1)).reshape(len(base), 12)
    b = demand[0, base]
    angles = 2 * np.pi * np.arange(SIDES) / SIDES
    polygon = [{"type": "ineq", "fun": lambda x, c=c, e=e: mu * math.cos(math.pi / SIDES)
                * x[3 * c] - math.cos(e) * x[3 * c + 1] - math.sin(e) * x[3 * c + 2]}
               for c in range(4) for e in angles]
    oracle = minimize(lambda x: x @ x, result.contact.forces[0].reshape(-1) * 0.5,
                      jac=lambda x: 2 * x, method="SLSQP", options={"ftol": 1e-14},
                      constraints=[{"type": "eq", "fun": lambda x: A @ x - b}, *polygon])
    assert oracle.success
    assert np.abs(oracle.x - result.contact.forces[0].reshape(-1)).max() < 1e-5
