"""The generic kernel's state Jacobian (``kernel.jac``: J = [[R], [M^-1 K]] at fixed
joint efforts, K by forward-mode differentiation of the Newton-Euler recursion):
exact, so equal to rounding (1e-12 of the largest entry; central differences, the
kernel's way before, agree to 1e-11..1e-9, 5e-7 with friction near zero speed, and
fail every one of these checks)

- to anadyn's generated derivatives (``derivatives(robot, native=False)``,
  d(ddq)/dq and d(ddq)/d(dq) at the efforts given) on rr (A invertible), rrt
  (A = 1), rrt with its friction, dampers and shoulder spring (external loads
  left off: the kernel refuses them), a tree of mimic joints with damping and
  friction (anadyn_features.urdf: A not square) and example-robot-data's UR5
  and Panda (its fingers a mimic pair), one state of each at speeds near zero
  (friction's tanh at its steepest);
- with spherical joints and a floating base, to the traced recursive path's
  Jacobian (no control laws: the efforts are zero), the quaternion's rows too;
- to Pinocchio's computeABADerivatives on the UR5 and the Panda with its fingers
  locked (Pinocchio's model reduced the same way), the Panda's joint damping
  added to both sides, 1e-10.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli import load_robot, robot_from_text
from anadyn_cli.model.urdf import import_file
from anadyn_cli.numeric import derivatives, generic, recursive

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_derivatives import passive_derivatives  # noqa: E402
from test_generic_kernel import (BALL_ON_ARM, TWIN, erd, generic_model, kernel,  # noqa: E402,F401
                                 needs_compiler, passive, pinocchio_pair, rel, spherical_robot)

ROOT = Path(__file__).resolve().parent.parent
pytestmark = needs_compiler


def jac(module, tables, x, e) -> np.ndarray:
    J = np.empty((len(x), len(x)))
    assert module.jac(tables.ints, tables.doubles, np.ascontiguousarray(x, dtype=float),
                      np.ascontiguousarray(e, dtype=float), J) == 0
    return J


def urdf_robot(path: Path, **options):
    return robot_from_text(import_file(path, fix_base=True, **options).text, path.name)


def without_loads(path: Path):
    """The robot file with its ``loads`` section left off."""
    text = path.read_text()
    start = text.index("\nloads:")
    return robot_from_text(text[:start + 1] + text[text.index("\ncontroller:") + 1:], path.name)


def example(path: str):
    urdf = erd(path)
    if urdf is None or not urdf.exists():
        pytest.skip(f"{path}: example-robot-data not installed")
    return urdf_robot(urdf)


ROBOTS = {"rr": lambda: load_robot(ROOT / "robots/rr.yaml"),
          "rrt": lambda: load_robot(ROOT / "robots/rrt.yaml"),
          "rrt_springs": lambda: without_loads(ROOT / "robots/rrt_friction.yaml"),
          "mimic_tree": lambda: urdf_robot(ROOT / "tests/data/urdf/anadyn_features.urdf"),
          "ur5": lambda: example("ur_description/urdf/ur5_robot.urdf"),
          "panda": lambda: example("panda_description/urdf/panda.urdf")}


@pytest.mark.parametrize("name, mode", [("rr", "INVERTIBLE"), ("rrt", "IDENTITY"),
                                        ("rrt_springs", "IDENTITY"), ("mimic_tree", "GENERAL"),
                                        ("ur5", "IDENTITY"), ("panda", "GENERAL")])
def test_jacobian_equals_the_generated_derivatives(name, mode, kernel):  # noqa: F811
    robot = ROBOTS[name]()
    pl = recursive.plan(robot)
    tables, why = generic.pack(pl)
    assert tables is not None, why
    assert tables.mode == getattr(generic.tables, mode)
    passives = tables.passive()
    if name in ("rrt_springs", "mimic_tree"):
        assert passives[:, 0].any() and passives[:, 1].any()      # dampers, friction
        assert name != "rrt_springs" or passives[:, 3].any()       # a spring
    exact = derivatives.derivatives(robot, native=False)
    n, nm = pl.n, tables.A.shape[0]
    rng = np.random.default_rng(17)
    for k in range(6):
        q, dq = rng.uniform(-1.5, 1.5, n), rng.uniform(-1.5, 1.5, n) * (1e-3 if k == 0 else 1)
        efforts = rng.uniform(-1, 1, len(pl.efforts))
        e = np.zeros(nm)
        np.add.at(e, list(tables.actuator_joint), np.array(tables.actuator_scale) * efforts)
        J = jac(kernel, tables, np.concatenate([q, dq]), e)
        assert np.array_equal(J[:n], np.eye(2 * n)[n:])
        assert rel(J[n:], np.hstack(exact.forward_derivatives(0.0, q, dq, efforts)[:2])) < 1e-12


@pytest.mark.parametrize("name", ["spherical_pendulum", "ball_on_arm", "twin_arms", "solo12_free"])
def test_jacobian_with_spherical_joints_equals_the_traced_one(name, kernel):  # noqa: F811
    """ball_on_arm, twin_arms: test_generic_kernel's robots without their control
    law; the quaternions of norm 1 and 1.7 (R(p) written for any non-zero p)."""
    if name in ("ball_on_arm", "twin_arms"):
        text = BALL_ON_ARM[:BALL_ON_ARM.index("controller:")]
        robot = robot_from_text(text.format(both=TWIN if name == "twin_arms" else ""),
                                f"{name}.yaml")
    else:
        robot = spherical_robot(name)
    pl, tables, model, reference = generic_model(robot, kernel)
    nq, n = pl.nq, pl.n
    rng = np.random.default_rng(19)
    for k in range(6):
        x = rng.uniform(-1, 1, nq + n)
        for quaternion in model.quaternions:
            x[list(quaternion)] *= (1.0 if k % 2 else 1.7) / np.linalg.norm(x[list(quaternion)])
        e = model._joint_efforts(0.0, x)
        assert not e.any()
        assert rel(jac(kernel, tables, x, e), reference.jacobian(0.0, x)) < 1e-12


def locked_panda():
    """(pinocchio, anadyn's Panda with the fingers locked at 0, its plan, Pinocchio's
    model reduced the same way and its data)."""
    pin, _, _, _, _, model, _ = pinocchio_pair("panda")
    from test_generic_kernel import URDFS

    robot = urdf_robot(URDFS["panda"], lock={"panda_finger_joint1": 0})
    fingers = [model.getJointId(j) for j in ("panda_finger_joint1", "panda_finger_joint2")]
    model = pin.buildReducedModel(model, fingers, pin.neutral(model))
    model.gravity.linear = np.array(recursive.plan(robot).gravity)
    return pin, robot, recursive.plan(robot), model, model.createData()


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_jacobian_matches_pinocchios_aba_derivatives(name, kernel):  # noqa: F811
    if name == "ur5":
        pin, _, pl, _, _, model, data = pinocchio_pair(name)
    else:
        pin, _, pl, model, data = locked_panda()
    tables, why = generic.pack(pl)
    assert tables is not None, why
    assert tables.mode == generic.tables.IDENTITY and model.nv == pl.n
    n, (_, c) = pl.n, generic.tables.affine_map(pl)
    index = [model.joints[model.frames[model.getFrameId(pl.bodies[b].name)].parentJoint].idx_v
             for b in pl.moving]                      # anadyn's moving joint -> Pinocchio's
    ix = np.ix_(index, index)
    rng = np.random.default_rng(23)
    for _ in range(10):
        q, dq, e = (rng.uniform(-1.5, 1.5, n) for _ in range(3))
        theta = q + c
        qp, vp, ep = np.empty(n), np.empty(n), np.empty(n)
        qp[index], vp[index], ep[index] = theta, dq, e + passive(pl, theta, dq)
        a_q, a_v, a_tau = (np.asarray(v)
                           for v in pin.computeABADerivatives(model, data, qp, vp, ep))
        Minv = np.triu(a_tau) + np.triu(a_tau, 1).T
        p_theta, p_rate = passive_derivatives(pl, dq)
        J = jac(kernel, tables, np.concatenate([q, dq]), e)
        assert rel(J[n:, :n], a_q[ix] + Minv[ix] @ p_theta) < 1e-10
        assert rel(J[n:, n:], a_v[ix] + Minv[ix] @ p_rate) < 1e-10
