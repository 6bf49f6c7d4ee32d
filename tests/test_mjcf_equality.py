"""MJCF <equality> connect and weld imported as anadyn loops (model.mjcf.equality).

Checks: an MJCF four-bar with a connect has the dynamics of the hand-written
robots/fourbar.yaml (the same geometry; its coordinates are MuJoCo's relative
joint angles, the file's absolute ones: q_abs = T q_rel) to 1e-12 and keeps its
drift at the default tolerances in simulate; against MuJoCo (test-only oracle),
whose connect is soft, the trajectories differ by the softness: second order in
solref's time constant and a few times MuJoCo's own constraint violation (radians
per metre of lever); a weld that locks two links gives the dynamics of the robot
without the joint between them; bad input is one line, exit 2.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from anadyn_cli.cli import main
from anadyn_cli.model import robot_from_text
from anadyn_cli.model.mjcf import import_file
from anadyn_cli.numeric.build import numeric_model

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
#: the crank-rocker of robots/fourbar.yaml (a 0.1, b 0.35, c 0.3, d 0.4 m) assembled at
#: q1 = 0 (pin above the ground link: coupler at 0.94797 rad, rocker at 1.89594 rad);
#: each joint's ref is its body's angle, so the coordinates are the coupler's angle to
#: the crank and the rocker's to the x axis; ixx 1e-6 (MuJoCo refuses 0) moves nothing
FOURBAR = """<mujoco model="fourbar">
  <compiler angle="radian"/>
  <option gravity="0 -9.81 0"/>
  <worldbody>
    <body name="crank">
      <joint name="j1" type="hinge" axis="0 0 1"/>
      <inertial pos="0.05 0 0" mass="0.5"
                diaginertia="1e-6 0.00041666666666666675 0.00041666666666666675"/>
      <body name="coupler" pos="0.1 0 0" axisangle="0 0 1 0.9479697413828936">
        <joint name="j2" type="hinge" axis="0 0 1" ref="0.9479697413828936"/>
        <inertial pos="0.175 0 0" mass="1"
                  diaginertia="1e-6 0.010208333333333331 0.010208333333333331"/>
        <site name="tip" pos="0.35 0 0"/>
      </body>
    </body>
    <body name="rocker" pos="0.4 0 0" axisangle="0 0 1 1.8959394827657874">
      <joint name="j3" type="hinge" axis="0 0 1" ref="1.8959394827657874"/>
      <inertial pos="0.15 0 0" mass="0.9" diaginertia="1e-6 0.00675 0.00675"/>
      <site name="end" pos="0.3 0 0"/>
    </body>
  </worldbody>
  <equality>
    <connect name="pin" body1="coupler" body2="rocker" anchor="0.35 0 0"/>
  </equality>
  <actuator>
    <motor name="motor" joint="j1"/>
  </actuator>
</mujoco>
"""
T = np.array([[1.0, 0, 0], [1, 1, 0], [0, 0, 1]])       # absolute = T relative angles
#: a spatial chain of three links (l2 turned a quarter turn: its joint's rpy is written
#: as pi/2); EQUALITY is replaced by each test's
CHAIN = """<mujoco model="chain">
  <compiler angle="radian"/>
  <worldbody>
    <body name="l1" pos="0 0 1">
      <joint name="j1" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="l2" pos="0.3 0 0" euler="1.5707963267948966 0 0">
        <joint name="j2" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.025"/>
        <body name="l3" pos="0 0 -0.25">
          <joint name="j3" axis="1 0 0"/>
          <geom type="box" size="0.05 0.04 0.1" pos="0 0.02 -0.1"/>
        </body>
      </body>
    </body>
  </worldbody>
  EQUALITY
