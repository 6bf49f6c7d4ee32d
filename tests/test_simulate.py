"""`anadyn simulate`: trajectories against independent sources, and the CLI contract.

The independent sources:

* ``sympy.physics.mechanics`` (``mechanics_oracle.py``: KanesMethod built from
  the YAML text alone, nothing from anadyn), with the chapter's feedback laws
  written out by hand below from the design guide (section 2), its
  accelerations from mass_matrix/forcing lambdified and integrated by SciPy's
  DOP853 at rtol 1e-12, atol 1e-14;
* Lagrange's equations against Kane's method;
* the exact period of a physical pendulum, 4 K(sin^2(A/2)) / w0 (complete
  elliptic integral), and its small-angle limit 2 pi sqrt(I_pivot / (m g d));
* conservation of T + V for passive, undamped arms, and T, V by hand;
* the fall time of a pendulum by quadrature (a cubic joint makes M singular
  where the fall ends);
* a counting wrapper around ``CompiledRobot.rhs``, and the Jacobian
  eigenvalues of the oracle by finite differences.

The expensive runs (anadyn's default runs, the DOP853 references) are cached
for the test session.
"""
from __future__ import annotations

import functools
import math
import re
from math import cos, pi, sin
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
import yaml
from scipy.integrate import quad, solve_ivp
from scipy.interpolate import CubicHermiteSpline
from scipy.special import ellipk

from anadyn_cli import load_robot, robot_from_text
from anadyn_cli.services import simulate as service
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.cli import main

from mechanics_oracle import oracle_equations
from scenes import cubic_text

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
G = 9.81
GRID = np.arange(1501) * 0.01          # the robots' own 0..15 s, dt 0.01
METHODS = ["auto", "odeint", "RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"]


@pytest.fixture(scope="module", autouse=True)
def _private_cache(tmp_path_factory):
    """Keep the derivation cache of these tests out of the user's ~/.cache."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ANADYN_CACHE_DIR", str(tmp_path_factory.mktemp("anadyn-cache")))
        yield


def run_cli(capsys, *args) -> tuple[int, str, str]:
    code = main(["simulate", *map(str, args)])
    out, err = capsys.readouterr()
    return code, out, err


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path) as stream:
        header = stream.readline().rstrip("\n").split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


# -- the chapter's scenes, by hand from GUIDE section 2 -----------------------
def rr_laws(q, dq) -> dict:
    L1 = L2 = m1 = m2 = 1.0
    b01, g01, b12, g12, q1f, q2f = 450, 300, 200, 300, pi / 6, pi / 3
    return {"T01z": -b01 * dq[0] - g01 * (q[0] - q1f) + 0.5 * G * L1 * m1 * cos(q[0])
                    + G * L1 * m2 * cos(q[0]),
            "T12z": -b12 * dq[1] - g12 * (q[1] - q2f) + 0.5 * G * L2 * m2 * cos(q[1])}


def rrt_laws(q, dq) -> dict:
    L2, m2, m3 = 0.4, 60.0, 40.0
    b01, g01, b12, g12, b23, g23 = 450, 300, 200, 300, 150, 50
    q1f, q2f, q3f = pi / 3, pi / 3, 0.3
    return {"T01x": -b01 * dq[0] - g01 * (q[0] - q1f),
            "T12y": -b12 * dq[1] - g12 * (q[1] - q2f)
                    + G * (m2 * L2 + m3 * (L2 + q[2])) * cos(q[1]),
            "F23z": -b23 * dq[2] - g23 * (q[2] - q3f) + G * m3 * sin(q[1])}


CHAPTER = {"rr": (np.array([-pi / 18, pi / 6, 0, 0]), rr_laws),
           "rrt": (np.array([pi / 18, pi / 6, 0.25, 0, 0, 0]), rrt_laws)}


class Oracle:
    """x' = [dq, M^-1 (F + B tau)] from sympy.physics.mechanics' M, F, B."""

    def __init__(self, text: str, laws=None):
        q, dq, tau, M, F, B = oracle_equations(text)
        self.n, self.laws = len(q), laws
        self.effort_names = [str(s) for s in tau]
        self._mfb = sp.lambdify([*q, *dq], [M, F, B], modules="numpy", cse=True)

    def rhs(self, t, x):
        n = self.n
        M, F, B = (np.asarray(a, dtype=float) for a in self._mfb(*x))
        G_ = F.reshape(n)
        if self.laws is not None:
            tau = self.laws(x[:n], x[n:])
            G_ = G_ + B.reshape(n, -1) @ np.array([tau[name] for name in self.effort_names])
        return np.concatenate([x[n:], np.linalg.solve(M.reshape(n, n), G_)])

    def trajectory(self, x0, grid) -> np.ndarray:
        sol = solve_ivp(self.rhs, (grid[0], grid[-1]), x0, method="DOP853", t_eval=grid,
                        rtol=1e-12, atol=1e-14)
        assert sol.success, sol.message
        return sol.y.T

    def jacobian(self, x, h=1e-6) -> np.ndarray:
        """Central differences of the state derivative."""
        columns = []
        for j in range(len(x)):
            step = np.zeros(len(x))
            step[j] = h
            columns.append((self.rhs(0.0, x + step) - self.rhs(0.0, x - step)) / (2 * h))
        return np.column_stack(columns)


@functools.lru_cache(maxsize=None)
def chapter_oracle(name: str) -> Oracle:
    return Oracle((ROBOTS / f"{name}.yaml").read_text(), CHAPTER[name][1])


@functools.lru_cache(maxsize=None)
def reference(name: str) -> np.ndarray:
    """The oracle's states on GRID from the chapter's initial state."""
    return chapter_oracle(name).trajectory(CHAPTER[name][0], GRID)


@functools.lru_cache(maxsize=None)
def default_run(name: str, formulation: str | None = None) -> service.SimulationResult:
    return service.simulate(numeric_model(ROBOTS / f"{name}.yaml", formulation))


def without(name: str, *sections: str) -> str:
    """A book robot's YAML without some top-level sections."""
    data = yaml.safe_load((ROBOTS / f"{name}.yaml").read_text())
    for section in sections:
        data.pop(section)
    return yaml.safe_dump(data, sort_keys=False)


