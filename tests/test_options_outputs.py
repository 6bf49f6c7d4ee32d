"""Options checked before any work, result files that belong together, exports that
keep their compile promise, and compare's per-robot folders (issue 22 items 10-12,
issue 23 items 4 and 6)."""
from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import sympy as sp

from anadyn_cli import files, progress
from anadyn_cli.cli import main
from anadyn_cli.errors import ALLOWED, Allowed, NumericalError, SettingError, check
from anadyn_cli.model import load_robot
from anadyn_cli.services import export as export_service

ROOT = Path(__file__).resolve().parent.parent
COMPILERS = [c for c in ("gcc", "clang") if shutil.which(c)]
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# -- 1. options: range checked when the command line is read --------------------------------
REFUSED = [
    (["simulate", "--rtol", "1e300"],
     "--rtol must be a number greater than 0 and less than 1, got 1e300"),
    (["simulate", "--rtol", "1"], "--rtol must be a number greater than 0 and less than 1, "
                                  "got 1"),
    (["simulate", "--rtol", "0"], "--rtol must be a number greater than 0 and less than 1, "
                                  "got 0"),
    (["check", "--atol", "1e-320"],
     "--atol must be a number of at least 1e-100 and less than 1 (below it the integrators' "
     "error norms, which square error / atol, overflow), got 1e-320"),
    (["sweep", "--vary", "m2=1,2", "--atol", "2"],
     "--atol must be a number of at least 1e-100 and less than 1 (below it the integrators' "
     "error norms, which square error / atol, overflow), got 2"),
    (["compare", "--seed", "-1"], "--seed must be a whole number from 0 to 4294967295, got -1"),
    (["compare", "--seed", "4294967296"],
     "--seed must be a whole number from 0 to 4294967295, got 4294967296"),
    (["compare", "--samples", "1e23"],
     "--samples must be a whole number from 1 to 1,000,000, got 1e23"),
    (["compare", "--samples", "100000000000000000000000"],
     "--samples must be a whole number from 1 to 1,000,000, got 100000000000000000000000"),
    (["compare", "--tol", "2"], "--tol must be a number greater than 0 and less than 1, got 2"),
    (["accuracy", "--reference-calls", "0"],
     "--reference-calls must be a whole number of at least 100, got 0"),
    (["accuracy", "--repeats", "2.5"], "--repeats must be a whole number of at least 1, got 2.5"),
    (["simulate", "--t-end", "-1"], "--t-end must be a positive number, got -1"),
    (["inverse", "--dt", "nan"], "--dt must be a positive number, got nan"),
    (["animate", "--dt", "abc"], "--dt must be a positive number, got 'abc'"),
    (["check", "--energy-tol", "5"],
     "--energy-tol must be a number greater than 0 and less than 1, got 5"),
    (["check", "--max-condition", "0"], "--max-condition must be a positive number, got 0"),
    (["inverse", "--roundtrip-tol", "0"], "--roundtrip-tol must be a positive number, got 0"),
    (["animate", "--frames", "1"], "--frames must be a whole number of at least 2, got 1"),
    (["sweep", "--vary", "m2=1,2", "--jobs", "0"],
     "--jobs must be a whole number of at least 1, got 0"),
    (["sweep", "--vary", "m2=1,2", "--settle-band", "3"],
     "--settle-band must be a number greater than 0 and less than 1, got 3"),
]


@pytest.mark.parametrize("argv, message", REFUSED, ids=[" ".join(a) for a, _ in REFUSED])
def test_out_of_range_options_are_refused_before_any_work(argv, message, tmp_path, capsys):
    """The robot file does not exist: an option refused before it is even looked for was
    checked before any work.  One line, exit 2, nothing written."""
    command, options = argv[0], argv[1:]
    code, out, err = run(capsys, command, tmp_path / "no_such.yaml", *options,
                         "--out", tmp_path / "out")
    assert (code, err) == (2, f"anadyn: error: {message}\n")
    assert not (tmp_path / "out").exists()


