"""Open-loop derivatives of the forward and inverse dynamics (``anadyn.derivatives``):

- against Pinocchio's computeABADerivatives and computeRNEADerivatives on the URDF
  arms (UR5, SO-101, Panda) and example-robot-data's Baxter (17 coordinates, root
  welded), 20 random states each, 1e-9 relative, the C and the Python (Baxter's C
  compiles for ~10 s: slow).  Mimic joints (Panda's and
  Baxter's fingers) are mapped: theta = A q + c, so ID = A^T (RNEA - passive) and
  its derivatives are A^T (.) A; where A is the identity the forward derivatives
  are Pinocchio's ABA derivatives, else -M^-1 dID/dx at the forward accelerations.
  anadyn keeps the URDF's joint damping and friction in F, Pinocchio's algorithms
  do not: their derivatives are added (diagonal, d(passive)/d(theta, dtheta));
- against central differences of anadyn's own forward dynamics on rr and rrt;
- batched calls equal the single-state calls; shapes and bad shapes.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import anadyn
from anadyn_cli.numeric import native as cc

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_generic_kernel import passive, pinocchio_pair, rel  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ["ur5", "so101", "panda", "baxter"]
needs_compiler = cc.unavailable()                # None: C is built


def build(robot, native: bool, monkeypatch):
    """``anadyn.derivatives``, C compiled now (conftest turns background builds off)."""
    if native:
        monkeypatch.setenv("ANADYN_NATIVE", "wait")
    return anadyn.derivatives(robot, native=native)


def passive_derivatives(pl, dtheta):
    """d(passive)/d(theta) and d(passive)/d(dtheta), diagonal (``passive``'s terms)."""
    bodies = [pl.bodies[b] for b in pl.moving]
    d_theta = np.diag([-p.stiffness for p in bodies])
    d_rate = np.diag([-p.damping - (p.friction / p.friction_velocity
                                    * (1 - np.tanh(r / p.friction_velocity) ** 2)
                                    if p.friction else 0.0) for p, r in zip(bodies, dtheta)])
    return d_theta, d_rate


@pytest.mark.parametrize("name, native", [
    *[pytest.param(name, native, id=f"{name}-{'C' if native else 'Python'}",
                   marks=[pytest.mark.slow] if (name, native) == ("baxter", True) else [])
      for name in ROBOTS for native in (True, False)]])
def test_derivatives_match_pinocchio(name, native, monkeypatch):
    pin, robot, pl, A, c, model, data = pinocchio_pair(name)  # theta = A q + c
    n, nm, m = pl.n, len(pl.moving), len(pl.actuator_joint)
    identity = A.shape == (nm, n) and np.array_equal(A, np.eye(n)) and nm == n

    def joint_of(body):
        frame = model.frames[model.getFrameId(pl.bodies[body].name)]
        return model.joints[getattr(frame, "parentJoint", None) or frame.parent].idx_v

    index = [joint_of(b) for b in pl.moving]
    B = A[pl.actuator_joint, :].T                     # d(theta_j)/dq of actuator k's joint j
    d = build(robot, native, monkeypatch)
    assert (d.n, d.m) == (n, m)
    assert (d.native is not None) == (native and needs_compiler is None), d.note
    rng = np.random.default_rng(11)
    for _ in range(20):
        q, dq, ddq = (rng.uniform(-1.5, 1.5, n) for _ in range(3))
        tau = rng.uniform(-1.5, 1.5, m)
        theta, rate = A @ q + c, A @ dq
        qp, vp, ap = (np.empty(nm) for _ in range(3))
        qp[index], vp[index] = theta, rate
        pas = passive(pl, theta, rate)
        p_theta, p_rate = passive_derivatives(pl, rate)
        ix = np.ix_(index, index)

        # inverse dynamics: ID = A^T (RNEA(theta, A dq, A ddq) - passive)
        ap[index] = A @ ddq
        r_q, r_v, r_a = (np.asarray(x) for x in pin.computeRNEADerivatives(model, data, qp, vp, ap))
        Mp = np.triu(r_a) + np.triu(r_a, 1).T
        want = (A.T @ (r_q[ix] - p_theta) @ A, A.T @ (r_v[ix] - p_rate) @ A, A.T @ Mp[ix] @ A)
        got = d.inverse_derivatives(0.0, q, dq, ddq)
        for g, w in zip(got, want):
            assert g.shape == (n, n)
            assert rel(g, w) < 1e-9

        # forward dynamics with the efforts tau given
        M = want[2]
        if identity:
            ep = np.empty(nm)
            ep[index] = B @ tau + pas
            a_q, a_v, a_tau = (np.asarray(x) for x in
                               pin.computeABADerivatives(model, data, qp, vp, ep))
            Minv = np.triu(a_tau) + np.triu(a_tau, 1).T
            want = (a_q[ix] + Minv[ix] @ p_theta, a_v[ix] + Minv[ix] @ p_rate, Minv[ix] @ B)
        else:                                         # M ddq = A^T (B_theta tau + passive - bias)
            bias = pin.rnea(model, data, qp, vp, np.zeros(nm))[index]
            acc = np.linalg.solve(M, B @ tau + A.T @ (pas - bias))
            ap[index] = A @ acc
            r_q, r_v, _ = (np.asarray(x) for x in
                           pin.computeRNEADerivatives(model, data, qp, vp, ap))
            want = (-np.linalg.solve(M, A.T @ (r_q[ix] - p_theta) @ A),
                    -np.linalg.solve(M, A.T @ (r_v[ix] - p_rate) @ A), np.linalg.solve(M, B))
        got = d.forward_derivatives(0.0, q, dq, tau)
        for g, w, shape in zip(got, want, [(n, n), (n, n), (n, m)]):
            assert g.shape == shape
            assert rel(g, w) < 1e-9
        assert rel(d.mass_matrix_inverse(q), np.linalg.inv(M)) < 1e-9


def central(f, x, h=1e-6):
    """d f / d x by central differences, one column per component of x."""
    cols = []
    for k in range(len(x)):
        step = np.zeros(len(x))
        step[k] = h
        cols.append((f(x + step) - f(x - step)) / (2 * h))
    return np.array(cols).T


@pytest.mark.parametrize("native", [True, False], ids=["C", "Python"])
@pytest.mark.parametrize("path", ["robots/rr.yaml", "robots/rrt.yaml", "robots/rrt_friction.yaml"])
def test_forward_derivatives_match_central_differences(path, native, monkeypatch):
    robot = anadyn.load(ROOT / path)
    model = anadyn.numeric_model(robot, evaluator="recursive")
    d = build(robot, native, monkeypatch)
    n, m = d.n, d.m
    rng = np.random.default_rng(3)
    for _ in range(5):
        t = float(rng.uniform(0, 2))
        q, dq, tau = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, m)

        def acc(x):
            return model.driven_accelerations(t, x[:2 * n], x[2 * n:])

        want = central(acc, np.concatenate([q, dq, tau]))
        got = np.hstack(d.forward_derivatives(t, q, dq, tau))
        assert np.abs(got - want).max() < 1e-6 * max(1.0, np.abs(want).max())

        def inverse(x):
            return model.demand(t, x[:n], x[n:2 * n], x[2 * n:])[0]     # M ddq - F

        ddq = rng.uniform(-1, 1, n)
        want = central(inverse, np.concatenate([q, dq, ddq]))
        got = np.hstack(d.inverse_derivatives(t, q, dq, ddq))
        assert np.abs(got - want).max() < 1e-6 * max(1.0, np.abs(want).max())


