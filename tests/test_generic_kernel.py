"""The generic kernel (``anadyn_cli.numeric.generic``): the recursions compiled
once, over a robot's numeric tables.

- against Pinocchio's ABA, RNEA, CRBA and kinetic and potential energies on URDF
  arms and example-robot-data robots (root welded), 20 random states each, 1e-12
  relative;
- against anadyn's generated code (rhs, inverse dynamics, M F B, efforts) on
  the YAML robots it serves, 1e-12 (not bit for bit: another order of
  operations);
- spherical joints (quaternion coordinates, body angular-velocity speeds) and
  floating bases: against the traced recursive path at 20 random states (1e-12;
  the Jacobian 1e-6, the control laws' part by central differences; its quaternion
  rows exactly; ``test_generic_jacobian`` holds the kernel's own part to 1e-12), each way
  to the accelerations, and Solo12 against Pinocchio's free-flyer
  (``pinocchio_mapped``, 1e-9);
- what it refuses (loads, nonlinear displacements): the generated code runs;
- a cold run served by the kernel gives the warm run's results to the run's
  tolerance, and needs none of the robot's generated code.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli import load_robot, robot_from_text
from anadyn_cli.model.info import RobotInfo
from anadyn_cli.model.urdf import import_file
from anadyn_cli.numeric import generic, native, recursive

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scenes import cubic_text  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
needs_compiler = pytest.mark.skipif(native.unavailable() is not None,
                                    reason=f"native code: {native.unavailable()}")
pytestmark = needs_compiler


def rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


@pytest.fixture(scope="module")
def kernel(tmp_path_factory):
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ANADYN_CACHE_DIR", str(tmp_path_factory.mktemp("generic") / "cache"))
        patch.delenv("ANADYN_NATIVE", raising=False)
        generic._KERNEL.clear()
        module = generic.kernel()
        generic._KERNEL.clear()
    assert module is not None
    return module


def generic_model(robot, module):
    pl = recursive.plan(robot)
    tables, why = generic.pack(pl)
    assert tables is not None, why
    code = recursive.module_source(recursive.generate(robot))
    info = RobotInfo.from_robot(robot)
    reference = native.RecursiveModel(info, code)
    model = generic.GenericModel(info, generic.Layout.of(pl), tables, module,
                                 generic.small_source(pl, robot), lambda: reference)
    return pl, tables, model, reference


# ------------------------------------------------------------- Pinocchio --

def erd(path: str) -> Path | None:
    try:
        import example_robot_data as e
        return Path(e.getModelPath(path)) / path
    except ImportError:
        base = next((Path(p) / "cmeel.prefix/share/example-robot-data/robots"
                     for p in sys.path if Path(p, "cmeel.prefix").is_dir()), None)
        return base / path if base is not None else None


URDFS = {"ur5": ROOT / "robots/ur5.urdf", "panda": ROOT / "robots/panda.urdf",
         "so101": ROOT / "robots/so101.urdf",
         "ur10": erd("ur_description/urdf/ur10_joint_limited_robot.urdf"),
         "z1": erd("z1_description/urdf/z1.urdf"),
         "baxter": erd("baxter_description/urdf/baxter.urdf"),
         "talos": erd("talos_data/robots/talos_reduced.urdf")}


def passive(pl, theta, dtheta) -> np.ndarray:
    """The joint springs, dampers and friction of the plan (as tracer.passive)."""
    out = []
    for j, b in enumerate(pl.moving):
        p = pl.bodies[b]
        out.append(-p.damping * dtheta[j] - p.friction * np.tanh(dtheta[j] / p.friction_velocity)
                   - p.stiffness * (theta[j] - p.rest))
    return np.array(out)


def pinocchio_pair(name):
    """(pinocchio, anadyn's robot of URDFS[name] with the root welded, its plan, A
    and c of its joint map theta = A q + c, Pinocchio's model of the same file and
    its data); skips where Pinocchio or the URDF is missing."""
    pin = pytest.importorskip("pinocchio")
    path = URDFS[name]
    if path is None or not path.exists():
        pytest.skip(f"{name}: URDF not installed")
    robot = robot_from_text(import_file(path, fix_base=True).text, path.name)
    pl = recursive.plan(robot)
    A, c = generic.tables.affine_map(pl)
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array(pl.gravity)
    return pin, robot, pl, A, c, model, model.createData()


@pytest.mark.parametrize("name", list(URDFS))
def test_kernel_matches_pinocchio(name, kernel):
    pin, _, pl, A, c, model, data = pinocchio_pair(name)
    tables, why = generic.pack(pl)
    assert tables is not None, why
    n, nm = pl.n, len(pl.moving)
    assert model.nv == nm and model.nq == nm

    def joint_of(body):
        frame = model.frames[model.getFrameId(pl.bodies[body].name)]
        return model.joints[getattr(frame, "parentJoint", None) or frame.parent].idx_v

    index = [joint_of(b) for b in pl.moving]
    rng = np.random.default_rng(7)
    for _ in range(20):
        q, dq, ddq = (rng.uniform(-1.5, 1.5, n) for _ in range(3))
        e = rng.uniform(-1.5, 1.5, nm)
        theta = A @ q + c
        qp, vp, ap = (np.empty(nm) for _ in range(3))
        qp[index], vp[index], ap[index] = theta, A @ dq, A @ ddq
        pas = passive(pl, theta, A @ dq)
        Mp = pin.crba(model, data, qp)
        Mp = (np.triu(Mp) + np.triu(Mp, 1).T)[np.ix_(index, index)]
        out = np.empty(2 * n)
        assert kernel.rhs(tables.ints, tables.doubles, np.concatenate([q, dq]), e, out) == 0
        if tables.mode == generic.tables.IDENTITY:
            ep = np.empty(nm)
            ep[index] = e + pas
            expected = pin.aba(model, data, qp, vp, ep)[index]
        else:                                         # M ddq = A^T (e + passive - bias)
            bias = pin.rnea(model, data, qp, vp, np.zeros(nm))[index]
            expected = np.linalg.solve(A.T @ Mp @ A, A.T @ (e + pas - bias))
        assert rel(out[n:], expected) < 1e-12
        ID = np.empty(n)
        kernel.inverse(tables.ints, tables.doubles, 1, np.concatenate([q, dq]), ddq, ID)
        assert rel(ID, A.T @ (pin.rnea(model, data, qp, vp, ap)[index] - pas)) < 1e-12
        M = np.empty((n, n))
        kernel.mass(tables.ints, tables.doubles, q, M)
        assert rel(M, A.T @ Mp @ A) < 1e-12
        energies = np.empty(3)                    # T, V (gravity, springs), P_d
        kernel.energies(tables.ints, tables.doubles, 1, np.concatenate([q, dq]), energies)
        springs = [(b.stiffness, b.rest) for b in (pl.bodies[i] for i in pl.moving)]
        V = pin.computePotentialEnergy(model, data, qp) + sum(
            0.5 * k * (th - rest) ** 2 for (k, rest), th in zip(springs, theta))
        dissipated = -(A @ dq) @ (pas + np.array([k * (th - rest) for (k, rest), th
                                                  in zip(springs, theta)]))
        assert rel(energies, [pin.computeKineticEnergy(model, data, qp, vp), V,
                              dissipated]) < 1e-12
        if tables.mode == generic.tables.IDENTITY and not pas.any():
            # the Jacobian (exact, forward mode) against Pinocchio's ABA derivatives
            J = np.empty((2 * n, 2 * n))
            kernel.jac(tables.ints, tables.doubles, np.concatenate([q, dq]), e, J)
            ep = np.empty(nm)
            ep[index] = e
            d_q, d_v, _ = pin.computeABADerivatives(model, data, qp, vp, ep)
            assert rel(J[n:, :n], d_q[np.ix_(index, index)]) < 1e-10
            assert rel(J[n:, n:], d_v[np.ix_(index, index)]) < 1e-10
            assert np.array_equal(J[:n], np.eye(2 * n)[n:])


# ------------------------------------------------- anadyn's generated code --

@pytest.mark.parametrize("path, mode", [("robots/rr.yaml", "INVERTIBLE"), ("robots/rrt.yaml", "IDENTITY"),
                                        ("configs/chain6.yaml", "IDENTITY"),
                                        ("robots/panda.urdf", "GENERAL"),
                                        ("robots/drives/rr_drives.yaml", "GENERAL")])
def test_kernel_matches_generated_code(path, mode, kernel):
    """(rr_drives: gears of 2 and 10 and rotors, so B holds each drive's N k_t.)"""
    robot = load_robot(ROOT / path)
    pl, tables, model, reference = generic_model(robot, kernel)
    assert tables.mode == getattr(generic.tables, mode)      # each way to the accelerations
    n = pl.n
    rng = np.random.default_rng(3)
    for _ in range(20):
        t, x, w = 0.3, rng.uniform(-1, 1, 2 * n), rng.uniform(-1, 1, n)
        assert rel(model.rhs(t, x), reference.rhs(t, x)) < 1e-12
        assert rel(model.demand(t, x[:n], x[n:], w)[0], reference.demand(t, x[:n], x[n:], w)[0]) < 1e-12
        e = rng.uniform(-1, 1, len(pl.efforts))
        assert rel(model.driven_accelerations(t, x, e),
                   reference.driven_accelerations(t, x, e)) < 1e-12
        for a, b in zip(model.mfb(t, x[:n, None], x[n:, None]),
                        reference.mfb(t, x[:n, None], x[n:, None])):
            assert rel(a, b) < 1e-12
        assert rel(model.jacobian(t, x), reference.jacobian(t, x)) < 1e-5
    q = rng.uniform(-1, 1, (n, 5))
    assert rel(model.efforts(np.zeros(5), q, q), reference.efforts(np.zeros(5), q, q)) < 1e-15
    for a, b in zip(model.energy(q, q), reference.energy(q, q)):     # T and V
        assert rel(a, b) < 1e-12


# ------------------------------------------------------ spherical joints --

#: a spherical joint on a turning arm, a fixed tip (A = 1: the tree's LTL factor with
#: a three-speed joint), or ``both`` a second arm turned by the same coordinate
#: (theta = A q with A 5 x 4: CRBA and a dense Cholesky factor)
BALL_ON_ARM = """name: ball_on_arm
gravity: [0, -3.0, -9.81]
coordinates:
  a: {{initial: 0.3}}
bodies:
  - name: arm
    joint: {{type: revolute, axis: [0, 0.6, 0.8], origin: [0, 0, 0.1], displacement: a,
             damping: 0.3, friction: 0.2, stiffness: 2.0}}
    mass: 1.5
    com: [0.2, 0.01, 0]
    inertia: {{ixx: 0.03, iyy: 0.05, izz: 0.04, ixy: 0.003}}
{both}  - name: ball
    parent: arm
    joint: {{type: spherical, origin: [0.4, 0, 0.05], rpy: [0.2, -0.1, 0.3]}}
    mass: 0.8
    com: [0.05, -0.02, 0.15]
    inertia: {{ixx: 0.02, iyy: 0.03, izz: 0.025, ixz: 0.002}}
  - name: tip
    parent: ball
    joint: {{type: fixed, origin: [0, 0, 0.3], rpy: [0.4, 0, 0]}}
    mass: 0.3
    com: [0, 0.02, 0.05]
    inertia: {{ixx: 0.001, iyy: 0.002, izz: 0.001}}
actuators:
  motor: {{joint: arm}}
controller:
  laws:
    motor: -4*(a - 0.2) - 0.5*da + sin(t)
"""
TWIN = """  - name: twin
    joint: {type: revolute, axis: [1, 0, 0], origin: [0, 0.2, 0], displacement: -a}
    mass: 0.5
    com: [0, 0.1, 0]
    inertia: {ixx: 0.002, iyy: 0.001, izz: 0.002}
"""


def spherical_robot(name: str):
    if name in ("ball_on_arm", "twin_arms"):
        return robot_from_text(BALL_ON_ARM.format(both=TWIN if name == "twin_arms" else ""),
                               f"{name}.yaml")
    return load_robot(ROOT / f"robots/{name}.yaml")


@pytest.mark.parametrize("name, mode", [("spherical_pendulum", "IDENTITY"),
                                        ("ball_on_arm", "IDENTITY"),
                                        ("satellite", "INVERTIBLE"),
                                        ("space_robot", "INVERTIBLE"),
                                        ("solo12_free", "INVERTIBLE"),
                                        ("twin_arms", "GENERAL")])
def test_kernel_matches_the_traced_path_with_spherical_joints(name, mode, kernel):
    """State [q (nq), u (n)]: the rates W(q) u, the accelerations, driven
    accelerations, inverse dynamics, M F B and the Jacobian (its quaternion rows
    d(W(q) u)/dx analytic) at quaternions of any norm (the motion does not depend
    on it), each way to the accelerations."""
    robot = spherical_robot(name)
    pl, tables, model, reference = generic_model(robot, kernel)
    assert tables.mode == getattr(generic.tables, mode) and pl.spherical
    nq, n = pl.nq, pl.n
    assert (model.nq, model.n, model.speeds, model.quaternions) == (
        reference.nq, reference.n, reference.speeds, reference.quaternions)
    rng = np.random.default_rng(11)
    for k in range(20):
        t, x, w = 0.7, rng.uniform(-1, 1, nq + n), rng.uniform(-1, 1, n)
        for quaternion in model.quaternions:
            x[list(quaternion)] *= (1.0 if k % 2 else 1.7) / np.linalg.norm(x[list(quaternion)])
        q, u = x[:nq], x[nq:]
        assert rel(model.rhs(t, x), reference.rhs(t, x)) < 1e-12
        assert rel(model.demand(t, q, u, w)[0], reference.demand(t, q, u, w)[0]) < 1e-12
        e = rng.uniform(-1, 1, len(pl.efforts))
        if len(e):
            assert rel(model.driven_accelerations(t, x, e),
                       reference.driven_accelerations(t, x, e)) < 1e-12
        for a, b in zip(model.mfb(t, q[:, None], u[:, None]),
                        reference.mfb(t, q[:, None], u[:, None])):
            assert a.size == b.size == 0 or rel(a, b) < 1e-12
        J, expected = model.jacobian(t, x), reference.jacobian(t, x)
        assert rel(J[:nq], expected[:nq]) < 1e-15
        assert rel(J, expected) < 1e-6
    rows = rng.uniform(-1, 1, (nq + n, 4))
    assert rel(model.coordinate_rates(rows), reference.coordinate_rates(rows)) == 0.0


def test_kernel_matches_pinocchios_free_flyer_on_solo12(kernel):
    """Solo12 imported with a free base (no joint damping: Pinocchio's RNEA has
    none) against Pinocchio's JointModelFreeFlyer: M, inverse and forward dynamics
    at 20 random states to 1e-9 (``pinocchio_mapped``; the kernel's, not the
    generated code's)."""
    pytest.importorskip("pinocchio")
    from pinocchio_mapped import check_mapped
    from test_floating import pin, urdf_robot

    robot, pmodel, mapping = urdf_robot("solo_description/robots/solo12.urdf")
    pl = recursive.plan(robot)
    tables, why = generic.pack(pl)
    assert tables is not None, why

    def full():
        raise AssertionError("the generated code is not needed here")
    model = generic.GenericModel(RobotInfo.from_robot(robot), generic.Layout.of(pl), tables,
                                 kernel, generic.small_source(pl, robot), full)
    nq, n = pl.nq, pl.n
    namespace = {"mfb": lambda t, *s: model.mfb(t, s[:nq], s[nq:]),
                 "inverse_dynamics": lambda t, *s: model.demand(t, s[:nq], s[nq:nq + n],
                                                                s[nq + n:])[0],
                 "accelerations": lambda t, *s: model.accelerations(t, np.array(s))}
    assert check_mapped(pin, namespace, pmodel, mapping.random, mapping.to_pin) == 20


def test_what_the_tables_cannot_hold():
    loads = load_robot(ROOT / "robots/rrt_friction.yaml")
    assert generic.pack(recursive.plan(loads)) == (None, "external loads")
    cubic = robot_from_text(cubic_text(0.4), "cubic.yaml")
    assert generic.pack(recursive.plan(cubic)) == (
        None, "a joint displacement that is not affine in the coordinates")


# ------------------------------------------------------ a cold run, served --

@pytest.mark.parametrize("path", ["configs/chain6.yaml", "robots/satellite.yaml"])
def test_a_cold_run_served_by_the_kernel_gives_the_warm_results(path, tmp_path, monkeypatch,
                                                                 kernel):
    """Cold: the kernel runs and the robot's code is generated, stored and
    compiled (here in this process instead of a forked one); warm: that code.
    The two trajectories agree to the run's tolerance (the satellite: a free
    base, its quaternion, its wheel's control law)."""
    from anadyn_cli.cli import main
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("ANADYN_NATIVE", raising=False)
    monkeypatch.setattr(generic, "_fork", lambda work: work())
    generic._KERNEL.clear()
    runs = []
    for k in range(2):
        out = tmp_path / f"run{k}"
        assert main(["simulate", str(ROOT / path), "--t-end", "1",
                     "--no-plot", "--out", str(out)]) == 0
        runs.append(out)
    import json
    codes = [json.loads((r / "simulate.json").read_text())["code"] for r in runs]
    assert codes[0].startswith("generic kernel") and codes[1].startswith("native C (cached")
    cold, warm = (np.loadtxt(r / "simulate.csv", delimiter=",", skiprows=1) for r in runs)
    assert cold.shape == warm.shape
    assert np.abs(cold - warm).max() < 1e-7 * max(1.0, np.abs(warm).max())
    monkeypatch.setenv("ANADYN_GENERIC", "0")            # off: the old cold path
    assert not generic.enabled()


def test_check_integrands_are_the_kernels_cold_and_warm(tmp_path, monkeypatch, kernel):
    """``check`` on panda.urdf (joint damping): the cold run on the kernel, the warm run
    on the robot's C with the kernel's integrands over the tables stored in its cache
    entry, and the generated integrands (ANADYN_GENERIC=0) agree on the dissipated
    energy and the energy balance to the run's tolerance."""
    import json

    from anadyn_cli.cli import main
    from anadyn_cli.numeric import build
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("ANADYN_NATIVE", raising=False)
    monkeypatch.setattr(generic, "_fork", lambda work: work())
    generic._KERNEL.clear()
    path = str(ROOT / "robots/panda.urdf")
    runs = []
    for k, switch in enumerate(("1", "1", "0")):
        monkeypatch.setenv("ANADYN_GENERIC", switch)
        out = tmp_path / f"run{k}"
        assert main(["check", path, "--t-end", "0.5", "--out", str(out)]) in (0, 1)
        runs.append(json.loads((out / "check.json").read_text()))
    monkeypatch.setenv("ANADYN_GENERIC", "1")
    warm = build.numeric_model(path, use_cache=True)
    assert isinstance(warm.integrands, generic.Energies)
    assert [r["code"].split(" (")[0] for r in runs] == ["generic kernel", "native C", "native C"]
    dissipated = [r["dissipated_final"] for r in runs]
    assert dissipated[0] > 0 and np.ptp(dissipated) < 1e-6 * dissipated[0]
    assert all(r["energy_error"] < 1e-8 for r in runs)


@pytest.mark.parametrize("path", ["robots/panda.urdf", "robots/drives/rr_drives.yaml",
                                  "ball_on_arm"])
def test_kernel_energies_and_powers_match_the_generated_ones(path, kernel):
    """``check``'s integrands: T, V (gravity and springs) and the power joint damping
    and friction dissipate, from the kernel's tables, against the generated code's
    (the kinematics' closed forms, ``closed_form.forces_source``, or the traced
    velocities with a spherical joint) at 7 random states, 1e-12; whether the robot
    has such forces, as the generated code says."""
    from anadyn_cli.numeric.closed_form import forces_source
    from anadyn_cli.numeric.model import run_generated

    robot = spherical_robot(path) if "/" not in path else load_robot(ROOT / path)
    pl, _, model, reference = generic_model(robot, kernel)
    rng = np.random.default_rng(5)
    q, u = rng.uniform(-1, 1, (model.nq, 7)), rng.uniform(-1, 1, (model.n, 7))
    for c in model.quaternions:
        q[list(c)] /= np.linalg.norm(q[list(c)], axis=0)
    for a, b in zip(model.energy(q, u), reference.energy(q, u)):
        assert rel(a, b) < 1e-12
    t = np.linspace(0, 1, 7)
    if pl.spherical:
        expected = reference.powers(t, q, u)
    else:
        expected = np.moveaxis(run_generated(forces_source(robot))["powers"](t, *q, *u), -1, 0)
    assert model.has_forces
    assert rel(model.powers(t, q, u), expected) < 1e-12 and np.all(expected[1] > 0)


def kernel_only(path: str, kernel) -> generic.GenericModel:
    """The GenericModel of the robot file ``path`` whose generated code (``full``) must
    not be built: asking for it fails the test."""
    robot = load_robot(ROOT / path)
    pl = recursive.plan(robot)
    tables, _ = generic.pack(pl)

    def full():
        raise AssertionError("a cold run built the robot's generated code")
    return generic.GenericModel(RobotInfo.from_robot(robot), generic.Layout.of(pl), tables,
                                kernel, generic.small_source(pl, robot), full)


@pytest.mark.parametrize("path", ["configs/chain6.yaml", "robots/satellite.yaml"])
def test_a_run_on_the_kernel_needs_none_of_the_generated_code(path, kernel):
    """``simulate`` on a GenericModel whose generated code (``full``) may not be
    built: what the run asks of the model (state names, quaternions, rates,
    contacts) is the kernel's, not a fallback that would generate the whole robot
    during a cold run."""
    from anadyn_cli.services.simulate import simulate
    model = kernel_only(path, kernel)
    result = simulate(model, t_end=0.2)
    assert result.solution.success and len(result.t) == 21
    if model.quaternions:
        assert 0.0 <= result.quaternion_drift < 1e-9


@pytest.mark.parametrize("path", ["robots/panda.urdf", "robots/drives/rr_drives.yaml"])
def test_a_check_on_the_kernel_needs_none_of_the_generated_code(path, kernel):
    """``check`` (energies, dissipated power, efforts, M, the Jacobian) on a GenericModel
    whose generated code may not be built, and its energy balance closes."""
    from anadyn_cli.services.check import check
    report = check(kernel_only(path, kernel), t_end=0.3, samples=5, probe_calls=200)
    assert report.dissipated is not None and report.dissipated[-1] > 0
    assert report.energy_error < 1e-6


def test_warm_spherical_runs_integrate_with_differences_of_the_c_rhs(tmp_path, monkeypatch):
    """A robot with a spherical joint has no C Jacobian: its cached model gives the
    integrators central differences of the C rhs (no generated Python Jacobian
    compiled for the stiffness estimate at the start); ``jacobian`` stays exact."""
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    robot = load_robot(ROOT / "robots/satellite.yaml")
    gen = recursive.generate(robot)
    module, note = native.build(native.c_source(gen), {})
    assert module is not None, note
    model = native.NativeModel(RobotInfo.from_robot(robot), recursive.module_source(gen),
                               "recursive", module)
    x = model.initial_state() + np.random.default_rng(5).uniform(-0.3, 0.3, model.nq + model.n)
    J = model.problem().jacobian(2.1, x)
    assert model._scalars == {}                    # nothing compiled from Python
    assert rel(J, model.jacobian(2.1, x)) < 1e-6 and model._scalars
