"""The recursive numeric path (``anadyn_cli.numeric.recursive``, ``native``)
against independent sources:

- the closed forms of Kane's method (``derive``: M, F, B, evaluated by
  ``sympy.lambdify``, and the closed-form generated module) on rr, rrt,
  configs/chain6.yaml and random robots (trees, joint types, axes, rpy,
  coupled displacements, full inertias), to 1e-10 relative;
- Pinocchio's CRBA, RNEA and ABA (test-only; the same robot written as a
  URDF string) to 1e-9;
- joint springs, dampers, friction and external loads against their
  generalized forces computed directly from the symbolic partial velocities
  (``anadyn_cli.symbolic.kinematics``) and J = d(theta)/dq;
- the forward-mode Jacobian against central differences of the residual;
- the C kernels against the generated Python, and the fallback without a compiler.
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from anadyn_cli import derive, load_robot, robot_from_text
from anadyn_cli.numeric import native, recursive
from anadyn_cli.model.robot import Load
from random_robots import random_robot_yaml
from scenes import cubic_text

TOL = 1e-10
REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def repo() -> Path:
    return REPO


def module(robot):
    namespace: dict = {}
    exec(compile(recursive.source(robot), "<test>", "exec"), namespace)  # noqa: S102
    return namespace


def closed_form(robot):
    """M, F, B and tau of Kane's closed forms as NumPy functions of (t, q, dq)."""
    eom = derive(robot, "kane")
    args = (sp.Symbol("t", real=True), *eom.q, *eom.dq)
    from anadyn_cli.numeric.closed_form import control_laws
    f = sp.lambdify(args, [m.evalf(20) for m in (eom.M, eom.F, eom.B, control_laws(robot))],
                    "numpy")

    def mfbt(t, q, dq):
        M, F, B, tau = f(t, *q, *dq)
        return (np.array(M, float), np.array(F, float).ravel(),
                np.array(B, float).reshape(len(q), -1), np.array(tau, float).ravel())
    return mfbt


def rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.size == 0:
        return 0.0
    return float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b))))


def states(n, seed, count=4):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        yield (float(rng.uniform(0, 2)), rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n),
               rng.uniform(-3, 3, n))


def check_against_closed_form(robot, seed=0, count=4):
    ns = module(robot)
    mfbt = closed_form(robot)
    n = len(robot.coordinates)
    checked = 0
    for t, q, dq, ddq in states(n, seed, count):
        M, F, B, tau = mfbt(t, q, dq)
        M1, F1, B1 = ns["mfb"](t, *q, *dq)
        assert rel(M1, M) < TOL and rel(F1, F) < TOL and rel(B1, B) < TOL
        assert rel(ns["inverse_dynamics"](t, *q, *dq, *ddq), M @ ddq - F) < TOL
        assert rel(ns["efforts"](t, *q, *dq), tau) < TOL
        if np.linalg.eigvalsh(M).min() < 1e-9 * max(1.0, np.abs(M).max()):
            continue                      # a degenerate state of a random robot
        expected = np.linalg.solve(M, F + B @ tau)
        assert rel(ns["accelerations"](t, *q, *dq), expected) < 1e-9
        checked += 1
    return checked


@pytest.mark.parametrize("path", ["robots/rr.yaml", "robots/rrt.yaml", "configs/chain6.yaml"])
def test_shipped_robots_match_closed_forms(repo, path):
    robot = load_robot(repo / path)
    assert check_against_closed_form(robot) == 4


@pytest.mark.parametrize("path", ["robots/rr.yaml", "robots/rrt.yaml", "configs/chain6.yaml"])
def test_jacobian_and_potential_match_closed_form_module(repo, path):
    """dynamics_jacobian (M, K) and potential against the closed-form generated module."""
    from anadyn_cli.numeric import closed_form as cf
    robot = load_robot(repo / path)
    ns = module(robot)
    reference: dict = {}
    exec(cf.source(robot, derive(robot, "kane")), reference)  # noqa: S102
    n = len(robot.coordinates)
    for t, q, dq, _ in states(n, 1, 3):
        ddq = np.array(reference["accelerations"](t, *q, *dq))
        M1, K1 = ns["dynamics_jacobian"](t, *q, *dq, *ddq)
        M2, K2 = reference["dynamics_jacobian"](t, *q, *dq, *ddq)
        assert rel(M1, M2) < TOL and rel(K1, K2) < TOL
        assert rel(ns["potential"](*q), reference["potential"](*q)) < TOL


@pytest.mark.parametrize("seed", range(12))
def test_random_robots_match_closed_forms(seed):
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    check_against_closed_form(robot, seed)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(12, 60))
def test_more_random_robots_match_closed_forms(seed):
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    check_against_closed_form(robot, seed)