# -- 1, 2: the chapter's scenes ------------------------------------------------
@pytest.mark.parametrize("name", ["rr", "rrt"])
def test_default_run_matches_the_mechanics_oracle(name):
    result = default_run(name)
    s = result.settings
    assert (s.method, s.rtol, s.atol, s.t_end, s.output_step) == ("auto", 1e-10, 1e-12, 15, 0.01)
    assert result.solution.success, result.solution.message
    assert np.array_equal(result.t, GRID)
    error = np.abs(result.x - reference(name)).max(axis=0)
    assert error.max() < 1e-8, f"max |anadyn - oracle| per state: {error}"


def test_rr_settles_where_the_chapters_laws_put_it():
    """The laws leave q1 short of q1f by T12z/g01 (GUIDE: 'near 0.515 rad')."""
    q1, q2 = default_run("rr").x[-1, :2]
    assert q2 == pytest.approx(pi / 3, abs=1e-6)
    assert q1 == pytest.approx(pi / 6 - 0.5 * G * cos(pi / 3) / 300, abs=1e-4)


@pytest.mark.parametrize("name", ["rr", "rrt"])
def test_recursive_and_lagrange_closed_form_trajectories_agree(name):
    recursive, lagrange = default_run(name), default_run(name, "lagrange")
    assert recursive.solution.success and lagrange.solution.success
    assert np.array_equal(recursive.t, lagrange.t)
    assert np.abs(recursive.x - lagrange.x).max() < 1e-8
    scale = max(1.0, np.abs(recursive.efforts).max())
    assert np.abs(recursive.efforts - lagrange.efforts).max() < 1e-8 * scale


# -- 3: a passive pendulum -------------------------------------------------------
PENDULUM = dict(m=2.0, L=0.8)      # a homogeneous rod, pivot at one end


