"""CLI manners: --version, -h, completion, any-case choices, umask, CSV numbers,
tables for any horizon, peak efforts, progress, and the Ctrl-C line."""
from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli import __version__
from anadyn_cli.cli import main
from anadyn_cli.output.csv_table import csv_text
from anadyn_cli import progress

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ROOT / "robots"
INTERRUPTED = ("anadyn: interrupted; results written before the interruption are complete, "
               "none is half-written\n")


@pytest.mark.parametrize("flag", ["--version", "-V"])
def test_version(capsys, flag):
    assert main([flag]) == 0
    assert capsys.readouterr().out == f"anadyn {__version__}\n"


def test_short_help_everywhere(capsys):
    assert main(["-h"]) == 0
    top = capsys.readouterr().out
    assert top.startswith("Usage: anadyn [OPTIONS] COMMAND") and "-h, --help" in top
    assert "--install-completion" in top and "--show-completion" in top
    for command in ("simulate", "show", "animate", "equations"):
        assert main([command, "-h"]) == 0
        assert capsys.readouterr().out.startswith(f"Usage: anadyn {command} [OPTIONS]")


def test_choices_in_any_case(tmp_path, capsys):
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--formulation", "LAGRANGE", "--method",
                 "rk45", "--t-end", "0.2", "--no-plot", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "\nmethod: RK45\n" in out
    assert main(["equations", str(ROBOTS / "rr.yaml"), "--formulation", "Kane", "--format",
                 "TEXT"]) == 0
    assert capsys.readouterr().out.startswith("# kane equations")
    assert main(["accuracy", str(ROBOTS / "rrt.yaml"), "--methods", "AUTO,radau",
                 "--tolerances", "1e-4", "--repeats", "1", "--t-end", "0.5", "--no-plot",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "\nauto " in out and "\nRadau " in out


def test_unknown_method_still_lists_the_choices(tmp_path, capsys):
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--method", "Euler",
                 "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == ("anadyn: error: unknown method 'Euler'; choose one of "
                                       "auto, odeint, RK45, RK23, DOP853, Radau, BDF, LSODA\n")


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o027, 0o640), (0o002, 0o664)])
def test_files_follow_the_umask(tmp_path, umask, mode):
    """Results (and plots) get 0666 & ~umask, like any new file; run in a child
    process, since the umask belongs to the process."""
    code = (f"import os, sys\nos.umask({umask})\nfrom anadyn_cli.cli import main\n"
            f"sys.exit(main(['simulate', r'{ROBOTS / 'rr.yaml'}', '--t-end', '0.1', "
            f"'--out', sys.argv[1]]))")
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True,
                          text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    modes = {p.name: p.stat().st_mode & 0o777 for p in out.iterdir()}
    assert modes == {"simulate.csv": mode, "simulate.json": mode, "simulate.png": mode}


def test_csv_numbers_are_shortest_round_trip_and_never_negative_zero():
    values = np.array([0.08, -0.0, 0.1 + 0.2, 1e-300, -2.5e17, 1 / 3, 0.0])
    text = csv_text(["t", "x"], [np.arange(len(values)) * 0.01, values])
    lines = text.splitlines()
    assert lines[0] == "t,x"
    assert [line.split(",")[1] for line in lines[1:]] == [
        "0.08", "0.0", "0.30000000000000004", "1e-300", "-2.5e+17", "0.3333333333333333", "0.0"]
    assert lines[4].split(",")[0] == "0.03"
    back = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    assert np.array_equal(back[:, 1], values + 0.0)            # exact round trip
    assert "-0.0" not in text


def test_simulate_table_at_sensible_times_with_units(tmp_path, capsys):
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--t-end", "0.5", "--no-plot",
                 "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == ("       t (s)      q1 (rad)   dq1 (rad/s)      q2 (rad)   dq2 (rad/s)")
    times = [line.split()[0] for line in lines[1:12]]
    assert times == ["0", "0.05", "0.1", "0.15", "0.2", "0.25", "0.3", "0.35", "0.4", "0.45",
                     "0.5"]
    assert lines[12].startswith("method: ")


