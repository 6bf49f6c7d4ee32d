"""The generated regressor (``numeric.recursive.regressor``) and its export
(``anadyn export --regressor``), against independent sources:

- native C, generated Python (the fallback without a compiler) and Pinocchio's
  ``computeJointTorqueRegressor`` on every URDF of the test data at 20 random
  states, to 1e-10 relative: each moving body's ten columns are Pinocchio's for its
  joint (same frame, same order); the drive columns are J^T (ddtheta, dtheta,
  tanh(dtheta / v)) computed here; Y pi against Pinocchio's RNEA, fixed bodies
  included, is tests/test_identification.py's;
- the exported C (compiled under -std=c99 -Wall -Wextra -Werror -pedantic, one
  state and batched) and Python against the API to 1e-12;
- Y pi with the file's parameters against the exported equations' inverse
  dynamics, B tau = M ddq - F (joint damping and friction included);
- bad options and robots: one line, exit 2, nothing written.
"""
from __future__ import annotations

import csv
import ctypes
import math
from pathlib import Path

import numpy as np
import pytest

import anadyn
from anadyn_cli.cli import main
from anadyn_cli.numeric.recursive.regressor import regressor
from anadyn_cli.output.export import regressor as regressor_files
from anadyn_cli.services import export as service
from anadyn_cli.studies.identification.base import random_states
from test_export import GCC, compile_c, load_module, needs_gcc  # noqa: E402
from test_identification import URDFS, Pinocchio  # noqa: E402

TOL = 1e-10


def _states(model, count, seed):
    q, dq, ddq = random_states(model, count, seed)
    return q, 2 * dq, 5 * ddq


def _drive_columns(model, q, dq, ddq):
    """J^T [ddtheta_j, dtheta_j, tanh(dtheta_j / v_j)] per moving joint j: (N, n, 3 nj)."""
    rate, acc = dq @ model.J.T, ddq @ model.J.T
    nj = len(model.J)
    joint = np.zeros((len(q), nj, 3 * nj))
    for j in range(nj):
        joint[:, j, 3 * j:3 * j + 3] = np.stack(
            [acc[:, j], rate[:, j], np.tanh(rate[:, j] / model.friction_velocity[j])], -1)
    return np.einsum("jk,Njp->Nkp", model.J, joint)


@pytest.mark.parametrize("path", URDFS, ids=lambda p: p.stem)
def test_native_python_and_pinocchio_regressors_agree(path, monkeypatch):
    monkeypatch.setenv("ANADYN_NATIVE", "wait")
    oracle = Pinocchio(path)
    model = oracle.model
    native = regressor(oracle.robot)
    if GCC is not None:
        assert native.native is not None, native.note
    python = regressor(oracle.robot, native=False)
    q, dq, ddq = _states(model, 20, 11)
    Y = native(q, dq, ddq)
    scale = np.abs(Y).max()
    assert np.abs(Y - python(q, dq, ddq)).max() <= TOL * scale
    drive = 10 * len(model.bodies)
    assert np.abs(Y[:, :, drive:] - _drive_columns(model, q, dq, ddq)).max() <= TOL * scale
    worst = 0.0
    for k in range(len(q)):
        pin_Y = oracle.regressor(q[k], dq[k], ddq[k])
        for j, row in enumerate(oracle.rows):
            b = model.moving[row]
            worst = max(worst, np.abs(Y[k][:, 10 * b:10 * b + 10]
                                      - pin_Y[:, 10 * j:10 * j + 10]).max())
    print(f"{path.stem}: max |Y - Pinocchio's| / max |Y| = {worst / scale:.1e}")
    assert worst <= TOL * scale


def test_the_pinocchio_comparison_sees_a_wrong_column():
    """A regressor with one column scaled by 1 + 1e-6 fails the comparison above."""
    oracle = Pinocchio(URDFS[-1])
    model = oracle.model
    q, dq, ddq = (a[:1] for a in _states(model, 1, 0))
    Y = model.regressor(q, dq, ddq)[0]
    b = model.moving[oracle.rows[1]]
    Y[:, 10 * b] *= 1 + 1e-6
    pin_Y = oracle.regressor(q[0], dq[0], ddq[0])
    assert np.abs(Y[:, 10 * b:10 * b + 10] - pin_Y[:, 10:20]).max() > TOL * np.abs(Y).max()


