"""Joint types as units (``anadyn_cli.model.joints``, issue 21 item 3): each type's
motion subspace is checked against the derivative of its own transform (numbers
and SymPy), and the modules that read joints do it through the unit, not by
comparing type words."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from anadyn_cli.errors import ModelError
from anadyn_cli.model.joints import JOINT_TYPES
from anadyn_cli.model.loader import robot_from_text
from anadyn_cli.model.robot import JOINT_TYPES as ROBOT_FILE_TYPES
from anadyn_cli.symbolic.kinematics import rotation, rpy_rotation

PACKAGE = Path(__file__).resolve().parent.parent / "anadyn_cli"


def _rotation(axis, angle):
    """Rot(a, angle), Rodrigues, NumPy (independent of the modules under test)."""
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _skew_vector(S):
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


def test_the_registry_is_what_a_robot_file_accepts():
    assert tuple(JOINT_TYPES) == ROBOT_FILE_TYPES == ("revolute", "prismatic", "fixed",
                                                      "spherical")
    for word, kind in JOINT_TYPES.items():
        assert kind.word == word
        assert (kind.coordinates, kind.speeds) == {"fixed": (0, 0), "spherical": (4, 3)}.get(
            word, (1, 1))
        assert kind.moving == (word != "fixed")
    assert [JOINT_TYPES[w].unit for w in ROBOT_FILE_TYPES] == ["rad", "m", None, "1"]
    assert [JOINT_TYPES[w].effort_unit for w in ROBOT_FILE_TYPES] == ["N*m", "N", None, "N*m"]


#: the types whose one displacement moves along or about an axis, or nothing (the
#: spherical joint's quaternion: tests/test_spherical.py)
DISPLACED = [word for word, kind in JOINT_TYPES.items() if not kind.orientation]


@pytest.mark.parametrize("word", DISPLACED)
def test_the_subspace_is_the_velocity_of_the_transform(word):
    """(s, v) = (R_l^T dR_l/dd as a vector, R_l^T do/dd) by central differences of
    ``transform``: the relative spatial velocity per unit speed, in body axes."""
    kind = JOINT_TYPES[word]
    rng = np.random.default_rng(3)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    tilt = rng.normal(size=3)
    C = _rotation(tilt / np.linalg.norm(tilt), 0.7) @ _rotation([0.0, 0.0, 1.0], 0.3)
    origin = rng.normal(size=3)
    d, eps = 0.4, 1e-6
    (R0, o0), (R1, o1), (R2, o2) = (kind.transform(C, origin, axis, x, _rotation)
                                    for x in (d, d - eps, d + eps))
    w = _skew_vector(R0.T @ (R2 - R1) / (2 * eps))
    v = R0.T @ (o2 - o1) / (2 * eps)
    angular, linear = kind.subspace(axis)
    zero = np.zeros(3)
    assert np.allclose(w, zero if angular is None else angular, atol=1e-8)
    assert np.allclose(v, zero if linear is None else linear, atol=1e-8)
    assert np.allclose(R0.T @ R0, np.eye(3))
    if not kind.moving:
        assert angular is None and linear is None
        assert np.array_equal(R0, C) and np.array_equal(o0, origin)


@pytest.mark.parametrize("word", DISPLACED)
def test_the_symbolic_transform_is_the_numeric_one(word):
    """The same ``transform`` on SymPy matrices (as ``symbolic.kinematics`` calls it)
    gives the numbers of the NumPy call."""
    kind = JOINT_TYPES[word]
    d = sp.Symbol("d", real=True)
    axis, origin = sp.Matrix([0, 0.6, 0.8]), sp.Matrix([0.1, -0.2, 0.3])
    C = rpy_rotation([sp.Float(0.2), sp.Float(-0.5), sp.Float(1.1)])
    R, o = kind.transform(C, origin, axis, d, rotation)
    Rn, on = kind.transform(np.array(C, float), np.array(origin, float).ravel(),
                            np.array(axis, float).ravel(), 0.9, _rotation)
    assert np.allclose(np.array(R.subs(d, 0.9), float), Rn)
    assert np.allclose(np.array(o.subs(d, 0.9), float).ravel(), on)


def test_the_kinematic_equations_are_identity():
    """dq = W(q) u with W = 1 for every type but the spherical joint (the speeds are
    the rates)."""
    for word in DISPLACED:
        kind = JOINT_TYPES[word]
        assert kind.coordinate_rates([0.3] * kind.coordinates,
                                     [0.5] * kind.speeds) == [0.5] * kind.speeds


ONE_JOINT = """\
name: one
coordinates:
  q1: {{}}
