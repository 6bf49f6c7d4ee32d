"""One-state calls of ``anadyn.derivatives`` through the C (issue 26's speed):

- the extension's one-state functions (``one_forward``, ``one_inverse``,
  ``one_dynamics``) take float64 vectors and give fresh arrays equal to the batched
  kernel's row; anything else (lists, other dtypes, views, wrong shapes, a time
  array) is left to the general path, which converts or refuses it as before;
- a failing state raises LinAlgError from either path;
- the solves over the structural nonzeros of M's factor (a tree's branches) on a
  tree with two branches from the ground and two siblings on a hub (fill-in):
  the C against the generated Python (NumPy's LAPACK) and central differences.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import anadyn
from anadyn_cli import robot_from_text
from anadyn_cli.numeric import native as cc
from anadyn_cli.numeric.derivatives import generate
from anadyn_cli.numeric.recursive.derivatives import _factor_pattern

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_generic_kernel import rel  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.skipif(cc.unavailable() is not None, reason="no C compiler")

#: two bodies on the ground (a, b), a hub (c) carrying two siblings (d, e)
TREE = """
name: tree
gravity: [0, 0, -9.81]
coordinates: {a: {initial: 0}, b: {initial: 0}, c: {initial: 0}, d: {initial: 0},
              e: {initial: 0}}
bodies:
  - name: left1
    joint: {type: revolute, axis: [0, 0, 1], origin: [0, 0.2, 0], displacement: a}
    mass: 1.5
    com: [0.2, 0.02, 0]
    inertia: {ixx: 0.02, iyy: 0.025, izz: 0.015, ixy: 0.002}
  - name: left2
    parent: left1
    joint: {type: revolute, axis: [0, 0.6, 0.8], origin: [0.4, 0, 0], displacement: b}
    mass: 1.0
    com: [0.15, 0.05, 0.02]
    inertia: {ixx: 0.01, iyy: 0.01, izz: 0.004}
  - name: hub
    joint: {type: revolute, axis: [0, 0, 1], origin: [0, -0.2, 0], displacement: c}
    mass: 2.0
    com: [0.05, 0.01, 0.1]
    inertia: {ixx: 0.03, iyy: 0.03, izz: 0.02}
  - name: arm1
    parent: hub
    joint: {type: revolute, axis: [0, 0, 1], origin: [0.3, 0, 0.1], displacement: d}
    mass: 0.8
    com: [0.2, 0.01, 0]
    inertia: {ixx: 0.002, iyy: 0.01, izz: 0.01, ixz: 0.001}
  - name: arm2
    parent: hub
    joint: {type: prismatic, axis: [0, 1, 0], origin: [-0.3, 0, 0.1], displacement: e}
    mass: 0.5
    com: [0.02, 0, 0.05]
    inertia: {ixx: 0.001, iyy: 0.002, izz: 0.002}
actuators:
  Ta: {joint: left1}
  Tc: {joint: hub}
  Fe: {joint: arm2}
