"""The doors real URDF files hit (issue 25 item 3): massless links between joints,
joint locking (a reduced robot, as Pinocchio's buildReducedModel), the URDF reading
options (--fix-base, --inertia, --lock) on every command that takes a URDF, and no
hidden cap on the number of coordinates.

The dynamics are checked against Pinocchio (CRBA and RNEA at random states, 1e-12
relative): Pinocchio's reduced model for a locked robot, its full model for massless
links (Pinocchio takes a body without mass)."""
from __future__ import annotations

import hashlib
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from anadyn_cli.cli import main
from anadyn_cli.errors import ModelError
from anadyn_cli.model import robot_from_text
from anadyn_cli.model.urdf import (ReadingOptions, import_file, import_urdf, link_bodies,
                                   reading)
from anadyn_cli.model.yamlsource import read_text

pin = pytest.importorskip("pinocchio")

DATA = Path(__file__).parent / "data" / "urdf"
ERD = next((p for p in (Path(s) / "cmeel.prefix/share/example-robot-data/robots"
                        for s in sys.path) if p.is_dir()), None)
TOLERANCE = 1e-12
STATES = 8


# -- the oracle: anadyn's M and RNEA against a Pinocchio model, joints matched by name ----------
def _anadyn(text: str, source: str):
    """(q, dq, ddq) -> (M, tau) on the recursive path that the commands run; joint
    damping and friction left out (Pinocchio has none)."""
    from anadyn_cli.numeric.build import numeric_model

    data = yaml.safe_load(text)
    for body in data["bodies"]:
        body["joint"].pop("damping", None)
        body["joint"].pop("friction", None)
    robot = robot_from_text(yaml.safe_dump(data, sort_keys=False), source)
    model = numeric_model(robot, evaluator="recursive")

    def run(q, dq, ddq):
        M = np.array(model.mfb(0.0, q, dq)[0], dtype=float)
        demand, B = model.demand(0.0, q, dq, ddq)
        return M, np.linalg.solve(np.array(B, dtype=float), np.asarray(demand, dtype=float))
    return robot, run


def _pinocchio(model, names: list[str]):
    """(q, dq, ddq) in anadyn's coordinate order (named after the URDF joints) -> (M, tau)
    of the Pinocchio ``model``; continuous joints as (cos, sin)."""
    data = model.createData()
    index = [names.index(model.names[j]) for j in range(1, model.njoints)]

    def run(q, dq, ddq):
        config = np.zeros(model.nq)
        v, a = np.zeros(model.nv), np.zeros(model.nv)
        for j, k in zip(range(1, model.njoints), index):
            joint = model.joints[j]
            if joint.nq == 2:
                config[joint.idx_q:joint.idx_q + 2] = math.cos(q[k]), math.sin(q[k])
            else:
                config[joint.idx_q] = q[k]
            v[joint.idx_v], a[joint.idx_v] = dq[k], ddq[k]
        M = pin.crba(model, data, config)
        M = np.triu(M) + np.triu(M, 1).T
        tau = pin.rnea(model, data, config, v, a)
        order = np.argsort(index)                  # Pinocchio's joints -> anadyn's order
        return M[np.ix_(order, order)], tau[order]
    return run


def _worst(anadyn, pinocchio, n: int, seed: int = 5) -> tuple[float, float]:
    rng = np.random.default_rng(seed)
    worst = [0.0, 0.0]
    for _ in range(STATES):
        q, dq, ddq = rng.uniform(-1.5, 1.5, n), rng.normal(0, 2, n), rng.normal(0, 5, n)
        for k, (mine, theirs) in enumerate(zip(anadyn(q, dq, ddq), pinocchio(q, dq, ddq))):
            worst[k] = max(worst[k], float(np.abs(mine - theirs).max() / np.abs(theirs).max()))
    return tuple(worst)


def _reduced(path: Path, lock: dict[str, float]):
    """Pinocchio's buildReducedModel of the URDF with ``lock`` joints at their values."""
    full = pin.buildModelFromUrdf(str(path))
    q_ref = pin.neutral(full)
    for name, value in lock.items():
        joint = full.joints[full.getJointId(name)]
        q_ref[joint.idx_q] = value
    return pin.buildReducedModel(full, [full.getJointId(name) for name in lock], q_ref)


