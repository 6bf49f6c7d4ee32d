"""The Python API (issue 21): every command is a function of ``import anadyn`` that
never prints, and every number says what computed it (formulation and evaluator)."""
from __future__ import annotations

import inspect
import json
from pathlib import Path

import numpy as np
import pytest

import anadyn
from anadyn_cli.cli import main
from anadyn_cli.commands import COMMANDS

REPO = Path(__file__).resolve().parent.parent
RR, RRT, FOURBAR = (REPO / "robots" / f"{n}.yaml" for n in ("rr", "rrt", "fourbar"))


@pytest.fixture(autouse=True)
def _nothing_printed(capsys):
    """No function of the API prints (stdout or stderr)."""
    yield
    assert capsys.readouterr() == ("", "")


# -- one function per command --------------------------------------------------------------
def test_every_command_is_a_function_with_a_documented_signature():
    names = {getattr(c, "cli_name", c.__name__) for c in COMMANDS}
    api = {"import": "import_urdf"}
    for name in names:
        function = getattr(anadyn, api.get(name, name))
        doc = inspect.getdoc(function)
        assert doc and ":returns:" in doc, name
        for parameter in inspect.signature(function).parameters:
            assert f":param {parameter}:" in doc, f"{name}({parameter})"
    for name in ("load", "derive", "numeric_model"):
        assert ":returns:" in inspect.getdoc(getattr(anadyn, name))


def test_load_overrides_parameters_without_writing_a_file():
    heavy = anadyn.load("rr", parameters={"m2": 3.0, "L2": "2*L1"})
    plain = anadyn.load(RR)
    values = {str(k): v for k, v in heavy.parameter_substitution().items()}
    assert (values["m2"], values["L2"], values["m1"]) == (3, 2, 1)
    assert heavy.digest != plain.digest                   # the cache tells them apart
    # the override reaches the numbers: the static efforts scale with m2 and L2
    at_rest = anadyn.inverse(heavy, roundtrip=False, output_step=15).efforts[0]
    plain_rest = anadyn.inverse(plain, roundtrip=False, output_step=15).efforts[0]
    assert at_rest[1] == pytest.approx(plain_rest[1] * 6)         # T12z = m2 g L2/2 cos q2


def test_load_refuses_a_parameter_the_file_does_not_define():
    with pytest.raises(anadyn.ModelError, match=r"rr\.yaml.*the file defines no mass "
                                                r"\(it defines: L1, L2, m1, m2, g\)"):
        anadyn.load(RR, parameters={"mass": 1.0})
    with pytest.raises(anadyn.ModelError, match="bodies\\[0\\]\\.mass: must be positive"):
        anadyn.load(RR, parameters={"m1": -1})
    with pytest.raises(anadyn.ModelError, match="not to a loaded Robot"):
        anadyn.load(anadyn.load(RR), parameters={"m1": 2})


def test_simulate_inverse_check_keep_rows_as_times(tmp_path):
    run = anadyn.simulate("rr", t_end=0.2, output_step=0.1)
    assert run.t.tolist() == pytest.approx([0, 0.1, 0.2]) and run.x.shape == (3, 4)
    assert run.to_csv(tmp_path / "run.csv").read_text().startswith("t,q1,q2,dq1,dq2,")
    motion = anadyn.inverse(RR, roundtrip=False, output_step=5.0)
    assert motion.t.tolist() == [0, 5, 10, 15] and motion.efforts.shape == (4, 2)
    report = anadyn.check(RR, t_end=0.5, samples=5)
    assert report.x.shape == (len(report.t), 4) and report.passed
    with pytest.raises(anadyn.SettingError, match="^roundtrip_segment must be a positive"):
        anadyn.inverse(RR, roundtrip_segment=-1)