def test_table_rows_for_long_and_odd_horizons():
    from anadyn_cli.output.tables import grid_rows, table_times

    assert table_times(1000) == [0.0, 100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0,
                                 900.0, 1000.0]
    assert table_times(7.3)[-3:] == [6.5, 7.0, 7.3]
    assert grid_rows(100001, 0.01)[:3] == [0, 10000, 20000]
    assert grid_rows(67, 0.03) == [0, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60, 65, 66]
    assert grid_rows(1, 0.01) == [0]


def test_inverse_prints_peak_efforts(tmp_path, capsys):
    assert main(["inverse", str(ROBOTS / "rrt.yaml"), "--no-plot", "--no-roundtrip",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "\n    T01x   +4.1683 N·m      3.54 " in out       # the sizing table's rows
    assert "\n    F23z    +339.828 N        15 " in out


def test_peak_against_a_limit():
    from types import SimpleNamespace

    from anadyn_cli.services import inverse

    result = SimpleNamespace(
        robot=SimpleNamespace(actuators=[SimpleNamespace(name="T1", unit="N*m",
                                                         effort_limit=20.0)]),
        efforts=np.array([[1.0], [-25.0], [3.0]]), t=np.array([0.0, 0.5, 1.0]),
        rates=np.array([[0.0], [2.0], [-3.0]]), wrench=None)
    table = inverse.sizing_table(result).splitlines()
    assert table[1].split() == ["T1", "-25", "N·m", "0.5", "17.7482", "N·m", "3", "rad/s",
                                "50", "125%", "of", "20", "EXCEEDED"]


# -- progress ---------------------------------------------------------------------------
class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_mode(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.delenv("ANADYN_PROGRESS", raising=False)
    assert progress.choose_mode(Terminal()) == "live"
    assert progress.choose_mode(io.StringIO()) == "plain"
    monkeypatch.setenv("CI", "true")
    assert progress.choose_mode(Terminal()) == "plain"
    monkeypatch.setenv("ANADYN_PROGRESS", "off")
    assert progress.choose_mode(Terminal()) == "off"


def test_plain_progress_names_long_steps_only(monkeypatch):
    monkeypatch.setattr(progress, "PLAIN_DELAY", 0.2)
    monkeypatch.setattr(progress, "TICK", 0.02)
    stream = io.StringIO()
    with progress.session(stream, "plain"):
        with progress.task("quick"):
            pass
        with progress.task("deriving kane equations of chain6", total=3) as step:
            step.advance(detail="M")
            time.sleep(0.5)
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2 and "quick" not in stream.getvalue()
    assert lines[0].startswith("anadyn: deriving kane equations of chain6 ... (1/3, M, ")
    assert lines[1].startswith("anadyn: deriving kane equations of chain6: done in 0.")


def test_live_progress_draws_with_rich_and_erases(monkeypatch):
    monkeypatch.setattr(progress, "LIVE_DELAY", 0.0)
    monkeypatch.setattr(progress, "TICK", 0.02)
    screen = Terminal()
    with progress.session(screen, "live"):
        with progress.task("integrating chain6") as step:
            step.note("t = 3 s")
            time.sleep(0.5)
    shown = screen.getvalue()
    assert "integrating chain6" in shown and "t = 3 s" in shown and "0:00:00" in shown


def test_no_progress_outside_the_command_line(capsys):
    with progress.task("anything") as step:
        step.advance()
    assert capsys.readouterr() == ("", "")


# -- Ctrl-C ------------------------------------------------------------------------------
def test_ctrl_c_in_a_command_is_one_line_and_130(monkeypatch, capsys):
    from anadyn_cli.services import simulate

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(simulate, "simulate", interrupted)
    assert main(["simulate", str(ROBOTS / "rr.yaml"), "--no-cache"]) == 130
    assert capsys.readouterr().err == INTERRUPTED


def test_ctrl_c_on_a_real_run(tmp_path):
    """SIGINT to a running ``python -m anadyn_cli``: the line, exit 130, no temporary
    files left behind."""
    env = {**os.environ, "ANADYN_PROGRESS": "off"}
    child = subprocess.Popen([sys.executable, "-m", "anadyn_cli", "accuracy",
                              str(ROBOTS / "rr.yaml"), "--out", str(tmp_path), "--no-cache"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                             env=env)
    time.sleep(3.0)
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=60)
    assert child.returncode == 130 and err == INTERRUPTED
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
