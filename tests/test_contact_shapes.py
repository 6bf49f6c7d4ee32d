"""Capsules and boxes as contact geometry (issue 27; ``model.loader.contacts``,
``numeric.contact``): against a ground a capsule is its two end spheres and a box its
eight corners; against a sphere, the point of the segment or of the box nearest the
sphere's centre.

Checked against closed forms of the compliant law (rest forces and depths, a tilted
box's first corner and its energy, the stop distance of a sliding box, a capsule
rolling down an incline, a ball resting on a capsule's side and end cap and on a box's
face and edge), the gripper scene (holds when 2 mu F > m g, slides at g - 2 mu F / m
below), MuJoCo's rest pose of a dropped box, and the file's mistakes (one line,
exit 2)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from anadyn_cli import robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.model.loader import load_robot
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services.check import check
from anadyn_cli.services.simulate import simulate

G = 9.81
K = 1e6                                       # N/m^1.5 in every scene but the gripper


def _run(text, t_end, step, rtol=1e-10):
    model = numeric_model(robot_from_text(text, "scene.yaml"))
    return model, simulate(model, rtol=rtol, atol=rtol * 1e-2, t_end=t_end, output_step=step)


def _planar(geometry, m=2.0, x=0.0, z=0.1, pitch=0.0, rate=0.0, slides_only=False,
            inertia="m*(a**2 + c**2)/3", friction=0.5, ground="{normal: [0, 0, 1]}"):
    """A body on x and z slides (and a pitch joint about y unless ``slides_only``) with
    the contact ``geometry`` against ``ground``; box-like inertia of half-extents a, b,
    c = 0.2, 0.1, 0.05 (about y: ``inertia``)."""
    turn = "" if slides_only else f"""  - name: body
    parent: sz
    joint: {{type: revolute, axis: [0, 1, 0], displacement: pitch}}
    mass: m
    inertia: {{ixx: m*(b**2 + c**2)/3, iyy: {inertia}, izz: m*(a**2 + b**2)/3}}
"""
    return f"""
name: shape
parameters: {{m: {m}, a: 0.2, b: 0.1, c: 0.05}}
gravity: [0, 0, -{G}]
coordinates:
  x: {{initial: {x}, rate: {rate}}}
  z: {{initial: {z}}}
{'' if slides_only else f'  pitch: {{initial: {pitch}}}'}
bodies:
  - {{name: sx, joint: {{type: prismatic, axis: [1, 0, 0], displacement: x}}, mass: 0}}
  - {{name: {'body' if slides_only else 'sz'}, parent: sx,
     joint: {{type: prismatic, axis: [0, 0, 1], displacement: z}},
     mass: {'m' if slides_only else 0}, inertia: {{ixx: 0.01, iyy: 0.01, izz: 0.01}}}}
{turn}contacts:
  ground: {ground}
  stiffness: {K}
  damping: 3e6
  friction: {friction}
  geometry:
    - {geometry}
"""


BOX = "{name: crate, body: body, shape: box, size: [a, b, c]}"


def test_a_box_at_rest_carries_its_weight_on_its_four_lower_corners():
    """Corners _1, _3, _5, _7 (the negative z half-extent) each carry m g / 4 at the
    depth (m g / 4 k)^(2/3); the upper four are in the air (the old loader refused
    ``shape``)."""
    depth = (2.0 * G / 4 / K) ** (2 / 3)
    model, run = _run(_planar(BOX, z=0.05 - depth), 1.0, 1e-2)
    assert model.contact_names == tuple(f"crate_{j}" for j in range(1, 9))
    fn, d = run.contacts.values[:, 0, -1], run.contacts.values[:, 3, -1]
    assert np.abs(fn[0::2] - 2.0 * G / 4).max() < 1e-9 * G
    assert np.all(fn[1::2] == 0) and np.abs(d[1::2] + 0.1 - depth).max() < 1e-9
    assert abs(fn.sum() - 2.0 * G) < 1e-8 * G
    assert abs(run.x[-1, 1] - (0.05 - depth)) < 1e-10 and abs(run.x[-1, 2]) < 1e-10


def _tilted_box(damping):
    """A floating box (half-extents 0.2, 0.1, 0.05, 2 kg) tilted about [1, 2, 0] by 0.3
    rad and let go 5 cm above the floor at its lowest corner."""
    axis = np.array([1.0, 2.0, 0.0]) / math.sqrt(5)
    half = np.array([0.2, 0.1, 0.05])
    w, v = math.cos(0.15), math.sin(0.15) * axis
    quaternion = [w, *v]
    x, y, z = v
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    corners = [(2 * np.array(j) - 1) * half for j in np.ndindex(2, 2, 2)]
    heights = [(R @ c)[2] for c in corners]
    lowest = int(np.argmin(heights))
    start = 0.05 - heights[lowest]
    names = ("box_qw", "box_qx", "box_qy", "box_qz")
    text = f"""
