"""The background build of a robot's own code (``anadyn_cli.numeric.background``):
its cost in the next run's timings and JSON, once; no second build while one
runs; a failed build said once and not retried.

The generic kernel serves the cold runs (native code in its default mode:
ANADYN_NATIVE unset here).  Builds run in this process (``generic._fork``
replaced by a call) except in the test of a build in progress, which forks.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import library
from anadyn_cli.numeric import background, build, cache, generic, native

ROOT = Path(__file__).resolve().parent.parent
RR = str(ROOT / "robots/rr.yaml")
pytestmark = pytest.mark.skipif(native.unavailable() is not None or not hasattr(os, "fork"),
                                reason=f"native code: {native.unavailable()}, or no fork")


@pytest.fixture
def cold(tmp_path, monkeypatch):
    """A new cache folder, native code in its default mode, the kernel loaded."""
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("ANADYN_NATIVE", raising=False)
    monkeypatch.delenv("ANADYN_GENERIC", raising=False)
    assert generic.kernel() is not None
    return tmp_path


def run(out: Path, capsys) -> tuple[dict, str, str]:
    """``anadyn simulate rr`` (1 s) into ``out``: (simulate.json, stdout, stderr)."""
    library._announced.clear()
    assert main(["simulate", RR, "--t-end", "1", "--no-plot", "--out", str(out)]) == 0
    printed = capsys.readouterr()
    return json.loads((out / "simulate.json").read_text()), printed.out, printed.err


def record_path(name: str = "rr") -> Path:
    from anadyn_cli import load_robot

    entry = cache.key(load_robot(ROOT / "robots" / f"{name}.yaml").digest, "recursive")
    return cache.directory() / (entry + background.RECORD)


def test_the_next_run_reports_the_build_once(cold, monkeypatch, capsys):
    forks = []
    monkeypatch.setattr(generic, "_fork", lambda work: (forks.append(1), work()))
    first, _, _ = run(cold / "a", capsys)
    assert first["code"] == "generic kernel (the robot's own code is built for the next run)"
    assert "background_build_cpu" not in first["timings"] and len(forks) == 1
    stored = cache.read_record(record_path().parent, record_path().name, "test")
    assert stored["failed"] is None and stored["note"] is None
    assert 0 < stored["cpu_s"] and 0 < stored["wall_s"]
    second, out, err = run(cold / "b", capsys)
    assert second["code"] == "native C (cached)" and err == ""
    assert second["timings"]["background_build_cpu"] == pytest.approx(stored["cpu_s"])
    assert second["timings"]["background_build_wall"] == pytest.approx(stored["wall_s"])
    line = next(s for s in out.splitlines() if s.startswith("time: "))
    assert (f"cache hit, background_build_cpu {stored['cpu_s']:.3f} s, "
            f"background_build_wall {stored['wall_s']:.3f} s" in line)
    assert not record_path().exists()
    third, out, _ = run(cold / "c", capsys)                        # reported once
    assert "background_build_cpu" not in third["timings"] and "background" not in out
    assert len(forks) == 1


def test_no_second_build_while_one_runs(cold, monkeypatch, capsys):
    """The first run forks a build (held here until the test lets it go); a run
    meanwhile is served by the kernel and forks nothing; the run after the build
    reports it."""
    go = cold / "go"

    def own_code(robot, pl):
        for _ in range(600):
            if go.exists():
                return None
            time.sleep(0.05)
        return "never let go"

    forks = []
    real = generic._fork
    monkeypatch.setattr(build, "_own_code", own_code)
    monkeypatch.setattr(generic, "_fork", lambda work: (forks.append(1), real(work)))
    first, _, _ = run(cold / "a", capsys)
    assert first["code"].endswith("is built for the next run)") and len(forks) == 1
    second, _, _ = run(cold / "b", capsys)
    assert second["code"] == "generic kernel (the robot's own code is being built by an earlier run)"
    assert len(forks) == 1 and "background_build_cpu" not in second["timings"]
    go.touch()
    for _ in range(600):
        if record_path().exists():
            break
        time.sleep(0.05)
    time.sleep(0.2)                                   # the build lets go of its lock
    third, _, _ = run(cold / "c", capsys)            # own_code stored nothing: a miss again
    assert third["timings"]["background_build_wall"] > 0
    assert third["code"].endswith("is built for the next run)") and len(forks) == 2


def test_a_failed_build_is_said_once_and_not_retried(cold, monkeypatch, capsys):
    def own_code(robot, pl):
        raise RuntimeError("no space left")

    forks = []
    monkeypatch.setattr(build, "_own_code", own_code)
    monkeypatch.setattr(generic, "_fork", lambda work: (forks.append(1), work()))
    run(cold / "a", capsys)
    assert len(forks) == 1
    second, _, err = run(cold / "b", capsys)
    assert err == (f"anadyn: warning: the background build of rr's own code failed "
                   f"(RuntimeError: no space left); runs use the generic kernel; to try "
                   f"again, remove {record_path()}\n")
    assert second["code"] == ("generic kernel (the robot's own code failed to build before "
                              f"(RuntimeError: no space left); to try again, remove "
                              f"{record_path()})")
    assert "background_build_cpu" in second["timings"]
    third, _, err = run(cold / "c", capsys)
    assert err == "" and "background_build_cpu" not in third["timings"]
    assert len(forks) == 1
    record_path().unlink()                            # removed: tried again
    run(cold / "d", capsys)
    assert len(forks) == 2


def test_c_that_did_not_build_is_said_by_the_next_run(cold, monkeypatch, capsys):
    """The robot's code is stored but its C does not compile (CC is false): the
    next run runs the generated Python and says why, once, and builds nothing."""
    monkeypatch.setattr(generic, "_fork", lambda work: work())
    monkeypatch.setenv("CC", "false")
    run(cold / "a", capsys)
    second, _, err = run(cold / "b", capsys)
    assert second["code"].startswith("generated Python (native build failed before")
    assert err.startswith("anadyn: warning: rr's own code was built in the background "
                          "without its C library: generated Python (the C compiler failed")
    assert "background_build_cpu" in second["timings"]
    third, _, err = run(cold / "c", capsys)
    assert err == "" and third["code"] == second["code"]
