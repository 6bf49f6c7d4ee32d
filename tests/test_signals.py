"""Every signal is honoured, every wait is bounded (issue 22, item 3).

SIGINT and SIGTERM, to the main process or to its process group, at startup,
while deriving, while solving and once a sweep's workers or a batch's jobs
run: the command ends within seconds with exit 130 or 143, one line on
stderr, no process of its own left, and no result set half replaced.  A
scheduler that accepts and never answers, and a law with a singularity, end
with one line too.  The CLI runs in a subprocess (``python -m anadyn_cli``),
in a session of its own so that its whole group can be signalled.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
import weakref
from pathlib import Path

import pytest

from anadyn_cli import progress
from anadyn_cli.cli import main
from anadyn_cli.studies import executors

ROOT = Path(__file__).resolve().parents[1]
RR = ROOT / "robots" / "rr.yaml"
LINE = {signal.SIGINT: "anadyn: interrupted; results written before the interruption are "
                       "complete, none is half-written\n",
        signal.SIGTERM: "anadyn: stopped by SIGTERM; results written before the interruption "
                        "are complete, none is half-written\n"}
PROMISE = 5.0          # s from the signal to the exit (the promise is 2 s; a loaded machine)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """A private derivation cache, warm for rr (so that runs reach their solve at once)."""
    folder = tmp_path_factory.mktemp("cache")
    subprocess.run([sys.executable, "-m", "anadyn_cli", "simulate", str(RR), "--no-plot",
                    "--t-end", "0.1", "--out", str(folder / "warm")], cwd=ROOT, check=True,
                   env={**os.environ, "ANADYN_CACHE_DIR": str(folder)}, capture_output=True)
    return folder


class Run:
    """``python -m anadyn_cli ARGV`` in a session of its own."""

    def __init__(self, argv: list, cache: Path, **env):
        self.child = subprocess.Popen(
            [sys.executable, "-m", "anadyn_cli", *map(str, argv)], cwd=ROOT,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
            env={**os.environ, "ANADYN_CACHE_DIR": str(cache), "ANADYN_PROGRESS": "off",
                 **env})
        self.seen: set[int] = set()

    def descendants(self) -> set[int]:
        """Living (not zombie) processes below the CLI's, by their parent links."""
        parents = {}
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
                except OSError:
                    continue
                if fields[0] != "Z":
                    parents[int(entry)] = int(fields[1])
        found, frontier = set(), {self.child.pid}
        while frontier:
            frontier = {pid for pid, parent in parents.items() if parent in frontier} - found
            found |= frontier
        return found

    def wait_for(self, ready, timeout: float = 60.0) -> None:
        end = time.monotonic() + timeout
        while not ready():
            assert self.child.poll() is None, self.child.communicate()
            assert time.monotonic() < end, "never got there"
            time.sleep(0.002)

    def workers(self, count: int) -> bool:
        found = self.descendants()
        self.seen |= found
        return len(found) >= count

    def catching(self) -> bool:
        """anadyn's handlers are in place (SIGTERM caught: Python alone does not)."""
        try:
            status = Path(f"/proc/{self.child.pid}/status").read_text()
        except OSError:
            return False
        caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
        return bool(int(caught.split()[1], 16) & (1 << (signal.SIGTERM - 1)))

    def stop(self, signum: int, group: bool = False) -> tuple[int, str, str, float]:
        """Send ``signum``; (exit code, stdout, stderr, seconds to the exit)."""
        self.seen |= self.descendants()
        start = time.monotonic()
        (os.killpg if group else os.kill)(self.child.pid, signum)
        try:
            out, err = self.child.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(self.child.pid, signal.SIGKILL)
            out, err = self.child.communicate()
        return self.child.returncode, out, err, time.monotonic() - start

    def survivors(self) -> set[int]:
        end = time.monotonic() + 2.0            # reaped by init once their parent is gone
        while time.monotonic() < end:
            alive = self.seen & {pid for pid in self.seen if _alive(pid)}
            if not alive:
                return set()
            time.sleep(0.05)
        return alive


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def assert_stopped(run: Run, signum: int, group: bool = False):
    code, out, err, seconds = run.stop(signum, group)
    assert (code, err) == (128 + signum, LINE[signum]), (code, err)
    assert seconds < PROMISE, seconds
    assert not run.survivors()
    return out


