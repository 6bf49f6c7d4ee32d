"""`anadyn compare`: Lagrange against Kane, and that it catches a wrong term.

The wrong terms are injected into Lagrange's equations through
``formulations.FORMULATIONS`` (what ``derive`` calls), with a private derivation
cache so that the patched code neither comes from nor goes to a real one.
"""
import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from anadyn_cli import robot_from_text
from anadyn_cli.symbolic import formulations
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.cli import main
from anadyn_cli.services.compare import symbolic_check, trajectory_check
from anadyn_cli.symbolic.eom import EquationsOfMotion
from anadyn_cli.symbolic.formulations import derive

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from random_robots import random_robot_yaml  # noqa: E402

RR = ROOT / "robots" / "rr.yaml"


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))


def inject(monkeypatch, part: str, term):
    """Lagrange's ``part`` (M or F) gets ``term(eom)`` added to its first entry."""
    original = formulations.FORMULATIONS["lagrange"]

    def wrong(robot, kin):
        eom = original(robot, kin)
        matrix = sp.Matrix(getattr(eom, part))
        matrix[0] += term(eom)
        return EquationsOfMotion(**{**eom.__dict__, part: sp.ImmutableMatrix(matrix)})

    monkeypatch.setitem(formulations.FORMULATIONS, "lagrange", wrong)


def test_compare_passes_on_every_shipped_robot(tmp_path, monkeypatch, capsys):
    """With no argument: every robots/*.yaml, closed chains and forces included; those
    with a spherical joint (compared when named: tests/test_spherical_closed_forms.py)
    left out, and said so."""
    from anadyn_cli import load_robot

    monkeypatch.chdir(ROOT)
    assert main(["compare", "--out", str(tmp_path)]) == 0
    spherical = {p.stem for p in (ROOT / "robots").glob("*.yaml") if load_robot(p).spherical}
    assert {"spherical_pendulum", "tumbling_box"} <= spherical
    assert "left out (a spherical joint: name them to compare them; a floating base's " \
           "closed forms are large): " in capsys.readouterr().err
    names = {p.stem for p in (ROOT / "robots").glob("*.yaml")} - spherical
    assert {p.parent.name for p in tmp_path.glob("*/compare.json")} == names  # a folder each
    for name in names:
        figures = json.loads((tmp_path / name / "compare.json").read_text())
        assert set(figures["robots"]) == {name}
        assert figures["passed"] is True and figures["mismatches"] == 0