</mujoco>
"""


def _write(tmp_path, text: str, name: str = "model.xml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _model(path: Path, formulation: str = "lagrange"):
    return numeric_model(robot_from_text(import_file(path).text, str(path)), formulation)


def _handwritten_fourbar():
    """robots/fourbar.yaml without its motor and speed controller (the MJCF's motor
    has control 0)."""
    data = yaml.safe_load((ROBOTS / "fourbar.yaml").read_text())
    for key in ("actuators", "controller", "trajectory"):
        data.pop(key)
    return robot_from_text(yaml.safe_dump(data, sort_keys=False), "fourbar.yaml")


def test_connect_becomes_the_loop_with_unactuated_dependents(tmp_path, capsys):
    imported = import_file(_write(tmp_path, FOURBAR))
    (loop,) = imported.data["loops"]
    assert loop["a"] == {"body": "coupler", "point": [0.35, 0, 0]}
    assert loop["b"]["body"] == "rocker"
    assert np.allclose(loop["b"]["point"], [0.3, 0, 0], rtol=0, atol=1e-15)
    assert loop["directions"] == ["x", "y"]           # z: the points stay in one plane
    coordinates = imported.data["coordinates"]
    assert [q for q, c in coordinates.items() if c.get("dependent")] == ["j2", "j3"]
    (warning,) = [w for w in imported.warnings if "<equality>" in w]
    assert "exact: MuJoCo's are soft (solref, solimp)" in warning
    # the crank's motor made it independent: without it the pivoting takes the crank
    bare = import_file(_write(tmp_path, FOURBAR.replace('<motor name="motor" joint="j1"/>',
                                                        ""), "bare.xml"))
    assert "j1" in [q for q, c in bare.data["coordinates"].items() if c.get("dependent")]


def test_fourbar_from_mjcf_has_the_handwritten_dynamics(tmp_path):
    """M and F of the tree (M_rel = T^T M_abs T, F_rel = T^T F_abs) at random states,
    and the constrained forward dynamics (the integrated field, ddq_rel = T^-1 ddq_abs)
    at states along the hand-written robot's motion, both formulations, to 1e-12."""
    path = _write(tmp_path, FOURBAR)
    rng = np.random.default_rng(29)
    hand = _handwritten_fourbar()
    for formulation in ("lagrange", "kane"):
        ours, theirs = _model(path, formulation), numeric_model(hand, formulation)
        for _ in range(10):
            q, dq = rng.uniform(-3, 3, 3), rng.normal(0, 3, 3)
            M, F, _ = (np.asarray(a, dtype=float) for a in ours.mfb(0.0, q, dq))
            M_abs, F_abs, _ = (np.asarray(a, dtype=float)
                               for a in theirs.mfb(0.0, T @ q, T @ dq))
            assert np.abs(M - T.T @ M_abs @ T).max() <= 1e-12 * np.abs(M).max()
            assert np.abs(F.ravel() - T.T @ F_abs.ravel()).max() <= 1e-12 * np.abs(F).max()
        from scipy.integrate import solve_ivp

        x0 = theirs.initial_state()
        x0[3:] = theirs.rates(0.0, x0[:3], np.array([4.0, 0, 0]))   # the crank turning
        run = solve_ivp(theirs.rhs, (0, 1), x0, rtol=1e-10, atol=1e-12, t_eval=[0.3, 0.6, 1])
        inverse = np.linalg.inv(T)
        for x in run.y.T:
            mine = ours.rhs(0.0, np.concatenate([inverse @ x[:3], inverse @ x[3:]]))
            expected = theirs.rhs(0.0, x)
            expected = np.concatenate([inverse @ expected[:3], inverse @ expected[3:]])
            assert np.abs(mine - expected).max() <= 1e-12 * np.abs(expected).max()


def test_the_comparison_sees_a_wrong_anchor(tmp_path):
    """A pin 1e-6 m off moves the dynamics far more than 1e-12 (the check can fail)."""
    path = _write(tmp_path, FOURBAR.replace('anchor="0.35 0 0"', 'anchor="0.350001 0 0"'))
    ours, theirs = _model(path), numeric_model(_handwritten_fourbar(), "lagrange")
    x = theirs.initial_state()
    inverse = np.linalg.inv(T)
    mine = ours.rhs(0.0, np.concatenate([inverse @ x[:3], inverse @ x[3:]]))
    expected = theirs.rhs(0.0, x)
    assert np.abs(mine[3:] - inverse @ expected[3:]).max() > 1e-9