def pendulum_text(amplitude: float, carriage: bool) -> str:
    """A rod hanging from a revolute joint (q1 = 0 straight down), released at rest.

    With ``carriage`` the pivot rides on a prismatic joint along z, across the
    plane of the swing: that coordinate is decoupled and stays at rest.
    """
    if carriage:
        coordinates = f"  s: {{initial: 0}}\n  q1: {{initial: {amplitude!r}}}\n"
        bodies = ("  - name: carriage\n"
                  "    joint: {type: prismatic, axis: [0, 0, 1], displacement: s}\n"
                  "    mass: 3\n"
                  "  - name: rod\n"
                  "    parent: carriage\n")
    else:
        coordinates = f"  q1: {{initial: {amplitude!r}}}\n"
        bodies = "  - name: rod\n"
    return (f"name: pendulum\n"
            f"parameters: {{m: {PENDULUM['m']}, L: {PENDULUM['L']}, g: {G}}}\n"
            f"gravity: [0, -g, 0]\n"
            f"coordinates:\n{coordinates}"
            f"bodies:\n{bodies}"
            f"    joint: {{type: revolute, axis: [0, 0, 1], displacement: q1}}\n"
            f"    mass: m\n"
            f"    com: [0, -L/2, 0]\n"
            f"    inertia: {{ixx: m*L**2/12, izz: m*L**2/12}}\n"
            f"simulation: {{t_end: 12, output_step: 0.01}}\n")


def measured_period(t, q, dq) -> float:
    """From the zero crossings of q (cubic Hermite in q, dq between rows): they
    are half a period apart; fit a line through all of them."""
    crossings = CubicHermiteSpline(t, q, dq).roots(extrapolate=False)
    assert len(crossings) >= 10, crossings
    k = np.arange(len(crossings))
    slope, start = np.polyfit(k, crossings, 1)
    assert np.abs(crossings - (start + slope * k)).max() < 1e-8 * slope   # evenly spaced
    return 2 * slope


@pytest.mark.parametrize("carriage", [False, True], ids=["fixed pivot", "on a carriage"])
@pytest.mark.parametrize("amplitude", [0.01, 1.0])
def test_pendulum_period(amplitude, carriage):
    m, L = PENDULUM["m"], PENDULUM["L"]
    robot = robot_from_text(pendulum_text(amplitude, carriage), "pendulum.yaml")
    result = service.simulate(numeric_model(robot))
    assert result.solution.success, result.solution.message
    assert result.efforts.shape == (len(result.t), 0)
    i = 1 if carriage else 0
    n = 2 if carriage else 1
    if carriage:        # the carriage is not pushed along z
        assert np.abs(result.x[:, [0, n]]).max() == 0
    period = measured_period(result.t, result.x[:, i], result.x[:, n + i])

    inertia, d = m * L**2 / 3, L / 2                   # about the pivot; pivot to centre
    small_angle = 2 * pi * math.sqrt(inertia / (m * G * d))
    exact = 2 / pi * small_angle * ellipk(sin(amplitude / 2) ** 2)
    assert abs(period / exact - 1) < 1e-8
    if amplitude == 0.01:       # correction ~ A^2/16 = 6.3e-6
        assert abs(period / small_angle - 1) < 1e-5
    else:                       # and the measurement does see the nonlinearity
        assert period / small_angle - 1 > 0.06


def test_one_coordinate_robot_has_a_square_mass_matrix():
    """M is n x n also for n = 1 (codegen once made it a vector of length 1, and
    np.linalg.solve then reported a 'singular mass matrix' for every 1-DOF robot)."""
    robot = robot_from_text(pendulum_text(0.5, carriage=False), "pendulum.yaml")
    compiled = numeric_model(robot, evaluator="recursive")
    M, F, B = compiled.mfb(0.0, np.array([0.5]), np.array([0.0]))
    assert np.shape(M) == (1, 1) and np.shape(F) == (1,) and np.shape(B) == (1, 0)
    m, L = PENDULUM["m"], PENDULUM["L"]
    expected = -m * G * (L / 2) * sin(0.5) / (m * L**2 / 3)
    assert compiled.accelerations(0.0, np.array([0.5, 0.0])) == pytest.approx([expected])