def test_sweep_grid_count_names_its_limit(tmp_path, capsys):
    code, _, err = run(capsys, "sweep", "rr", "--vary", "m2=1:2:1000000000", "--out", tmp_path)
    assert (code, err) == (2, "anadyn: error: --vary m2=1:2:1000000000: the grid's COUNT must "
                              "be a whole number from 1 to 1,000,000, got '1000000000'\n")


def test_the_library_refuses_the_same_values_in_the_same_words():
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric.settings import resolve

    info = RobotInfo.from_robot(load_robot("rr"))
    with pytest.raises(SettingError) as refused:
        resolve(info, rtol=1e300)
    assert str(refused.value) == "rtol must be a number greater than 0 and less than 1, " \
                                 "got 1e+300"
    assert resolve(info, rtol=0.5, atol=1e-100).rtol == 0.5
    with pytest.raises(SettingError, match="^samples must be a whole number from 1 to"):
        check("samples", 0)


@pytest.mark.parametrize("allowed, good, bad", [
    (Allowed(0, 1, low_open=True, high_open=True), [1e-300, 0.5, "0.999"], [0, 1, -1, "inf"]),
    (Allowed(1, 10, whole=True), [1, 10, "1e1", 3.0, 10**1], [0, 11, 2.5, True, "x", "1e400"]),
    (Allowed(0, whole=True), [0, 2**70], [-1, float("nan")]),
])
def test_allowed_accepts_its_range_only(allowed, good, bad):
    for value in good:
        assert allowed.check("x", value) == float(value)
    for value in bad:
        with pytest.raises(SettingError, match=r"^x must be "):
            allowed.check("x", value)
    assert isinstance(allowed.check("x", good[0]), int if allowed.whole else float)


def test_every_ranged_setting_has_a_flag():
    """A setting in errors.ALLOWED without a flag would be checked by the library only,
    after the work; FLAGS gives the command line its check."""
    from anadyn_cli.commands.common import FLAGS

    assert set(ALLOWED) <= set(FLAGS)


def test_defaults_of_ranged_options_are_within_their_range(capsys):
    """Every command still starts with its defaults (the parser checks them too)."""
    from anadyn_cli.commands import COMMANDS

    for command in COMMANDS:
        name = getattr(command, "cli_name", None) or command.__name__.replace("_", "-")
        assert main([name, "--help"]) == 0
    capsys.readouterr()


# -- 2. output folder checked first; the files of a run form one set --------------------------
def test_a_dangling_symlink_out_is_refused_before_any_work(tmp_path, capsys):
    link = tmp_path / "results_link"
    link.symlink_to(tmp_path / "gone")
    code, _, err = run(capsys, "simulate", tmp_path / "no_such.yaml", "--out", link)
    assert code == 2
    assert err == (f"anadyn: error: --out {link}: is a symbolic link to {tmp_path / 'gone'}, "
                   "which does not exist; give an existing folder or a new name\n")
    code, _, err = run(capsys, "compare", tmp_path / "no_such.yaml", "--out", link)
    assert code == 2 and "is a symbolic link to" in err      # compare's own --out too


