"""The robot simulated is the robot described (issue 22, items 2, 4, 8, 10).

* URDF import: no name or file name from the URDF can change the robot's
  structure (a hypothesis fuzz over link, joint and file names checks the
  loaded bodies, masses, actuators and controller against the URDF), and the
  YAML that ``anadyn import`` writes loads back to the same data; messages
  name a place in the URDF, never a line of YAML generated in memory.
* Numbers are read as their text reads: URDF ``1_0`` is refused, YAML
  ``010`` is 10 and ``1:30`` is text (refused where a number is wanted),
  expressions take decimal literals only.
* Expressions: ``sqrt(q1**2)`` is |q1| (a law may use it; a displacement,
  which is differentiated twice, may not), and deep nesting is one line,
  exit 2, with the limit.
* A file name that is not UTF-8, or that holds a line break, works or gives
  one line; ``anadyn check`` on coaxial vertical joints gives its figures.
"""
from __future__ import annotations

import json
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from anadyn_cli.cli import main
from anadyn_cli.model import load_robot, robot_from_text, yamlschema
from anadyn_cli.model.expressions import MAX_DEPTH, ExpressionError, parse
from anadyn_cli.model.urdf import import_file

REPO = Path(__file__).resolve().parent.parent
SMUGGLED = ("tool\n  - name: smuggled\n    parent: ground\n    joint: {type: revolute, "
            "axis: [0, 0, 1], displacement: j1}\n    mass: 1000\n    inertia: {ixx: 1, "
            "iyy: 1, izz: 1}\n  #")
CONTROLLER_FILE = "e.urdf\ncontroller:\n  laws:\n    tau_j1: 50\n#.urdf"


def urdf(links: list[tuple[str, float]], joints: list[tuple[str, str]], name: str = "r") -> bytes:
    """A chain: the base, then links[i] hung on joints[i] (type "revolute" or
    "fixed") from the link before; ElementTree writes the names (escaping
    quotes, <, &, line breaks as &#10;)."""
    robot = ET.Element("robot", name=name)
    ET.SubElement(robot, "link", name="base")
    parent = "base"
    for (link, mass), (joint, kind) in zip(links, joints):
        element = ET.SubElement(robot, "link", name=link)
        inertial = ET.SubElement(element, "inertial")
        ET.SubElement(inertial, "origin", xyz="0.5 0 0")
        ET.SubElement(inertial, "mass", value=repr(mass))
        ET.SubElement(inertial, "inertia", ixx="0.01", iyy="0.02", izz="0.02",
                      ixy="0", ixz="0", iyz="0")
        j = ET.SubElement(robot, "joint", name=joint, type=kind)
        ET.SubElement(j, "origin", xyz="1 0 0")
        ET.SubElement(j, "parent", link=parent)
        ET.SubElement(j, "child", link=link)
        ET.SubElement(j, "axis", xyz="0 1 0")
        parent = link
    return ET.tostring(robot)


def expected_masses(links, joints) -> list[float]:
    """Each moving joint's body: its link plus the links fixed after it."""
    masses: list[float] = []
    for (_, mass), (_, kind) in zip(links, joints):
        if kind == "fixed" and masses:
            masses[-1] += mass
        elif kind != "fixed":
            masses.append(mass)
    return masses


def assert_as_described(path: Path, links, joints) -> None:
    """The loaded robot has the URDF's bodies, masses and actuators, no
    controller and no loads; the YAML written loads back to the same data."""
    robot = load_robot(path)
    masses = expected_masses(links, joints)
    assert [float(b.mass) for b in robot.bodies] == pytest.approx(masses, rel=1e-12)
    assert len(robot.coordinates) == len(robot.actuators) == len(masses)
    assert robot.controller is None and not robot.loads and robot.trajectory is None
    imported = import_file(path)
    data, _ = yamlschema.load(imported.text, "imported")
    assert data == imported.data
    again = robot_from_text(imported.text, "again.yaml")
    assert [b.mass for b in again.bodies] == [b.mass for b in robot.bodies]
    assert [b.name for b in again.bodies] == [b.name for b in robot.bodies]


