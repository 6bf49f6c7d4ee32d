"""`anadyn inverse`: efforts along a prescribed motion, against independent sources.

The oracle is written here from the chapter's description of the two arms
(sections 6.3 and 6.5), with sympy.physics.mechanics' KanesMethod, and driven
by the cycloidal motion's derivatives written out by hand; nothing of
anadyn's kinematics, formulations or trajectory code is used for it.
"""
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from sympy.physics import mechanics as me

from anadyn_cli import robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services.inverse import InverseDynamics, inverse
from anadyn_cli.numeric.trajectory import motion

ROOT = Path(__file__).resolve().parents[1]
RR_PATH, RRT_PATH = str(ROOT / "robots" / "rr.yaml"), str(ROOT / "robots" / "rrt.yaml")
RR_TEXT, RRT_TEXT = Path(RR_PATH).read_text(), Path(RRT_PATH).read_text()
G = sp.Rational(981, 100)
PI = math.pi
# the chapter's inverse problems: start, end, Tp (RR starts at the text's -pi/18)
CHAPTER = {"rr": ((-PI / 18, PI / 6), (PI / 6, PI / 3), 15.0),
           "rrt": ((PI / 18, PI / 6, 0.25), (PI / 3, PI / 3, 0.3), 15.0)}


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))


def edited(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new)


def robot(name: str, text: str | None = None):
    text = text if text is not None else {"rr": RR_TEXT, "rrt": RRT_TEXT}[name]
    return robot_from_text(text, f"{name}.yaml")


