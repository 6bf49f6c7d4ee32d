"""Contacts in the drawings (issue 27: "animate draws the contacts and forces"):
`show`, `animate` and `view` of a scene with a `contacts` section.

What is checked against numbers worked out here, not by the code under test:

- a sphere's centre in world axes is the body's origin plus R times its centre
  (the bouncing ball: slides x and z, so the centre is (x, 0, z));
- the force drawn is fn n + ft1 t1 + ft2 t2 with t1 = x, t2 = y on a level floor,
  acting at the sphere's lowest point c - r n; between two spheres fn along the
  line of centres at the middle of the overlap;
- a ball resting on the floor pushes it with m g (the run's own fn column agrees,
  and the arrow drawn from its lowest point points straight up, newton x m g long).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from anadyn_cli.cli import main
from anadyn_cli.numeric.frames import frames
from anadyn_cli.output import contact_drawing, drawing
from anadyn_cli.services import show as service

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
BALL = ROBOTS / "contact" / "bouncing_ball.yaml"
M, R, G = 0.5, 0.1, 9.81            # the shipped ball's m, r, g


def resting_ball(tmp_path: Path) -> Path:
    """The shipped ball put on the floor at rest, sunk by the depth that carries its
    weight: k d^1.5 = m g."""
    depth = (M * G / 1e6) ** (2 / 3)
    text = BALL.read_text().replace("x: {rate: 1.0}", "x: {initial: 0.3}").replace(
        "z: {initial: 1.0}", f"z: {{initial: {R - depth!r}}}").replace(
        "simulation: {t_end: 2.5, output_step: 0.001}", "simulation: {t_end: 0.3, output_step: 0.01}")
    path = tmp_path / "resting_ball.yaml"
    path.write_text(text)
    return path


def test_show_json_places_the_contact_sphere_and_its_gap(tmp_path):
    assert main(["show", str(BALL), "--at", "x=0.4, z=0.7", "--out", str(tmp_path)]) == 0
    contact = json.loads((tmp_path / "show.json").read_text())["contacts"]["floor"]
    assert contact["body"] == "ball" and contact["radius"] == pytest.approx(R)
    assert contact["centre"] == pytest.approx([0.4, 0.0, 0.7], abs=1e-12)
    assert contact["ground"]["gap"] == pytest.approx(0.7 - R, abs=1e-12)


def test_forces_are_rebuilt_from_the_columns_in_world_axes():
    fk = frames(BALL)
    poses = fk(np.array([[0.2, 0.05, 0.0], [0.2, 0.08, 0.0]]))
    forces = contact_drawing.contact_forces(fk.skeleton, poses, {
        "floor_fn": np.array([2.0, 0.0]), "floor_ft1": np.array([1.0, 0.0]),
        "floor_ft2": np.array([-0.5, 0.0])})
    assert forces[0, 0] == pytest.approx([1.0, -0.5, 2.0])      # ft1 x + ft2 y + fn z
    assert forces[1, 0] == pytest.approx([0.0, 0.0, 0.0])
    floor = fk.skeleton.contact_list()[0]
    assert floor.force_point(poses)[0] == pytest.approx([0.2, 0.0, 0.05 - R])


def test_a_pair_pushes_along_the_line_of_centres_at_the_middle_of_the_overlap(tmp_path):
    text = BALL.read_text().replace(
        "    - {name: floor, body: ball, radius: r}",
        "    - {name: floor, body: ball, radius: r}\n"
        "    - {name: knock, body: ball, radius: r, against: {body: slide_x, "
        "point: [0.3, 0, 0.4], radius: 0.05}}")
    path = tmp_path / "pair.yaml"
    path.write_text(text)
    fk = frames(path)
    pose = fk(np.array([0.18, 0.24, 0.0]))              # centre (0.18, 0, 0.24)
    knock = next(c for c in fk.skeleton.contact_list() if c.name == "knock")
    gap = np.array([0.18 - (0.18 + 0.3), 0.0, 0.24 - 0.4])  # from the partner's centre
    distance = np.linalg.norm(gap)                      # (on slide_x, which moves by x)
    n = gap / distance
    assert knock.normal_at(pose) == pytest.approx(n)
    depth = R + 0.05 - distance
    assert knock.force_point(pose) == pytest.approx(
        np.array([0.18, 0.0, 0.24]) - (R - depth / 2) * n)
    forces = contact_drawing.contact_forces(fk.skeleton, pose, {"knock_fn": 3.0, "knock_ft1": 7.0})
    assert forces[1] == pytest.approx(3.0 * n)           # the pair's ft1 is a magnitude


def test_the_arrow_of_a_resting_ball_is_its_weight_straight_up(tmp_path):
    path = resting_ball(tmp_path)
    out = tmp_path / "run"
    assert main(["simulate", str(path), "--no-plot", "--out", str(out)]) == 0
    fk = frames(path)
    t, q, columns = service.read_run(out / "simulate.csv", fk.skeleton)
    assert set(columns) == {"floor_fn", "floor_ft1", "floor_ft2"}
    assert columns["floor_fn"][-1] == pytest.approx(M * G, rel=1e-4)
    animation = service.animate(fk, t, q, "resting", max_frames=3, columns=columns)
    movie_frame = drawing.Frame.around(fk(q[[-1]]), fk.skeleton, float(M * G))
    artist = drawing.RobotArtist(Figure().add_subplot(), drawing.View("front", (0, 2)),
                                 fk.skeleton, movie_frame)
    forces = contact_drawing.contact_forces(fk.skeleton, fk(q[-1]), {k: v[-1] for k, v in columns.items()})
    artist.update(fk(q[-1]), forces)
    arrow = np.array(artist.contacts.forces.get_data()).T[:2]
    start = np.array([q[-1, 0], q[-1, 1] - R])           # (x, z) of the lowest point
    assert arrow[0] == pytest.approx(start, abs=1e-9)
    assert arrow[1] == pytest.approx(start + [0.0, movie_frame.newton * M * G], rel=1e-4)
    assert len(animation.images) >= 2


@pytest.mark.parametrize("source", ["simulate", "from"])
def test_animate_draws_the_force_arrows(tmp_path, source):
    """The frames hold the force's red where the ball rests on the floor, and a drawing
    without forces has none of it."""
    path = resting_ball(tmp_path)
    fk = frames(path)
    if source == "from":
        assert main(["simulate", str(path), "--no-plot", "--out", str(tmp_path / "run")]) == 0
        t, q, columns = service.read_run(tmp_path / "run" / "simulate.csv", fk.skeleton)
    else:
        from anadyn_cli.commands.animate import force_columns
        from anadyn_cli.model import load_robot
        from anadyn_cli.numeric.build import numeric_model
        from anadyn_cli.services.simulate import simulate

        result = simulate(numeric_model(load_robot(path)))
        t, q, columns = result.t, result.x[:, :3], force_columns(result)
    red = np.array([0xc0, 0x39, 0x2b])
    drawn = service.animate(fk, t, q, "resting", max_frames=2, columns=columns)
    bare = service.animate(fk, t, q, "resting", max_frames=2)
    def reds(image) -> int:
        return int((np.abs(image.astype(int) - red).sum(axis=-1) <= 6).sum())

    assert reds(drawn.images[-1]) > 20
    assert reds(bare.images[-1]) == 0


def test_animate_command_on_a_contact_scene_writes_its_gif(tmp_path):
    path = resting_ball(tmp_path)
    assert main(["animate", str(path), "--no-mp4", "--frames", "4", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "animate.gif").stat().st_size > 0


def test_the_view_carries_the_spheres_the_ground_and_the_force_arrows(tmp_path):
    from anadyn_cli.model import load_robot
    from anadyn_cli.services import view as viewer

    path = resting_ball(tmp_path)
    assert main(["simulate", str(path), "--no-plot", "--out", str(tmp_path / "run")]) == 0
    run = viewer.read_run(tmp_path / "run" / "simulate.csv", ["x", "z", "spin"])
    scene = viewer.view(load_robot(path), run, use_cache=False).scene
    spheres = [s for s in scene["shapes"] if s["kind"] == "sphere" and s["size"] == [R]]
    assert len(spheres) == 1 and spheres[0]["body"] == 2
    ground = [s for s in scene["shapes"] if s.get("backdrop")]
    assert len(ground) == 1 and ground[0]["body"] == -1
    top = np.array(ground[0]["matrix"]).reshape(4, 4)
    assert top[2, 3] + ground[0]["size"][2] / 2 == pytest.approx(0.0)   # top face at z = 0
    arrows = {a["name"]: a for a in scene["arrows"]}
    assert arrows["contact floor"]["peak"] == pytest.approx(M * G, rel=1e-3)