def run(capsys, argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(err: str) -> str:
    assert err.startswith("anadyn: error: ") and err.endswith("\n") and err.count("\n") == 1, err
    return err


# -- 1. URDF import builds the robot the URDF describes ----------------------------------
LINKS = [("arm", 1.0), (SMUGGLED, 0.5)]
JOINTS = [("j1", "revolute"), ("fix", "fixed")]


def test_a_link_name_cannot_add_a_body(tmp_path, capsys):
    path = tmp_path / "smuggle.urdf"
    path.write_bytes(urdf(LINKS, JOINTS))
    assert_as_described(path, LINKS, JOINTS)          # one body of 1.5 kg, not 1000 kg more
    assert run(capsys, ["import", path, "-o", tmp_path / "r.yaml"])[0] == 0
    robot = load_robot(tmp_path / "r.yaml")           # the file written is the robot
    assert [(b.name, float(b.mass)) for b in robot.bodies] == [("arm", 1.5)]


def test_a_file_name_cannot_add_a_controller(tmp_path, capsys):
    path = tmp_path / CONTROLLER_FILE
    path.write_bytes(urdf(LINKS[:1], JOINTS[:1]))
    assert_as_described(path, LINKS[:1], JOINTS[:1])
    code, out, err = run(capsys, ["import", path])
    assert code == 0 and "controller" not in yamlschema.load(out, "out")[0]
    assert err.count("\n") == 1 and "e.urdf\\ncontroller:" in err   # one line, escaped


XML_CHARACTERS = st.characters(blacklist_categories=("Cs",)).filter(
    lambda c: c in "\t\n\r" or "\x20" <= c <= "\ud7ff" or "\ue000" <= c <= "\ufffd"
    or c >= "\U00010000")
NAMES = st.text(XML_CHARACTERS, min_size=1, max_size=12)
FILE_NAMES = st.binary(min_size=1, max_size=20).map(
    lambda b: os.fsdecode(b.replace(b"/", b"_").replace(b"\0", b"_")))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(names=st.lists(NAMES, min_size=6, max_size=6, unique=True),
       kinds=st.lists(st.sampled_from(["revolute", "fixed"]), min_size=3, max_size=3),
       masses=st.lists(st.sampled_from([0.25, 1.0, 3.5, 7.0]), min_size=3, max_size=3),
       file_name=FILE_NAMES)
def test_fuzz_names_cannot_change_the_robot(names, kinds, masses, file_name):
    kinds[0] = "revolute"                              # something moves
    link_names = [n for n in names[:3]]
    if "base" in link_names:
        return
    links = list(zip(link_names, masses))
    joints = list(zip(names[3:], kinds))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / (file_name + ".urdf")
        path.write_bytes(urdf(links, joints, name=names[0]))
        assert_as_described(path, links, joints)


TRICKY = ["yes", "null", "~", "010", "1e5", "on", "- x", "#c", "&a", "*a", "!tag", "a: b",
          '"q"', "'q'", "x\u2028y", "x\x85y", "\u00e9t\u00e9", "\u65e5\u672c", "ground", "sin",
          "t", "dq", "q\r\n- name: z", "{a: 1}", "[1]", "%YAML", "---", "...", "@x", "`x"]


@pytest.mark.parametrize("start", range(0, len(TRICKY), 3))
def test_names_with_yaml_syntax_cannot_change_the_robot(tmp_path, start):
    names = (TRICKY * 2)[start:start + 6]
    links = [(names[0], 1.0), (names[1], 2.0), (names[2], 3.0)]
    joints = [(names[3], "revolute"), (names[4], "fixed"), (names[5], "revolute")]
    path = tmp_path / f"{names[0]}.urdf".replace("/", "_")
    path.write_bytes(urdf(links, joints, name=names[1]))
    assert_as_described(path, links, joints)


def test_messages_name_the_place_in_the_urdf(tmp_path, capsys):
    """A robot the loader refuses (a point mass on its own joint axis moves no
    mass) is reported at the URDF joint, not at a line of generated YAML."""
    path = tmp_path / "point.urdf"
    path.write_bytes(urdf([("arm", 1.0)], [("elbow", "revolute")]).replace(
        b'xyz="0.5 0 0"', b'xyz="0 0 0"').replace(b'"0.01"', b'"0"').replace(b'"0.02"', b'"0"'))
    code, out, err = run(capsys, ["show", path, "--out", tmp_path / "out"])
    assert code == 2 and out == ""
    assert one_line_error(err).startswith(
        f"anadyn: error: {path}: joint 'elbow' (imported as coordinates.elbow): ")
    assert not (tmp_path / "out").exists()


# -- 2. numbers read as their text reads --------------------------------------------------
def test_urdf_underscore_number_refused(tmp_path, capsys):
    path = tmp_path / "u.urdf"
    path.write_bytes(urdf([("arm", 1.0)], [("j1", "revolute")]).replace(
        b'value="1.0"', b'value="1_0"'))
    code, out, err = run(capsys, ["import", path])
    assert (code, out) == (2, "")
    assert one_line_error(err) == (
        f"anadyn: error: {path}: link 'arm': <mass value=\"1_0\">: expected 1 number; '1_0' "
        "is not a decimal number such as -1.5e-3 (digits, a point, an exponent: no "
        "underscores)\n")


RR = (REPO / "robots" / "rr.yaml").read_text()


def with_mass(text: str) -> str:
    assert RR.count("    mass: m2") == 1
    return RR.replace("    mass: m2", f"    mass: {text}")


@pytest.mark.parametrize("written, value", [("010", 10), ("0o10", 8), ("1e-1", 0.1),
                                            ("'1e-1'", 0.1), ("+3", 3)])
def test_yaml_numbers_follow_yaml_1_2(written, value):
    robot = robot_from_text(with_mass(written), "rr.yaml")
    assert float(robot.bodies[1].mass) == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize("written, message", [
    ("1:30", "syntax error in '1:30' at column 2"),          # text, never 90
    ("1_0", "'1_0' is not a decimal number"),                # text, then not a decimal
    ("'2*1_0'", "'1_0' is not a decimal number"),
    ("'0x10'", "'0x10' is not a decimal number"),
    ("!!int 1_0", "cannot read the value '1_0' (not an integer of the YAML 1.2 core schema)"),
])
def test_yaml_numbers_that_read_otherwise_are_refused(tmp_path, capsys, written, message):
    path = tmp_path / "rr.yaml"
    path.write_text(with_mass(written))
    code, out, err = run(capsys, ["equations", path])
    assert (code, out) == (2, "")
    assert one_line_error(err).startswith(f"anadyn: error: {path}:21: bodies[1].mass: {message}")


def test_loader_resolves_numbers_as_yaml_1_2():
    data, _ = yamlschema.load("a: 010\nb: 1:30\nc: 1_000\nd: 1e-5\ne: 0x1F\nf: .inf\n", "x")
    assert data == {"a": 10, "b": "1:30", "c": "1_000", "d": 1e-5, "e": 31, "f": float("inf")}
    assert [type(v) for v in data.values()] == [int, str, str, float, int, float]


# -- 3. expressions ---------------------------------------------------------------------
def test_sqrt_of_a_square_in_a_law_is_its_absolute_value(tmp_path, capsys):
    text = RR.replace("    T12z: -b12*dq2 - g12*(q2 - q2f) + 0.5*g*L2*m2*cos(q2)",
                      "    T12z: sqrt(q2**2)")
    assert "sqrt(q2**2)" in text
    robot = robot_from_text(text, "rr.yaml")
    assert str(robot.controller.laws["T12z"]) == "Abs(q2)"
    path = tmp_path / "rr.yaml"
    path.write_text(text)
    assert run(capsys, ["equations", path])[0] == 0


def test_sqrt_of_a_square_in_a_displacement_is_one_line(tmp_path, capsys):
    path = tmp_path / "rr.yaml"
    path.write_text(RR.replace("displacement: q2 - q1}", "displacement: sqrt(q2**2)}"))
    code, out, err = run(capsys, ["inverse", path, "--out", tmp_path / "out"])
    assert (code, out) == (2, "")
    assert one_line_error(err) == (
        f"anadyn: error: {path}:20: bodies[1].joint.displacement: 'sqrt(q2**2)' is Abs(q2): "
        "Abs(q2) has a kink or a jump, not allowed here (this expression is differentiated "
        "twice)\n")


@pytest.mark.parametrize("text", [
    "(" * 2000 + "m2" + ")" * 2000,            # over the length limit
    "+".join(["m2"] * 100_000),                # 10^5 terms: over the file size limit
    "-" * 1500 + "m2",                         # parsed, then too deep
    "sin(" * 150 + "m2" + ")" * 150,
    "m2**" * 300 + "1",
], ids=["parentheses", "terms", "signs", "calls", "powers"])
def test_deep_or_long_expressions_are_one_line(tmp_path, capsys, text):
    path = tmp_path / "rr.yaml"
    path.write_text(with_mass(f"'{text}'"))
    code, out, err = run(capsys, ["equations", path])
    assert (code, out) == (2, "")
    one_line_error(err)
    assert ("expression longer than 2000 characters" in err or "bytes, the limit is" in err
            or f"expression too deeply nested (limit {MAX_DEPTH})" in err
            or "too many nested parentheses" in err), err


def test_nesting_up_to_the_limit_is_read():
    import sympy as sp

    q = sp.Symbol("q", real=True)
    assert parse("sin(" * (MAX_DEPTH - 1) + "q" + ")" * (MAX_DEPTH - 1), {"q": q}) \
        .count(sp.sin) == MAX_DEPTH - 1
    with pytest.raises(ExpressionError, match=rf"too deeply nested \(limit {MAX_DEPTH}\)"):
        parse("sin(" * MAX_DEPTH + "q" + ")" * MAX_DEPTH, {"q": q})
    assert parse("+".join(["q"] * 600), {"q": q}) == 600 * q      # a long chain is one level


# -- 4. file names that are not UTF-8 or hold a line break --------------------------------
NO_NAME = "\n".join(line for line in RR.splitlines() if not line.startswith("name:")) + "\n"


def test_non_utf8_file_name_works(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = Path(os.fsdecode(b"robot\xff.yaml"))
    path.write_text(NO_NAME)
    code, out, err = run(capsys, ["show", path])
    assert code == 0, err
    figures = json.loads((tmp_path / "results" / "robot_xff" / "show.json").read_text())
    assert figures["robot"] == "robot_xff"
    assert run(capsys, ["check", path, "--t-end", "1"])[0] == 0
    assert "robot_xff" in json.loads(
        (tmp_path / "results" / "robot_xff" / "check.json").read_text())["robot"]


def test_non_utf8_file_name_in_a_message_is_one_line(tmp_path, capsys):
    path = tmp_path / os.fsdecode(b"bad\xff\n.yaml")
    path.write_text(with_mass("-1"))
    code, out, err = run(capsys, ["equations", path])
    assert (code, out) == (2, "")
    assert one_line_error(err).startswith(f"anadyn: error: {tmp_path}/bad\\xff\\n.yaml:21: ")


def test_non_utf8_urdf_file_name_imports(tmp_path, capsys):
    path = tmp_path / os.fsdecode(b"arm\xfe.urdf")
    path.write_bytes(urdf([("arm", 2.0)], [("j1", "revolute")]))
    code, out, err = run(capsys, ["import", path, "-o", tmp_path / "arm.yaml"])
    assert code == 0, err
    assert load_robot(tmp_path / "arm.yaml").name == "arm_xfe"


# -- 5. check on coaxial vertical joints ---------------------------------------------------
COAXIAL = """name: coax
gravity: [0, 0, -9.81]
coordinates:
  q1: {initial: 0.1}
  q2: {initial: 0.2}
bodies:
  - name: a
    parent: ground
    joint: {type: revolute, axis: [0, 0, 1], displacement: q1}
    mass: 1
    com: [0.5, 0, 0]
    inertia: {ixx: 0.01, iyy: 0.1, izz: 0.1}
  - name: b
    parent: a
    joint: {type: revolute, axis: [0, 0, 1], origin: [1, 0, 0], displacement: q2}
    mass: 1
    com: [0.5, 0, 0]
    inertia: {ixx: 0.01, iyy: 0.1, izz: 0.1}
"""


def test_check_on_coaxial_vertical_joints(tmp_path, capsys):
    """Gravity along both joint axes does no work, so nothing moves from rest:
    every eigenvalue is 0, no mode decays (no time constant), the scene is not
    stiff, and the energy does not drift."""
    path = tmp_path / "coax.yaml"
    path.write_text(COAXIAL)
    from anadyn_cli.numeric.build import numeric_model

    model = numeric_model(path, "kane", False)
    rng = np.random.default_rng(1)
    for _ in range(3):                  # independent: the generalized gravity force is 0
        q = rng.uniform(-3, 3, 2)
        _, F, _ = model.mfb(0.0, q, np.zeros(2))
        assert np.abs(np.asarray(F, dtype=float)).max() == 0
    code, out, err = run(capsys, ["check", path, "--out", tmp_path / "out"])
    assert code == 0, err
    assert "stiffness: not stiff" in out
    figures = json.loads((tmp_path / "out" / "check.json").read_text())
    assert figures["stiff"] is False and figures["fastest_time_constant"] is None
    assert figures["fastest_decay"] == 0 and figures["energy_error"] == 0