def test_a_wrong_inertia_is_caught():
    """The comparison fails when the recursive path is given a different robot."""
    robot = robot_from_text(random_robot_yaml(3), "random3.yaml")
    body = robot.bodies[-1]
    heavier = dataclasses.replace(robot, bodies=robot.bodies[:-1] + (
        dataclasses.replace(body, mass=body.mass * 1.001),))
    ns, mfbt = module(heavier), closed_form(robot)
    t, q, dq, _ = next(states(len(robot.coordinates), 0))
    assert rel(ns["mfb"](t, *q, *dq)[0], mfbt(t, q, dq)[0]) > 1e-6


# --------------------------------------------------------------- Pinocchio --

def urdf_of(robot) -> str:
    """The robot as URDF (each displacement must be one coordinate)."""
    def num(e):
        return float(sp.sympify(e).xreplace(robot.parameter_substitution()))

    def xyz(v):
        return " ".join(repr(num(x)) for x in v)

    out = [f'<robot name="{robot.name}">', '  <link name="ground"/>']
    for b in robot.bodies:
        I = [[num(b.inertia[i, j]) for j in range(3)] for i in range(3)]
        out += [f'  <link name="{b.name}"><inertial><origin xyz="{xyz(b.com)}" rpy="0 0 0"/>',
                f'    <mass value="{num(b.mass)}"/>',
                f'    <inertia ixx="{I[0][0]!r}" ixy="{I[0][1]!r}" ixz="{I[0][2]!r}" '
                f'iyy="{I[1][1]!r}" iyz="{I[1][2]!r}" izz="{I[2][2]!r}"/>',
                '  </inertial></link>',
                f'  <joint name="{b.name}" type="{b.joint.type}">',
                f'    <parent link="{b.parent}"/><child link="{b.name}"/>',
                f'    <origin xyz="{xyz(b.joint.origin)}" rpy="{xyz(b.joint.rpy)}"/>']
        if b.joint.type != "fixed":
            out += [f'    <axis xyz="{xyz(b.joint.axis)}"/>',
                    '    <limit lower="-100" upper="100" effort="1" velocity="1"/>']
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out)


def pinocchio_model(robot):
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromXML(urdf_of(robot))
    model.gravity.linear = np.array([float(sp.sympify(g).xreplace(robot.parameter_substitution()))
                                     for g in robot.gravity])
    index = []                 # our coordinate k -> pinocchio's q index
    symbols = [c.symbol for c in robot.coordinates]
    by_symbol = {b.joint.displacement: b.name for b in robot.bodies if b.joint.type != "fixed"}
    for s in symbols:
        index.append(model.joints[model.getJointId(by_symbol[s])].idx_q)
    return pin, model, np.array(index)


def own_coordinates(robot) -> bool:
    """Every moving joint's displacement is one coordinate, and no robot controller."""
    moving = [b.joint.displacement for b in robot.bodies if b.joint.type != "fixed"]
    return (all(isinstance(d, sp.Symbol) for d in moving) and robot.controller is None
            and len(set(moving)) == len(moving))


PIN_SEEDS = [s for s in range(40) if own_coordinates(
    robot_from_text(random_robot_yaml(s), f"random{s}.yaml"))][:14]


@pytest.mark.parametrize("seed", PIN_SEEDS)
def test_random_robots_match_pinocchio(seed):
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    pin, model, index = pinocchio_model(robot)
    data = model.createData()
    ns = module(robot)
    n = len(robot.coordinates)
    for t, q, dq, ddq in states(n, seed):
        qp, vp, ap = np.zeros(model.nq), np.zeros(model.nv), np.zeros(model.nv)
        qp[index], vp[index], ap[index] = q, dq, ddq
        M = pin.crba(model, data, qp)
        M = np.triu(M) + np.triu(M, 1).T
        M1, F1, _ = ns["mfb"](t, *q, *dq)
        assert rel(M1, M[np.ix_(index, index)]) < 1e-9
        tau = pin.rnea(model, data, qp, vp, ap)[index]
        assert rel(ns["inverse_dynamics"](t, *q, *dq, *ddq), tau) < 1e-9
        if np.linalg.eigvalsh(M1).min() > 1e-8:
            a = pin.aba(model, data, qp, vp, np.zeros(model.nv))[index]
            assert rel(ns["accelerations"](t, *q, *dq), a) < 1e-9


def test_chain6_matches_pinocchio(repo):
    robot = load_robot(repo / "configs/chain6.yaml")
    robot = dataclasses.replace(robot, controller=None)
    pin, model, index = pinocchio_model(robot)
    data = model.createData()
    ns = module(robot)
    for t, q, dq, ddq in states(6, 7):
        tau = pin.rnea(model, data, _placed(q, index, model), _placed(dq, index, model),
                       _placed(ddq, index, model))[index]
        assert rel(ns["inverse_dynamics"](t, *q, *dq, *ddq), tau) < 1e-9
        a = pin.aba(model, data, _placed(q, index, model), _placed(dq, index, model),
                    np.zeros(6))[index]
        assert rel(ns["accelerations"](t, *q, *dq), a) < 1e-9