def test_a_state_that_is_not_finite_is_refused(monkeypatch):
    model = anadyn.parametric_model("rr")
    bad = np.array([[0.1, 0.2], [math.nan, 0.0]])
    for how in ("0", "wait"):
        monkeypatch.setenv("ANADYN_NATIVE", how)
        with pytest.raises(anadyn.ModelError, match="not finite at state 1"):
            regressor(model.robot)(bad, np.zeros((2, 2)), np.zeros((2, 2)))


# -- the export ---------------------------------------------------------------------------
def _damped_rr(folder):
    """rr with joint damping and friction (the drive columns Fv and Fc at work)."""
    text = Path(anadyn.load("rr").source).read_text()
    text = text.replace("displacement: q1}", "displacement: q1, damping: 0.3, friction: 0.2}")
    text = text.replace("displacement: q2 - q1}",
                        "displacement: q2 - q1, damping: 0.1, friction: 0.4, "
                        "friction_velocity: 0.5}")
    path = folder / "rr_damped.yaml"
    path.write_text(text)
    return anadyn.load(path)


EXPORT_CASES = ["rr damped", "rrt"]


def _robot(case, folder):
    return _damped_rr(folder) if case == "rr damped" else anadyn.load(case)


@needs_gcc
@pytest.mark.parametrize("case", EXPORT_CASES)
def test_exported_c_regressor_and_inverse_dynamics(case, tmp_path):
    """NAME_regressor.c compiles under the strict flags; Y, one state and batched, is
    the API's to 1e-12; Y pi (its NOMINAL) is B tau of the exported NAME_inverse."""
    robot = _robot(case, tmp_path)
    result = service.export(robot, "c", regressor=True)
    service.write(result, tmp_path)
    name = result.model.name
    lib = compile_c(tmp_path, f"{name}_regressor")
    equations = compile_c(tmp_path, name)
    model = anadyn.parametric_model(robot)
    n, p = len(model.coordinates), len(model.names)
    q, dq, ddq = _states(model, 5, 4)
    want = model.regressor(q, dq, ddq)
    pointer = ctypes.POINTER(ctypes.c_double)

    def ptr(a):
        return np.ascontiguousarray(a, dtype=float).ctypes.data_as(pointer)

    batch = getattr(lib, f"{name}_regressor_batch")
    batch.restype = ctypes.c_long
    batch.argtypes = [ctypes.c_long, pointer, pointer, pointer, pointer]
    out = np.empty((len(q), n, p))
    assert batch(len(q), ptr(q), ptr(dq), ptr(ddq), out.ctypes.data_as(pointer)) == -1
    assert np.abs(out - want).max() <= 1e-12 * max(1.0, np.abs(want).max())
    single = getattr(lib, f"{name}_regressor")
    single.restype = ctypes.c_int
    nominal = np.ctypeslib.as_array((ctypes.c_double * p).in_dll(
        lib, f"{name.upper()}_REGRESSOR_NOMINAL"))
    assert np.array_equal(nominal, model.nominal)
    names = (ctypes.c_char_p * p).in_dll(lib, f"{name.upper()}_REGRESSOR_PARAMETERS")
    assert tuple(x.decode() for x in names) == model.names
    for k in range(len(q)):
        Y = np.empty((n, p))
        assert single(ptr(q[k]), ptr(dq[k]), ptr(ddq[k]), Y.ctypes.data_as(pointer)) == 0
        assert np.array_equal(Y, out[k])
        tau, B = np.empty(len(model.actuators)), np.empty((n, len(model.actuators)))
        getattr(equations, f"{name}_inverse")(ctypes.c_double(0.0), ptr(q[k]), ptr(dq[k]),
                                              ptr(ddq[k]), tau.ctypes.data_as(pointer))
        getattr(equations, f"{name}_input_matrix")(ptr(q[k]), B.ctypes.data_as(pointer))
        assert np.abs(Y @ nominal - B @ tau).max() <= 1e-10 * max(1.0, np.abs(B @ tau).max())


