"""Rigid contact (issue 27): unilateral constraints with impacts, events located by the
integrator (``numeric.impacts``).

Checked against closed forms: a dropped ball's bounce times and heights (Newton's
restitution), a pushed block's stop, a block on an incline sticking or sliding, a
sphere and a disc rolling, a pendulum striking a wall (elliptic integrals), a ball
leaving a dome (cos = 2/3), two spheres colliding, a bar on an incline on both ends,
a growing push making a resting block slip or lift off, friction in an impact
(sticking inside the cone, sliding outside); the impulse's momentum balance worked
by hand on a tilted bar; a free box tumbling onto its face; energy never gained at
an impact, the energy balance with the impacts' losses; the robot file's mistakes
(one line, exit 2)."""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ellipk

from anadyn_cli import robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.errors import ModelError
from anadyn_cli.numeric import impacts
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services.simulate import simulate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_contact import _drop as compliant_drop  # noqa: E402

G = 9.81
ROOT = Path(__file__).resolve().parents[1]


def _run(text, t_end, step, rtol=1e-11):
    model = numeric_model(robot_from_text(text, "scene.yaml"))
    return simulate(model, rtol=rtol, atol=rtol * 1e-2, t_end=t_end, output_step=step)


def _never_gains(result):
    for e in result.contacts.located:
        assert e["energy_lost"] >= -1e-12, e


def _drop(e):
    """test_contact's ball (m = 1 kg, r = 0.1 m, on a vertical slide from 1 m) on a
    rigid floor."""
    return compliant_drop().replace("stiffness: 1000000.0\n  damping: 0.0",
                                    f"model: rigid\n  restitution: {e}")


def _bounces(e, h0, n):
    """Touch-down times and the heights after each of the first n impacts."""
    v = math.sqrt(2 * G * h0)
    times = [v / G]
    for k in range(1, n):
        times.append(times[-1] + 2 * e ** k * v / G)
    return times, [e ** (2 * k) * h0 for k in range(1, n + 1)]


def _height(t, e, h0, r=0.1):
    """The ball's centre on the closed-form path (piecewise parabolas)."""
    v = math.sqrt(2 * G * h0)
    start, speed, z0 = 0.0, 0.0, h0
    end = v / G
    k = 0
    while t > end:
        k += 1
        start, speed, z0 = end, e ** k * v, 0.0
        end = start + 2 * speed / G
    s = t - start
    return r + z0 + speed * s - 0.5 * G * s * s


def test_ball_bounces_at_newtons_times_and_heights():
    """e = 0.7 from h0 = 0.9 m: touch-downs t_k, rebound heights e^(2k) h0 (from the
    rebound speeds) and every row on the parabolas, to 1e-8; each impact takes
    (1 - e^2) of the kinetic energy."""
    e, h0 = 0.7, 0.9
    result = _run(_drop(e), 2.0, 0.001)
    hits = [x for x in result.contacts.located if x["event"] == "touch-down"]
    times, heights = _bounces(e, h0, len(hits))
    assert len(hits) == 5
    for hit, t, h in zip(hits, times, heights):
        assert abs(hit["t"] - t) < 1e-8
        assert abs(hit["speed_after"] ** 2 / (2 * G) - h) < 1e-8
        assert hit["speed_after"] == pytest.approx(-e * hit["speed_before"], rel=1e-12)
        assert hit["impulse"][0] == pytest.approx(1.0 * (1 + e) * -hit["speed_before"])
        lost = 0.5 * hit["speed_before"] ** 2 * (1 - e ** 2)
        assert hit["energy_lost"] == pytest.approx(lost, rel=1e-10)
    z = result.x[:, 0]
    exact = np.array([_height(t, e, h0) for t in result.t])
    assert np.abs(z - exact).max() < 1e-8
    assert result.contacts.balance < 1e-9
    _never_gains(result)