def _placed(values, index, model):
    out = np.zeros(model.nv)
    out[index] = values
    return out


# ------------------------------------------------- joint forces and loads --

def _partials(robot, body_name):
    """World rotation and partial velocities (body axes) of ``body_name`` from the
    symbolic kinematics, as functions of q."""
    from anadyn_cli.symbolic import kinematics
    kin = kinematics.build(robot)
    b = next(kb for kb in kin.bodies if kb.body.name == body_name)
    f = sp.lambdify(kin.q, [b.R, b.W, b.Vo], "numpy")
    return lambda q: [np.array(m, float) for m in f(*q)]


def _with_joint_forces(robot, **values):
    bodies = []
    for k, b in enumerate(robot.bodies):
        if b.joint.type == "fixed":
            bodies.append(b)
            continue
        joint = dataclasses.replace(b.joint, **{key: sp.Float(v * (1 + 0.3 * k))
                                                for key, v in values.items()})
        bodies.append(dataclasses.replace(b, joint=joint))
    return dataclasses.replace(robot, bodies=tuple(bodies))


@pytest.mark.parametrize("seed", [0, 2, 5, 9])
def test_joint_springs_dampers_friction(seed):
    """F gains J^T tau_p, tau_p = -c dtheta - f tanh(dtheta/v) - k (theta - rest);
    V gains sum 1/2 k (theta - rest)^2."""
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    forces = dict(damping=0.7, friction=0.4, friction_velocity=0.05, stiffness=3.0, rest=0.2)
    loaded = _with_joint_forces(robot, **forces)
    plain, ns = module(robot), module(loaded)
    q_syms = [c.symbol for c in robot.coordinates]
    moving = [(k, b) for k, b in enumerate(loaded.bodies) if b.joint.type != "fixed"]
    theta = sp.lambdify(q_syms, [b.joint.displacement for _, b in moving])
    J = sp.lambdify(q_syms, [[sp.diff(b.joint.displacement, s) for s in q_syms]
                             for _, b in moving])
    n = len(q_syms)
    for t, q, dq, _ in states(n, seed, 3):
        th, Jm = np.array(theta(*q), float), np.array(J(*q), float)
        rate = Jm @ dq
        tau_p = np.array([-float(b.joint.damping) * r
                          - float(b.joint.friction) * math.tanh(r / float(b.joint.friction_velocity))
                          - float(b.joint.stiffness) * (x - float(b.joint.rest))
                          for (_, b), r, x in zip(moving, rate, th)])
        F0 = plain["mfb"](t, *q, *dq)[1]
        F1 = ns["mfb"](t, *q, *dq)[1]
        assert rel(F1 - F0, Jm.T @ tau_p) < TOL
        V = sum(0.5 * float(b.joint.stiffness) * (x - float(b.joint.rest)) ** 2
                for (_, b), x in zip(moving, th))
        assert rel(ns["potential"](*q) - plain["potential"](*q), V) < TOL


def _loads(robot):
    """A world-frame force and torque on the last moving body, a body-frame force on the
    first, as expressions of t, q, dq."""
    q = [c.symbol for c in robot.coordinates]
    dq = [c.rate_symbol for c in robot.coordinates]
    t = sp.Symbol("t", real=True)
    moving = [b.name for b in robot.bodies if b.joint.type != "fixed"]
    return (Load(moving[-1], (sp.Float(0.1), sp.Float(-0.2), sp.Float(0.3)),
                 (sp.Float(2.0) * sp.sin(t), -3 * q[0], sp.Float(1.5) + dq[-1]),
                 (sp.Float(0.2), sp.Float(0.0), 0.5 * q[-1]), "world"),
            Load(moving[0], (sp.Float(0.05), sp.Float(0.0), sp.Float(0.0)),
                 (sp.Float(0.0), 4 * sp.cos(q[-1]), sp.Float(0.0)),
                 (sp.Float(0.0), sp.Float(0.0), sp.Float(0.0)), "body"))


def _generalized(robot, load, t, q, dq):
    """Q = (Vo + W x p)^T F_b + W^T T_b, F_b = R^T F (world) or F (body)."""
    R, W, Vo = _partials(robot, load.body)(q)
    env = {sp.Symbol("t", real=True): t}
    env.update({c.symbol: v for c, v in zip(robot.coordinates, q)})
    env.update({c.rate_symbol: v for c, v in zip(robot.coordinates, dq)})
    F = np.array([float(sp.sympify(x).xreplace(env)) for x in load.force])
    T = np.array([float(sp.sympify(x).xreplace(env)) for x in load.torque])
    p = np.array([float(x) for x in load.point])
    if load.frame == "world":
        F, T = R.T @ F, R.T @ T
    Vp = Vo + np.cross(W.T, p).T
    return Vp.T @ F + W.T @ T