"""


def built(robot, monkeypatch):
    monkeypatch.setenv("ANADYN_NATIVE", "wait")           # compiled now
    d = anadyn.derivatives(robot)
    assert d.native is not None, d.note
    return d


@pytest.fixture
def rrt(monkeypatch):
    return built(ROOT / "robots/rrt.yaml", monkeypatch)


def state(d, seed=3):
    rng = np.random.default_rng(seed)
    return (rng.uniform(-1, 1, d.n), rng.uniform(-1, 1, d.n), rng.uniform(-1, 1, d.m),
            rng.uniform(-1, 1, d.n))


def test_one_state_calls_are_the_batched_kernel_in_fresh_arrays(rrt):
    d = rrt
    n, m = d.n, d.m
    q, dq, tau, ddq = state(d)
    forward = d.forward_derivatives(0.25, q, dq, tau)
    assert d.native.one_forward(0.25, q, dq, tau) is not None       # the C's own path
    row = np.empty((1, n * (2 * n + m)))
    assert d.native.forward(1, 0.25, q, dq, tau, row) == -1
    row = row.reshape(n, 2 * n + m)
    for got, want, shape in zip(forward, (row[:, :n], row[:, n:2 * n], row[:, 2 * n:]),
                                ((n, n), (n, n), (n, m))):
        assert got.shape == shape and got.dtype == np.float64
        assert got.flags.c_contiguous and got.flags.owndata and got.flags.writeable
        assert np.array_equal(got, want)
    inverse = d.inverse_derivatives(0.25, q, dq, ddq)
    row = np.empty((1, 3 * n * n))
    assert d.native.inverse(1, 0.25, q, dq, ddq, row) == -1
    for got, want in zip(inverse, row.reshape(3, n, n)):
        assert got.shape == (n, n) and got.flags.owndata and np.array_equal(got, want)
    acc = d.forward_dynamics(0.25, q, dq, tau)
    row = np.empty((1, n))
    assert d.native.dynamics(1, 0.25, q, dq, tau, row) == -1
    assert acc.shape == (n,) and acc.flags.owndata and np.array_equal(acc, row[0])
    # fresh: a later call does not write into an earlier result
    kept = [a.copy() for a in forward]
    forward[0][:] = 7.0
    again = d.forward_derivatives(0.25, q + 0.1, dq, tau)
    assert not any(np.shares_memory(a, b) for a in again for b in forward)
    assert np.array_equal(d.forward_derivatives(0.25, q, dq, tau)[0], kept[0])


@pytest.mark.parametrize("how", ["lists", "float32", "ints", "strided", "numpy time",
                                 "time array", "int time"])
def test_other_arguments_take_the_general_path(how, rrt):
    d = rrt
    q, dq, tau, ddq = state(d)
    t = 0.5
    want_f, want_i = d.forward_derivatives(t, q, dq, tau), d.inverse_derivatives(t, q, dq, ddq)
    if how == "lists":
        args = (t, list(q), list(dq), list(tau)), (t, list(q), list(dq), list(ddq))
    elif how == "float32":
        q, dq, tau, ddq = (x.astype(np.float32) for x in (q, dq, tau, ddq))
        want_f = d.forward_derivatives(t, *(x.astype(float) for x in (q, dq, tau)))
        want_i = d.inverse_derivatives(t, *(x.astype(float) for x in (q, dq, ddq)))
        args = (t, q, dq, tau), (t, q, dq, ddq)
    elif how == "ints":
        q = np.array([1, 0, -1])
        want_f = d.forward_derivatives(t, q.astype(float), dq, tau)
        want_i = d.inverse_derivatives(t, q.astype(float), dq, ddq)
        args = (t, q, dq, tau), (t, q, dq, ddq)
    elif how == "strided":
        wide = np.repeat(q, 2)
        args = (t, wide[::2], dq, tau), (t, wide[::2], dq, ddq)
    elif how == "numpy time":
        args = (np.float64(t), q, dq, tau), (np.float64(t), q, dq, ddq)
    elif how == "time array":
        args = (np.array([t]), q, dq, tau), (np.array([t]), q, dq, ddq)
    else:
        want_f, want_i = d.forward_derivatives(1.0, q, dq, tau), d.inverse_derivatives(1.0, q, dq,
                                                                                      ddq)
        args = (1, q, dq, tau), (1, q, dq, ddq)
    for got, want in zip(d.forward_derivatives(*args[0]), want_f):
        assert np.array_equal(got, want)
    for got, want in zip(d.inverse_derivatives(*args[1]), want_i):
        assert np.array_equal(got, want)


def test_bad_shapes_and_failing_states_from_the_c(rrt):
    d = rrt
    q, dq, tau, _ = state(d)
    assert d.native.one_forward(0.0, q, dq, tau[:2]) is None
    with pytest.raises(anadyn.ModelError, match=r"^tau: shape \(2,\); expected \(3,\) for one "
                                                r"state or \(N, 3\) for N states"):
        d.forward_derivatives(0.0, q, dq, tau[:2])
    with pytest.raises(anadyn.ModelError, match=r"^q: shape \(4,\); expected \(3,\)"):
        d.inverse_derivatives(0.0, np.append(q, 0.0), dq, q)
    bad = q.copy()
    bad[1] = np.nan
    message = r"^mass matrix not positive definite, or a non-finite result, at state 0$"
    for call in (lambda: d.forward_derivatives(0.0, bad, dq, tau),
                 lambda: d.forward_derivatives(0.0, list(bad), dq, tau),
                 lambda: d.inverse_derivatives(0.0, bad, dq, q),
                 lambda: d.forward_dynamics(0.0, bad, dq, tau)):
        with pytest.raises(np.linalg.LinAlgError, match=message):
            call()


def test_factor_pattern_has_the_fill_in():
    # M of TREE: {a, b} one block, c with d and e, d and e siblings (zero) -> fill at (e, d)
    nz = np.zeros((5, 5), dtype=bool)
    for block in ([0, 1], [2, 3], [2, 4]):
        nz[np.ix_(block, block)] = True
    lines = _factor_pattern(nz.tolist())
    assert lines == ["static const int LOWER_START[N + 1] = {0, 0, 1, 1, 2, 4};",
                     "static const int LOWER[4] = {0, 2, 2, 3};",
                     "static const int UPPER_START[N + 1] = {0, 1, 1, 3, 4, 4};",
                     "static const int UPPER[4] = {1, 3, 4, 4};"]
    assert _factor_pattern([[True]]) == ["static const int LOWER_START[N + 1] = {0, 0};",
                                         "static const int LOWER[1] = {0};",
                                         "static const int UPPER_START[N + 1] = {0, 0};",
                                         "static const int UPPER[1] = {0};"]


def test_tree_derivatives_over_the_sparse_factor(monkeypatch):
    robot = robot_from_text(TREE, "tree.yaml")
    d = built(robot, monkeypatch)
    python = anadyn.derivatives(robot, native=False)
    assert "static const int LOWER[4] = {0, 2, 2, 3};" in generate(robot).c()
    rng = np.random.default_rng(8)
    n, h = d.n, 1e-6
    for _ in range(5):
        q, dq, tau, ddq = state(d, rng.integers(1 << 30))
        for got, want in zip(d.forward_derivatives(0.0, q, dq, tau),
                             python.forward_derivatives(0.0, q, dq, tau)):
            assert rel(got, want) < 1e-12
        for got, want in zip(d.inverse_derivatives(0.0, q, dq, ddq),
                             python.inverse_derivatives(0.0, q, dq, ddq)):
            assert rel(got, want) < 1e-12
        assert rel(d.mass_matrix_inverse(q), np.linalg.inv(python.inverse_derivatives(
            0.0, q, dq, ddq)[2])) < 1e-12
        ddq_q = d.forward_derivatives(0.0, q, dq, tau)[0]
        for k in range(n):
            step = np.eye(n)[k] * h
            column = (python.forward_dynamics(0.0, q + step, dq, tau)
                      - python.forward_dynamics(0.0, q - step, dq, tau)) / (2 * h)
            assert rel(ddq_q[:, k], column) < 1e-6