def test_bounces_end_and_the_ball_rests_on_its_weight():
    """The bounces accumulate at t0 (1 + 2e / (1 - e)); a rebound slower than
    impacts.SPEED ends them, and the ball rests: normal force m g, no penetration."""
    e, h0 = 0.5, 0.9
    t_rest = math.sqrt(2 * h0 / G) * (1 + 2 * e / (1 - e))
    result = _run(_drop(e), 1.6, 0.01)
    assert result.solution.success
    last = result.contacts.located[-1]
    assert abs(last["t"] - t_rest) < 1e-7
    assert result.t[-1] > t_rest
    fn, depth = result.contacts.values[0, 0], result.contacts.values[0, 3]
    rest = result.t > t_rest
    assert np.abs(fn[rest] - G).max() < 1e-9
    assert np.abs(depth[rest]).max() < 1e-10
    assert abs(result.x[-1, 0] - 0.1) < 1e-10
    assert np.all(fn[~rest] == 0)
    assert result.contacts.balance < 1e-8
    _never_gains(result)


def _block(theta="0", v0=2.0, mu=0.5):
    """A block on two slides (x, z) on a plane tilted by theta, launched down it at v0."""
    return f"""
name: block
parameters: {{m: 1.0, theta: {theta}, v0: {v0}, mu: {mu}}}
gravity: [0, 0, -{G}]
coordinates:
  x: {{rate: v0*cos(theta)}}
  z: {{rate: -v0*sin(theta)}}
bodies:
  - {{name: slide_x, joint: {{type: prismatic, axis: [1, 0, 0], displacement: x}}, mass: 0}}
  - name: block
    parent: slide_x
    joint: {{type: prismatic, axis: [0, 0, 1], displacement: z}}
    mass: m
    inertia: {{ixx: 0.01, iyy: 0.01, izz: 0.01}}
contacts:
  model: rigid
  ground: {{normal: [sin(theta), 0, cos(theta)], height: 0}}
  friction: mu
  geometry:
    - {{name: sole, body: block}}
"""


def test_pushed_block_stops_after_v0_squared_over_2_mu_g():
    v0, mu = 2.0, 0.5
    result = _run(_block(v0=v0, mu=mu), 1.0, 0.01)
    (stop,) = result.contacts.located
    assert stop["event"] == "stick"
    assert abs(stop["t"] - v0 / (mu * G)) < 1e-8
    assert abs(result.x[-1, 0] - v0 ** 2 / (2 * mu * G)) < 1e-8
    assert np.abs(result.x[:, 1]).max() < 1e-10                  # on the plane
    ft, fn = result.contacts.values[0, 1], result.contacts.values[0, 0]
    sliding = result.t < stop["t"]
    assert np.abs(ft[sliding] + mu * G).max() < 1e-9          # -mu m g along t1 = x
    assert np.abs(ft[~sliding]).max() < 1e-9 and np.abs(fn - G).max() < 1e-9
    assert result.contacts.balance < 1e-10                  # friction's loss counted


@pytest.mark.parametrize("mu", [0.7, 0.5, 0.3])
def test_incline_sticks_below_tan_theta_and_slides_above(mu):
    """30 degrees, tan = 0.577: mu = 0.7 holds the block at rest (friction m g sin up
    the slope, along t2), mu = 0.5 and 0.3 let it slide at g (sin - mu cos)."""
    theta = math.pi / 6
    result = _run(_block("pi/6", 0.0, mu), 1.0, 0.01)
    values = result.contacts.values[0]
    assert result.contacts.located == []
    assert np.abs(values[0] - G * math.cos(theta)).max() < 1e-9
    if mu > math.tan(theta):
        assert np.abs(result.x[:, :2]).max() < 1e-10
        assert np.abs(values[2] - G * math.sin(theta)).max() < 1e-9
    else:
        a = G * (math.sin(theta) - mu * math.cos(theta))
        s = 0.5 * a * result.t ** 2
        assert np.abs(result.x[:, 0] - s * math.cos(theta)).max() < 1e-9
        assert np.abs(result.x[:, 1] + s * math.sin(theta)).max() < 1e-9
        assert np.abs(values[2] - mu * G * math.cos(theta)).max() < 1e-9
        assert result.contacts.balance < 1e-10