def whole_or_absent(folder: Path, *names: str) -> None:
    """A result set is all there or not at all (no CSV without its JSON)."""
    present = [(folder / name).exists() for name in names]
    assert all(present) or not any(present), dict(zip(names, present))


# -- simulate --------------------------------------------------------------------------
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_at_startup(cache, tmp_path, signum):
    """As soon as anadyn's first line has run, while the command line's modules load."""
    run = Run(["simulate", RR, "--no-plot", "--out", tmp_path], cache)
    run.wait_for(run.catching)
    assert_stopped(run, signum)
    assert not tmp_path.exists() or not any(tmp_path.iterdir())


@pytest.mark.parametrize("signum, group", [(signal.SIGINT, False), (signal.SIGTERM, True)])
def test_a_signal_while_deriving(tmp_path, signum, group):
    run = Run(["simulate", ROOT / "configs" / "chain6.yaml", "--formulation", "lagrange",
               "--no-plot", "--out", tmp_path], tmp_path / "cold-cache")
    time.sleep(1.5)                             # chain6's Lagrange equations take 3-7 s
    assert_stopped(run, signum, group)
    whole_or_absent(tmp_path, "simulate.csv", "simulate.json")


@pytest.mark.parametrize("signum, group", [(signal.SIGINT, True), (signal.SIGTERM, False)])
def test_a_signal_while_solving(cache, tmp_path, signum, group):
    (tmp_path / "out").mkdir()
    for name in ("simulate.csv", "simulate.json"):       # an earlier run's set
        (tmp_path / "out" / name).write_text("earlier\n")
    run = Run(["simulate", RR, "--no-plot", "--method", "RK45", "--rtol", "1e-12",
               "--t-end", "1000", "--dt", "1", "--out", tmp_path / "out"], cache)
    time.sleep(2.5)                             # loaded; RK45 on the stiff arm takes minutes
    assert_stopped(run, signum, group)
    assert {p.name: p.read_text() for p in (tmp_path / "out").iterdir()} == \
        {"simulate.csv": "earlier\n", "simulate.json": "earlier\n"}


# -- sweep: its worker processes -------------------------------------------------------
@pytest.mark.parametrize("signum, group", [(signal.SIGINT, False), (signal.SIGTERM, False),
                                           (signal.SIGINT, True), (signal.SIGTERM, True)])
def test_a_signal_once_a_sweeps_workers_run(cache, tmp_path, signum, group):
    run = Run(["sweep", RR, "--vary", "m2=0.5:2:200", "--jobs", "2", "--no-plot", "--method",
               "RK45", "--rtol", "1e-12", "--out", tmp_path], cache)   # pieces of minutes
    run.wait_for(lambda: run.workers(2))
    time.sleep(0.3)
    out = assert_stopped(run, signum, group)
    assert out.startswith("rr: simulate for 200 samples")
    whole_or_absent(tmp_path, "sweep.csv", "sweep.json")


# -- batch: its jobs and their workers -------------------------------------------------
BATCH = """\
jobs:
  - command: sweep
    robot: RR
    options: [--vary, "m2=0.5:2:200", --jobs, 2, --no-plot, --method, RK45, --rtol, 1.0e-12]
  - command: simulate
    robot: RR
    options: [--no-plot, --method, RK45, --rtol, 1.0e-12, --t-end, 1000, --dt, 1]
"""


@pytest.mark.parametrize("signum, group", [(signal.SIGINT, False), (signal.SIGTERM, False),
                                           (signal.SIGTERM, True)])
def test_a_signal_once_a_batchs_jobs_run(cache, tmp_path, signum, group):
    config = tmp_path / "batch.yaml"
    config.write_text(BATCH.replace("RR", str(RR)))
    out = tmp_path / "out"
    run = Run(["batch", config, "--jobs", "2", "--out", out], cache)
    run.wait_for(lambda: run.workers(4))        # 2 jobs and the sweep's 2 workers
    time.sleep(0.3)
    assert_stopped(run, signum, group)
    assert sorted(p.name for p in out.iterdir()) == ["simulate", "sweep"]   # no summary
    for folder in (out / "sweep" / "rr", out / "simulate" / "rr"):
        assert not [p.name for p in folder.iterdir()]    # nothing of a job that was stopped


