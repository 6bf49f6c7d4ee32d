"""The cache cannot be used against its user (docs/explanation/security.md).

A second user (``nobody``; the suite runs as root in CI) plants code where
anadyn keeps its cache: entries whose generated Python, and libraries whose
init code, would write a marker file if anadyn ran them.  Every test asserts
that the marker is never written, that the victim's run either refuses in
one line (exit 2) or takes the planted files as a miss (a warning line, then
rebuilt), and that its results are the bytes of a run without the cache.
Victim runs are subprocesses, so that a crash (SIGBUS from a truncated
library) is seen as one.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import stat
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from anadyn_cli.cli import main
from anadyn_cli.model import library
from anadyn_cli.numeric import cache, compile_job, native

ROOT = Path(__file__).resolve().parent.parent
RR = ROOT / "robots" / "rr.yaml"
ROOT_USER = hasattr(os, "getuid") and os.getuid() == 0
NOBODY = ["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups"]
needs_root = pytest.mark.skipif(not (ROOT_USER and shutil.which("setpriv")),
                                reason="planting as another user needs root and setpriv")
needs_compiler = pytest.mark.skipif(native.unavailable() is not None,
                                    reason=f"native code: {native.unavailable()}")


def run(cache_dir: Path, out: Path, *extra: str, native_mode: str = "wait",
        umask: int | None = None) -> subprocess.CompletedProcess:
    """`anadyn simulate rr --t-end 0.5` in a new process with this cache folder."""
    env = {**os.environ, "ANADYN_CACHE_DIR": str(cache_dir), "ANADYN_NATIVE": native_mode,
           "ANADYN_PROGRESS": "off"}
    code = ("import os, sys\n"
            + (f"os.umask({umask})\n" if umask is not None else "")
            + "from anadyn_cli.cli import main\nsys.exit(main(sys.argv[1:]))")
    return subprocess.run([sys.executable, "-c", code, "simulate", str(RR), "--t-end", "0.5",
                           "--no-plot", "--out", str(out), *extra],
                          capture_output=True, text=True, env=env, timeout=600)


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    """A cache filled by an honest run (entry, library and its record) and the
    CSV of a run without the cache."""
    base = tmp_path_factory.mktemp("genuine")
    reference = run(base / "unused", base / "reference", "--no-cache")
    assert reference.returncode == 0, reference.stderr
    filled = run(base / "cache", base / "filled")
    assert filled.returncode == 0, filled.stderr
    return base


def csv(folder: Path) -> bytes:
    return (folder / "simulate.csv").read_bytes()


def copy_cache(genuine: Path, to: Path) -> Path:
    """The honest cache (both folders) copied to ``to``/cache; its path."""
    for name in ("cache", "cache-native"):
        shutil.copytree(genuine / name, to / name)
    return to / "cache"


def planted_library(name: str, marker: Path, folder: Path) -> Path:
    """An extension module ``name`` whose init code writes ``marker``."""
    source = folder / "planted.c"
    source.write_text(
        "#include <stdio.h>\n"
        "__attribute__((constructor)) static void planted(void) {\n"
        f'    FILE *f = fopen("{marker}", "w"); if (f) {{ fputs("ran", f); fclose(f); }}\n'
        "}\n"
        f"void *PyInit_{name}(void) {{ planted(); return 0; }}\n")
    target = folder / "planted.so"
    subprocess.run([native.compiler(), "-shared", "-fPIC", str(source), "-o", str(target)],
                   check=True, capture_output=True)
    return target


def plant(genuine: Path, into: Path, marker: Path) -> None:
    """Hostile files under the honest files' names in ``into``/cache and
    ``into``/cache-native, sealed as anadyn seals them: every entry's code and
    every library writes ``marker`` when run."""
    (into / "cache").mkdir(parents=True)
    (into / "cache-native").mkdir()
    hostile = f"open({str(marker)!r}, 'w').write('ran')\n"
    for entry in (genuine / "cache").glob("*.json"):
        value = json.loads(cache.unseal(entry.read_bytes()))
        code = "code" if "code" in value else "light"     # the recursive path's light source
        value[code] = hostile + value[code]
        side = entry.with_suffix(cache.TEXTS)               # and its side file's texts
        if side.exists():
            texts = json.loads(cache.unseal(side.read_bytes()))
            payload = json.dumps({**texts, "code": hostile + texts["code"]}).encode()
            (into / "cache" / side.name).write_bytes(cache.seal(payload))
            value["texts"] = hashlib.sha256(payload).hexdigest()
        (into / "cache" / entry.name).write_bytes(cache.seal(json.dumps(value).encode()))
    for record in (genuine / "cache-native").glob("*.lib"):
        name = record.name[:-len(".lib")]
        data = planted_library(name, marker, into).read_bytes()
        digest = hashlib.sha256(data).hexdigest()
        (into / "cache-native" / compile_job.library_name(name, digest, native.suffix())
         ).write_bytes(data)
        (into / "cache-native" / record.name).write_bytes(
            cache.seal(json.dumps({"sha256": digest}).encode()))
    for leftover in ("planted.c", "planted.so"):
        (into / leftover).unlink()


@pytest.fixture
def shared():
    """A folder like /tmp (root's, sticky, everyone may create in it) that user
    nobody can reach; removed afterwards."""
    folder = Path(tempfile.mkdtemp(prefix="anadyn-shared-"))
    folder.chmod(0o1777)
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def as_nobody(script: str, *args: str) -> None:
    """Run the shell ``script`` as user nobody ($0, $1, ...: ``args``)."""
    subprocess.run([*NOBODY, "sh", "-c", f"set -e; {script}", *args], check=True,
                   capture_output=True)


def tree_modes(*folders: Path) -> dict[str, int]:
    return {str(p): stat.S_IMODE(p.lstat().st_mode)
            for folder in folders for p in [folder, *folder.rglob("*")]}


# ------------------------------------------------------------ another user --

@needs_root
@needs_compiler
@pytest.mark.parametrize("planted", [("cache", "cache-native"), ("cache-native",)])
def test_cache_folders_planted_by_another_user_are_refused(genuine, shared, tmp_path, planted):
    """User nobody makes the cache folders (both, or the library folder beside
    root's own cache) in a folder like /tmp and fills them with code; root's run
    refuses in one line naming the folder and the fix, and runs none of it."""
    marker = tmp_path / "marker"
    staging = shared / "staging"
    staging.mkdir()
    plant(genuine, staging, marker)
    for path in [staging, *staging.rglob("*")]:
        path.chmod(0o755 if path.is_dir() else 0o644)
    attack = shared / "attack"
    attack.mkdir()
    attack.chmod(0o1777)
    if "cache" not in planted:
        shutil.copytree(genuine / "cache", attack / "cache")
    as_nobody('for f in "$@"; do cp -r "$f" "$0/"; done', str(attack),
              *(str(staging / name) for name in planted))
    assert (attack / planted[0]).stat().st_uid == 65534
    done = run(attack / "cache", tmp_path / "out")
    assert done.returncode == 2, done.stderr
    assert done.stderr == (f"anadyn: error: cache folder {attack / planted[0]} belongs to user "
                           "nobody (uid 65534), not to you; remove it or set ANADYN_CACHE_DIR "
                           "to a folder of yours\n")
    assert not marker.exists() and not (tmp_path / "out").exists()


@needs_root
@needs_compiler
def test_planted_files_in_your_own_folders_are_misses(genuine, tmp_path):
    """The folders are root's (0700), the files in them nobody's (left from a time
    the folders were open): each is a miss with a warning, none runs, the run
    rebuilds them and its results are those of a run without the cache."""
    marker = tmp_path / "marker"
    plant(genuine, tmp_path, marker)
    for folder in ("cache", "cache-native"):
        (tmp_path / folder).chmod(0o700)
        for path in (tmp_path / folder).iterdir():
            os.chown(path, 65534, 65534)
    done = run(tmp_path / "cache", tmp_path / "out")
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert lines and all(line.startswith("anadyn: warning: ") and "belongs to user nobody "
                         "(uid 65534), not to you; not used, rebuilt" in line for line in lines)
    assert not marker.exists()
    assert csv(tmp_path / "out") == csv(genuine / "reference")
    again = run(tmp_path / "cache", tmp_path / "again")          # rebuilt: root's own now
    assert again.returncode == 0 and again.stderr == ""
    assert "cache hit" in again.stdout and csv(tmp_path / "again") == csv(genuine / "reference")


@needs_compiler
def test_the_planted_code_is_live(genuine, tmp_path):
    """The control of the tests above: the same planted files, had you written
    them yourself (in your own folders), would run and write the marker; only the
    checks of owner and mode keep it away there."""
    marker = tmp_path / "marker"
    plant(genuine, tmp_path, marker)
    for folder in ("cache", "cache-native"):
        (tmp_path / folder).chmod(0o700)
    run(tmp_path / "cache", tmp_path / "out")
    assert marker.read_text() == "ran"


@pytest.mark.parametrize("mode, owner_group, words", [
    (0o777, None, "is writable by others (mode 0777); remove it or run: chmod 700 "),
    (0o770, "nogroup", "is writable by the group nogroup (mode 0770); remove it or run: "
                       "chmod 700 ")])
def test_a_cache_folder_others_can_write_is_refused(genuine, tmp_path, mode, owner_group,
                                                    words):
    if owner_group and not ROOT_USER:
        pytest.skip("giving the folder to another group needs root")
    folder = copy_cache(genuine, tmp_path)
    folder.chmod(mode)
    if owner_group:
        os.chown(folder, -1, 65534)
    done = run(folder, tmp_path / "out")
    assert done.returncode == 2
    assert done.stderr == f"anadyn: error: cache folder {folder} {words}{folder}\n"


def test_a_folder_above_that_others_can_write_is_refused(genuine, tmp_path):
    """Whoever can rename folders above the cache can swap it: refused, unless
    the folder above is sticky like /tmp."""
    above = tmp_path / "open"
    folder = copy_cache(genuine, above)
    above.chmod(0o777)
    done = run(folder, tmp_path / "out")
    assert done.returncode == 2
    assert done.stderr == (f"anadyn: error: cache folder {folder}: the folder above it, "
                           f"{above}, is writable by others (mode 0777); set ANADYN_CACHE_DIR "
                           "to a folder only you can write\n")
    above.chmod(0o1777)
    done = run(folder, tmp_path / "out")
    assert done.returncode == 0 and "cache hit" in done.stdout


@needs_root
def test_a_symbolic_link_of_another_user_on_the_way_is_refused(genuine, shared, tmp_path):
    """A link in a folder like /tmp, pointing at your own cache: its owner could
    point it elsewhere between anadyn's checks and its reads."""
    folder = copy_cache(genuine, tmp_path)
    as_nobody('ln -s "$0" "$1"', str(folder), str(shared / "link"))
    done = run(shared / "link", tmp_path / "out")
    assert done.returncode == 2
    assert done.stderr == (f"anadyn: error: cache folder {shared / 'link'}: {shared / 'link'} "
                           "is a symbolic link of user nobody (uid 65534); set "
                           "ANADYN_CACHE_DIR to a folder only you can write\n")


# ---------------------------------------------------------------- symlinks --

def victims(folder: Path) -> dict[Path, bytes]:
    folder.mkdir()
    found = {}
    for k in range(16):
        path = folder / f"precious{k}"
        path.write_bytes(f"precious {k}\n".encode())
        found[path] = path.read_bytes()
    return found


@needs_compiler
def test_symbolic_links_named_like_cache_files_are_not_written_through(genuine, tmp_path):
    """Links where a run writes (the C file, the build marker, the library, its
    record, the entry, the SciPy record) must not make it overwrite their targets;
    the run replaces them with its own files."""
    precious = victims(tmp_path / "victim")
    targets = iter(precious)
    names = {"cache": [p.name for p in (genuine / "cache").iterdir()],
             "cache-native": [p.name for p in (genuine / "cache-native").iterdir()]}
    modules = {n[:-len(".lib")] for n in names["cache-native"] if n.endswith(".lib")}
    names["cache-native"] += [f"{m}{end}" for m in modules for end in (".c", ".building",
                                                                      ".failed")]
    for folder, files in names.items():
        (tmp_path / folder).mkdir(mode=0o700)
        for name in files:
            (tmp_path / folder / name).symlink_to(next(targets))
    done = run(tmp_path / "cache", tmp_path / "out", native_mode="wait")
    assert done.returncode == 0, done.stderr
    assert all(path.read_bytes() == data for path, data in precious.items())
    assert csv(tmp_path / "out") == csv(genuine / "reference")
    assert not [p for p in (tmp_path / "cache").iterdir() if p.is_symlink()]


# ------------------------------------------------------------------- umask --

@needs_compiler
def test_under_umask_000_everything_is_owner_only(genuine, tmp_path):
    """Folders 0700 and files 0600 whatever the umask: entries, libraries, records,
    and the folders above the cache that the run had to create."""
    cache_dir = tmp_path / "made" / "by" / "anadyn" / "cache"
    done = run(cache_dir, tmp_path / "out", native_mode="wait", umask=0)
    assert done.returncode == 0, done.stderr
    modes = tree_modes(tmp_path / "made")
    assert modes and set(modes.values()) == {0o700, 0o600}, modes
    assert {m for p, m in modes.items() if Path(p).is_dir()} == {0o700}
    assert len(list(cache_dir.glob("*.json"))) == 1
    assert len(list(cache_dir.with_name("cache-native").glob("*.so"))) == 1
    assert csv(tmp_path / "out") == csv(genuine / "reference")


# --------------------------------------------------------- damaged libraries --

@needs_compiler
@pytest.mark.parametrize("damage", ["truncated", "one bit flipped", "emptied", "removed"])
def test_a_damaged_library_never_reaches_the_loader(genuine, tmp_path, damage):
    """A truncated library used to kill every run with SIGBUS; now its SHA-256
    does not match its record: a warning, the run goes on (exit 0, the same
    bytes) and the library is rebuilt."""
    folder = copy_cache(genuine, tmp_path)
    (library_file,) = folder.with_name("cache-native").glob("*.so")
    data = library_file.read_bytes()
    if damage == "removed":
        library_file.unlink()
    else:
        library_file.write_bytes({"truncated": data[:len(data) // 3], "emptied": b"",
                                  "one bit flipped": data[:-100] + bytes([data[-100] ^ 1])
                                  + data[-99:]}[damage])
    done = run(folder, tmp_path / "out")
    assert done.returncode == 0, (done.returncode, done.stderr)      # not -7 (SIGBUS)
    word = "missing" if damage == "removed" else ("damaged (its SHA-256 does not match its "
                                                  "record)")
    assert done.stderr == (f"anadyn: warning: native library {library_file} is {word}; "
                           "not used, rebuilt\n")
    assert csv(tmp_path / "out") == csv(genuine / "reference")
    assert library_file.read_bytes() == data or hashlib.sha256(
        library_file.read_bytes()).hexdigest()[:16] in library_file.name
    again = run(folder, tmp_path / "again")
    assert again.returncode == 0 and again.stderr == ""
    assert "native_compile" not in again.stdout


# ------------------------------------------------------------ hostile JSON --

NESTED = b"[" * 100000 + b"]" * 100000          # json.loads: RecursionError


@pytest.mark.parametrize("sealed", [True, False])
def test_deeply_nested_records_are_misses(tmp_path, monkeypatch, sealed):
    """Every kind of sealed file read back (an entry, a library's record, a failed
    build's record, the SciPy self-check's record), nested 100000 deep: a miss
    with a warning, never RecursionError (exit 4)."""
    from anadyn_cli.numeric import odepack
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(library, "_announced", set())
    content = cache.seal(NESTED) if sealed else NESTED
    entries = cache.trusted_folder(cache.directory(), create=True)
    natives = cache.trusted_folder(cache.native_directory(), create=True)
    digest = "0" * 64
    import scipy
    (entries / f"{cache.key(digest, 'kane')}.json").write_bytes(content)
    for name in ("_anadyn_m.lib", "_anadyn_m.failed",
                 f"scipy-odepack-{scipy.__version__}-{sys.implementation.cache_tag}.json"):
        (natives / name).write_bytes(content)
    monkeypatch.setattr(native.builder, "module_name", lambda c_text: "_anadyn_m")
    odepack.extension.cache_clear()
    with pytest.warns(UserWarning) as said:
        assert cache.load(digest, "kane") is None
        assert native.library_path("") is None
        assert native.failed_before(natives, "_anadyn_m") is None
        assert odepack.extension() is not None             # checked again, and recorded
    odepack.extension.cache_clear()
    assert len(said) == 4 and all("is damaged" in str(w.message) for w in said)


# ------------------------------------------------------------ build markers --

@needs_compiler
def test_a_marker_left_by_a_dead_builder_is_stale(tmp_path, monkeypatch):
    """The marker holds the builder's process id: a live builder's marker stops a
    second build; a dead one's (killed mid-build) does not, however recent."""
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    c_text = small_c_text()
    name = native.module_name(c_text)
    place = cache.trusted_folder(native.folder(), create=True)
    marker = place / f"{name}.building"
    cache.create_private(marker, str(os.getpid()).encode())         # alive: this process
    assert native.build_in_background(c_text) == ("being compiled in the background", None)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    marker.write_text(str(dead.pid))
    note, process = native.build_in_background(c_text)
    assert note == "compiling in the background for the next run" and process is not None
    assert process.wait(timeout=300) == 0
    assert not marker.exists() and native.library_path(c_text) is not None


def small_c_text() -> str:
    from anadyn_cli import load_robot
    from anadyn_cli.numeric import recursive
    return native.c_source(recursive.forward(recursive.plan(load_robot(RR))))


# ------------------------------------------------------------ failed builds --

@needs_compiler
def test_a_failed_build_is_remembered_and_said_once(tmp_path, monkeypatch):
    """A compiler that fails: one warning line saying why, on the run that finds
    out; later runs neither retry nor say it again.  In the background too."""
    calls = tmp_path / "calls"
    fake = tmp_path / "fakecc"
    fake.write_text(f"#!/bin/sh\necho x >> {calls}\necho 'error: no room on this disk' >&2\n"
                    "exit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(library, "_announced", set())
    c_text = small_c_text()
    name = native.module_name(c_text)
    record = native.folder() / f"{name}.failed"
    why = "the C compiler failed (error: no room on this disk)"
    with pytest.warns(UserWarning) as said:
        assert native.load(c_text, how="wait") == (None, why)
    assert [str(w.message) for w in said] == [
        f"anadyn: warning: native code not built: {why}; runs use the generated Python (the "
        f"same results, slower); to try again, remove {record.parent / '*.failed'}"]
    monkeypatch.setattr(library, "_announced", set())
    assert native.load(c_text, how="wait") == (None, f"native build failed before: {why}")
    assert native.load(c_text, how="auto") == (None, f"native build failed before: {why}")
    assert calls.read_text() == "x\n"                          # compiled once
    # the background: the detached build remembers; the next run says a new reason, once
    record.unlink()
    fake.write_text(fake.read_text().replace("no room on this disk", "out of memory"))
    note, process = native.build_in_background(c_text)
    assert process is not None and process.wait(timeout=60) == 0
    assert calls.read_text() == "x\nx\n"
    why = "the C compiler failed (error: out of memory)"
    monkeypatch.setattr(library, "_announced", set())
    with pytest.warns(UserWarning, match=re.escape(f"native code not built: {why};")):
        assert native.load(c_text, how="auto") == (None, f"native build failed before: {why}")
    monkeypatch.setattr(library, "_announced", set())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert native.load(c_text, how="auto") == (None, f"native build failed before: {why}")
    assert calls.read_text() == "x\nx\n"


# ------------------------------------------------------------- compilers --

COMPILERS = ["gcc", "clang"]


@pytest.mark.parametrize("cc", COMPILERS)
def test_each_compiler_builds_the_same_bits(cc, tmp_path, monkeypatch):
    """The compile line comes from Python's own build configuration with the
    compiler swapped for $CC; gcc and clang both give the generated Python's bits."""
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed")
    if native.python_include() is None:
        pytest.skip("no Python headers")
    import sysconfig

    import numpy as np

    from anadyn_cli import load_robot
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import recursive

    monkeypatch.setenv("CC", cc)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    line = native.command(native.FLAGS)
    assert line[0] == shutil.which(cc)
    assert set(sysconfig.get_config_var("CCSHARED").split()) <= set(line)
    assert "-shared" in line or "-bundle" in line
    robot = load_robot(ROOT / "robots" / "rrt.yaml")
    gen = recursive.generate(robot)
    code, c_text = recursive.module_source(gen), native.c_source(gen)
    info = RobotInfo.from_robot(robot)
    fast = native.recursive_model(info, code, c_text, how="wait")
    assert isinstance(fast, native.NativeModel), fast.native_note
    slow = native.RecursiveModel(info, code)
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.uniform(-1, 1, 2 * slow.n)
        assert np.array_equal(fast.rhs(0.2, x), slow.rhs(0.2, x))
        assert np.array_equal(fast.jacobian(0.2, x), slow.jacobian(0.2, x))
    others = {c for c in COMPILERS if c != cc and shutil.which(c)}
    for other in others:                          # one library per compiler
        monkeypatch.setenv("CC", other)
        assert native.module_name(c_text) != fast.native.__name__


# ------------------------------------------------------------------- fuzz --

def sealed_json():
    leaves = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20)
    values = st.recursive(leaves, lambda inner: st.lists(inner, max_size=4)
                          | st.dictionaries(st.text(max_size=8), inner, max_size=4),
                          max_leaves=20)
    keys = st.sampled_from(["code", "c", "robot", "digest", "sha256", "why", "reported"])
    entries = st.dictionaries(keys, values, max_size=5)
    return (values | entries).map(lambda v: cache.seal(json.dumps(v).encode()))


def mutated(data: bytes):
    cut = st.integers(0, len(data)).map(lambda k: data[:k])
    flip = st.integers(0, len(data) - 1).map(
        lambda k: data[:k] + bytes([data[k] ^ 0x40]) + data[k + 1:])
    return cut | flip


@pytest.fixture(scope="module")
def honest_entry(genuine) -> tuple[str, bytes]:
    (entry,) = (genuine / "cache").glob("*.json")
    return entry.name, entry.read_bytes()


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzzed_entries_are_misses_or_the_same_result(genuine, honest_entry, tmp_path_factory,
                                                      data):
    """Random bytes, random JSON sealed as anadyn seals it, or the honest entry cut
    or with a byte changed: the run exits 0 with the bytes of a run without the
    cache, and the entry is repaired."""
    name, honest = honest_entry
    content = data.draw(st.binary(max_size=300) | sealed_json() | mutated(honest))
    base = tmp_path_factory.mktemp("fuzz")
    folder = base / "cache"
    folder.mkdir(mode=0o700)
    (folder / name).write_bytes(content)
    library._announced.clear()
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ANADYN_CACHE_DIR", str(folder))
        code = main(["simulate", str(RR), "--t-end", "0.5", "--no-plot", "--out",
                     str(base / "out")])
    assert code == 0
    assert csv(base / "out") == csv(genuine / "reference")
    built(folder)            # a miss is served by the generic kernel, repaired by the build
    assert cache.unseal((folder / name).read_bytes()) is not None


def built(folder: Path) -> None:
    """Wait for the background builds in the cache ``folder`` to end: each holds its
    ``KEY.building`` lock (``numeric.background``) while it runs."""
    import fcntl

    for lock in folder.glob("*.building"):
        with open(lock, "rb") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX)


@needs_compiler
@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzzed_native_records_are_misses(genuine, tmp_path_factory, data):
    """Random contents of a library's record, of the library, or of a failed-build
    record: the library is the honest one or None, and nothing raises."""
    base = tmp_path_factory.mktemp("fuzz-native")
    folder = copy_cache(genuine, base).with_name("cache-native")
    (record,) = folder.glob("*.lib")
    (library_file,) = folder.glob("*.so")
    target = data.draw(st.sampled_from([record, library_file, record.with_suffix(".failed")]))
    honest = target.read_bytes() if target.exists() else cache.seal(b'{"why": "x"}')
    target.write_bytes(data.draw(st.binary(max_size=300) | sealed_json() | mutated(honest)))
    library._announced.clear()
    with pytest.MonkeyPatch.context() as patch, warnings.catch_warnings():
        warnings.simplefilter("ignore")             # the warning lines: tested above
        patch.setenv("ANADYN_CACHE_DIR", str(base / "cache"))
        name = record.name[:-len(".lib")]
        patch.setattr(native.builder, "module_name", lambda c_text: name)
        found = native.library_path("")
        why = native.failed_before(folder, name)
    assert found in (None, library_file)
    if found is not None:
        assert hashlib.sha256(found.read_bytes()).hexdigest()[:16] in found.name
    assert why is None or isinstance(why, str)

