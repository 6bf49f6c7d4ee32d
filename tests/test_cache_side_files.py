"""The recursive path's cache entry and its side file (``cache.store``'s texts).

The entry KEY.json holds what every warm run uses (robot info, tables, the light
source, the C's signature, which names its library); the whole generated Python
and C go to KEY.texts, read only when a scalar function or a build needs them.
Every test has its own cache folder; the first run compiles the library now
(ANADYN_NATIVE=wait) without the generic kernel, so that every later run is a
hit on the robot's own code and gives the first run's bytes.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import library
from anadyn_cli.numeric import cache, native
from anadyn_cli.numeric.build import numeric_model

ROOT = Path(__file__).resolve().parent.parent
RRT, RR, UR5 = (ROOT / "robots" / name for name in ("rrt.yaml", "rr.yaml", "ur5.urdf"))

pytestmark = pytest.mark.skipif(native.unavailable() is not None,
                                reason="no C compiler or Python headers")


@pytest.fixture
def folder(tmp_path, monkeypatch) -> Path:
    """The cache folder."""
    place = tmp_path / "cache"
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(place))
    monkeypatch.setenv("ANADYN_GENERIC", "0")
    monkeypatch.setenv("ANADYN_NATIVE", "wait")
    library._announced.clear()
    return place


@pytest.fixture
def reads(monkeypatch) -> list[str]:
    """The names of the side files read (``cache.read_private``), in order."""
    found: list[str] = []
    real = cache.read_private

    def counted(path):
        if Path(path).name.endswith(cache.TEXTS):
            found.append(Path(path).name)
        return real(path)
    monkeypatch.setattr(cache, "read_private", counted)
    return found


def simulate(capsys, robot: Path, out: Path, *options: str, err: str | None = "") -> str:
    """`anadyn simulate` (exit 0, ``err`` on stderr unless None); its `time:` line."""
    code = main(["simulate", str(robot), "--t-end", "0.5", "--no-plot", "--out", str(out),
                 *options])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert err is None or captured.err == err
    return re.search(r"^time: (.*)$", captured.out, re.M)[1]


def csv(out: Path) -> bytes:
    return (out / "simulate.csv").read_bytes()


def entry_files(folder: Path) -> tuple[Path, Path]:
    """(KEY.json, KEY.texts) of the one recursive entry in ``folder``."""
    (side,) = folder.glob("*" + cache.TEXTS)
    return side.with_suffix(".json"), side


@pytest.mark.parametrize("robot", [RRT, UR5], ids=["rrt", "ur5 urdf"])
def test_a_warm_run_reads_no_side_file_and_gives_the_cold_bytes(folder, reads, tmp_path, capsys,
                                                                  monkeypatch, robot):
    said = "" if robot.suffix == ".yaml" else None        # the URDF's joint limits: said
    assert "cache miss" in simulate(capsys, robot, tmp_path / "cold", err=said)
    entry_path, side = entry_files(folder)
    entry = json.loads(cache.unseal(entry_path.read_bytes()))
    assert {"code", "c"}.isdisjoint(entry) and {"light", "native", "texts"} <= set(entry)
    texts = json.loads(cache.unseal(side.read_bytes()))
    assert set(texts) == {"code", "c"}
    assert entry["light"] == native.light_source(texts["code"])
    assert native.named(entry["native"]) == native.module_name(texts["c"])
    assert reads == []
    monkeypatch.delenv("ANADYN_NATIVE")              # the default: a cached library is used
    assert "cache hit" in simulate(capsys, robot, tmp_path / "warm", err=said)
    assert reads == []
    assert json.loads((tmp_path / "warm" / "simulate.json").read_text())["code"] \
        == "native C (cached)"
    assert csv(tmp_path / "warm") == csv(tmp_path / "cold")


def test_a_scalar_function_reads_the_side_file_once(folder, reads, tmp_path, capsys,
                                                     monkeypatch):
    simulate(capsys, RRT, tmp_path / "cold")
    with cache.keeping_code():
        model = numeric_model(RRT, use_cache=True)
    assert isinstance(model, native.NativeModel) and reads == []
    x = [0.1, -0.2, 0.3, 0.5, -0.4, 0.2]
    python = model.scalar("accelerations")(0.0, *x)
    model.scalar("factor")
    assert len(reads) == 1
    assert python == model.accelerations(0.0, np.array(x))      # the C's bits
    # the generated Python alone (no library): its functions come from the side file
    monkeypatch.setenv("ANADYN_NATIVE", "0")
    assert "cache hit" in simulate(capsys, RRT, tmp_path / "python")
    assert len(reads) == 2
    assert csv(tmp_path / "python") == csv(tmp_path / "cold")


def _another_entry_side_file(tmp_path: Path, capsys, side: Path) -> bytes:
    """The side file of another robot's entry (rr), well sealed; that entry removed."""
    simulate(capsys, RR, tmp_path / "rr")
    (other,) = set(side.parent.glob("*" + cache.TEXTS)) - {side}
    data = other.read_bytes()
    other.unlink()
    other.with_suffix(".json").unlink()
    return data