def test_equations_and_derive():
    text = anadyn.equations(RR, "lagrange", matrices=True)
    # the chapter's (6.23): M11 = (1/3 + 1) m L^2, M12 = m L^2/2 cos(q1 - q2)
    assert "M[1,1] = 1.3333333\nM[1,2] = 0.5*cos(q1 - q2)\n" in text
    eom = anadyn.derive(RR, "lagrange", symbolic=True)
    assert eom.M.shape == (2, 2) and eom.symbolic
    assert anadyn.equations(RR, fmt="latex").rstrip().endswith(r"\end{document}")


def test_compare_and_accuracy():
    assert anadyn.compare(RR, samples=5, symbolic_terms=0, t_end=0.5).passed
    study = anadyn.accuracy(RR, methods=["rk45", "DOP853"], tolerances=[1e-4], repeats=1,
                            t_end=0.5)
    assert {r.method for r in study.rows} == {"RK45", "DOP853"}
    assert study.computation == {"formulation": None, "evaluator": "recursive",
                                 "code": study.computation["code"]}
    assert study.computation["code"].startswith(("generated Python", "native C",
                                                 "generic kernel"))


def test_export_writes_only_into_the_given_folder(tmp_path):
    result = anadyn.export(RR, "python")
    assert "rr.py" in result.files and not any(tmp_path.iterdir())
    anadyn.export(RR, "c", out=tmp_path / "c")
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["export.json", "rr.c", "rr.h"]


def test_linearize():
    lin = anadyn.linearize(RR, at="q1=0, q2=0, dq1=0, dq2=0", efforts="zero")
    assert lin.A.shape == (4, 4) and lin.B.shape == (4, 2)
    assert lin.controllability_rank == 4


def test_sweep_runs_each_sample():
    result = anadyn.sweep(RR, ["m2=1,2"], t_end=0.2, jobs=1)
    assert [row["status"] for row in result.rows] == ["ok", "ok"]


def test_batch_writes_its_reports_into_out(tmp_path):
    config = tmp_path / "mini.yaml"
    config.write_text(f"jobs:\n  - command: simulate\n    robot: {RR}\n"
                      "    options: [--no-plot, --t-end, '0.1']\n"
                      "    expect:\n      equal: {success: true}\n")
    result = anadyn.batch(config, tmp_path / "out", jobs=1)
    assert result.failed == [] and [r.status for r in result.results] == ["ok"]
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["jobs"][0]["ok"]


def test_inverse_of_a_measured_motion_equals_the_files_own(tmp_path):
    """The file's trajectory written as a CSV with its rates and accelerations and read
    back as measured data gives the same efforts (the same points, exact derivatives)."""
    planned = anadyn.inverse(RR, roundtrip=False, output_step=0.5)
    planned.to_csv(tmp_path / "motion.csv")
    measured = anadyn.inverse(RR, roundtrip=False, motion=tmp_path / "motion.csv")
    assert np.array_equal(measured.t, planned.t)
    assert np.abs(measured.efforts - planned.efforts).max() <= 1e-12 * np.abs(
        planned.efforts).max()


def test_import_urdf_locks_joints():
    """A locked joint is no coordinate of the imported robot; the others stay."""
    whole = anadyn.import_urdf("ur5")
    locked = anadyn.import_urdf("ur5", lock={"wrist_3_joint": "pi/4"})
    assert "wrist_3_joint" in whole.data["coordinates"]
    assert "wrist_3_joint" not in locked.data["coordinates"]
    assert len(locked.data["coordinates"]) == len(whole.data["coordinates"]) - 1


