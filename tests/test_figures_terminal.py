"""Figures for reports, a terminal that fits, messages for newcomers, motor sizing
(issue 23, items 3, 4 and 7).

Every number is checked against an independent source: the cycloid's closed
form (peak rate 2 (qf - q0) / T, zero rate and acceleration at the poses),
the CSV's own columns (RMS by the trapezoidal rule, power as effort x joint
rate with the chapter's joint rate dq2 - dq1 for T12z), the RRT arm without
payload (a 0 kg payload must give the same efforts).
"""
from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.output import tables

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ROOT / "robots"
RR, RRT = ROBOTS / "rr.yaml", ROBOTS / "rrt.yaml"


def read_csv(path: Path) -> dict[str, np.ndarray]:
    rows = list(csv.reader(path.open()))
    data = np.array(rows[1:], dtype=float)
    return {name: data[:, k] for k, name in enumerate(rows[0])}


def one_line_error(capsys, argv, *expected) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("anadyn: error: ") and err.count("\n") == 1, err
    for text in expected:
        assert text in err, err


# -- a terminal that fits -----------------------------------------------------------------
def wide_table(columns: int = 12) -> str:
    heads = ["t (s)"] + [f"T{k} (N·m)" for k in range(1, columns + 1)]
    rows = [[f"{t:g}"] + [f"{-123.456789 * (k + 1) * (t + 1):.6f}" for k in range(columns)]
            for t in range(4)]
    return tables.render(heads, rows)


def test_a_wide_table_keeps_its_first_and_last_columns_and_says_so():
    text = "title\n" + wide_table() + "\nafter"
    assert max(map(len, text.splitlines())) > 120
    cut = tables.fit(text, 80, "inverse.csv").splitlines()
    assert cut[0] == "title" and cut[-1] == "after"
    assert all(len(line) < 80 for line in cut)
    assert "T1 (N·m)" in cut[1] and "T3 (N·m)" in cut[1] and "T12 (N·m)" in cut[1] and "T4 (N·m)" not in cut[1]
    assert cut[-2] == "(8 columns left out to fit 80 columns; inverse.csv has every one)"
    for line in cut[2:6]:                  # values whole, minus signs with their numbers
        for field in line.split()[1:]:
            assert field == "\u2026" or re.fullmatch(r"-\d+\.\d{6}", field), field
    assert tables.fit(text, None, "x") == text        # a pipe or a file: every column
    assert tables.fit(text, 200, "x") == text         # it fits: untouched


def test_long_tables_repeat_their_header():
    rows = [f"row {k}" for k in range(45)]
    out = tables.repeat_header(rows, "HEAD", 20)
    assert out.count("HEAD") == 3 and out[0] == "HEAD" and out[21] == "HEAD"
    assert tables.repeat_header(rows, "HEAD", None) == ["HEAD", *rows]


