"""MJCF import (anadyn_cli.model.mjcf) checked against MuJoCo, the test-only oracle.

Models: Gymnasium's and DeepMind Control's MJCF files (tests/data/mjcf/gymnasium,
dm_control, their licences beside them) and anadyn's own features.xml (every frame
form, defaults, ref, springref, armature on a slide and a hinge, settotalmass,
servos).  Coordinates: anadyn's coordinates are MuJoCo's qpos, in MuJoCo's order
(depth-first bodies, joints in body order), so q maps one to one; anadyn's
M ddq = F + B tau has F = qfrc_passive - qfrc_bias (frictionloss, MuJoCo's
constraint, is taken out of both), and M includes armature (the rotor bodies).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from anadyn_cli.cli import main
from anadyn_cli.model import robot_from_text
from anadyn_cli.model.mjcf import import_file

mujoco = pytest.importorskip("mujoco")

DATA = Path(__file__).parent / "data" / "mjcf"
#: swimmer.xml has fluid forces (option density, viscosity): its import warns (below)
MODELS = sorted(p for p in DATA.glob("*/*.xml") if p.stem != "swimmer")
TOLERANCE = 1e-9
STATES = 20


@pytest.fixture(autouse=True)
def _in_a_temporary_folder(tmp_path, monkeypatch):
    """MuJoCo writes its warnings (settotalmass is deprecated) to MUJOCO_LOG.TXT in the
    working folder: keep them out of the repository."""
    monkeypatch.chdir(tmp_path)


def _relative(a, b) -> float:
    return float(np.abs(np.asarray(a) - b).max() / max(np.abs(b).max(), 1e-300))


class Oracle:
    """anadyn's numeric model of an imported MJCF file and MuJoCo's of the same file."""

    def __init__(self, path: Path, controller: bool = False):
        from anadyn_cli.numeric.build import numeric_model

        self.imported = import_file(path)
        data = self.imported.data
        for body in data["bodies"]:
            body["joint"].pop("friction", None)       # frictionloss: a constraint in MuJoCo
        if not controller:
            data.pop("controller", None)
            data.pop("actuators", None)
        self.robot = robot_from_text(yaml.safe_dump(data, sort_keys=False), str(path))
        self.numeric = numeric_model(self.robot, evaluator="recursive")
        self.model = mujoco.MjModel.from_xml_path(str(path))
        self.model.opt.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONTACT
                                        | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
        self.data = mujoco.MjData(self.model)
        assert [c.name for c in self.robot.coordinates] == [
            self.model.joint(j).name for j in range(self.model.njnt)]

    def random_state(self, rng):
        q = self.model.qpos0 + rng.uniform(-1, 1, self.model.nq)
        return q, rng.normal(0, 2, self.model.nv)

    def anadyn(self, q, dq):
        M, F, _ = (np.array(a, dtype=float) for a in self.numeric.mfb(0.0, q, dq))
        return M, F.ravel()

    def mujoco(self, q, dq):
        m, d = self.model, self.data
        d.qpos[:], d.qvel[:], d.ctrl[:] = q, dq, 0
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        return M, d.qfrc_passive - d.qfrc_bias


@pytest.mark.parametrize("path", MODELS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_mass_matrix_and_bias_forces_agree_with_mujoco(path):
    oracle = Oracle(path)
    rng = np.random.default_rng(29)
    worst = {"M": 0.0, "F": 0.0}
    for _ in range(STATES):
        q, dq = oracle.random_state(rng)
        (M, F), (M_mj, F_mj) = oracle.anadyn(q, dq), oracle.mujoco(q, dq)
        worst["M"] = max(worst["M"], _relative(M, M_mj))
        worst["F"] = max(worst["F"], _relative(F, F_mj))
    print(f"{path.parent.name}/{path.stem}: max relative error M {worst['M']:.1e}, "
          f"F {worst['F']:.1e}")
    assert worst["M"] <= TOLERANCE and worst["F"] <= TOLERANCE, worst


def test_the_oracle_sees_a_wrong_model(tmp_path):
    """A 1e-6 change of one capsule's radius is seen in M; armature left out is seen."""
    path = DATA / "gymnasium" / "hopper.xml"
    wrong = tmp_path / "hopper.xml"
    wrong.write_text(path.read_text().replace('size="0.04 0.25"', 'size="0.04000004 0.25"'))
    oracle = Oracle(wrong)
    oracle.model = mujoco.MjModel.from_xml_path(str(path))
    oracle.data = mujoco.MjData(oracle.model)
    q, dq = oracle.random_state(np.random.default_rng(0))
    assert _relative(oracle.anadyn(q, dq)[0], oracle.mujoco(q, dq)[0]) > 1e-8
    oracle.model.dof_armature[:] = 0
    assert _relative(Oracle(path).anadyn(q, dq)[0], oracle.mujoco(q, dq)[0]) > 1e-3


