"""Joint damping, friction and springs, and external loads (issue 14).

Each against something independent of the code under test:

* closed forms: a damped pendulum's decay rate and damped frequency, a
  spring-mass period and equilibrium, an arm holding a tip load
  (efforts = -J^T f, J by hand or by differences of a hand-written forward
  kinematics), a block with Coulomb friction that sticks below breakaway
  and slides above it (bounds that follow from the tanh smoothing);
* ``sympy.physics.mechanics.KanesMethod`` (``mechanics_oracle.py``) on random
  robots with random joint forces and loads, at random times and states;
* Kane against Lagrange symbolically, and ``check``'s energy balance and
  ``compare``, each shown to fail on a wrong force term;
* bad input: one line naming file, line, key path and what is allowed.

Runs go through the command line (``anadyn_cli.cli.main``) and its files,
with both numeric paths: ``kane`` (by default the recursive, O(n) code) and
``lagrange`` (the closed forms of ``numeric.closed_form``).
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from anadyn_cli import derive, load_robot, robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.numeric import closed_form
from anadyn_cli.symbolic import forces as forces_module
from anadyn_cli.symbolic import kinematics
from anadyn_cli.symbolic.formulations import lagrange as lagrange_module

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mechanics_oracle import oracle_equations  # noqa: E402
from random_robots import random_robot_yaml  # noqa: E402

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
RR = (ROBOTS / "rr.yaml").read_text()
RRT = (ROBOTS / "rrt.yaml").read_text()
T = sp.Symbol("t", real=True)
PATHS = {"recursive": ("--evaluator", "recursive"),      # Newton-Euler code
         "lagrange": ("--formulation", "lagrange")}    # Lagrange's closed forms


# -- helpers -------------------------------------------------------------------------
def write(tmp_path: Path, text: str, name: str = "robot.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def cli(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def columns(path: Path) -> dict[str, np.ndarray]:
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def simulate(capsys, tmp_path: Path, text: str, *options,
             computation: str = "recursive") -> dict[str, np.ndarray]:
    path, out = write(tmp_path, text), tmp_path / "out"
    code, _, err = cli(capsys, "simulate", path, "--out", out, "--no-plot", "--no-cache",
                       *PATHS[computation], *options)
    assert code == 0, err
    return columns(out / "simulate.csv")


def edit(text: str, old: str, new: str) -> str:
    assert text.count(old) == 1, f"{old!r} occurs {text.count(old)} times"
    return text.replace(old, new)


def crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times where y changes sign, by linear interpolation."""
    k = np.flatnonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


