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

import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import robot_from_text
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services import accuracy

G = 9.81
M, R, H0 = 1.0, 0.1, 1.0


def drop(e: float, extra: str = "", t_end: float = 1.2) -> str:
    return f"""
name: drop
parameters: {{m: {M}, r: {R}}}
gravity: [0, 0, -{G}]
coordinates:
  z: {{initial: {H0 + R}}}
bodies:
  - name: ball
    joint: {{type: prismatic, axis: [0, 0, 1], displacement: z}}
    mass: m
    inertia: {{ixx: 0.004, iyy: 0.004, izz: 0.004}}
contacts:
  model: rigid
  restitution: {e}
  geometry:
    - {{name: floor, body: ball, radius: r}}
simulation: {{t_end: {t_end}, output_step: 0.001}}
{extra}"""


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
