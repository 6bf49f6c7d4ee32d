"""Results are never lost: atomic writes, failed runs leave earlier results
alone, and an unusable --out is refused in one line before any work.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli import files as output
from anadyn_cli.output import plots
from anadyn_cli.output.csv_table import write_csv
from anadyn_cli.cli import main
from anadyn_cli.errors import ModelError

from scenes import cubic_text

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
RR = (ROBOTS / "rr.yaml").read_text()
COMMANDS = ["simulate", "inverse", "check", "accuracy"]     # those with --out


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def no_work(monkeypatch):
    """Reading a robot fails the test: --out must be refused before that."""
    def refuse(*args, **kwargs):
        raise AssertionError("the robot was read before --out was checked")
    monkeypatch.setattr("anadyn_cli.model.loader.robot_from_text", refuse)
    monkeypatch.setattr("anadyn_cli.model.yamlsource.read_text", refuse)


# -- --out that cannot take results ----------------------------------------------------------
@pytest.mark.parametrize("command", COMMANDS)
def test_out_is_a_file(tmp_path, capsys, monkeypatch, command):
    target = tmp_path / "results.txt"
    target.write_text("keep me\n")
    no_work(monkeypatch)
    code, out, err = run(capsys, command, ROBOTS / "rr.yaml", "--out", target)
    assert err == f"anadyn: error: --out {target}: is a file, expected a folder\n"
    assert (code, out) == (2, "")
    assert target.read_text() == "keep me\n"


def test_default_folder_that_is_a_file_is_named_as_such(tmp_path, capsys, monkeypatch):
    """Without --out the message names the default folder, not an option never given."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "rr").write_text("keep me\n")
    code, out, err = run(capsys, "simulate", ROBOTS / "rr.yaml", "--no-plot", "--no-cache",
                         "--t-end", "0.1")
    assert (code, out) == (2, "")
    assert err == "anadyn: error: output folder results/rr: is a file, expected a folder\n"
    assert (tmp_path / "results" / "rr").read_text() == "keep me\n"


@pytest.mark.parametrize("command", ["simulate", "inverse"])
def test_out_under_a_file(tmp_path, capsys, monkeypatch, command):
    """A folder below a regular file can be created by nobody, root included."""
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    target = blocker / "deeper" / "out"
    no_work(monkeypatch)
    code, out, err = run(capsys, command, ROBOTS / "rr.yaml", "--out", target)
    assert err == (f"anadyn: error: --out {target}: cannot create the folder, {blocker} is a "
                   "file\n")
    assert (code, out) == (2, "")
    assert blocker.is_file() and blocker.read_text() == ""


def unprivileged(call):
    """``call()``'s value, computed by a user that read-only folders stop: this user,
    or for root (which writes anywhere) a forked child that has become ``nobody``
    (as ``setpriv --reuid=nobody --regid=nogroup --clear-groups`` would; setpriv or
    runuser cannot start this Python: it lives in root's home), with everything
    imported already."""
    if os.geteuid() != 0:
        return call()
    import pickle
    import pwd

    nobody = pwd.getpwnam("nobody")
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:                                   # the child: never back into pytest
        try:
            os.close(read)
            os.setgroups([])
            os.setgid(nobody.pw_gid)
            os.setuid(nobody.pw_uid)
            answer = ("value", call())
        except BaseException as err:               # noqa: BLE001  reported to the parent
            answer = ("raised", f"{type(err).__name__}: {err}")
        with os.fdopen(write, "wb") as pipe:
            pipe.write(pickle.dumps(answer))
        os._exit(0)
    os.close(write)
    with os.fdopen(read, "rb") as pipe:
        data = pipe.read()
    os.waitpid(pid, 0)
    kind, value = pickle.loads(data)               # noqa: S301  our own child's answer
    assert kind == "value", value
    return value


@pytest.fixture
def shared_tmp():
    """A scratch folder that ``nobody`` can reach (pytest's tmp_path is root's alone)."""
    folder = Path(tempfile.mkdtemp(prefix="anadyn-locked-"))
    folder.chmod(0o755)
    yield folder
    for path in [folder, *folder.rglob("*")]:
        if path.is_dir():
            path.chmod(0o700)
    shutil.rmtree(folder)