name: tilted
parameters: {{m: 2.0, a: 0.2, b: 0.1, c: 0.05}}
gravity: [0, 0, -{G}]
coordinates:
  box_z: {{initial: {start}}}
{''.join(f'  {n}: {{initial: {q}}}{chr(10)}' for n, q in zip(names, quaternion))}bodies:
  - name: box
    joint: {{type: floating}}
    mass: m
    inertia: {{ixx: m*(b**2 + c**2)/3, iyy: m*(a**2 + c**2)/3, izz: m*(a**2 + b**2)/3}}
contacts:
  stiffness: 1e5
  damping: {damping}
  friction: 0.5
  geometry:
    - {{name: crate, body: box, shape: box, size: [a, b, c]}}
"""
    return text, lowest, start


def _mechanical_energy(model, run):
    q, u = run.x[:, :len(model.coordinates)].T, run.x[:, len(model.coordinates):].T
    kinetic, potential = model.energy(q, u)
    return kinetic + potential + run.contacts.values[:, 4].sum(axis=0)


def test_a_tilted_box_lands_on_one_corner_then_settles_losing_energy():
    """The first touch-down is the lowest corner's, after the free fall's sqrt(2 h / g);
    T + V + V_c never rises (friction and damping only take energy away; undamped and
    frictionless it stays constant to the tolerance) and the box comes to rest flat on
    its four lower corners carrying m g."""
    text, lowest, _ = _tilted_box(3e5)
    model, run = _run(text, 1.5, 1e-3, rtol=1e-9)
    first = run.contacts.events()[0]
    assert first["contact"] == f"crate_{lowest + 1}" and first["event"] == "touch-down"
    assert abs(first["t"] - math.sqrt(2 * 0.05 / G)) < 1e-6
    energy = _mechanical_energy(model, run)
    assert np.diff(energy).max() < 1e-7 * abs(energy[0])
    fn = run.contacts.values[:, 0, -1]
    assert abs(fn.sum() - 2.0 * G) < 1e-6 * G and np.all(fn[1::2] == 0)
    final = dict(zip(model.state_names(), run.x[-1]))
    assert abs(final["box_z"] - (0.05 - (2.0 * G / 4 / 1e5) ** (2 / 3))) < 1e-6
    assert abs(final["box_qx"]) < 1e-6 and abs(final["box_qy"]) < 1e-6     # flat
    report = check(model, rtol=1e-9, atol=1e-11, t_end=0.5, output_step=1e-3)
    assert report.energy_error < 1e-6
    model, run = _run(_tilted_box(0)[0].replace("friction: 0.5", "friction: 0"), 0.4, 1e-3)
    energy = _mechanical_energy(model, run)
    assert np.abs(energy - energy[0]).max() < 1e-7 * abs(energy[0])


def test_a_capsule_lying_on_the_floor_rests_on_its_two_end_spheres_equally():
    """A capsule along x (ends at x = -+0.15, radius 0.04): its ends _1 and _2 carry m g / 2
    each at the depth (m g / 2 k)^(2/3)."""
    capsule = ("{name: rod, body: body, shape: capsule, radius: 0.04, from: [-0.15, 0, 0], "
               "to: [0.15, 0, 0]}")
    depth = (2.0 * G / 2 / K) ** (2 / 3)
    model, run = _run(_planar(capsule, z=0.045, pitch=0.05), 3.0, 1e-2)
    assert model.contact_names == ("rod_1", "rod_2")
    fn = run.contacts.values[:, 0, -1]
    assert abs(fn[0] - fn[1]) < 1e-8 * G and abs(fn.sum() - 2.0 * G) < 1e-8 * G
    assert abs(run.x[-1, 1] - (0.04 - depth)) < 1e-9 and abs(run.x[-1, 2]) < 1e-9


def test_a_sliding_box_stops_after_the_regularized_coulomb_distance():
    """Pushed at v0 on its four lower corners (no pitch: each corner carries m g / 4), it
    stops after (v0^2 / 2 + (pi^2 / 12) v_s^2) / (mu g) (docs/how-to/contact.md)."""
    v0, mu, vs = 2.0, 0.5, 0.01
    model, run = _run(_planar(BOX, z=0.05 - (2.0 * G / 4 / K) ** (2 / 3), rate=v0,
                              slides_only=True), 1.0, 1e-3)
    regularized = (v0 ** 2 / 2 + math.pi ** 2 / 12 * vs ** 2) / (mu * G)
    assert abs(run.x[-1, 0] - regularized) < 1e-8
    assert abs(run.x[-1, 0] - v0 ** 2 / (2 * mu * G)) < 1.7e-5


def test_a_capsule_rolls_down_an_incline_about_its_axis():
    """A capsule with its axis along y on a 25 degree incline rolls at
    g sin / (1 + I / (m r^2)) (I its moment about the axis), both ends rolling."""
    theta, r, m, inertia = math.radians(25), 0.05, 2.0, 0.03
    depth = (m * G * math.cos(theta) / 2 / K) ** (2 / 3)
    capsule = (f"{{name: roll, body: body, shape: capsule, radius: {r}, from: [0, -0.1, 0], "
               "to: [0, 0.1, 0]}")
    _, run = _run(_planar(capsule, m, (r - depth) * math.sin(theta), (r - depth) *
                          math.cos(theta), inertia=inertia, friction=0.6,
                          ground=f"{{normal: [{math.sin(theta)}, 0, {math.cos(theta)}]}}"),
                  1.0, 1e-3)
    down = run.x[:, 3] * math.cos(theta) - run.x[:, 4] * math.sin(theta)   # the speed
    first = np.argmax(run.t > 0.3)                # past the start's transient: uniform
    acceleration = (down[-1] - down[first]) / (run.t[-1] - run.t[first])
    rolling = G * math.sin(theta) / (1 + inertia / (m * r * r))
    assert abs(acceleration - rolling) < 1e-6 * rolling
    fn = run.contacts.values[:, 0, -1]
    assert abs(fn[0] - fn[1]) < 1e-6 * fn[0]
    slip = 0.01 * math.atanh(inertia / (inertia + m * r * r) * math.tan(theta) / 0.6)
    assert abs(down[-1] - r * run.x[-1, 5] - slip) < 1e-4 * slip     # rolls, v_s's creep


def _ball_on(shape, x, z):
    """A ball (radius 0.05, 1 kg) on a vertical slide at x, let go at height z over
    ``shape`` on a body that slides along y only (normal to every force here).  Let go
    close: in a long free fall an integrator's step could carry the ball past a thin
    shape, which no force resists once the centres have crossed."""
    return f"""