@pytest.mark.parametrize("path", MODELS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_masses_and_inertias_agree_with_mujoco(path):
    """Each anadyn body that carries one MJCF body has its body_mass, body_ipos (from the
    last joint's anchor, where the anadyn body frame sits) and inertia R(iquat)
    diag(body_inertia) R(iquat)^T; the moving mass in all is MuJoCo's."""
    from anadyn_cli.model.mjcf.frames import quat_matrix

    imported = import_file(path)
    model = mujoco.MjModel.from_xml_path(str(path))
    bodies = {b["name"]: b for b in imported.data["bodies"]}
    moving = [b for b in range(1, model.nbody) if model.body_weldid[b] != 0]
    rotors = [b for b in bodies if b.endswith("_armature")]
    total = sum(float(b["mass"]) for name, b in bodies.items() if name not in rotors)
    assert total == pytest.approx(float(model.body_mass[moving].sum()), rel=1e-12)
    checked = 0
    for b in moving:
        name = model.body(b).name
        folded = any(model.body_parentid[c] == b and model.body_jntnum[c] == 0
                     for c in range(model.nbody))
        if model.body_jntnum[b] == 0 or folded or name not in bodies:
            continue
        last = model.body_jntadr[b] + model.body_jntnum[b] - 1
        anchor = model.jnt_pos[last] if model.jnt_type[last] == mujoco.mjtJoint.mjJNT_HINGE \
            else np.zeros(3)
        body = bodies[name]
        R = quat_matrix(model.body_iquat[b])
        inertia = R @ np.diag(model.body_inertia[b]) @ R.T
        keys = {"ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2), "ixy": (0, 1), "ixz": (0, 2),
                "iyz": (1, 2)}
        ours = np.zeros((3, 3))
        for key, (i, j) in keys.items():
            ours[i, j] = ours[j, i] = float(body["inertia"].get(key, 0))
        assert float(body["mass"]) == pytest.approx(model.body_mass[b], rel=1e-12)
        np.testing.assert_allclose(body.get("com", [0, 0, 0]), model.body_ipos[b] - anchor,
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(ours, inertia, rtol=0, atol=1e-12 * np.abs(inertia).max())
        checked += 1
    assert checked >= 1


# -- simulation against MuJoCo's RK4 ---------------------------------------------------------
#: model -> initial state (coordinate -> (q0, dq0)); each model's servos are kept
MOVING = {DATA / "dm_control" / "acrobot.xml": {"shoulder": (0.4, 1.0), "elbow": (-0.3, 0.5)},
          DATA / "anadyn" / "features.xml": {"slide": (0.1, 0.3), "shoulder": (-0.2, 1.0),
                                             "elbow": (0.3, -0.5), "wrist": (0.02, 0.1)},
          DATA / "gymnasium" / "hopper.xml": {"rootx": (0, 0.5), "rootz": (1.25, 0.0),
                                              "rooty": (0.1, 0.3), "thigh_joint": (-0.5, 1.0),
                                              "leg_joint": (-0.4, 0.0),
                                              "foot_joint": (0.2, -1.0)}}


@pytest.mark.parametrize("path", list(MOVING), ids=lambda p: p.stem)
def test_simulation_agrees_with_mujoco_rk4(path, tmp_path):
    """anadyn simulate (DOP853, rtol 1e-12) against MuJoCo's RK4 at 2.5e-5 s for 1 s, no
    contact, the servos' controls 0 in both.  features.xml's servo starts saturated
    (forcerange): RK4 across that kink is second order, 8e-8 off at 1e-4 s, 2e-9 at
    2.5e-5 s, 1.3e-10 at 5e-6 s; without a kink the models agree to 1e-12."""
    data = import_file(path).data
    for name, (q0, dq0) in MOVING[path].items():
        data["coordinates"][name] = {"initial": q0, "rate": dq0}
    robot_file = tmp_path / f"{path.stem}.yaml"
    robot_file.write_text(yaml.safe_dump(data, sort_keys=False))
    assert main(["simulate", str(robot_file), "--method", "DOP853", "--rtol", "1e-12",
                 "--atol", "1e-14", "--t-end", "1", "--dt", "0.1", "--no-plot",
                 "--out", "out", "--no-cache"]) == 0
    table = np.loadtxt(tmp_path / "out" / "simulate.csv", delimiter=",", skiprows=1)
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONTACT
                           | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    m.opt.integrator, m.opt.timestep = mujoco.mjtIntegrator.mjINT_RK4, 2.5e-5
    d = mujoco.MjData(m)
    names = [m.joint(j).name for j in range(m.njnt)]
    d.qpos[:] = [MOVING[path][n][0] for n in names]
    d.qvel[:] = [MOVING[path][n][1] for n in names]
    states = []
    for step in range(40001):
        if step % 4000 == 0:
            states.append(np.concatenate([d.qpos, d.qvel]))
        mujoco.mj_step(m, d)
    expected = np.array(states)
    n = m.nq
    scale = np.maximum(1.0, np.abs(expected).max(axis=0))
    error = float((np.abs(table[:, 1:2 * n + 1] - expected) / scale).max())
    print(f"{path.stem}: 1 s, max |x - x_mujoco| / max(1, |x|max) = {error:.1e}")
    assert np.abs(expected - expected[0]).max() > 1e-2          # it moved
    assert error < 1e-8


# -- the command line ------------------------------------------------------------------------
def test_import_writes_a_robot_file_that_loads(tmp_path, capsys):
    out = tmp_path / "hopper.yaml"
    assert main(["import", str(DATA / "gymnasium" / "hopper.xml"), "-o", str(out)]) == 0
    robot = robot_from_text(out.read_text(), str(out))
    assert [c.name for c in robot.coordinates] == ["rootx", "rootz", "rooty", "thigh_joint",
                                                   "leg_joint", "foot_joint"]
    assert float(robot.coordinates[1].initial) == 1.25          # rootz's ref
    assert "wrote" in capsys.readouterr().out


def test_library_has_the_mjcf_robots(capsys):
    assert main(["robots"]) == 0
    listing = capsys.readouterr().out
    rows = {line.split()[0]: line.split()[1] for line in listing.splitlines() if "(MJCF" in line}
    assert rows == {"cartpole": "2", "reacher": "2", "hopper": "6"}     # degrees of freedom


def test_fix_base_welds_a_free_joint(tmp_path, capsys):
    path = _write(tmp_path, FREE)
    assert main(["import", str(path)]) == 0
    assert "type: floating" in capsys.readouterr().out         # free: anadyn's floating
    assert main(["import", "--fix-base", str(path)]) == 0
    text = capsys.readouterr().out
    assert "displacement: hinge" in text and "rootz" not in text


def test_frictionloss_and_fluid_forces_are_warned():
    assert any("frictionloss 0.1" in w for w in import_file(DATA / "dm_control" /
                                                            "finger.xml").warnings)
    assert any("fluid forces" in w for w in import_file(DATA / "gymnasium" /
                                                        "swimmer.xml").warnings)


FREE = """<mujoco><worldbody><body name="base" pos="0 0 1"><freejoint name="root"/>
<geom size="0.1"/><body pos="0 0 0.2"><joint name="hinge"/><geom size="0.05"/></body></body>
</worldbody></mujoco>"""
ARM = """<mujoco><worldbody><body name="link"><joint name="j1" {joint}/><geom {geom}/>
</body></worldbody>{extra}</mujoco>"""


def _arm(joint: str = "", geom: str = 'size="1"', extra: str = "") -> str:
    """A one-joint model with the given attributes of its joint and geom."""
    return ARM.format(joint=joint, geom=geom, extra=extra)
LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;">]>
<mujoco><worldbody><body name="&lol2;"><joint/><geom size="1"/></body></worldbody></mujoco>"""


def _write(tmp_path, text: str, name: str = "robot.xml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


BAD = {
    "entities": (LAUGHS, "XML entity declarations are refused"),
    "include outside": ('<mujoco><include file="../outside.xml"/></mujoco>',
                        "<include file=\"../outside.xml\">: outside the model's folder"),
    "not mujoco": ("<robot name='r'/>", "the root element is <robot>, expected <mujoco>"),
    "joint type": (_arm('type="screw"'), "type=\"screw\": expected free, ball, slide or hinge"),
    "ball": (_arm('type="ball" damping="1"'), 'damping="1" on a ball joint: not imported'),
    "number": (_arm('damping="1_0"'), "damping=\"1_0\": '1_0' is not a decimal number"),
    "nan": (_arm('axis="0 nan 1"'), "axis=\"0 nan 1\": numbers must be finite"),
    "count": (_arm('pos="0 1"'), "pos=\"0 1\": expected 3 numbers, got 2"),
    "zero axis": (_arm('axis="0 0 0"'), "axis=\"0 0 0\": the vector is zero"),
    "class": (_arm('class="arm"'), "class=\"arm\": no <default> of this class"),
    "mesh": (_arm(geom='type="mesh" mesh="m"'),
             "body 'link': geom 1: a mesh geom: anadyn computes the inertia of sphere"),
    "no mass": (_arm(geom='size="1" mass="0"'), "body 'link': moves (joint 'j1') but has no mass"),
    "two orientations": (_arm(geom='size="1" quat="1 0 0 0" euler="0 0 1"'),
                         "geom 1: quat and euler: give one orientation at most"),
    "tendon": (_arm(extra='<tendon><fixed name="t"><joint joint="j1"/></fixed></tendon>'),
               "<tendon>: <fixed> t: anadyn imports no tendon elements"),
    "actuator": (_arm(extra='<actuator><motor name="m" joint="j9"/></actuator>'),
                 "actuator 'm': joint=\"j9\": no hinge or slide joint of this name"),
    "same name": (_arm().replace("</body>", '<body><joint name="j1"/><geom size="1"/></body>'
                                            "</body>"),
                  "joint 'j1': a second joint of this name"),
    "deep": ("<mujoco><worldbody>" + '<body><joint/><geom size="1"/>' * 201 + "</body>" * 201
             + "</worldbody></mujoco>", "<body>: elements nested more than 200 deep"),
}
#: the joint's messages name it
JOINT_CASES = ("joint type", "ball", "number", "nan", "count", "zero axis", "class")


@pytest.mark.parametrize("case", list(BAD))
def test_bad_mjcf_is_one_line_exit_2_nothing_written(case, tmp_path, capsys):
    text, message = BAD[case]
    folder = tmp_path / "model"
    folder.mkdir()
    _write(tmp_path, "<mujoco/>", "outside.xml")
    path = _write(folder, text)
    out = tmp_path / "robot.yaml"
    assert main(["import", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"anadyn: error: {path}"), err
    assert message in err, err
    assert case not in JOINT_CASES or f"{path}: joint 'j1': " in err, err
    assert not out.exists()
    assert main(["simulate", str(path), "--t-end", "0.1", "--no-plot",
                 "--out", str(tmp_path / "run")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_size_cap_counts_the_includes(tmp_path, capsys, monkeypatch):
    from anadyn_cli.model.mjcf import source

    monkeypatch.setattr(source, "MAX_BYTES", 300)
    _write(tmp_path, "<mujoco>" + "<!-- padding -->" * 20 + "</mujoco>", "big.xml")
    path = _write(tmp_path, _arm(extra='<include file="big.xml"/>'))
    assert main(["import", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"anadyn: error: {tmp_path / 'big.xml'}: file is ") and \
        err.endswith(f"the limit for MJCF is {300 - path.stat().st_size}\n"), err


def test_euler_sequences_match_mujoco():
    """Intrinsic (lower case) and extrinsic (upper case) sequences, in degrees and
    radians, against MuJoCo's compiled body_quat."""
    from anadyn_cli.model.mjcf.frames import euler, quat_matrix

    for seq in ("xyz", "ZYX", "zyX", "XzY"):
        for angle, scale in (("degree", math.pi / 180), ("radian", 1.0)):
            xml = (f'<mujoco><compiler angle="{angle}" eulerseq="{seq}"/><worldbody>'
                   '<body euler="0.3 -0.7 1.1"><joint/><geom size="1"/></body>'
                   "</worldbody></mujoco>")
            m = mujoco.MjModel.from_xml_string(xml)
            np.testing.assert_allclose(euler(np.array([0.3, -0.7, 1.1]) * scale, seq),
                                       quat_matrix(m.body_quat[1]), atol=1e-14)


def test_names_cannot_change_the_yaml_structure(tmp_path):
    """Names with YAML syntax, quotes and line breaks end up as identifiers or in
    escaped text: the text loads back to the data, and the robot loads."""
    xml = ('<mujoco model="m&#10;bodies: []"><worldbody>'
           '<body name="a: b&#10;- c"><joint name="x\'y #z"/><geom size="0.1"/>'
           '<body name="{&quot;q&quot;}"><joint name="&#10;coordinates:"/><geom size="0.1"/>'
           '</body></body></worldbody><actuator><motor name="tau: [1]" joint="x\'y #z"/>'
           "</actuator></mujoco>")
    imported = import_file(_write(tmp_path, xml, "odd names.xml"))
    assert yaml.safe_load(imported.text) == imported.data
    robot = robot_from_text(imported.text, "odd.yaml")
    assert [c.name for c in robot.coordinates] == ["x_y__z", "q__coordinates_"]
    assert [b.name for b in robot.bodies] == ["a__b___c", "link___q__"]


def test_urdf_options_are_refused_for_mjcf(capsys):
    path = DATA / "dm_control" / "acrobot.xml"
    assert main(["show", str(path), "--lock", "elbow=0"]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: --lock: this option says how a URDF file is read; MJCF "
        "models are imported whole, their impossible inertias refused\n")


FREE_BALL = """<mujoco model="freeball">
  <worldbody>
    <body name="torso" pos="0.1 0.2 1.0" quat="0.9 0.1 0.3 0.2">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="3"/>
      <body name="upper" pos="0.2 0 0" euler="10 20 30">
        <joint name="shoulder" type="ball" pos="0.05 0 0.02"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
        <body name="lower" pos="0.3 0 0">
          <joint name="elbow" type="hinge" axis="0 1 0" damping="0.3"/>
          <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.025" mass="0.6"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_free_and_ball_joints_agree_with_mujoco(tmp_path):
    """A free joint imports as anadyn's floating joint, a ball joint as its spherical
    one, with MuJoCo's conventions (qpos: position and quaternion (w, x, y, z); qvel:
    the velocity in the world and the angular velocity in body axes), so the two
    states map one to one by name: M (mj_fullM) and F (qfrc_passive - qfrc_bias) at
    20 random states to 1e-9, and the free body starts where MuJoCo places it."""
    from anadyn_cli.numeric.build import numeric_model

    path = tmp_path / "freeball.xml"
    path.write_text(FREE_BALL)
    imported = import_file(path)
    robot = robot_from_text(imported.text, str(path))
    model = mujoco.MjModel.from_xml_string(FREE_BALL)
    data = mujoco.MjData(model)
    names, speeds = [c.name for c in robot.coordinates], [u.name for u in robot.speeds]
    q_at, u_at = [], []                   # anadyn index of each qpos / qvel entry
    for j in range(model.njnt):
        name = model.joint(j).name
        kind = model.jnt_type[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            q_at += [names.index(f"{name}_{p}") for p in ("x", "y", "z", "qw", "qx", "qy", "qz")]
            u_at += [speeds.index(f"d{name}_{p}") for p in "xyz"]
            u_at += [speeds.index(f"{name}_w{p}") for p in "xyz"]
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            q_at += [names.index(f"{name}_q{p}") for p in "wxyz"]
            u_at += [speeds.index(f"{name}_w{p}") for p in "xyz"]
        else:
            q_at.append(names.index(name))
            u_at.append(speeds.index("d" + name))
    start = np.array([float(c.initial) for c in robot.coordinates])
    assert _relative(start[q_at], model.qpos0) < 1e-12          # placed as MuJoCo places it
    numeric = numeric_model(robot, evaluator="recursive")
    rng = np.random.default_rng(7)
    for _ in range(STATES):
        qpos = model.qpos0 + rng.uniform(-1, 1, model.nq)
        for j in range(model.njnt):
            kind, adr = model.jnt_type[j], model.jnt_qposadr[j]
            first = {mujoco.mjtJoint.mjJNT_FREE: 3, mujoco.mjtJoint.mjJNT_BALL: 0}.get(kind)
            if first is not None:
                qpos[adr + first:adr + first + 4] /= np.linalg.norm(qpos[adr + first:adr + first + 4])
        qvel = rng.normal(0, 2, model.nv)
        data.qpos[:], data.qvel[:] = qpos, qvel
        mujoco.mj_forward(model, data)
        M_mj = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M_mj)
        q, u = np.empty(len(names)), np.empty(len(speeds))
        q[q_at], u[u_at] = qpos, qvel
        M, F, _ = (np.array(a, dtype=float) for a in numeric.mfb(0.0, q, u))
        assert _relative(M[np.ix_(u_at, u_at)], M_mj) < TOLERANCE
        assert _relative(F.ravel()[u_at], data.qfrc_passive - data.qfrc_bias) < TOLERANCE