@pytest.mark.parametrize("inside", [False, True])
def test_out_not_writable(shared_tmp, capsys, monkeypatch, inside):
    locked = shared_tmp / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    target = locked / "out" if inside else locked
    run(capsys, "simulate", "--help")       # the CLI's own imports, while files are readable
    no_work(monkeypatch)
    code, out, err = unprivileged(lambda: run(capsys, "simulate", ROBOTS / "rr.yaml",
                                              "--out", target))
    expected = (f"cannot create the folder, {locked} is not writable" if inside
                else "folder is not writable")
    assert err == f"anadyn: error: --out {target}: {expected}\n"
    assert (code, out) == (2, "")
    assert list(locked.iterdir()) == []


@pytest.mark.parametrize("inside", [False, True])
def test_out_not_writable_as_the_system_says(tmp_path, capsys, monkeypatch, inside):
    """The same for root too: the folder is reported not writable by os.access."""
    locked = tmp_path / "locked"
    locked.mkdir()
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: (
        False if Path(path) == locked and mode & os.W_OK else real_access(path, mode, **kw)))
    target = locked / "out" if inside else locked
    no_work(monkeypatch)
    code, out, err = run(capsys, "inverse", ROBOTS / "rr.yaml", "--out", target)
    expected = (f"cannot create the folder, {locked} is not writable" if inside
                else "folder is not writable")
    assert err == f"anadyn: error: --out {target}: {expected}\n"
    assert (code, out) == (2, "")
    assert list(locked.iterdir()) == []


def test_out_name_too_long(tmp_path, capsys, monkeypatch):
    target = tmp_path / ("x" * 300) / "out"
    no_work(monkeypatch)
    code, out, err = run(capsys, "simulate", ROBOTS / "rr.yaml", "--out", target)
    assert err == (f"anadyn: error: --out {target}: cannot use it as a folder (File name too "
                   "long)\n")
    assert (code, out) == (2, "")


def test_out_check_creates_nothing(tmp_path, capsys):
    """A bad robot with a new --out folder: the error, and no folder left behind."""
    bad = tmp_path / "bad.yaml"
    bad.write_text(RR.replace("    mass: m2", "    mass: 0"))
    target = tmp_path / "new" / "out"
    code, out, err = run(capsys, "simulate", bad, "--out", target, "--no-plot")
    assert err == (f"anadyn: error: {bad}:21: bodies[1].mass: must be positive (a mass in kg), "
                   "got 0\n")
    assert (code, out) == (2, "")
    assert not (tmp_path / "new").exists()


def test_check_dir_accepts_what_can_be_created(tmp_path):
    output.check_dir(tmp_path)                       # an existing folder
    output.check_dir(tmp_path / "a" / "b" / "c")      # folders still to be made
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "f").write_text("")
    with pytest.raises(ModelError, match=r"is a file, expected a folder$"):
        output.check_dir(tmp_path / "f")


def test_default_folder_is_named_safely(tmp_path, capsys, monkeypatch):
    """Without --out and without a name the folder is named after the file,
    reduced to an identifier: no path tricks from the file name."""
    monkeypatch.chdir(tmp_path)
    robot = tmp_path / "..; rm -rf ~ (copy).yaml"
    robot.write_text(RR.replace("name: rr\n", ""))
    code, _, err = run(capsys, "simulate", robot, "--t-end", "0.1", "--no-plot", "--no-cache")
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["..; rm -rf ~ (copy).yaml",
                                                          "results"]
    assert [p.name for p in (tmp_path / "results").iterdir()] == ["robot_____rm__rf____copy_"]
    assert sorted(p.name for p in (tmp_path / "results" / "robot_____rm__rf____copy_")
                  .iterdir()) == ["simulate.csv", "simulate.json"]


