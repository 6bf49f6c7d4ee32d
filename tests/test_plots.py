"""Report-ready plots: formats, resolution, one unit per axis, layout, titles."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.output import plots

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ROOT / "robots"
SIGNATURES = {"png": b"\x89PNG\r\n\x1a\n", "svg": b"<?xml", "pdf": b"%PDF"}


def labels(figure) -> list[str]:
    return [ax.get_ylabel() for ax in figure.axes if ax.get_visible()]


@pytest.mark.parametrize("fmt", ["png", "SVG", "Pdf"])
def test_plot_formats(tmp_path, capsys, fmt):
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--t-end", "0.5", "--out", str(tmp_path),
                 "--plot-format", fmt]) == 0
    path = tmp_path / f"simulate.{fmt.lower()}"
    assert path.read_bytes().startswith(SIGNATURES[fmt.lower()])
    assert f"wrote {tmp_path / 'simulate.csv'}, {path}," in capsys.readouterr().out


def test_png_resolution_and_no_creation_date(tmp_path):
    from PIL import Image

    t = np.linspace(0, 1, 11)
    first, second = tmp_path / "a.png", tmp_path / "b.png"
    for path in (first, second):
        plots.write_plot(path, t, [("x (m)", [("x", t)])], "title")
    dpi = Image.open(first).info["dpi"]
    assert min(dpi) >= 150 and round(dpi[0]) == plots.DPI
    assert first.read_bytes() == second.read_bytes()         # no date: same bytes
    for fmt in ("svg", "pdf"):
        paths = [tmp_path / f"{k}.{fmt}" for k in "ab"]
        for path in paths:
            plots.write_plot(path, t, [("x (m)", [("x", t)])], "title")
        assert paths[0].read_bytes() == paths[1].read_bytes()


def test_unknown_plot_format_is_a_usage_error(tmp_path, capsys):
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--plot-format", "jpeg",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "jpeg" in err and "png" in err and not (tmp_path / "o").exists()


def test_one_unit_per_axis():
    """Torques apart from forces, angles (deg) apart from lengths (m), rates apart."""
    rows = 5
    panels = plots.effort_panels([("T1", "N*m"), ("F2", "N"), ("T3", "N*m")],
                                 np.zeros((rows, 3)))
    assert [(p.label, [n for n, _ in p.series]) for p in panels] == [
        ("torque (N·m)", ["T1", "T3"]), ("force (N)", ["F2"])]
    q = np.array([[np.pi, 0.5]] * rows)
    panels = plots.state_panels([("q1", "rad"), ("q2", "m")], q, 2 * q)
    assert [p.label for p in panels] == ["q1 (deg)", "dq1 (deg/s)", "q2 (m)", "dq2 (m/s)"]
    assert panels[0].series[0][1][0] == pytest.approx(180.0)
    assert panels[3].series[0][1][0] == pytest.approx(1.0)
    many = plots.effort_panels([(f"T{k}", "N*m") for k in range(1, 13)], np.zeros((rows, 12)))
    assert [p.label for p in many] == ["torque T1..T6 (N·m)", "torque T7..T12 (N·m)"]


@pytest.mark.parametrize("joints, rates, grid", [
    (2, False, (3, 1)), (6, False, (4, 2)), (6, True, (7, 2)), (12, False, (5, 3)),
    (12, True, (7, 4))])
def test_layout_stays_readable_at_many_joints(joints, rates, grid):
    rows = 50
    t = np.linspace(0, 1, rows)
    names = [(f"q{k}", "rad") for k in range(1, joints + 1)]
    q = np.zeros((rows, joints))
    panels = plots.state_panels(names, q, q if rates else None)
    panels += plots.effort_panels([(f"T{k}", "N*m") for k in range(1, joints + 1)], q)
    figure = plots.time_figure(t, panels, "title", pairs=rates)
    width, height = figure.get_size_inches()
    assert plots.grid(len(panels), rates) == grid
    assert height <= plots.FIGURE_MAX_HEIGHT and width <= 16.5
    assert len([ax for ax in figure.axes if ax.get_visible()]) == len(panels)
    if rates:     # each coordinate's rate beside it
        visible = [ax for ax in figure.axes if ax.get_visible()]
        assert [ax.get_ylabel() for ax in visible[:2]] == ["q1 (deg)", "dq1 (deg/s)"]


def test_simulate_plot_has_rates_on_request_a_plain_title_and_named_signals():
    from anadyn_cli.numeric.build import numeric_model
    from anadyn_cli.services import simulate as service

    result = service.simulate(numeric_model(ROBOTS / "rrt.yaml"), t_end=0.5, rtol=1e-8,
                              method="rk45")
    plain, with_rates = result.figure(), result.figure(rates=True)
    assert labels(plain) == ["q1 (deg)", "q2 (deg)", "q3 (m)", "torque (N·m)", "force (N)"]
    assert labels(with_rates) == ["q1 (deg)", "dq1 (deg/s)", "q2 (deg)", "dq2 (deg/s)",
                                  "q3 (m)", "dq3 (m/s)", "torque (N·m)", "force (N)"]
    assert plain.get_suptitle() == "rrt: simulate (recursive Newton-Euler)"   # the solver: simulate.json
    force = [ax for ax in plain.axes if ax.get_ylabel() == "force (N)"][0]
    assert [t.get_text() for t in force.get_legend().get_texts()] == ["F23z"]
    q1 = [ax for ax in plain.axes if ax.get_ylabel() == "q1 (deg)"][0]
    assert q1.get_legend() is None                      # its label names it already


def test_inverse_plot_title_is_plain_and_limits_are_drawn(tmp_path, capsys):
    assert main(["inverse", str(ROBOTS / "rr.yaml"), "--out", str(tmp_path), "--rates",
                 "--plot-format", "svg"]) == 0
    svg = (tmp_path / "inverse.svg").read_text()
    assert "rr: inverse" in svg and "round trip" not in svg
    assert "prescribed ddq (deg/s²)" in svg
    from anadyn_cli.output.plots import Panel, time_figure

    t = np.linspace(0, 1, 5)
    figure = time_figure(t, [Panel("T1 (N·m)", (("T1", t),), 20.0)], "x")
    ax = figure.axes[0]
    assert sorted(line.get_ydata()[0] for line in ax.lines[1:]) == [-20.0, 20.0]
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["T1", "limit ±20"]


def test_size_title_and_font_size(tmp_path, capsys):
    from PIL import Image

    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--t-end", "0.5", "--out",
                 str(tmp_path), "--size", "4x3", "--title", "Figure 2: the arm",
                 "--font-size", "14"]) == 0
    assert Image.open(tmp_path / "simulate.png").size == (4 * plots.DPI, 3 * plots.DPI)
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--t-end", "0.5", "--out",
                 str(tmp_path / "svg"), "--plot-format", "svg", "--title",
                 "Figure 2: the arm", "--font-size", "14"]) == 0
    svg = (tmp_path / "svg" / "simulate.svg").read_text()
    assert "Figure 2: the arm" in svg and "rr: simulate" not in svg
    figure = plots.time_figure(np.linspace(0, 1, 5), [("x (m)", [("x", np.zeros(5))])], "t")
    plots.apply_style(figure, plots.FigureStyle(font_size=18))
    assert figure.axes[0].get_ylabel() and figure.axes[0].yaxis.label.get_fontsize() == 18
    capsys.readouterr()
    for flag, value, message in (("--size", "4", "--size: expected WIDTHxHEIGHT in inches"),
                                 ("--size", "0.1x3", "each 1 to 50"),
                                 ("--font-size", "100", "--font-size: expected 4 to 40")):
        assert main(["simulate", str(ROBOTS / "rr.yaml"), "--out", str(tmp_path / "bad"),
                     flag, value]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1
    assert not (tmp_path / "bad").exists()


def test_plotting_leaves_matplotlib_alone(tmp_path):
    """No pyplot, no backend switch: a notebook importing anadyn keeps its state."""
    code = f"""
import matplotlib
matplotlib.use("svg")
import sys
from anadyn_cli.cli import main
assert main(["simulate", r"{ROBOTS / 'rr.yaml'}", "--t-end", "0.2", "--out", sys.argv[1]]) == 0
assert main(["show", r"{ROBOTS / 'rr.yaml'}", "--out", sys.argv[1]]) == 0
assert "matplotlib.pyplot" not in sys.modules, "pyplot imported"
assert matplotlib.get_backend() == "svg", matplotlib.get_backend()
print("untouched")
"""
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path)],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.stdout.strip().endswith("untouched"), done.stderr
