"""A run that comes while the robot's own code is still being built (issue 25):
served by the generic kernel from what the first run stored (``generic.RECORD``),
without reading the robot again, with the first run's numbers; a damaged record
is a warning and the robot is read as before."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from anadyn_cli import model as model_package
from anadyn_cli.cli import main
from anadyn_cli.numeric import generic, native

ROOT = Path(__file__).resolve().parent.parent
ROBOT = str(ROOT / "configs/chain6.yaml")
pytestmark = pytest.mark.skipif(native.unavailable() is not None,
                                reason=f"native code: {native.unavailable()}")


@pytest.fixture
def builds(tmp_path, monkeypatch):
    """A new cache folder; background builds are kept here, not run (as if still
    running): the list of their jobs."""
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("ANADYN_NATIVE", raising=False)
    monkeypatch.delenv("ANADYN_GENERIC", raising=False)
    jobs = []
    monkeypatch.setattr(generic, "_fork", jobs.append)
    return jobs


def simulate(out: Path) -> dict:
    assert main(["simulate", ROBOT, "--t-end", "0.5", "--no-plot", "--out", str(out)]) == 0
    return json.loads((out / "simulate.json").read_text())


def test_a_second_run_reads_no_robot_and_gives_the_first_runs_bytes(tmp_path, monkeypatch,
                                                                       builds):
    first = simulate(tmp_path / "first")
    assert first["code"].startswith("generic kernel") and len(builds) == 1

    def no_reading(*args, **kwargs):
        raise AssertionError("the second run read the robot")
    with monkeypatch.context() as patch:
        patch.setattr(model_package, "robot_from_text", no_reading, raising=False)
        second = simulate(tmp_path / "second")
    assert second["code"].startswith("generic kernel")
    assert ((tmp_path / "second/simulate.csv").read_bytes()
            == (tmp_path / "first/simulate.csv").read_bytes())
    assert len(builds) == 2                    # the first's build "ended": a new one started
    builds[1]()                                # it reads the robot, builds and stores its code
    assert simulate(tmp_path / "third")["code"].startswith("native C (cached")


def test_a_damaged_record_is_said_and_the_robot_read(tmp_path, capsys, builds):
    simulate(tmp_path / "first")
    cache = tmp_path / "cache"
    (record,) = cache.glob("*" + generic.RECORD)
    record.write_bytes(record.read_bytes()[:-5])
    capsys.readouterr()
    assert simulate(tmp_path / "second")["code"].startswith("generic kernel")
    err = capsys.readouterr().err
    assert f"first-run record {record} is damaged" in err
    assert ((tmp_path / "second/simulate.csv").read_bytes()
            == (tmp_path / "first/simulate.csv").read_bytes())