# -- failing runs leave earlier results alone -----------------------------------------------
def test_singular_start_keeps_earlier_simulate_results(tmp_path, capsys):
    out = tmp_path / "out"
    good = tmp_path / "cubic.yaml"
    good.write_text(cubic_text(0.8))
    code, _, err = run(capsys, "simulate", good, "--out", out, "--t-end", "0.2", "--no-cache")
    assert code == 0, err
    before = files(out)
    assert set(before) == {"simulate.csv", "simulate.json", "simulate.png"}
    bad = tmp_path / "cubic0.yaml"
    bad.write_text(cubic_text(0.0))
    code, text, err = run(capsys, "simulate", bad, "--out", out, "--no-cache")
    assert err == (f"anadyn: error: {bad}: singular mass matrix at t = 0 s, state "
                   f"(s=0, q1=0, ds=0, dq1=0); 1 rows before it in "
                   f"{out / 'simulate.partial.csv'}\n")
    assert (code, text) == (3, "")
    after = files(out)
    assert after.pop("simulate.partial.csv").startswith(b"t,s,q1,ds,dq1\n0.0,0.0,0.0,0.0,0.0\n")
    assert after == before


def test_refused_inverse_keeps_earlier_inverse_results(tmp_path, capsys):
    out = tmp_path / "out"
    rr = tmp_path / "rr.yaml"
    rr.write_text(RR)
    code, _, err = run(capsys, "inverse", rr, "--out", out, "--dt", "0.5", "--no-roundtrip",
                       "--no-cache")
    assert code == 0, err
    before = files(out)
    assert set(before) == {"inverse.csv", "inverse.json", "inverse.png"}
    assert json.loads(before["inverse.json"])["robot"] == "rr"
    under = tmp_path / "under.yaml"        # the same robot without its second actuator
    under.write_text(RR.replace("  T12z: {joint: bar2}         # bar 1 on bar 2 at B (and "
                                "-T12z on bar 1)\n", "")
                     .replace("    T12z: -b12*dq2 - g12*(q2 - q2f) + 0.5*g*L2*m2*cos(q2)\n",
                              ""))
    assert under.read_text().count("T12z") == 0
    code, text, err = run(capsys, "inverse", under, "--out", out, "--dt", "0.25",
                          "--no-roundtrip", "--no-cache")
    assert err == (f"anadyn: error: {under}: actuators: 2 coordinates, 1 actuator: inverse "
                   "dynamics needs one independent actuator per coordinate (B square and "
                   "non-singular); not actuated: q2\n")
    assert (code, text) == (2, "")
    assert files(out) == before


def test_failed_write_keeps_earlier_results_and_says_so(tmp_path, capsys, monkeypatch):
    """The disk refusing the new simulate.csv (here: fsync fails) is one line,
    exit 2, and the earlier file stays whole."""
    out = tmp_path / "out"
    rr = tmp_path / "rr.yaml"
    rr.write_text(RR)
    code, _, err = run(capsys, "simulate", rr, "--out", out, "--t-end", "0.2", "--no-plot",
                       "--no-cache")
    assert code == 0, err
    before = files(out)

    def full_disk(fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", full_disk)
    code, text, err = run(capsys, "simulate", rr, "--out", out, "--t-end", "0.3", "--no-plot",
                          "--no-cache")
    assert err == (f"anadyn: error: cannot write {out / 'simulate.csv'}: No space left on "
                   "device; earlier results there are left as they were\n")
    assert (code, text) == (2, "")
    assert files(out) == before


# -- the writers themselves -------------------------------------------------------------------
def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp")
                  or p.name.startswith("."))