@pytest.mark.parametrize("case", EXPORT_CASES)
def test_exported_python_regressor_and_inverse_dynamics(case, tmp_path):
    """NAME_regressor.py (NumPy, no anadyn): Y is the API's to 1e-12, one state and
    batched; Y pi is B tau of the exported inverse; the companion list is pi's order."""
    robot = _robot(case, tmp_path)
    result = service.export(robot, "python", regressor=True)
    service.write(result, tmp_path)
    name = result.model.name
    text = (tmp_path / f"{name}_regressor.py").read_text()
    assert "anadyn" not in text.split('"""')[2]              # imports numpy and math only
    exported = load_module(tmp_path / f"{name}_regressor.py")
    equations = load_module(tmp_path / f"{name}.py")
    model = anadyn.parametric_model(robot)
    assert exported.PARAMETERS == model.names and np.array_equal(exported.NOMINAL,
                                                                 model.nominal)
    with open(tmp_path / f"{name}_regressor_parameters.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["name"] for r in rows] == list(model.names)
    assert [float(r["nominal"]) for r in rows] == list(model.nominal)
    q, dq, ddq = _states(model, 5, 4)
    want = model.regressor(q, dq, ddq)
    got = exported.regressor(q, dq, ddq)
    assert np.abs(got - want).max() <= 1e-12 * max(1.0, np.abs(want).max())
    for k in range(len(q)):
        Y = exported.regressor(q[k], dq[k], ddq[k])
        assert Y.shape == want[k].shape
        assert np.abs(Y - want[k]).max() <= 1e-12 * max(1.0, np.abs(want).max())
        Btau = np.asarray(equations.input_matrix(q[k])) @ np.asarray(
            equations.inverse(0.0, q[k], dq[k], ddq[k]))
        assert np.abs(Y @ exported.NOMINAL - Btau).max() <= 1e-10 * max(1.0, np.abs(Btau).max())


@needs_gcc
def test_exported_ur5_regressor_is_the_apis(tmp_path, monkeypatch):
    """The UR5's exported C and Python Y (six joints, 78 parameters) against the API's
    native Y, batched, to 1e-12."""
    monkeypatch.setenv("ANADYN_NATIVE", "wait")
    robot = anadyn.load("ur5")
    texts = {**regressor_files.files(robot, "ur5", "c"),
             **regressor_files.files(robot, "ur5", "python")}
    for file, text in texts.items():
        (tmp_path / file).write_text(text)
    lib = compile_c(tmp_path, "ur5_regressor")
    model = anadyn.parametric_model(robot)
    assert model.generated.native is not None
    q, dq, ddq = _states(model, 50, 8)
    want = model.regressor(q, dq, ddq)
    out = np.empty_like(want)
    pointer = ctypes.POINTER(ctypes.c_double)
    batch = lib.ur5_regressor_batch
    batch.restype = ctypes.c_long
    assert batch(ctypes.c_long(len(q)), *(np.ascontiguousarray(a).ctypes.data_as(pointer)
                                          for a in (q, dq, ddq, out))) == -1
    scale = np.abs(want).max()
    assert np.abs(out - want).max() <= 1e-12 * scale
    exported = load_module(tmp_path / "ur5_regressor.py")
    assert np.abs(exported.regressor(q, dq, ddq) - want).max() <= 1e-12 * scale


@pytest.mark.parametrize("argv, message", [
    (["rr", "--lang", "matlab", "--regressor"],
     "anadyn: error: --regressor applies to lang c and python, not matlab\n"),
    (["rr", "--lang", "c", "--regressor", "--symbolic"],
     "anadyn: error: --regressor folds the robot file's numbers in, so not with symbolic\n"),
])
def test_export_regressor_options_are_checked(argv, message, tmp_path, capsys):
    assert main(["export", *argv, "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err.endswith(message)
    assert not (tmp_path / "out").exists()


def test_export_regressor_refuses_a_robot_with_loads(tmp_path, capsys):
    assert main(["export", "rrt_friction", "--lang", "c", "--regressor",
                 "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.endswith("rrt_friction.yaml: the regressor models no external loads; this "
                        "robot has 1 (remove its loads: section)\n")
    assert err.count("anadyn: error:") == 1
    assert not (tmp_path / "out").exists()
