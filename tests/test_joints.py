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

from anadyn_cli.model.joints import JOINT_TYPES
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
    assert tuple(JOINT_TYPES) == ROBOT_FILE_TYPES == ("revolute", "prismatic", "fixed")
    for word, kind in JOINT_TYPES.items():
        assert kind.word == word
        assert kind.coordinates == kind.speeds == (0 if word == "fixed" else 1)
        assert kind.moving == (word != "fixed")
    assert [JOINT_TYPES[w].unit for w in ROBOT_FILE_TYPES] == ["rad", "m", None]
    assert [JOINT_TYPES[w].effort_unit for w in ROBOT_FILE_TYPES] == ["N*m", "N", None]


@pytest.mark.parametrize("word", list(JOINT_TYPES))
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


@pytest.mark.parametrize("word", list(JOINT_TYPES))
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
    """dq = W(q) u with W = 1 for every type here (the speeds are the rates)."""
    for kind in JOINT_TYPES.values():
        assert kind.coordinate_rates([0.5] * kind.speeds) == [0.5] * kind.speeds


#: modules that still name joint type words, each for a reason: the unit itself; the
#: robot-file and URDF readers (type words are their input; the loader's units and
#: the URDF importer's kinds to move to the unit); the generic C kernel's joint codes
#: (numeric/generic/tables.py); the 3-D view and the modules that test ``!= "fixed"``
#: (to read ``joint_type.moving``) are listed for the lead.
NAMING_WORDS = {"model/joints.py", "model/loader.py", "model/urdf.py", "model/library.py",
                "numeric/generic/tables.py", "services/view.py", "symbolic/forces.py",
                "numeric/frames.py", "numeric/closed_form.py", "studies/sweep.py",
                "output/view/visuals.py"}


def test_the_recursions_and_kinematics_read_joints_through_the_unit():
    """No other module compares a joint's type word: a new type is one class."""
    words = re.compile(r'"(revolute|prismatic|fixed)"')
    naming = {str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
              if words.search(p.read_text(encoding="utf-8"))}
    assert naming <= NAMING_WORDS
    for module in ("numeric/recursive", "symbolic/kinematics.py",
                   "symbolic/formulations/kane.py", "model/massmatrix.py", "model/info.py",
                   "model/constraints.py", "model/robot.py", "output/drawing.py"):
        assert not any(m.startswith(module) for m in naming), module