@pytest.mark.parametrize("k", [0.4, 0.5])       # a sphere, a disc: I = k m r^2
def test_sphere_and_disc_roll_at_g_sin_over_1_plus_k(k):
    """From rest on a 30 degree incline with mu = 0.5 (rolling needs mu >= k/(1+k)
    tan 30): sticking is rolling, at g sin / (1 + I/(m r^2)); the contact point stays
    at rest."""
    theta = math.pi / 6
    text = f"""
name: roll
parameters: {{m: 0.5, r: 0.1, theta: pi/6, k: {k}}}
gravity: [0, 0, -{G}]
coordinates:
  x: {{}}
  z: {{initial: 1.0}}
  spin: {{}}
bodies:
  - {{name: slide_x, joint: {{type: prismatic, axis: [1, 0, 0], displacement: x}}, mass: 0}}
  - {{name: slide_z, parent: slide_x, joint: {{type: prismatic, axis: [0, 0, 1],
     displacement: z}}, mass: 0}}
  - name: ball
    parent: slide_z
    joint: {{type: revolute, axis: [0, 1, 0], displacement: spin}}
    mass: m
    inertia: {{ixx: k*m*r**2, iyy: k*m*r**2, izz: k*m*r**2}}
contacts:
  model: rigid
  ground: {{normal: [sin(theta), 0, cos(theta)], height: cos(theta) - r}}
  friction: 0.5
  geometry:
    - {{name: floor, body: ball, radius: r}}
"""
    result = _run(text, 1.0, 0.01)
    a = G * math.sin(theta) / (1 + k)
    s = 0.5 * a * result.t ** 2
    assert np.abs(result.x[:, 0] - s * math.cos(theta)).max() < 1e-9
    assert np.abs(result.x[:, 2] - s / 0.1).max() < 1e-8        # spin = s / r
    assert np.abs(result.contacts.values[0, 7]).max() < 1e-9    # no slip
    assert result.contacts.located == []


def test_pendulum_strikes_the_wall_at_the_elliptic_times():
    """The shipped scene: released at 0.5 rad, it strikes at sqrt(L/g) K(sin^2(0.25))
    and returns with e times its speed; the next strike is a full swing out and back
    later, 2 sqrt(L/g) K(e^2 sin^2(0.25)); each strike takes (1 - e^2) of T."""
    result = _run((ROOT / "robots/contact/pendulum_wall.yaml").read_text(), 3.0, 0.001)
    e, L = 0.8, 1.0
    hits = result.contacts.located
    assert [h["event"] for h in hits] == ["touch-down"] * 3
    k = math.sin(0.25)
    t = math.sqrt(L / G) * ellipk(k ** 2)
    for hit in hits:
        assert abs(hit["t"] - t) < 1e-8
        assert hit["speed_after"] == pytest.approx(-e * hit["speed_before"], rel=1e-10)
        assert hit["energy_lost"] == pytest.approx(0.5 * hit["speed_before"] ** 2 * (1 - e * e),
                                                   rel=1e-9)
        assert abs(hit["speed_before"] + 2 * math.sqrt(G * L) * k) < 1e-8   # L omega
        k *= e
        t += 2 * math.sqrt(L / G) * ellipk(k ** 2)
    assert result.contacts.balance < 1e-8
    _never_gains(result)


