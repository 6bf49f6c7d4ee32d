"""`anadyn inverse ROBOT --motion data.csv`: efforts along a measured motion.

Checked against (a) the same analytic motion given exactly, to the error the
Savitzky-Golay differentiator's known response predicts; Pinocchio's RNEA on
the UR5 (joint order mapped by name) to 1e-12 relative; the differentiator
against scipy.signal.savgol_filter and against polynomials it must reproduce
exactly; (b) every bad input, one line and exit 2; (c) extra columns ignored.
"""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.numeric import measured
from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.services import inverse as service

H = 1e-3                                    # s: 1 kHz
AMPLITUDE = np.array([0.5, 0.4, 0.6, 0.3, 0.5, 0.7])          # rad
FREQUENCY = np.array([0.5, 0.7, 1.0, 0.9, 1.3, 1.1])          # Hz
PHASE = np.array([0.0, 0.3, 0.6, 0.9, 1.2, 1.5])


def sinusoids(t):
    """q = A sin(w t + phi) on each UR5 joint, and its exact rates and accelerations."""
    w = 2 * np.pi * FREQUENCY
    arg = w * t[:, None] + PHASE
    return (AMPLITUDE * np.sin(arg), AMPLITUDE * w * np.cos(arg),
            -AMPLITUDE * w ** 2 * np.sin(arg))


def write_csv(path, header, columns):
    with open(path, "w", newline="") as handle:
        out = csv.writer(handle)
        out.writerow(header)
        for row in zip(*columns):
            out.writerow([v if isinstance(v, str) else repr(float(v)) for v in row])
    return path


