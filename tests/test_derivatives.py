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


# derivatives with respect to the robot file's parameters ----------------------------

#: UR5 numbers of the import made parameters: (name, text in the import, its
#: replacement, how Pinocchio's model changes with the value)
UR5_PARAMETERS = [
    ("m_upper", "mass: 8.393", "mass: m_upper", 8.393),
    ("L_fore", "origin: [0, -0.1197, 0.425]", "origin: [0, -0.1197, L_fore]", 0.425),
    ("c_fore", "com: [0, 0, 0.25]", "com: [0, 0, c_fore]", 0.25),
    ("I_fore", "ixx: 0.049443313556", "ixx: I_fore", 0.049443313556),
    ("g", "gravity: [0, 0, -9.81]", "gravity: [0, 0, -g]", 9.81)]


def ur5_with_parameters(pin, model, name, value):
    """A copy of Pinocchio's UR5 with the parameter ``name`` set to ``value``."""
    model = model.copy()
    joint = {"m_upper": "shoulder_lift_joint", "L_fore": "elbow_joint", "c_fore": "elbow_joint",
             "I_fore": "elbow_joint"}.get(name)
    j = model.getJointId(joint) if joint else None
    if name == "L_fore":
        model.jointPlacements[j].translation = np.array([0, -0.1197, value])
    elif name == "g":
        model.gravity.linear = np.array([0, 0, -value])
    else:
        inertia = model.inertias[j]
        mass, lever, I = inertia.mass, inertia.lever.copy(), inertia.inertia.copy()
        if name == "m_upper":
            mass = value
        elif name == "c_fore":
            lever[2] = value
        else:
            I[0, 0] = value
        model.inertias[j] = pin.Inertia(mass, lever, I)
    return model


@pytest.mark.parametrize("native", [True, False], ids=["C", "Python"])
def test_parameter_derivatives_match_pinocchio_central_differences(native, monkeypatch):
    """d(ddq)/dp and d(ID)/dp against central differences (step h = 1e-5 max(p, 1)) of
    Pinocchio's ABA and RNEA with a mass, a joint placement (a link length), a centre of
    mass, an inertia and gravity changed in Pinocchio's UR5: truncation ~h^2 |f'''| / 6
    and rounding ~1e-16 |f| / h stay near 1e-9 of the derivatives or below (measured
    2e-11 to 7e-9 over 10 states); asserted at 1e-7."""
    from anadyn_cli import robot_from_text
    from anadyn_cli.model.urdf import import_file

    pin, _, pl, A, c, model, data = pinocchio_pair("ur5")
    assert np.array_equal(A, np.eye(pl.n)) and not c.any()
    text = import_file(ROOT / "robots/ur5.urdf", fix_base=True).text
    values = {}
    for name, old, new, value in UR5_PARAMETERS:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
        values[name] = value
    text = text.replace("\nname: ur5\n", "\nname: ur5\nparameters: {" + ", ".join(
        f"{k}: {v}" for k, v in values.items()) + "}\n")
    robot = robot_from_text(text, "ur5_parameters.yaml")
    if native:
        monkeypatch.setenv("ANADYN_NATIVE", "wait")
    d = anadyn.derivatives(robot, native=native, parameters=list(values))
    if native:
        assert (d.native is not None) == (needs_compiler is None), d.note
    index = [model.joints[model.getJointId(name)].idx_v for name in pl.coordinates]
    assert index == list(range(pl.n))
    n = pl.n
    rng = np.random.default_rng(13)
    for _ in range(4):
        q, dq, ddq, tau = (rng.uniform(-1.5, 1.5, n) for _ in range(4))
        pas = passive(pl, q, dq)
        want_f, want_i = [], []
        for name, value in values.items():
            h = 1e-5 * max(value, 1.0)
            plus, minus = (ur5_with_parameters(pin, model, name, value + s) for s in (h, -h))
            want_f.append((pin.aba(plus, plus.createData(), q, dq, tau + pas)
                           - pin.aba(minus, minus.createData(), q, dq, tau + pas)) / (2 * h))
            want_i.append((pin.rnea(plus, plus.createData(), q, dq, ddq)
                           - pin.rnea(minus, minus.createData(), q, dq, ddq)) / (2 * h))
        got_f = d.forward_parameter_derivatives(0.0, q, dq, tau)
        got_i = d.inverse_parameter_derivatives(0.0, q, dq, ddq)
        assert got_f.shape == got_i.shape == (n, len(values))
        for k in range(len(values)):                      # each column on its own scale
            assert rel(got_f[:, k], want_f[k]) < 1e-7, list(values)[k]
            assert rel(got_i[:, k], want_i[k]) < 1e-7, list(values)[k]