@pytest.mark.parametrize("seed", [1, 4, 6, 10])
def test_external_loads(seed):
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    loads = _loads(robot)
    loaded = dataclasses.replace(robot, loads=loads)
    plain, ns = module(robot), module(loaded)
    n = len(robot.coordinates)
    for t, q, dq, ddq in states(n, seed, 3):
        expected = sum(_generalized(robot, ld, t, q, dq) for ld in loads)
        F0, F1 = plain["mfb"](t, *q, *dq)[1], ns["mfb"](t, *q, *dq)[1]
        assert rel(F1 - F0, expected) < TOL
        ID0 = plain["inverse_dynamics"](t, *q, *dq, *ddq)
        assert rel(ns["inverse_dynamics"](t, *q, *dq, *ddq), ID0 - expected) < TOL


TWO_LOADS = """
parameters: {m: 1.2, L: 0.8, g: 9.81}
gravity: [0, -g, 0]
coordinates: {q1: {initial: 0.4}, s: {initial: 0.1}}
bodies:
  - {name: arm, joint: {type: revolute, axis: [0, 0, 1]}, mass: m, com: [L/2, 0, 0],
     inertia: {izz: m*L**2/12, iyy: m*L**2/12}}
  - {name: slider, parent: arm, joint: {type: prismatic, axis: [1, 0, 0], origin: [L, 0, 0]},
     mass: 0.5}
loads:
  - {body: slider, force: [0, -3*sin(2*t), 0]}
  - {body: arm, torque: [0, 0, 0.5*cos(t) - 0.1*dq1]}
"""


def test_two_world_frame_loads_on_one_chain_both_act():
    """Converting the second load's vector once reused the first one's (a memo keyed
    by the id of a freed list), so one of two world-frame loads was lost."""
    assert check_against_closed_form(robot_from_text(TWO_LOADS, "two_loads.yaml")) > 0


@pytest.mark.parametrize("seed", [0, 1, 4, 7])
def test_jacobian_against_central_differences(seed):
    """K = -d(M ddq - F - B tau)/dx at fixed ddq, with springs, friction and loads."""
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    robot = _with_joint_forces(robot, damping=0.5, friction=0.3, friction_velocity=0.5,
                               stiffness=2.0, rest=0.1)
    robot = dataclasses.replace(robot, loads=_loads(robot))
    ns = module(robot)
    n = len(robot.coordinates)

    def residual(t, x, ddq):
        M, F, B = ns["mfb"](t, *x[:n], *x[n:])
        tau = ns["efforts"](t, *x[:n], *x[n:])
        return M @ ddq - F - B @ tau

    for t, q, dq, ddq in states(n, seed, 2):
        x = np.concatenate([q, dq])
        _, K = ns["dynamics_jacobian"](t, *q, *dq, *ddq)
        h = 1e-6
        K_fd = np.column_stack([-(residual(t, x + h * e, ddq) - residual(t, x - h * e, ddq))
                                / (2 * h) for e in np.eye(2 * n)])
        assert rel(K, K_fd) < 1e-7


# -------------------------------------------------------------- contract --

def test_contract_shapes_and_broadcasting(repo):
    robot = load_robot(repo / "robots/rrt.yaml")
    ns = module(robot)
    assert ns["COORDINATES"] == ("q1", "q2", "q3") and len(ns["EFFORTS"]) == 3
    q = [np.linspace(0, 1, 5)[:, None] * np.ones((5, 2)), 0.3, np.full((5, 2), 0.25)]
    dq = [0.1, np.zeros((5, 2)), 0.2]
    M, F, B = ns["mfb"](0.0, *q, *dq)
    assert M.shape == (5, 2, 3, 3) and F.shape == (5, 2, 3) and B.shape == (5, 2, 3, 3)
    assert ns["inverse_dynamics"](np.zeros((5, 2)), *q, *dq, 1.0, 2.0, 3.0).shape == (5, 2, 3)
    assert ns["potential"](*q).shape == (5, 2, 1)
    assert ns["efforts"](0.0, *q, *dq).shape == (5, 2, 3)
    M0, F0, B0 = ns["mfb"](0.0, 0.0, 0.3, 0.25, 0.1, 0.0, 0.2)
    assert rel(M[0, 0], M0) < 1e-15 and rel(F[0, 0], F0) < 1e-15
    assert isinstance(ns["accelerations"](0.0, 0.1, 0.2, 0.3, 0, 0, 0), list)


def test_singular_mass_matrix_raises():
    robot = robot_from_text(cubic_text(0.0), "cubic.yaml")
    ns = module(robot)
    with pytest.raises(np.linalg.LinAlgError):
        ns["accelerations"](0.0, 0.0, 0.0, 0.0, 0.0)
    assert len(ns["accelerations"](0.0, 0.0, 0.5, 0.0, 0.0)) == 2


# -------------------------------------------------------- structure, size --