@pytest.mark.parametrize("native", [True, False], ids=["C", "Python"])
def test_batched_calls_equal_single_calls(native, monkeypatch):
    d = build(ROOT / "robots/rrt.yaml", native, monkeypatch)
    python = anadyn.derivatives(ROOT / "robots/rrt.yaml", native=False)
    n, m = d.n, d.m
    rng = np.random.default_rng(5)
    N = 7
    t, q, dq, tau = (rng.uniform(-1, 1, N), rng.uniform(-1, 1, (N, n)),
                     rng.uniform(-1, 1, (N, n)), rng.uniform(-1, 1, (N, m)))
    batch = d.forward_derivatives(t, q, dq, tau)
    assert [x.shape for x in batch] == [(N, n, n), (N, n, n), (N, n, m)]
    for b, p in zip(batch, python.forward_derivatives(t, q, dq, tau)):   # C against Python
        assert rel(b, p) < 1e-12
    acc = d.forward_dynamics(t, q, dq, tau)
    assert acc.shape == (N, n)
    inv = d.mass_matrix_inverse(q)
    ib = d.inverse_derivatives(t, q, dq, tau[:, :n] if m >= n else q)
    for k in range(N):
        for b, s in zip(batch, d.forward_derivatives(t[k], q[k], dq[k], tau[k])):
            assert rel(b[k], s) < 1e-13
        assert rel(inv[k], d.mass_matrix_inverse(q[k])) < 1e-13
        assert rel(acc[k], d.forward_dynamics(t[k], q[k], dq[k], tau[k])) < 1e-13
        single = d.inverse_derivatives(t[k], q[k], dq[k], tau[k, :n] if m >= n else q[k])
        for b, s in zip(ib, single):
            assert rel(b[k], s) < 1e-13


def test_bad_shapes_are_one_line_errors():
    d = anadyn.derivatives(ROOT / "robots/rr.yaml", native=False)
    with pytest.raises(anadyn.ModelError, match=r"^tau: shape \(3,\); expected \(2,\) for one "
                                                r"state or \(N, 2\) for N states"):
        d.forward_derivatives(0.0, np.zeros(2), np.zeros(2), np.zeros(3))
    with pytest.raises(anadyn.ModelError, match=r"^dq: shape \(4, 2\)"):
        d.inverse_derivatives(0.0, np.zeros((3, 2)), np.zeros((4, 2)), np.zeros((3, 2)))


def test_closed_chains_are_refused():
    with pytest.raises(anadyn.ModelError, match="derivatives need an open tree"):
        anadyn.derivatives(ROOT / "robots/fourbar.yaml")