def test_the_default_results_folder_is_checked_first(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("results").write_text("not a folder")
    code, _, err = run(capsys, "simulate", "no_such.yaml")
    assert (code, err) == (2, "anadyn: error: output folder results: is a file, expected a "
                              "folder\n")


def _exported(formulation: str):
    return export_service.export(load_robot("rr"), "python", formulation)


def _consistent(folder: Path) -> str:
    """The formulation the folder's export.json names, after checking that every file
    it lists is the one that run wrote (same size and the same formulation inside)."""
    figures = json.loads((folder / "export.json").read_text())
    for name, size in figures["files"].items():
        text = (folder / name).read_text()
        assert len(text.encode()) == size["bytes"], name
        method = {"kane": "Kane's method", "lagrange": "Lagrange's equations"}
        assert method[figures["formulation"]] in text.splitlines()[0], name
    return figures["formulation"]


def test_two_runs_into_one_folder_leave_the_files_of_one(tmp_path, monkeypatch):
    """Run A writes its code file, then pauses; run B writes all of its files; then A
    writes its JSON.  File by file (the old way) that left B's code beside A's JSON; as
    one set, A's files go in place together after B's."""
    kane, lagrange = _exported("kane"), _exported("lagrange")
    paused, resume = threading.Event(), threading.Event()
    write_json = files.write_json

    def slow_json(path, data):
        if data["formulation"] == "kane":
            paused.set()
            assert resume.wait(30)
        write_json(path, data)

    monkeypatch.setattr(files, "write_json", slow_json)
    first = threading.Thread(target=export_service.write, args=(kane, tmp_path))
    first.start()
    assert paused.wait(30)
    export_service.write(lagrange, tmp_path)
    assert _consistent(tmp_path) == "lagrange"
    resume.set()
    first.join(30)
    assert _consistent(tmp_path) == "kane"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no leftovers


def test_concurrent_processes_into_one_folder(tmp_path):
    """Two real runs at once: whatever order they finish in, the folder holds one run."""
    commands = [[sys.executable, "-m", "anadyn_cli", "export", "rr", "--lang", "python",
                 "--formulation", formulation, "--out", str(tmp_path)]
                for formulation in ("kane", "lagrange")]
    running = [subprocess.Popen(c, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=ROOT)
               for c in commands]
    assert [p.wait(120) for p in running] == [0] * len(running)
    assert _consistent(tmp_path) in ("kane", "lagrange")


def test_a_set_that_fails_leaves_the_earlier_files(tmp_path):
    files.write_text(tmp_path / "a.csv", "old a\n")
    files.write_text(tmp_path / "a.json", "old json\n")
    with pytest.raises(RuntimeError):
        with files.file_set():
            files.write_text(tmp_path / "a.csv", "new a\n")
            raise RuntimeError("a bug between the CSV and the JSON")
    assert (tmp_path / "a.csv").read_text() == "old a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "a.json"]
    with pytest.raises(NumericalError):          # the run's own verdict keeps its files
        with files.file_set():
            files.write_text(tmp_path / "a.partial.csv", "rows before the failure\n")
            raise NumericalError("blow-up")
    assert (tmp_path / "a.partial.csv").read_text() == "rows before the failure\n"


# -- 3. exports: user text cannot break the code; C compiles for every robot ---------------
NASTY_FOLDER = "we*/ird/*x\nline??/"


@pytest.fixture
def nasty_rr(tmp_path) -> Path:
    folder = tmp_path / NASTY_FOLDER
    folder.mkdir(parents=True)
    path = folder / "rr.yaml"
    path.write_text((ROOT / "robots" / "rr.yaml").read_text())
    return path


@pytest.mark.skipif(not COMPILERS, reason="no C compiler")
def test_c_comments_survive_any_path(nasty_rr, tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["export", str(nasty_rr), "--lang", "c", "--out", str(out)]) == 0
    for compiler in COMPILERS:
        done = subprocess.run([compiler, *STRICT, "-Wcomment", "-c", str(out / "rr.c"),
                               "-o", str(tmp_path / f"{compiler}.o")],
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    first = (out / "rr.c").read_text().splitlines()[1]
    assert first.endswith("/we* /ird/ *x\\nline? ?/rr.yaml), by Kane's method, parameters "
                          "folded in; generated by anadyn 0.1.0.")


def test_python_and_matlab_exports_keep_a_path_in_their_comments(nasty_rr, tmp_path, capsys):
    assert main(["export", str(nasty_rr), "--lang", "python", "--out", str(tmp_path)]) == 0
    module = ast.parse((tmp_path / "rr.py").read_text())
    doc = ast.get_docstring(module)
    assert f"({nasty_rr.parent}/rr.yaml)".replace("\n", "\\n") in doc.splitlines()[0]
    assert main(["export", str(nasty_rr), "--lang", "matlab", "--out", str(tmp_path)]) == 0
    for path in tmp_path.glob("*.m"):        # the path stays inside its % comment line
        lines = path.read_text().splitlines()
        assert [line for line in lines if "rr.yaml" in line and not line.startswith("%")] == []
        assert any("x\\nline??/rr.yaml)" in line for line in lines), path.name


def test_user_text_is_one_printable_line():
    """Controls escaped; a byte of a file name that was not UTF-8 shown as that byte."""
    from anadyn_cli.errors import printable

    assert printable("a\nb\tc\x00d\udcff é") == "a\\nb\\tc\\x00d\\xff é"


def test_temporaries_nothing_reads_are_dropped():
    """cse left an unused temporary in the UR5's partials (C: unused variable 'w455')."""
    from anadyn_cli.output.export.model import _needed

    x, y, z = sp.symbols("x y z")
    w0, w1, w2 = sp.symbols("w0 w1 w2")
    temps = [(w0, x + y), (w1, 2 * w0), (w2, sp.sin(z))]
    assert _needed(temps, [w1 + 1]) == [(w0, x + y), (w1, 2 * w0)]


def test_export_reports_its_stages(monkeypatch):
    monkeypatch.setattr(progress, "PLAIN_DELAY", 0.0)
    monkeypatch.setattr(progress, "PLAIN_EVERY", 0.0)
    monkeypatch.setattr(progress, "TICK", 0.001)
    seen = []
    real = progress.Task.note

    def note(self, detail):
        seen.append((self.description, detail))
        real(self, detail)

    monkeypatch.setattr(progress.Task, "note", note)
    export_service.export(load_robot("rr"), "c")
    assert seen[0] == ("generating the c files of rr", "the Jacobian's partial derivatives")
    assert ("generating the c files of rr", "K (2 x 4): common subexpressions and code") in seen


def _export_cases():
    """Every open-chain robot of the library (export refuses closed loops, tested in
    test_export) but G1 (35 speeds: generating its closed forms did not finish in 25
    minutes on a loaded 2-core machine, where Solo12's 18 speeds take about 30 s) and
    every test URDF."""
    import yaml

    from anadyn_cli.model import library

    def exported(path):
        data = yaml.safe_load(path.read_text()) if path.suffix == ".yaml" else {}
        return not {"loops", "constraints"} & set(data) and path.stem != "g1_free"

    urdfs = sorted((ROOT / "tests" / "data" / "urdf").glob("*.urdf"))
    names = sorted(name for name, path in library.entries().items() if exported(path))
    quick = {"rr", "rrt", "twodofs"}
    return ([pytest.param(n, marks=() if n in quick else pytest.mark.slow) for n in names]
            + [pytest.param(str(p), id=p.name, marks=pytest.mark.slow) for p in urdfs])


@pytest.mark.skipif(not COMPILERS, reason="no C compiler")
@pytest.mark.parametrize("robot", _export_cases())
def test_every_robot_exports_to_c_that_compiles_strictly(robot, tmp_path):
    robot = load_robot(robot)
    assert robot.constraints is None
    for symbolic in (False, True):
        result = export_service.export(robot, "c", symbolic=symbolic)
        folder = tmp_path / str(symbolic)
        export_service.write(result, folder)
        for compiler in COMPILERS:
            done = subprocess.run([compiler, *STRICT, "-c", str(folder / f"{result.model.name}.c"),
                                   "-o", str(folder / f"{compiler}.o")],
                                  capture_output=True, text=True)
            assert done.returncode == 0, f"{compiler}: {done.stderr[:2000]}"


# -- 4. compare writes results/<robot>/ ---------------------------------------------------------
def test_compare_writes_each_robot_to_its_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    quick = ["--samples", "5", "--symbolic-terms", "0", "--t-end", "0.2"]
    code, out, _ = run(capsys, "compare", "rr", *quick)
    assert code == 0 and out.splitlines()[-1] == ("wrote results/rr/compare.csv, "
                                                  "results/rr/compare.json")
    code, out, _ = run(capsys, "compare", "rr", "rrt", *quick)
    assert code == 0
    assert sorted(str(p) for p in Path("results").rglob("*.*")) == [
        "results/rr/compare.csv", "results/rr/compare.json",
        "results/rrt/compare.csv", "results/rrt/compare.json"]
    assert json.loads(Path("results/rrt/compare.json").read_text())["robots_compared"] == 1
    code, out, _ = run(capsys, "compare", "rr", "rrt", *quick, "--out", "elsewhere")
    assert code == 0 and sorted(p.parent.name for p in Path("elsewhere").glob("*/compare.json")
                                ) == ["rr", "rrt"]