# -- 4: energy of passive arms -------------------------------------------------
ARM_3D = """\
name: arm3d
description: passive spatial two-link arm (the RRT arm's links 1 and 2), spinning
parameters: {L1: 0.4, L2: 0.4, m1: 90, m2: 60, g: 9.81}
gravity: [-g, 0, 0]
coordinates:
  q1: {initial: pi/18, rate: 2}
  q2: {initial: pi/6, rate: -1}
bodies:
  - name: link1
    joint: {type: revolute, axis: [1, 0, 0]}
    mass: m1
    com: [0, 0, L1]
    inertia: {ixx: m1*(2*L1)**2/12, iyy: m1*(2*L1)**2/12}
  - name: link2
    parent: link1
    joint: {type: revolute, axis: [0, 1, 0], origin: [0, 0, 2*L1]}
    mass: m2
    com: [0, 0, L2]
    inertia: {ixx: m2*(2*L2)**2/12, iyy: m2*(2*L2)**2/12}
simulation: {t_end: 15, output_step: 0.01}
"""


def rr_energy_by_hand(q, dq):
    """T and V of the chapter's RR bars (L = 1 m, m = 1 kg), V = 0 at the base."""
    L1 = L2 = m1 = m2 = 1.0
    q1, q2, d1, d2 = q[0], q[1], dq[0], dq[1]
    y1, y2 = L1 / 2 * np.sin(q1), L1 * np.sin(q1) + L2 / 2 * np.sin(q2)
    v2_squared = L1**2 * d1**2 + (L2 / 2) ** 2 * d2**2 + L1 * L2 * d1 * d2 * np.cos(q2 - q1)
    T = (0.5 * m1 * (L1 / 2) ** 2 * d1**2 + 0.5 * m1 * L1**2 / 12 * d1**2
         + 0.5 * m2 * v2_squared + 0.5 * m2 * L2**2 / 12 * d2**2)
    return T, G * (m1 * y1 + m2 * y2)


@functools.lru_cache(maxsize=None)
def passive_run(case: str):
    text = without("rr", "actuators", "controller", "trajectory") if case == "rr" else ARM_3D
    robot = robot_from_text(text, f"{case}_passive.yaml")
    compiled = numeric_model(robot, evaluator="recursive")
    return service.simulate(compiled), compiled


@pytest.mark.parametrize("case", ["rr", "arm3d"])
def test_passive_arm_keeps_its_energy(case):
    """|E(t) - E(0)| within 1e-8 of the energy that moves (max T): V's zero is arbitrary."""
    result, compiled = passive_run(case)
    assert result.solution.success and result.t[-1] == 15
    n = compiled.n
    T, V = compiled.energy(result.x[:, :n].T, result.x[:, n:].T)
    E = T + V
    assert T.max() > 10              # it really moves (J)
    assert np.abs(E - E[0]).max() / T.max() < 1e-8


def test_rr_energy_by_hand():
    result, compiled = passive_run("rr")
    q, dq = result.x[:, :2].T, result.x[:, 2:].T
    T, V = compiled.energy(q, dq)
    T_hand, V_hand = rr_energy_by_hand(q, dq)
    assert np.abs(T - T_hand).max() < 1e-12 * T_hand.max()
    assert np.abs(V - V_hand).max() < 1e-12 * np.abs(V_hand).max()


# -- 5: numerical failures ----------------------------------------------------
def fall_time(angle: float) -> float:
    """Time for the bar (pivot at an end, I = m L^2/3) released at rest at
    ``angle`` above the horizontal to reach the horizontal:
    1/2 I w^2 = m g L/2 (sin angle - sin theta)."""
    m, L = 1.0, 1.0
    factor = math.sqrt((m * L**2 / 3) / (2 * m * G * L / 2))

    def f(theta):    # the integrand times sqrt(angle - theta), smooth up to the end
        return (math.sqrt((angle - theta) / (sin(angle) - sin(theta))) if theta < angle
                else 1 / math.sqrt(cos(angle)))
    value, _ = quad(f, 0, angle, weight="alg", wvar=(0, -0.5))
    return factor * value


STATE = r"\(s=(\S+), q1=(\S+), ds=(\S+), dq1=(\S+)\)"


@pytest.fixture
def good_result(tmp_path, capsys):
    """An out folder holding a good rr result, and the bytes of its simulate.csv."""
    out = tmp_path / "out"
    assert run_cli(capsys, ROBOTS / "rr.yaml", "--t-end", 0.5, "--no-plot", "--out", out)[0] == 0
    return out, (out / "simulate.csv").read_bytes()


