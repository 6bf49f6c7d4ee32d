"""`anadyn accuracy` (work-precision study) and `simulate --estimate-error`."""
import csv
import json
import math
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.services import accuracy
from anadyn_cli.services import simulate
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.numeric.integrators import state_error
from anadyn_cli.numeric.settings import output_grid
from anadyn_cli.cli import main

COLUMNS = ["method", "ran", "rtol", "atol", "status", "max_error", "final_error", "wall_s",
           "rhs_calls", "jacobian_calls", "steps", "reference", "note"]


def read_rows(folder):
    with open(folder / "accuracy.csv", newline="") as stream:
        return list(csv.DictReader(stream))


# ----------------------------------------------------------------------------
# the norm and the budget
# ----------------------------------------------------------------------------
def test_error_is_absolute_for_small_states_and_relative_for_large_ones():
    ref = np.array([[0.1, 100.0], [0.2, -200.0], [0.3, 50.0]])
    x = ref.copy()
    x[1, 0] += 1e-6            # small state: absolute error 1e-6
    x[2, 1] += 2e-3            # large state (max |x| = 200): relative 1e-5
    assert state_error(x, ref) == (pytest.approx(1e-5), pytest.approx(1e-5))
    x[2, 1] = ref[2, 1]
    assert state_error(x, ref) == (pytest.approx(1e-6), 0.0)


def test_a_run_over_budget_stops_there():
    compiled = numeric_model("robots/rr.yaml")
    grid = output_grid(15.0, 0.01)
    solution, _ = accuracy.run(compiled.problem(), compiled.initial_state(), grid, "RK45",
                               1e-3, 1e-5, budget=2_000)
    over = solution.over_budget
    assert not solution.success
    assert over.calls == 2_000 and 0 < over.t < 1.0       # stiff: 2,000 calls go < 1 s
    solution, _ = accuracy.run(compiled.problem(), compiled.initial_state(), grid, "Radau",
                               1e-3, 1e-5, budget=2_000)
    assert solution.over_budget is None and solution.success and solution.rhs_calls < 2_000


