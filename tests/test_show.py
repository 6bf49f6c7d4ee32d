"""`anadyn show` and `anadyn animate`: what is drawn is the forward kinematics.

The chapter's arms are drawn at random poses and the lines actually put on
the figure (the artists' data, in the 3-D view and a 2-D view) are compared
with the arms' closed-form geometry, written out here from the chapter:

    RR  (absolute angles): B = L1 (cos q1, sin q1), D = B + L2 (cos q2, sin q2)
    RRT: k1 = Rx(q1) k, k2 = Rx(q1) Ry(q2) k; B = 2 L1 k1, C2 = B + L2 k2, C3 = C2 + q3 k2
"""
from __future__ import annotations

import json
import math
import os
import stat
import sys
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.numeric.frames import frames
from anadyn_cli.services import show as service

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
RNG = np.random.default_rng(7)


def segments(line, three_d: bool) -> list[np.ndarray]:
    """The pieces of a NaN-separated line artist, each as rows of points."""
    data = np.array(line.get_data_3d() if three_d else line.get_data(), dtype=float).T
    pieces, current = [], []
    for row in data:
        if np.isnan(row).any():
            if current:
                pieces.append(np.array(current))
            current = []
        else:
            current.append(row)
    if current:
        pieces.append(np.array(current))
    return pieces


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rr_points(q1, q2, L1=1.0, L2=1.0):
    B = L1 * np.array([math.cos(q1), math.sin(q1), 0])
    D = B + L2 * np.array([math.cos(q2), math.sin(q2), 0])
    return {"links": [(np.zeros(3), B), (B, D)], "coms": [B / 2, (B + D) / 2],
            "joints": [np.zeros(3), B]}


def rrt_points(q1, q2, q3, L1=0.4, L2=0.4):
    k = np.array([0, 0, 1.0])
    k1, k2 = rx(q1) @ k, rx(q1) @ ry(q2) @ k
    B = 2 * L1 * k1
    C2 = B + L2 * k2
    C3 = C2 + q3 * k2
    return {"links": [(np.zeros(3), B), (B, C2), (C3, C3)], "coms": [L1 * k1, C2, C3],
            "joints": [np.zeros(3), B, C2], "slide": (C2, C3)}


@pytest.mark.parametrize("name", ["rr", "rrt"])
def test_drawn_links_are_the_forward_kinematics(name):
    fk = frames(ROBOTS / f"{name}.yaml")
    for _ in range(4):
        q = RNG.uniform(-math.pi, math.pi, len(fk.skeleton.coordinates))
        if name == "rrt":
            q[2] = RNG.uniform(0, 0.5)
        expected = rr_points(*q) if name == "rr" else rrt_points(*q)
        drawing = service.draw(fk, [",".join(f"{c}={float(v)!r}" for c, v in
                                             zip(fk.skeleton.coordinates, q))])
        figure = drawing.figure()
        # rrt: the 3-D view (every coordinate) and three planes; rr, planar: its plane alone
        planar = name == "rr"
        assert len(figure.axes) == (1 if planar else 4)
        plane = figure.axes[0 if planar else 1]
        h, v = ("xyz".index(plane.get_xlabel()[0]), "xyz".index(plane.get_ylabel()[0]))
        assert not planar or (h, v) == (0, 1)            # x across, y up (against gravity)
        for view, pick in (((0, [h, v]),) if planar else ((0, [0, 1, 2]), (1, [h, v]))):
            pieces = segments(next(l for l in figure.axes[view].lines
                                   if l.get_label() == "link"), pick == [0, 1, 2])
            links = [(a, b) for a, b in expected["links"]]
            assert len(pieces) == len(links)
            for piece, (start, end) in zip(pieces, links):
                assert np.allclose(piece, np.array([start, end])[:, pick], atol=1e-12)
        assert np.allclose(drawing.pose.com, expected["coms"], atol=1e-12)
        assert np.allclose(drawing.pose.joint, expected["joints"], atol=1e-12)
        if name == "rrt":        # the prismatic link's travel, drawn as a sleeve
            sleeve = next(l for l in figure.axes[0].lines if l.get_linewidth() == 7)
            assert np.allclose(segments(sleeve, True)[0], np.array(expected["slide"]))


def test_frames_agree_with_the_energy_of_the_dynamics():
    """V(q) of the compiled equations = -sum m g . r_i with r_i the drawn mass
    centres, on a robot with rpy, offsets, prismatic and fixed joints."""
    sys.path.insert(0, str(Path(__file__).parent))
    from random_robots import random_robot_yaml

    from anadyn_cli.model import robot_from_text
    from anadyn_cli.numeric.build import numeric_model

    for seed in (3, 11, 19):
        robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
        fk, model = frames(robot), numeric_model(robot)
        masses = np.array([float(b.mass.xreplace(robot.parameter_substitution()))
                           for b in robot.bodies])
        g = np.array(fk.skeleton.gravity)
        q = RNG.uniform(-2, 2, (5, model.n))
        V = model.energy(q.T, np.zeros_like(q.T))[1]
        drawn = -np.einsum("b,kbj,j->k", masses, fk(q).com, g)
        assert np.allclose(V, drawn, rtol=1e-12, atol=1e-9)