bodies:
  - name: bar
    joint: {{type: {word}, axis: [0, 0, 1]{extra}}}
    mass: 1
    com: [1, 0, 0]
    inertia: {{ixx: 0.1, iyy: 0.1, izz: 0.1}}
actuators:
  drive: {{joint: bar}}
"""

#: the units the robot file's messages and the actuators give, written out by hand
UNITS = {"revolute": {"damping": "N*m*s/rad", "friction": "N*m", "stiffness": "N*m/rad",
                      "friction_velocity": "rad/s", "coordinate": "rad", "actuator": "N*m"},
         "prismatic": {"damping": "N*s/m", "friction": "N", "stiffness": "N/m",
                       "friction_velocity": "m/s", "coordinate": "m", "actuator": "N"}}


@pytest.mark.parametrize("word", list(UNITS))
def test_the_loader_takes_the_units_from_the_joint_type(word):
    """The coordinate's and the actuator's unit, and the units the joint-force messages
    name, are the joint type's (the loader composes the force units from them)."""
    robot = robot_from_text(ONE_JOINT.format(word=word, extra=""))
    assert robot.coordinates[0].unit == UNITS[word]["coordinate"]
    assert robot.actuators[0].unit == UNITS[word]["actuator"]
    for key in ("damping", "friction", "stiffness"):
        with pytest.raises(ModelError, match=re.escape(f"must be 0 or positive "
                                                       f"({UNITS[word][key]}), got -1")):
            robot_from_text(ONE_JOINT.format(word=word, extra=f", {key}: -1"))
    with pytest.raises(ModelError, match=re.escape(f"in {UNITS[word]['friction_velocity']}, "
                                                   "over which")):
        robot_from_text(ONE_JOINT.format(word=word, extra=", friction_velocity: 0"))


def test_the_loader_refuses_a_type_word_outside_the_registry():
    with pytest.raises(ModelError, match=r"joint\.type: must be one of revolute, prismatic, "
                                         r"fixed, spherical\b.*, got 'continuous'$"):
        robot_from_text(ONE_JOINT.format(word="continuous", extra=""))


FLOATING_BASE = """\
<robot name="floating">
  <link name="world"/>
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.5 0 0"/><mass value="1"/>
      <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><sphere radius="0.05"/></geometry></visual>
  </link>
  <joint name="free" type="floating"><parent link="world"/><child link="base"/></joint>
  <joint name="turn" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def test_the_view_reads_the_urdf_joints_that_move_as_the_importer_does(tmp_path):
    """A floating base joint that --fix-base welds carries no body: the 3-D view's
    visuals put the base link on the ground and the arm on the importer's body."""
    from anadyn_cli.model.urdf import ReadingOptions, import_file, reading
    from anadyn_cli.output.view.visuals import visuals

    urdf = tmp_path / "floating.urdf"
    urdf.write_text(FLOATING_BASE, encoding="utf-8")
    bodies = [b["name"] for b in import_file(urdf, fix_base=True).data["bodies"]]
    assert bodies == ["arm"]
    with reading(ReadingOptions(fix_base=True)):
        found = visuals(urdf)
    assert [(v.link, v.owner) for v in found.items] == [("base", -1), ("arm", 0)]


#: modules that still name joint type words, each for a reason: the unit itself; the
#: generic C kernel's joint codes (numeric/generic/tables.py).
NAMING_WORDS = {"model/joints.py", "numeric/generic/tables.py"}


def test_the_recursions_and_kinematics_read_joints_through_the_unit():
    """No other module names a joint's type word: a new type is one class."""
    words = re.compile(r"""["'](revolute|prismatic|fixed)["']""")
    naming = {str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
              if words.search(p.read_text(encoding="utf-8"))}
    assert naming <= NAMING_WORDS
