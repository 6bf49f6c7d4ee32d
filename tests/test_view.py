"""anadyn view (issue 23): the 3-D page, its meshes and paths, and notebook display.

Meshes are tiny files written here (STL binary and ASCII, OBJ, COLLADA) with
known coordinates; link placements are checked against Pinocchio; the page is
loaded in headless Chromium (skipped when there is none).
"""
from __future__ import annotations

import json
import re
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import load_robot
from anadyn_cli.numeric.frames import frames
from anadyn_cli.output.view import meshes, pack, page
from anadyn_cli.output.view.visuals import visuals
from anadyn_cli.services import view as service

CUBE = np.array([[x, y, z] for x in (0, 0.1) for y in (0, 0.1) for z in (0, 0.1)])
CUBE_FACES = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
              (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
DAE = """<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
 <asset><unit meter="0.01"/><up_axis>Z_UP</up_axis></asset>
 <library_effects><effect id="red-fx"><profile_COMMON><technique sid="t"><phong>
  <diffuse><color>0.8 0.1 0.1 1</color></diffuse></phong></technique></profile_COMMON></effect>
 </library_effects>
 <library_materials><material id="red"><instance_effect url="#red-fx"/></material>
 </library_materials>
 <library_geometries><geometry id="g"><mesh>
  <source id="g-pos"><float_array id="g-arr" count="12">0 0 0 10 0 0 10 10 0 0 10 0</float_array>
   <technique_common><accessor source="#g-arr" count="4" stride="3"/></technique_common></source>
  <vertices id="g-v"><input semantic="POSITION" source="#g-pos"/></vertices>
  <polylist material="m" count="1"><input semantic="VERTEX" source="#g-v" offset="0"/>
   <vcount>4</vcount><p>0 1 2 3</p></polylist>
 </mesh></geometry></library_geometries>
 <library_visual_scenes><visual_scene id="s"><node id="n">
  <translate>0 0 5</translate>
  <instance_geometry url="#g"><bind_material><technique_common>
   <instance_material symbol="m" target="#red"/></technique_common></bind_material>
  </instance_geometry>
 </node></visual_scene></library_visual_scenes>
 <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""
INERTIAL = ('<inertial><mass value="1"/><origin xyz="0 0 0.1"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial>')
ARM = """<robot name="arm">
 <material name="blue"><color rgba="0.1 0.2 0.9 1"/></material>
 <link name="base"><visual><geometry><mesh filename="{base}"/></geometry>
  <material name="blue"/></visual></link>
 <link name="upper">{inertial}<visual><origin xyz="0 0 0.05" rpy="0 0.3 0"/>
  <geometry><mesh filename="{upper}" scale="2 2 2"/></geometry></visual></link>
 <link name="fore">{inertial}<visual><geometry><mesh filename="{fore}"/></geometry></visual></link>
 <link name="tool"><visual><origin xyz="0.01 0 0"/><geometry><sphere radius="0.02"/></geometry>
  </visual></link>
 <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
  <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
  <limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
 <joint name="elbow" type="continuous"><parent link="upper"/><child link="fore"/>
  <origin xyz="0 0 0.3" rpy="0.2 0 0"/><axis xyz="0 1 0"/></joint>
 <joint name="flange" type="fixed"><parent link="fore"/><child link="tool"/>
  <origin xyz="0 0 0.25" rpy="0 0 1.0"/></joint>
</robot>
"""
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_browser = pytest.mark.skipif(CHROMIUM is None, reason="no chromium (apt-get install -y "
                                                            "chromium)")


def binary_stl(points, faces) -> bytes:
    data = b"\0" * 80 + struct.pack("<I", len(faces))
    for face in faces:
        data += struct.pack("<12fH", 0, 0, 0, *np.asarray(points)[list(face)].ravel(), 0)
    return data


def write_package(folder: Path) -> Path:
    """A ROS package ``meshpkg`` in ``folder`` with one mesh of each kind."""
    package = folder / "meshpkg"
    (package / "meshes").mkdir(parents=True)
    (package / "package.xml").write_text("<package><name>meshpkg</name></package>")
    (package / "meshes" / "cube.stl").write_bytes(binary_stl(CUBE, CUBE_FACES))
    (package / "meshes" / "tri.stl").write_text(
        "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 0.2 0 0\n"
        "  vertex 0 0.2 0\n endloop\nendfacet\nendsolid t\n")
    (package / "meshes" / "square.obj").write_text(
        "# square\nv 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\nf 1/1/1 2/2/2 3/3/3 -1\n")
    (package / "meshes" / "square.dae").write_text(DAE)
    return package


def write_arm(folder: Path, base="package://meshpkg/meshes/cube.stl",
              upper="../meshes/square.obj", fore="package://meshpkg/meshes/square.dae") -> Path:
    package = write_package(folder)
    (package / "urdf").mkdir()
    urdf = package / "urdf" / "arm.urdf"
    urdf.write_text(ARM.format(base=base, upper=upper, fore=fore, inertial=INERTIAL))
    return urdf


# -- meshes -----------------------------------------------------------------------------
def corners(part: meshes.Part) -> np.ndarray:
    """The triangles' corners as a sorted set of points (independent of indexing)."""
    return np.unique(np.round(part.positions[part.triangles].reshape(-1, 3), 9), axis=0)


def test_mesh_readers_give_the_written_triangles(tmp_path):
    package = write_package(tmp_path)
    [cube] = meshes.read_mesh(package / "meshes" / "cube.stl")
    assert len(cube.triangles) == 12 and len(cube.positions) == 8      # shared corners merged
    assert np.allclose(corners(cube), np.unique(CUBE, axis=0))
    [tri] = meshes.read_mesh(package / "meshes" / "tri.stl")
    assert np.allclose(tri.positions[tri.triangles[0]], [[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0]])
    [square] = meshes.read_mesh(package / "meshes" / "square.obj")     # a quad: two triangles
    assert square.triangles.tolist() == [[0, 1, 2], [0, 2, 3]]
    [dae] = meshes.read_mesh(package / "meshes" / "square.dae")
    # 10 units of 1 cm, the node translated by 5 cm along z; the material's colour
    expected = np.array([[0, 0, 0.05], [0.1, 0, 0.05], [0.1, 0.1, 0.05], [0, 0.1, 0.05]])
    assert np.allclose(dae.positions[dae.triangles].reshape(-1, 3),
                       expected[[0, 1, 2, 0, 2, 3]])
    assert dae.color == (0.8, 0.1, 0.1, 1.0)


def test_pack_quantizes_within_half_a_step(tmp_path):
    [cube] = meshes.read_mesh(write_package(tmp_path) / "meshes" / "cube.stl")
    packed = pack(cube)
    import base64

    u = np.frombuffer(base64.b64decode(packed["positions"]), "<u2").reshape(-1, 3)
    back = np.array(packed["low"]) + u * np.array(packed["step"])
    assert np.abs(back - cube.positions).max() <= max(packed["step"]) / 2 + 1e-12
    assert not packed["wide"] and packed["triangles"] == 12


@pytest.mark.parametrize("name, raw, message", [
    ("bad.stl", b"solid x\n vertex 0 0 0\n vertex 1 0 0\n", "not a multiple of 3"),
    ("bad.stl", b"\x00\x01" * 100, "neither binary STL"),
    ("bad.obj", b"v 0 0 0\nf 1 2 3\n", "index out of range"),
    ("bad.dae", b"<!DOCTYPE x [<!ENTITY a 'b'>]><COLLADA/>", "XML refused"),
    ("bad.ply", b"ply", "mesh format .ply is not read"),
    ("bad.dae", DAE.replace("<vcount>4</vcount>", "").encode(), "not a readable DAE mesh"),
    ("bad.dae", DAE.replace("#g-pos", "#nowhere").encode(), "reference '#nowhere' not found"),
    ("bad.dae", DAE.replace('semantic="POSITION"', 'semantic="NORMAL"').encode(),
     "not a readable DAE mesh"),
])
def test_bad_meshes_are_one_line(tmp_path, name, raw, message):
    (tmp_path / name).write_bytes(raw)
    with pytest.raises(service.ModelError, match=message):
        meshes.read_mesh(tmp_path / name)


# -- URDF visuals and their paths ------------------------------------------------------------
def test_visuals_sit_where_pinocchio_puts_the_links(tmp_path):
    """Owner body pose (anadyn's kinematics) x visual pose in the owner's frame equals
    Pinocchio's link frame x the visual's <origin>, at a random configuration."""
    pin = pytest.importorskip("pinocchio")
    from anadyn_cli.model.urdf import rpy_matrix

    urdf = write_arm(tmp_path)
    found = visuals(urdf)
    assert [(v.link, v.owner, v.kind) for v in found.items] == [
        ("base", -1, "mesh"), ("upper", 0, "mesh"), ("fore", 1, "mesh"), ("tool", 1, "sphere")]
    assert found.items[0].color == (0.1, 0.2, 0.9, 1.0) and found.items[1].size == (2, 2, 2)
    robot = load_robot(urdf)
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    q = np.array([0.7, -1.1])
    # joints in file order, as anadyn's coordinates; a continuous joint is (cos, sin) in Pinocchio
    pin.forwardKinematics(model, data, np.array([q[0], np.cos(q[1]), np.sin(q[1])]))
    pin.updateFramePlacements(model, data)
    poses = frames(robot)(q)
    origins = {"base": ([0, 0, 0], [0, 0, 0]), "upper": ([0, 0, 0.05], [0, 0.3, 0]),
               "fore": ([0, 0, 0], [0, 0, 0]), "tool": ([0.01, 0, 0], [0, 0, 0])}
    for item in found.items:
        body = np.eye(4)
        if item.owner >= 0:
            body[:3, :3], body[:3, 3] = poses.R[item.owner], poses.origin[item.owner]
        link = data.oMf[model.getFrameId(item.link)].homogeneous
        xyz, rpy = origins[item.link]
        local = np.eye(4)
        local[:3, :3], local[:3, 3] = rpy_matrix(rpy), xyz
        assert np.allclose(body @ item.matrix, link @ local, atol=1e-12), item.link


def test_package_path_option_finds_a_package_elsewhere(tmp_path):
    package = write_package(tmp_path / "packages")
    (tmp_path / "robot").mkdir()
    urdf = tmp_path / "robot" / "arm.urdf"
    urdf.write_text(ARM.format(base="package://meshpkg/meshes/cube.stl",
                               upper="package://meshpkg/meshes/tri.stl",
                               fore="package://meshpkg/meshes/square.dae", inertial=INERTIAL))
    assert visuals(urdf).warnings[0].startswith(f"{urdf}: package 'meshpkg' not found")
    found = visuals(urdf, [tmp_path / "packages"])
    assert not found.warnings
    assert [v.path for v in found.items[:3]] == [
        (package / "meshes" / n).resolve() for n in ("cube.stl", "tri.stl", "square.dae")]


@pytest.mark.parametrize("filename", ["../../../../../../etc/passwd", "/etc/passwd",
                                      "file:///etc/passwd", "package://meshpkg/../../x.stl",
                                      "link.stl"])
def test_paths_outside_the_roots_are_refused(tmp_path, capsys, filename):
    urdf = write_arm(tmp_path, upper=filename)
    (urdf.parent / "link.stl").symlink_to("/etc/passwd")     # a link inside that leads out
    assert main(["view", str(urdf), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == (f"anadyn: error: {urdf}: link 'upper': <visual> <mesh filename=\"{filename}\">: "
                   "the file is outside the URDF's folder and its package roots; meshes must be "
                   "inside them\n")
    assert not (tmp_path / "out").exists()


def test_missing_meshes_warn_and_draw_generated_shapes(tmp_path, capsys):
    urdf = write_arm(tmp_path, upper="package://nowhere/a.stl", fore="meshes/none.stl")
    assert main(["view", str(urdf), "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert "package 'nowhere' not found" in err and "meshes/none.stl\">: no such file" in err
    scene = scene_of(tmp_path / "out" / "view.html")
    kinds = [(s["body"], s["kind"]) for s in scene["shapes"]]
    assert (-1, "mesh") in kinds and (1, "sphere") in kinds      # the base's cube, the tool
    assert (0, "cylinder") in kinds                               # generated for 'upper'


def scene_of(html: Path) -> dict:
    text = html.read_text(encoding="utf-8")
    start = text.index('<script type="application/json" id="anadyn-scene">')
    body = text[text.index(">", start) + 1:text.index("</script>", start)]
    return json.loads(body)


# -- the scene ---------------------------------------------------------------------------
def compose(live: list, q: np.ndarray) -> list[np.ndarray]:
    """Body poses from the live-mode data, composed as viewer.js does."""
    from anadyn_cli.output.view.meshes import _axis_angle

    poses = []
    for joint in live:
        d = joint["offset"] + np.dot(joint["gains"], q)
        motion = np.eye(4)
        axis = np.array(joint["axis"])
        if joint["type"] == "revolute":
            motion[:3, :3] = _axis_angle(axis, d)
        elif joint["type"] == "prismatic":
            motion[:3, 3] = axis * d
        parent = poses[joint["parent"]] if joint["parent"] >= 0 else np.eye(4)
        poses.append(parent @ np.array(joint["matrix"]).reshape(4, 4) @ motion)
    return poses


@pytest.mark.parametrize("name", ["rr", "rrt", "arm", "panda"])     # panda: a <mimic> finger
def test_live_mode_data_reproduce_the_forward_kinematics(tmp_path, name):
    robot = load_robot(write_arm(tmp_path) if name == "arm" else name)
    scene = service.view(robot, use_cache=False).scene
    assert scene["live"] is not None and len(scene["live"]) == len(robot.bodies)
    fk = frames(robot)
    for q in np.random.default_rng(1).uniform(-1.5, 1.5, (5, len(robot.coordinates))):
        pose = fk(q)
        for i, matrix in enumerate(compose(scene["live"], q)):
            assert np.allclose(matrix[:3, :3], pose.R[i], atol=1e-12)
            assert np.allclose(matrix[:3, 3], pose.origin[i], atol=1e-12)


def test_a_run_is_played_decimated_with_poses_and_effort_arrows(tmp_path):
    robot = load_robot("rr")
    t = np.linspace(0, 10, 2001)
    q = np.column_stack([0.3 * np.sin(t), 0.5 * np.cos(t)])
    torque = np.column_stack([np.cos(t), -2 * np.ones_like(t)])
    csv = tmp_path / "simulate.csv"
    rows = np.column_stack([t, q, torque])
    csv.write_text("t,q1,q2,T01z,T12z\n" + "\n".join(",".join(map(repr, r)) for r in rows.tolist()))
    run = service.read_run(csv, ["q1", "q2"])
    scene = service.view(robot, run, use_cache=False).scene
    times = np.array(scene["times"])
    assert len(times) == service.MAX_FRAMES and times[0] == 0 and times[-1] == 10
    import base64

    poses = np.frombuffer(base64.b64decode(scene["poses"]), "<f4").reshape(len(times), 2, 3, 4)
    # bar 2's origin is bar 1's far end: (L1 cos q1, L1 sin q1, 0) with L1 = 1 m
    q1 = 0.3 * np.sin(times)
    assert np.allclose(poses[:, 1, :, 3], np.column_stack([np.cos(q1), np.sin(q1), 0 * q1]),
                       atol=1e-6)
    arrows = {a["name"]: a for a in scene["arrows"]}
    assert set(arrows) == {"T01z", "T12z"} and arrows["T12z"]["peak"] == 2
    vectors = np.frombuffer(base64.b64decode(arrows["T12z"]["vectors"]), "<f4").reshape(-1, 3)
    assert np.allclose(vectors, [0, 0, -0.3 * scene["extent"]], atol=1e-6)   # -z: negative torque


def test_load_arrows_follow_the_loads_expressions(tmp_path):
    """rrt_friction's payload: force (-P, 5 sin 2t, 0) N in world axes at (0, 0, tool)
    on link3; the arrows at the run's rows against those expressions."""
    import base64

    robot = load_robot("rrt_friction")
    t = np.linspace(0, 2, 41)
    q = np.column_stack([0.2 + 0 * t, 0.9 + 0.2 * t, 0.25 + 0 * t])
    csv = tmp_path / "simulate.csv"
    np.savetxt(csv, np.column_stack([t, q, 0 * q]), delimiter=",", comments="",
               header="t,q1,q2,q3,dq1,dq2,dq3")
    scene = service.view(robot, service.read_run(csv, ["q1", "q2", "q3"]), use_cache=False).scene
    [arrow] = [a for a in scene["arrows"] if a["name"] == "load 1 on link3"]
    assert arrow["color"] == service.LOAD_COLOR
    P, tool = (float(robot.parameters[k]) for k in ("P", "tool"))
    force = np.column_stack([-P + 0 * t, 5 * np.sin(2 * t), 0 * t])
    assert np.isclose(arrow["peak"], np.linalg.norm(force, axis=1).max())
    vectors = np.frombuffer(base64.b64decode(arrow["vectors"]), "<f4").reshape(-1, 3)
    assert np.allclose(vectors, force / arrow["peak"] * 0.3 * scene["extent"], atol=1e-6)
    pose = frames(robot)(q)
    origins = np.frombuffer(base64.b64decode(arrow["origins"]), "<f4").reshape(-1, 3)
    assert np.allclose(origins, pose.origin[:, 2] + pose.R[:, 2, :, 2] * tool, atol=1e-6)


@pytest.mark.parametrize("text, message", [
    ("t,q1\n0,1\n", "simulate.csv:1: header has no column q2; expected t, q1, q2, ... "
                      "(simulate.csv or inverse.csv of this robot)"),
    ("t,q1,q2\n0,1,x\n", "simulate.csv:2: expected 3 numbers separated by commas"),
    ("t,q1,q2\n0,1,nan\n", "simulate.csv:2: expected 3 finite numbers, got 3"),
    ("t,q1,q2\n1,1,1\n0,1,1\n", "simulate.csv: t decreases; rows must be in time order"),
    ("t,q1,q2\n", "simulate.csv: no rows after the header"),
])
def test_bad_runs_are_one_line(tmp_path, capsys, monkeypatch, text, message):
    monkeypatch.chdir(tmp_path)
    Path("simulate.csv").write_text(text)
    assert main(["view", "rr", "simulate.csv"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == f"anadyn: error: {message}"
    assert not Path("results").exists()


def test_a_pipe_as_the_run_is_refused_not_read(tmp_path, capsys):
    import os

    os.mkfifo(tmp_path / "run.csv")          # reading it would wait for a writer forever
    assert main(["view", "rr", str(tmp_path / "run.csv"), "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        f"anadyn: error: {tmp_path / 'run.csv'}: is not a regular file, expected a CSV file")


def test_names_cannot_close_the_script_element():
    html = page({"name": "</script><script>alert(1)</script>"}, "a </script> b", False)
    assert html.count("</script>") == 5            # the five script elements' own ends
    assert "alert(1)" in html and "<script>alert" not in html


def test_the_page_is_self_contained(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["view", "rr"]) == 0
    html = Path("results/rr/view.html").read_text()
    assert not re.search(r"<(script|link|img|iframe)[^>]*(src|href)=", html)   # nothing fetched
    summary = json.loads(Path("results/rr/view.json").read_text())
    assert summary["live"] and summary["shapes"] == 4 and summary["bytes"] < 1_000_000


ERD = next((p for p in (Path(s) / "cmeel.prefix/share/example-robot-data/robots" for s in sys.path)
            if p.is_dir()), None)


@pytest.mark.skipif(ERD is None, reason="example-robot-data is not installed")
def test_ur5_collada_visuals_fill_the_collision_boxes():
    """The UR5's COLLADA visual meshes and its STL collision meshes are separate files
    of one shape: their bounding boxes agree to 2 mm."""
    robot = load_robot("ur5")
    found = visuals(Path(robot.source))
    assert not found.warnings and len(found.items) == 7
    for item in found.items:
        collision = item.path.parent.parent / "collision" / (item.path.stem + ".stl")
        parts = meshes.read_mesh(item.path)
        low = np.min([p.positions[p.triangles].min(axis=(0, 1)) for p in parts], axis=0)
        [stl] = meshes.read_mesh(collision)
        assert np.allclose(low, stl.positions.min(axis=0), atol=2e-3), item.path.name


# -- in a browser ------------------------------------------------------------------------
def browse(tmp_path: Path, url: str, status: str) -> np.ndarray:
    """A screenshot of the page below its header, after checking (same run, --dump-dom)
    that the page says ``status`` and logged no error."""
    from matplotlib.image import imread

    png = tmp_path / f"shot{len(list(tmp_path.glob('shot*.png')))}.png"
    done = subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu",
                           "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
                           "--window-size=640,480", "--virtual-time-budget=3000",
                           "--enable-logging=stderr", "--v=0", "--dump-dom",
                           f"--screenshot={png}", url],
                          capture_output=True, text=True, timeout=120)
    shown = re.search(r'<div id="status"[^>]*>([^<]*)<', done.stdout)
    assert shown and shown[1] == f"drawn: {status}", done.stderr[-2000:]
    errors = [line for line in done.stderr.splitlines()      # SwiftShader's performance
              if ("CONSOLE" in line or "Uncaught" in line)      # notes are not the page's
              and "GL Driver Message" not in line]
    assert not errors
    return imread(png)[170:, :, :3]          # below the controls


def changed(a: np.ndarray, b: np.ndarray) -> float:
    """The fraction of pixels that differ."""
    return float((np.abs(a - b).max(axis=2) > 0.02).mean())


@needs_browser
def test_the_page_draws_the_robot_without_errors_and_the_slider_moves_it(tmp_path, monkeypatch):
    import anadyn

    monkeypatch.chdir(tmp_path)
    run = anadyn.simulate("rrt", t_end=4)        # coordinates only: no effort arrows to move
    np.savetxt("simulate.csv", np.column_stack([run.t, run.x[:, :3]]), delimiter=",",
               header="t,q1,q2,q3", comments="")
    assert main(["view", "rrt", "simulate.csv"]) == 0
    url = (tmp_path / "results" / "rrt" / "view.html").as_uri()
    start = browse(tmp_path, url + "#t=0", "5 shapes on 3 bodies, frame 1 of 401")
    end = browse(tmp_path, url + "#t=end", "5 shapes on 3 bodies, frame 401 of 401")
    empty = browse(tmp_path, url + "#t=0&empty",
                   "5 shapes on 3 bodies, frame 1 of 401, robot hidden")
    assert changed(start, empty) > 0.005          # the robot is drawn
    assert changed(start, end) > 0.005            # the time slider moves it


@needs_browser
def test_live_sliders_and_meshes_in_the_browser(tmp_path):
    urdf = write_arm(tmp_path)
    assert main(["view", str(urdf), "--out", str(tmp_path / "out")]) == 0
    url = (tmp_path / "out" / "view.html").as_uri()
    rest = browse(tmp_path, url, "4 shapes on 2 bodies, live")
    bent = browse(tmp_path, url + "#q=0,1.2", "4 shapes on 2 bodies, live")
    empty = browse(tmp_path, url + "#empty", "4 shapes on 2 bodies, live, robot hidden")
    assert changed(rest, empty) > 0.002 and changed(rest, bent) > 0.002


@needs_browser
def test_live_mode_draws_the_pose_that_anadyn_computes(tmp_path):
    """The page's own composition in live mode gives the picture of the same pose
    played from anadyn's poses."""
    urdf = write_arm(tmp_path)
    assert main(["view", str(urdf), "--out", str(tmp_path / "out")]) == 0
    csv = tmp_path / "run.csv"
    csv.write_text("t,shoulder,elbow\n0,0.7,-1.1\n1,0,0\n")   # the robot's size as in live mode
    assert main(["view", str(urdf), str(csv), "--out", str(tmp_path / "run")]) == 0
    played = browse(tmp_path, (tmp_path / "run" / "view.html").as_uri(),
                    "4 shapes on 2 bodies, frame 1 of 2")
    live = browse(tmp_path, (tmp_path / "out" / "view.html").as_uri() + "#q=0.7,-1.1",
                  "4 shapes on 2 bodies, live")
    assert changed(live, played) < 0.002          # (0.22 when the page composes wrongly)


@needs_browser
def test_a_closed_chain_shows_its_initial_pose_in_the_browser(tmp_path, capsys):
    assert main(["view", "fourbar", "--out", str(tmp_path)]) == 0
    assert "anadyn: note: loop constraints: the coordinates are not independent" \
        in capsys.readouterr().err
    browse(tmp_path, (tmp_path / "view.html").as_uri(), "6 shapes on 3 bodies, frame 1 of 1")


# -- notebooks ---------------------------------------------------------------------------
def test_robots_and_results_display_themselves():
    import anadyn

    robot = anadyn.load("rrt")
    assert repr(robot) == f"<Robot rrt: 3 DOF (q1, q2, q3), 3 bodies, 3 actuators; {robot.source}>"
    assert "<td>link3</td><td>link2</td><td>prismatic</td>" in robot._repr_html_()
    run = anadyn.simulate(robot, t_end=1, output_step=0.1)
    table = run._repr_html_()
    assert "<caption>rrt: SimulationResult, 11 rows x 10 columns</caption>" in table
    assert "<th>0</th><td>0</td>" in table and "<th>10</th><td>1</td>" in table
    assert "5 more rows" in table and "<th>max</th>" in table
    assert run._repr_png_().startswith(b"\x89PNG\r\n\x1a\n")
    inverse = anadyn.inverse(robot, roundtrip=False)
    assert "InverseResult, 1501 rows x 13 columns" in inverse._repr_html_()
    frame = service.view(robot, use_cache=False)._repr_html_()
    assert frame.startswith('<iframe srcdoc="&lt;!DOCTYPE html&gt;') and "</script>" not in frame