name: ball_on_shape
gravity: [0, 0, -{G}]
coordinates:
  z: {{initial: {z}}}
  y: {{}}
bodies:
  - {{name: ball, joint: {{type: prismatic, axis: [0, 0, 1], origin: [{x}, 0, 0],
     displacement: z}}, mass: 1, inertia: {{ixx: 0.001, iyy: 0.001, izz: 0.001}}}}
  - {{name: table, joint: {{type: prismatic, axis: [0, 1, 0], displacement: y}}, mass: 1,
     inertia: {{ixx: 0.001, iyy: 0.001, izz: 0.001}}}}
contacts:
  stiffness: {K}
  damping: 3e7
  geometry:
    - {{name: touch, body: table, {shape}, against: {{body: ball, radius: 0.05}}}}
"""


CAPSULE = "shape: capsule, radius: 0.02, from: [-0.1, 0, 0], to: [0.1, 0, 0]"


@pytest.mark.parametrize("shape, x, level, rho, beyond", [
    (CAPSULE, 0.03, 0.0, 0.02, 0.0),                          # on the segment's side
    (CAPSULE, 0.13, 0.0, 0.02, 0.03),                         # on the end cap
    ("shape: box, size: [0.1, 0.1, 0.03], rpy: [0, 0, 0.4]", 0.02, 0.03, 0.0, 0.0),   # face
    ("shape: box, size: [0.1, 0.1, 0.03]", 0.12, 0.03, 0.0, 0.02),                  # edge
])
def test_a_ball_rests_on_the_nearest_point_of_a_capsule_or_a_box(shape, x, level, rho,
                                                                   beyond):
    """Above the segment (or the face at height ``level``) the ball rests at
    level + rho + r - d, d = (m g / k)^(2/3); beyond the segment's end (or the edge) by
    ``beyond``, on the end cap (or the edge): the normal tilts by phi,
    sin phi = beyond / (r + rho - d), and f_n cos phi = m g."""
    _, run = _run(_ball_on(shape, x, level + math.sqrt((rho + 0.051) ** 2 - beyond ** 2)),
                  1.0, 1e-3)
    fn, depth = run.contacts.values[0, 0, -1], run.contacts.values[0, 3, -1]
    reach = 0.05 + rho - depth
    cosine = math.sqrt(1 - (beyond / reach) ** 2)
    assert abs(fn * cosine - G) < 1e-8 * G and abs(fn - K * depth ** 1.5) < 1e-8 * fn
    assert abs(run.x[-1, 0] - (level + reach * cosine)) < 1e-9
    assert abs(run.x[-1, 1]) < 1e-12                       # no push along y


def _gripper(grip):
    return load_robot("robots/contact/gripper.yaml", {"F": grip})


def test_the_gripper_holds_the_box_when_2_mu_f_exceeds_its_weight_and_drops_it_below():
    """Holding (F = 3 N, 2 mu F = 3 N > m g = 1.96 N): the box creeps at the regularized
    law's v_s atanh(m g / (2 mu F)), each pad's friction m g / 2; slipping (F = 1.5 N): it
    slides at g - 2 mu F / m."""
    m, mu, vs = 0.2, 0.5, 0.001
    model = numeric_model(_gripper(3.0))
    run = simulate(model, rtol=1e-9, atol=1e-11, t_end=1.0, output_step=1e-3)
    assert abs(run.x[-1, 3] + vs * math.atanh(m * G / (2 * mu * 3.0))) < 1e-9
    values = run.contacts.values[:, :, -1]
    assert np.abs(values[:, 0] - 3.0).max() < 1e-9 and np.abs(values[:, 1] - m * G / 2).max() < 1e-9
    model = numeric_model(_gripper(1.5))
    run = simulate(model, rtol=1e-9, atol=1e-11, t_end=0.15, output_step=1e-3)
    late = run.t > 0.05                           # within 3 cm: the pads stay on its sides
    acceleration = np.polyfit(run.t[late], run.x[late, 3], 1)[0]
    assert abs(acceleration + (G - 2 * mu * 1.5 / m)) < 1e-6


def test_mujoco_box_dropped_tilted_rests_as_ours_does():
    """A box (planar: x, z, pitch) dropped 5 cm tilted by 0.3 rad lands on an edge and
    settles flat: MuJoCo's rest height and ours are its half-height c less each soft
    contact's penetration (ours 0.29 mm), within 1 mm; pitch 0 in both."""
    mj = pytest.importorskip("mujoco")
    xml = """<mujoco><option timestep="1e-4" gravity="0 0 -9.81"/><worldbody>
      <geom type="plane" size="5 5 0.1" friction="0.5 0 0"/>
      <body pos="0 0 0.2"><joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/><joint name="pitch" axis="0 1 0"/>
      <geom type="box" size="0.2 0.1 0.05" mass="2" friction="0.5 0 0"/></body>
      </worldbody></mujoco>"""
    M = mj.MjModel.from_xml_string(xml)
    D = mj.MjData(M)
    D.qpos[2] = 0.3
    while D.time < 2.0:
        mj.mj_step(M, D)
    _, run = _run(_planar(BOX, z=0.2, pitch=0.3), 2.0, 1e-2, rtol=1e-8)
    ours = run.x[-1, 1:3]
    theirs = np.array([D.qpos[1] + 0.2, D.qpos[2]])       # its z: from the body's pos
    assert abs(ours[0] - (0.05 - (2.0 * G / 4 / K) ** (2 / 3))) < 1e-8
    assert abs(theirs[0] - 0.05) < 1e-3 and abs(ours[0] - theirs[0]) < 1e-3
    assert abs(ours[1]) < 1e-8 and abs(theirs[1]) < 1e-3


