"""The robot library: shipped robots by name, from any folder; a local file wins."""
from __future__ import annotations

import shutil
import sys
import tomllib
from pathlib import Path

import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import library, load_robot
from anadyn_cli.model.yamlsource import read_text

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def elsewhere(tmp_path, monkeypatch):
    """Every test runs in an empty folder, and notices are shown afresh, as in a command
    (the CLI's progress session: a library call prints nothing)."""
    from anadyn_cli import progress

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(library, "_announced", set())
    with progress.session(mode="off"):
        yield


def test_a_library_call_prints_nothing(capsys):
    import anadyn

    with pytest.MonkeyPatch.context() as patch:
        from anadyn_cli import progress
        patch.setattr(progress, "_session", None)
        assert anadyn.load("rrt").name == "rrt"
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("name, file", [
    ("rrt", "robots/rrt.yaml"), ("rrt.yaml", "robots/rrt.yaml"), ("RRT", "robots/rrt.yaml"),
    ("ur5", "robots/ur5.urdf"), ("ur5.urdf", "robots/ur5.urdf"), ("panda", "robots/panda.urdf"),
    ("twodofs", "robots/TwoDofs.urdf"), ("chain6", "configs/chain6.yaml")])
def test_a_name_finds_the_library_robot(name, file, capsys):
    text, source = read_text(name)
    expected = library.find(name)
    assert source == str(expected) and expected.parent.name in ("robots", "configs", "scenes")
    assert expected.name == Path(file).name
    assert capsys.readouterr().err == f"anadyn: {name}: the library's robot, {expected}\n"
    assert "bodies:" in text          # URDFs arrive imported


def test_a_local_file_wins(tmp_path, capsys):
    shutil.copy(ROOT / "robots" / "rr.yaml", tmp_path / "rrt.yaml")
    for given in ("rrt.yaml", "rrt"):
        text, source = read_text(given)
        assert source == "rrt.yaml" and "name: rr" in text
    err = capsys.readouterr().err
    assert err.startswith(f"anadyn: rrt.yaml: the local file rrt.yaml, not the library's "
                          f"{library.find('rrt')}\n")


def test_a_path_with_a_folder_is_never_a_name(capsys):
    assert main(["equations", "robots/rrt.yaml"]) == 2
    assert capsys.readouterr().err == "anadyn: error: robots/rrt.yaml: no such file\n"


def test_unknown_name_is_one_line(capsys):
    assert main(["simulate", "rrx"]) == 2
    assert capsys.readouterr().err == ("anadyn: error: rrx: no such file and no library robot "
                                       "of that name (did you mean 'rr'?); `anadyn robots` "
                                       "lists the library\n")


def test_batch_files_are_not_robots():
    assert library.find("ci") is None and "ci" not in library.entries()


def test_robots_lists_every_library_robot(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("Robots (") and "Test scenes: stress tests" in "\n".join(out)
    assert out[1].split() == ["name", "DOF", "joints", "description"]
    rows = {line.split()[0]: line for line in out
            if line.startswith("  ") and line.split()[0] != "name"}
    assert set(rows) == set(library.entries())
    assert set(rows) >= {"rr", "rrt", "ur5", "panda", "so101", "double_pendulum", "twodofs",
                         "chain6", "stiff_rr_gains1000"}
    assert rows["panda"].split()[1:6] == ["8", "7", "revolute,", "2", "prismatic"]
    assert "(1 mimic)" in rows["panda"] and "Franka Emika Panda" in rows["panda"]
    assert rows["rrt"].split()[1] == "3" and "chapter 6.5" in rows["rrt"]
    assert out[-1].startswith("library: ")


@pytest.mark.parametrize("name", sorted(library.entries()))
def test_every_library_robot_loads(name):
    robot = load_robot(library.find(name))
    assert robot.coordinates and robot.bodies


def test_simulate_a_library_robot_from_anywhere(tmp_path, capsys):
    assert main(["simulate", "double_pendulum", "--t-end", "0.1", "--no-plot", "--no-cache"]) == 0
    captured = capsys.readouterr()
    assert (tmp_path / "results" / "double_pendulum" / "simulate.csv").exists()
    assert f"anadyn: double_pendulum: the library's robot, {library.find('double_pendulum')}" \
        in captured.err


def test_compare_without_robots_uses_the_library(capsys):
    from anadyn_cli.commands.compare import robot_files

    files = robot_files([])
    assert [f.name for f in files] == sorted(p.name for p in (ROOT / "robots").glob("*.yaml"))
    assert "no robots/*.yaml here: comparing the library's" in capsys.readouterr().err


def test_every_package_is_listed_in_pyproject():
    """pyproject.toml lists the packages (the library maps folders onto packages, which
    rules out automatic discovery): a package missing there would be missing from a
    non-editable install."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    found = {".".join(p.parent.relative_to(ROOT).parts)
             for top in ("anadyn", "anadyn_cli") for p in (ROOT / top).rglob("__init__.py")}
    listed, wanted = set(config["packages"]), found | {"anadyn_cli.robots", "anadyn_cli.scenes"}
    assert listed == wanted, (f"pyproject.toml [tool.setuptools] packages: add "
                              f"{sorted(wanted - listed)}, remove {sorted(listed - wanted)}")
    assert config["package-dir"] == {"anadyn_cli.robots": "robots",
                                     "anadyn_cli.scenes": "configs"}


@pytest.mark.slow
def test_the_wheel_carries_the_library(tmp_path):
    """A non-editable install gets robots/ and the scenes, without the batch file."""
    import subprocess
    import zipfile

    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w",
                    str(tmp_path), str(ROOT)], check=True, capture_output=True)
    (wheel,) = tmp_path.glob("anadyn-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for path in (ROOT / "robots").iterdir():
        if path.suffix in (".yaml", ".urdf", ".LICENSE"):
            assert f"anadyn_cli/robots/{path.name}" in names
    assert "anadyn_cli/scenes/chain6.yaml" in names
    assert "anadyn_cli/scenes/ci.yaml" not in names