# -- the oracle ---------------------------------------------------------------------
def _kane(frame, q, bodies, loads, taus):
    """M, F, B of M ddq = F + B tau by KanesMethod with u = dq, as plain-symbol functions."""
    u = me.dynamicsymbols(" ".join(f"u{i}" for i in range(len(q))))
    kane = me.KanesMethod(frame, q_ind=q, u_ind=u,
                          kd_eqs=[qi.diff(me.dynamicsymbols._t) - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(bodies, loads)
    x = sp.symbols(f"x0:{2 * len(q)}")
    plain = dict(zip([*q, *u], x))
    M = kane.mass_matrix.xreplace(plain)
    forcing = kane.forcing.xreplace(plain)
    B = forcing.jacobian(taus)
    F = forcing.xreplace({tau: 0 for tau in taus})
    return sp.lambdify(x, M, "numpy"), sp.lambdify(x, F, "numpy"), sp.lambdify(x, B, "numpy")


def rr_oracle():
    """Section 6.3: two bars, absolute angles from the horizontal x axis, gravity -y."""
    q1, q2 = me.dynamicsymbols("q1 q2")
    T01z, T12z = sp.symbols("T01z T12z")
    m, L = 1, 1
    N = me.ReferenceFrame("N")
    bar1, bar2 = N.orientnew("A", "Axis", (q1, N.z)), N.orientnew("B", "Axis", (q2, N.z))
    A = me.Point("A")
    A.set_vel(N, 0)
    C1 = A.locatenew("C1", L / 2 * bar1.x)
    C1.v2pt_theory(A, N, bar1)
    B = A.locatenew("B", L * bar1.x)
    B.v2pt_theory(A, N, bar1)
    C2 = B.locatenew("C2", L / 2 * bar2.x)
    C2.v2pt_theory(B, N, bar2)
    I = sp.Rational(m * L**2, 12)
    bodies = [me.RigidBody("b1", C1, bar1, m, (me.inertia(bar1, 0, 0, I), C1)),
              me.RigidBody("b2", C2, bar2, m, (me.inertia(bar2, 0, 0, I), C2))]
    loads = [(C1, -m * G * N.y), (C2, -m * G * N.y),
             (bar1, (T01z - T12z) * N.z), (bar2, T12z * N.z)]
    return _kane(N, [q1, q2], bodies, loads, [T01z, T12z])


def rrt_oracle():
    """Section 6.5: i0 vertical; link 1 about i0, link 2 about j1 at 2 L1 on k1, link 3
    slides along k2 from C2 (C3 = C2 + q3 k2); F23z reacts on link 2 at C32."""
    q1, q2, q3 = me.dynamicsymbols("q1 q2 q3")
    T01x, T12y, F23z = sp.symbols("T01x T12y F23z")
    L1 = L2 = sp.Rational(2, 5)
    m1, m2, m3 = 90, 60, 40
    N = me.ReferenceFrame("N")
    f1 = N.orientnew("F1", "Axis", (q1, N.x))
    f2 = f1.orientnew("F2", "Axis", (q2, f1.y))
    A = me.Point("A")
    A.set_vel(N, 0)
    C1 = A.locatenew("C1", L1 * f1.z)
    C1.v2pt_theory(A, N, f1)
    B = A.locatenew("B", 2 * L1 * f1.z)
    B.v2pt_theory(A, N, f1)
    C2 = B.locatenew("C2", L2 * f2.z)
    C2.v2pt_theory(B, N, f2)
    C3 = C2.locatenew("C3", q3 * f2.z)
    C3.set_vel(N, C3.pos_from(A).dt(N))
    C32 = C2.locatenew("C32", q3 * f2.z)          # the point of link 2 under C3
    C32.v2pt_theory(C2, N, f2)
    I1, I2 = m1 * (2 * L1)**2 / 12, m2 * (2 * L2)**2 / 12
    bodies = [me.RigidBody("l1", C1, f1, m1, (me.inertia(f1, I1, I1, 0), C1)),
              me.RigidBody("l2", C2, f2, m2, (me.inertia(f2, I2, I2, 0), C2)),
              me.RigidBody("l3", C3, f2, m3, (me.inertia(f2, 5, 4, 1), C3))]
    loads = [(C1, -m1 * G * N.x), (C2, -m2 * G * N.x), (C3, -m3 * G * N.x),
             (f1, T01x * f1.x - T12y * f2.y), (f2, T12y * f2.y),
             (C3, F23z * f2.z), (C32, -F23z * f2.z)]
    return _kane(N, [q1, q2, q3], bodies, loads, [T01x, T12y, F23z])


def cycloid(start, end, Tp, t):
    """The chapter's (6.24)/(6.43) and its derivatives, written out: (N, n) arrays."""
    a = (np.asarray(end) - np.asarray(start)) / Tp
    w = 2 * PI / Tp
    t = np.asarray(t)[:, None]
    q = np.asarray(start) + a * (t - np.sin(w * t) / w)
    return q, a * (1 - np.cos(w * t)), a * w * np.sin(w * t)


def oracle_efforts(matrices, q, dq, ddq):
    M, F, B = matrices
    out = []
    for x, acc in zip(np.hstack([q, dq]), ddq):
        Mx, Fx, Bx = (np.asarray(f(*x), dtype=float) for f in (M, F, B))
        out.append(np.linalg.solve(Bx, Mx @ acc - Fx[:, 0]))
    return np.array(out)


@pytest.fixture(scope="module")
def oracles():
    return {"rr": rr_oracle(), "rrt": rrt_oracle()}


def scale(tau):
    return np.abs(tau).max(axis=0)


# -- efforts -------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rr", "rrt"])
def test_efforts_agree_with_the_mechanics_oracle(name, oracles):
    result = inverse(numeric_model(robot(name), evaluator="recursive"), roundtrip=False)
    times = np.arange(16.0)
    ours = result.dynamics.efforts(times)[3]
    theirs = oracle_efforts(oracles[name], *cycloid(*CHAPTER[name], times))
    assert np.all(np.abs(ours - theirs) <= 1e-9 * scale(theirs))
    # the written grid has the same values at its whole seconds
    rows = np.rint(times / result.step).astype(int)
    assert np.allclose(result.t[rows], times, rtol=0, atol=1e-12)
    assert np.all(np.abs(result.efforts[rows] - theirs) <= 1e-9 * scale(theirs))


@pytest.mark.parametrize("name", ["rr", "rrt"])
def test_recursive_and_lagrange_closed_form_efforts_agree(name):
    recursive = inverse(numeric_model(robot(name), evaluator="recursive"), roundtrip=False)
    lagrange = inverse(numeric_model(robot(name), "lagrange"), roundtrip=False)
    assert np.all(np.abs(recursive.efforts - lagrange.efforts)
                  <= 1e-10 * scale(recursive.efforts))


def rr_static(q1, q2, m=1.0, L=1.0, g=9.81):
    """(6.23) at rest: T12z = m g L/2 cos q2, T01z = 3/2 m g L cos q1 + T12z."""
    t12 = 0.5 * m * g * L * np.cos(q2)
    return np.stack([1.5 * m * g * L * np.cos(q1) + t12, t12], axis=-1)


def rrt_static(q2, q3, m2=60.0, m3=40.0, L2=0.4, g=9.81):
    """(6.41) at rest: T01x = 0, T12y = g m2 L2 c2 + g m3 c2 (L2 + q3), F23z = g m3 s2."""
    c2, s2 = np.cos(q2), np.sin(q2)
    return np.stack([0 * c2, g * m2 * L2 * c2 + g * m3 * c2 * (L2 + q3), g * m3 * s2], axis=-1)


def test_at_rest_the_efforts_are_the_static_gravity_load():
    # the chapter's motions start and end at rest (zero rate and acceleration)
    for name, static in (("rr", lambda q: rr_static(q[0], q[1])),
                         ("rrt", lambda q: rrt_static(q[1], q[2]))):
        result = inverse(numeric_model(robot(name)), roundtrip=False)
        start, end, _ = CHAPTER[name]
        for row, pose in ((0, start), (-1, end)):
            assert np.allclose(result.efforts[row], static(pose), rtol=1e-12, atol=1e-12)
    # and a robot told to hold still, at poses off the chapter's path
    still = "trajectory: {kind: expression, duration: 2, expressions: {q1: 0.3, q2: -1.1}}"
    text = edited(RR_TEXT, "trajectory: {kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}",
                  still)
    result = inverse(numeric_model(robot("rr", text)), roundtrip=False)
    assert np.all(result.dq == 0) and np.all(result.ddq == 0)
    assert np.allclose(result.efforts, rr_static(0.3, -1.1), rtol=1e-12, atol=1e-12)
    text = edited(RRT_TEXT, "trajectory: {kind: cycloidal, duration: 15, "
                            "to: {q1: pi/3, q2: pi/3, q3: 0.3}}",
                  "trajectory: {kind: expression, duration: 2, "
                  "expressions: {q1: 2, q2: -0.7, q3: 0.6}}")
    result = inverse(numeric_model(robot("rrt", text)), roundtrip=False)
    assert np.allclose(result.efforts, rrt_static(-0.7, 0.6), rtol=1e-12, atol=1e-12)


def test_quintic_and_expression_rates_are_exact():
    text = edited(RR_TEXT, "trajectory: {kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}",
                  "trajectory: {kind: quintic, duration: 4, from: {q1: 0.5}, to: {q1: -0.5}}")
    prescribed = motion(robot("rr", text))
    t = np.linspace(0, 4, 9)
    s = t / 4
    q, dq, ddq = prescribed(t)
    assert np.allclose(q[:, 0], 0.5 - (10 * s**3 - 15 * s**4 + 6 * s**5), rtol=0, atol=1e-15)
    assert np.allclose(dq[:, 0], -(30 * s**2 - 60 * s**3 + 30 * s**4) / 4, rtol=0, atol=1e-15)
    assert np.allclose(ddq[:, 0], -(60 * s - 180 * s**2 + 120 * s**3) / 16, rtol=0, atol=1e-15)
    assert np.all(q[:, 1] == PI / 6) and np.all(dq[:, 1] == 0)     # left out: holds its start
    text = edited(RR_TEXT, "trajectory: {kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}",
                  "trajectory: {kind: expression, duration: 3, "
                  "expressions: {q2: 0.2*exp(-t)*cos(3*t)}}")
    q, dq, ddq = motion(robot("rr", text))(t)
    e, c, s3 = np.exp(-t), np.cos(3 * t), np.sin(3 * t)
    assert np.allclose(dq[:, 1], 0.2 * e * (-c - 3 * s3), rtol=0, atol=1e-15)
    assert np.allclose(ddq[:, 1], 0.2 * e * (-8 * c + 6 * s3), rtol=0, atol=1e-15)
    assert np.all(q[:, 0] == -PI / 18)


# -- round trip ------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rr", "rrt"])
def test_round_trip_passes_and_files_are_written(name, tmp_path, capsys):
    out = tmp_path / name
    path = RR_PATH if name == "rr" else RRT_PATH
    assert main(["inverse", path, "--out", str(out), "--no-cache"]) == 0
    printed = capsys.readouterr().out.splitlines()
    summary = json.loads((out / "inverse.json").read_text())
    trip = summary["roundtrip"]
    assert trip["passed"] and 0 < trip["max_error"] < 1e-6 and trip["tolerance"] == 1e-6
    assert trip["segments"] > 1 and trip["growth_rate"] > 3   # an unstable open loop
    assert summary["points"] == 1501
    assert (out / "inverse.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    header, *rows = (out / "inverse.csv").read_text().splitlines()
    names = {"rr": ["q1", "q2"], "rrt": ["q1", "q2", "q3"]}[name]
    efforts = {"rr": ["T01z", "T12z"], "rrt": ["T01x", "T12y", "F23z"]}[name]
    assert header.split(",") == ["t", *names, *("d" + n for n in names),
                                 *("dd" + n for n in names), *efforts]
    assert len(rows) == 1501 and rows[-1].startswith("15.0,")
    first = [float(v) for v in rows[0].split(",")]
    assert first[1:1 + len(names)] == list(CHAPTER[name][0])   # full precision
    table = {"rr": ["       t (s)    T01z (N·m)    T12z (N·m)",
                    "           0     18.739301      4.247855"],
             "rrt": ["       t (s)    T01x (N·m)    T12y (N·m)      F23z (N)",
                     "           0      0.000000    424.785461    196.200000"]}[name]
    assert printed[1:3] == table and len(printed) >= 3 + 15
    assert printed[3 + 14].startswith("          15 ")
    assert any(line.startswith("round trip: largest tracking error") and ": ok [" in line
               for line in printed)


def test_round_trip_misses_a_tight_tolerance(tmp_path, capsys):
    assert main(["inverse", RR_PATH, "--out", str(tmp_path), "--no-plot", "--no-cache",
                 "--roundtrip-tol", "1e-14"]) == 1
    err = capsys.readouterr().err
    pattern = (re.escape(f"anadyn: error: {RR_PATH}: round trip: largest tracking error ")
               + r"\d\.\d+e-\d\d rad \(q[12] at t = [\d.]+ s\) exceeds the round trip's "
               r"tolerance 1e-14\n")
    assert re.fullmatch(pattern, err), err
    assert json.loads((tmp_path / "inverse.json").read_text())["roundtrip"]["passed"] is False


def test_round_trip_catches_slightly_wrong_efforts(monkeypatch):
    """Efforts off by one part in a million make the motion miss by more than 1e-6."""
    result = inverse(numeric_model(robot("rr")), roundtrip=True)
    assert result.roundtrip.passed
    exact = InverseDynamics.applied_at
    monkeypatch.setattr(InverseDynamics, "applied_at",
                        lambda self, t: (exact(self, t)[0] * (1 + 1e-6), exact(self, t)[1]))
    wrong = inverse(numeric_model(robot("rr")), roundtrip=True)
    assert not wrong.roundtrip.passed and wrong.roundtrip.max_error > 1e-6


# -- refusals ---------------------------------------------------------------------------
def without_controller(text: str) -> str:
    return re.sub(r"controller:\n(?:  .*\n)+", "", text)


def test_an_unactuated_coordinate_is_refused(tmp_path, capsys):
    path = tmp_path / "rrt_no_slider_force.yaml"
    slider = "  F23z: {joint: link3}        # force along k2, reaction on link 2 at C32\n"
    path.write_text(edited(without_controller(RRT_TEXT), slider, ""))
    assert main(["inverse", str(path), "--out", str(tmp_path / "out"), "--no-cache"]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: actuators: 3 coordinates, 2 actuators: inverse dynamics needs "
        "one independent actuator per coordinate (B square and non-singular); not actuated: q3\n")
    assert not (tmp_path / "out").exists()


def test_two_actuators_on_one_joint_are_refused(tmp_path, capsys):
    path = tmp_path / "rr_two_on_bar1.yaml"
    path.write_text(edited(without_controller(RR_TEXT), "T12z: {joint: bar2}",
                           "T01b: {joint: bar1}"))
    assert main(["inverse", str(path), "--out", str(tmp_path / "out"), "--no-cache"]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: actuators: 2 coordinates, 2 actuators, but B is singular at "
        "t = 0 s: inverse dynamics needs one independent actuator per coordinate (B square and "
        "non-singular); not actuated: q2\n")


def test_no_trajectory_is_one_line_and_exit_2(tmp_path, capsys):
    path = tmp_path / "still.yaml"
    path.write_text(re.sub(r"trajectory: .*\n", "", RR_TEXT))
    assert main(["inverse", str(path), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: no trajectory section: inverse dynamics needs a prescribed "
        "motion (trajectory: kind cycloidal, quintic or expression)\n")


def test_a_motion_without_acceleration_is_refused(tmp_path, capsys):
    path = tmp_path / "kink.yaml"
    path.write_text(edited(RR_TEXT, "{kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}",
                           "{kind: expression, duration: 2, expressions: {q1: abs(t - 1)}}"))
    assert main(["inverse", str(path), "--out", str(tmp_path / "out"), "--no-cache"]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: trajectory.expressions.q1: q1(t) is not twice differentiable "
        "(its rate jumps); inverse dynamics needs a finite acceleration\n")