@pytest.mark.parametrize("change, message", [
    ("shape: box, size: [a, 0, c]", "contacts.geometry[0].size[1]: must be positive (a "
     "half-extent of the box, m), got 0"),
    ("shape: box, size: [a, b, c], radius: 0.1", "contacts.geometry[0].radius: a box takes "
     "no radius (radius is for shape: sphere, capsule)"),
    ("shape: capsule, radius: 0.1, from: [0, 0, 0], to: [0, 0, 0]", "contacts.geometry[0]"
     ".to: a capsule's ends must differ (equal ends: give a sphere)"),
    ("shape: capsule, radius: -0.1, from: [0, 0, 0], to: [1, 0, 0]", "contacts.geometry[0]"
     ".radius: must be positive (the capsule's radius, m), got -0.1"),
    ("shape: capsule, radius: 0.1, to: [1, 0, 0]", "contacts.geometry[0].shape: a capsule "
     "needs from (radius, from, to)"),
    ("shape: cylinder", "contacts.geometry[0].shape: "),
    ("shape: point, size: [a, b, c]", "contacts.geometry[0].size: a point takes no size "
     "(size is for shape: box)"),
    ("shape: box, size: [a, b, c]}\n    - {name: crate_3, body: body",
     "contacts.geometry[1].name: contact name 'crate_3' is already used by geometry[0]"),
    ("shape: box, size: [a, b, c], against: {body: sz, radius: 0.1}, rigid",
     "contacts.geometry[0].shape: a capsule or a box against a sphere is the compliant "
     "model's; the rigid model's pairs are two spheres"),
])
def test_bad_shapes_get_one_line_naming_the_place(tmp_path, capsys, change, message):
    path = tmp_path / "bad.yaml"
    text = _planar("{name: crate, body: body, " + change.removesuffix(", rigid") + "}")
    if change.endswith(", rigid"):
        text = text.replace(f"  stiffness: {K}\n  damping: 3e6\n  friction: 0.5\n",
                            "  model: rigid\n  restitution: 0.5\n")
    path.write_text(text)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