# -- joint locking -------------------------------------------------------------------------
@pytest.mark.parametrize("path, lock", [
    (DATA / "ur5_robot.urdf", {"shoulder_lift_joint": math.pi / 4, "wrist_2_joint": -0.3}),
    # the Panda's hand: finger 1 locked (prismatic), finger 2 mimics it and follows
    (DATA / "panda.urdf", {"panda_joint4": -2.0, "panda_finger_joint1": 0.02,
                           "panda_finger_joint2": 0.02}),
], ids=["ur5", "panda"])
def test_a_locked_robot_is_pinocchios_reduced_model(path, lock):
    given = {k: v for k, v in lock.items() if k != "panda_finger_joint2"}   # a mimic follows
    text = import_file(path, lock=given).text
    robot, anadyn = _anadyn(text, path.name)
    names = [c.name for c in robot.coordinates]
    assert not set(lock) & set(names)
    reduced = _reduced(path, lock)
    assert reduced.nv == len(names)
    worst = _worst(anadyn, _pinocchio(reduced, names), len(names))
    assert max(worst) <= TOLERANCE, worst
    # the oracle sees a wrong lock: the same joints at other values disagree
    other = _reduced(path, {k: v + 0.01 for k, v in lock.items()})
    assert max(_worst(anadyn, _pinocchio(other, names), len(names))) > 1e-6


def test_the_lock_is_in_the_header_and_the_text_so_in_the_cache_key():
    plain = import_file(DATA / "ur5_robot.urdf").text
    locked = import_file(DATA / "ur5_robot.urdf", lock={"elbow_joint": "pi/2"}).text
    assert "(`anadyn import --lock elbow_joint=pi/2`)" in locked
    assert "#   elbow_joint: revolute at 1.5707963267948966 rad" in locked
    assert "elbow_joint: {initial" not in locked and "elbow_joint: {initial" in plain
    with reading(ReadingOptions(lock=(("elbow_joint", "pi/2"),))):      # as a command does
        assert read_text(DATA / "ur5_robot.urdf")[0] == locked
    assert read_text(DATA / "ur5_robot.urdf")[0] == plain          # the block ended
    digest = lambda text: hashlib.sha256(text.encode()).hexdigest()         # noqa: E731
    assert digest(locked) != digest(plain)


BAD_LOCKS = {
    "nope=1": r"{f}: --lock nope=1: no such joint; the joints that can be locked are "
              r"'shoulder_pan_joint', .*",
    "elbow_joint=9": r"{f}: joint 'elbow_joint': --lock elbow_joint=9: 9 is outside the "
                     r"joint's <limit> \[-3.14159, 3.14159\]",
    "elbow_joint=q1": r"{f}: joint 'elbow_joint': --lock elbow_joint=q1: unknown name 'q1'.*",
    "elbow_joint": r"--lock 'elbow_joint': expected JOINT=VALUE, e.g. --lock elbow=pi/4 .*",
    "ee_fixed_joint=0": r"{f}: --lock ee_fixed_joint=0: joint 'ee_fixed_joint' is fixed; the "
                        r"joints that can be locked are .*",
}


@pytest.mark.parametrize("lock", list(BAD_LOCKS))
@pytest.mark.parametrize("command", ["import", "show"])
def test_a_bad_lock_is_one_line(lock, command, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = DATA / "ur5_robot.urdf"
    assert main([command, str(path), "--lock", lock]) == 2
    err = capsys.readouterr().err
    assert re.fullmatch("anadyn: error: " + BAD_LOCKS[lock].format(f=re.escape(str(path)))
                        + "\n", err), err
    assert list(tmp_path.iterdir()) == []


def test_a_mimic_is_locked_through_its_joint(capsys):
    assert main(["import", str(DATA / "panda.urdf"), "--lock", "panda_finger_joint2=0"]) == 2
    assert capsys.readouterr().err.endswith(
        "panda.urdf: joint 'panda_finger_joint2': --lock panda_finger_joint2=0: the joint mimics "
        "'panda_finger_joint1'; lock that joint (its mimics follow it)\n")


# -- massless links between joints -----------------------------------------------------------
def _link(name: str, mass: float | None = None) -> str:
    if mass is None:
        return f'<link name="{name}"/>'
    return (f'<link name="{name}"><inertial><origin xyz="0.02 0.01 -0.1" rpy="0.1 0 0.2"/>'
            f'<mass value="{mass}"/><inertia ixx="0.02" iyy="0.03" izz="0.015" ixy="0.001" ixz="0" iyz="0"/>'
            "</inertial></link>")


def _joint(name: str, parent: str, child: str, axis: str, xyz: str = "0 0 0",
           kind: str = "revolute") -> str:
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="0.1 -0.2 0.3"/><axis xyz="{axis}"/>'
            f'<limit effort="10" velocity="10" lower="-3" upper="3"/></joint>')