def extrema(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the local extrema of |y|, by a parabola through 3 rows."""
    a = np.abs(y)
    k = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
    y0, y1, y2 = y[k - 1], y[k], y[k + 1]
    h = t[1] - t[0]
    shift = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    return t[k] + shift * h, y1 - 0.25 * (y0 - y2) * shift


# -- 1. damped pendulum ------------------------------------------------------------------
PENDULUM = """\
name: damped_pendulum
parameters: {m: 2.0, L: 0.5, g: 9.81, c: 0.3}
gravity: [0, -g, 0]
coordinates:
  q1: {initial: -pi/2 + 0.0001}
bodies:
  - name: bob
    joint: {type: revolute, axis: [0, 0, 1], damping: c}
    mass: m
    com: [L, 0, 0]
simulation: {t_end: 6, output_step: 0.001}
"""


@pytest.mark.parametrize("computation", PATHS)
def test_damped_pendulum_decays_at_the_closed_form_rate_and_frequency(tmp_path, capsys,
                                                                      computation):
    """I phi'' + c phi' + m g L phi = 0 (small phi, I = m L^2): phi = phi0 e^(-sigma t)
    (cos wd t + sigma/wd sin wd t), sigma = c / (2 I), wd = sqrt(g/L - sigma^2)."""
    m, L, g, c, phi0 = 2.0, 0.5, 9.81, 0.3, 1e-4
    sigma, wd = c / (2 * m * L**2), math.sqrt(g / L - (c / (2 * m * L**2)) ** 2)
    run = simulate(capsys, tmp_path, PENDULUM, "--rtol", "1e-12", "--atol", "1e-16",
                   computation=computation)
    t, phi = run["t"], run["q1"] + math.pi / 2
    exact = phi0 * np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))
    assert np.abs(phi - exact).max() <= 1e-7 * phi0          # measured 1e-9 phi0 (sin phi)
    # the decay rate and the damped frequency, read off the motion itself
    zeros = crossings(t, phi)
    assert len(zeros) >= 8
    measured_wd = math.pi * (len(zeros) - 1) / (zeros[-1] - zeros[0])
    times, peaks = extrema(t, phi)
    measured_sigma = math.log(abs(peaks[0] / peaks[-1])) / (times[-1] - times[0])
    assert measured_wd == pytest.approx(wd, rel=1e-6)
    assert measured_sigma == pytest.approx(sigma, rel=1e-5)
    # undamped, the amplitude stays: the decay is the damping's
    undamped = simulate(capsys, tmp_path, edit(PENDULUM, ", damping: c", ""),
                        "--rtol", "1e-12", "--atol", "1e-16", computation=computation)
    assert np.abs(undamped["q1"] + math.pi / 2).max() == pytest.approx(phi0, rel=1e-6)
    assert np.abs(phi[t > 5]).max() < 0.25 * phi0


# -- 2. spring and mass on a prismatic joint ------------------------------------------
SPRING = """\
name: spring_mass
parameters: {m: 1.5, k: 60.0, r: 0.4, g: 9.81}
gravity: [0, -g, 0]
coordinates:
  y: {initial: 0.4}
bodies:
  - name: block
    joint: {type: prismatic, axis: [0, 1, 0], stiffness: k, rest: r}
    mass: m
simulation: {t_end: 5, output_step: 0.001}
"""


@pytest.mark.parametrize("computation", PATHS)
def test_spring_mass_oscillates_about_its_equilibrium_with_the_closed_form_period(
        tmp_path, capsys, computation):
    """m y'' = -k (y - r) - m g: equilibrium y_eq = r - m g / k, period 2 pi sqrt(m/k);
    released at rest at y = r, y = y_eq + (r - y_eq) cos(sqrt(k/m) t)."""
    m, k, r, g = 1.5, 60.0, 0.4, 9.81
    y_eq, w = r - m * g / k, math.sqrt(k / m)
    run = simulate(capsys, tmp_path, SPRING, "--rtol", "1e-12", "--atol", "1e-14",
                   computation=computation)
    t, y = run["t"], run["y"]
    assert np.abs(y - (y_eq + (r - y_eq) * np.cos(w * t))).max() <= 1e-9
    zeros = crossings(t, y - y_eq)
    period = 2 * (zeros[-1] - zeros[0]) / (len(zeros) - 1)
    assert period == pytest.approx(2 * math.pi * math.sqrt(m / k), rel=1e-6)
    # started at the equilibrium it stays there
    still = simulate(capsys, tmp_path, edit(SPRING, "initial: 0.4", f"initial: {y_eq!r}"),
                     computation=computation)
    assert np.abs(still["y"] - y_eq).max() <= 1e-12


@pytest.mark.parametrize("computation", PATHS)
def test_spring_energy_is_part_of_the_potential(tmp_path, capsys, computation):
    """check's balance holds only if V has k/2 (y - r)^2: without it, T + V swings by
    the spring's energy (about 1.8 J here)."""
    path, out = write(tmp_path, SPRING), tmp_path / "check"
    code, _, err = cli(capsys, "check", path, "--out", out, "--no-cache", "--t-end", "2",
                       *PATHS[computation])
    assert code == 0, err
    figures = json.loads((out / "check.json").read_text())
    assert figures["energy_error"] < 1e-9
    robot = load_robot(path)
    springs = forces_module.spring_energy(robot, kinematics.build(robot))
    y = sp.Symbol("y", real=True)
    assert sp.expand(springs - 30 * (y - sp.Rational(2, 5)) ** 2) == 0


# -- 3. an arm holding a tip load ------------------------------------------------------
HOLDING = """\
name: holding
parameters: {L1: 0.8, L2: 0.6, m1: 2.0, m2: 1.5, fx: 12.0, fy: -30.0, tz: 1.5}
coordinates:
  q1: {initial: 0.3}
  q2: {initial: 0.7}
bodies:
  - name: upper
    joint: {type: revolute, axis: [0, 0, 1]}
    mass: m1
    com: [L1/2, 0, 0]
    inertia: {iyy: m1*L1**2/12, izz: m1*L1**2/12}
  - name: fore
    parent: upper
    joint: {type: revolute, axis: [0, 0, 1], origin: [L1, 0, 0]}
    mass: m2
    com: [L2/2, 0, 0]
    inertia: {iyy: m2*L2**2/12, izz: m2*L2**2/12}
actuators:
  T1: {joint: upper}
  T2: {joint: fore}
loads:
  - {body: fore, point: [L2, 0, 0], force: [fx, fy, 0], torque: [0, 0, tz]}
trajectory: {kind: expression, duration: 2, expressions: {q1: "0.3", q2: "0.7"}}
simulation: {t_end: 2, output_step: 0.01}
"""


def planar_holding_efforts(q1: float, q2: float, f: np.ndarray, tz: float) -> np.ndarray:
    """-J^T f - (tz, tz): the tip at (L1 c1 + L2 c12, L1 s1 + L2 s12), by hand."""
    L1, L2 = 0.8, 0.6
    s1, c1, s12, c12 = math.sin(q1), math.cos(q1), math.sin(q1 + q2), math.cos(q1 + q2)
    J = np.array([[-L1 * s1 - L2 * s12, -L2 * s12], [L1 * c1 + L2 * c12, L2 * c12]])
    return -(J.T @ f) - tz


@pytest.mark.parametrize("computation", PATHS)
@pytest.mark.parametrize("frame", ["world", "body"])
def test_static_arm_holding_a_tip_load_needs_minus_J_transpose_f(tmp_path, capsys, frame,
                                                                 computation):
    q1, q2, f = 0.3, 0.7, np.array([12.0, -30.0])
    text = HOLDING
    if frame == "body":     # the same force, given in the forearm's axes
        c, s = math.cos(q1 + q2), math.sin(q1 + q2)
        fb = np.array([[c, s], [-s, c]]) @ f
        text = edit(text, "force: [fx, fy, 0], torque: [0, 0, tz]}",
                    f"force: [{float(fb[0])!r}, {float(fb[1])!r}, 0], torque: [0, 0, tz], "
                    "frame: body}")
    path, out = write(tmp_path, text), tmp_path / "out"
    code, _, err = cli(capsys, "inverse", path, "--out", out, "--no-plot", "--no-cache",
                       *PATHS[computation])
    assert code == 0, err
    run = columns(out / "inverse.csv")
    expected = planar_holding_efforts(q1, q2, f, 1.5)
    assert np.abs(run["T1"] - expected[0]).max() <= 1e-12 * 40
    assert np.abs(run["T2"] - expected[1]).max() <= 1e-12 * 40


@pytest.mark.parametrize("computation", PATHS)
def test_the_arm_held_by_those_efforts_stays_put(tmp_path, capsys, computation):
    """The direct dynamics agrees on the sign: under tau = -J^T f the arm does not move."""
    laws = """\
controller:
  laws:
    T1: -((-L1*sin(q1) - L2*sin(q1 + q2))*fx + (L1*cos(q1) + L2*cos(q1 + q2))*fy + tz)
    T2: -(-L2*sin(q1 + q2)*fx + L2*cos(q1 + q2)*fy + tz)
"""
    run = simulate(capsys, tmp_path, edit(HOLDING, "trajectory:", laws + "trajectory:"),
                   "--rtol", "1e-12", "--atol", "1e-14", computation=computation)
    assert np.abs(run["q1"] - 0.3).max() <= 1e-9 and np.abs(run["q2"] - 0.7).max() <= 1e-9
    without = simulate(capsys, tmp_path, HOLDING, computation=computation)   # load alone
    assert np.abs(without["q2"] - 0.7).max() > 0.1


def rrt_tip(q: np.ndarray, tool: float = 0.2) -> np.ndarray:
    """The RRT tool point by hand: Rx(q1) ([0, 0, 2 L1] + Ry(q2) [0, 0, L2 + q3 + tool])."""
    L1 = L2 = 0.4
    q1, q2, q3 = q
    reach = L2 + q3 + tool
    local = np.array([math.sin(q2) * reach, 0.0, 2 * L1 + math.cos(q2) * reach])
    c, s = math.cos(q1), math.sin(q1)
    return np.array([local[0], c * local[1] - s * local[2], s * local[1] + c * local[2]])


@pytest.mark.parametrize("computation", PATHS)
def test_spatial_arm_holding_a_tip_force_and_torque(tmp_path, capsys, computation):
    """RRT without gravity: efforts = -(J^T f + J_w^T T), J by central differences of the
    hand-written tool point, J_w = [i0, Rx(q1) j0, 0] (the slider does not turn)."""
    q = np.array([math.pi / 18, math.pi / 6, 0.25])
    f, torque = np.array([-20.0, 7.0, 4.0]), np.array([1.0, -2.0, 0.5])
    text = edit(RRT, "gravity: [-g, 0, 0]\n", "")
    text = edit(text, "controller:",
                "loads:\n  - {body: link3, point: [0, 0, 0.2], force: [-20, 7, 4], "
                "torque: [1, -2, 0.5]}\ncontroller:")
    text = edit(text, "trajectory: {kind: cycloidal, duration: 15, to: {q1: pi/3, q2: pi/3, "
                      "q3: 0.3}}",
                "trajectory: {kind: expression, duration: 1, expressions: {q1: pi/18, "
                "q2: pi/6, q3: 0.25}}")
    path, out = write(tmp_path, text), tmp_path / "out"
    code, _, err = cli(capsys, "inverse", path, "--out", out, "--no-plot", "--no-cache",
                       "--dt", "0.5", *PATHS[computation])
    assert code == 0, err
    run = columns(out / "inverse.csv")
    h = 1e-6
    J = np.column_stack([(rrt_tip(q + h * e) - rrt_tip(q - h * e)) / (2 * h) for e in np.eye(3)])
    c, s = math.cos(q[0]), math.sin(q[0])
    J_w = np.column_stack([[1.0, 0, 0], [0, c, s], [0, 0, 0]])
    expected = -(J.T @ f + J_w.T @ torque)
    for name, value in zip(("T01x", "T12y", "F23z"), expected):
        assert run[name] == pytest.approx(np.full(len(run["t"]), value), abs=1e-8)


# -- 4. Coulomb friction: stick and slip ---------------------------------------------
BLOCK = """\
name: block
parameters: {m: 2.0, f: 10.0, P: 5.0}
coordinates:
  x: {}
bodies:
  - name: block
    joint: {type: prismatic, axis: [1, 0, 0], friction: f}
    mass: m
loads:
  - {body: block, force: [P, 0, 0]}
simulation: {t_end: 2, output_step: 0.001}
"""


@pytest.mark.parametrize("computation", PATHS)
def test_block_sticks_below_breakaway_within_the_smoothing(tmp_path, capsys, computation):
    """Pushed by P < f from rest, m x'' = P - f tanh(x'/v) creeps at most at
    v atanh(P/f) (v = 0.01 m/s, the default): 5.5 mm/s, where a frictionless block
    would be at 5 m/s after 2 s."""
    v, P, f = 0.01, 5.0, 10.0
    creep = v * math.atanh(P / f)
    run = simulate(capsys, tmp_path, BLOCK, "--rtol", "1e-11", "--atol", "1e-14",
                   computation=computation)
    assert run["dx"].max() <= creep * (1 + 1e-9) and run["dx"].min() >= 0
    assert run["dx"][-1] == pytest.approx(creep, rel=1e-8)
    assert 0 < run["x"][-1] <= creep * 2.0                        # 1.1 cm in 2 s


@pytest.mark.parametrize("computation", PATHS)
def test_block_slides_above_breakaway_within_the_smoothing(tmp_path, capsys, computation):
    """Pushed by P > f: x'' = (P - f tanh(x'/v))/m >= (P - f)/m, and the smoothing's
    shortfall integrates to at most f v ln 2 / (P - f), so
    (P - f) T/m <= x'(T) <= (P - f) T/m + f v ln 2 / (P - f)."""
    v, P, f, m, T_end = 0.01, 20.0, 10.0, 2.0, 2.0
    run = simulate(capsys, tmp_path, edit(BLOCK, "P: 5.0", "P: 20.0"),
                   "--rtol", "1e-11", "--atol", "1e-14", computation=computation)
    coulomb = (P - f) * T_end / m
    assert coulomb <= run["dx"][-1] <= coulomb + f * v * math.log(2) / (P - f)
    assert coulomb * T_end / 2 <= run["x"][-1] <= (coulomb / 2 + f * v * math.log(2) / (P - f)
                                                   ) * T_end


# -- 5. random robots against sympy.physics.mechanics ------------------------------------
FAST_SEEDS = [0, 1, 2, 3, 4, 5]
SLOW_SEEDS = list(range(6, 30))


def _numbers(matrices, symbols, values):
    function = sp.lambdify(symbols, list(matrices), modules="numpy", cse=True)
    return [np.asarray(a, dtype=float) for a in function(*values)]


def agree_with_oracle(seed: int) -> float:
    """Largest max|anadyn - oracle| / max(1, max|oracle|) over M, F, B, both methods,
    three random (t, q, dq)."""
    text = random_robot_yaml(seed, forces=True)
    q, dq, tau, M, F, B = oracle_equations(text)
    robot = robot_from_text(text, f"random{seed}.yaml")
    rng = np.random.default_rng(seed)
    worst = 0.0
    for method in ("kane", "lagrange"):
        eom = derive(robot, method)
        assert [str(s) for s in eom.q] == [str(s) for s in q]
        for _ in range(3):
            values = [rng.uniform(0, 5), *rng.uniform(-1.5, 1.5, 2 * len(q))]
            ours = _numbers((eom.M, eom.F, eom.B), [T, *eom.q, *eom.dq], values)
            theirs = _numbers((M, F, B), [T, *q, *dq], values)
            for a, b in zip(ours, theirs):
                worst = max(worst, float(np.abs(a - b).max(initial=0.0)
                                         / max(1.0, np.abs(b).max(initial=0.0))))
    return worst


@pytest.mark.parametrize("seed", FAST_SEEDS)
def test_random_robots_with_forces_match_kanes_method(seed):
    assert agree_with_oracle(seed) <= 1e-10                     # measured <= 3e-15


@pytest.mark.slow
@pytest.mark.parametrize("seed", SLOW_SEEDS)
def test_more_random_robots_with_forces_match_kanes_method(seed):
    assert agree_with_oracle(seed) <= 1e-10


def test_random_robots_actually_carry_forces():
    """The cross-check is not vacuous: the seeds bring damping, friction with and without
    its own smoothing, springs, and loads of t, q and dq in both frames."""
    texts = "".join(random_robot_yaml(s, forces=True) for s in FAST_SEEDS + SLOW_SEEDS)
    for word in ("damping:", "friction:", "friction_velocity:", "stiffness:", "rest:",
                 "frame: world", "frame: body", "point:", "torque:", "*t)", "dq", "cos("):
        assert word in texts, word
    for seed in FAST_SEEDS:
        robot = robot_from_text(random_robot_yaml(seed, forces=True), "r.yaml")
        eom = derive(robot, "kane")
        assert eom.Q is not None and any(entry != 0 for entry in eom.Q)


def test_the_oracle_sees_a_wrong_load(monkeypatch):
    """Loads taken in the wrong axes (world for body and body for world) miss the oracle
    (seed 1: a 2-link arm with two loads)."""
    original = forces_module.loads

    def wrong_axes(robot, kin):
        return tuple(forces_module.LoadValues(ld.body, ld.point, ld.force, ld.torque,
                                              "body" if ld.frame == "world" else "world")
                     for ld in original(robot, kin))

    monkeypatch.setattr(forces_module, "loads", wrong_axes)
    assert agree_with_oracle(1) > 0.1                               # measured 0.44


# -- 6. Kane against Lagrange, symbolically; compare can fail ------------------------------
@pytest.mark.parametrize("seed", [0, 1, 4])
def test_kane_and_lagrange_forces_are_equal_symbolically(seed):
    from anadyn_cli.services.compare import symbolic_check

    robot = robot_from_text(random_robot_yaml(seed, forces=True), f"random{seed}.yaml")
    kane, lagrange = derive(robot, "kane"), derive(robot, "lagrange")
    result = symbolic_check(kane, lagrange)
    assert result.status == "zero", result.describe()
    q = kane.joint_forces_and_loads
    assert sp.ImmutableMatrix(sp.expand(q - lagrange.joint_forces_and_loads)).is_zero_matrix


def test_compare_catches_a_wrong_force_term(tmp_path, capsys, monkeypatch):
    original = lagrange_module.generalized_forces

    def extra_damping(robot, kin):           # 1% more damping on q1, Lagrange only
        Q = sp.Matrix(original(robot, kin))
        Q[0] -= sp.Rational(2, 100) * kin.dq[0]
        return sp.ImmutableMatrix(Q)

    monkeypatch.setattr(lagrange_module, "generalized_forces", extra_damping)
    code, _, err = cli(capsys, "compare", ROBOTS / "rrt_friction.yaml", "--out", tmp_path,
                       "--no-cache", "--t-end", "1")
    assert code == 1
    assert err.startswith("anadyn: error: compare: rrt_friction: F[1] differs symbolically")


# -- 7. the energy balance, and that it can fail --------------------------------------------
def run_check(capsys, tmp_path, path, *options) -> tuple[int, dict, str]:
    out = tmp_path / "check"
    code, _, err = cli(capsys, "check", path, "--out", out, "--no-cache", *options)
    figures = json.loads((out / "check.json").read_text()) if (out / "check.json").exists() \
        else {}
    return code, figures, err


@pytest.mark.parametrize("computation", PATHS)
def test_energy_balance_holds_with_friction_springs_and_loads(tmp_path, capsys, computation):
    code, figures, err = run_check(capsys, tmp_path, ROBOTS / "rrt_friction.yaml",
                                   "--t-end", "5", *PATHS[computation])
    assert code == 0, err
    assert figures["energy_error"] < 1e-8                          # measured 5e-11
    assert figures["dissipated_final"] > 1.0                       # J: it is not vacuous
    assert figures["load_work_final"] != 0.0


def test_energy_balance_catches_a_wrong_dissipation_term_in_the_equations(
        tmp_path, capsys, monkeypatch):
    """Twice the damping and friction in F (the closed forms, through which
    ``symbolic.forces`` reaches the equations): the dissipated power, taken from the joint
    rates, no longer matches the energy lost."""
    original = forces_module.JointForce.dissipative
    monkeypatch.setattr(forces_module.JointForce, "dissipative",
                        lambda self, rate: 2 * original(self, rate))
    code, figures, err = run_check(capsys, tmp_path, ROBOTS / "rrt_friction.yaml",
                                   "--t-end", "5", "--formulation", "lagrange")
    assert code == 1 and figures["energy_error"] > 1e-3
    assert "energy balance" in err and "exceeds 1e-06" in err


@pytest.mark.parametrize("computation", PATHS)
def test_energy_balance_catches_a_wrong_dissipated_power(tmp_path, capsys, monkeypatch,
                                                         computation):
    from anadyn_cli.services import check as check_service

    original = check_service.path.external_powers
    def nothing_dissipated(model, t, x):
        out = original(model, t, x)
        out[1] = 0.0
        return out
    monkeypatch.setattr(check_service.path, "external_powers", nothing_dissipated)
    code, figures, _ = run_check(capsys, tmp_path, ROBOTS / "rrt_friction.yaml",
                                 "--t-end", "5", *PATHS[computation])
    assert code == 1 and figures["energy_error"] > 1e-3


# -- 8. inverse and the round trip --------------------------------------------------------
@pytest.mark.parametrize("computation", PATHS)
def test_inverse_efforts_overcome_friction_spring_and_load(tmp_path, capsys, computation):
    """rrt_friction has rrt's masses: its efforts differ from rrt's by exactly -Q(t, q, dq)
    (B = I), which holds the time-dependent load; the round trip still closes."""
    runs = {}
    for name in ("rrt", "rrt_friction"):
        out = tmp_path / name
        code, _, err = cli(capsys, "inverse", ROBOTS / f"{name}.yaml", "--out", out,
                           "--no-plot", "--no-cache", *PATHS[computation],
                           *(("--no-roundtrip",) if name == "rrt" else ()))
        assert code == 0, err
        runs[name] = columns(out / "inverse.csv")
    eom = derive(load_robot(ROBOTS / "rrt_friction.yaml"), "kane")
    a = runs["rrt_friction"]
    Q = _numbers([eom.joint_forces_and_loads], [T, *eom.q, *eom.dq],
                 [a["t"], a["q1"], a["q2"], a["q3"], a["dq1"], a["dq2"], a["dq3"]])[0]
    Q = np.broadcast_to(Q.reshape(3, -1), (3, len(a["t"])))
    for k, name in enumerate(("T01x", "T12y", "F23z")):
        difference = a[name] - runs["rrt"][name]
        assert np.abs(difference + Q[k]).max() <= 1e-9 * np.abs(a[name]).max()
    assert np.abs(Q).max() > 10                     # friction, spring and load matter
    summary = json.loads((tmp_path / "rrt_friction" / "inverse.json").read_text())
    assert summary["roundtrip"]["passed"] and summary["roundtrip"]["max_error"] < 1e-6


# -- 9. leave out what a scene does not need ---------------------------------------------
def test_a_robot_without_forces_generates_what_it_did():
    """Zero damping, friction and stiffness add nothing; no powers function, no tanh."""
    plain = robot_from_text(RR, "rr.yaml")
    zeros = robot_from_text(edit(RR, "displacement: q1}",
                                 "displacement: q1, damping: 0, friction: 0, stiffness: 0, "
                                 "rest: 0.3}"), "rr.yaml")
    for method in ("kane", "lagrange"):
        a, b = derive(plain, method), derive(zeros, method)
        assert a.Q is None and b.Q is None
        assert (a.M, a.F, a.B) == (b.M, b.F, b.B)
        code = closed_form.source(plain, a)
        assert code == closed_form.source(zeros, b)
        assert "def powers" not in code and "tanh" not in code


def test_friction_without_a_smoothing_velocity_uses_the_default(tmp_path):
    robot = robot_from_text(BLOCK, "block.yaml")
    (joint,) = forces_module.joint_forces(robot, kinematics.build(robot))
    assert joint.friction_velocity == sp.Rational(1, 100)
    assert derive(robot).F[0].has(sp.tanh(100 * sp.Symbol("dx", real=True)))


# -- 10. the equations show Q apart ------------------------------------------------------
def test_equations_show_joint_forces_and_loads_apart(tmp_path, capsys):
    path = write(tmp_path, PENDULUM.replace("damping: c}", "damping: c, friction: 0.4, "
                                                         "stiffness: 3, rest: -pi/2}")
                 + "loads:\n  - {body: bob, point: [L, 0, 0], force: [0, -2*sin(t), 0]}\n")
    code, out, err = cli(capsys, "equations", path)
    assert code == 0, err
    assert out.splitlines() == [
        "# kane equations, numeric parameters",
        "q1: 0.5*ddq1 + 9.81*cos(q1) - Q_q1 = 0",
        "# joint forces and loads: generalized forces Q, part of F",
        "Q_q1 = -0.3*dq1 - 3*q1 - sin(t)*cos(q1) - 0.4*tanh(100*dq1) - 1.5*pi",
    ]
    code, out, _ = cli(capsys, "equations", path, "--matrices", "--symbolic")
    assert "F[1] = -L*g*m*cos(q1) + Q[1]" in out
    assert "Q[1] = -2*L*sin(t)*cos(q1) - c*dq1 - 3*q1 - 2*tanh(100*dq1)/5 - 3*pi/2" in out


# -- 11. bad input ------------------------------------------------------------------------
LOADS = "loads:\n  - {body: bar2, point: [L2, 0, 0], force: [0, -10, 0]}\n"
BAD = [
    ("load-unknown-body", RR + LOADS.replace("body: bar2", "body: bar3"),
     "{file}:37: loads[0].body: unknown body 'bar3' (did you mean 'bar2'?); loads act on "
     "one of: bar1, bar2"),
    ("load-on-ground", RR + LOADS.replace("body: bar2", "body: ground"),
     "{file}:37: loads[0].body: unknown body 'ground'; loads act on one of: bar1, bar2"),
    ("load-point-two-numbers", RR + LOADS.replace("point: [L2, 0, 0]", "point: [L2, 0]"),
     "{file}:37: loads[0].point: expected a list of 3 components [x, y, z], got 2"),
    ("load-point-text", RR + LOADS.replace("point: [L2, 0, 0]", "point: tip"),
     "{file}:37: loads[0].point: expected a list, got the text 'tip'"),
    ("load-point-moves", RR + LOADS.replace("point: [L2, 0, 0]", "point: [q1, 0, 0]"),
     "{file}:37: loads[0].point[0]: 'q1' is a coordinate and cannot be used here; allowed "
     "here: L1, L2, g, m1, m2, pi"),
    ("load-nothing", RR + LOADS.replace(", point: [L2, 0, 0], force: [0, -10, 0]", ""),
     "{file}:37: loads[0]: a load needs a force, a torque or both, e.g. force: [0, 0, -50] "
     "(N) or torque: [0, 0, 2] (N*m)"),
    ("load-frame", RR + LOADS.replace("force: [0, -10, 0]}", "force: [0, -10, 0], "
                                                             "frame: tool}"),
     "{file}:37: loads[0].frame: must be one of world, body, got 'tool'"),
    ("load-uses-a-gain", RR + LOADS.replace("force: [0, -10, 0]", "force: [0, -b01, 0]"),
     "{file}:37: loads[0].force[1]: 'b01' is a controller gain and cannot be used here; "
     "allowed here: L1, L2, dq1, dq2, g, m1, m2, q1, q2, t, pi"),
    ("load-not-finite", RR + LOADS.replace("force: [0, -10, 0]", "force: [0, 1/(q1 + pi/18), "
                                                                 "0]"),
     "{file}:37: loads[0].force: the y component is not a finite real number at the "
     "initial state (q1 = -0.174533); it must be defined where the motion starts"),
    ("loads-not-a-list", RR + "loads: {body: bar2}\n",
     "{file}:36: loads: expected a list, got a mapping"),
    ("damping-negative", edit(RR, "displacement: q1}", "displacement: q1, damping: -0.5}"),
     "{file}:14: bodies[0].joint.damping: must be 0 or positive (N*m*s/rad), got -0.5"),
    ("stiffness-negative", edit(RR, "displacement: q2 - q1}",
                                "displacement: q2 - q1, stiffness: -2*m2}"),
     "{file}:20: bodies[1].joint.stiffness: must be 0 or positive (N*m/rad), got -2"),
    ("friction-negative", edit(RRT, "origin: [0, 0, L2]}", "origin: [0, 0, L2], "
                                                           "friction: -3}"),
     "{file}:27: bodies[2].joint.friction: must be 0 or positive (N), got -3"),
    ("friction-velocity-zero", edit(RR, "displacement: q1}",
                                    "displacement: q1, friction: 2, friction_velocity: 0}"),
     "{file}:14: bodies[0].joint.friction_velocity: must be positive (the joint rate, in "
     "rad/s, over which friction is smoothed), got 0"),
    ("friction-velocity-of-q", edit(RR, "displacement: q1}",
                                    "displacement: q1, friction_velocity: 0.01*dq1}"),
     "{file}:14: bodies[0].joint.friction_velocity: 'dq1' is the rate of coordinate 'q1' "
     "and cannot be used here; allowed here: L1, L2, g, m1, m2, pi"),
]


@pytest.mark.parametrize("name, text, error", BAD, ids=[b[0] for b in BAD])
def test_bad_forces_and_loads_are_one_line_and_exit_2(tmp_path, capsys, name, text, error):
    path = write(tmp_path, text, "bad.yaml")
    code, out, err = cli(capsys, "equations", path)
    assert (code, out) == (2, "")
    assert err == "anadyn: error: " + error.replace("{file}", str(path)) + "\n"


def test_a_fixed_joint_has_no_joint_forces(tmp_path, capsys):
    text = """\
name: fixed_damped
coordinates:
  q1: {}
bodies:
  - name: base
    joint: {type: revolute, axis: [0, 0, 1]}
    mass: 1
    com: [1, 0, 0]
  - name: tool
    parent: base
    joint: {type: fixed, origin: [1, 0, 0], damping: 0.3}
    mass: 1
"""
    path = write(tmp_path, text, "bad.yaml")
    code, out, err = cli(capsys, "equations", path)
    assert (code, out) == (2, "")
    assert err == (f"anadyn: error: {path}:11: bodies[1].joint.damping: a fixed joint does "
                   "not move, so it has no damping; remove it or make the joint revolute or "
                   "prismatic\n")
