"""The analytic RNEA derivatives (``recursive.rnea_derivatives``, Carpentier and
Mansard 2018) against the forward-mode differentiation of the traced RNEA
(``derivatives.trace_forward_mode_jacobian``), M and K = -dID/d[q, dq, e] at fixed
ddq, 1e-13 relative at random states, in every choice of axes, on chains and trees,
revolute and prismatic joints, mimic joints (theta = A q + c), springs, dampers,
friction and geared drives; what they do not cover falls back to forward mode; the
open-loop Jacobian is the cheapest.  (Against Pinocchio: tests/test_derivatives.py,
which runs whichever ``trace_open_loop_jacobian`` picks: the analytic one on the
URDF arms.)
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

import anadyn
from anadyn_cli import robot_from_text
from anadyn_cli.model.urdf import import_file
from anadyn_cli.numeric import recursive
from anadyn_cli.numeric.ir import Ex, Program
from anadyn_cli.numeric.model import run_generated
from anadyn_cli.numeric.recursive import derivatives as traced, rnea_derivatives
from anadyn_cli.numeric.recursive.trace import _finish
from anadyn_cli.numeric.recursive.tracer import Tracer

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_generic_kernel import URDFS, erd, rel  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def function(tr):
    """The generated Python function of a ``Traced``."""
    source = recursive.PY_HEADER + "\n".join(recursive._python_function(tr, False, ""))
    return run_generated(source)[tr.name]


def robot_of(name: str):
    """A robot file of the repository, or a URDF (root welded); the loads of
    rrt_friction removed (``no loads``)."""
    if name in URDFS or name == "solo12":
        path = URDFS.get(name) or erd("solo_description/robots/solo12.urdf")
        if path is None or not path.exists():
            pytest.skip(f"{name}: URDF not installed")
        return robot_from_text(import_file(path, fix_base=True).text, path.name)
    robot = anadyn.load(ROOT / name.removesuffix(" no loads"))
    return dataclasses.replace(robot, loads=()) if name.endswith("no loads") else robot


def analytic(pl, depth):
    """M and K by ``rnea_derivatives.jacobian`` in the axes ``depth`` joints below each
    group's first body (None: the world's)."""
    P = Program()
    with P:
        M, K = rnea_derivatives.jacobian(Tracer(pl, P), [Ex.atom(f"_w{k}") for k in range(pl.n)],
                                         depth)
    return _finish("open_loop_jacobian", traced._args(pl), P, {"M": M, "K": K})


@pytest.mark.parametrize("name", [
    "robots/rr.yaml", "robots/rrt.yaml",                      # chains, a prismatic joint
    "robots/drives/rr_drives.yaml",        # q2 - q1, geared drives, rotors, motor friction
    "robots/rrt_friction.yaml no loads",   # springs, dampers, friction
    "tests/data/urdf/anadyn_features.urdf",  # a tree, fixed joints, a chain of mimics
    "tests/data/mjcf/gymnasium/half_cheetah.xml",  # planar root (slides), stiff joints
    "ur5", "panda",                        # the Panda with its mimic fingers (n = 8)
    "solo12"])                             # four legs: four groups
def test_analytic_equals_forward_mode(name):
    """In every choice of axes (world, each group's first body, one and two joints
    below), M and K equal the forward mode's (M: the CRBA's); the open-loop Jacobian
    is the cheapest of them."""
    pl = recursive.plan(robot_of(name))
    assert rnea_derivatives.covered(pl)
    forward = traced.trace_forward_mode_jacobian(pl)
    f = function(forward)
    n, m = pl.n, len(pl.actuator_joint)
    rng = np.random.default_rng(23)
    states = [list(rng.uniform(-1.5, 1.5, 1 + pl.nq + 2 * n + m)) for _ in range(4)]
    want = [f(*x) for x in states]
    costs = [forward.counts.total]
    for depth in (None, 0, 1, 2):
        tr = analytic(pl, depth)
        costs.append(tr.counts.total)
        a = function(tr)
        for x, (M1, K1) in zip(states, want):
            M2, K2 = a(*x)
            assert K2.shape == K1.shape == (n, 2 * n + m)
            assert rel(K2, K1) < 1e-13, depth
            assert rel(M2, M1) < 1e-13, depth
    assert traced.trace_open_loop_jacobian(pl).counts.total == min(costs)


def test_what_is_not_covered_falls_back_to_forward_mode():
    """Loads (rrt_friction), spherical joints and a displacement not affine in the
    coordinates (rr's second joint turned by q2 - q1 + 0.1 q1^2): forward mode."""
    text = (ROOT / "robots/rr.yaml").read_text()
    assert text.count("displacement: q2 - q1") == 1
    curved = robot_from_text(text.replace("displacement: q2 - q1",
                                          "displacement: q2 - q1 + 0.1*q1**2"), "rr.yaml")
    for robot in (anadyn.load(ROOT / "robots/rrt_friction.yaml"),
                  anadyn.load(ROOT / "robots/spherical_pendulum.yaml"), curved):
        pl = recursive.plan(robot)
        assert not rnea_derivatives.covered(pl)
        assert traced.trace_analytic_jacobian(pl) is None
    assert rnea_derivatives.covered(recursive.plan(anadyn.load(ROOT / "robots/rr.yaml")))
    pl = recursive.plan(anadyn.load(ROOT / "robots/rrt_friction.yaml"))
    assert (traced.trace_open_loop_jacobian(pl).statements
            == traced.trace_forward_mode_jacobian(pl).statements)


def test_panda_takes_the_analytic_derivatives():
    """On the Panda (n = 8) the analytic K and M cost fewer operations (measured
    5,572 multiplications and additions against 12,510), so the generated code is
    them."""
    pl = recursive.plan(robot_of("panda"))
    analytic = traced.trace_analytic_jacobian(pl)
    forward = traced.trace_forward_mode_jacobian(pl)
    assert analytic.counts.total < 0.5 * forward.counts.total
    assert traced.trace_open_loop_jacobian(pl).statements == analytic.statements