def test_show_writes_the_drawing_and_its_points(tmp_path, capsys):
    assert main(["show", str(ROBOTS / "rr.yaml"), "--out", str(tmp_path), "--at", "q1=0.3",
                 "--at", "q2=90deg"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "rr, pose: q1 = 17.19°, q2 = 90°"
    assert (tmp_path / "show.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = json.loads((tmp_path / "show.json").read_text())
    assert data["pose"] == {"q1": 0.3, "q2": math.pi / 2}
    expected = rr_points(0.3, math.pi / 2)
    assert np.allclose(data["bodies"]["bar2"]["joint"], expected["joints"][1])
    assert np.allclose(data["bodies"]["bar2"]["link_end"], [expected["links"][1][1]])
    assert data["bodies"]["bar2"]["displacement"] == "q2 - q1"


def test_show_svg_and_initial_pose(tmp_path, capsys):
    assert main(["show", str(ROBOTS / "rrt.yaml"), "--out", str(tmp_path),
                 "--plot-format", "SVG"]) == 0
    assert capsys.readouterr().out.startswith("rrt, initial pose: q1 = 10°, q2 = 30°, "
                                              "q3 = 0.25 m\n")
    assert b"<svg" in (tmp_path / "show.svg").read_bytes()[:400]


@pytest.mark.parametrize("at, message", [
    ("q9=1", "--at q9=1: unknown coordinate 'q9'; coordinates: q1, q2, q3"),
    ("q1", "--at q1: expected COORDINATE=VALUE, e.g. q1=0.5 or q1=30deg"),
    ("q3=5deg", "--at q3=5deg: q3 is a length in m; degrees apply to angles"),
    ("q1=__import__('os')", "--at q1=__import__('os'): "),
    ("q2=1/0", "--at q2=1/0: "),
])
def test_bad_pose_is_one_line_and_nothing_written(tmp_path, capsys, at, message):
    out = tmp_path / "out"
    assert main(["show", str(ROBOTS / "rrt.yaml"), "--out", str(out), "--at", at]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.startswith("anadyn: error: " + message)
    assert captured.err.count("\n") == 1
    assert not out.exists()


def chain_yaml(order: list[str]) -> str:
    bodies = {
        "bar1": "  - name: bar1\n    joint: {type: revolute, axis: [0, 0, 1]}\n",
        "bar2": "  - name: bar2\n    parent: bar1\n"
                "    joint: {type: revolute, axis: [0, 0, 1], origin: [1, 0, 0]}\n",
        "bar3": "  - name: bar3\n    parent: bar2\n"
                "    joint: {type: prismatic, axis: [1, 0, 0], origin: [1, 0, 0]}\n",
    }
    tail = "    mass: 1\n    com: [0.5, 0, 0]\n    inertia: {iyy: 0.1, izz: 0.1}\n"
    return ("name: chain\ngravity: [0, -9.81, 0]\ncoordinates: {a: {initial: 0.1}, "
            "b: {initial: 0.2}, c: {initial: 0.3}}\nbodies:\n"
            + "".join(bodies[k] + tail for k in order))


def test_default_coordinates_follow_the_tree_not_the_file():
    from anadyn_cli.model import robot_from_text

    reference = robot_from_text(chain_yaml(["bar1", "bar2", "bar3"]), "chain.yaml")
    for order in (["bar3", "bar2", "bar1"], ["bar2", "bar3", "bar1"], ["bar3", "bar1", "bar2"]):
        robot = robot_from_text(chain_yaml(order), "chain.yaml")
        assert {b.name: str(b.joint.displacement) for b in robot.bodies} == \
            {"bar1": "a", "bar2": "b", "bar3": "c"}
        assert np.allclose(frames(robot)(np.array([0.1, 0.2, 0.3])).tip,
                           frames(reference)(np.array([0.1, 0.2, 0.3])).tip)


def test_defaults_on_separate_branches_are_refused_in_one_line(tmp_path, capsys):
    text = chain_yaml(["bar1", "bar2", "bar3"]).replace("    parent: bar2\n", "    parent: bar1\n")
    robot = tmp_path / "branched.yaml"
    robot.write_text(text)
    assert main(["show", str(robot), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {robot}:18: bodies[2].joint: bodies 'bar2' and 'bar3' both take a "
        "default coordinate but lie on different branches of the tree, so which coordinate "
        "each gets would depend on their order in the file; give them displacements "
        "(e.g. 'displacement: c')\n")
    assert not (tmp_path / "o").exists()
    explicit = text.replace("origin: [1, 0, 0]}\n    mass: 1\n    com: [0.5, 0, 0]\n"
                            "    inertia: {iyy: 0.1, izz: 0.1}\n  - name: bar3",
                            "origin: [1, 0, 0], displacement: b}\n    mass: 1\n"
                            "    com: [0.5, 0, 0]\n    inertia: {iyy: 0.1, izz: 0.1}\n"
                            "  - name: bar3")
    assert explicit != text
    robot.write_text(explicit)
    assert main(["show", str(robot), "--out", str(tmp_path / "o")]) == 0


def test_animation_plan_is_real_time_when_it_fits():
    t = np.arange(301) * 0.01                    # 3 s
    plan = service.plan(t)
    assert plan.frame_ms == 40 and abs(plan.speed - 1) < 1e-9 and plan.note == ""
    assert plan.rows[0] == 0 and plan.rows[-1] == 300 and len(plan.rows) == 76
    long = service.plan(np.arange(100001) * 0.01)  # 1000 s in about 20 s of playback
    assert len(long.rows) == service.MAX_FRAMES and long.frame_ms == 130   # GIF: 10 ms steps
    assert long.speed == pytest.approx(1000 / (0.130 * 149)) and long.note == "  (51.6x speed)"


def test_animate_writes_a_gif_with_the_time_shown(tmp_path, capsys):
    from PIL import Image

    assert main(["animate", str(ROBOTS / "rr.yaml"), "--t-end", "0.4", "--out", str(tmp_path),
                 "--no-mp4"]) == 0
    gif = Image.open(tmp_path / "animate.gif")
    assert gif.n_frames == 11 and gif.info["duration"] == 40 and gif.info["loop"] == 0
    frames_seen = []
    for k in (0, 10):
        gif.seek(k)
        frames_seen.append(np.asarray(gif.convert("RGB")))
    assert (frames_seen[0] != frames_seen[1]).any()        # the arm moved, the clock ran
    data = json.loads((tmp_path / "animate.json").read_text())
    assert data["frames"] == 11 and data["t_last"] == pytest.approx(0.4)
    assert "mp4: not asked for" in capsys.readouterr().out


def test_animation_frames_show_the_time():
    fk = frames(ROBOTS / "rr.yaml")
    t = np.arange(3) * 0.5
    q = np.array([[0, 0], [0.5, 1.0], [1.0, 2.0]])
    movie = service.animate(fk, t, q, "rr")
    from anadyn_cli.output.drawing import Animation, Frame

    probe = Animation(fk.skeleton, Frame.around(fk(q)), "rr")
    probe.frame(fk(q[1]), 0.5)
    assert probe.clock.get_text() == "rr    t =   0.50 s"
    assert len(movie.images) == 3 and movie.images[0].dtype == np.uint8


def fake_ffmpeg(folder: Path, fails: bool = False) -> None:
    """An ``ffmpeg`` that copies its input to the output file (or fails)."""
    script = folder / "ffmpeg"
    body = ("import sys\n"
            + ("sys.stderr.write('no encoder\\n'); sys.exit(1)\n" if fails else
               "data = sys.stdin.buffer.read()\nopen(sys.argv[-1], 'wb').write(data)\n"))
    script.write_text(f"#!{sys.executable}\n{body}")
    script.chmod(script.stat().st_mode | stat.S_IXUSR)


def test_mp4_when_ffmpeg_is_there(tmp_path, capsys, monkeypatch):
    tools = tmp_path / "bin"
    tools.mkdir()
    fake_ffmpeg(tools)
    monkeypatch.setenv("PATH", f"{tools}{os.pathsep}{os.environ['PATH']}")
    out = tmp_path / "out"
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--t-end", "0.2", "--no-plot",
                 "--animate", "--out", str(out)]) == 0
    assert "animation: mp4: written by ffmpeg" in capsys.readouterr().out
    raw = (out / "animate.mp4").read_bytes()      # the fake stores the raw frames
    shape = json.loads((out / "animate.json").read_text())
    assert (shape["width"], shape["height"]) == (1280, 720)      # text >= 12 px at 100 dpi
    assert len(raw) == 6 * 1280 * 720 * 3
    assert sorted(p.name for p in out.iterdir()) == ["animate.gif", "animate.json",
                                                     "animate.mp4", "simulate.csv",
                                                     "simulate.json"]


def test_a_failing_mp4_writer_leaves_the_gif(tmp_path, capsys, monkeypatch):
    tools = tmp_path / "bin"
    tools.mkdir()
    fake_ffmpeg(tools, fails=True)
    monkeypatch.setenv("PATH", f"{tools}{os.pathsep}{os.environ['PATH']}")
    out = tmp_path / "out"
    assert main(["animate", str(ROBOTS / "rr.yaml"), "--t-end", "0.2", "--out", str(out)]) == 0
    assert "mp4: not written (ffmpeg failed: no encoder)" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["animate.gif", "animate.json"]
