"""`anadyn sweep`: one derivation, many samples, any executor, same numbers.

The references are independent of the sweep: separate `anadyn simulate` and
`anadyn inverse` runs on robot files edited by hand (here: by text), and the
metrics recomputed from their CSV files with the definitions written out
again below.
"""
import csv
import json
import math
import os
import re
import signal
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.studies import sweep

ROOT = Path(__file__).resolve().parents[1]
RR = ROOT / "robots" / "rr.yaml"
RRT = ROOT / "robots" / "rrt.yaml"
PAYLOAD = ROOT / "configs" / "rrt_payload.yaml"


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("ANADYN_SCHEDULER", raising=False)
    monkeypatch.setenv("ANADYN_PROGRESS", "off")


def rows(folder: Path) -> list[dict]:
    with open(folder / "sweep.csv", newline="") as stream:
        return list(csv.DictReader(stream))


def run_sweep(capsys, *argv) -> tuple[int, str, str]:
    code = main(["sweep", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def edited(tmp_path: Path, source: Path, name: str, value: float, section: str = "parameters"
           ) -> Path:
    """``source`` with ``name: ...`` in its one-line ``section`` mapping set to ``value``."""
    text = source.read_text()
    line = next(l for l in text.splitlines() if l.startswith(f"{section}:")
                or l.strip().startswith(f"{section}:"))
    new, count = re.subn(rf"\b{name}: [^,}}]+", f"{name}: {value!r}", line)
    assert count == 1, (name, line)
    path = tmp_path / f"{source.stem}_{name}_{value!r}.yaml"
    path.write_text(text.replace(line, new))
    return path


def simulate_csv(capsys, tmp_path: Path, robot: Path) -> dict[str, np.ndarray]:
    out = tmp_path / f"sim_{robot.stem}"
    assert main(["simulate", str(robot), "--no-plot", "--out", str(out)]) == 0
    capsys.readouterr()
    data = np.genfromtxt(out / "simulate.csv", delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def cycloidal(t, start, end, duration):
    """The chapter's cycloidal motion, held at its end after ``duration``."""
    s = np.minimum(t, duration)
    return start + (end - start) / duration * (s - duration / (2 * np.pi)
                                               * np.sin(2 * np.pi * s / duration))


def settling(t, q, band=0.02):
    """First time after which every coordinate stays within band x its largest
    deviation from its final value (written out again, independently)."""
    last = 0
    for column in q:
        deviation = np.abs(column - column[-1])
        if deviation.max() <= 1e-9:
            continue
        outside = np.nonzero(deviation > band * deviation.max())[0]
        if len(outside):
            last = max(last, outside[-1] + 1)
    return t[min(last, len(t) - 1)]


# ----------------------------------------------------------------------------
# against separate runs on edited files
# ----------------------------------------------------------------------------
def test_mass_sweep_reproduces_simulate_on_edited_files(tmp_path, capsys):
    masses = [0.25, 1.0, 2.5]
    code, out, err = run_sweep(capsys, RR, "--vary", "m2=" + ",".join(map(str, masses)),
                               "--no-plot", "--jobs", "1", "--out", tmp_path / "sweep")
    assert code == 0, err
    assert out.startswith("rr: simulate for 3 samples (grid) of m2 (parameter)\n")
    found = rows(tmp_path / "sweep")
    assert [float(r["m2"]) for r in found] == masses
    for row, mass in zip(found, masses):
        assert row["status"] == "ok" and row["reason"] == ""
        run = simulate_csv(capsys, tmp_path, edited(tmp_path, RR, "m2", mass))
        t = run["t"]
        for name in ("q1", "q2", "dq1", "dq2"):
            assert float(row[f"final_{name}"]) == pytest.approx(run[name][-1], abs=1e-8)
        for effort in ("T01z", "T12z"):
            tau = run[effort]
            assert float(row[f"peak_{effort}"]) == pytest.approx(np.abs(tau).max(), rel=1e-8)
            rms = math.sqrt(np.sum((tau[1:] ** 2 + tau[:-1] ** 2) / 2 * np.diff(t)) / t[-1])
            assert float(row[f"rms_{effort}"]) == pytest.approx(rms, rel=1e-7)
        start, end = np.array([-np.pi / 18, np.pi / 6]), np.array([np.pi / 6, np.pi / 3])
        reference = cycloidal(t[:, None], start, end, 15.0)
        error = np.abs(np.column_stack([run["q1"], run["q2"]]) - reference)
        assert float(row["tracking_error"]) == pytest.approx(error.max(), rel=1e-7)
        assert float(row["final_error"]) == pytest.approx(error[-1].max(), rel=1e-6)
        assert float(row["settling_time"]) == pytest.approx(
            settling(t, [run["q1"], run["q2"]]), abs=1e-12)
    # the heavier the second bar, the lower the first settles (the chapter's 0.515 at 1 kg)
    finals = [float(r["final_q1"]) for r in found]
    assert finals == sorted(finals, reverse=True) and finals[1] == pytest.approx(0.5154, 1e-3)


FOLLOWER = """\
name: follower
parameters: {L1: 1.0, L2: 1.0, m1: 1.0, m2: 1.0, g: 9.81, I2: m2*L2**2/12, reach: L1 + L2}
gravity: [0, -g, 0]
coordinates:
  q1: {initial: -pi/18*m2}
  q2: {initial: pi/6, rate: 0.1*reach}
bodies:
  - name: bar1
    joint: {type: revolute, axis: [0, 0, 1], displacement: q1}
    mass: m1
    com: [L1/2, 0, 0]
    inertia: {iyy: m1*L1**2/12, izz: m1*L1**2/12}
  - name: bar2
    parent: bar1
    joint: {type: revolute, axis: [0, 0, 1], origin: [L1, 0, 0], displacement: q2 - q1}
    mass: m2
    com: [L2/2, 0, 0]
    inertia: {iyy: I2, izz: I2}
actuators:
  T01z: {joint: bar1}
  T12z: {joint: bar2}
controller:
  gains: {b01: 450, g01: 300, b12: 200*m2, g12: 2*b12 - 100, q1f: pi/6, q2f: pi/3}
  laws:
    T01z: -b01*dq1 - g01*(q1 - q1f) + 0.5*g*L1*m1*cos(q1) + g*L1*m2*cos(q1)
    T12z: -b12*dq2 - g12*(q2 - q2f) + 0.5*g*L2*m2*cos(q2)
trajectory: {kind: cycloidal, duration: 3*L2, to: {q1: pi/6*m2, q2: pi/3}}
simulation: {t_end: 4, output_step: 0.01}
"""


@pytest.mark.parametrize("name, values", [("m2", (0.5, 1.5)), ("L2", (0.8, 1.3))])
def test_what_the_file_computes_from_a_varied_name_follows_it(tmp_path, capsys, name, values):
    """Derived parameters (I2, reach), gains (b12, and g12 from b12), initial values and
    rates, and the trajectory (its end and duration) are computed from the sample's
    value, exactly as a file edited to that value gives them."""
    robot = tmp_path / "follower.yaml"
    robot.write_text(FOLLOWER)
    code, out, err = run_sweep(capsys, robot, "--vary", f"{name}=" + ",".join(map(str, values)),
                               "--no-plot", "--out", tmp_path / "sweep")
    assert code == 0, err
    following = {"m2": "computed from them: parameters I2; gains b12, g12; initial q1; "
                       "trajectory to.q1",
                 "L2": "computed from them: parameters I2, reach; initial q2; trajectory "
                       "duration"}[name]
    assert out.splitlines()[0] == (f"follower: simulate for 2 samples (grid) of {name} "
                                   f"(parameter); {following}")
    for row, value in zip(rows(tmp_path / "sweep"), values):
        assert row["status"] == "ok", row["reason"]
        run = simulate_csv(capsys, tmp_path, edited(tmp_path, robot, name, value))
        for q in ("q1", "q2", "dq1", "dq2"):
            assert float(row[f"final_{q}"]) == pytest.approx(run[q][-1], abs=1e-8)
        for effort in ("T01z", "T12z"):
            assert float(row[f"peak_{effort}"]) == pytest.approx(np.abs(run[effort]).max(),
                                                                 rel=1e-8)
        m2 = value if name == "m2" else 1.0
        L2 = value if name == "L2" else 1.0
        reference = cycloidal(run["t"][:, None], np.array([-np.pi / 18 * m2, np.pi / 6]),
                              np.array([np.pi / 6 * m2, np.pi / 3]), 3 * L2)
        error = np.abs(np.column_stack([run["q1"], run["q2"]]) - reference)
        assert float(row["tracking_error"]) == pytest.approx(error.max(), rel=1e-7)


def test_inverse_sweep_reproduces_inverse_on_edited_files(tmp_path, capsys):
    code, _, err = run_sweep(capsys, RRT, "--vary", "m3=20,60", "--command", "inverse",
                             "--no-plot", "--out", tmp_path / "sweep")
    assert code == 0, err
    for row, mass in zip(rows(tmp_path / "sweep"), (20, 60)):
        out = tmp_path / f"inverse_{mass}"
        assert main(["inverse", str(edited(tmp_path, RRT, "m3", mass)), "--no-plot",
                     "--out", str(out)]) == 0
        capsys.readouterr()
        data = np.genfromtxt(out / "inverse.csv", delimiter=",", names=True)
        figures = json.loads((out / "inverse.json").read_text())
        for effort in ("T01x", "T12y", "F23z"):
            assert float(row[f"peak_{effort}"]) == pytest.approx(np.abs(data[effort]).max(),
                                                                 rel=1e-9)
        # the round trip's error is the integrator's own (2e-9 to 7e-9 rad here, changing
        # with the last bits of the efforts): the same size, both far within tolerance
        assert 1e-11 < float(row["tracking_error"]) < 1e-7
        assert 1e-11 < figures["roundtrip"]["max_error"] < 1e-7


# ----------------------------------------------------------------------------
# executors and seeds
# ----------------------------------------------------------------------------
def test_local_processes_give_the_same_file_as_one_process(tmp_path, capsys):
    args = [RR, "--vary", "m2=0.5:2:6", "--vary", "b01=300,450", "--no-plot"]
    assert run_sweep(capsys, *args, "--jobs", "1", "--out", tmp_path / "one")[0] == 0
    code, out, _ = run_sweep(capsys, *args, "--jobs", "2", "--out", tmp_path / "two")
    assert code == 0 and "on 2 local processes" in out
    assert (tmp_path / "one" / "sweep.csv").read_bytes() == \
        (tmp_path / "two" / "sweep.csv").read_bytes()
    found = rows(tmp_path / "one")
    assert [(float(r["m2"]), float(r["b01"])) for r in found] == \
        [(m, b) for m in np.linspace(0.5, 2, 6) for b in (300.0, 450.0)]


def test_monte_carlo_is_reproducible_from_its_seed(tmp_path, capsys):
    args = [RRT, "--vary", "m3=normal(40,4)", "--vary", "g23=uniform(40,60)",
            "--samples", "12", "--no-plot", "--metrics", "final,calls"]
    for folder, seed in (("a", 7), ("b", 7), ("c", 8)):
        code, _, err = run_sweep(capsys, *args, "--seed", seed, "--out", tmp_path / folder)
        assert code == 0, err
    assert (tmp_path / "a" / "sweep.csv").read_bytes() == (tmp_path / "b" / "sweep.csv").read_bytes()
    first, other = rows(tmp_path / "a"), rows(tmp_path / "c")
    rng = np.random.default_rng(7)          # the documented draws: one generator, in order
    assert [float(r["m3"]) for r in first] == list(rng.normal(40, 4, 12))
    assert [float(r["g23"]) for r in first] == list(rng.uniform(40, 60, 12))
    assert [r["m3"] for r in first] != [r["m3"] for r in other]
    figures = json.loads((tmp_path / "a" / "sweep.json").read_text())
    assert figures["design"] == "monte-carlo" and figures["seed"] == 7
    assert figures["samples"] == 12 and figures["ok"] == 12


def test_grid_times_draws_uses_the_same_draws_at_every_point():
    specs = [sweep.parse_vary("b01=100,200"), sweep.parse_vary("m2=uniform(1,2)")]
    chosen = sweep.design(specs, samples=3, seed=1)
    assert chosen.kind == "grid x monte-carlo" and chosen.count == 6
    assert list(chosen.values[:, 0]) == [100, 100, 100, 200, 200, 200]
    assert list(chosen.values[:3, 1]) == list(chosen.values[3:, 1])


def test_dask_local_cluster_agrees_with_the_local_run(tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    args = [RR, "--vary", "m2=0.5:2:7", "--no-plot"]
    assert run_sweep(capsys, *args, "--jobs", "1", "--out", tmp_path / "local")[0] == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        code, out, err = run_sweep(capsys, *args, "--scheduler", cluster.scheduler_address,
                                   "--out", tmp_path / "dask")
    assert code == 0, err
    assert f"on Dask at {cluster.scheduler_address} (2 workers)" in out
    assert (tmp_path / "local" / "sweep.csv").read_bytes() == \
        (tmp_path / "dask" / "sweep.csv").read_bytes()
    figures = json.loads((tmp_path / "dask" / "sweep.json").read_text())
    assert figures["executor"]["kind"] == "dask" and figures["ok"] == 7


def test_the_scheduler_can_come_from_the_environment(tmp_path, capsys, monkeypatch):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        monkeypatch.setenv("ANADYN_SCHEDULER", cluster.scheduler_address)
        code, out, err = run_sweep(capsys, RR, "--vary", "m2=1,2", "--no-plot", "--t-end", "1",
                                   "--out", tmp_path)
    assert code == 0, err
    assert f"on Dask at {cluster.scheduler_address} (1 workers)" in out


def test_without_dask_a_scheduler_says_what_to_install(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "distributed", None)   # import fails
    code, _, err = run_sweep(capsys, RR, "--vary", "m2=1,2", "--scheduler",
                             "tcp://127.0.0.1:8786", "--out", tmp_path / "out")
    assert code == 2 and not (tmp_path / "out").exists()
    assert err == ("anadyn: error: --scheduler needs Dask distributed, which is not "
                   "installed: pip install 'anadyn[distributed]'\n")


def test_a_repeated_sweep_reuses_the_derivation(tmp_path, capsys):
    args = [RR, "--vary", "m2=1,2", "--no-plot", "--t-end", "1", "-j", "1"]
    first = run_sweep(capsys, *args, "--out", tmp_path / "a")[1]
    second = run_sweep(capsys, *args, "--out", tmp_path / "b")[1]
    assert "cache miss, derive" in first and "cache hit" in second
    assert (tmp_path / "a" / "sweep.csv").read_bytes() == (tmp_path / "b" / "sweep.csv").read_bytes()


@pytest.mark.slow
def test_a_worker_lost_mid_run_loses_no_sample(tmp_path):
    """Two worker processes on loopback; one is killed once the first pieces are back.
    Dask reruns its pieces elsewhere, and every sample equals the local run's."""
    distributed = pytest.importorskip("distributed")
    plan = sweep.plan(RR, ["m2=0.5:2:48"])
    local = sweep.run(plan, jobs=1)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster, set_as_default=False) as client:
        pids = list(client.run(os.getpid).values())
        killed = []

        def kill_one(done, failed, total):
            if not killed and 0 < done < total // 2:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(done)

        remote = sweep.run(plan, scheduler=client, on_progress=kill_one)
    assert killed, "the worker was not killed mid-run"
    assert [r["status"] for r in remote.rows] == ["ok"] * 48
    assert sweep.csv_text(remote) == sweep.csv_text(local)


# ----------------------------------------------------------------------------
# statuses, limits, plots
# ----------------------------------------------------------------------------
def test_samples_that_make_no_robot_or_fail_are_rows_not_errors(tmp_path, capsys):
    code, out, err = run_sweep(capsys, RR, "--vary", "L2=1,0", "--vary", "m2=1,-1",
                               "--no-plot", "--t-end", "1", "--out", tmp_path)
    assert code == 0, err
    found = {(r["L2"], r["m2"]): r for r in rows(tmp_path)}
    assert found["1.0", "1.0"]["status"] == "ok"
    assert found["1.0", "-1.0"]["status"] == "invalid"
    assert found["1.0", "-1.0"]["reason"] == "body bar2: mass -1 kg is not positive"
    assert found["0.0", "1.0"]["status"] == "failed"
    assert found["0.0", "1.0"]["reason"].startswith("singular mass matrix at t = 0 s")
    assert found["0.0", "1.0"]["final_q1"] == ""
    assert "4 samples: 1 ok, 1 failed, 2 invalid\n" in out
    figures = json.loads((tmp_path / "sweep.json").read_text())
    assert (figures["ok"], figures["failed"], figures["invalid"]) == (1, 1, 2)


def test_payload_capacity_under_effort_limits(tmp_path, capsys):
    code, out, err = run_sweep(capsys, PAYLOAD, "--vary", "m_tip=2:20:10", "--command",
                               "inverse", "--no-roundtrip", "--max", "peak_T12y=600",
                               "--max", "peak_F23z=500", "--out", tmp_path)
    assert code == 0, err
    found = rows(tmp_path)
    within = [r["within_limits"] == "1" for r in found]
    for r in found:
        assert (r["within_limits"] == "1") == (float(r["peak_T12y"]) <= 600
                                               and float(r["peak_F23z"]) <= 500)
    last = within.index(False) - 1
    assert within == [True] * (last + 1) + [False] * (len(found) - last - 1)
    assert (f"m_tip: within the limits from 2 to {float(found[last]['m_tip']):g}; "
            f"{float(found[last + 1]['m_tip']):g} misses") in out
    for r in found:      # the slide holds link 3 and the payload at rest at q2 = pi/3
        static = (40 + float(r["m_tip"])) * 9.81 * math.sin(math.pi / 3)
        assert float(r["peak_F23z"]) == pytest.approx(static, rel=1e-9)
    figures = json.loads((tmp_path / "sweep.json").read_text())
    assert figures["capacity"]["contiguous_to"] == float(found[last]["m_tip"])
    assert (tmp_path / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_two_names_draw_a_heat_map_and_monte_carlo_histograms(tmp_path, capsys):
    for folder, vary in (("map", ["m2=1,2", "b01=300,450"]), ("mc", ["m2=normal(1,0.1)"])):
        args = [a for v in vary for a in ("--vary", v)]
        code, _, err = run_sweep(capsys, RR, *args, "--samples", "4", "--t-end", "1",
                                 "--out", tmp_path / folder) if folder == "mc" else \
            run_sweep(capsys, RR, *args, "--t-end", "1", "--out", tmp_path / folder)
        assert code == 0, err
        assert (tmp_path / folder / "sweep.png").stat().st_size > 10_000


@pytest.mark.slow
def test_check_sweep_reports_the_energy_balance(tmp_path, capsys):
    code, _, err = run_sweep(capsys, RRT, "--vary", "m3=40,80", "--command", "check",
                             "--no-plot", "--out", tmp_path)
    assert code == 0, err
    for row in rows(tmp_path):
        assert row["status"] == "ok" and row["check_passed"] == "1"
        assert float(row["energy_error"]) < 1e-8 and row["stiff"] == "0"


# ----------------------------------------------------------------------------
# bad input: one line, exit 2, nothing written
# ----------------------------------------------------------------------------
BAD = [
    (["--vary", "m2"], "--vary 'm2': expected NAME=SPEC, e.g. m2=0.5:2:7 (grid), m2=1,2,5 "
                       "(list), m2=normal(1,0.05) or m2=uniform(0.8,1.2)"),
    (["--vary", "m2=1:2"], "--vary m2=1:2: a grid is FROM:TO:COUNT, e.g. 10:60:11 (11 values "
                           "from 10 to 60)"),
    (["--vary", "m2=1:2:x"], "--vary m2=1:2:x: the grid's COUNT must be a whole number from "
                             "1 to 1,000,000, got 'x'"),
    (["--vary", "m2=1:2:1"], "--vary m2=1:2:1: a grid of 1 value from 1 to 2; give 2 or more "
                             "values, or one value as a list"),
    (["--vary", "m2=1,,2"], "--vary m2=1,,2: empty value in the list; write numbers separated "
                            "by commas, e.g. m2=0.5:2:7 (grid), m2=1,2,5 (list), "
                            "m2=normal(1,0.05) or m2=uniform(0.8,1.2)"),
    (["--vary", "m2=normal(1)"], "--vary m2=normal(1): normal takes two numbers, "
                                 "normal(MEAN,SD)"),
    (["--vary", "m2=normal(1,-0.1)"], "--vary m2=normal(1,-0.1): the standard deviation must "
                                      "be positive, got -0.1"),
    (["--vary", "m2=uniform(2,1)"], "--vary m2=uniform(2,1): uniform(LOW,HIGH) needs LOW < "
                                    "HIGH, got 2 and 1"),
    (["--vary", "m2=gauss(1,0.1)"], "--vary m2=gauss(1,0.1): unknown distribution 'gauss'; "
                                    "use normal(MEAN,SD) or uniform(LOW,HIGH)"),
    (["--vary", "m2=__import__('os')"], "--vary m2=__import__('os'): unknown distribution "
                                        "'__import__'; use normal(MEAN,SD) or "
                                        "uniform(LOW,HIGH)"),
    (["--vary", "m2=1e999"], "--vary m2=1e999: number too large (the largest allowed is "
                             "about 1.8e308)"),
    (["--vary", "m2=mass"], "--vary m2=mass: unknown name 'mass'; allowed here: pi"),
    (["--vary", "mass2=1,2"], "--vary mass2: no parameter or gain of that name in ROBOT (did "
                              "you mean 'm2'?); parameters: L1, L2, m1, m2, g; gains: b01, "
                              "g01, b12, g12, q1f, q2f"),
    (["--vary", "m2=1,2", "--vary", "m2=3"], "--vary m2: given twice; vary each name once"),
    (["--vary", "m2=1,2", "--samples", "5"], "--samples is the number of draws from a "
                                             "distribution (normal(...), uniform(...)); grids "
                                             "and lists run every value once"),
    (["--vary", "m2=1:2:1001", "--vary", "b01=1:2:1001"], "1,002,001 samples (1001 x 1001); "
                                                          "at most 1,000,000"),
    (["--vary", "m2=1,2", "--command", "compare"], "--command: 'compare' cannot be swept; "
                                                   "choose one of simulate, inverse, check"),
    (["--vary", "m2=1,2", "--metrics", "peaks"], "--metrics: unknown metric 'peaks'; choose "
                                                 "from effort, tracking, settling, final, "
                                                 "energy, check, limits, calls"),
    (["--vary", "m2=1,2", "--metrics", "check"], "--metrics: check does not apply to --command "
                                                 "simulate (it takes effort, tracking, "
                                                 "settling, final, energy, limits, calls)"),
    (["--vary", "m2=1,2", "--metrics", "limits"], "--metrics limits: the robot file gives no "
                                                  "joint limits (limits: {lower, upper, "
                                                  "velocity, effort} of a joint); give bounds "
                                                  "with --max/--min"),
    (["--vary", "m2=1,2", "--max", "peak_T99=3"], "--max peak_T99: not a metric of this sweep; "
                                                  "metrics: peak_T01z, peak_T12z, rms_T01z, "
                                                  "rms_T12z, tracking_error, final_error, "
                                                  "settling_time, final_q1, final_q2, "
                                                  "final_dq1, final_dq2, rhs_calls, steps"),
    (["--vary", "m2=1,2", "--max", "peak_T01z"], "--max 'peak_T01z': expected METRIC=BOUND, "
                                                 "e.g. --max peak_T01z=50"),
    (["--vary", "m2=1,2", "--jobs", "0"], "--jobs must be a whole number of at least 1, got 0"),
    (["--vary", "m2=1,2", "--dt", "-1"], "--dt must be a positive number, got -1"),
    (["--vary", "m2=1,2", "--command", "inverse", "--rtol", "1e-6"],
     "--rtol applies to --command simulate or check, not inverse (which runs on the "
     "trajectory's own time grid, --dt)"),
    (["--vary", "m2=1,2", "--scheduler", "bogus"],
     "--scheduler bogus: cannot reach a Dask scheduler (missing port number in address "
     "'bogus')"),
]


@pytest.mark.parametrize("argv, message", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_sweeps_get_one_line_and_exit_2(tmp_path, capsys, argv, message):
    if "--scheduler" in argv:
        pytest.importorskip("distributed")
    out = tmp_path / "out"
    code, stdout, err = run_sweep(capsys, RR, *argv, "--out", out)
    assert code == 2
    assert err == f"anadyn: error: {message.replace('ROBOT', str(RR))}\n"
    assert not out.exists()


def test_a_varied_name_the_run_settings_depend_on_is_refused(tmp_path, capsys):
    robot = tmp_path / "settings.yaml"
    robot.write_text(RR.read_text().replace("simulation: {t_end: 15,", "simulation: {t_end: 15*m2,"))
    code, _, err = run_sweep(capsys, robot, "--vary", "m2=1,2", "--out", tmp_path / "out")
    assert code == 2
    assert err == (f"anadyn: error: --vary m2: simulation.t_end in {robot} depends on it; a "
                   "sweep keeps the run's settings fixed (give them as numbers, or on the "
                   "command line)\n")


# ----------------------------------------------------------------------------
# anadyn batch --scheduler
# ----------------------------------------------------------------------------
BATCH = """\
jobs:
  - command: simulate
    robot: RR
    options: [--no-plot, --t-end, 2]
    expect:
      equal: {success: true, rows: 201}
  - command: inverse
    robot: RR
    name: impossible
    options: [--no-plot, --roundtrip-tol, 1.0e-15]
    must_fail: 1
"""


@pytest.mark.slow
def test_batch_on_a_dask_cluster_gives_the_local_results(tmp_path, capsys):
    """No shared folder: the robot file travels with each job, the results come back."""
    distributed = pytest.importorskip("distributed")
    config = tmp_path / "batch.yaml"
    config.write_text(BATCH.replace("RR", str(RR)))
    assert main(["batch", str(config), "--jobs", "2", "--out", str(tmp_path / "local")]) == 0
    capsys.readouterr()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        code = main(["batch", str(config), "--scheduler", cluster.scheduler_address,
                     "--out", str(tmp_path / "dask")])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "batch " + str(config) + ": 2 jobs, 2 ok, 0 failed" in out
    local = json.loads((tmp_path / "local" / "summary.json").read_text())
    remote = json.loads((tmp_path / "dask" / "summary.json").read_text())
    for a, b in zip(local["jobs"], remote["jobs"]):
        assert (a["status"], a["exit_code"], a["figures"]) == (b["status"], b["exit_code"],
                                                               b["figures"])
    for folder in ("local", "dask"):
        results = tmp_path / folder / "simulate" / "rr"
        assert {p.name for p in results.iterdir()} == {"simulate.csv", "simulate.json",
                                                        "stdout.txt", "stderr.txt"}
    # equal, not identical: a later run may use the natively compiled equations that the
    # first one's cache miss started building (numeric.native), with other last bits
    local_csv, dask_csv = (np.genfromtxt(tmp_path / f / "simulate" / "rr" / "simulate.csv",
                                         delimiter=",", skip_header=1) for f in ("local", "dask"))
    assert local_csv.shape == dask_csv.shape == (201, 7)
    assert np.allclose(local_csv, dask_csv, rtol=1e-9, atol=1e-9)
    stderr = (tmp_path / "dask" / "inverse" / "impossible" / "stderr.txt").read_text()
    assert stderr.startswith(f"anadyn: error: {RR}: round trip")     # the file's own path


def _square_or_fail(state, piece):
    if piece == 3:
        raise ValueError("piece 3 always fails")
    return state + piece * piece


def _offset(payload):
    return payload


@pytest.mark.parametrize("where", ["here", "processes", "dask"])
def test_a_piece_that_fails_for_good_comes_back_as_its_exception(where):
    """The other pieces' results stand, whatever ran them (Dask retries it first)."""
    from anadyn_cli.studies import executors

    work = executors.Work(_offset, _square_or_fail, 100, label="anadyn-test")
    pieces = list(range(6))
    if where == "dask":
        distributed = pytest.importorskip("distributed")
        with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                      dashboard_address=None) as cluster:
            ran = executors.run(work, pieces, scheduler=cluster.scheduler_address)
    else:
        ran = executors.run(work, pieces, jobs=1 if where == "here" else 2)
    assert [r for i, r in enumerate(ran.results) if i != 3] == [100, 101, 104, 116, 125]
    assert isinstance(ran.results[3], ValueError) and str(ran.results[3]) == "piece 3 always fails"


@pytest.mark.parametrize("argv, message", [
    (["--settle-band", "1.5"], "--settle-band must be a number greater than 0 and less than 1, "
                               "got 1.5"),
    (["--command", "inverse", "--dt", "20"], "--dt 20 s is longer than the trajectory's "
                                             "duration 15 s"),
    (["--command", "check", "--method", "RK45"], "--method applies to --command simulate; "
                                                  "check integrates with odeint (LSODA), as "
                                                  "anadyn check does"),
    (["--no-roundtrip"], "--no-roundtrip, --roundtrip-tol and --roundtrip-segment apply to "
                         "--command inverse"),
    (["--command", "inverse", "--no-roundtrip", "--metrics", "tracking"],
     "--metrics tracking: inverse's tracking error is the round trip's; drop --no-roundtrip"),
])
def test_options_that_do_not_fit_the_command_are_refused(tmp_path, capsys, argv, message):
    code, _, err = run_sweep(capsys, RR, "--vary", "m2=1,2", *argv, "--out", tmp_path / "out")
    assert (code, err) == (2, f"anadyn: error: {message}\n")
    assert not (tmp_path / "out").exists()


def test_a_robot_without_a_trajectory_has_no_tracking_columns(tmp_path, capsys):
    robot = tmp_path / "free.yaml"
    robot.write_text(re.sub(r"\ntrajectory:.*\n", "\n", RR.read_text()))
    code, _, err = run_sweep(capsys, robot, "--vary", "m2=1,2", "--no-plot", "--t-end", "1",
                             "--out", tmp_path / "out")
    assert code == 0, err
    header = (tmp_path / "out" / "sweep.csv").read_text().splitlines()[0]
    assert "tracking_error" not in header and "settling_time" in header
    code, _, err = run_sweep(capsys, robot, "--vary", "m2=1,2", "--metrics", "tracking",
                             "--out", tmp_path / "out2")
    assert (code, err) == (2, "anadyn: error: --metrics tracking: the robot file has no "
                              "trajectory to track (the tracking error is measured against "
                              "it)\n")


def test_the_files_own_joint_limits_judge_every_sample(tmp_path, capsys):
    """A file with an effort limit on the slide: samples whose slide force passes it are
    not within limits, with the limits service's own words; --max adds to it."""
    robot = tmp_path / "limited.yaml"
    robot.write_text(PAYLOAD.read_text().replace(
        "joint: {type: prismatic, axis: [0, 0, 1], origin: [0, 0, L2]}",
        "joint: {type: prismatic, axis: [0, 0, 1], origin: [0, 0, L2], limits: {effort: 500}}"))
    code, out, err = run_sweep(capsys, robot, "--vary", "m_tip=18,19", "--command", "inverse",
                               "--no-roundtrip", "--out", tmp_path / "out")
    assert code == 0, err
    first, second = rows(tmp_path / "out")
    assert (first["limits_passed"], first["within_limits"], first["limit_miss"]) == ("0", "1", "")
    assert (second["limits_passed"], second["within_limits"]) == ("1", "0")
    assert second["limit_miss"].startswith("file limit F23z: effort beyond its limit +-500 N")
    assert "limits the file's joint limits: 1 of 2 samples within" in out
    robot.write_text(robot.read_text().replace("limits: {effort: 500}",
                                               "limits: {effort: 5*m3}"))
    code, _, err = run_sweep(capsys, robot, "--vary", "m3=40,50", "--out", tmp_path / "o2")
    assert code == 2 and err == (
        f"anadyn: error: --vary m3: the limits of body link3's joint (effort) in {robot} "
        "depend on it; a sweep checks the file's limits at their values (give them as "
        "numbers, or as --max/--min bounds)\n")