def test_simulate_keeps_the_loop_closed(tmp_path, capsys):
    path = _write(tmp_path, FOURBAR)
    assert main(["simulate", str(path), "--t-end", "2", "--no-plot",
                 "--out", str(tmp_path / "run")]) == 0
    summary = json.loads((tmp_path / "run" / "simulate.json").read_text())["constraints"]
    assert summary["max_position_drift"] < 1e-9          # m (measured 5.1e-11)
    assert summary["max_velocity_drift"] < 1e-8          # m/s (measured 1.3e-9)


def _mujoco_fourbar(timeconst: float):
    """MuJoCo's passive four-bar (RK4 at half solref's time constant, the smallest
    step MuJoCo lets it have) over 1 s: qpos every 0.01 s, and the largest violation
    of its (soft) connect, in m."""
    mujoco = pytest.importorskip("mujoco")
    xml = FOURBAR.replace('anchor="0.35 0 0"/>', f'anchor="0.35 0 0" solref="{timeconst} 1" '
                          'solimp="0.9999 0.9999 0.001 0.5 2"/>').replace(
        '<option gravity="0 -9.81 0"/>',
        f'<option gravity="0 -9.81 0" timestep="{timeconst / 2}" integrator="RK4"/>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    every = int(round(0.01 / model.opt.timestep))
    samples, violation = [data.qpos.copy()], 0.0
    for _ in range(100):
        mujoco.mj_step(model, data, nstep=every)
        samples.append(data.qpos.copy())
        violation = max(violation, float(np.abs(data.efc_pos).max(initial=0.0)))
    return np.array(samples), violation


def test_fourbar_agrees_with_mujoco_to_its_softness(tmp_path):
    """Released from rest under gravity.  MuJoCo's connect holds only to a violation
    of about (its acceleration) x timeconst^2; the trajectories differ by about that
    over the lever arms (measured: 5.4e-8 rad at timeconst 4e-4 s, 1.4e-8 rad at
    2e-4 s, 3.6e-9 at 1e-4 s: the ratio 4 of a second-order softness; the
    difference over MuJoCo's largest violation, 2.3 and 2.4 rad/m).  A mapping
    error would not shrink with timeconst."""
    from scipy.integrate import solve_ivp

    model = _model(_write(tmp_path, FOURBAR))
    run = solve_ivp(model.rhs, (0, 1), model.initial_state(), method="DOP853", rtol=1e-12,
                    atol=1e-12, t_eval=np.linspace(0, 1, 101))
    ours = run.y[:3].T
    coarse, coarse_violation = _mujoco_fourbar(4e-4)
    fine, fine_violation = _mujoco_fourbar(2e-4)
    coarse_error, fine_error = np.abs(coarse - ours).max(), np.abs(fine - ours).max()
    assert np.ptp(ours[:, 0]) > 0.5                           # it moves (rad)
    assert fine_error <= 5 * fine_violation                   # rad per m of violation
    assert 3 < coarse_error / fine_error < 5                  # second order in timeconst
    assert fine_error < 3e-8


def _chain(tmp_path, equality: str, name: str = "chain.xml") -> Path:
    return _write(tmp_path, CHAIN.replace("EQUALITY", equality), name)


def test_weld_locks_the_joint_between_two_links(tmp_path):
    """The welded chain moves as the chain without j2 (l2 then part of l1): its
    independent accelerations equal the reduced tree's, and j2 stays at rest."""
    welded = _model(_chain(tmp_path, '<equality><weld body1="l1" body2="l2"/></equality>'))
    imported = import_file(tmp_path / "chain.xml")
    assert imported.data["bodies"][1]["joint"]["rpy"] == ["pi/2", 0, 0]
    assert [q for q, c in imported.data["coordinates"].items() if c.get("dependent")] == ["j2"]
    assert sum(len(loop["directions"]) for loop in imported.data["loops"]) == 1
    reduced = _model(_write(tmp_path, CHAIN.replace('<joint name="j2" axis="0 1 0"/>', "")
                            .replace("EQUALITY", ""), "reduced.xml"))
    rng = np.random.default_rng(7)
    for _ in range(10):
        q1, q3, dq1, dq3 = rng.uniform(-2, 2, 4)
        mine = welded.rhs(0.0, np.array([q1, 0.0, q3, dq1, 0.0, dq3]))
        expected = reduced.rhs(0.0, np.array([q1, q3, dq1, dq3]))
        assert abs(mine[4]) <= 1e-12 * np.abs(expected).max()          # ddj2
        assert np.abs(mine[[3, 5]] - expected[2:]).max() <= 1e-12 * np.abs(expected).max()


def test_weld_takes_three_two_and_one_directions(tmp_path):
    """A 7R loop welded to the world at its end: 6 independent equations, 3 + 2 + 1 at
    the anchor and the points 1 m along world x and y, and 6 dependent joints."""
    axes = ["0 0 1", "0 1 0", "1 0 0", "0 1 1", "1 0 1", "1 1 0", "0 0 1"]
    bodies, close = "", ""
    for k, axis in enumerate(axes):
        bodies += (f'<body name="b{k}" pos="{0.2 if k else 0} 0.05 0.1" euler="0.2 0.1 0">'
                   f'<joint name="k{k}" axis="{axis}"/><geom size="0.03"/>')
        close += "</body>"
    text = (f'<mujoco><compiler angle="radian"/><worldbody>{bodies}{close}</worldbody>'
            '<equality><weld name="w" body1="b6"/></equality></mujoco>')
    imported = import_file(_write(tmp_path, text))
    assert [loop["directions"] for loop in imported.data["loops"]] == [
        ["x", "y", "z"], ["y", "z"], ["z"]]
    assert [loop["name"] for loop in imported.data["loops"]] == ["w_1", "w_2", "w_3"]
    assert sum(bool(c.get("dependent")) for c in imported.data["coordinates"].values()) == 6
    robot_from_text(imported.text, "7r")                      # the loader accepts it


def test_connect_by_sites_is_the_same_loop(tmp_path):
    by_body = import_file(_write(tmp_path, FOURBAR)).data["loops"]
    by_site = import_file(_write(tmp_path, FOURBAR.replace(
        'body1="coupler" body2="rocker" anchor="0.35 0 0"', 'site1="tip" site2="end"'),
        "sites.xml")).data["loops"]
    assert by_site[0]["a"] == by_body[0]["a"]
    assert np.allclose(by_site[0]["b"]["point"], by_body[0]["b"]["point"], atol=1e-15)


#: l2 turned 0.2 rad about its hinge from its place in the file: R_x(pi/2) R_y(0.2) in l1
TURNED = ("0.7035741925769525 0.7035741925769523 0.07059288589999416 "
          "0.07059288589999416")


@pytest.mark.parametrize("equality", [
    f'<weld body1="l1" body2="l2" relpose="0.3 0 0 {TURNED}"/>',
    '<weld site1="s1" site2="s2"/>'], ids=["relpose", "sites"])
def test_weld_away_from_the_reference_starts_where_mujoco_is_satisfied(equality, tmp_path):
    """A weld that does not hold at qpos0 (relpose, or two site frames apart): the
    robot starts where it holds (j2 = 0.2 rad, j1 and j3 held), and there MuJoCo's
    own equality residual (efc_pos) is zero."""
    mujoco = pytest.importorskip("mujoco")
    text = CHAIN.replace("EQUALITY", f"<equality>{equality}</equality>").replace(
        '<joint name="j1" axis="0 0 1"/>',
        '<joint name="j1" axis="0 0 1"/><site name="s1" pos="0.3 0 0" quat="{TURNED}"/>'
        .replace("{TURNED}", TURNED)).replace(
        '<joint name="j2" axis="0 1 0"/>', '<joint name="j2" axis="0 1 0"/><site name="s2"/>')
    path = _write(tmp_path, text)
    robot = robot_from_text(import_file(path).text, str(path))
    q0 = np.array([float(c.initial) for c in robot.coordinates])
    assert q0 == pytest.approx([0, 0.2, 0], abs=1e-12)
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    data.qpos[:] = q0
    mujoco.mj_forward(model, data)
    assert data.nefc == 6 and np.abs(data.efc_pos).max() < 1e-12
    data.qpos[1] = 0.21                                    # and the residual can be seen
    mujoco.mj_forward(model, data)
    assert np.abs(data.efc_pos).max() > 1e-3


REFUSED = {
    "joint": ('<equality><joint name="couple" joint1="j1" joint2="j3"/></equality>',
              "equality joint 'couple': a <joint> equality: anadyn maps connect and weld "
              "equalities onto loops only; remove it from a copy"),
    "inactive": ('<equality><weld name="w" body1="l1" body2="l2" active="false"/></equality>',
                 "equality weld 'w': active=\"false\": anadyn's loops always hold; an "
                 "equality switched off at the start is not imported"),
    "unknown": ('<equality><connect body1="l9" anchor="0 0 0"/></equality>',
                "equality connect 'connect1': body1=\"l9\": no body of this name"),
    "mixed": ('<equality><weld body1="l1" site1="a" site2="b"/></equality>',
              "equality weld 'weld1': body1 with site1 and site2: give the two sites only "
              "(their frames meet)"),
    "unreachable": ('<equality><weld body1="l2" body2="l1" relpose="0.1 0.2 0 1 0 0 0"/>'
                    '</equality>',
                    "equality weld 'weld1': the equality constraints cannot be met near the "
                    "reference configuration; check the sites or relpose"),
    "nothing": ('<equality><weld body1="l3" body2="l3"/></equality>',
                "equality weld 'weld1': both objects are on one rigid body here (no joint "
                "between them): the equality constrains nothing"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_bad_equality_is_one_line_exit_2(case, tmp_path, capsys):
    equality, message = REFUSED[case]
    path = _chain(tmp_path, equality)
    out = tmp_path / "out.yaml"
    assert main(["import", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == f"anadyn: error: {path}: {message}\n"
    assert not out.exists()


def test_equality_with_a_free_joint_is_refused(tmp_path, capsys):
    text = CHAIN.replace('<body name="l1" pos="0 0 1">', '<body name="l1" pos="0 0 1">'
                         '<freejoint name="base"/>').replace(
        '<joint name="j1" axis="0 0 1"/>', "").replace(
        "EQUALITY", '<equality><connect body1="l3" anchor="0 0 0"/></equality>')
    assert main(["import", str(_write(tmp_path, text))]) == 2
    assert ("an equality in a model with ball or free joints: anadyn's loops take hinge "
            "and slide joints only") in capsys.readouterr().err


def test_a_singular_start_is_refused(tmp_path, capsys):
    """A parallelogram four-bar laid flat: at qpos0 the pin moves only along y (rank
    1), next to it on either branch along x too (rank 2); keeping one equation would
    leave a spurious degree of freedom."""
    flat = """<mujoco><compiler angle="radian"/><worldbody>
      <body name="crank"><joint name="j1" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01"/>
        <body name="coupler" pos="0.1 0 0"><joint name="j2" axis="0 0 1"/>
          <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.01"/></body></body>
      <body name="rocker" pos="0.4 0 0"><joint name="j3" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01"/></body></worldbody>
      <equality><connect name="pin" body1="coupler" body2="rocker" anchor="0.4 0 0"/>
      </equality></mujoco>"""
    path = _write(tmp_path, flat)
    assert main(["import", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: equality connect 'pin': the equality constraints are "
        "singular at the reference configuration (rank 1 there, 2 next to it); move the "
        "joints' ref\n")
    raised = flat.replace('<body name="crank">', '<body name="crank" axisangle="0 0 1 0.5">')\
        .replace('<body name="coupler" pos="0.1 0 0">',
                 '<body name="coupler" pos="0.1 0 0" axisangle="0 0 1 -0.5">')\
        .replace('<body name="rocker" pos="0.4 0 0">',
                 '<body name="rocker" pos="0.4 0 0" axisangle="0 0 1 0.5">')
    assert main(["import", str(_write(tmp_path, raised, "raised.xml"))]) == 0   # not flat
