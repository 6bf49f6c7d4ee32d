"""One helper for each small text job (issue 21): ``errors.shorten`` cuts text for a
one-line message, ``model.text.split_items`` splits a typed list at its outer
commas; and the sweep package keeps one job a module, its settings refused by
their library names."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from anadyn_cli.cli import main
from anadyn_cli.errors import SettingError, shorten
from anadyn_cli.model.text import split_items

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "anadyn_cli"
RR = ROOT / "robots" / "rr.yaml"
RRT = ROOT / "robots" / "rrt.yaml"


def test_shorten_cuts_to_the_limit_with_three_dots():
    assert shorten("x" * 60) == "x" * 60
    assert shorten("x" * 61) == "x" * 57 + "..."
    assert len(shorten("y" * 500, 40)) == 40 and shorten("y" * 500, 40).endswith("y...")
    assert shorten(12345, 4) == "1..."
    assert shorten(10 ** 5000) == "a huge number"     # str() refuses it


def test_split_items_splits_at_outer_commas_only():
    assert split_items("a, (b,c) ,[d, e]", "at") == ["a", " (b,c) ", "[d, e]"]
    assert split_items("1,,2", "vary") == ["1", "", "2"]
    assert split_items("", "at") == [""]
    for text, reason in (("q=[1,2", "'q=[1,2': unbalanced brackets"),
                         ("1),2", "'1),2': unbalanced ')'")):
        with pytest.raises(SettingError) as err:
            split_items(text, "at")
        assert (err.value.setting, err.value.reason) == ("at", reason)


def test_one_truncator_and_one_splitter_in_the_package():
    truncations = re.compile(r"\[[^\]\n]*:[^\]\n]*\]\s*\+\s*\"\.\.\.\"")
    splitters = re.compile(r"def _?split\w*\(")
    found = {path.relative_to(PACKAGE).as_posix(): (len(truncations.findall(text)),
                                                    len(splitters.findall(text)))
             for path in PACKAGE.rglob("*.py") for text in [path.read_text(encoding="utf-8")]}
    assert {p: n for p, (n, _) in found.items() if n} == {"errors.py": 1}
    assert {p: n for p, (_, n) in found.items() if n} == {"model/text.py": 1}


def test_a_sweep_list_with_an_unbalanced_parenthesis_is_one_line(capsys, tmp_path):
    code = main(["sweep", str(RR), "--vary", "m2=1,(2", "--out", str(tmp_path / "out")])
    assert (code, capsys.readouterr().err) == (
        2, "anadyn: error: --vary '1,(2': unbalanced brackets\n")
    assert not (tmp_path / "out").exists()


def test_the_sweep_package_has_one_job_a_module():
    for path in sorted((PACKAGE / "studies" / "sweep").glob("*.py")):
        text = path.read_text(encoding="utf-8")
        assert len(text.splitlines()) <= 500, path.name
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef):
                assert node.end_lineno - node.lineno < 80, f"{path.name}: {node.name}"


@pytest.mark.parametrize("command, settings, setting", [
    ("inverse", {"rtol": 1e-6}, "rtol"),
    ("inverse", {"max_condition": 10.0}, "max_condition"),
    ("check", {"method": "RK45"}, "method"),
    ("inverse", {"output_step": 20.0}, "output_step"),
])
def test_a_sweep_refuses_a_setting_by_its_library_name(command, settings, setting):
    """The CLI words these as flags (``--rtol applies to ...``, tests/test_sweep.py)."""
    from anadyn_cli.studies import sweep

    with pytest.raises(SettingError) as err:
        sweep.plan(RRT, ["m3=1,2"], command, **settings)
    assert err.value.setting == setting


def test_a_sweep_plan_names_an_unknown_setting():
    from anadyn_cli.studies import sweep

    with pytest.raises(TypeError, match="unexpected setting 'dt'"):
        sweep.plan(RR, ["m2=1,2"], dt=0.1)