# -- MJCF contact geoms (model.mjcf.contact) -----------------------------------------------
HOPPER = Path(__file__).parent.parent / "robots" / "hopper.xml"


@pytest.mark.parametrize("solref, solimp", [("0.02 1", "0.9 0.95 0.001 0.5 2"),
                                            ("0.02 1", "0.8 0.8 0.01"),
                                            ("0.01 0.5", "0.9 0.95 0.001 0.5 2"),
                                            ("0.02 1", "0 0.8 0.01")])   # half_cheetah's
def test_mujocos_resting_depth_is_the_closed_form_the_import_maps(solref, solimp, tmp_path,
                                                                  monkeypatch):
    """A sphere resting on a plane in MuJoCo sinks r = g (1 - d) dmax^2 tc^2 dr^2 / d^2
    (d = d(r), the impedance), whatever its mass: the depth the imported stiffness
    reproduces (to 1e-12 relative; 4e-5 where r lies past solimp's midpoint, as with
    half_cheetah's dmin = 0)."""
    mj = pytest.importorskip("mujoco")
    from anadyn_cli.model.mjcf import contact

    monkeypatch.chdir(tmp_path)                   # MuJoCo's log file
    xml = f"""<mujoco><option timestep="1e-4"/><default><geom solref="{solref}"
      solimp="{solimp}"/></default><worldbody><geom type="plane" size="5 5 0.1"/>
      <body><joint type="slide" axis="0 0 1"/><geom type="sphere" size="0.1" mass="7"/>
      </body></worldbody></mujoco>"""
    M = mj.MjModel.from_xml_string(xml)
    D = mj.MjData(M)
    D.qpos[0] = 0.1
    while D.time < 1.0:
        mj.mj_step(M, D)
    impedance = [float(x) for x in solimp.split()]
    impedance += list(contact.SOLIMP[len(impedance):])
    depth = contact.resting_depth([float(x) for x in solref.split()], impedance, 9.81)
    assert abs((0.1 - D.qpos[0]) - depth) < 1e-4 * depth   # 1e-12 but for half_cheetah's


