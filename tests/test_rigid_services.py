"""`check` and `accuracy` on scenes with rigid contacts (issue 27: the energy balance
counts the impacts' losses; accuracy measures error against run time with the event
times).  Expected values are closed forms worked out here:

- a ball (m = 1 kg) dropped from h0 onto a rigid floor with restitution e touches down
  at t_1 = v/g, t_k = t_(k-1) + 2 e^(k-1) v / g (v = sqrt(2 g h0)), and the k-th impact
  takes (1 - e^2) m (e^(k-1) v)^2 / 2;
- the path's energy T + V plus what the impacts took stays E0 (a balance, not a drift).
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import robot_from_text
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services import accuracy

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_contact import G, _drop as compliant_drop  # noqa: E402
from test_rigid_contact import _block as rigid_block  # noqa: E402

M, R, H0 = 1.0, 0.1, 1.0          # test_contact's ball, dropped from 1 m


def drop(e: float, extra: str = "", t_end: float = 1.2) -> str:
    """test_contact's ball (m = 1 kg, r = 0.1 m) on its vertical slide, dropped from H0
    onto a rigid floor with restitution ``e``."""
    return compliant_drop(height=H0 + R, extra=(
        f"simulation: {{t_end: {t_end}, output_step: 0.001}}\n{extra}")).replace(
        "stiffness: 1000000.0\n  damping: 0.0", f"model: rigid\n  restitution: {e}")


def touchdowns(e: float, count: int) -> list[float]:
    v = math.sqrt(2 * G * H0)
    times = [v / G]
    for k in range(1, count):
        times.append(times[-1] + 2 * e ** k * v / G)
    return times


def test_check_balances_the_energy_with_the_impacts_losses(tmp_path, capsys):
    e = 0.5
    scene = tmp_path / "drop.yaml"
    scene.write_text(drop(e))
    assert main(["check", str(scene), "--out", str(tmp_path / "out")]) == 0
    text = capsys.readouterr().out
    report = json.loads((tmp_path / "out" / "check.json").read_text())
    strikes = [t for t in touchdowns(e, 10) if t <= 1.2]
    v = math.sqrt(2 * G * H0)
    taken = sum((1 - e * e) * M * (e ** k * v) ** 2 / 2 for k in range(len(strikes)))
    assert report["impact_losses"] == pytest.approx(taken, rel=1e-8)
    hits = [ev["t"] for ev in report["events"] if ev["event"] == "touch-down"]
    assert hits == pytest.approx(strikes, abs=1e-8)
    assert report["checks"][0]["name"] == "energy drift" and report["checks"][0]["passed"]
    assert report["energy_error"] < 1e-8
    assert "T + V + E_c - E0" in text and f"{len(strikes)} impacts" in text


def test_the_balance_fails_when_the_losses_are_left_out(tmp_path, monkeypatch):
    """The balance is what the check is about: without the impacts' losses it misses."""
    from anadyn_cli.numeric import impacts

    real = impacts.run

    def without_losses(*args, **kwargs):
        ran = real(*args, **kwargs)
        ran.lost[:] = 0.0
        return ran

    monkeypatch.setattr(impacts, "run", without_losses)
    scene = tmp_path / "drop.yaml"
    scene.write_text(drop(0.5))
    assert main(["check", str(scene), "--out", str(tmp_path / "out")]) == 1