def chain_text(n: int, planar: bool = False) -> str:
    lines = ["name: chain", "gravity: [0, 0, -9.81]" if not planar else "gravity: [0, -9.81, 0]",
             "coordinates:"] + [f"  q{i + 1}: {{initial: 0.1}}" for i in range(n)] + ["bodies:"]
    for i in range(n):
        axis = "[0, 0, 1]" if planar or i % 2 == 0 else "[0, 1, 0]"
        origin = "[0, 0, 0]" if i == 0 else ("[0.5, 0, 0]" if planar else "[0, 0, 0.5]")
        com = "[0.25, 0, 0]" if planar else "[0, 0, 0.25]"
        lines += [f"  - name: l{i + 1}", f"    parent: {'ground' if i == 0 else f'l{i}'}",
                  f"    joint: {{type: revolute, axis: {axis}, origin: {origin}}}",
                  "    mass: 1", f"    com: {com}",
                  "    inertia: {ixx: 0.02, iyy: 0.021, izz: 0.001}"]
    return "\n".join(lines) + "\n"


def test_operation_counts_grow_linearly_and_planar_scenes_stay_planar():
    counts = {}
    for n in (4, 8, 12, 16):
        gen = recursive.generate(robot_from_text(chain_text(n), f"chain{n}.yaml"))
        counts[n] = {k: gen.counts(k).mul + gen.counts(k).add for k in gen.functions}
        if n == 8:
            spatial_mul = gen.counts("inverse_dynamics").mul
    # inverse dynamics O(n): the same cost per added link (past the first links,
    # whose zero velocities fold away); the mass matrix O(n^2)
    steps = [counts[n + 4]["inverse_dynamics"] - counts[n]["inverse_dynamics"] for n in (4, 8, 12)]
    assert max(steps[1:]) <= 1.02 * min(steps[1:]) and steps[0] <= steps[1]
    assert counts[16]["mfb"] / counts[8]["mfb"] < 4.0
    planar = recursive.generate(robot_from_text(chain_text(8, planar=True), "planar.yaml"))
    assert planar.counts("inverse_dynamics").mul < 0.5 * spatial_mul


def test_branches_do_not_couple():
    """Two arms on one base: their mass-matrix block is zero in the code and the
    factor has no fill-in (leaves eliminated first)."""
    text = chain_text(1) + "".join(
        f"  - name: {arm}{k}\n    parent: {'l1' if k == 1 else f'{arm}{k - 1}'}\n"
        f"    joint: {{type: revolute, axis: [0, 1, 0], origin: [0, 0, 0.5], displacement: {arm}q{k}}}\n"
        "    mass: 1\n    com: [0, 0, 0.25]\n    inertia: {ixx: 0.02, iyy: 0.02, izz: 0.001}\n"
        for arm in "ab" for k in (1, 2))
    text = text.replace("bodies:", "  aq1: {}\n  aq2: {}\n  bq1: {}\n  bq2: {}\nbodies:")
    robot = robot_from_text(text, "twoarms.yaml")
    gen = recursive.generate(robot)
    M = gen.functions["mfb"].outputs["M"]
    names = [c.name for c in robot.coordinates]
    a, b = names.index("aq1"), names.index("bq2")
    assert M[a][b].is_zero() and M[names.index("aq2")][names.index("bq1")].is_zero()
    n = len(names)
    nonzero_lower = sum(1 for i in range(n) for j in range(i) if not M[i][j].is_zero())
    assert len(gen.factor.L) == nonzero_lower          # no fill-in


# ------------------------------------------------------------------ native --

needs_compiler = pytest.mark.skipif(native.unavailable() is not None,
                                    reason=f"native code: {native.unavailable()}")