def _hopper_held(contacts=True):
    """Gymnasium's hopper imported (with its contacts), its three joints held by springs
    of 1e4 N m/rad (damping 100): a rigid body on the foot's capsule."""
    from anadyn_cli.model.mjcf import import_file

    imported = import_file(HOPPER, contacts=contacts)
    data = imported.data
    data.pop("controller")
    data.pop("actuators")
    for body in data["bodies"]:
        if body["parent"] != "ground" and body["joint"].get("displacement") in HELD:
            body["joint"].update(stiffness=1e4, damping=100)
    return imported, robot_from_text(yaml.safe_dump(data, sort_keys=False), "hopper.yaml")


HELD = ("thigh_joint", "leg_joint", "foot_joint")


def test_the_hopper_imported_with_contacts_rests_on_its_foot_as_mujocos_does(tmp_path,
                                                                           monkeypatch):
    """Dropped 4 cm onto the floor, the hopper rests on the two ends of its foot capsule,
    their normal forces summing to its weight (the rotors of the armature sit on the
    ground); MuJoCo's same scene (same springs) rests at the same height and tilt within
    the penetrations (MuJoCo's two contacts sink 3.1 and 1.2 mm past its 1 mm margin,
    ours 0.4 and 0.6 mm: its soft contacts share the load through their impedance)."""
    imported, robot = _hopper_held()
    assert imported.data["contacts"]["ground"] == {"normal": [0, 0, 1], "height": 0.001}
    foot = imported.data["contacts"]["geometry"][-1]
    assert foot == {"name": "foot_geom", "body": "foot", "shape": "capsule", "radius": 0.06,
                    "from": [0.26, 0, 0], "to": [-0.13, 0, 0], "friction": 2}
    model = numeric_model(robot)
    run = simulate(model, rtol=1e-8, atol=1e-10, t_end=2.0, output_step=1e-2)
    fn = dict(zip(model.contact_names, run.contacts.values[:, 0, -1]))
    mass = sum(float(b["mass"]) for b in imported.data["bodies"]
               if not b["name"].endswith("_armature"))
    assert abs(fn["foot_geom_1"] + fn["foot_geom_2"] - mass * 9.81) < 1e-6 * mass * 9.81
    assert all(f == 0 for name, f in fn.items() if not name.startswith("foot"))
    ours = dict(zip(model.state_names(), run.x[-1]))
    depth = run.contacts.values[:, 3, -1].max()

    mj = pytest.importorskip("mujoco")
    monkeypatch.chdir(tmp_path)
    M = mj.MjModel.from_xml_path(str(HOPPER))
    D = mj.MjData(M)
    for name in HELD:
        joint = M.joint(name).id
        M.jnt_stiffness[joint] = 1e4
        M.dof_damping[M.jnt_dofadr[joint]] = 100
    M.opt.timestep = 1e-4
    while D.time < 2.0:
        mj.mj_step(M, D)
    sunk = max(M.geom_margin.max() - D.contact[i].dist for i in range(D.ncon))
    assert D.ncon == 2 and sunk < 5e-3
    bound = sunk + depth
    assert abs(ours["rootz"] - D.qpos[1]) < bound
    assert abs(ours["rooty"] - D.qpos[2]) < bound / 0.39          # the foot: 0.39 m long
    assert abs(ours["rootz"] - (1.21 + 0.001 - depth)) < 1e-3      # 4 cm down, the margin