# -- in this process --------------------------------------------------------------------
def test_a_signal_inside_uninterrupted_waits_for_its_end():
    restore = progress.stop_on_signals()
    done = []
    try:
        with pytest.raises(progress.Interrupted) as stopped:
            with progress.uninterrupted():
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.05)                # the handler has run by now
                done.append("whole")
        assert done == ["whole"] and stopped.value.signum == signal.SIGTERM
    finally:
        restore()


def test_a_signal_where_python_can_only_print_the_exception_still_stops(
        monkeypatch, capsys, tmp_path):
    """A signal handled inside a weakref callback (where the import machinery was when
    a CI run sent SIGINT at startup): Python prints the exception and goes on; anadyn
    keeps it, prints nothing, and stops the command before its first task."""
    from anadyn_cli.commands import common

    class Thing:
        pass

    def signalled_in_a_callback(value):
        thing = Thing()
        ref = weakref.ref(thing, lambda _: signal.raise_signal(signal.SIGINT))
        del thing                              # the callback runs, the handler inside it
        assert ref() is None
        return value

    monkeypatch.setattr(common.OutOpt, "callback", signalled_in_a_callback)
    assert main(["simulate", str(RR), "--no-plot", "--out", str(tmp_path / "out")]) == 130
    assert capsys.readouterr().err == LINE[signal.SIGINT]
    assert not (tmp_path / "out").exists()


def test_ctrl_c_before_the_command_parses_its_options_is_130(monkeypatch, capsys):
    """Typer and click turn a KeyboardInterrupt into 'Aborted!' and exit 1; anadyn's
    Interrupted passes through them."""
    from anadyn_cli.commands import common

    def interrupted(value):
        raise progress.Interrupted(signal.SIGINT)

    monkeypatch.setattr(common.OutOpt, "callback", interrupted)
    assert main(["simulate", str(RR), "--out", "x"]) == 130
    assert capsys.readouterr().err == LINE[signal.SIGINT]


# -- every wait is bounded --------------------------------------------------------------
@pytest.fixture
def silent_scheduler():
    """A loopback port that accepts connections and never answers."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    server.settimeout(0.1)
    accepted, stop = [], threading.Event()

    def serve():
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])
            except OSError:
                pass

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}", accepted
    stop.set()
    thread.join(5)
    for connection in accepted:
        connection.close()
    server.close()


@pytest.mark.parametrize("command", ["sweep", "batch"])
def test_a_scheduler_that_never_answers_is_one_line_and_exit_2(
        silent_scheduler, tmp_path, capsys, monkeypatch, command):
    pytest.importorskip("distributed")
    address, accepted = silent_scheduler
    monkeypatch.setattr(executors.cluster, "ANSWER_TIMEOUT", 1.0)
    config = tmp_path / "batch.yaml"
    config.write_text(f"jobs:\n  - {{command: simulate, robot: {RR}}}\n")
    argv = ({"sweep": ["sweep", str(RR), "--vary", "m2=1,2"],
             "batch": ["batch", str(config)]}[command]
            + ["--scheduler", address, "--out", str(tmp_path / "out")])
    start = time.monotonic()
    assert main(argv) == 2
    assert time.monotonic() - start < 30
    assert accepted                              # it did connect: the handshake hung
    assert capsys.readouterr().err.endswith(
        f"anadyn: error: --scheduler {address}: cannot reach a Dask scheduler (no answer "
        "within 1 s)\n")
    assert not (tmp_path / "out").exists()


def test_a_law_with_a_singularity_stops_with_exit_3(tmp_path, capsys):
    """LSODA steps on towards t = 0.5 without end unless stopped (the stall limit)."""
    robot = tmp_path / "singular.yaml"
    text = RR.read_text()
    law = "    T12z: -b12*dq2 - g12*(q2 - q2f) + 0.5*g*L2*m2*cos(q2)\n"
    assert law in text
    robot.write_text(text.replace(law, "    T12z: 1/(t - 0.5)\n"))
    out = tmp_path / "out"
    assert main(["simulate", str(robot), "--method", "LSODA", "--no-plot", "--no-cache",
                 "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert err.startswith(f"anadyn: error: {robot}: the step size collapsed (a singularity "
                          "of the equations or of a law?): 20000 RHS calls took t less than "
                          "1e-09 of the horizon further at t = 0.5 s, state (")
    assert err.endswith(f"; 50 rows before it in {out / 'simulate.partial.csv'}\n")
    assert err.count("\n") == 1
