"""anadyn optimize: Hermite-Simpson collocation checked by an independent integration of
Pinocchio's ABA under the optimized efforts, the limits by numeric.limits on the rows."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main

pytest.importorskip("casadi")
ROBOTS = Path(__file__).resolve().parent.parent / "robots"


def _rows(path: Path) -> dict:
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def _integrate(accelerations, rows: dict, efforts: list[str], start, span=None) -> np.ndarray:
    """x at the end of ``span`` [default: the whole motion] of q'' = accelerations(t, q, dq,
    u(t)) from ``start``, u quadratic on each interval through the knot, midpoint and knot
    values (as Hermite-Simpson assumes)."""
    from scipy.integrate import solve_ivp

    t = rows["t"]
    u = np.column_stack([rows[e] for e in efforts])
    n = len(start) // 2

    def effort(time):
        k = min(int(time / (t[2] - t[0])), len(t) // 2 - 1)
        a, m, b = u[2 * k], u[2 * k + 1], u[2 * k + 2]
        s = (time - t[2 * k]) / (t[2 * k + 2] - t[2 * k])
        return a * (1 - s) * (1 - 2 * s) + 4 * m * s * (1 - s) + b * s * (2 * s - 1)

    def rhs(time, x):
        return np.concatenate([x[n:], accelerations(time, x[:n], x[n:], effort(time))])

    return solve_ivp(rhs, span or (0, t[-1]), start, method="DOP853", rtol=1e-11,
                     atol=1e-12).y[:, -1]


def _optimize(robot: Path, out: Path, *options: str) -> tuple[dict, dict]:
    assert main(["optimize", str(robot), *options, "--out", str(out)]) == 0
    summary = json.loads((out / "optimize" / "optimize.json").read_text())
    assert summary["status"] == "Solve_Succeeded" and summary["defect"] < 1e-9
    return summary, _rows(out / "optimize" / "optimize.csv")


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_double_pendulum_reaches_goal_under_pinocchio(tmp_path):
    pin = pytest.importorskip("pinocchio")
    urdf = ROBOTS / "double_pendulum.urdf"
    _, rows = _optimize(urdf, tmp_path, "--to", "joint1=1.0,joint2=-0.5", "--duration", "1",
                        "--intervals", "60")
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()

    def aba(t, q, dq, tau):    # the URDF's joint damping 0.05 N m s/rad, which ABA leaves out
        return pin.aba(model, data, np.asarray(q), np.asarray(dq), tau - model.damping * dq)

    efforts = ["tau_joint1", "tau_joint2"]
    end = _integrate(aba, rows, efforts, np.zeros(4))
    assert np.allclose(end, [1.0, -0.5, 0.0, 0.0], atol=5e-3), end   # 3e-3 measured (N = 60)
    # the collocation's accelerations are Pinocchio's at every point
    for j in range(len(rows["t"])):
        q = np.array([rows["joint1"][j], rows["joint2"][j]])
        dq = np.array([rows["djoint1"][j], rows["djoint2"][j]])
        ddq = aba(0.0, q, dq, np.array([rows[e][j] for e in efforts]))
        assert np.allclose(ddq, [rows["ddjoint1"][j], rows["ddjoint2"][j]], atol=1e-8)


def test_cartpole_swing_up_under_kane_closed_forms(tmp_path):
    """The YAML cart-pole (no URDF for Pinocchio): integrated with Kane's closed forms,
    a different path from the traced recursive dynamics the optimizer uses."""
    import anadyn

    robot = ROBOTS / "optimize" / "cartpole.yaml"
    summary, rows = _optimize(robot, tmp_path, "--intervals", "40")
    kane = anadyn.numeric_model(str(robot), formulation="kane")
    assert kane.evaluator == "closed-form"
    end = _integrate(lambda t, q, dq, u: kane.driven_accelerations(t, np.concatenate([q, dq]), u),
                     rows, ["F"], np.array([0.0, -np.pi / 2, 0.0, 0.0]))
    assert np.allclose(end, [0.0, np.pi / 2, 0.0, 0.0], atol=5e-3), end   # 2.2e-3 measured
    assert np.all(np.abs(rows["x"]) <= 1.0) and np.all(np.abs(rows["F"]) <= 20.0)
    assert {(m["name"], m["quantity"]) for m in summary["margins"]} == {("x", "position"),
                                                                        ("F", "effort")}


@pytest.mark.parametrize("objective", ["effort", "time"])
def test_rr_swing_respects_limits_and_replays(tmp_path, objective):
    from anadyn_cli.model import load_robot
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import limits

    out = tmp_path / "o"
    robot = ROBOTS / "optimize" / "rr_swing.yaml"
    summary, _ = _optimize(robot, out, "--minimize", objective)
    assert summary["success"] and summary["goal_error"] < 1e-9
    assert all(m["margin"] > 0 for m in summary["margins"]) and len(summary["margins"]) == 6
    rows = _rows(out / "optimize" / "optimize.csv")
    q = np.column_stack([rows["q1"], rows["q2"]])
    dq = np.column_stack([rows["dq1"], rows["dq2"]])
    u = np.column_stack([rows["T01z"], rows["T12z"]])
    info = RobotInfo.from_robot(load_robot(robot))
    assert limits.check(info, rows["t"], q, dq, u) == []
    if objective == "time":    # bang-bang: some bound is active (the time is not free)
        assert min(m["margin"] for m in summary["margins"]) < 1e-3
    assert np.allclose(q[-1], [np.pi / 4, np.pi / 2]) and np.allclose(q[0], [-np.pi / 2] * 2)
    assert main(["inverse", str(robot), "--motion", str(out / "optimize" / "optimize.csv"),
                 "--no-plot", "--out", str(tmp_path / "i")]) == 0
    replay = _rows(tmp_path / "i" / "inverse.csv")
    assert np.allclose(replay["T01z"], rows["T01z"], atol=1e-7)


def test_unreachable_goal_and_failure(tmp_path, capsys):
    robot = str(ROBOTS / "optimize" / "rr_swing.yaml")
    assert main(["optimize", robot, "--to", "q1=4", "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"anadyn: error: {robot}: unreachable goal: q1 = 4 is outside "
                   "its limits [-3.14159, 3.14159]"]
    assert not (tmp_path / "a").exists()
    assert main(["optimize", robot, "--to", "q1=2,q2=2.5", "--duration", "0.3",
                 "--out", str(tmp_path / "b")]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("anadyn: error: optimization failed: IPOPT ")
    assert not json.loads((tmp_path / "b" / "optimize" / "optimize.json").read_text())["success"]
    assert main(["optimize", robot, "--to", "q9=1"]) == 2
    assert "--to names unknown coordinate 'q9'" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::UserWarning")
def test_ur5_point_to_point_under_pinocchio_and_limits(tmp_path):
    pin = pytest.importorskip("pinocchio")
    from anadyn_cli.model import load_robot
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import limits

    urdf = ROBOTS / "ur5.urdf"
    summary, rows = _optimize(urdf, tmp_path, "--to", "shoulder_pan_joint=1,shoulder_lift_"
                              "joint=-1,elbow_joint=1.2", "--duration", "2")
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    info = RobotInfo.from_robot(load_robot(urdf))
    names = [c.name for c in info.coordinates]
    efforts = [a.name for a in info.actuators]
    q = np.column_stack([rows[c] for c in names])
    dq = np.column_stack([rows["d" + c] for c in names])
    # each interval from its first knot reaches the next one: the local error of the
    # collocation (the whole motion, open loop, drifts away on the wrists' fast modes)
    t = rows["t"]
    for k in range(len(t) // 2):
        end = _integrate(lambda t, q, dq, u: pin.aba(model, data, q, dq, u - model.damping * dq),
                         rows, efforts, np.concatenate([q[2 * k], dq[2 * k]]),
                         (t[2 * k], t[2 * k + 2]))
        assert np.allclose(end, np.concatenate([q[2 * k + 2], dq[2 * k + 2]]), atol=0.1)  # 0.044
    u = np.column_stack([rows[e] for e in efforts])
    assert limits.check(info, rows["t"], q, dq, u) == []
    assert all(m["margin"] > 0 for m in summary["margins"])


def test_limit_expressions_in_casadi_equal_numeric_limits():
    """The bounds' expression trees (displacements, rates) built in CasADi evaluate as
    numeric.limits evaluates them (one-argument functions applied, n-ary ones folded)."""
    ca = pytest.importorskip("casadi")
    import sympy as sp

    from anadyn_cli.model.info import expression_tree
    from anadyn_cli.numeric.limits import _evaluate
    from anadyn_cli.services.optimize import _tree

    q1, q2 = sp.symbols("q1 q2")
    expr = (sp.sin(q1) * sp.Max(q2, 0.1, q1) + sp.atan2(q1, q2) ** 2 - sp.Abs(q2)
            + sp.exp(-q1) + sp.Min(q1, q2) * sp.cos(q2) + sp.tanh(q1 * q2) + sp.sign(q2))
    tree = expression_tree(expr)
    for a, b in ((0.3, -0.7), (-1.2, 0.4), (2.0, 2.5)):
        got = float(_tree(ca, tree, {"q1": ca.DM(a), "q2": ca.DM(b)}))
        assert got == pytest.approx(_evaluate(tree, {"q1": np.array([a]), "q2": np.array([b])},
                                              1)[0], rel=1e-14)


def test_optimized_robot_file_replays(tmp_path):
    """NAME_optimized.yaml holds the motion as a spline trajectory (quintics through q, dq,
    ddq at the points): ``inverse`` on it gives the optimized efforts at every point."""
    import yaml

    robot = ROBOTS / "optimize" / "rr_swing.yaml"
    _, rows = _optimize(robot, tmp_path / "o", "--intervals", "6")
    folder = tmp_path / "o" / "optimize"
    section = yaml.safe_load((folder / "trajectory.yaml").read_text())["trajectory"]
    assert section["kind"] == "spline" and section["times"] == list(rows["t"])
    step = str(rows["t"][1])
    assert main(["inverse", str(folder / "rr_swing_optimized.yaml"), "--no-roundtrip",
                 "--no-plot", "--no-cache", "--dt", step, "--out", str(tmp_path / "i")]) == 0
    replay = _rows(tmp_path / "i" / "inverse.csv")
    assert np.allclose(replay["t"], rows["t"], atol=1e-12)
    for name in ("q1", "dq2", "ddq1", "T01z", "T12z"):
        assert np.allclose(replay[name], rows[name], rtol=1e-9, atol=1e-9), name


def test_simulate_tracks_the_optimized_motion_with_the_files_laws(tmp_path):
    """NAME_optimized.yaml's control laws (the optimized efforts plus a PD about the
    motion, ``services.optimize.tracking``) make ``simulate`` follow the RR swing:
    within 5e-3 rad of the optimized motion (its cubic Hermite interpolant) over the
    2 s, and 1 s later within 1e-3 rad of the goal and 1e-2 rad/s of rest (measured
    1.4e-3 rad, 5e-5 rad, 1.2e-4 rad/s).  Without the laws (no controller: no
    efforts) the arm falls from the start."""
    import yaml
    from scipy.interpolate import CubicHermiteSpline

    import anadyn

    _, rows = _optimize(ROBOTS / "optimize" / "rr_swing.yaml", tmp_path / "o")
    optimized = tmp_path / "o" / "optimize" / "rr_swing_optimized.yaml"
    controller = yaml.safe_load(optimized.read_text())["controller"]
    assert set(controller["laws"]) == {"T01z", "T12z"}
    T = rows["t"][-1]
    run = anadyn.simulate(optimized, t_end=T + 1.0, output_step=0.01)
    during = run.t <= T + 1e-9
    for i, name in enumerate(("q1", "q2")):
        reference = CubicHermiteSpline(rows["t"], rows[name], rows["d" + name])(run.t[during])
        assert np.abs(run.x[during, i] - reference).max() < 5e-3, name
        assert abs(run.x[-1, i] - rows[name][-1]) < 1e-3, name
        assert abs(run.x[-1, 2 + i]) < 1e-2, name


@pytest.mark.parametrize("change, message", [
    ("times: [0, 1, 1]", "trajectory.times: times must increase"),
    ("times: [0.5, 1, 2]", "trajectory.times: at least two times, the first 0"),
    ("q: {q1: [0, 1]}", "trajectory.q.q1: one value per time: 3 times, got 2 values"),
    ("q: {q1: [0, x, 1]}", "trajectory.q.q1[1]: expected a finite number, got 'x'"),
    ("q: {q9: [0, 1, 1]}", "trajectory.q.q9: unknown coordinate 'q9'"),
    ("dq: {}", "trajectory.dq: q1 has q, dq and ddq or none of them; dq is missing"),
])
def test_spline_trajectory_refuses_bad_samples(tmp_path, change, message, capsys):
    base = {"times": "times: [0, 1, 2]", "q": "q: {q1: [0, 0.5, 1]}",
            "dq": "dq: {q1: [0, 1, 0]}", "ddq": "ddq: {q1: [0, 0, 0]}"}
    base[change.split(":")[0]] = change
    text = (ROBOTS / "rr.yaml").read_text().replace(
        "trajectory: {kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}",
        "trajectory:\n  kind: spline\n" + "".join(f"  {v}\n" for v in base.values()))
    path = tmp_path / "rr.yaml"
    path.write_text(text)
    assert main(["inverse", str(path), "--no-plot", "--out", str(tmp_path / "i")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"anadyn: error: {path}:") and message in err and err.count("\n") == 1