@pytest.mark.parametrize("method", ["auto", "RK45", "Radau"])
def test_mass_matrix_singular_mid_run(tmp_path, capsys, good_result, method):
    out, before = good_result
    robot = tmp_path / "cubic.yaml"
    robot.write_text(cubic_text(0.8))
    code, out_text, err = run_cli(capsys, robot, "--out", out, "--no-plot", "--method", method)
    assert code == 3 and out_text == ""
    crossing = fall_time(0.8**3)          # q1 -> 0 as the bar reaches the horizontal
    rows = int(crossing / 0.01) + 1
    match = re.fullmatch(rf"anadyn: error: {re.escape(str(robot))}: .* at t = (\S+) s, "
                         rf"state {STATE}; {rows} rows before it in "
                         rf"{re.escape(str(out / 'simulate.partial.csv'))}\n", err)
    assert match, err
    assert abs(float(match[1]) - crossing) < 1e-3
    assert abs(float(match[3])) < 1e-3                    # q1 at the failure
    assert (out / "simulate.csv").read_bytes() == before   # the earlier result stays
    header, partial = read_csv(out / "simulate.partial.csv")
    assert header == ["t", "s", "q1", "ds", "dq1"]
    assert len(partial) == rows and np.isfinite(partial).all()
    assert np.array_equal(partial[:, 0], np.arange(rows) * 0.01)


@pytest.mark.parametrize("method", ["auto", "RK45", "Radau", "BDF", "LSODA"])
def test_mass_matrix_singular_at_the_start(tmp_path, capsys, method):
    robot, out = tmp_path / "cubic0.yaml", tmp_path / "fresh"
    robot.write_text(cubic_text(0.0))
    code, _, err = run_cli(capsys, robot, "--out", out, "--no-plot", "--method", method)
    assert err == (f"anadyn: error: {robot}: singular mass matrix at t = 0 s, state "
                   f"(s=0, q1=0, ds=0, dq1=0); 1 rows before it in "
                   f"{out / 'simulate.partial.csv'}\n")
    assert code == 3
    assert not (out / "simulate.csv").exists() and not (out / "simulate.json").exists()
    header, partial = read_csv(out / "simulate.partial.csv")
    assert header == ["t", "s", "q1", "ds", "dq1"] and partial.tolist() == [[0, 0, 0, 0, 0]]


# -- 6: the CSV and the command line ------------------------------------------
def test_csv_header_grid_and_full_precision(tmp_path, capsys):
    code, out, _ = run_cli(capsys, ROBOTS / "rr.yaml", "--out", tmp_path, "--no-plot")
    assert code == 0
    header, data = read_csv(tmp_path / "simulate.csv")
    assert header == ["t", "q1", "q2", "dq1", "dq2", "T01z", "T12z"]
    assert np.array_equal(data[:, 0], np.arange(1501) * 0.01)       # bit for bit
    expected = default_run("rr")                # in memory, same settings
    assert np.array_equal(data[:, 1:5], expected.x)
    assert np.array_equal(data[:, 5:], expected.efforts)
    efforts = np.array([list(rr_laws(x[:2], x[2:]).values()) for x in expected.x])
    assert np.abs(data[:, 5:] - efforts).max() < 1e-9           # the laws, by hand


def test_write_round_trips_the_result_exactly(tmp_path):
    result = service.simulate(numeric_model(ROBOTS / "rrt.yaml"), t_end=2.0, output_step=0.03)
    service.write(result, tmp_path, plot=False)
    header, data = read_csv(tmp_path / "simulate.csv")
    assert header == ["t", "q1", "q2", "q3", "dq1", "dq2", "dq3", "T01x", "T12y", "F23z"]
    assert np.array_equal(data[:, 0], np.arange(67) * 0.03)        # 66 * 0.03 <= 2
    assert np.array_equal(data[:, 1:7], result.x)
    assert np.array_equal(data[:, 7:], result.efforts)