# ----------------------------------------------------------------------------
# the command
# ----------------------------------------------------------------------------
def test_rrt_every_method(capsys, tmp_path):
    """The non-stiff arm: every method runs, each against a reference of another family."""
    code = main(["accuracy", "robots/rrt.yaml", "--tolerances", "1e-4,1e-8", "--repeats", "1",
                 "--no-plot", "--out", str(tmp_path)])
    out = capsys.readouterr().out.splitlines()
    assert code == 0
    assert out[0] == ("rrt: 15 s, error over 1501 rows, atol = rtol * 0.01, time = min of 1 "
                      "runs, budget 20000 RHS calls per run")
    assert re.fullmatch(r"reference A: DOP853 rtol 1e-13 atol 1e-15: \d+ RHS calls, 0 Jacobian "
                        r"calls, \d+ steps, .*", out[1])
    assert out[2].startswith("reference B: LSODA rtol 1e-13 atol 1e-15: ")
    estimate = re.fullmatch(r"reference error estimate \|A - B\|: (\S+) \(errors near or below "
                            r"it are not resolved\)", out[3])
    assert estimate and float(estimate.group(1)) < 1e-11
    assert (" error <=  fastest setting             time   auto (rank among the methods "
            "reaching it, odeint aside)") in out
    rows = read_rows(tmp_path)
    assert list(rows[0]) == COLUMNS
    assert [(r["method"], float(r["rtol"])) for r in rows] == [
        (m, tol) for m in ("auto", "odeint", "RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
        for tol in (1e-4, 1e-8)]
    for r in rows:
        assert r["status"] == "ok"
        assert accuracy.family(r["reference"].split()[0]) != accuracy.family(r["method"])
        assert float(r["max_error"]) <= 30 * float(r["rtol"])
        assert float(r["final_error"]) <= float(r["max_error"])
        assert float(r["wall_s"]) > 0 and int(r["rhs_calls"]) > 0
    assert [r["ran"] for r in rows[:2]] == ["odeint", "odeint"]
    assert {r["reference"] for r in rows if r["method"] == "DOP853"} == {"LSODA rtol 1e-13"}
    summary = json.loads((tmp_path / "accuracy.json").read_text())
    assert [r["method"] for r in summary["references"]] == ["DOP853", "LSODA"]
    assert summary["reference_error"] < 1e-11
    assert summary["levels"][0]["level"] == 1e-3 and summary["levels"][0]["auto_rank"] >= 1


def test_rr_stiff_budget_and_plot(capsys, tmp_path):
    """The stiff arm: explicit methods hit the call budget and the rest of the method is
    skipped, which the table and the CSV say."""
    code = main(["accuracy", "robots/rr.yaml", "--methods", "auto,RK45,Radau",
                 "--tolerances", "1e-4,1e-7", "--repeats", "1", "--t-end", "5",
                 "--max-calls", "10000", "--out", str(tmp_path)])
    out = capsys.readouterr().out.splitlines()
    assert code == 0
    over = [line for line in out if line.startswith("RK45      1e-04 over budget")]
    assert len(over) == 1 and "stopped at 10000 RHS calls, t = " in over[0]
    assert "RK45      1e-07    skipped  over budget at rtol 1e-04" in out
    rows = read_rows(tmp_path)
    assert [r["status"] for r in rows] == ["ok", "ok", "over budget", "skipped", "ok", "ok"]
    assert rows[2]["rhs_calls"] == "10000" and rows[2]["max_error"] == ""
    for r in rows:
        if r["method"] == "auto":
            assert float(r["max_error"]) <= 10 * float(r["rtol"])
    png = (tmp_path / "accuracy.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


def test_unknown_method_and_bad_tolerance(capsys):
    assert main(["accuracy", "robots/rr.yaml", "--methods", "auto,Euler"]) == 2
    assert capsys.readouterr().err == (
        "anadyn: error: --methods: unknown method 'Euler'; choose from auto, odeint, RK45, "
        "RK23, DOP853, Radau, BDF, LSODA\n")
    assert main(["accuracy", "robots/rr.yaml", "--tolerances", "1e-3,tight"]) == 2
    assert capsys.readouterr().err == "anadyn: error: --tolerances: 'tight' is not a number\n"


# ----------------------------------------------------------------------------
# every run knows its error
# ----------------------------------------------------------------------------
def true_error(compiled, result):
    refs, _ = accuracy.references(compiled, result.x[0], result.t, count=1, exclude=("auto",),
                                  candidates=(("DOP853", 1e-11), ("Radau", 1e-11)))
    return state_error(result.x, refs[0].x)[0]


@pytest.mark.parametrize("path, rtol, worse_than", [
    ("robots/rr.yaml", 1e-6, 1),
    # full horizons where every method's global error outgrows its tolerance (~t^2 on a
    # conservative fast oscillation); the README quotes these factors
    ("configs/fast_spin.yaml", 1e-6, 1000),
    ("configs/short_link_1mm.yaml", 1e-6, 1000),
    ("configs/near_singular.yaml", 1e-6, 10),
])
def test_estimate_error_matches_the_true_error(path, rtol, worse_than):
    compiled = numeric_model(path)
    result = simulate.simulate(compiled, rtol=rtol, atol=rtol * 1e-2, estimate_error=True)
    estimate = result.estimated_error
    true = true_error(compiled, result)
    assert true > worse_than * rtol
    assert estimate == pytest.approx(true, rel=0.05)


def test_simulate_prints_and_stores_the_estimate(capsys, tmp_path):
    code = main(["simulate", "robots/rr.yaml", "--rtol", "1e-6", "--atol", "1e-8",
                 "--estimate-error", "--no-plot", "--out", str(tmp_path)])
    out = capsys.readouterr().out.splitlines()
    assert code == 0
    line = next(line for line in out if line.startswith("time: "))
    found = re.fullmatch(r"time: .*estimate \d\.\d{3} s.*; total \d+\.\d{3} s; "
                         r"estimated error (\S+)", line)
    assert found, line
    stored = json.loads((tmp_path / "simulate.json").read_text())["estimated_error"]
    assert f"{stored:.2e}" == found.group(1)
    assert 1e-6 < stored < 3e-6                # the accuracy table's 1.84e-6 for auto at 1e-6
    code = main(["simulate", "robots/rr.yaml", "--no-plot", "--out", str(tmp_path)])
    assert "estimated error" not in capsys.readouterr().out
    assert "estimated_error" not in json.loads((tmp_path / "simulate.json").read_text())


def test_batch_can_demand_a_bound_on_the_estimate(capsys, tmp_path):
    robot = Path("robots/rr.yaml").resolve()
    (tmp_path / "bound.yaml").write_text(textwrap.dedent(f"""\
        jobs:
          - command: simulate
            robot: {robot}
            name: loose-enough
            options: [--no-plot, --estimate-error, --rtol, 1.0e-6, --atol, 1.0e-8]
            expect:
              max: {{estimated_error: 1.0e-5}}
          - command: simulate
            robot: {robot}
            name: too-strict
            options: [--no-plot, --estimate-error, --rtol, 1.0e-6, --atol, 1.0e-8]
            expect:
              max: {{estimated_error: 1.0e-7}}
        """))
    code = main(["batch", str(tmp_path / "bound.yaml"), "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    assert code == 1
    assert "too-strict" in captured.err and "loose-enough" not in captured.err
    assert "estimated_error" in captured.out
    assert math.isfinite(json.loads(
        (tmp_path / "out" / "simulate" / "loose-enough" / "simulate.json").read_text()
    )["estimated_error"])
