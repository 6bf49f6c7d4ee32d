"""Compliant contact (issue 27): Hunt-Crossley normal force and regularized Coulomb
friction against ground planes (``model.contacts``, ``numeric.contact``).

Checked against closed forms of the same law (a dropped ball's touch-down, contact
duration and apex; Hunt-Crossley's restitution; a pushed block's stop distance; the
creep and the sliding acceleration on an incline; a sphere rolling down one), against
the energy balance, against MuJoCo on what does not depend on the contact model, and
the robot file's mistakes (one line, exit 2)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import quad

from anadyn_cli import robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.errors import ModelError
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services.check import check, contact_figures
from anadyn_cli.services.simulate import simulate

G = 9.81


def _drop(stiffness=1e6, damping=0.0, height=1.0, extra=""):
    """A ball (m = 1 kg, r = 0.1 m) on a vertical slide, dropped on the floor."""
    return f"""
name: drop
parameters: {{m: 1.0, r: 0.1}}
gravity: [0, 0, -{G}]
coordinates:
  z: {{initial: {height}}}
bodies:
  - name: ball
    joint: {{type: prismatic, axis: [0, 0, 1], displacement: z}}
    mass: m
    inertia: {{ixx: 0.004, iyy: 0.004, izz: 0.004}}
contacts:
  stiffness: {stiffness}
  damping: {damping}
  geometry:
    - {{name: floor, body: ball, radius: r}}
{extra}"""


def _run(text, t_end, step, rtol=1e-11):
    model = numeric_model(robot_from_text(text, "scene.yaml"))
    return model, simulate(model, rtol=rtol, atol=rtol * 1e-2, t_end=t_end, output_step=step)


def _contact_duration(v, k, m=1.0):
    """2 * integral of dd / |d'| over the compression, from the energy of the same law
    with gravity: d'^2 = v^2 + 2 g d - 2 k d^2.5 / (2.5 m)."""
    def speed2(d):
        return v * v + 2 * G * d - 2 * k * d ** 2.5 / (2.5 * m)
    lo, hi = 0.0, 1.0
    for _ in range(200):                          # the deepest point: speed2 = 0
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if speed2(mid) > 0 else (lo, mid)
    deepest = lo
    # x = deepest (1 - s^2): the square-root end point becomes smooth
    value, _ = quad(lambda s: 2 * deepest * s / math.sqrt(max(speed2(deepest * (1 - s * s)),
                                                              1e-300)), 0, 1, limit=200)
    return 2 * value, deepest


def test_an_undamped_ball_touches_down_and_bounces_as_the_closed_forms_say():
    model, run = _run(_drop(), 2.0, 1e-4)
    events = run.contacts.events()
    assert [e["event"] for e in events] == ["touch-down", "lift-off"] * 2
    fall = math.sqrt(2 * 0.9 / G)                 # the centre falls 0.9 m to touch
    v = G * fall
    duration, deepest = _contact_duration(v, 1e6)
    assert abs(events[0]["t"] - fall) < 1e-8
    assert abs(events[1]["t"] - (fall + duration)) < 1e-8
    assert abs(events[2]["t"] - (fall + duration + 2 * v / G)) < 1e-8
    assert abs(run.contacts.values[0, 3].max() - deepest) < 1e-6     # rows every 0.1 ms
    # no damping: every apex is the drop height, and T + V + V_c is conserved
    apex = run.x[(run.t > 0.6) & (run.t < 1.1), 0].max()
    assert abs(apex - 1.0) < 1e-7                 # rows 0.1 ms apart: g dt^2 / 8 = 1.2e-8
    T, V = model.energy(run.x[:, :1].T, run.x[:, 1:].T)
    energy = T + V + run.contacts.values[0, 4]
    assert np.abs(energy - energy[0]).max() < 1e-8 * energy[0]
    # the rigid floor's closed form misses by the contact's duration at each bounce
    assert 9e-3 < duration < 1e-2