def test_mjcf_contact_geoms_follow_mujocos_collision_rules(tmp_path, capsys):
    """contype/conaffinity bits, planes of the world (tilted: normal and height from their
    frame; on a body fixed to the world too), margin, condim 1 (no friction), friction
    the larger of the pair's, geoms in <frame>s, boxes with their axes; a cylinder that
    would touch is left out with a warning; without --contacts nothing."""
    xml = tmp_path / "scene.xml"
    xml.write_text("""<mujoco><worldbody>
      <geom name="floor" type="plane" size="1 1 0.1" friction="0.3"/>
      <body name="wall"><geom name="slope" type="plane" pos="0 0 0.5" zaxis="0 1 1"
        size="1 1 0.1" contype="2" conaffinity="2" margin="0.01" condim="1"/></body>
      <body name="a" pos="0 0 1"><joint name="z" type="slide" axis="0 0 1"/>
        <geom name="ball" type="sphere" size="0.1" friction="0.8"/>
        <geom name="ghost" type="sphere" size="0.1" contype="0" conaffinity="0"/>
        <frame pos="0.2 0 0" euler="0 0 90"><geom name="brick" type="box" size="0.1 0.2 0.3"
          contype="2" conaffinity="0" condim="1"/></frame>
        <geom name="can" type="cylinder" size="0.1 0.2"/>
      </body></worldbody></mujoco>""")
    assert main(["import", str(xml), "-o", str(tmp_path / "plain.yaml")]) == 0
    assert "contacts" not in yaml.safe_load((tmp_path / "plain.yaml").read_text())
    out = tmp_path / "scene.yaml"
    assert main(["import", str(xml), "--contacts", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "body 'a': geom 'can': left out of the contacts" in err
    section = yaml.safe_load(out.read_text())["contacts"]
    geometry = {g["name"]: g for g in section["geometry"]}
    assert set(geometry) == {"ball", "brick"}         # ghost: no bits; can: a cylinder
    assert geometry["ball"]["friction"] == 0.8 and geometry["ball"]["ground"] == {
        "normal": [0, 0, 1], "height": 0}
    brick = geometry["brick"]                         # against the slope only (bit 2)
    assert brick["friction"] == 0 and brick["shape"] == "box" and brick["size"] == [0.1, 0.2, 0.3]
    assert brick["point"] == [0.2, 0, 0] and brick["rpy"] == [0, 0, "pi/2"]
    s = math.sqrt(0.5)
    assert brick["ground"]["normal"] == pytest.approx([0, s, s])
    assert brick["ground"]["height"] == pytest.approx(0.5 * s + 0.01)
    assert main(["check", str(out), "--out", str(tmp_path / "check")]) == 0


def test_a_negative_solref_is_refused_in_one_line(tmp_path, capsys):
    xml = tmp_path / "direct.xml"
    xml.write_text("""<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>
      <body><joint type="slide" axis="0 0 1"/><geom name="ball" size="0.1"
      solref="-1000 -10"/></body></worldbody></mujoco>""")
    assert main(["import", str(xml), "--contacts"]) == 2
    err = capsys.readouterr().err
    assert err == (f"anadyn: error: {xml}: body 'body1': geom 'ball': solref=\"-1000 -10\": "
                   "anadyn maps (timeconst, dampratio) > 0, not direct stiffness and "
                   "damping\n")