def test_inverse_tables_fit_a_narrow_terminal(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "50")
    assert main(["inverse", str(RRT), "--no-plot", "--no-roundtrip", "--out",
                 str(tmp_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    efforts = out[out.index(next(line for line in out if line.lstrip().startswith("t (s)"))):]
    assert efforts[0].split() == ["t", "(s)", "T01x", "(N·m)", "\u2026", "F23z", "(N)"]
    assert all(len(line) < 50 for line in efforts[:17])
    assert "(1 column left out to fit 50 columns; inverse.csv has every one)" in out
    monkeypatch.delenv("COLUMNS")          # not a terminal: everything
    assert main(["inverse", str(RRT), "--no-plot", "--no-roundtrip", "--out",
                 str(tmp_path)]) == 0
    assert "left out" not in capsys.readouterr().out


def test_many_limit_warnings_become_one_line(capsys):
    from anadyn_cli.commands.common import echo_limits
    from anadyn_cli.numeric.limits import Exceeded

    found = [Exceeded(f"j{k}", quantity, "upper", 1.0, "rad", 0.5 * k + (q == "rate"), 2.0,
                      1.0, 3) for k in range(1, 8) for q, quantity in
             (("position", "position"), ("rate", "rate"))]
    echo_limits(found, "simulate.json")
    err = capsys.readouterr().err
    assert err == ("anadyn: warning: 14 joint limits exceeded (position 7, rate 7), first "
                   "j1's position at t = 0.5 s; details in simulate.json\n")
    echo_limits(found[:2], "simulate.json")
    assert capsys.readouterr().err.count("anadyn: warning: limit exceeded: j1") == 2


def test_robots_and_test_scenes_are_listed_apart(capsys, monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    robots, scenes = out.split("\n\nTest scenes")
    assert robots.startswith("Robots (") and " rr " in robots and " ur5 " in robots
    assert " stiff_rr_gains1000 " in scenes and " stiff_rr_gains1000 " not in robots
    assert " rr " not in scenes


# -- messages for newcomers ------------------------------------------------------------------
def test_the_round_trip_says_what_to_know_and_keeps_the_figure_in_the_json(tmp_path, capsys):
    assert main(["inverse", str(RR), "--no-plot", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "fold" not in out and "1e2" not in out
    assert "without feedback the arm drifts off it; see inverse.json" in out
    trip = json.loads((tmp_path / "inverse.json").read_text())["roundtrip"]
    assert trip["growth_log10"] > 10 and trip["segments"] > 1


def test_an_undamped_pendulum_has_no_time_constant(tmp_path, capsys):
    """Hanging at rest: the eigenvalues are +-i w, their real parts rounding noise
    (which used to print as a time constant of ~1e16 s)."""
    robot = tmp_path / "pendulum.yaml"
    robot.write_text("name: pendulum\nparameters: {g: 9.81}\ngravity: [0, -g, 0]\n"
                     "coordinates:\n  q1: {initial: -pi/2}\n  q2: {initial: 0}\n"
                     "bodies:\n"
                     "  - name: a\n    joint: {type: revolute, axis: [0, 0, 1]}\n"
                     "    mass: 1\n    com: [0.5, 0, 0]\n"
                     "    inertia: {ixx: 0.001, iyy: 0.08, izz: 0.08}\n"
                     "  - name: b\n    parent: a\n"
                     "    joint: {type: revolute, axis: [0, 0, 1], origin: [1, 0, 0]}\n"
                     "    mass: 1\n    com: [0.5, 0, 0]\n"
                     "    inertia: {ixx: 0.001, iyy: 0.08, izz: 0.08}\n"
                     "simulation: {t_end: 2, output_step: 0.01}\n")
    main(["check", str(robot), "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert "fastest decay        none: no motion dies out over the run" in out
    assert "fastest growth       none: no motion grows over the run" in out
    assert "e+1" not in out.split("fastest decay")[1].splitlines()[0]
    decay = json.loads((tmp_path / "out" / "check.json").read_text())["fastest_decay"]
    assert decay * 2 < 1e-6                              # the figure stays in the JSON


# -- motor sizing --------------------------------------------------------------------------
def test_inverse_reports_rms_peak_rate_and_peak_power(tmp_path, capsys):
    assert main(["inverse", str(RR), "--no-plot", "--no-roundtrip", "--out",
                 str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "RMS effort" in out and "peak rate" in out and "peak power (W)" in out
    figures = json.loads((tmp_path / "inverse.json").read_text())["efforts"]
    data = read_csv(tmp_path / "inverse.csv")
    t = data["t"]
    # the chapter's joint rates: T01z drives q1 from the ground, T12z the relative q2 - q1
    rates = {"T01z": data["dq1"], "T12z": data["dq2"] - data["dq1"]}
    for name, rate in rates.items():
        tau = data[name]
        rms = math.sqrt(np.sum(np.diff(t) * (tau[1:] ** 2 + tau[:-1] ** 2) / 2) / t[-1])
        assert figures[name]["rms"] == pytest.approx(rms, rel=1e-12)
        assert figures[name]["peak_rate"] == pytest.approx(np.abs(rate).max(), rel=1e-9)
        assert figures[name]["peak_power_W"] == pytest.approx(np.abs(tau * rate).max(),
                                                              rel=1e-9)
        assert figures[name]["rate_unit"] == "rad/s"
    # the cycloid's largest rate, 2 (qf - q0) / T, at mid-motion (q1: -pi/18 -> pi/6, 15 s)
    assert figures["T01z"]["peak_rate"] == pytest.approx(2 * (math.pi / 6 + math.pi / 18) / 15,
                                                         rel=1e-6)


def test_the_inverse_plot_draws_the_effort_limits(tmp_path):
    from anadyn_cli.numeric.build import numeric_model
    from anadyn_cli.services import inverse

    robot = tmp_path / "rr_limits.yaml"
    robot.write_text(RR.read_text().replace(
        "displacement: q1}", "displacement: q1, limits: {effort: 40}}"))
    assert "effort: 40" in robot.read_text()
    result = inverse.inverse(numeric_model(robot), roundtrip=False)
    figure = result.figure()
    ax = next(a for a in figure.axes if a.get_ylabel() == "T01z (N·m)")
    assert sorted(line.get_ydata()[0] for line in ax.lines[1:]) == [-40.0, 40.0]


# -- waypoints -----------------------------------------------------------------------------
WAYPOINTS = ("trajectory: {kind: waypoints, points: [{q1: 0, q2: 0}, {q1: 1, q2: 0.5}, "
             "{q2: 0}], durations: [2, 3]}")


def with_trajectory(tmp_path, text: str) -> Path:
    lines = [line for line in RR.read_text().splitlines() if not line.startswith("trajectory:")]
    path = tmp_path / "rr_waypoints.yaml"
    path.write_text("\n".join(lines + [text, ""]))
    return path


def test_waypoints_stop_at_every_pose_and_follow_the_cycloid(tmp_path, capsys):
    robot = with_trajectory(tmp_path, WAYPOINTS)
    assert main(["inverse", str(robot), "--no-plot", "--out", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    data = read_csv(tmp_path / "out" / "inverse.csv")
    t = data["t"]
    assert t[-1] == pytest.approx(5.0)
    for moment, q1, q2 in ((0, 0, 0), (2, 1, 0.5), (5, 1, 0)):
        k = int(np.argmin(abs(t - moment)))
        assert (data["q1"][k], data["q2"][k]) == pytest.approx((q1, q2), abs=1e-12)
        for column in ("dq1", "dq2", "ddq1", "ddq2"):       # rest at every pose
            assert data[column][k] == pytest.approx(0, abs=1e-9)
    for moment in (0.7, 3.1):                                # the cycloid between them
        k = int(np.argmin(abs(t - moment)))
        start, duration, a, b = (0, 2, (0, 0), (1, 0.5)) if moment < 2 else (2, 3, (1, .5),
                                                                              (1, 0))
        u = (t[k] - start) / duration
        s = u - math.sin(2 * math.pi * u) / (2 * math.pi)
        assert data["q1"][k] == pytest.approx(a[0] + (b[0] - a[0]) * s, abs=1e-12)
        assert data["q2"][k] == pytest.approx(a[1] + (b[1] - a[1]) * s, abs=1e-12)
    quintic = with_trajectory(tmp_path, WAYPOINTS.replace("3]}", "3], shape: quintic}"))
    assert main(["inverse", str(quintic), "--no-plot", "--no-roundtrip", "--out",
                 str(tmp_path / "quintic")]) == 0
    data = read_csv(tmp_path / "quintic" / "inverse.csv")
    k = int(np.argmin(abs(data["t"] - 0.7)))
    u = data["t"][k] / 2
    assert data["q1"][k] == pytest.approx(10 * u**3 - 15 * u**4 + 6 * u**5, abs=1e-12)


@pytest.mark.parametrize("trajectory, message", [
    ("{kind: waypoints, points: [{q1: 0}], durations: []}",
     "trajectory.points: at least two poses are needed, got 1"),
    ("{kind: waypoints, points: [{q1: 0}, {q1: 1}], durations: [1, 2]}",
     "trajectory.durations: one duration per segment: 2 points need 1, got 2"),
    ("{kind: waypoints, points: [{q1: 0}, {q1: 1}], durations: [-1]}",
     "trajectory.durations[0]: must be positive (a duration in s), got -1"),
    ("{kind: waypoints, points: [{q1: 0}, {q9: 1}], durations: [1]}",
     "trajectory.points[1].q9: unknown coordinate 'q9'"),
    ("{kind: waypoints, points: [{q1: 0}, {q1: 1}], durations: [1], duration: 3}",
     "trajectory.duration: 'duration' does not belong to a waypoints trajectory"),
    ("{kind: waypoints, points: [{q1: 0}, {q1: 1}]}",
     "trajectory: missing required key 'durations' for kind 'waypoints'"),
    ("{kind: cycloidal, duration: 2, to: {q1: 1}, durations: [1]}",
     "trajectory.durations: 'durations' belongs to kind 'waypoints'"),
])
def test_bad_waypoints_are_one_line(tmp_path, capsys, trajectory, message):
    robot = with_trajectory(tmp_path, f"trajectory: {trajectory}")
    one_line_error(capsys, ["inverse", str(robot), "--out", str(tmp_path / "out")], message)
    assert not (tmp_path / "out").exists()


# -- a payload of 0 kg -----------------------------------------------------------------------
def test_a_massless_payload_adds_nothing(tmp_path, capsys):
    payload = tmp_path / "payload0.yaml"
    payload.write_text((ROOT / "configs" / "rrt_payload.yaml").read_text()
                       .replace("m_tip: 5,", "m_tip: 0,"))
    for robot, out in ((payload, "a"), (RRT, "b")):
        assert main(["inverse", str(robot), "--no-plot", "--no-roundtrip", "--out",
                     str(tmp_path / out)]) == 0
    capsys.readouterr()
    with_payload, without = read_csv(tmp_path / "a" / "inverse.csv"), read_csv(
        tmp_path / "b" / "inverse.csv")
    for name in ("T01x", "T12y", "F23z"):
        assert np.allclose(with_payload[name], without[name], rtol=1e-12, atol=1e-9)
    moving = tmp_path / "moving0.yaml"                      # a moving body still needs mass
    moving.write_text(RRT.read_text().replace("    mass: m3\n", "    mass: 0\n"))
    one_line_error(capsys, ["inverse", str(moving), "--out", str(tmp_path / "c")],
                   "mass: must be positive (a mass in kg), got 0")


@pytest.mark.slow
def test_a_sweep_from_0_kg_and_its_plot(tmp_path, capsys):
    from anadyn_cli.studies import sweep, sweep_plot

    plan = sweep.plan(ROOT / "configs" / "rrt_payload.yaml", ["m_tip=0,10"], "inverse",
                      roundtrip=False, maxima=["peak_F23z=500", "peak_T12y=600"])
    result = sweep.run(plan, jobs=1)
    assert [r["status"] for r in result.rows] == ["ok", "ok"]
    figure = sweep_plot.figure(result, sweep.capacity(result), sweep.headline(result))
    assert figure.get_suptitle() == "rrt_payload: sweep (inverse)"
    assert {ax.get_xlabel() for ax in figure.axes if ax.get_xlabel()} == {"m_tip (kg)"}
    for ax in figure.axes:                   # every signal and every bound is named
        names = [t.get_text() for t in ax.get_legend().get_texts()]
        assert names and all(n.startswith(("peak_", "rms_", "max ")) for n in names)
    force = next(ax for ax in figure.axes if ax.get_ylabel() == "peak |effort| (N)")
    assert [t.get_text() for t in force.get_legend().get_texts()] == [
        "peak_F23z", "max = 500"]


# -- show, animate, LaTeX --------------------------------------------------------------------
def test_a_planar_robot_is_drawn_in_its_plane():
    from anadyn_cli.numeric.frames import frames
    from anadyn_cli.services import show

    assert show.plane_normal(frames(RR)) == 2              # moves in x-y
    assert show.plane_normal(frames(RRT)) is None


def test_animate_plays_an_inverse_motion_with_tip_traces(tmp_path, capsys):
    from anadyn_cli.numeric.frames import frames
    from anadyn_cli.output import drawing

    assert main(["animate", str(RR), "--motion", "inverse", "--frames", "3", "--no-mp4",
                 "--out", str(tmp_path)]) == 0
    assert "rr: 1501 rows over 15 s (cycloidal trajectory)" in capsys.readouterr().out
    shape = json.loads((tmp_path / "animate.json").read_text())
    assert (shape["width"], shape["height"], shape["frames"]) == (1280, 720, 3)
    fk = frames(RR)
    poses = fk(np.array([[0.0, 0.0], [0.5, 1.0]]))
    movie = drawing.Animation(fk.skeleton, drawing.Frame.around(poses), "rr", normal=2)
    for j in range(2):
        movie.frame(poses.at(j), float(j))
    trace = movie.traces[0]                                # the tip of bar2, frame by frame
    assert np.allclose(np.c_[trace.get_xdata(), trace.get_ydata()][:2],
                       poses.tip[:, 1, :2])
    assert min(t.get_fontsize() for t in movie.figure.findobj(
        lambda a: hasattr(a, "get_fontsize"))) * 100 / 72 >= 12   # px at 100 dpi
    one_line_error(capsys, ["animate", str(RRT), "--from", str(tmp_path / "none.csv"),
                            "--out", str(tmp_path / "x")], "none.csv: cannot read it")


def test_latex_equations_break_over_lines(capsys):
    from anadyn_cli.symbolic.render import latex_width

    assert main(["equations", str(RRT), "--format", "latex", "--symbolic"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("  ")]
    assert len(rows) > 6
    for row in rows:
        assert latex_width(row) < 130, row
        assert row.count(r"\left") == row.count(r"\right")
        assert row.count("{") == row.count("}")