@pytest.mark.parametrize("alpha", [0.005, 0.02])
def test_hunt_crossley_damping_gives_its_restitution(alpha):
    """e = 1 - (2/3) alpha v to first order in alpha v (Hunt and Crossley 1975); the
    terms left out are below (alpha v)^2."""
    _, run = _run(_drop(damping=alpha * 1e6), 1.0, 1e-4)
    events = run.contacts.events()
    v = G * math.sqrt(2 * 0.9 / G)
    rebound = np.interp(events[1]["t"], run.t, run.x[:, 1])
    e = rebound / v
    assert abs(e - (1 - 2 / 3 * alpha * v)) < (alpha * v) ** 2
    assert e < 1 - 0.5 * alpha * v                # and the damping does take energy


def _block(v0=2.0, mu=0.5, vs=0.01, theta=0.0):
    """A block (1 kg) on two slides, x and z, its sole the body origin, resting on the
    ground (normal tilted by ``theta`` about y) at its static penetration, pushed along
    the slope at ``v0``."""
    n = (math.sin(theta), 0.0, math.cos(theta))
    depth = (G * n[2] / 1e6) ** (2 / 3)           # k d^1.5 = m g cos theta
    return f"""
name: block
gravity: [0, 0, -{G}]
coordinates:
  x: {{initial: {-depth * n[0]}, rate: {v0 * n[2]}}}
  z: {{initial: {-depth * n[2]}, rate: {-v0 * n[0]}}}
bodies:
  - {{name: slide, joint: {{type: prismatic, axis: [1, 0, 0], displacement: x}}, mass: 0}}
  - name: block
    parent: slide
    joint: {{type: prismatic, axis: [0, 0, 1], displacement: z}}
    mass: 1.0
contacts:
  ground: {{normal: [{n[0]}, 0, {n[2]}]}}
  stiffness: 1e6
  damping: 3e6
  friction: {mu}
  friction_velocity: {vs}
  geometry:
    - {{name: sole, body: block}}
"""


def test_a_pushed_block_stops_after_v0_squared_over_2_mu_g():
    """Regularized friction mu f_n tanh(v / v_s) brakes at mu g tanh(v / v_s): the stop
    distance is (v0^2 / 2 + (pi^2 / 12) v_s^2) / (mu g), Coulomb's plus 0.82 v_s^2 / (mu g)
    (1.7e-5 m here)."""
    v0, mu, vs = 2.0, 0.5, 0.01
    _, run = _run(_block(v0, mu, vs), 1.0, 1e-3)
    coulomb = v0 ** 2 / (2 * mu * G)
    regularized = coulomb + math.pi ** 2 / 12 * vs ** 2 / (mu * G)
    assert abs(run.x[-1, 0] - regularized) < 1e-8
    assert abs(run.x[-1, 0] - coulomb) < 1.7e-5
    stop = run.t[np.argmax(run.x[:, 2] < 0.05)]   # decelerating at mu g until v ~ v_s
    assert abs(stop - (v0 - 0.05) / (mu * G)) < 2e-3
    fn = run.contacts.values[0, 0]                # the floor carries the weight
    assert np.abs(fn - G).max() < 1e-6 * G


def test_on_an_incline_the_block_creeps_below_tan_theta_mu_and_slides_above():
    mu = 0.5
    below = math.atan(0.8 * mu)                   # tan theta = 0.4: friction holds it...
    _, run = _run(_block(0.0, mu, 0.01, below), 1.0, 1e-3)
    slope = np.array([math.cos(below), -math.sin(below)])
    speed = run.x[-1, 2:] @ slope
    creep = 0.01 * math.atanh(math.tan(below) / mu)   # ...but for the regularization's creep
    assert abs(speed - creep) < 1e-5 * creep
    assert creep < 0.011
    above = math.atan(1.2 * mu)                   # tan theta = 0.6: it slides
    _, run = _run(_block(0.0, mu, 0.01, above), 1.0, 1e-3)
    slope = np.array([math.cos(above), -math.sin(above)])
    speed = run.x[:, 2:] @ slope
    late = run.t > 0.5                            # v >> v_s: tanh = 1 within 1e-40
    acceleration = np.polyfit(run.t[late], speed[late], 1)[0]
    expected = G * (math.sin(above) - mu * math.cos(above))
    assert abs(acceleration - expected) < 1e-6 * expected