@needs_compiler
@pytest.mark.parametrize("text_of", ["rrt", "chain6", "random5", "cubic"])
def test_native_kernels_match_generated_python(repo, tmp_path, monkeypatch, text_of):
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric.model import NumericModel
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("ANADYN_NATIVE")          # conftest turns native code off elsewhere
    robot = {"rrt": lambda: load_robot(repo / "robots/rrt.yaml"),
             "chain6": lambda: load_robot(repo / "configs/chain6.yaml"),
             "random5": lambda: robot_from_text(random_robot_yaml(5), "r5.yaml"),
             "cubic": lambda: robot_from_text(cubic_text(0.4), "cubic.yaml")}[text_of]()
    gen = recursive.generate(robot)
    code, c_text = recursive.module_source(gen), native.c_source(gen)
    info = RobotInfo.from_robot(robot)
    fast = native.recursive_model(info, code, c_text, how="wait")
    assert isinstance(fast, native.NativeModel), fast.native_note
    slow = native.RecursiveModel(info, code, "recursive")
    closed = NumericModel(info, code, "recursive")       # numpy.linalg.solve(M, K)
    n = slow.n
    for t, q, dq, _ in states(n, 3, 3):
        x = np.concatenate([q, dq])
        if text_of == "cubic" or np.linalg.cond(slow.mfb(t, q[:, None], dq[:, None])[0][0]) < 1e8:
            assert rel(slow.jacobian(t, x), closed.jacobian(t, x)) < 1e-10
        # the same bits in C and in Python: a run does not depend on the build
        assert np.array_equal(fast.rhs(t, x), slow.rhs(t, x))
        assert np.array_equal(fast.jacobian(t, x), slow.jacobian(t, x))
        assert fast.accelerations(t, x) == slow.accelerations(t, x)
        # the round trip's direct dynamics under given efforts: C and Python to the
        # bit, and M^-1 (F + B e) from the vectorized M, F, B
        e = np.linspace(-1.0, 2.0, len(info.actuators))
        driven = fast.driven_accelerations(t, x, e)
        assert np.array_equal(driven, slow.driven_accelerations(t, x, e))
        if text_of == "cubic" or np.linalg.cond(slow.mfb(t, q[:, None], dq[:, None])[0][0]) < 1e8:
            assert rel(driven, NumericModel.driven_accelerations(slow, t, x, e)) < 1e-10
    # inverse dynamics over many points in C against the vectorized Python (NumPy's
    # sin and cos may differ from the C library's in the last bit on some machines)
    rng = np.random.default_rng(5)
    t, q, dq, ddq = rng.uniform(0, 1, 50), *(rng.uniform(-1, 1, (n, 50)) for _ in range(3))
    (D_c, B_c), (D_py, B_py) = fast.demand(t, q, dq, ddq), slow.demand(t, q, dq, ddq)
    assert D_c.shape == D_py.shape == (50, n) and rel(D_c, D_py) < 1e-14
    assert np.array_equal(B_c, B_py)
    D_one, _ = fast.demand(0.3, q[:, 0], dq[:, 0], ddq[:, 0])    # one point, scalars
    assert D_one.shape == (n,) and rel(D_one, slow.demand(0.3, q[:, 0], dq[:, 0],
                                                          ddq[:, 0])[0]) < 1e-14
    again = native.recursive_model(info, code, c_text)          # cached library
    assert again.native_note == "native C (cached)"
    if text_of == "cubic":
        x = np.zeros(4)
        with pytest.raises(np.linalg.LinAlgError):
            fast.rhs(0.0, x)
        with pytest.raises(np.linalg.LinAlgError):
            fast.jacobian(0.0, x)


def test_without_a_compiler_the_generated_python_runs(tmp_path, monkeypatch, repo):
    from anadyn_cli.model.info import RobotInfo
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(native.builder, "compiler", lambda: None)
    robot = load_robot(repo / "robots/rr.yaml")
    gen = recursive.generate(robot)
    model = native.recursive_model(RobotInfo.from_robot(robot), recursive.module_source(gen),
                                 native.c_source(gen), how="wait")
    assert not isinstance(model, native.NativeModel)
    assert model.native_note == "generated Python (no C compiler found (set CC))"
    assert np.isfinite(model.rhs(0.0, np.array([0.1, 0.2, 0.0, 0.0]))).all()
    monkeypatch.setenv("ANADYN_NATIVE", "0")
    model = native.recursive_model(RobotInfo.from_robot(robot), recursive.module_source(gen),
                                 native.c_source(gen))
    assert model.native_note == "generated Python (native code off (ANADYN_NATIVE=0))"


@pytest.mark.parametrize("seed", [0, 2, 4, 6, 9])
def test_forces_and_loads_match_closed_forms(seed):
    """The formulations' own joint forces and loads (issue 14) against the recursive ones."""
    from anadyn_cli.numeric import closed_form as cf
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    robot = _with_joint_forces(robot, damping=0.6, friction=0.25, friction_velocity=0.3,
                               stiffness=4.0, rest=-0.2)
    robot = dataclasses.replace(robot, loads=_loads(robot))
    assert check_against_closed_form(robot, seed, 3) >= 0
    ns, reference = module(robot), {}
    exec(cf.source(robot, derive(robot, "kane")), reference)  # noqa: S102
    for t, q, dq, _ in states(len(robot.coordinates), seed, 2):
        assert rel(ns["potential"](*q), reference["potential"](*q)) < TOL
        M, F, B = reference["mfb"](t, *q, *dq)
        ddq = np.linalg.lstsq(M, F, rcond=None)[0]
        assert rel(ns["dynamics_jacobian"](t, *q, *dq, *ddq)[1],
                   reference["dynamics_jacobian"](t, *q, *dq, *ddq)[1]) < TOL


def aba_function(robot):
    """The articulated-body accelerations of ``robot`` as a Python function (whether
    or not ``generate`` picks them), or None when J is not constant and invertible."""
    traced = recursive.trace_aba(recursive.plan(robot))
    if traced is None:
        return None
    namespace: dict = {}
    exec(recursive.PY_HEADER + "\n".join(recursive._python_function(traced, False, "")),  # noqa: S102
         namespace)
    return namespace["accelerations"]