def test_compare_on_the_chapters_arms(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    assert main(["compare", "robots/rr.yaml", "robots/rrt.yaml", "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == ("kane vs lagrange: symbolic budget 10000 terms per robot; 200 random "
                        "states (seed 0), |lagrange - kane| <= 1e-09 x size per state; "
                        "trajectories: states scaled by max(1, |x|max) within 1e-07")
    rows = [line.split() for line in lines[2:14]]
    assert [r[:2] for r in rows] == [[robot, check] for robot in ("rr", "rrt") for check in
                                     ("symbolic", "M", "F", "B", "ddq", "trajectory")]
    assert lines[2].endswith("0 exactly (all 10 entries of M, F, B)")
    assert lines[8].endswith("0 exactly (all 21 entries of M, F, B)")
    assert all(line.split()[6] == "ok" for line in lines[3:8] + lines[9:14])
    assert lines[7].endswith("ok (1501 rows to 15 s, odeint rtol 1e-10)")
    assert not (tmp_path / "compare.json").exists()          # each robot in its own folder
    for name in ("rr", "rrt"):
        figures = json.loads((tmp_path / name / "compare.json").read_text())
        assert figures["passed"] is True and figures["mismatches"] == 0
        assert figures["robots_compared"] == 1 and figures["symbolic_proven"] == 1
        assert set(figures["robots"]) == {name}
        with open(tmp_path / name / "compare.csv") as stream:
            table = list(csv.reader(stream))
        assert table[0] == ["robot", "check", "max_abs", "max_rel", "tolerance", "passed",
                            "detail"]
        assert len(table) == 7 and all(row[5] == "True" and row[0] == name
                                       for row in table[1:])


def test_a_wrong_term_in_f_is_caught_by_every_check(tmp_path, monkeypatch, capsys):
    inject(monkeypatch, "F", lambda eom: sp.Rational(1, 1000) * eom.dq[0] ** 2)
    assert main(["compare", str(RR), "--out", str(tmp_path)]) == 1
    captured = capsys.readouterr()
    err = captured.err
    assert err.startswith("anadyn: error: compare: rr: F[1] differs symbolically "
                          "(lagrange - kane = dq1**2/1000); rr: F differs: max relative "
                          "difference 3.35e-03 > 1e-09 at state ")
    assert "; rr: ddq differs: " in err and "; rr: trajectory differs: " in err
    assert "\n" not in err.rstrip("\n")
    out = captured.out.splitlines()
    assert out[2].endswith("MISMATCH F[1]: lagrange - kane = dq1**2/1000")
    assert out[4].endswith("MISMATCH (200 of 200 states over)")
    summary = json.loads((tmp_path / "compare.json").read_text())
    assert summary["robots"]["rr"]["mismatches"] == ["symbolic", "F", "ddq", "trajectory"]


def test_numbers_alone_catch_a_wrong_mass_matrix(tmp_path, monkeypatch, capsys):
    inject(monkeypatch, "M", lambda eom: sp.Rational(1, 100) * sp.cos(eom.q[1]) ** 2)
    assert main(["compare", str(RR), "--symbolic-terms", "0", "--out", str(tmp_path)]) == 1
    captured = capsys.readouterr()
    assert captured.err.startswith("anadyn: error: compare: rr: M differs: max relative "
                                   "difference ")
    assert "numeric only (symbolic check off)" in captured.out


def test_a_term_below_the_numeric_tolerance_is_caught_symbolically(tmp_path, monkeypatch,
                                                                   capsys):
    inject(monkeypatch, "F", lambda eom: sp.Rational(1, 10**13) * eom.dq[0] ** 2)
    assert main(["compare", str(RR), "--out", str(tmp_path)]) == 1
    assert capsys.readouterr().err == ("anadyn: error: compare: rr: F[1] differs symbolically "
                                       "(lagrange - kane = dq1**2/10000000000000)\n")


def test_trajectory_check_sees_a_different_motion(tmp_path):
    text = RR.read_text()
    robot = robot_from_text(text, "rr.yaml")
    stronger = robot_from_text(text.replace("g: 9.81", "g: 9.82"), "rr.yaml")
    ours = numeric_model(robot, evaluator="recursive")
    other = numeric_model(stronger, "lagrange")
    same, failure = trajectory_check(ours, numeric_model(robot, "lagrange"), 1e-7)
    assert same.passed and same.max_rel < 1e-9 and failure == ""     # recursive vs closed form
    differs, failure = trajectory_check(ours, other, 1e-7)
    assert not differs.passed and differs.max_rel > 1e-6 and failure == ""


@pytest.mark.parametrize("seed", [0, 1, 5])
def test_symbolic_check_proves_random_robots(seed):
    robot = robot_from_text(random_robot_yaml(seed), f"random{seed}.yaml")
    result = symbolic_check(derive(robot, "kane"), derive(robot, "lagrange"))
    assert result.status == "zero" and result.proven == result.entries


def test_symbolic_check_stays_within_its_term_budget():
    robot = robot_from_text(random_robot_yaml(5), "random5.yaml")
    kane = derive(robot, "kane", tidy=False)
    lagrange = derive(robot, "lagrange", tidy=False)
    result = symbolic_check(kane, lagrange, budget=50)
    assert result.status == "numeric only" and result.terms <= 50 and result.too_large > 0
    assert result.describe() == (f"numeric only (too large for a symbolic check); "
                                 f"{result.proven} of 21 entries proven 0")
    full = symbolic_check(kane, lagrange)
    assert full.status == "zero" and full.terms > 50


def test_numeric_check_on_random_robots(tmp_path, capsys):
    path = tmp_path / "random0.yaml"
    path.write_text(random_robot_yaml(0))
    assert main(["compare", str(path), "--out", str(tmp_path)]) == 0
    figures = json.loads((tmp_path / "compare.json").read_text())
    worst = figures["worst"]
    assert all(worst[q]["max_rel"] <= 1e-12 for q in ("M", "F", "B", "ddq"))


def test_bad_arguments_are_one_line_and_exit_2(tmp_path, monkeypatch, capsys):
    assert main(["compare", str(RR), "--samples", "0", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err == ("anadyn: error: --samples must be a whole number from "
                                       "1 to 1,000,000, got 0\n")
    assert main(["compare", "no/such.yaml"]) == 2
    assert capsys.readouterr().err == "anadyn: error: no/such.yaml: no such file\n"


def test_samples_cover_a_range_around_the_start():
    from anadyn_cli.services.compare import sample_states
    from anadyn_cli.model.info import RobotInfo

    robot = robot_from_text((ROOT / "robots" / "rrt.yaml").read_text(), "rrt.yaml")
    compiled = numeric_model(robot, evaluator="recursive")
    q, dq, tau = sample_states(RobotInfo.from_robot(robot), compiled, 200)
    assert q.shape == dq.shape == (3, 200) and tau.shape == (3, 200)
    assert np.all(np.abs(q[0] - np.pi / 18) <= np.pi) and np.ptp(q[0]) > np.pi
    assert np.all(np.abs(q[2] - 0.25) <= 0.25) and np.ptp(q[2]) > 0.25
    assert len({tuple(column) for column in q.T}) == 200
