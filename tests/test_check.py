"""`anadyn check`: the stability report, its verdicts and its exit codes."""
import json
import re

import numpy as np
import pytest

from anadyn_cli.services import check as stability
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.cli import main

STIFF = "stiffness: stiff (explicit methods are stability-limited)"
NOT_STIFF = "stiffness: not stiff (explicit methods are not stability-limited)"

# file, extra options, stiff?  (fast_spin and the 1 mm link on 1 s of their 5 s: the
# verdict is the same and the full runs cost 60,000 and 35,000 RHS calls)
SCENES = [
    ("robots/rr.yaml", [], True),
    ("configs/stiff_rr_gains1000.yaml", [], True),
    ("configs/stiff_mass_ratio_1e4.yaml", [], True),
    ("robots/rrt.yaml", [], False),
    ("configs/short_link_1mm.yaml", ["--t-end", "1"], False),
    ("configs/fast_spin.yaml", ["--t-end", "1"], False),
    ("configs/near_singular.yaml", [], False),
    ("configs/chain6.yaml", [], False),
    ("configs/long_horizon_1000s.yaml", [], False),
]


def run_check(capsys, tmp_path, path, *options):
    code = main(["check", path, "--out", str(tmp_path), *options])
    captured = capsys.readouterr()
    return code, captured.out.splitlines(), captured.err


@pytest.mark.parametrize("path, options, stiff", SCENES,
                         ids=[s[0].split("/")[-1][:-5] for s in SCENES])
def test_stiff_scenes_are_called_stiff_and_benign_ones_not(capsys, tmp_path, path, options,
                                                           stiff):
    code, out, err = run_check(capsys, tmp_path, path, *options)
    assert code == 0, err
    assert err == ""
    assert (STIFF if stiff else NOT_STIFF) in out
    assert out[-3] == "check: passed"
    energy = "energy drift" if "actuators' work" not in out[0] else "energy balance"
    assert any(line.startswith(f"ok   {energy}: max |T + V") for line in out)
    assert any(line.startswith("ok   mass matrix conditioning: scaled condition number")
               for line in out)
    assert ("warning: stiff: explicit methods (RK45, RK23, DOP853) are stability-limited"
            in "\n".join(out)) == stiff
    summary = json.loads((tmp_path / "check.json").read_text())
    assert summary["stiff"] is stiff and summary["passed"] is True
    assert summary["energy_error"] <= 1e-6
    assert summary["probe"]["stability_limited"] is stiff
    header = (tmp_path / "check.csv").read_text().splitlines()[0]
    assert header == ("t,fastest_decay,fastest_growth,fastest_rate,stiffness_ratio,"
                      "mass_condition,mass_condition_scaled,energy_residual,actuator_work")


def test_rr_report(capsys, tmp_path):
    code, out, _ = run_check(capsys, tmp_path, "robots/rr.yaml")
    assert code == 0
    assert out[0] == ("rr: 15 s, 1501 rows, odeint (LSODA) rtol 1e-10 atol 1e-12, "
                      f"{out[0].split(', ')[3]}, actuators' work integrated with the state")
    assert out[1] == "eigenvalues of the Jacobian at 200 points along the path:"
    summary = json.loads((tmp_path / "check.json").read_text())
    # the chapter's arm: eigenvalues ~ -1300 ... -1700 1/s, time constant below a millisecond
    assert 1000 < summary["fastest_decay"] < 2500
    assert summary["fastest_time_constant"] < 1e-3
    assert summary["decay_times_horizon"] > 1000
    assert summary["mass_condition_scaled"] < 10
    assert summary["actuator_work_final"] > 0


def test_warnings_for_a_near_singular_mass_matrix_and_unstable_modes(capsys, tmp_path):
    code, out, _ = run_check(capsys, tmp_path, "configs/near_singular.yaml")
    assert code == 0
    text = "\n".join(out)
    assert re.search(r"warning: mass matrix near-singular in absolute terms \(condition number "
                     r"2\.\de\+07\) but 1 after diagonal scaling", text)
    assert "warning: unstable modes along the path" in text
    assert "energy: passive, T + V drifts by at most" in text


def test_energy_balance_fails_on_a_loose_tolerance(capsys, tmp_path):
    """A real miss: at rtol 1e-3 the integrator's own error breaks the balance."""
    code, out, err = run_check(capsys, tmp_path, "robots/rr.yaml", "--rtol", "1e-3",
                               "--atol", "1e-5")
    assert code == 1
    assert "check: FAILED (energy balance)" in out
    assert re.fullmatch(r"anadyn: error: robots/rr\.yaml: energy balance \S+ exceeds 1e-06\n",
                        err), err
    assert json.loads((tmp_path / "check.json").read_text())["passed"] is False


def test_conditioning_threshold(capsys, tmp_path):
    code, out, err = run_check(capsys, tmp_path, "robots/rrt.yaml", "--max-condition", "0.5")
    assert code == 1
    assert out[-3] == "check: FAILED (mass matrix conditioning)"
    assert err == ("anadyn: error: robots/rrt.yaml: mass matrix conditioning 1 exceeds "
                   "5e-01\n")


def test_the_balance_catches_a_wrong_actuator_power(monkeypatch):
    """Power taken as tau . dq (forgetting B^T) must break the RR balance: absolute angles
    make B = [[1, -1], [0, 1]], so T12z does work through dq2 - dq1, not dq2."""
    compiled = numeric_model("robots/rr.yaml")
    right = stability.check(compiled, t_end=3.0)
    assert right.passed and right.energy_error < 1e-8

    def wrong(compiled, t, x):
        n = compiled.n
        tau = np.asarray(compiled.efforts(t, x[:n], x[n:]), dtype=float)
        return np.sum(x[n:] * tau, axis=0)

    monkeypatch.setattr(stability.path, "actuator_power", wrong)
    broken = stability.check(compiled, t_end=3.0)
    assert not broken.passed and broken.energy_error > 1e-3


def test_bad_threshold_is_a_usage_error(capsys, tmp_path):
    code, _, err = run_check(capsys, tmp_path, "robots/rr.yaml", "--energy-tol", "-1")
    assert code == 2
    assert err == ("anadyn: error: --energy-tol must be a number greater than 0 and less "
                   "than 1, got -1\n")