@pytest.mark.parametrize("seed", range(16))
def test_articulated_body_algorithm_matches_cholesky(seed):
    """ABA against the CRBA + Cholesky path (checked above against the closed forms),
    with springs, friction and loads; the closed forms directly for a few seeds."""
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    if seed % 2:
        robot = _with_joint_forces(robot, damping=0.5, friction=0.3, friction_velocity=0.5,
                                   stiffness=2.0, rest=0.1)
        robot = dataclasses.replace(robot, loads=_loads(robot))
    aba = aba_function(robot)
    if aba is None:
        pytest.skip("coordinates are not a constant invertible map of the joints")
    ns = module(robot)
    mfbt = closed_form(robot) if seed < 4 else None
    for t, q, dq, _ in states(len(robot.coordinates), seed, 3):
        M = ns["mfb"](t, *q, *dq)[0]
        if np.linalg.eigvalsh(M).min() < 1e-9 * max(1.0, np.abs(M).max()):
            continue
        expected = ns["factor"](t, *q, *dq)[0]
        assert rel(aba(t, *q, *dq), expected) < 1e-9
        if mfbt is not None:
            M, F, B, tau = mfbt(t, q, dq)
            assert rel(aba(t, *q, *dq), np.linalg.solve(M, F + B @ tau)) < 1e-9


@pytest.mark.parametrize("path", ["robots/rr.yaml", "robots/rrt.yaml", "configs/chain6.yaml"])
def test_articulated_body_algorithm_on_shipped_robots(repo, path):
    robot = load_robot(repo / path)
    aba, mfbt = aba_function(robot), closed_form(robot)
    for t, q, dq, _ in states(len(robot.coordinates), 2, 3):
        M, F, B, tau = mfbt(t, q, dq)
        assert rel(aba(t, *q, *dq), np.linalg.solve(M, F + B @ tau)) < 1e-9


def test_the_cheaper_forward_dynamics_is_picked():
    """CRBA + Cholesky on short chains, the articulated-body algorithm on long ones."""
    short = recursive.generate(robot_from_text(chain_text(4), "c4.yaml"))
    long = recursive.generate(robot_from_text(chain_text(16), "c16.yaml"))
    assert short.functions["accelerations"].statements is short.functions["factor"].statements
    assert long.functions["accelerations"].statements is not long.functions["factor"].statements
    assert long.counts("accelerations").total < long.counts("factor").total


@needs_compiler
@pytest.mark.parametrize("text_of", ["random5", "chain16"])
def test_the_quick_build_gives_the_bits_of_the_python(text_of, tmp_path, monkeypatch):
    """The forward dynamics alone (CRBA + Cholesky on random5, the articulated-body
    algorithm on chain16), unoptimized: no Jacobian in the module, and the RHS of
    the generated Python to the bit."""
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path))
    text = random_robot_yaml(5) if text_of == "random5" else chain_text(16)
    robot = robot_from_text(text, f"{text_of}.yaml")
    forward = recursive.forward(recursive.plan(robot))
    c_text = native.c_source(forward)
    assert "anadyn_jac" not in c_text and native.flags(c_text) == native.QUICK_FLAGS
    module, why = native.build(c_text)
    assert module is not None, why
    assert not hasattr(module, "jac")
    from anadyn_cli.model.info import RobotInfo
    info = RobotInfo.from_robot(robot)
    code = recursive.module_source(recursive.complete(forward))
    python = native.RecursiveModel(info, code)
    quick = native.RecursiveModel(info, code, quick=native.QuickBuild(c_text, None, module))
    n = python.n
    for t, q, dq, _ in states(n, 4, 11):
        x = np.concatenate([q, dq])
        out = np.empty(2 * n)
        if module.rhs(t, x, out) == 0:
            assert np.array_equal(out, python.rhs(t, x))
            assert np.array_equal(quick.rhs(t, x), out)
            # the Jacobian: C factor and solve around the Python K, to the bit
            assert np.array_equal(quick.jacobian(t, x), python.jacobian(t, x))
    assert quick.native_note.startswith("native C (compiled during the run")


@needs_compiler
def test_a_cache_miss_builds_the_library_in_the_background(tmp_path, monkeypatch, repo):
    """First run: generated Python; the forward dynamics alone compiled quickly
    (the run's RHS switches to them once built, with the same bits) and the full
    library for next time; once done, both sit beside the derivation cache and
    the next run uses the full one."""
    from anadyn_cli.numeric.build import numeric_model
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "anadyn"))
    monkeypatch.delenv("ANADYN_NATIVE", raising=False)
    monkeypatch.setenv("ANADYN_GENERIC", "0")     # the generic kernel: test_generic_kernel.py
    first = numeric_model(repo / "robots/rrt.yaml", use_cache=True)
    assert not isinstance(first, native.NativeModel)
    assert first.native_note == ("generated Python (compiling in the background for the "
                                 "next run)")
    libraries = tmp_path / "anadyn-native"
    deadline = time.time() + 300                 # a bound, not a timing
    while any(libraries.glob("*.building")) and time.time() < deadline:
        time.sleep(0.05)
    assert len(list(libraries.glob("*.so"))) == 2          # quick and full
    x = first.initial_state()
    python = native.RecursiveModel(first.info, first.full_source)
    time.sleep(2 * native.QuickBuild.POLL)
    swapped = first.rhs(0.3, x)
    assert first.native_note.startswith("native C (compiled during the run")
    assert np.array_equal(swapped, python.rhs(0.3, x))
    second = numeric_model(repo / "robots/rrt.yaml", use_cache=True)
    assert isinstance(second, native.NativeModel) and second.native_note == "native C (cached)"
    assert np.array_equal(second.rhs(0.3, x), swapped)
    assert np.array_equal(second.jacobian(0.3, x), first.jacobian(0.3, x))
    third = numeric_model(repo / "robots/rrt.yaml", use_cache=True, timings=(timings := {}))
    assert timings["cache"] == "hit" and isinstance(third, native.NativeModel)