def test_view_is_a_page_and_writes_only_when_asked(tmp_path):
    page = anadyn.view(RR)
    assert "<html" in page.html().lower() and page.name == "rr"
    assert list(tmp_path.iterdir()) == []
    anadyn.view(RR, out=tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["view.html", "view.json"]


def test_show_animate_import_robots(tmp_path):
    drawing = anadyn.show(RR, at={"q1": 0.3})
    assert drawing.q[0] == pytest.approx(0.3) and drawing.figure() is not None
    animation = anadyn.animate(RR, t_end=0.2, frames=2)
    assert len(animation.images) == 2 and animation.computation["evaluator"] == "recursive"
    imported = anadyn.import_urdf("TwoDofs", out=tmp_path / "two.yaml")
    assert (tmp_path / "two.yaml").read_text() == imported.text
    assert "rr" in {entry.name for entry in anadyn.robots()}


# -- formulation and evaluator -------------------------------------------------------------
@pytest.mark.parametrize("robot, formulation, evaluator, ran", [
    (RR, None, None, (None, "recursive")),
    (RR, "lagrange", None, ("lagrange", "closed-form")),
    (RR, "kane", None, ("kane", "closed-form")),
    (RR, None, "closed-form", ("kane", "closed-form")),
    (RR, None, "recursive", (None, "recursive")),
    (FOURBAR, None, None, ("kane", "closed-form")),
])
def test_the_model_says_what_computes_it(robot, formulation, evaluator, ran):
    model = anadyn.numeric_model(robot, formulation, evaluator)
    assert (model.formulation, model.evaluator) == ran


def test_kanes_closed_forms_and_the_recursions_are_two_computations_that_agree():
    recursive = anadyn.numeric_model(RRT)
    closed = anadyn.numeric_model(RRT, "kane")
    assert "inverse_dynamics" in recursive.source and "inverse_dynamics" not in closed.source
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, dq = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
        for a, b in zip(recursive.mfb(0.0, q, dq), closed.mfb(0.0, q, dq)):
            assert np.allclose(np.asarray(a, float), np.asarray(b, float), rtol=1e-12,
                               atol=1e-9)


@pytest.mark.parametrize("argv, message", [
    (["simulate", str(FOURBAR), "--evaluator", "recursive"],
     "--evaluator recursive needs an open tree; fourbar has closed loops (constraints): use "
     "closed-form, the default there"),
    (["simulate", str(RR), "--evaluator", "recursive", "--formulation", "kane"],
     "--evaluator recursive derives no symbolic equations; drop the formulation (kane) or "
     "use closed-form"),
])
def test_an_impossible_choice_is_one_line_and_exit_2(argv, message, tmp_path, capsys):
    assert main([*argv, "--out", str(tmp_path), "--no-cache"]) == 2
    assert capsys.readouterr() == ("", f"anadyn: error: {message}\n")
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("options, ran", [
    ([], {"formulation": None, "evaluator": "recursive"}),
    (["--formulation", "lagrange"], {"formulation": "lagrange", "evaluator": "closed-form"}),
    (["--evaluator", "closed-form"], {"formulation": "kane", "evaluator": "closed-form"}),
])
def test_every_json_records_what_ran(options, ran, tmp_path, capsys):
    runs = {"simulate": ["--t-end", "0.2", "--no-plot"],
            "inverse": ["--dt", "5", "--no-roundtrip", "--no-plot"],
            "check": ["--t-end", "0.5", "--samples", "5"]}
    for command, extra in runs.items():
        assert main([command, str(RR), *options, *extra, "--out", str(tmp_path),
                     "--no-cache"]) == 0, command
        figures = json.loads((tmp_path / f"{command}.json").read_text())
        assert {k: figures[k] for k in ran} == ran, command
    capsys.readouterr()


def test_the_closed_form_commands_record_it_too(tmp_path, capsys):
    assert main(["export", str(RR), "--lang", "python", "--out", str(tmp_path)]) == 0
    assert main(["linearize", str(RR), "--formulation", "lagrange", "--out",
                 str(tmp_path)]) == 0
    capsys.readouterr()
    for name, formulation in (("export", "kane"), ("linearize", "lagrange")):
        figures = json.loads((tmp_path / f"{name}.json").read_text())
        assert (figures["formulation"], figures["evaluator"]) == (formulation, "closed-form")