def test_ball_leaves_a_dome_where_its_force_would_pull():
    """A ball (radius 0.1) nudged off the top of a fixed sphere (radius 1), frictionless:
    its centre's path has radius R = 1.1 and it lifts off at cos = (2 + v0^2/(g R))/3,
    at the time of the quadrature of the energy integral (1e-8).  The normal turns with
    the ball: this checks the contact Jacobian's derivative (dJ/dt) u as well."""
    v0, R = 0.1, 1.1
    text = f"""
name: dome
parameters: {{m: 1.0, v0: {v0}}}
gravity: [0, 0, -{G}]
coordinates:
  x: {{rate: v0}}
  z: {{initial: 1.1}}
bodies:
  - {{name: dome, joint: {{type: fixed}}, mass: 1}}
  - {{name: slide_x, joint: {{type: prismatic, axis: [1, 0, 0], displacement: x}}, mass: 0}}
  - {{name: ball, parent: slide_x, joint: {{type: prismatic, axis: [0, 0, 1],
     displacement: z}}, mass: m, inertia: {{ixx: 0.004, iyy: 0.004, izz: 0.004}}}}
contacts:
  model: rigid
  geometry:
    - {{name: top, body: ball, radius: 0.1, against: {{body: dome, radius: 1.0}}}}
"""
    result = _run(text, 1.5, 0.01)
    (leave,) = result.contacts.located
    angle = math.acos((2 + v0 ** 2 / (G * R)) / 3)
    t = quad(lambda a: R / math.sqrt(v0 ** 2 + 2 * G * R * (1 - math.cos(a))), 0, angle,
             epsabs=1e-14, epsrel=1e-13)[0]
    assert leave["event"] == "lift-off" and leave["bodies"] == ["ball", "dome"]
    assert abs(leave["t"] - t) < 1e-8
    before = result.t < t
    x, z = result.x[before, 0], result.x[before, 1]
    assert np.abs(np.hypot(x, z) - R).max() < 1e-10              # on the dome until then
    assert result.contacts.balance < 1e-9


def _bar(e, tilt):
    """A bar (m = 1, L = 1, I = m L^2 / 12) on slides x, z and a pitch joint, with a
    point at each end; tilted by ``tilt`` and falling from rest."""
    return f"""
name: bar
parameters: {{m: 1.0, L: 1.0}}
gravity: [0, 0, -{G}]
coordinates:
  x: {{}}
  z: {{initial: 0.5}}
  pitch: {{initial: {tilt}}}
bodies:
  - {{name: slide_x, joint: {{type: prismatic, axis: [1, 0, 0], displacement: x}}, mass: 0}}
  - {{name: slide_z, parent: slide_x, joint: {{type: prismatic, axis: [0, 0, 1],
     displacement: z}}, mass: 0}}
  - name: bar
    parent: slide_z
    joint: {{type: revolute, axis: [0, 1, 0], displacement: pitch}}
    mass: m
    inertia: {{ixx: 0.001, iyy: m*L**2/12, izz: m*L**2/12}}
contacts:
  model: rigid
  restitution: {e}
  geometry:
    - {{name: left, body: bar, point: [-L/2, 0, 0]}}
    - {{name: right, body: bar, point: [L/2, 0, 0]}}
"""


def test_flat_bar_hits_with_both_ends_at_once():
    """Two simultaneous impacts: both ends leave at e times their approach speed, each
    with half the impulse m (1 + e) v, and (1 - e^2) of T is lost."""
    e = 0.6
    result = _run(_bar(e, 0), 0.5, 0.01)
    first = [h for h in result.contacts.located if h["t"] == result.contacts.located[0]["t"]]
    assert sorted(h["contact"] for h in first) == ["left", "right"]
    v = math.sqrt(2 * G * 0.5)
    assert abs(first[0]["t"] - v / G) < 1e-8
    for h in first:
        assert h["speed_after"] == pytest.approx(e * v, rel=1e-9)
        assert h["impulse"][0] == pytest.approx(0.5 * (1 + e) * v, rel=1e-9)
    assert first[0]["energy_lost"] == pytest.approx(0.5 * v * v * (1 - e * e), rel=1e-9)
    assert np.abs(result.x[:, 2]).max() < 1e-12                 # stays flat
    _never_gains(result)