def test_non_smooth_control_laws(repo, tmp_path, monkeypatch):
    """sign, abs and min in a law: values against the closed forms, the Jacobian
    zero almost everywhere for sign and a step for min (as the closed forms'),
    and the C kernel (when it builds) giving the same bits."""
    text = (repo / "configs/chain6.yaml").read_text().replace(
        "T1: -bz*dq1 - kz*(q1 - f1)",
        "T1: -bz*dq1 - kz*(q1 - f1) - 0.3*sign(dq1) + 0.1*abs(q2) + min(q3, 0.2)")
    robot = robot_from_text(text, "chain6s.yaml")
    assert check_against_closed_form(robot, 5, 3) == 3
    from anadyn_cli.model.info import RobotInfo
    gen = recursive.generate(robot)
    code, c_text = recursive.module_source(gen), native.c_source(gen)
    info = RobotInfo.from_robot(robot)
    slow = native.RecursiveModel(info, code)
    for q3 in (0.1, 0.3):                    # both sides of min's kink
        x = np.array([0.1, -0.2, q3, 0.1, 0.1, 0.1, 0.5, -0.2, 0.1, 0.1, 0.1, 0.1])
        h = 1e-7
        J_fd = np.column_stack([(slow.rhs(0, x + h * e) - slow.rhs(0, x - h * e)) / (2 * h)
                                for e in np.eye(12)])
        assert rel(slow.jacobian(0, x), J_fd) < 1e-5
    if native.unavailable() is None:
        monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "anadyn"))
        fast = native.recursive_model(info, code, c_text, how="wait")
        assert isinstance(fast, native.NativeModel), fast.native_note
        assert np.array_equal(fast.jacobian(0, x), slow.jacobian(0, x))


def test_the_c_source_is_the_same_in_every_process(repo):
    """The library is named by a hash of its C text: two processes (other string
    hashes) must write the same text for the same robot."""
    import os
    import subprocess
    import sys
    code = ("import hashlib\nfrom anadyn_cli import load_robot\n"
            "from anadyn_cli.numeric import native, recursive\n"
            f"gen = recursive.generate(load_robot({str(repo / 'robots/rrt.yaml')!r}))\n"
            "print(hashlib.sha256(native.c_source(gen).encode()).hexdigest())")
    digests = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              check=True, env={**os.environ, "PYTHONHASHSEED": seed}).stdout
               for seed in ("1", "2")}
    assert len(digests) == 1 and len(digests.pop().strip()) == 64


def test_the_plans_rotations_are_the_exact_matrices_rounded_once():
    """``plan``'s joint rotations (128-bit arithmetic, each entry rounded once) are,
    to the bit, the exact Rz Ry Rx evaluated to 30 digits and rounded: multiples of
    pi/4 (exact zeros, ones and sqrt(2)/2), URDF decimals, random rationals."""
    import itertools
    import random

    from anadyn_cli.numeric.recursive.plan import _rotation_numbers
    from anadyn_cli.symbolic.kinematics import rpy_rotation

    rng = random.Random(7)
    cases = [[sp.pi * k / 4 for k in ks] for ks in itertools.product(range(-4, 5, 2), repeat=3)]
    cases += [[sp.Rational(15708, 10000), 0, sp.Rational(-31416, 10000)],
              [sp.Rational(1, 10**12), 0, 0]]
    cases += [[sp.Rational(rng.randint(-40000, 40000), 10000) if rng.random() < 0.7
               else sp.Integer(0) for _ in range(3)] for _ in range(150)]
    for rpy in cases:
        exact = rpy_rotation([sp.sympify(a) for a in rpy])
        numbers, identity = _rotation_numbers([sp.sympify(a) for a in rpy])
        assert numbers == [[float(exact[i, j].evalf(30)) for j in range(3)] for i in range(3)], rpy
        assert identity == (numbers == [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    assert _rotation_numbers([0, 0, 0])[1] and not _rotation_numbers([sp.pi, 0, 0])[1]