#: a hip as URDF writes a ball joint: three revolute joints with two massless virtual links,
#: then a thigh and a shank (a knee), and a massless tool frame fixed to the shank
BALL = "".join([
    '<robot name="leg">', _link("pelvis"), _link("hip_v1"), _link("hip_v2"),
    _link("thigh", 3.0), _link("shank", 2.0), _link("tool"),
    _joint("hip_z", "pelvis", "hip_v1", "0 0 1", "0.1 0 0"),
    _joint("hip_x", "hip_v1", "hip_v2", "1 0 0"),
    _joint("hip_y", "hip_v2", "thigh", "0 1 0"),
    _joint("knee", "thigh", "shank", "0 1 0", "0 0 -0.4"),
    _joint("tool_fixed", "shank", "tool", "0 0 1", "0 0 -0.3", kind="fixed"), "</robot>"])


def test_massless_links_between_joints_import_and_agree_with_pinocchio(tmp_path):
    path = tmp_path / "leg.urdf"
    path.write_text(BALL)
    imported = import_file(path)
    assert [b["mass"] for b in imported.data["bodies"]] == [0, 0, 3, 2]
    robot, anadyn = _anadyn(imported.text, path.name)
    names = [c.name for c in robot.coordinates]
    assert names == ["hip_z", "hip_x", "hip_y", "knee"]
    worst = _worst(anadyn, _pinocchio(pin.buildModelFromUrdf(str(path)), names), len(names))
    assert max(worst) <= TOLERANCE, worst


@pytest.mark.skipif(ERD is None, reason="example-robot-data is not installed")
def test_every_import_reads_back_as_its_description():
    """The loader builds a robot imported in the same process from the import's
    description, not from its text (``urdf.description``): the two are equal for
    every URDF of example-robot-data that imports."""
    from anadyn_cli.errors import ModelError
    from anadyn_cli.model.yamlschema import load

    count = 0
    for path in sorted(ERD.glob("**/*.urdf")):
        try:
            imported = import_file(path, fix_base=True)
        except ModelError:
            continue
        assert load(imported.text, path.name)[0] == imported.data, path
        count += 1
    assert count >= 50


@pytest.mark.skipif(ERD is None, reason="example-robot-data is not installed")
def test_human_urdf_imports_and_agrees_with_pinocchio():
    path = ERD / "human_description/robots/human.urdf"
    imported = import_file(path)
    assert sum(b["mass"] == 0 for b in imported.data["bodies"]) > 10   # the virtual links
    robot, anadyn = _anadyn(imported.text, path.name)
    names = [c.name for c in robot.coordinates]
    worst = _worst(anadyn, _pinocchio(pin.buildModelFromUrdf(str(path)), names), len(names))
    assert max(worst) <= TOLERANCE, worst


#: BALL with a massless wrist of two joints after the shank (they move nothing)
IDLE = BALL.replace("</robot>", "".join([
    _link("wrist_v"), _link("hand"), _joint("wrist_a", "tool", "wrist_v", "1 0 0"),
    _joint("wrist_b", "wrist_v", "hand", "0 1 0"), "</robot>"]))