@pytest.mark.parametrize("native", [True, False], ids=["C", "Python"])
@pytest.mark.parametrize("path, names", [
    ("robots/rr.yaml", ["m2", "L1", "g", "L2"]),
    ("robots/rrt_friction.yaml", ["m3", "L1", "I3x", "g", "P", "k2"])])
def test_parameter_derivatives_match_central_differences(path, names, native, monkeypatch):
    """Against central differences of anadyn's own forward and inverse dynamics with
    the parameter changed in the robot (the file's expressions re-evaluated: masses,
    lengths in origins, centres of mass and inertias, gravity, a load, a spring),
    step 1e-5 p, 1e-7 relative; batched calls equal single ones."""
    import dataclasses

    import sympy as sp

    robot = anadyn.load(ROOT / path)
    if native:
        monkeypatch.setenv("ANADYN_NATIVE", "wait")
    d = anadyn.derivatives(robot, native=native, parameters=names)
    assert d.parameters == tuple(names)
    n, m = d.n, d.m
    rng = np.random.default_rng(17)
    N = 3
    t, q, dq, ddq, tau = (rng.uniform(0, 2, N), rng.uniform(-1, 1, (N, n)),
                          rng.uniform(-1, 1, (N, n)), rng.uniform(-1, 1, (N, n)),
                          rng.uniform(-1, 1, (N, m)))
    forward, inverse = [], []
    for name in names:
        value = float(robot.parameters[name])
        h = 1e-5 * abs(value)
        runs = []
        for v in (value + h, value - h):
            model = anadyn.numeric_model(dataclasses.replace(
                robot, parameters={**robot.parameters, name: sp.Float(v)}), evaluator="recursive")
            runs.append([(model.driven_accelerations(t[k], np.concatenate([q[k], dq[k]]), tau[k]),
                          model.demand(t[k], q[k], dq[k], ddq[k])[0]) for k in range(N)])
        forward.append([(p[0] - s[0]) / (2 * h) for p, s in zip(*runs)])
        inverse.append([(p[1] - s[1]) / (2 * h) for p, s in zip(*runs)])
    got_f = d.forward_parameter_derivatives(t, q, dq, tau)
    got_i = d.inverse_parameter_derivatives(t, q, dq, ddq)
    assert got_f.shape == got_i.shape == (N, n, len(names))
    for k in range(N):
        assert rel(d.forward_parameter_derivatives(t[k], q[k], dq[k], tau[k]), got_f[k]) < 1e-13
        assert rel(d.inverse_parameter_derivatives(t[k], q[k], dq[k], ddq[k]), got_i[k]) < 1e-13
        for j, name in enumerate(names):
            assert rel(got_f[k, :, j], forward[j][k]) < 1e-7, name
            assert rel(got_i[k, :, j], inverse[j][k]) < 1e-7, name


@pytest.mark.parametrize("native", [True, False], ids=["C", "Python"])
@pytest.mark.parametrize("path, names", [
    ("robots/rr.yaml", ["b01", "g01", "q1f", "m2", "L1", "g"]),
    ("robots/rrt_friction.yaml", ["g12", "b23", "m3", "L2"]),
    ("no controller", ["m2", "L1"])])
