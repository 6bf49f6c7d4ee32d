"""`anadyn linearize`'s recursive evaluator on the generic kernel (``numeric.generic``,
compiled once per installation) and on the derivatives generated for the robot
(``numeric.derivatives``): the same point, ddq, A, B, A_closed_loop and rank to
1e-10 relative on rr (a controller: closed-loop A), rrt, the double pendulum, the
UR5, the Panda (a mimic finger), anadyn_features.urdf (a chain of mimic joints with
offsets and multipliers: theta = A q + c, A not square) and rr_drives (gears, rotors
and a controller); the kernel road generates no code; the generated road serves
what the kernel cannot (ANADYN_GENERIC=0, external loads) and says why.
Pinocchio's agreement, on both roads: tests/test_linearize_roads.py.

Independent sources: the kernel is a hand-written C implementation of the
recursions reading the robot's numeric tables; the generated road traces the
recursions symbolically for this robot and differentiates them analytically (or in
forward mode); they share the plan of the robot (``recursive.plan``) and nothing
else.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main
from anadyn_cli.model import load_robot, robot_from_text
from anadyn_cli.numeric import derivatives
from anadyn_cli.services import linearize as service

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_linearize import pendulum  # noqa: E402
from test_linearize_roads import (assert_same_numbers, kernel_road, points,  # noqa: E402
                                  robot_of)

REPO = Path(__file__).resolve().parent.parent
MIMIC = REPO / "tests" / "data" / "urdf" / "anadyn_features.urdf"
DRIVES = REPO / "robots" / "drives" / "rr_drives.yaml"


def robot(name: str):
    """test_linearize_roads' robots, the mimic URDF, the geared arm and a passive
    pendulum (no actuator)."""
    if name == "pendulum":
        return robot_from_text(pendulum(), "pendulum.yaml")
    return load_robot({"mimic": MIMIC, "drives": DRIVES}[name]) if name in ("mimic", "drives") \
        else robot_of(name)


def both(monkeypatch, r, **options):
    """(by the kernel, by the generated derivatives) of ``service.linearize(r, **options)``."""
    kernel_road(monkeypatch)
    kernel = service.linearize(r, **options)
    monkeypatch.setenv("ANADYN_GENERIC", "0")
    generated = service.linearize(r, **options)
    monkeypatch.delenv("ANADYN_GENERIC")
    assert (kernel.evaluator, kernel.formulation, kernel.code) == ("recursive", None,
                                                                   "generic kernel")
    assert generated.code == "generated Python (the generic kernel is off: ANADYN_GENERIC=0)"
    return kernel, generated


@pytest.mark.parametrize("name, count", [("rr.yaml", 3), ("rrt.yaml", 2), ("double", 2),
                                         ("pendulum", 1), ("mimic", 2), ("drives", 2),
                                         ("ur5.urdf", 2), ("panda.urdf", 2)])
def test_the_kernel_and_the_generated_derivatives_agree(name, count, monkeypatch):
    r = robot(name)
    for at in [None, *points(r, count, seed=11)]:
        kernel, generated = both(monkeypatch, r, at=at)
        assert_same_numbers(kernel, generated)
        assert kernel.has_controller == (r.controller is not None)


@pytest.mark.parametrize("name, efforts", [("rr.yaml", "holding"), ("rr.yaml", "zero"),
                                           ("mimic", "holding"), ("pendulum", "auto")])
def test_the_efforts_and_the_equilibrium_search_agree(name, efforts, monkeypatch):
    r = robot(name)
    assert_same_numbers(*both(monkeypatch, r, efforts=efforts))
    kernel, generated = both(monkeypatch, r, equilibrium=True,
                             efforts="zero" if efforts == "holding" else efforts)
    assert kernel.point.searched and kernel.point.equilibrium
    assert_same_numbers(kernel, generated, 1e-9)


def test_a_cold_run_on_the_kernel_generates_no_code(monkeypatch, tmp_path, capsys):
    kernel_road(monkeypatch)

    def refused(*_, **__):
        raise AssertionError("code generated")

    monkeypatch.setattr(derivatives, "generate", refused)
    from anadyn_cli.numeric.native import builder
    monkeypatch.setattr(builder, "build", refused)
    monkeypatch.setattr(builder, "build_in_background", refused)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))    # nothing cached
    assert main(["linearize", str(MIMIC), "--out", str(tmp_path / "o")]) == 0
    assert capsys.readouterr().out.startswith(
        "anadyn_features (recursive Newton-Euler, generic kernel) at")
    figures = json.loads((tmp_path / "o" / "linearize.json").read_text())
    assert (figures["evaluator"], figures["formulation"], figures["code"]) == (
        "recursive", None, "generic kernel")
    # the cache holds the URDF's import and the kernel's record (for the next run),
    # nothing of the robot's code
    assert sorted(p.suffix for p in (tmp_path / "cache").iterdir()) == [".json", ".kernel"]
    assert not (tmp_path / "cache-native").exists()


def test_a_second_run_reads_the_urdfs_import_from_the_cache(monkeypatch, tmp_path):
    """As the commands that run a model do, linearize files a URDF's import under the
    cache and reads it back the next time (no XML parsed), with the same results."""
    from anadyn_cli.model import urdf
    kernel_road(monkeypatch)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["linearize", str(MIMIC), "--out", str(tmp_path / "first")]) == 0

    def no_import(*args, **kwargs):
        raise AssertionError("the URDF was imported again")
    monkeypatch.setattr(urdf, "import_urdf", no_import)
    assert main(["linearize", str(MIMIC), "--out", str(tmp_path / "second")]) == 0
    for name in ("linearize_A.csv", "linearize_B.csv"):
        assert (tmp_path / "second" / name).read_bytes() == (tmp_path / "first" / name).read_bytes()
    assert main(["linearize", str(MIMIC), "--no-cache", "--out", str(tmp_path / "third")]) == 0
    assert ((tmp_path / "third/linearize_A.csv").read_bytes()
            == (tmp_path / "first/linearize_A.csv").read_bytes())


def test_what_the_kernel_cannot_serve_runs_the_generated_derivatives(monkeypatch):
    """External loads (test_export's "forced" arm): the tables cannot hold them."""
    kernel_road(monkeypatch)
    r = robot_of("forced")
    result = service.linearize(r, at="q1=0.2,s=0.1,dq1=0.3")
    assert result.code == "generated Python (external loads)"
    assert np.all(np.isfinite(result.A))


#: a joint that moves an inertia of 1e-18 about its axis (and its mass along it): M is
#: positive definite in exact arithmetic, singular to working precision (cond ~1e17)
SPIN = """\
name: spin
gravity: [0, -9.81, 0]
coordinates: {a: {initial: 0.2}, b: {initial: 0.1}}
bodies:
  - {name: one, joint: {type: revolute, axis: [0, 0, 1]}, mass: 1, com: [0.5, 0, 0]}
  - {name: two, parent: one, joint: {type: revolute, axis: [1, 0, 0], origin: [1, 0, 0]},
     mass: 1, com: [0.3, 0, 0], inertia: {ixx: 1e-18, iyy: 0.01, izz: 0.01}}
"""


@pytest.mark.parametrize("options", [[], ["--formulation", "kane"]])
@pytest.mark.parametrize("generic", ["1", "0"])
def test_a_mass_matrix_singular_to_working_precision_is_refused_by_every_road(
        options, generic, monkeypatch, tmp_path, capsys):
    """Rounding decides whether a Cholesky factorization of such an M succeeds (iCub's
    differs between the roads); every road refuses it alike, exit 3."""
    kernel_road(monkeypatch)
    monkeypatch.setenv("ANADYN_GENERIC", generic)
    path = tmp_path / "spin.yaml"
    path.write_text(SPIN)
    assert main(["linearize", str(path), *options, "--out", str(tmp_path / "o")]) == 3
    assert capsys.readouterr().err == (
        "anadyn: error: the mass matrix is singular or not positive definite at t = 0 s, "
        "(a = 0.2, b = 0.1, da = 0, db = 0)\n")
    assert not (tmp_path / "o").exists()


#: an arm with no parameters and no controller, springs, dampers, friction and a
#: prismatic joint: its kernel record serves the runs after the first
PLAIN = """\
name: plain
gravity: [0, 0, -9.81]
coordinates: {a: {initial: 0.3, rate: 0.2}, b: {initial: -0.4}, s: {initial: 0.1}}
actuators: {T1: {joint: one}, T2: {joint: two}, F3: {joint: slide}}
bodies:
  - {name: one, joint: {type: revolute, axis: [0, 0, 1], damping: 0.3}, mass: 2,
     com: [0.2, 0.1, 0], inertia: {ixx: 0.02, iyy: 0.03, izz: 0.04}}
  - {name: two, parent: one, joint: {type: revolute, axis: [0, 1, 0], origin: [0.5, 0, 0.1],
     stiffness: 4, rest: 0.2, friction: 0.1}, mass: 1.5, com: [0.3, 0, 0]}
  - {name: slide, parent: two, joint: {type: prismatic, axis: [1, 0, 0], origin: [0.6, 0, 0]},
     mass: 0.5, com: [0.05, 0, 0]}
"""


def _files(folder: Path) -> dict:
    """A linearization's files, linearize.json without its timings."""
    figures = json.loads((folder / "linearize.json").read_text())
    figures.pop("timings")
    return {"json": figures, **{p.name: p.read_bytes() for p in folder.glob("*.csv")}}


def _no_robot_read(monkeypatch) -> None:
    """From here on, reading a robot, planning its recursions or importing a URDF fails."""
    import anadyn_cli.model as model
    from anadyn_cli.model import urdf
    from anadyn_cli.numeric import recursive

    def refused(*_, **__):
        raise AssertionError("the robot was read")
    for module, name in ((model, "robot_from_text"), (recursive, "plan"),
                         (urdf, "import_urdf")):
        monkeypatch.setattr(module, name, refused)


@pytest.mark.parametrize("name, options", [
    *((name, options) for name in ("plain", "mimic", "ur5", "double")
      for options in ([], ["--at"], ["--efforts", "zero"])),
    ("double", ["--equilibrium", "--efforts", "zero"]), ("ur5", ["--efforts", "holding"])])
def test_runs_after_the_first_are_served_by_the_kernels_record_with_the_same_files(
        name, options, monkeypatch, tmp_path):
    """The first run keeps the kernel's tables beside the cache entry; the next runs
    linearize from them without reading the robot, and every file is the same, to
    the bit, as a run that reads the robot (--no-cache)."""
    path = {"mimic": MIMIC, "ur5": REPO / "robots" / "ur5.urdf",
            "double": REPO / "robots" / "double_pendulum.urdf"}.get(name)
    if path is None:
        path = tmp_path / "plain.yaml"
        path.write_text(PLAIN)
    if options == ["--at"]:                      # every coordinate and a rate
        names = [c.name for c in robot_from_text(*_text(path)).coordinates]
        options = ["--at", ",".join(f"{c}=0.1*{k + 1}" for k, c in enumerate(names))
                   + f",d{names[0]}=-pi/7"]
    kernel_road(monkeypatch)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    run = ["linearize", str(path), *options, "--out"]
    assert main([*run, str(tmp_path / "first")]) == 0
    assert any(p.suffix == ".kernel" for p in (tmp_path / "cache").iterdir())
    assert main([*run, str(tmp_path / "unread"), "--no-cache"]) == 0
    _no_robot_read(monkeypatch)
    for folder in ("second", "third"):
        assert main([*run, str(tmp_path / folder)]) == 0
        assert _files(tmp_path / folder) == _files(tmp_path / "unread") == _files(
            tmp_path / "first")


def _text(path: Path) -> tuple[str, str]:
    from anadyn_cli.model.yamlsource import read_text
    return read_text(path)


def test_a_simulations_first_run_leaves_the_record_linearize_reads(monkeypatch, tmp_path):
    kernel_road(monkeypatch)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["simulate", str(MIMIC), "--t-end", "0.01", "--no-plot",
                 "--out", str(tmp_path / "s")]) == 0
    assert main(["linearize", str(MIMIC), "--no-cache", "--out", str(tmp_path / "read")]) == 0
    _no_robot_read(monkeypatch)
    assert main(["linearize", str(MIMIC), "--out", str(tmp_path / "recorded")]) == 0
    assert _files(tmp_path / "recorded") == _files(tmp_path / "read")


