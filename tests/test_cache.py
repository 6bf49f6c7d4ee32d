"""The derivation cache, through `anadyn simulate`.

Every test has its own cache folder (ANADYN_CACHE_DIR).  Whether a run hit
the cache is read from the `time:` line the command prints.  The cache key
covers the robot file's bytes, the formulation, anadyn's version and a
fingerprint of anadyn's code; within one test process the fingerprint is
computed once (lru_cache), so other people editing anadyn meanwhile do not
turn hits into misses here.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from anadyn_cli.numeric import cache
from anadyn_cli.cli import main

ROOT = Path(__file__).resolve().parent.parent
RR = ROOT / "robots" / "rr.yaml"


@pytest.fixture
def cache_dir(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(folder))
    return folder


def simulate(capsys, robot, out, *options, err: str = "") -> tuple[str | None, str]:
    """Run `anadyn simulate` (exit 0 expected, ``err`` on stderr); ('hit' | 'miss' |
    None, stdout)."""
    code = main(["simulate", str(robot), "--out", str(out), *map(str, options)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert captured.err == err
    line = re.search(r"^time: (.*)$", captured.out, re.M)[1]
    found = re.search(r"\bcache (hit|miss)\b", line)
    return (found[1] if found else None), captured.out


def entries(folder: Path, pattern: str = "*.json") -> dict[str, bytes]:
    """The derivation entries (``pattern``: every file, bytecode kept too)."""
    if not folder.exists():
        return {}
    return {p.name: p.read_bytes() for p in sorted(folder.glob(pattern))}


def test_second_run_is_a_hit_with_the_same_csv(cache_dir, tmp_path, capsys):
    first, second = tmp_path / "first", tmp_path / "second"
    assert simulate(capsys, RR, first)[0] == "miss"          # with the plot, as users run it
    assert len(entries(cache_dir)) == 1
    hit, out = simulate(capsys, RR, second)
    assert hit == "hit"
    assert "derive" not in re.search(r"^time: .*$", out, re.M)[0]
    assert (second / "simulate.csv").read_bytes() == (first / "simulate.csv").read_bytes()
    assert (second / "simulate.png").exists()


def test_formulations_have_their_own_entries(cache_dir, tmp_path, capsys):
    assert simulate(capsys, RR, tmp_path / "k", "--t-end", 1, "--no-plot")[0] == "miss"
    assert simulate(capsys, RR, tmp_path / "l", "--t-end", 1, "--no-plot",
                    "--formulation", "lagrange")[0] == "miss"
    assert simulate(capsys, RR, tmp_path / "l", "--t-end", 1, "--no-plot",
                    "--formulation", "lagrange")[0] == "hit"
    assert len(entries(cache_dir)) == 2


def test_editing_the_robot_file_is_a_miss(cache_dir, tmp_path, capsys):
    robot = tmp_path / "rr.yaml"
    robot.write_text(RR.read_text())

    def run(name: str) -> str | None:
        return simulate(capsys, robot, tmp_path / name, "--t-end", 2, "--no-plot")[0]

    assert (run("a"), run("b")) == ("miss", "hit")
    robot.write_text(RR.read_text() + "# a comment\n")
    assert (run("c"), run("d")) == ("miss", "hit")
    assert (tmp_path / "c" / "simulate.csv").read_bytes() == (tmp_path / "a" / "simulate.csv").read_bytes()
    robot.write_text(RR.read_text().replace("m2: 1.0", "m2: 2.0"))
    assert run("e") == "miss"
    assert (tmp_path / "e" / "simulate.csv").read_bytes() != (tmp_path / "a" / "simulate.csv").read_bytes()
    robot.write_text(RR.read_text())
    assert run("f") == "hit"
    assert len(entries(cache_dir)) == 3


@pytest.mark.parametrize("change", ["code fingerprint", "version"])
def test_other_anadyn_code_is_a_miss(cache_dir, tmp_path, capsys, monkeypatch, change):
    assert simulate(capsys, RR, tmp_path / "a", "--t-end", 1, "--no-plot")[0] == "miss"
    assert simulate(capsys, RR, tmp_path / "b", "--t-end", 1, "--no-plot")[0] == "hit"
    with monkeypatch.context() as patch:
        if change == "version":
            patch.setattr(cache, "__version__", "99.0.0")
        else:
            patch.setattr(cache, "code_fingerprint", lambda: "0" * 64)
        assert simulate(capsys, RR, tmp_path / "c", "--t-end", 1, "--no-plot")[0] == "miss"
        assert simulate(capsys, RR, tmp_path / "d", "--t-end", 1, "--no-plot")[0] == "hit"
    assert simulate(capsys, RR, tmp_path / "e", "--t-end", 1, "--no-plot")[0] == "hit"
    assert len(entries(cache_dir)) == 2


def test_no_cache_neither_reads_nor_writes(cache_dir, tmp_path, capsys, monkeypatch):
    hit, out = simulate(capsys, RR, tmp_path / "a", "--t-end", 1, "--no-plot", "--no-cache")
    assert hit is None and "derive" in out
    assert not cache_dir.exists()
    simulate(capsys, RR, tmp_path / "b", "--t-end", 1, "--no-plot")      # fill the cache
    before = entries(cache_dir, "*")
    assert len(entries(cache_dir)) == 1

    def forbidden(*args, **kwargs):
        raise AssertionError("the cache was used")
    monkeypatch.setattr(cache, "load", forbidden)
    monkeypatch.setattr(cache, "store", forbidden)
    hit, out = simulate(capsys, RR, tmp_path / "c", "--t-end", 1, "--no-plot", "--no-cache")
    assert hit is None and "derive" in out
    assert entries(cache_dir, "*") == before
    assert (tmp_path / "c" / "simulate.csv").read_bytes() == (tmp_path / "a" / "simulate.csv").read_bytes()


def _damage(path: Path, how: str) -> None:
    """Damage the entry as a disk or an editor would (its seal no longer matches),
    or rewrite it with a valid seal but hostile content (as only its owner could)."""
    data = path.read_bytes()
    entry = json.loads(cache.unseal(data))
    if how == "garbage":
        path.write_bytes(b"\x00\xff\xfe not json")
    elif how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "one bit flipped":
        path.write_bytes(data[:200] + bytes([data[200] ^ 1]) + data[201:])
    elif how == "unsealed":
        path.write_text(json.dumps(entry))
    else:
        code = "code" if "code" in entry else "light"   # the recursive path's light source
        hostile = {"not a mapping": [1, 2, 3], "another robot's": {**entry, "digest": "0" * 64},
                   "no code": {k: v for k, v in entry.items() if k != code},
                   "code not text": {**entry, code: 12},
                   "code cut short": {**entry, code: entry[code][: len(entry[code]) // 2]},
                   "no robot info": {k: v for k, v in entry.items() if k != "robot"},
                   "robot info of the wrong type": {**entry, "robot": [None]}}.get(how)
        payload = (json.dumps(hostile).encode() if how != "deeply nested"    # RecursionError
                   else b'{"code": ' + b"[" * 200000 + b"]" * 200000 + b"}")
        path.write_bytes(cache.seal(payload))


#: damaged: its seal does not match; deeply nested: JSON that json cannot read
#: (RecursionError); both are misses with a warning.  The rest are well sealed.
DAMAGED = ["garbage", "truncated", "empty", "one bit flipped", "unsealed", "deeply nested"]
HOSTILE = ["not a mapping", "another robot's", "no code", "code not text", "code cut short",
           "no robot info", "robot info of the wrong type"]


@pytest.mark.parametrize("how", DAMAGED + HOSTILE)
def test_damaged_entry_is_a_miss(cache_dir, tmp_path, capsys, how):
    """A damaged entry (its SHA-256 does not match) is a miss with one warning line;
    a well-sealed entry with the wrong content is a miss too; the run then repairs it
    and the results are those of the first run, to the byte."""
    assert simulate(capsys, RR, tmp_path / "a", "--t-end", 1, "--no-plot")[0] == "miss"
    (entry,) = cache_dir.glob("*.json")
    _damage(entry, how)
    warning = (f"anadyn: warning: cache entry {entry} is damaged (its content does not match "
               "its SHA-256 or is not JSON); not used, rebuilt\n") if how in DAMAGED else ""
    assert simulate(capsys, RR, tmp_path / "b", "--t-end", 1, "--no-plot",
                    err=warning)[0] == "miss"
    assert (tmp_path / "b" / "simulate.csv").read_bytes() == (tmp_path / "a" / "simulate.csv").read_bytes()
    assert simulate(capsys, RR, tmp_path / "c", "--t-end", 1, "--no-plot")[0] == "hit"


@pytest.mark.parametrize("where", ["under a regular file", "a regular file"])
def test_unusable_cache_folder_does_not_fail_the_run(tmp_path, capsys, monkeypatch, where):
    blocker = tmp_path / "blocker"
    blocker.write_text("not a folder\n")
    folder = blocker / "cache" if where == "under a regular file" else blocker
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(folder))
    assert simulate(capsys, RR, tmp_path / "a", "--t-end", 1, "--no-plot")[0] == "miss"
    assert simulate(capsys, RR, tmp_path / "b", "--t-end", 1, "--no-plot")[0] == "miss"
    assert (tmp_path / "b" / "simulate.csv").read_bytes() == (tmp_path / "a" / "simulate.csv").read_bytes()
    assert blocker.read_text() == "not a folder\n"


def test_same_text_under_another_file_name_keeps_its_own_name(cache_dir, tmp_path, capsys,
                                                             monkeypatch):
    """A robot without `name:` is named after its file; a cache hit on a copy of
    the text under another name must not bring the first file's name along."""
    text = "".join(line for line in RR.read_text().splitlines(keepends=True)
                   if not line.startswith("name:"))
    (tmp_path / "alpha.yaml").write_text(text)
    (tmp_path / "beta.yaml").write_text(text)
    monkeypatch.chdir(tmp_path)
    code = main(["simulate", "alpha.yaml", "--t-end", "1", "--no-plot"])
    assert code == 0 and "cache miss" in capsys.readouterr().out
    code = main(["simulate", "beta.yaml", "--t-end", "1", "--no-plot"])
    out = capsys.readouterr().out
    assert code == 0
    assert "wrote results/beta/simulate.csv" in out, out.splitlines()[-1]
    assert json.loads(Path("results/beta/simulate.json").read_text())["robot"] == "beta"


_RUN = """\
import sys
import anadyn_cli.numeric.cache
anadyn_cli.numeric.cache.code_fingerprint = lambda: "test"   # others may be editing anadyn meanwhile
from anadyn_cli.cli import main
code = main(["simulate", {robot!r}, "--out", {out!r}, "--t-end", "1", "--no-plot"])
print("sympy imported:", "sympy" in sys.modules)
sys.exit(code)
"""


def test_cache_hit_does_not_import_sympy(cache_dir, tmp_path):
    env = {**os.environ, "ANADYN_CACHE_DIR": str(cache_dir)}

    def run(out: str) -> str:
        done = subprocess.run([sys.executable, "-c", _RUN.format(robot=str(RR), out=out)],
                              capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
        assert done.returncode == 0, done.stderr
        return done.stdout

    first = run("a")
    assert "cache miss" in first and "sympy imported: True" in first
    second = run("b")
    assert "cache hit" in second
    assert second.splitlines()[-1] == "sympy imported: False"