def test_the_refusal_names_every_joint_that_moves_nothing(tmp_path, capsys):
    path = tmp_path / "leg.urdf"
    path.write_text(IDLE)
    assert main(["import", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: joints 'wrist_a', 'wrist_b' move nothing: no link they move "
        "(link 'wrist_v' and beyond) has mass, so the mass matrix would be singular; give one "
        "of those links an <inertial> with a positive <mass>, or lock them (--lock wrist_a=0 "
        "--lock wrist_b=0)\n")
    # the massless subtree locked instead: the robot of BALL, a folded tool frame more
    locked = import_file(path, lock={"wrist_a": 0.3, "wrist_b": 0}).data
    assert list(locked["coordinates"]) == ["hip_z", "hip_x", "hip_y", "knee"]
    assert len(locked["bodies"]) == 4


def test_a_massless_leaf_is_still_refused_in_yaml(tmp_path, capsys):
    """The loader takes a massless moving body only when it carries others."""
    text = import_file(DATA / "ur5_robot.urdf").text
    data = yaml.safe_load(text)
    data["bodies"][-1]["mass"] = 0
    path = tmp_path / "ur5.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    assert main(["show", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "bodies[5].mass: must be positive (a mass in kg), got 0" in capsys.readouterr().err


# -- the reading options on every command that takes a URDF -------------------------------
ARM = ('<robot name="arm"><link name="world"/>'
       '<joint name="float" type="floating"><parent link="world"/><child link="base"/>'
       '<origin xyz="0 0 0.5"/></joint>' + _link("base", 5.0)
       + _joint("j1", "base", "l1", "0 0 1") + _link("l1", 1.0)
       + _joint("j2", "l1", "l2", "0 1 0", "0 0 0.3") + _link("l2", 1.0)
       + _joint("j3", "l2", "l3", "0 1 0", "0 0 0.3") + "</robot>")
BAD_INERTIA = ('<link name="l3"><inertial><mass value="0.5"/><inertia ixx="0.001" iyy="0.001" '
               'izz="0.01"/></inertial></link>')


@pytest.fixture
def arm(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(ARM.replace("</robot>", BAD_INERTIA + "</robot>"))
    return path


@pytest.mark.parametrize("command", [
    ["show"], ["simulate", "--t-end", "0.05", "--no-plot"], ["check", "--t-end", "0.05"],
    ["equations"], ["linearize"], ["export", "--lang", "python"]])
def test_the_reading_options_work_on_every_command(command, arm, tmp_path, capsys,
                                                   monkeypatch):
    monkeypatch.chdir(tmp_path)
    name, *rest = command
    assert main([name, str(arm), *rest]) == 2                   # floating: a free base,
    assert "breaks the triangle inequality" in capsys.readouterr().err   # the inertia refused
    assert main([name, str(arm), *rest, "--fix-base"]) == 2     # the bad inertia: refused
    assert "breaks the triangle inequality" in capsys.readouterr().err
    code = main([name, str(arm), *rest, "--fix-base", "--inertia", "repair", "--lock",
                 "j2=pi/6"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "repaired to the nearest valid inertia" in captured.err
    out = captured.out + "".join(p.read_text(errors="replace") for p in
                                 (tmp_path / "results").rglob("*") if p.is_file()
                                 and p.suffix in (".json", ".csv", ".txt", ".py"))
    assert "dj2" not in out and "j2," not in out and "j2:" not in out   # j2 is locked
    assert name == "check" or "j3" in out                              # check names none


def test_compare_and_the_views_links_take_them_too(arm, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    options = ["--fix-base", "--inertia", "repair", "--lock", "j2=0.4"]
    assert main(["compare", str(arm), "--samples", "5", "--t-end", "0.05", *options]) == 0
    capsys.readouterr()
    places = link_bodies(arm, ReadingOptions(True, "repair", (("j2", "0.4"),))).places
    assert places["l2"][0] == places["l1"][0] == 0                  # l2 folded into l1
    assert places["l3"][0] == 1 and places["world"][0] == places["base"][0] == -1


def test_the_options_on_a_yaml_robot_are_refused(capsys):
    assert main(["show", "rr", "--lock", "q1=0"]) == 2
    assert capsys.readouterr().err.endswith(
        "anadyn: error: --lock q1=0: these options say how a URDF file is read; rr is not a "
        "URDF file\n")


# -- --fix-base welds only the joint that carries the root --------------------------------------
def test_fix_base_welds_only_the_joint_that_carries_the_root(arm, tmp_path):
    imported = import_file(arm, fix_base=True, inertia="repair")
    assert list(imported.data["coordinates"]) == ["j1", "j2", "j3"]
    assert any("floating joint of the base welded" in w for w in imported.warnings)
    two = arm.read_text().replace("</robot>", '<joint name="float2" type="floating"><parent '
                                  'link="world"/><child link="box"/></joint>'
                                  + _link("box", 1.0) + "</robot>")
    with pytest.raises(ModelError, match="--fix-base welds the one joint that carries the root "
                                        r"link; 'world' carries 2 floating or planar joints "
                                        r"\('float', 'float2'\)"):
        import_urdf(two, "two.urdf", fix_base=True)
    deep = BALL.replace('type="revolute"><parent link="thigh"', 'type="floating"><parent '
                        'link="thigh"')
    assert "type: floating" in import_urdf(deep, "deep.urdf", fix_base=True).text  # kept
    fixed = import_urdf(BALL, "leg.urdf", fix_base=True)
    assert fixed.warnings == ["leg.urdf: --fix-base: no floating or planar joint carries the "
                              "root link 'pelvis'; nothing welded (the root link is fixed to "
                              "the world in every import)"]


# -- no hidden cap on the number of coordinates ------------------------------------------------
@pytest.mark.slow
@pytest.mark.skipif(ERD is None, reason="example-robot-data is not installed")
def test_tiago_dual_with_its_101_coordinates_loads():
    imported = import_file(ERD / "tiago_description/robots/tiago_dual.urdf", inertia="repair")
    robot = robot_from_text(imported.text, "tiago_dual.urdf")
    assert len(robot.coordinates) == 101