def test_check_refuses_rigid_scenes_with_actuators_in_one_line(tmp_path, capsys):
    scene = tmp_path / "driven.yaml"
    scene.write_text(drop(0.5, extra="actuators: {F: {joint: ball}}\ncontroller: {laws: {F: 0}}"))
    assert main(["check", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "without actuators, loads or joint forces" in err
    assert not (tmp_path / "out").exists()


def test_accuracy_scores_the_located_events_against_the_reference():
    e = 0.5
    model = numeric_model(robot_from_text(drop(e, t_end=1.0), "drop.yaml"))
    study = accuracy.study(model, methods=("auto", "DOP853", "RK45"), tolerances=(1e-5, 1e-9),
                           repeats=1)
    assert {r.method for r in study.rows} == {"DOP853", "RK45"}        # event-driven only
    assert all(r.status == "ok" for r in study.rows)
    for method in ("DOP853", "RK45"):
        loose, tight = (r for r in study.rows if r.method == method)
        assert tight.event_error < loose.event_error
        assert tight.event_error < 1e-6 and math.isfinite(loose.event_error)
    # the references' own touch-downs sit at the closed form's times
    runs = accuracy.RigidRuns(model, study.grid)
    runs("DOP853", 1e-12, 1e-14)
    hits = [ev["t"] for ev in runs.events[("DOP853", 1e-12)] if ev["event"] == "touch-down"]
    assert hits == pytest.approx([t for t in touchdowns(e, 10) if t <= 1.0], abs=1e-9)


# -- static and kinetic friction (the rigid model's static_friction) -------------------
def block(load: str, static: float, kinetic: float) -> str:
    """test_rigid_contact's 1 kg block (slides x and z) at rest on the floor, pushed
    along x by ``load``, with friction ``kinetic`` and ``static``."""
    return rigid_block(v0=0.0, mu=kinetic).replace(
        "  friction: mu\n", f"  friction: mu\n  static_friction: {static}\n") + (
        f"loads:\n  - {{body: block, force: {load}}}\n"
        "simulation: {t_end: 6, output_step: 0.01}\n")


def test_a_growing_push_breaks_static_friction_then_slides_against_kinetic():
    """Under a push k t the block sticks until k t = mu_s m g, then slides with friction
    mu_k m g: x = k (t - ts)^3 / 6 + (mu_s - mu_k) g (t - ts)^2 / 2 (m = 1)."""
    from anadyn_cli.services.simulate import simulate

    k, static, kinetic = 2.0, 0.6, 0.4
    model = numeric_model(robot_from_text(block("[2*t, 0, 0]", static, kinetic), "b.yaml"))
    result = simulate(model, rtol=1e-11, atol=1e-13)
    (event,) = result.contacts.located
    start = static * G / k
    assert event["event"] == "slip" and event["t"] == pytest.approx(start, abs=1e-8)
    s = (result.t - start).clip(min=0)
    expected = k * s ** 3 / 6 + (static - kinetic) * G * s ** 2 / 2
    assert abs(result.x[:, 0] - expected).max() < 1e-8
    friction = result.contacts.values[0, 1]
    sliding = result.t > start + 1e-6
    assert abs(friction[sliding] + kinetic * G).max() < 1e-9        # -mu_k m g along x
    assert abs(friction[~sliding] + k * result.t[~sliding]).max() < 1e-9   # holds k t


def test_a_push_between_the_two_coefficients_moves_nothing_from_rest():
    """A constant push of 0.5 m g: above mu_k m g but below mu_s m g, the block at rest
    stays at rest (static friction holds it)."""
    from anadyn_cli.services.simulate import simulate

    model = numeric_model(robot_from_text(block(f"[{0.5 * G}, 0, 0]", 0.6, 0.4), "b.yaml"))
    result = simulate(model, rtol=1e-11, atol=1e-13, t_end=2.0)
    assert result.contacts.located == [] and abs(result.x[:, 0]).max() < 1e-10


@pytest.mark.parametrize("change, message", [
    (("static_friction: 0.6", "static_friction: 0.3"),
     "must be at least friction (0.4, the kinetic coefficient), got 0.3"),
    (("model: rigid", "model: compliant\n  stiffness: 1e6"),
     "static_friction belongs to the rigid contact model"),
])
def test_static_friction_is_checked_in_one_line(tmp_path, capsys, change, message):
    scene = tmp_path / "block.yaml"
    scene.write_text(block("[0, 0, 0]", 0.6, 0.4).replace(*change))
    assert main(["simulate", str(scene), "--no-plot", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and message in err and "static_friction" in err
    assert not (tmp_path / "o").exists()