def test_impulse_balances_momentum_on_a_tilted_bar():
    """One end of a tilted bar strikes: by hand, m dvz = Lambda, I domega =
    -(L/2) cos(phi) Lambda, vx unchanged, Lambda = (1 + e) m_eff (-v_n) with
    1/m_eff = 1/m + (L/2 cos phi)^2 / I; the run's strikes never gain energy."""
    e, phi, L, m = 0.5, 0.3, 1.0, 1.0
    I = m * L * L / 12
    model = numeric_model(robot_from_text(_bar(e, phi), "bar.yaml"))
    rigid = impacts.Rigid(model)
    state = np.array([0.0, 0.5 * L * math.sin(phi), phi, 0.2, -1.0, 0.5])
    kin = impacts._Kinematics(model, 0.0, state)
    assert abs(kin.gap[1]) < 1e-15 and kin.gap[0] > 0
    after, (hit,) = rigid.impact(0.0, state, kin, [1])
    arm = 0.5 * L * math.cos(phi)
    vn = state[4] - arm * state[5]
    impulse = (1 + e) * -vn / (1 / m + arm ** 2 / I)
    assert hit.impulse[0] == pytest.approx(impulse, rel=1e-12)
    du = after[3:] - state[3:]
    assert du[0] == pytest.approx(0.0, abs=1e-15)
    assert m * du[1] == pytest.approx(impulse, rel=1e-12)
    assert I * du[2] == pytest.approx(-arm * impulse, rel=1e-12)
    assert after[4] - arm * after[5] == pytest.approx(-e * vn, rel=1e-12)
    result = _run(_bar(e, phi), 1.5, 0.01)
    assert len(result.contacts.located) > 3
    _never_gains(result)
    assert result.contacts.balance < 1e-8


PAIR = """
name: pair
parameters: {m1: 1.0, m2: 2.0, r: 0.1}
gravity: [0, 0, 0]
coordinates:
  a: {rate: 1.0}
  b: {initial: 1.0}
bodies:
  - {name: ball_a, joint: {type: prismatic, axis: [1, 0, 0], displacement: a}, mass: m1,
     inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}}
  - {name: ball_b, joint: {type: prismatic, axis: [1, 0, 0], displacement: b}, mass: m2,
     inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}}
contacts:
  model: rigid
  restitution: 0.5
  geometry:
    - {name: knock, body: ball_a, radius: r, against: {body: ball_b, radius: r}}
"""


def test_two_spheres_collide_by_newtons_law():
    """Frictionless spheres on x slides (1 kg at 1 m/s on 2 kg at rest), e = 0.5:
    v1 = (m1 - e m2) v / (m1 + m2) = 0, v2 = (1 + e) m1 v / (m1 + m2) = 0.5; momentum
    kept, m1 m2 / (m1 + m2) (1 - e^2) v^2 / 2 lost."""
    result = _run(PAIR, 2.0, 0.01)
    (hit,) = result.contacts.located
    assert abs(hit["t"] - 0.8) < 1e-10
    assert result.x[-1, 2:] == pytest.approx([0.0, 0.5], abs=1e-12)
    assert hit["energy_lost"] == pytest.approx(2 / 3 * 0.75 / 2, rel=1e-12)
    momentum = result.x[:, 2] + 2 * result.x[:, 3]
    assert np.abs(momentum - 1.0).max() < 1e-12


def test_simulate_writes_the_rigid_models_forces_and_events(tmp_path):
    out = tmp_path / "wall"
    assert main(["simulate", str(ROOT / "robots/contact/pendulum_wall.yaml"), "--no-plot",
                 "--t-end", "1", "--out", str(out)]) == 0
    header = (out / "simulate.csv").read_text().splitlines()[0].split(",")
    assert header[-4:] == ["wall_fn", "wall_ft1", "wall_ft2", "wall_depth"]
    contact = json.loads((out / "simulate.json").read_text())["contact"]
    assert contact["model"] == "rigid"
    (hit,) = contact["events"]
    assert set(hit) >= {"t", "contact", "bodies", "event", "impulse"}
    assert hit["bodies"] == ["bob"] and hit["impulse"][0] > 0
    assert contact["impact_losses"] == pytest.approx(hit["energy_lost"])
    assert contact["energy_balance"] < 1e-8