def test_writers_leave_only_their_files(tmp_path):
    t = np.linspace(0, 1, 11)
    write_csv(tmp_path / "a.csv", ["t", "x"], [t, t**2])
    output.write_json(tmp_path / "a.json", {"rows": 11, "error": np.float64(1e-9)})
    output.write_text(tmp_path / "a.txt", "done\n")
    plots.write_plot(tmp_path / "a.png", t, [("x", [("x", t**2)])], "title")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "a.json", "a.png", "a.txt"]
    rows = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1)
    assert np.array_equal(rows, np.column_stack([t, t**2]))      # full double precision
    assert (tmp_path / "a.csv").read_text().splitlines()[0] == "t,x"
    assert json.loads((tmp_path / "a.json").read_text()) == {"rows": 11, "error": 1e-9}
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_write_is_a_rename_of_a_complete_file(tmp_path, monkeypatch):
    """At the moment of the rename the new content is whole in a temporary file
    of the same folder and the old file is untouched."""
    target = tmp_path / "simulate.csv"
    target.write_text("old\n")
    seen = []
    real_replace = os.replace

    def watching_replace(source, destination):
        source, destination = Path(source), Path(destination)
        seen.append((source.parent, source.read_text(), destination.read_text()))
        return real_replace(source, destination)
    monkeypatch.setattr(os, "replace", watching_replace)
    output.write_text(target, "new\n" * 1000)
    assert seen == [(tmp_path, "new\n" * 1000, "old\n")]
    assert target.read_text() == "new\n" * 1000
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("failing", ["fsync", "replace", "write"])
@pytest.mark.parametrize("error", [OSError(5, "Input/output error"), KeyboardInterrupt()])
def test_interrupted_write_leaves_no_temporary_file(tmp_path, monkeypatch, failing, error):
    target = tmp_path / "simulate.csv"
    target.write_text("old\n")

    def fail(*args, **kwargs):
        raise error
    if failing == "write":                         # midway through writing the data
        real_fdopen = os.fdopen

        def half_writer(fd, *args, **kwargs):
            stream = real_fdopen(fd, *args, **kwargs)

            class Half:
                def __enter__(self):
                    return self

                def __exit__(self, *exc):
                    stream.close()

                def write(self, data):
                    stream.write(data[: len(data) // 2])
                    stream.flush()
                    raise error

                def __getattr__(self, name):
                    return getattr(stream, name)
            return Half()
        monkeypatch.setattr(os, "fdopen", half_writer)
    else:
        monkeypatch.setattr(os, failing, fail)
    expected = type(error) if isinstance(error, KeyboardInterrupt) else output.WriteError
    with pytest.raises(expected):
        write_csv(target, ["t"], [np.arange(1000.0)])
    monkeypatch.undo()
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["simulate.csv"]


def test_write_error_is_one_line_model_error(tmp_path):
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    with pytest.raises(output.WriteError) as caught:
        output.write_text(blocker / "a.txt", "x")
    assert isinstance(caught.value, ModelError) and isinstance(caught.value, OSError)
    assert str(caught.value) == (f"cannot write {blocker / 'a.txt'}: Not a directory; earlier "
                                 "results there are left as they were")


@pytest.fixture
def small_disk(tmp_path):
    """A real file system of 128 KiB (tmpfs, mounted as root), unmounted afterwards."""
    import subprocess

    folder = tmp_path / "disk"
    folder.mkdir()
    if os.geteuid() != 0 or subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=128k", "tmpfs", str(folder)],
            capture_output=True).returncode != 0:
        pytest.skip("mounting a tmpfs needs root (CI runs as root)")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def test_a_really_full_disk_keeps_earlier_results_whole(small_disk, tmp_path, capsys):
    """The same promise as above on a real full disk (ENOSPC from the kernel, not a
    stand-in): a run whose CSV does not fit is one line, exit 2; the earlier set
    stays byte for byte and no temporary file is left behind."""
    rr = tmp_path / "rr.yaml"
    rr.write_text(RR)
    out = small_disk / "out"
    code, _, err = run(capsys, "simulate", rr, "--out", out, "--t-end", "0.2", "--no-plot",
                       "--no-cache")
    assert code == 0, err
    before = files(out)
    code, text, err = run(capsys, "simulate", rr, "--out", out, "--t-end", "60",
                          "--no-plot", "--no-cache")
    assert (code, text) == (2, "")
    assert err.startswith("anadyn: error: cannot write ") and "No space left on device" in err
    assert err.count("\n") == 1
    assert files(out) == before
    assert leftovers(out) == []