def test_a_sphere_rolls_down_an_incline_at_g_sin_theta_over_1_plus_I_over_m_r2():
    theta, r, m = math.radians(25), 0.1, 2.0
    inertia = 0.4 * m * r * r
    depth = (m * G * math.cos(theta) / 1e6) ** (2 / 3)   # at rest on the plane through 0
    text = f"""
name: rolling
gravity: [0, 0, -{G}]
coordinates:
  x: {{initial: {(r - depth) * math.sin(theta)}}}
  z: {{initial: {(r - depth) * math.cos(theta)}}}
  spin: {{}}
bodies:
  - {{name: sx, joint: {{type: prismatic, axis: [1, 0, 0], displacement: x}}, mass: 0}}
  - {{name: sz, parent: sx, joint: {{type: prismatic, axis: [0, 0, 1], displacement: z}},
     mass: 0}}
  - name: ball
    parent: sz
    joint: {{type: revolute, axis: [0, 1, 0], displacement: spin}}
    mass: {m}
    inertia: {{ixx: {inertia}, iyy: {inertia}, izz: {inertia}}}
contacts:
  ground: {{normal: [{math.sin(theta)}, 0, {math.cos(theta)}]}}
  stiffness: 1e6
  damping: 3e6
  friction: 0.6
  geometry:
    - {{name: floor, body: ball, radius: {r}}}
"""
    _, run = _run(text, 1.0, 1e-3, rtol=1e-10)
    slope = np.array([math.cos(theta), -math.sin(theta)])
    speed = run.x[:, 3:5] @ slope
    late = run.t > 0.3
    acceleration = np.polyfit(run.t[late], speed[late], 1)[0]
    rolling = G * math.sin(theta) / (1 + inertia / (m * r * r))
    # steady slip (v_s atanh(2/7 tan theta / mu), 2.4 mm/s): the centre and the spin
    # accelerate together, so the regularization leaves the acceleration exact
    assert abs(acceleration - rolling) < 1e-6 * rolling
    slip = speed[-1] - r * run.x[-1, 5]
    assert 0 < slip < 0.01 * math.atanh(2 / 7 * math.tan(theta) / 0.6) * 1.01
    sliding = G * (math.sin(theta) - 0.6 * math.cos(theta))
    assert acceleration > sliding + 1                 # not the sliding one


def test_check_balances_the_contacts_energy_and_reports_penetration_and_time_constant():
    model = numeric_model(robot_from_text(_drop(damping=2e4), "drop.yaml"))
    report = check(model, rtol=1e-10, atol=1e-12, t_end=1.0, output_step=1e-4)
    assert report.energy_error < 1e-7
    assert report.dissipated[-1] > 0.5            # alpha = 0.02 s/m at 4.2 m/s: 11 % of 8.8 J
    name, depth, at, tau = contact_figures(report)[0]
    k_eff = 1.5 * 1e6 * math.sqrt(depth)
    assert name == "floor" and 0.012 < depth < 0.014 and 0.42 < at < 0.44
    assert abs(tau - math.sqrt(1.0 / k_eff)) < 1e-12
    # a wrong contact force breaks the balance: the springs' energy left out
    report.energy_residual = report.energy_residual - report.contacts.values[0, 4]
    assert report.energy_error > 1e-3


def test_simulate_writes_contact_columns_and_events(tmp_path):
    scene = tmp_path / "drop.yaml"
    scene.write_text(_drop(extra="simulation: {t_end: 1, output_step: 0.001}"))
    assert main(["simulate", str(scene), "--no-plot", "--out", str(tmp_path / "out")]) == 0
    header = (tmp_path / "out" / "simulate.csv").read_text().splitlines()[0]
    assert header == "t,z,dz,floor_fn,floor_ft1,floor_ft2,floor_depth"
    summary = json.loads((tmp_path / "out" / "simulate.json").read_text())
    contact = summary["contact"]
    assert contact["model"] == "compliant"
    assert [e["event"] for e in contact["events"]] == ["touch-down", "lift-off"]
    assert abs(contact["events"][0]["t"] - math.sqrt(2 * 0.9 / G)) < 1e-6