@pytest.mark.parametrize("damage", ["deleted", "one byte flipped", "truncated",
                                    "another entry's", "an older one"])
@pytest.mark.parametrize("native_mode", ["0", "1"])
def test_a_bad_side_file_is_rebuilt_with_one_warning(folder, tmp_path, capsys, monkeypatch,
                                                     damage, native_mode):
    """A side file that is missing, damaged or not the entry's is never used: one
    warning line, the texts are generated again (and filed again) and the results
    are the cold run's bytes.  ANADYN_NATIVE=0 needs the texts at once (the
    generated Python runs); with the library, the first scalar function does."""
    simulate(capsys, RRT, tmp_path / "cold")
    entry_path, side = entry_files(folder)
    data = side.read_bytes()
    if damage == "deleted":
        side.unlink()
    elif damage == "one byte flipped":
        side.write_bytes(data[:-50] + bytes([data[-50] ^ 1]) + data[-49:])
    elif damage == "truncated":
        side.write_bytes(data[:len(data) // 2])
    elif damage == "another entry's":
        side.write_bytes(_another_entry_side_file(tmp_path, capsys, side))
    else:                               # well sealed, the entry's kind, other texts
        texts = json.loads(cache.unseal(data))
        side.write_bytes(cache.seal(json.dumps({**texts, "code": texts["code"] + "\n"}).encode()))
    warning = {"deleted": f"cache side file {side} is missing; rebuilt",
               "one byte flipped": f"cache side file {side} is damaged (its content does not "
                                   "match its SHA-256 or is not JSON); not used, rebuilt",
               "truncated": f"cache side file {side} is damaged (its content does not "
                            "match its SHA-256 or is not JSON); not used, rebuilt"}.get(
        damage, f"cache side file {side} is not the one its cache entry names (its SHA-256 "
                "differs: another entry's or an older one); not used, rebuilt")
    library._announced.clear()
    monkeypatch.setenv("ANADYN_NATIVE", native_mode)
    if native_mode == "0":
        assert "cache hit" in simulate(capsys, RRT, tmp_path / "again",
                                       err=f"anadyn: warning: {warning}\n")
        assert csv(tmp_path / "again") == csv(tmp_path / "cold")
    else:
        with cache.keeping_code(), pytest.warns(UserWarning, match=re.escape(warning)):
            model = numeric_model(RRT, use_cache=True)
            assert isinstance(model, native.NativeModel)
            model.scalar("accelerations")
        capsys.readouterr()
    # filed again, the same texts as the cold run's: the next run reads them without a word
    assert side.read_bytes() == data
    library._announced.clear()
    monkeypatch.setenv("ANADYN_NATIVE", "0")
    assert "cache hit" in simulate(capsys, RRT, tmp_path / "after")
    assert csv(tmp_path / "after") == csv(tmp_path / "cold")


def test_an_entry_of_the_format_before_side_files_is_a_clean_miss(folder, tmp_path, capsys):
    """An entry with the texts inline (format 2: ``code`` and ``c``) is a miss, without a
    word; the run files the entry again, with its side file."""
    simulate(capsys, RRT, tmp_path / "cold")
    entry_path, side = entry_files(folder)
    entry = json.loads(cache.unseal(entry_path.read_bytes()))
    texts = json.loads(cache.unseal(side.read_bytes()))
    old = {"code": texts["code"], "c": texts["c"], "robot": entry["robot"],
           "tables": entry["tables"], "digest": entry["digest"]}
    entry_path.write_bytes(cache.seal(json.dumps(old).encode()))
    side.unlink()
    assert "cache miss" in simulate(capsys, RRT, tmp_path / "old")
    assert csv(tmp_path / "old") == csv(tmp_path / "cold")
    assert "native" in json.loads(cache.unseal(entry_path.read_bytes())) and side.exists()
    assert "cache hit" in simulate(capsys, RRT, tmp_path / "new")


def test_the_stored_signature_names_the_library_of_this_build(monkeypatch):
    """The entry keeps the C text's signature, not its module name: a run with other
    compile flags (or another Python, NumPy, compiler) names another library."""
    c_text = "int anadyn_jac;\n"
    stored = native.signature(c_text)
    assert native.named(stored) == native.module_name(c_text)
    here = native.named(stored)
    monkeypatch.setattr(native.builder, "FLAGS", ("-O2", *native.FLAGS[1:]))
    assert native.named(stored) != here
    monkeypatch.setattr(native.builder.sys, "version", "3.99.0 (another Python)")
    monkeypatch.setattr(native.builder, "FLAGS", native.FLAGS)
    assert native.named(stored) != here
    for bad in (None, {}, {**stored, "sha256": "x"}, {**stored, "numpy": 1}):
        with pytest.raises(ValueError):
            native.named(bad)