def test_closed_loop_parameter_derivatives_match_central_differences(path, names, native,
                                                                      monkeypatch):
    """d(ddq)/dp with the efforts under the file's control laws (gains, and parameters
    that the laws and the dynamics share) against central differences of anadyn's own
    closed-loop right-hand side with the value changed in the robot, step 1e-5 max(p, 1),
    1e-7 relative (measured 5e-12 to 6e-10); open loop, a gain's column is zero; without
    a controller (rr's laws removed) the closed loop is the open loop at tau = 0."""
    import dataclasses

    import sympy as sp

    from anadyn_cli.model.robot import frozen_map

    robot = (anadyn.load(ROOT / path) if path != "no controller" else
             dataclasses.replace(anadyn.load(ROOT / "robots/rr.yaml"), controller=None))
    if native:
        monkeypatch.setenv("ANADYN_NATIVE", "wait")
    d = anadyn.derivatives(robot, native=native, parameters=names)
    n = d.n
    rng = np.random.default_rng(19)
    N = 3
    t, q, dq = rng.uniform(0, 2, N), rng.uniform(-1, 1, (N, n)), rng.uniform(-1, 1, (N, n))
    got = d.closed_loop_parameter_derivatives(t, q, dq)
    assert got.shape == (N, n, len(names))
    gains = robot.controller.gains if robot.controller is not None else {}

    def changed(name, value):
        if name in robot.parameters:
            return dataclasses.replace(robot, parameters={**robot.parameters,
                                                          name: sp.Float(value)})
        return dataclasses.replace(robot, controller=dataclasses.replace(
            robot.controller, gains=frozen_map({**gains, name: sp.Float(value)})))

    for j, name in enumerate(names):
        value = float(robot.parameters[name] if name in robot.parameters else gains[name])
        h = 1e-5 * max(abs(value), 1.0)
        runs = [anadyn.numeric_model(changed(name, value + s), evaluator="recursive")
                for s in (h, -h)]
        for k in range(N):
            x = np.concatenate([q[k], dq[k]])
            want = (runs[0].rhs(t[k], x)[n:] - runs[1].rhs(t[k], x)[n:]) / (2 * h)
            assert rel(got[k, :, j], want) < 1e-7, name
            assert rel(d.closed_loop_parameter_derivatives(t[k], q[k], dq[k]), got[k]) < 1e-13
        if name in gains:
            tau = rng.uniform(-1, 1, (N, d.m))
            assert not d.forward_parameter_derivatives(t, q, dq, tau)[..., j].any()
    if robot.controller is None:
        assert rel(got, d.forward_parameter_derivatives(t, q, dq, np.zeros((N, d.m)))) < 1e-13


@pytest.mark.parametrize("names, message", [
    (["zz"], r"robots/rr\.yaml: parameters: rr has no parameter or gain 'zz'; its "
             r"parameters: L1, L2, g, m1, m2; its gains: b01, b12, g01, g12, q1f, q2f$"),
    (["m2", "m2"], r"robots/rr\.yaml: parameters: a parameter is named twice$")])
def test_bad_parameters_are_one_line_errors(names, message):
    with pytest.raises(anadyn.ModelError, match=message):
        anadyn.derivatives(ROOT / "robots/rr.yaml", native=False, parameters=names)


def test_parameters_where_they_are_not_differentiated_are_refused():
    with pytest.raises(anadyn.ModelError, match=r"parameters: tool enters a load's point on "
                                                r"link3; the parameter derivatives cover"):
        anadyn.derivatives(ROOT / "robots/rrt_friction.yaml", native=False, parameters=["tool"])
    d = anadyn.derivatives(ROOT / "robots/rr.yaml", native=False)
    with pytest.raises(anadyn.ModelError, match=r"^no parameters chosen"):
        d.forward_parameter_derivatives(0.0, np.zeros(2), np.zeros(2), np.zeros(2))


def test_spherical_joints_are_refused():
    with pytest.raises(anadyn.ModelError, match=r"spherical_pendulum\.yaml: derivatives "
                                                r"\(anadyn\.derivatives, export --derivatives\) "
                                                r"of a robot with a spherical joint"):
        anadyn.derivatives(ROOT / "robots/spherical_pendulum.yaml", native=False)