@pytest.mark.parametrize("argv, what", [
    (["equations"], "symbolic equations (derive, equations)"),
    (["compare"], "symbolic equations (compare)"),
    (["simulate", "--formulation", "kane"], "closed forms"),
    (["linearize"], "linearizations (linearize)"),
])
def test_what_does_not_know_contacts_refuses_them(tmp_path, capsys, argv, what):
    scene = tmp_path / "drop.yaml"
    scene.write_text(_drop(extra="trajectory: {kind: cycloidal, duration: 1, to: {z: 0.5}}"))
    assert main([argv[0], str(scene), *argv[1:]]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and what in err and "with contacts" in err


@pytest.mark.parametrize("change, message", [
    (("stiffness: 1000000.0", "stiffness: -5"), "stiffness: must be 0 or positive"),
    (("damping: 0.0", "damping: -1"), "damping: must be 0 or positive"),
    (("damping: 0.0", "friction: -0.2"), "friction: must be 0 or positive"),
    (("damping: 0.0", "restitution: 1.5"), "a coefficient of restitution lies in [0, 1]"),
    (("damping: 0.0", "restitution: 0.5"), "restitution belongs to the rigid contact model"),
    (("body: ball", "body: bal"), "unknown body 'bal' (did you mean 'ball'?)"),
    (("radius: r", "radius: -r"), "radius: must be positive"),
    (("radius: r", "radius: 0"), "radius: must be positive"),
    (("damping: 0.0", "model: rigid"), "the rigid contact model"),
    (("damping: 0.0", "ground: {normal: [0, 0, 0]}"), "must not be zero"),
    (("damping: 0.0", "exponent: 0.5"), "exponent: must be 1 or more"),
    (("radius: r}", "radius: r, against: {body: ball, radius: r}}"), "does not touch itself"),
    (("radius: r}", "radius: r, against: {body: ball}}"), "missing required key 'radius'"),
])
def test_bad_contacts_get_one_line_naming_the_place(tmp_path, capsys, change, message):
    text = _drop().replace(*change)
    assert text != _drop()
    scene = tmp_path / "bad.yaml"
    scene.write_text(text)
    assert main(["simulate", str(scene), "--no-plot", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"anadyn: error: {scene}:") and "contacts" in err
    assert message in err and "\n" not in err
    assert not (tmp_path / "o").exists()
    with pytest.raises(ModelError):
        robot_from_text(text, "bad.yaml")


# --- MuJoCo: the same ball and block, where the models agree -------------------------
def _mujoco():
    return pytest.importorskip("mujoco")


def test_mujoco_ball_falls_and_rests_as_ours_does():
    """MuJoCo's soft contact is not Hunt-Crossley: compare the free fall (touch-down
    time: MuJoCo steps 0.1 ms, and its contact shows a step late at most) and the rest
    height (the radius, less each model's static penetration, under 1 mm in both)."""
    mj = _mujoco()
    xml = """<mujoco><option timestep="1e-4" gravity="0 0 -9.81"/><worldbody>
      <geom type="plane" size="5 5 0.1"/>
      <body><joint type="slide" axis="0 0 1"/><geom type="sphere" size="0.1" mass="1"/>
      </body></worldbody></mujoco>"""
    M = mj.MjModel.from_xml_string(xml)
    D = mj.MjData(M)
    D.qpos[0] = 1.0
    touch = None
    while D.time < 3.0:
        mj.mj_step(M, D)
        if touch is None and D.ncon and D.contact[0].dist < 0:
            touch = D.time
    _, run = _run(_drop(damping=3e6), 3.0, 1e-3, rtol=1e-9)
    ours = run.contacts.events()[0]["t"]
    assert abs(ours - math.sqrt(2 * 0.9 / G)) < 1e-5   # rows 1 ms apart, a plastic touch
    assert abs(touch - ours) < 2e-4
    rest = (G / 1e6) ** (2 / 3)                   # ours: k d^1.5 = m g
    assert abs(run.x[-1, 0] - (0.1 - rest)) < 1e-9
    assert abs(D.qpos[0] - 0.1) < 1e-3 and abs(run.x[-1, 0] - D.qpos[0]) < 1e-3


def test_mujoco_block_stops_where_ours_does():
    """A box sliding at 2 m/s with mu = 0.5 (elliptic cone): MuJoCo's stop distance and
    ours agree with Coulomb's v0^2 / (2 mu g) within 1e-3 relative (MuJoCo's soft
    constraint lets the box slip a little at rest; ours adds 0.82 v_s^2 / (mu g))."""
    mj = _mujoco()
    xml = """<mujoco><option timestep="1e-4" gravity="0 0 -9.81" cone="elliptic"/>
      <worldbody><geom type="plane" size="5 5 0.1" friction="0.5 0 0"/>
      <body pos="0 0 0.1"><joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 0 1"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1" friction="0.5 0 0"/></body>
      </worldbody></mujoco>"""
    M = mj.MjModel.from_xml_string(xml)
    D = mj.MjData(M)
    mj.mj_forward(M, D)
    D.qvel[0] = 2.0
    while D.time < 1.0:
        mj.mj_step(M, D)
    _, run = _run(_block(2.0, 0.5, 0.01), 1.0, 1e-2)
    coulomb = 4 / (2 * 0.5 * G)
    assert abs(D.qpos[0] - coulomb) < 1e-3 * coulomb
    assert abs(run.x[-1, 0] - coulomb) < 1e-4 * coulomb
    assert abs(D.qpos[0] - run.x[-1, 0]) < 1e-3 * coulomb


@pytest.mark.parametrize("scene", ["bouncing_ball", "block_incline"])
def test_the_shipped_scenes_balance_their_energy_with_friction_and_damping(scene):
    """Friction's and damping's losses and the springs' energy close the balance (halving
    the friction's loss in ``numeric.contact`` gives 0.6 on the block)."""
    from pathlib import Path

    path = Path(__file__).parent.parent / "robots" / "contact" / f"{scene}.yaml"
    report = check(numeric_model(path))
    assert report.energy_error < 1e-7 and report.dissipated[-1] > 1.0


def test_a_spinning_free_ball_lands_and_rolls_with_two_sevenths_of_its_spin():
    """A floating ball spun at w0 about x, dropped: friction (any law that ends in
    rolling) acts at the contact, so the angular momentum about the contact point is
    kept, I w0 = I w + m r v with v = r w: w = I w0 / (I + m r^2) = 2/7 w0.  Runs the
    quaternion path (a floating joint) with contacts, and its energy balance."""
    text = """
name: free_ball
parameters: {m: 0.5, r: 0.1}
gravity: [0, 0, -9.81]
coordinates:
  ball_z: {initial: 0.3}
speeds:
  ball_wx: {initial: 3.0}
bodies:
  - name: ball
    joint: {type: floating}
    mass: m
    inertia: {ixx: 0.4*m*r**2, iyy: 0.4*m*r**2, izz: 0.4*m*r**2}
contacts:
  stiffness: 1e5
  damping: 3e5
  friction: 0.4
  geometry:
    - {name: floor, body: ball, radius: r}
"""
    model, run = _run(text, 1.5, 1e-3, rtol=1e-10)
    final = dict(zip(model.state_names(), run.x[-1]))
    assert abs(final["ball_wx"] - 2 / 7 * 3.0) < 1e-6
    assert abs(final["dball_y"] + 0.1 * final["ball_wx"]) < 1e-6     # rolling: v = -r w
    report = check(model, rtol=1e-10, atol=1e-12, t_end=1.5, output_step=1e-3)
    assert report.energy_error < 1e-7


def test_the_quadruped_dropped_on_the_floor_stands_on_its_weight():
    """robots/contact/quadruped_standing.yaml (a floating trunk, eight PD-held joints,
    four feet): it lands, settles, and the feet's normal forces (vertical: a level floor)
    carry its weight within 1e-6; no contact ever gives energy back beyond its spring's
    (the dissipated power is >= 0 on every row)."""
    from pathlib import Path

    path = Path(__file__).parent.parent / "robots" / "contact" / "quadruped_standing.yaml"
    model = numeric_model(path)
    run = simulate(model)
    assert run.solution.success
    weight = (10.0 + 4 * 1.5) * G
    support = run.contacts.values[:, 0, -1].sum()
    assert abs(support - weight) < 1e-6 * weight
    assert run.contacts.values[:, 5].min() >= 0
    assert [e["event"] for e in run.contacts.events()] == ["touch-down"] * 4
    final = dict(zip(model.state_names(), run.x[-1]))
    assert 0.33 < final["trunk_z"] < 0.37 and abs(final["trunk_qy"]) < 0.01


def _free_ball(name, x, y, vx):
    """A floating sphere's body entry and its coordinates' lines (a: 1 kg, b: 2 kg)."""
    return f"""  - name: {name}
    joint: {{type: floating}}
    mass: {1.0 if name == 'a' else 2.0}
    inertia: {{ixx: {0.004 if name == 'a' else 0.008}, iyy: {0.004 if name == 'a' else 0.008},
              izz: {0.004 if name == 'a' else 0.008}}}
""", f"  {name}_x: {{initial: {x}, rate: {vx}}}\n  {name}_y: {{initial: {y}}}\n"


def _rotation(q):
    w, x, y, z = np.asarray(q) / np.linalg.norm(q)
    return np.array([[w*w + x*x - y*y - z*z, 2*(x*y - w*z), 2*(x*z + w*y)],
                     [2*(x*y + w*z), w*w - x*x + y*y - z*z, 2*(y*z - w*x)],
                     [2*(x*z - w*y), 2*(y*z + w*x), w*w - x*x - y*y + z*z]])


def test_two_free_spheres_collide_keeping_momentum_and_angular_momentum():
    """Sphere against sphere on two floating bodies, off-centre, with friction and
    damping, no gravity: the contact's forces are equal and opposite at one point, so
    the linear momentum and the angular momentum about the origin are kept (to the
    integrator's tolerance) while the kinetic energy drops by what the contact
    dissipates; equal masses head-on and undamped exchange their speeds."""
    body_a, coord_a = _free_ball("a", 0.0, 0.0, 1.0)
    body_b, coord_b = _free_ball("b", 0.5, 0.08, 0.0)
    text = f"""
name: knock
coordinates:
{coord_a}{coord_b}speeds:
  a_wz: {{initial: 5.0}}
bodies:
{body_a}{body_b}contacts:
  stiffness: 1e6
  damping: 2e4
  friction: 0.3
  geometry:
    - {{name: knock, body: a, radius: 0.1, against: {{body: b, radius: 0.1}}}}
"""
    model, run = _run(text, 1.0, 1e-3, rtol=1e-10)
    names = model.state_names()

    def momenta(x):
        s = dict(zip(names, x))
        P, L = np.zeros(3), np.zeros(3)
        for body, m, inertia in (("a", 1.0, 0.004), ("b", 2.0, 0.008)):
            p = np.array([s[f"{body}_{k}"] for k in "xyz"])
            v = np.array([s[f"d{body}_{k}"] for k in "xyz"])
            w = np.array([s[f"{body}_w{k}"] for k in "xyz"])
            R = _rotation([s[f"{body}_q{k}"] for k in "wxyz"])
            P += m * v
            L += m * np.cross(p, v) + R @ (inertia * w)
        return P, L
    P0, L0 = momenta(run.x[0])
    P1, L1 = momenta(run.x[-1])
    assert [e["event"] for e in run.contacts.events()] == ["touch-down", "lift-off"]
    assert np.abs(P1 - P0).max() < 1e-8 and np.abs(L1 - L0).max() < 1e-8
    assert abs(P1[1]) < 1e-8 and dict(zip(names, run.x[-1]))["db_y"] > 0.01   # off-centre
    T, _ = model.energy(run.x[:, :model.nq].T, run.x[:, model.nq:].T)
    report = check(model, rtol=1e-10, atol=1e-12, t_end=1.0, output_step=1e-3)
    assert report.energy_error < 1e-7 and report.dissipated[-1] > 1e-3
    assert abs(T[0] - T[-1] - report.dissipated[-1]) < 1e-7


def test_equal_spheres_head_on_exchange_their_speeds():
    text = """
name: pair
coordinates:
  xa: {rate: 1.0}
  xb: {initial: 0.5}
bodies:
  - {name: a, joint: {type: prismatic, axis: [1, 0, 0], displacement: xa}, mass: 1.0}
  - {name: b, joint: {type: prismatic, axis: [1, 0, 0], displacement: xb}, mass: 1.0}
contacts:
  stiffness: 1e6
  geometry:
    - {name: knock, body: a, radius: 0.1, against: {body: b, radius: 0.1}}
"""
    _, run = _run(text, 1.0, 1e-3)
    assert abs(run.x[-1, 2]) < 1e-8 and abs(run.x[-1, 3] - 1.0) < 1e-8
    assert abs(run.contacts.events()[0]["t"] - 0.3) < 1e-9


def test_accuracy_times_the_contact_events_of_every_run():
    """accuracy on a bouncing ball: each run's touch-down and lift-off times against its
    reference's; tighter tolerances time them better."""
    from anadyn_cli.services.accuracy import study

    model = numeric_model(robot_from_text(_drop(stiffness=1e5), "drop.yaml"))
    result = study(model, methods=("auto", "Radau"), tolerances=(1e-4, 1e-8), repeats=1,
                   t_end=1.5, output_step=1e-3)
    errors = {(r.method, r.rtol): r.event_error for r in result.rows}
    assert all(math.isfinite(e) for e in errors.values())
    assert errors[("auto", 1e-8)] < 1e-6 and errors[("auto", 1e-8)] < errors[("auto", 1e-4)]


def test_mujoco_two_link_arm_falls_onto_the_floor_as_ours_does():
    """A two-link arm hinged 0.4 m above the floor, let go horizontal, its tip a 2 cm
    sphere: before the tip touches, both simulate the same rigid bodies (MuJoCo's RK4
    at 0.1 ms: the joint angles at 0.25 s agree to 1e-6 rad), and the tip touches down
    at the same time (within 2 MuJoCo steps: its contact shows a step late at most)."""
    mj = _mujoco()
    xml = """<mujoco><option timestep="1e-4" gravity="0 0 -9.81" integrator="RK4"/>
      <worldbody><geom type="plane" size="5 5 0.1"/>
      <body pos="0 0 0.4"><joint type="hinge" axis="0 -1 0"/>
        <inertial pos="0.125 0 0" mass="1" diaginertia="0.0001 0.0052083 0.0052083"/>
        <body pos="0.25 0 0"><joint type="hinge" axis="0 -1 0"/>
          <inertial pos="0.125 0 0" mass="1" diaginertia="0.0001 0.0052083 0.0052083"/>
          <geom type="sphere" pos="0.25 0 0" size="0.02" mass="0"/></body></body>
      </worldbody></mujoco>"""
    M = mj.MjModel.from_xml_string(xml)
    D = mj.MjData(M)
    touch, at_quarter = None, None
    while touch is None and D.time < 1.0:
        mj.mj_step(M, D)
        if at_quarter is None and D.time >= 0.25 - 1e-9:
            at_quarter = D.qpos.copy()
        if D.ncon and D.contact[0].dist < 0:
            touch = D.time
    link = "mass: 1.0\n    com: [0.125, 0, 0]\n    inertia: {ixx: 0.0001, iyy: 0.0052083, " \
           "izz: 0.0052083}"
    text = f"""
name: arm
gravity: [0, 0, -{G}]
coordinates: {{q1: {{}}, q2: {{}}}}
bodies:
  - name: upper
    joint: {{type: revolute, axis: [0, -1, 0], origin: [0, 0, 0.4], displacement: q1}}
    {link}
  - name: fore
    parent: upper
    joint: {{type: revolute, axis: [0, -1, 0], origin: [0.25, 0, 0], displacement: q2}}
    {link}
contacts:
  stiffness: 1e6
  damping: 3e6
  friction: 0.5
  geometry:
    - {{name: tip, body: fore, point: [0.25, 0, 0], radius: 0.02}}
"""
    _, run = _run(text, 0.3, 1e-4, rtol=1e-11)
    row = int(round(0.25 / 1e-4))
    assert abs(run.t[row] - 0.25) < 1e-12
    assert np.abs(run.x[row, :2] - at_quarter).max() < 1e-6
    ours = run.contacts.events()[0]["t"]
    assert 0.2 < ours < 0.3 and 0 <= touch - ours < 2e-4
