"""`anadyn linearize` by its two evaluators: the recursive one (the generated derivatives
of the recursive Newton-Euler algorithm, ``numeric.derivatives``; the default on open
trees of revolute and prismatic joints) and the closed forms (Kane's or Lagrange's
equations differentiated symbolically) give the same point, A, B, A_closed_loop and
equilibria to ~1e-10 relative; A and the accelerations agree with Pinocchio's
``computeABADerivatives`` (UR5) and its RNEA derivatives reduced to anadyn's coordinates
(Panda, whose second finger mimics the first), by both codes of the recursive evaluator
(the generated derivatives, and the generic kernel: tests/test_linearize_kernel.py).
Which evaluator and code ran is recorded.

Independent sources: the closed forms are SymPy's derivation and differentiation of
Kane's (or Lagrange's) equations, sharing nothing with the traced recursions but the
robot file; Pinocchio is a third implementation of the rigid-body algorithms.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import load_robot, robot_from_text
from anadyn_cli.services import linearize as service

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_export import SCENES  # noqa: E402
from test_linearize import DOUBLE, assert_close, at_text, pendulum  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
def robot_of(name: str):
    """A robot of robots/, or "forced" (test_export's arm with a damped, frictional joint,
    a sprung and damped slider, loads of t and dq, and a PD controller), or "double"."""
    if name in ("rr.yaml", "rrt.yaml", "ur5.urdf", "panda.urdf"):
        return load_robot(REPO / "robots" / name)
    return robot_from_text({"forced": SCENES["forced"], "double": DOUBLE}[name], f"{name}.yaml")


def points(r, count: int, seed: int = 1):
    """``at`` texts: random states, with given efforts, then without (the controller's
    or holding efforts)."""
    rng = np.random.default_rng(seed)
    n, m = len(r.coordinates), len(r.actuators)
    for k in range(count):
        t, q, dq = float(rng.uniform(0, 2)), rng.uniform(-1.2, 1.2, n), rng.uniform(-1.5, 1.5, n)
        yield at_text(r, t, q, dq, rng.uniform(-4, 4, m) if k % 2 == 0 else [])


def assert_same(recursive, closed, tol=1e-10):
    assert (recursive.evaluator, recursive.formulation) == ("recursive", None)
    assert closed.evaluator == "closed-form"
    assert_same_numbers(recursive, closed, tol)


def assert_same_numbers(one, other, tol=1e-10):
    """Two linearizations: the same point (its efforts' source too), A, B and
    A_closed_loop to ``tol`` relative, controllability rank, state and units."""
    p, c = one.point, other.point
    assert (p.efforts_from, p.equilibrium) == (c.efforts_from, c.equilibrium)
    for name, a, b in (("q", p.q, c.q), ("dq", p.dq, c.dq), ("tau", p.tau, c.tau),
                       ("ddq", p.ddq, c.ddq), ("A", one.A, other.A), ("B", one.B, other.B),
                       ("A_closed_loop", one.A_closed_loop, other.A_closed_loop)):
        assert_close(name, a, b, tol)
    assert one.controllability_rank == other.controllability_rank
    assert one.state == other.state and one.units == other.units


def kernel_road(monkeypatch) -> None:
    """Linearizations by the generic kernel from here on (the tests' ANADYN_NATIVE=0
    lifted); skipped where no kernel can be built."""
    from anadyn_cli.numeric import generic

    monkeypatch.delenv("ANADYN_NATIVE", raising=False)
    monkeypatch.delenv("ANADYN_GENERIC", raising=False)
    if generic.kernel() is None:
        pytest.skip("no generic kernel (no C compiler)")


@pytest.mark.parametrize("name, count", [("rr.yaml", 3), ("rrt.yaml", 3), ("forced", 3),
                                         ("double", 2), ("ur5.urdf", 2)])
def test_the_two_evaluators_agree(name, count):
    r = robot_of(name)
    for at in points(r, count):
        recursive = service.linearize(r, at=at)                   # the default
        closed = service.linearize(r, "kane", at=at)
        assert_same(recursive, closed)


def test_the_two_evaluators_agree_on_the_panda():
    r = robot_of("panda.urdf")
    from anadyn_cli.symbolic.formulations import derive
    eom = derive(r, "kane")
    for at in points(r, 2):
        assert_same(service.linearize(r, at=at), service.linearize(r, at=at, eom=eom))


@pytest.mark.parametrize("efforts", ["holding", "zero", "controller"])
def test_the_efforts_choices_agree(efforts):
    r = robot_of("rr.yaml")
    at = "q1=0.3,q2=1.1,dq1=0.2,dq2=-0.4"
    assert_same(service.linearize(r, at=at, efforts=efforts),
                service.linearize(r, "lagrange", at=at, efforts=efforts))


@pytest.mark.parametrize("name, text, at", [
    ("rr.yaml", None, None),                               # under the controller
    ("pendulum", pendulum(initial="-pi/2 + 0.4"), None),   # passive: hangs
    ("forced", None, "q1=0.2,s=0"),                        # springs, loads at t = 0
])
def test_the_equilibrium_searches_agree(name, text, at):
    r = robot_from_text(text, "pendulum.yaml") if text else robot_of(name)
    recursive = service.linearize(r, at=at, equilibrium=True)
    closed = service.linearize(r, "kane", at=at, equilibrium=True)
    assert recursive.point.searched and recursive.point.equilibrium
    assert_same(recursive, closed, 1e-9)


def test_a_spherical_joint_runs_the_closed_forms(tmp_path, capsys):
    path = REPO / "robots" / "spherical_pendulum.yaml"
    result = service.linearize(load_robot(path))
    assert (result.evaluator, result.formulation) == ("closed-form", "kane")
    assert main(["linearize", str(path), "--evaluator", "recursive",
                 "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: --evaluator recursive linearizes revolute and prismatic joints; "
        f"{result.robot} has a spherical joint: use closed-form, the default there\n")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("options, ran, header", [
    ([], {"formulation": None, "evaluator": "recursive",
          "code": "generated Python (the generic kernel is off: ANADYN_NATIVE=0)"},
     "rr (recursive Newton-Euler, generated Python) at"),
    (["--formulation", "lagrange"], {"formulation": "lagrange", "evaluator": "closed-form"},
     "rr (lagrange closed forms) at"),
    (["--evaluator", "closed-form"], {"formulation": "kane", "evaluator": "closed-form"},
     "rr (kane closed forms) at"),
])
def test_the_json_and_the_report_say_what_ran(options, ran, header, tmp_path, capsys):
    assert main(["linearize", "robots/rr.yaml", *options, "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.startswith(header)
    figures = json.loads((tmp_path / "linearize.json").read_text())
    assert {k: figures[k] for k in ran} == ran


def test_recursive_with_a_formulation_is_one_line(tmp_path, capsys):
    assert main(["linearize", "robots/rr.yaml", "--evaluator", "recursive", "--formulation",
                 "kane", "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == (
        "anadyn: error: --evaluator recursive derives no symbolic equations; drop the "
        "formulation (kane) or use closed-form\n")


# -- Pinocchio ------------------------------------------------------------------------------
def pinocchio_model(path: Path, names: list[str]):
    """Pinocchio's model of ``path`` and T (its nv x anadyn's n): its speeds from anadyn's
    coordinates (a mimic joint follows its leader)."""
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(path))
    T = np.zeros((model.nv, len(names)))
    for joint, name in zip(model.joints[1:], model.names[1:]):
        leader = name if name in names else name.replace("joint2", "joint1")   # the mimic
        T[joint.idx_v, names.index(leader)] = 1.0
    return pin, model, T


#: the recursive evaluator's two codes (``linearize.recursive.road``)
CODES = ["generated Python", "generic kernel"]


def on_code(code: str, monkeypatch, urdf: str):
    """(robot, its coordinate names, pinocchio, Pinocchio's model, T, its data) of the
    URDF ``urdf`` in robots/, linearized by the recursive evaluator's ``code``."""
    if code == "generic kernel":
        kernel_road(monkeypatch)
    r = robot_of(urdf)
    names = [c.name for c in r.coordinates]
    pin, model, T = pinocchio_model(REPO / "robots" / urdf, names)
    return r, names, pin, model, T, model.createData()


@pytest.mark.parametrize("code", CODES)
def test_A_matches_pinocchios_aba_derivatives_on_the_ur5(code, monkeypatch):
    r, names, pin, model, T, data = on_code(code, monkeypatch, "ur5.urdf")
    for at in points(r, 2, seed=3):
        result = service.linearize(r, at=at)
        assert result.code.startswith(code)
        p = result.point
        q, v, tau = T @ p.q, T @ p.dq, T @ p.tau
        pin.computeABADerivatives(model, data, q, v, tau)
        n = len(names)
        lower = np.hstack([T.T @ data.ddq_dq @ T, T.T @ data.ddq_dv @ T])
        assert_close("ddq", p.ddq, T.T @ pin.aba(model, data, q, v, tau), 1e-10)
        assert_close("A", result.A[n:], lower, 1e-10)
        Minv = np.array(data.Minv)
        Minv = np.triu(Minv) + np.triu(Minv, 1).T
        assert_close("B", result.B[n:], T.T @ Minv @ T, 1e-10)


@pytest.mark.parametrize("code", CODES)
def test_A_matches_pinocchios_rnea_derivatives_on_the_panda(code, monkeypatch):
    """The Panda's fingers move together (one coordinate): M = T^T M_pin T and
    K = -T^T [dID/dq, dID/dv + damping] T at anadyn's accelerations (Pinocchio's own)."""
    r, names, pin, model, T, data = on_code(code, monkeypatch, "panda.urdf")
    damping = np.array([float(b.joint.damping) for b in r.bodies if b.joint.type != "fixed"])
    assert len(damping) == model.nv
    for at in points(r, 2, seed=5):
        result = service.linearize(r, at=at)
        assert result.code.startswith(code)
        p = result.point
        q, v = T @ p.q, T @ p.dq
        M = T.T @ pin.crba(model, data, q) @ T
        M = np.triu(M) + np.triu(M, 1).T
        bias = T.T @ (pin.nonLinearEffects(model, data, q, v) + damping * v)
        ddq = np.linalg.solve(M, p.tau - bias)
        assert_close("ddq", p.ddq, ddq, 1e-10)
        pin.computeRNEADerivatives(model, data, q, v, T @ ddq)
        K = -np.hstack([T.T @ data.dtau_dq @ T, T.T @ (data.dtau_dv + np.diag(damping)) @ T])
        assert_close("A", result.A[len(names):], np.linalg.solve(M, K), 1e-10)