def test_table_at_whole_seconds(tmp_path, capsys):
    """15 s: a row every second (the round step giving at most 15 steps), with units."""
    code, out, _ = run_cli(capsys, ROBOTS / "rr.yaml", "--out", tmp_path, "--no-plot")
    assert code == 0
    lines = out.splitlines()
    assert lines[0].split() == ["t", "(s)", "q1", "(rad)", "dq1", "(rad/s)", "q2", "(rad)",
                                "dq2", "(rad/s)"]
    _, data = read_csv(tmp_path / "simulate.csv")
    for second in range(16):
        t, q1, q2, dq1, dq2 = data[100 * second, :5]
        assert lines[1 + second] == "  ".join(
            [f"{t:>12g}"] + [f"{round(v, 6) + 0.0:>12.6f}" for v in (q1, dq1, q2, dq2)])
    assert lines[17].startswith("method: auto -> odeint: ")
    assert lines[1].split() == ["0", "-0.174533", "0.000000", "0.523599", "0.000000"]


@pytest.mark.parametrize("method", METHODS)
def test_every_method_agrees_with_the_default_run(tmp_path, capsys, method):
    """rtol 1e-10 (the default) for every method: within 100 rtol of the default run."""
    code, out, _ = run_cli(capsys, ROBOTS / "rr.yaml", "--method", method, "--t-end", 0.5,
                           "--out", tmp_path, "--no-plot")
    assert code == 0
    shown = re.search(r"^method: (.*)$", out, re.M)[1]
    assert shown.startswith("auto -> odeint: ") if method == "auto" else shown == method
    assert re.search(r"^rhs calls \d+, jacobian calls \d+, steps \d+, rtol 1e-10, atol 1e-12$",
                     out, re.M)
    _, data = read_csv(tmp_path / "simulate.csv")
    assert np.array_equal(data[:, 0], np.arange(51) * 0.01)
    assert np.abs(data[:, 1:5] - default_run("rr").x[:51]).max() < 100 * 1e-10


def test_unknown_method_lists_the_choices(tmp_path, capsys):
    code, out, err = run_cli(capsys, ROBOTS / "rr.yaml", "--method", "euler", "--out", tmp_path / "o")
    assert (code, out) == (2, "")
    assert err == ("anadyn: error: unknown method 'euler'; choose one of auto, odeint, RK45, "
                   "RK23, DOP853, Radau, BDF, LSODA\n")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("options, message", [
    (["--t-end", "0"], "--t-end must be a positive number, got 0"),
    (["--t-end", "-1"], "--t-end must be a positive number, got -1"),
    (["--t-end", "nan"], "--t-end must be a positive number, got nan"),
    (["--dt", "-0.01"], "--dt must be a positive number, got -0.01"),
    (["--dt", "0"], "--dt must be a positive number, got 0"),
    (["--rtol", "0"], "--rtol must be a number greater than 0 and less than 1, got 0"),
    (["--atol", "inf"], "--atol must be a number of at least 1e-100 and less than 1 (below it "
                        "the integrators' error norms, which square error / atol, overflow), "
                        "got inf"),
    (["--dt", "2", "--t-end", "1"], "output step 2 s is longer than t_end 1 s"),
])
def test_bad_horizon_or_step_is_a_usage_error(tmp_path, capsys, options, message):
    code, out, err = run_cli(capsys, ROBOTS / "rr.yaml", *options, "--out", tmp_path / "o")
    assert (code, out, err) == (2, "", f"anadyn: error: {message}\n")
    assert not (tmp_path / "o").exists()


# -- 7: passive motion ----------------------------------------------------------
def test_no_actuators_no_effort_columns(tmp_path, capsys):
    robot = tmp_path / "rr_bare.yaml"
    robot.write_text(without("rr", "actuators", "controller", "trajectory"))
    assert run_cli(capsys, robot, "--t-end", 1, "--out", tmp_path, "--no-plot")[0] == 0
    header, data = read_csv(tmp_path / "simulate.csv")
    assert header == ["t", "q1", "q2", "dq1", "dq2"] and data.shape == (101, 5)


def test_actuators_without_controller_move_passively_with_zero_efforts(tmp_path, capsys):
    """Against the oracle with tau = 0 (1 s: the free double pendulum is chaotic)."""
    text = without("rr", "controller")
    robot = tmp_path / "rr_unc.yaml"
    robot.write_text(text)
    assert run_cli(capsys, robot, "--t-end", 1, "--out", tmp_path, "--no-plot")[0] == 0
    header, data = read_csv(tmp_path / "simulate.csv")
    assert header == ["t", "q1", "q2", "dq1", "dq2", "T01z", "T12z"]
    assert np.all(data[:, 5:] == 0)
    grid = np.arange(101) * 0.01
    expected = Oracle(text).trajectory(CHAPTER["rr"][0], grid)
    assert np.abs(data[:, 1:5] - expected).max() < 1e-8
    # and it is not the controlled motion
    assert np.abs(data[:, 1:5] - default_run("rr").x[:101]).max() > 0.1