@pytest.mark.parametrize("file, options, why", [
    ("rr.yaml", [], "a controller and parameters"),
    ("plain", ["--symbolic"], "symbolic"),
    ("plain", ["--formulation", "kane"], "closed forms"),
    ("plain", ["--evaluator", "closed-form"], "closed forms"),
    ("params", [], "parameters"),
    ("laws", [], "a controller"),
    ("plain", ["ANADYN_GENERIC=0"], "no kernel")])
def test_what_the_record_does_not_hold_reads_the_robot(file, options, why, monkeypatch,
                                                        tmp_path):
    """Control laws (their Jacobian is symbolic), parameters (``at`` may name them),
    the symbolic form and the closed forms need the robot: it is read on every run."""
    import anadyn_cli.model as model

    kernel_road(monkeypatch)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    path = REPO / "robots" / file
    if file in ("plain", "params", "laws"):
        path = tmp_path / f"{file}.yaml"
        path.write_text({"plain": PLAIN,
                         "params": PLAIN.replace("name: plain", "name: params\nparameters: {m: 2}")
                         .replace("mass: 2,", "mass: m,"),
                         "laws": PLAIN + "controller:\n  gains: {k: 3}\n  laws: {T1: -k*a, "
                                         "T2: -k*db, F3: 0}\n"}[file])
    assert main(["linearize", str(path), "--out", str(tmp_path / "first")]) == 0
    reads = []
    read = model.robot_from_text
    monkeypatch.setattr(model, "robot_from_text", lambda *a, **k: reads.append(1) or read(*a, **k))
    if options == ["ANADYN_GENERIC=0"]:
        monkeypatch.setenv("ANADYN_GENERIC", "0")
        options = []
    assert main(["linearize", str(path), *options, "--out", str(tmp_path / "second")]) == 0
    assert reads == [1], why


def test_a_damaged_record_is_a_miss_said_once(monkeypatch, tmp_path, capsys):
    kernel_road(monkeypatch)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "plain.yaml"
    path.write_text(PLAIN)
    assert main(["linearize", str(path), "--out", str(tmp_path / "first")]) == 0
    record = next(p for p in (tmp_path / "cache").iterdir() if p.suffix == ".kernel")
    data = bytearray(record.read_bytes())
    data[-5] ^= 1
    record.write_bytes(bytes(data))
    capsys.readouterr()
    assert main(["linearize", str(path), "--out", str(tmp_path / "second")]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "first-run record" in err and "damaged" in err, err
    assert _files(tmp_path / "second") == _files(tmp_path / "first")