@pytest.mark.parametrize("change, message", [
    ("restitution: 0.5", "restitution: 1.5"),
    ("restitution: 0.5", "restitution: -0.1"),
    ("restitution: 0.5", "friction: -0.2"),
    ("restitution: 0.5", "stiffness: 1e6"),
    ("restitution: 0.5", "damping: 1"),
])
def test_bad_rigid_input_gets_one_line(tmp_path, capsys, change, message):
    text = _drop(0.5).replace(change, message)
    scene = tmp_path / "bad.yaml"
    scene.write_text(text)
    assert main(["simulate", str(scene), "--no-plot", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    key = message.split(":")[0]
    assert err.startswith(f"anadyn: error: {scene}:") and f"contacts.{key}" in err
    assert "\n" not in err and not (tmp_path / "o").exists()
    expected = {"restitution": "a coefficient of restitution lies in [0, 1]",
                "friction": "must be 0 or positive",
                "stiffness": "the rigid contact model has no stiffness",
                "damping": "the rigid contact model has no damping"}[key]
    assert expected in err
    with pytest.raises(ModelError):
        robot_from_text(text, "bad.yaml")


def test_rigid_pairs_are_frictionless_and_smooth_field_services_refuse_rigid(tmp_path,
                                                                              capsys):
    scene = tmp_path / "pair.yaml"
    scene.write_text(PAIR.replace("radius: r}}", "radius: r}, friction: 0.3}"))
    assert main(["simulate", str(scene), "--no-plot"]) == 2
    err = capsys.readouterr().err.strip()
    assert "friction: the rigid model's sphere pairs are frictionless" in err
    scene.write_text(_drop(0.5))
    assert main(["sweep", str(scene), "--vary", "m=1,2", "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "rigid" in err


@pytest.mark.parametrize("mu", [0.5, 0.01])
def test_friction_in_an_impact_sticks_inside_the_cone_and_slides_outside(mu):
    """The shipped bouncing ball made rigid (thrown at 1 m/s, e = 0.8, I = 2/5 m r^2):
    with mu = 0.5 the first impact's sticking impulse, -(2/7) m v, lies in the cone and
    the ball leaves rolling (v = 5/7 m/s, v = r omega) and rolls on through the later
    bounces; with mu = 0.01 it lies outside and the impulse is -mu Lambda_n."""
    text = (ROOT / "robots/contact/bouncing_ball.yaml").read_text()
    text = text[:text.index("contacts:")] + f"""contacts:
  model: rigid
  restitution: 0.8
  friction: {mu}
  geometry:
    - {{name: floor, body: ball, radius: r}}
"""
    result = _run(text, 1.0, 0.01)
    hit = result.contacts.located[0]
    m, r, v = 0.5, 0.1, 1.0
    normal = m * 1.8 * math.sqrt(2 * G * 0.9)
    assert hit["impulse"][0] == pytest.approx(normal, rel=1e-10)
    after = result.x[result.t > hit["t"]]
    if mu == 0.5:
        assert hit["impulse"][1] == pytest.approx(-2 / 7 * m * v, rel=1e-10)
        assert np.abs(after[:, 3] - 5 / 7).max() < 1e-9
        assert np.abs(after[:, 3] - r * after[:, 5]).max() < 1e-9
    else:
        assert hit["impulse"][1] == pytest.approx(-mu * normal, rel=1e-10)
        assert np.abs(after[:, 3] - (v - mu * normal / m)).max() < 1e-9
    _never_gains(result)
    assert result.contacts.balance < 1e-9


@pytest.mark.parametrize("mu", [0.7, 0.3])
def test_bar_on_an_incline_with_both_ends_closed(mu):
    """The bar laid along a 30 degree incline, at rest on both ends: two closed contacts
    (the tangential rows redundant: least-norm friction, shared equally) hold it with
    mu = 0.7 and both slide from rest with mu = 0.3, at g (sin - mu cos)."""
    theta = math.pi / 6
    text = _bar(0, "pi/6").replace("z: {initial: 0.5}", "z: {}").replace(
        "model: rigid", f"model: rigid\n  friction: {mu}\n"
        "  ground: {normal: [sin(pi/6), 0, cos(pi/6)], height: 0}")
    result = _run(text, 1.0, 0.01)
    a = G * max(0.0, math.sin(theta) - mu * math.cos(theta))
    assert result.contacts.located == []
    assert np.abs(result.x[:, 0] - 0.5 * a * math.cos(theta) * result.t ** 2).max() < 1e-9
    assert np.abs(result.x[:, 2] - theta).max() < 1e-9
    fn, ft2 = result.contacts.values[:, 0], result.contacts.values[:, 2]
    assert np.abs(fn - 0.5 * G * math.cos(theta)).max() < 1e-9
    held = G * math.sin(theta) if mu > math.tan(theta) else mu * G * math.cos(theta)
    assert np.abs(ft2 - 0.5 * held).max() < 1e-9


@pytest.mark.parametrize("axis", ["x", "z"])
def test_a_growing_push_makes_a_resting_block_slip_or_lift_off(axis):
    """A block at rest on the floor (mu = 0.5) under a force k t (k = 2 N/s): along x it
    sticks until k t = mu m g, then slips (x = k (t - ts)^3 / (6 m), friction mu m g);
    upwards it lifts off where k t = m g (z = k (t - tl)^3 / (6 m))."""
    k, mu = 2.0, 0.5
    force = "[2*t, 0, 0]" if axis == "x" else "[0, 0, 2*t]"
    text = _block(v0=0.0, mu=mu) + f"""loads:
  - {{body: block, force: {force}}}
"""
    result = _run(text, 6.0, 0.01)
    (event,) = result.contacts.located
    start = (mu if axis == "x" else 1.0) * G / k
    assert event["event"] == ("slip" if axis == "x" else "lift-off")
    assert abs(event["t"] - start) < 1e-8
    moving = np.clip(result.t - start, 0, None)
    column = 0 if axis == "x" else 1
    assert np.abs(result.x[:, column] - k * moving ** 3 / 6).max() < 1e-8
    assert np.abs(result.x[:, 1 - column]).max() < 1e-10
    if axis == "x":
        ft = result.contacts.values[0, 1]
        assert np.abs(ft[result.t > start] + mu * G).max() < 1e-9
        assert np.abs(ft[result.t < start] + k * result.t[result.t < start]).max() < 1e-9
    else:
        assert np.all(result.contacts.values[0, 0][result.t > start] == 0)


def test_a_free_box_tumbles_onto_its_face_without_gaining_energy():
    """A box on a floating joint (quaternion), dropped tilted on its eight corners
    (e = 0.3, mu = 0.5): many impacts of one or several corners with friction, none
    gaining energy, the balance with their losses closed; it comes to rest on its face,
    the corners' normal forces carrying m g."""
    text = """
name: box
parameters: {m: 2.0, a: 0.1, b: 0.15, c: 0.05}
gravity: [0, 0, -9.81]
coordinates:
  box_x: {}
  box_y: {}
  box_z: {initial: 0.3}
  box_qw: {initial: 0.9950041652780258}
  box_qx: {initial: 0.09983341664682815}
  box_qy: {}
  box_qz: {}
bodies:
  - name: box
    joint: {type: floating}
    mass: m
    inertia: {ixx: m*(b**2 + c**2)/3, iyy: m*(a**2 + c**2)/3, izz: m*(a**2 + b**2)/3}
contacts:
  model: rigid
  restitution: 0.3
  friction: 0.5
  geometry:
    - {name: hull, body: box, shape: box, size: [a, b, c]}
"""
    result = _run(text, 2.0, 0.01, rtol=1e-10)
    events = result.contacts.located
    assert sum(e["event"] == "touch-down" for e in events) > 20
    _never_gains(result)
    assert result.contacts.balance < 1e-9
    final = dict(zip(result.table()[0], (column[-1] for column in result.table()[1])))
    assert abs(final["box_z"] - 0.05) < 1e-9
    assert abs(final["box_qx"]) < 1e-9 and abs(final["box_qy"]) < 1e-9
    assert abs(result.contacts.values[:, 0, -1].sum() - 2.0 * 9.81) < 1e-9