# -- 8: work counts and the stiffness analysis -----------------------------------
@pytest.mark.parametrize("method", METHODS)
def test_rhs_calls_are_the_calls_made(method):
    robot = load_robot(ROBOTS / "rr.yaml")
    compiled = numeric_model(robot, evaluator="recursive")
    made = {"rhs": 0, "jacobian": 0}
    rhs, jacobian = compiled.rhs, compiled.jacobian

    def counted_rhs(t, x):
        made["rhs"] += 1
        return rhs(t, x)

    def counted_jacobian(t, x):
        made["jacobian"] += 1
        return jacobian(t, x)

    compiled.rhs, compiled.jacobian = counted_rhs, counted_jacobian
    result = service.simulate(compiled, method=method, t_end=0.5)
    assert result.solution.success
    assert made["rhs"] > 0 and result.solution.rhs_calls == made["rhs"]
    # auto's stiffness analysis evaluates the Jacobian once before the run
    probe = 1 if method == "auto" else 0
    assert result.solution.jacobian_calls == made["jacobian"] - probe
    if method in ("RK45", "RK23", "DOP853"):
        assert made["jacobian"] == 0


@pytest.mark.parametrize("name, verdict", [("rr", "stiff"), ("rrt", "not stiff")])
def test_auto_reports_stiffness(name, verdict):
    solution = default_run(name).solution
    assert solution.method == "odeint"
    match = re.match(r"fastest time constant (\S+) s over a 15 s horizon \(ratio (\S+)\): "
                     r"(stiff|not stiff); ", solution.reason)
    assert match and match[3] == verdict, solution.reason
    # the oracle's Jacobian eigenvalues at the start, by finite differences
    eigenvalues = np.linalg.eigvals(chapter_oracle(name).jacobian(CHAPTER[name][0]))
    fastest = np.abs(eigenvalues.real).max()
    assert float(match[1]) == pytest.approx(1 / fastest, rel=1e-2)
    assert float(match[2]) == pytest.approx(15 * fastest, rel=1e-2)


@pytest.mark.parametrize("unrolled_max", [10, 0], ids=["unrolled Cholesky", "numpy solve"])
def test_generated_solver_matches_a_dense_solve(monkeypatch, unrolled_max):
    """codegen.solver_source (the unrolled Cholesky, and numpy past UNROLLED_MAX)
    against numpy.linalg.solve on M and G = F + B tau from SymPy's own lambdify,
    for random robots of 2 to 6 coordinates at random states and efforts."""
    import sympy as sp

    from anadyn_cli import derive, robot_from_text
    from anadyn_cli.numeric import codegen
    from random_robots import random_robot_yaml

    monkeypatch.setattr(codegen, "UNROLLED_MAX", unrolled_max)
    rng = np.random.default_rng(7)
    for seed in (0, 5, 11, 10, 19, 26):                 # n = 2, 3, 4, 5, 6, 6
        eom = derive(robot_from_text(random_robot_yaml(seed), "r.yaml"))
        n, m = len(eom.q), len(eom.efforts)
        args = (*eom.q, *eom.dq, *eom.efforts)
        G = list(eom.F + eom.B * sp.Matrix(eom.efforts))
        namespace: dict = {}
        exec("import math, numpy\n" + "\n".join(codegen.solver_source(   # noqa: S102
            "solve", args, eom.M, G, "test")), namespace)
        dense = sp.lambdify(args, (eom.M, sp.Matrix(G)), modules="numpy", cse=True)
        for _ in range(4):
            values = rng.normal(size=2 * n + m).tolist()
            M, rhs = dense(*values)
            expected = np.linalg.solve(np.asarray(M, float), np.asarray(rhs, float).ravel())
            got = np.array(namespace["solve"](*values))
            assert np.abs(got - expected).max() <= 1e-12 * max(1.0, np.abs(expected).max())