def read_csv(path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.fixture(scope="module")
def ur5(request):
    from pathlib import Path

    path = Path(request.config.rootpath) / "robots" / "ur5.urdf"
    return path, numeric_model(path)


def efforts(model, t, q, dq, ddq):
    """tau solving B tau = M ddq - F at the given states (the service's own solve)."""
    dynamics = service.InverseDynamics(model, None)
    return dynamics.solve(*dynamics.demand(t, q, dq, ddq))


def filtered(t, deriv, window=measured.DEFAULT_WINDOW, order=measured.DEFAULT_ORDER):
    """What the differentiator must give for the sinusoids, from the filter's known
    response: (1 + bias(f)) times the exact derivative at the interior samples (the filter is
    symmetric: no lag), the end windows' fits (savgol_coeffs at their position) at the
    first and last window // 2 samples."""
    from scipy.signal import savgol_coeffs

    exact = sinusoids(t)[deriv]
    out = exact * (1 + measured.bias(FREQUENCY, H, window, order, deriv))
    q, N, half = sinusoids(t)[0], len(t), window // 2
    for k in [*range(half), *range(N - half, N)]:
        first = 0 if k < half else N - window
        c = savgol_coeffs(window, order, deriv=deriv, delta=H, pos=k - first, use="dot")
        out[k] = c @ q[first:first + window]
    return out


# -- (a) against exact motion and Pinocchio ---------------------------------------------
def test_positions_only_agree_with_the_exact_motion_to_the_filters_error(ur5, tmp_path):
    path, model = ur5
    t = np.arange(2001) * H
    q, dq, ddq = sinusoids(t)
    names = list(model.coordinates)
    write_csv(tmp_path / "q.csv", ["t", *names], [t, *q.T])
    out = tmp_path / "out"
    assert main(["inverse", str(path), "--motion", str(tmp_path / "q.csv"), "--out", str(out),
                 "--no-roundtrip", "--no-plot"]) == 0
    header, rows = read_csv(out / "inverse.csv")
    tau = rows[:, [header.index(a) for a in model.effort_names]]
    exact = efforts(model, t, q, dq, ddq)
    predicted = efforts(model, t, q, filtered(t, 1), filtered(t, 2))
    scale = np.abs(exact).max()
    # the differentiator is exactly the stated filter (to rounding) ...
    assert np.abs(tau - predicted).max() <= 1e-8 * scale
    # ... so the efforts miss the exact ones by the error its response predicts: about
    # 4e-4 of the largest effort here (1 kHz, 21 samples, degree 3, 0.5-1.3 Hz)
    bound = np.abs(predicted - exact).max()
    assert 1e-6 * scale < bound < 2e-3 * scale
    assert np.abs(tau - exact).max() <= 1.001 * bound + 1e-8 * scale
    summary = json.loads((out / "inverse.json").read_text())
    assert summary["measured"]["differentiated"] == ["dq", "ddq"]
    assert summary["points"] == len(t) and summary["trajectory"] == "measured"


def test_exact_rates_and_accelerations_agree_with_pinocchio(ur5, tmp_path):
    pin = pytest.importorskip("pinocchio")
    path, model = ur5
    t = np.arange(0, 1001) * H
    q, dq, ddq = sinusoids(t)
    names = list(model.coordinates)
    write_csv(tmp_path / "m.csv", ["t", *names, *("d" + n for n in names),
                                   *("dd" + n for n in names)], [t, *q.T, *dq.T, *ddq.T])
    motion = measured.read_motion(tmp_path / "m.csv", names)
    assert motion.given == ("dq", "ddq")
    result = service.inverse(model, roundtrip=False, measured=motion)
    assert np.array_equal(result.t, t) and np.array_equal(result.ddq, ddq)
    pmodel = pin.buildModelFromUrdf(str(path))
    data = pmodel.createData()
    index = [pmodel.joints[pmodel.getJointId(n)].idx_v for n in names]
    actuator = {a: n for n in names for a in model.effort_names if a == "tau_" + n}
    columns = [names.index(actuator[a]) for a in model.effort_names]
    worst = 0.0
    for k in range(0, len(t), 25):
        x = [np.zeros(pmodel.nv) for _ in range(3)]
        for v, values in zip(x, (q[k], dq[k], ddq[k])):
            v[index] = values
        reference = pin.rnea(pmodel, data, *x)[index][columns]
        worst = max(worst, np.abs(result.efforts[k] - reference).max()
                    / np.abs(reference).max())
    assert worst <= 1e-12


def test_round_trip_follows_the_measured_positions(ur5, tmp_path):
    path, model = ur5
    t = np.arange(301) * H
    q = sinusoids(t)[0]
    write_csv(tmp_path / "q.csv", ["t", *model.coordinates], [t, *q.T])
    motion = measured.read_motion(tmp_path / "q.csv", model.coordinates)
    result = service.inverse(model, measured=motion)
    assert result.roundtrip.passed and result.roundtrip.max_error < 1e-7
    # the interpolant between samples is the samples at the samples, with their rates and
    # accelerations (to the rounding of its coefficients, scaled by 1/h and 1/h^2)
    at = motion(t[[0, 7, 300]])
    for got, want in zip(at, (motion.q, motion.dq, motion.ddq)):
        assert np.abs(got - want[[0, 7, 300]]).max() <= 1e-10 * np.abs(want).max()


def test_differentiator_is_savitzky_golay_and_exact_for_its_degree():
    from scipy.signal import savgol_filter

    rng = np.random.default_rng(3)
    t = np.arange(400) * 2e-3
    y = np.stack([np.sin(3 * t), np.exp(-t)], -1)
    fast = measured.Differentiator(21, 3).derivatives(t, y)
    slow = measured.local_fit(t, y, 21, 3)          # the non-uniform path on uniform times
    for d, (a, b) in enumerate(zip(fast, slow), 1):
        want = savgol_filter(y, 21, 3, deriv=d, delta=2e-3, axis=0, mode="interp")
        assert np.abs(a - want).max() <= 1e-12 * np.abs(want).max()
        assert np.abs(b - want).max() <= 1e-7 * np.abs(want).max()
    jittered = np.sort(t + rng.uniform(-0.4, 0.4, len(t)) * 2e-3)
    cubic = 1 - 2 * jittered + 3 * jittered ** 2 - 4 * jittered ** 3
    rate, acceleration = measured.Differentiator(21, 3).derivatives(jittered, cubic)
    assert np.allclose(rate, -2 + 6 * jittered - 12 * jittered ** 2, rtol=0, atol=1e-8)
    assert np.allclose(acceleration, 6 - 24 * jittered, rtol=0, atol=1e-5)


# -- (b) bad input --------------------------------------------------------------------
@pytest.fixture
def rr(repo):
    return str(repo / "robots" / "rr.yaml")


def run_bad(capsys, rr, tmp_path, text, *extra):
    data = tmp_path / "data.csv"
    data.write_text(text)
    out = tmp_path / "out"
    code = main(["inverse", rr, "--motion", str(data), "--out", str(out), "--no-plot",
                 *extra])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()
    return err.strip().replace(str(data), "data.csv")


def samples(count=30, header="t,q1,q2", row=lambda k: f"{k * 0.01},{0.1 * k},{0.2}"):
    return header + "\n" + "".join(row(k) + "\n" for k in range(count))


def with_value(row, column, text):
    """samples() with ``text`` as the value of ``column`` (0: t) in sample ``row``."""
    def values(k):
        fields = [f"{k * 0.01}", "0.1", "0.2"]
        if k == row:
            fields[column] = text
        return ",".join(fields)
    return samples(row=values)


BAD = [
    ("missing t", samples(header="time,q1,q2"),
     "anadyn: error: data.csv:1: no column t: expected t, q1, q2 (the robot's coordinates; "
     "optionally d<coordinate> and dd<coordinate> for each), found time, q1, q2"),
    ("missing coordinate", samples(header="t,q1,theta2"),
     "anadyn: error: data.csv:1: no column q2: expected t, q1, q2 (the robot's coordinates; "
     "optionally d<coordinate> and dd<coordinate> for each), found t, q1, theta2"),
    ("not a number", with_value(4, 1, "abc"),
     "anadyn: error: data.csv:6: column q1: must be a finite number, got 'abc'"),
    ("empty value", with_value(2, 2, ""),
     "anadyn: error: data.csv:4: column q2: must be a finite number, got ''"),
    ("nan", with_value(9, 2, "nan"),
     "anadyn: error: data.csv:11: column q2: must be a finite number, got 'nan'"),
    ("inf", with_value(29, 0, "inf"),
     "anadyn: error: data.csv:31: column t: must be a finite number, got 'inf'"),
    ("repeated time", samples(row=lambda k: f"{min(k, 5) * 0.01},0.1,0.2"),
     "anadyn: error: data.csv:8: column t: times must increase, got 0.05 after 0.05"),
    ("decreasing time", samples(row=lambda k: f"{(k if k != 3 else 1) * 0.01},0.1,0.2"),
     "anadyn: error: data.csv:5: column t: times must increase, got 0.01 after 0.02"),
    ("too few samples", samples(count=20),
     "anadyn: error: data.csv: 20 samples: the differentiator (Savitzky-Golay, 21 samples, "
     "degree 3) needs at least 21"),
    ("some rates", samples(header="t,q1,q2,dq1", row=lambda k: f"{k * 0.01},0.1,0.2,0"),
     "anadyn: error: data.csv: has dq1 but not dq2: give every d<coordinate> column or none"),
    ("short row", samples(row=lambda k: f"{k * 0.01},0.1" + ("" if k == 3 else ",0.2")),
     "anadyn: error: data.csv:5: 2 values, the header has 3 columns"),
    ("twice", samples(header="t,q1,q2,q1", row=lambda k: f"{k * 0.01},0.1,0.2,0.3"),
     "anadyn: error: data.csv:1: column q1 appears 2 times; give it once"),
    ("empty", "\n",
     "anadyn: error: data.csv: is empty: expected a header row (t, q1, q2) and one row of "
     "numbers per sample"),
]


@pytest.mark.parametrize("text, message", [case[1:] for case in BAD],
                         ids=[case[0] for case in BAD])
def test_bad_motion_file(capsys, rr, tmp_path, text, message):
    assert run_bad(capsys, rr, tmp_path, text) == message


def test_bad_motion_options(capsys, rr, tmp_path):
    good = samples()
    assert run_bad(capsys, rr, tmp_path, good, "--smoothing-window", "20") == (
        "anadyn: error: --smoothing-window must be an odd whole number of samples greater "
        "than the order 3, got 20")
    assert run_bad(capsys, rr, tmp_path, good, "--smoothing-order", "1") == (
        "anadyn: error: --smoothing-order must be a whole number from 2 to 10 (accelerations "
        "need degree 2 or more), got 1")
    assert run_bad(capsys, rr, tmp_path, good, "--dt", "0.1") == (
        "anadyn: error: --dt does not apply to a measured motion: its efforts are computed "
        "at its samples")
    assert main(["inverse", rr, "--motion", str(tmp_path / "none.csv"), "--no-plot"]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {tmp_path / 'none.csv'}: no such file (expected a CSV with columns "
        "t, q1, q2)\n")
    assert main(["inverse", rr, "--smoothing-window", "31", "--no-plot"]) == 2
    assert capsys.readouterr().err == ("anadyn: error: --smoothing-window and "
                                       "--smoothing-order apply to --motion data\n")


def test_urdf_without_motion_says_how_to_give_one(capsys, ur5, tmp_path):
    path, _ = ur5
    assert main(["inverse", str(path), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}: a URDF has no trajectory: give the motion as measured "
        "data (--motion data.csv with columns t, shoulder_pan_joint, shoulder_lift_joint, "
        "elbow_joint, ...) or write a robot file with 'anadyn import' and add a "
        "trajectory: section\n")
    assert not (tmp_path / "out").exists()


# -- (c) extra columns ----------------------------------------------------------------
def test_extra_columns_are_ignored(repo, tmp_path):
    t = np.arange(101) * 0.01
    q1, q2 = 0.3 * np.sin(t), 0.2 * np.cos(2 * t)
    plain = write_csv(tmp_path / "plain.csv", ["t", "q1", "q2"], [t, q1, q2])
    notes = ["note"] * len(t)
    extra = write_csv(tmp_path / "extra.csv", ["T01z", "t", "note", "q2", "q1", "ddx"],
                      [t * 7, t, notes, q2, q1, notes])
    rr = repo / "robots" / "rr.yaml"
    for name in ("plain", "extra"):
        assert main(["inverse", str(rr), "--motion", str(tmp_path / f"{name}.csv"),
                     "--out", str(tmp_path / name), "--no-plot", "--no-roundtrip"]) == 0
    assert plain.exists() and extra.exists()
    assert ((tmp_path / "plain" / "inverse.csv").read_text()
            == (tmp_path / "extra" / "inverse.csv").read_text())


def test_inverse_csv_reads_back_as_a_measured_motion(repo, tmp_path):
    """inverse.csv has every column --motion reads (rates and accelerations given):
    fed back, it gives the same efforts at the same times."""
    rr = str(repo / "robots" / "rr.yaml")
    assert main(["inverse", rr, "--dt", "0.05", "--out", str(tmp_path / "file"), "--no-plot",
                 "--no-roundtrip"]) == 0
    assert main(["inverse", rr, "--motion", str(tmp_path / "file" / "inverse.csv"),
                 "--out", str(tmp_path / "again"), "--no-plot", "--no-roundtrip"]) == 0
    header, first = read_csv(tmp_path / "file" / "inverse.csv")
    again_header, again = read_csv(tmp_path / "again" / "inverse.csv")
    assert again_header == header and len(first) == 301
    assert np.array_equal(again, first)
    summary = json.loads((tmp_path / "again" / "inverse.json").read_text())
    assert summary["measured"]["given"] == ["dq", "ddq"]
