"""What a warm run no longer redoes (issue 25), each with the same output:

- a URDF imported by an earlier run (same bytes, name and reading options) is
  read from the cache, its import warnings said again;
- generated code is compiled once: its code object is kept in the cache folder
  (sealed, as every cache file: a damaged one is a warning and is rebuilt), and
  only while the derivation cache is in use;
- plain command-line values are read without Pydantic, as typer reads them;
- OpenBLAS runs on one thread unless the user chose.
"""
from __future__ import annotations

import os
import subprocess
import sys
from enum import Enum
from pathlib import Path

import pytest

from anadyn_cli.cli import main
from anadyn_cli.numeric import cache

ROOT = Path(__file__).resolve().parent.parent


def test_an_imported_urdf_is_not_parsed_again(tmp_path, monkeypatch, capsys):
    from anadyn_cli.model import library, urdf
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    library._announced.clear()       # warnings said earlier in this process: said again
    command = ["simulate", str(ROOT / "robots/double_pendulum.urdf"), "--fix-base",
               "--t-end", "0.05", "--no-plot", "--out"]
    assert main([*command, str(tmp_path / "first")]) == 0
    first = capsys.readouterr().err
    assert "--fix-base: no floating or planar joint" in first

    def no_import(*args, **kwargs):
        raise AssertionError("the URDF was imported again")
    monkeypatch.setattr(urdf, "import_urdf", no_import)
    library._announced.clear()                  # said again, as by a new process
    assert main([*command, str(tmp_path / "second")]) == 0
    second = capsys.readouterr().err
    assert [w for w in second.splitlines() if "warning" in w] == \
        [w for w in first.splitlines() if "warning" in w]
    assert ((tmp_path / "second/simulate.csv").read_bytes()
            == (tmp_path / "first/simulate.csv").read_bytes())
    assert main(["simulate", str(ROOT / "robots/double_pendulum.urdf"), "--t-end", "0.05",
                 "--no-plot", "--out", str(tmp_path / "third")]) == 4   # other options
    assert "the URDF was imported again" in capsys.readouterr().err


def test_code_objects_are_kept_only_under_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    source = "def f(x):\n    return 2 * x + 1\n"
    cache.compiled(source, "<test>")
    assert not (tmp_path / "cache").exists()     # no cache in use: nothing written
    with cache.keeping_code():
        first = cache.compiled(source, "<test>")
        (stored,) = (tmp_path / "cache").glob("*" + cache.CODE)
        kept = cache.compiled(source, "<test>")            # read back
    for code in (first, kept):
        namespace = {}
        exec(code, namespace)                                      # noqa: S102
        assert namespace["f"](3) == 7
    assert kept.co_consts == compile(source, "<test>", "exec").co_consts


def test_a_damaged_code_object_is_a_warning(tmp_path, monkeypatch, recwarn):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    source = "X = 5\n"
    with cache.keeping_code():
        cache.compiled(source, "<test>")
        (stored,) = (tmp_path / "cache").glob("*" + cache.CODE)
        data = stored.read_bytes()
        stored.write_bytes(data[:-2] + bytes([data[-2] ^ 1]) + data[-1:])
        namespace = {}
        exec(cache.compiled(source, "<test>"), namespace)           # noqa: S102
    assert namespace["X"] == 5
    assert any("compiled code" in str(w.message) and "damaged" in str(w.message)
               for w in recwarn)
    assert stored.read_bytes() == data                    # rebuilt


class Color(str, Enum):
    red = "red"
    blue = "blue"


@pytest.mark.parametrize("annotation, value", [
    (float, "1"), (float, "-.5e+2"), (float, "1e400"), (float, "007"), (float, 0.25),
    (float, "x"), (float, "1_0"), (float, " 2"), (int, "12"), (int, "-0"), (int, "1.5"),
    (int, 4), (str, "text"), (Path, "a/b.csv"), (Path, ""), (Color, "BLUE"),
    (Color, Color.red), (Color, "green")])
def test_plain_values_are_typers(annotation, value):
    """``PlainValue`` gives typer's value, or typer's own message."""
    import typer
    from typer._coercion import build_runtime_param, resolve_type_descriptor
    from typer.models import OptionInfo

    from anadyn_cli.plain_options import PlainValue

    info = OptionInfo(case_sensitive=False)
    descriptor = resolve_type_descriptor(annotation, info)

    class Param:
        multiple, nargs = False, 1

        def get_error_hint(self, ctx=None):
            return "'--x'"

    def outcome(runtime):
        try:
            return runtime.coerce(value, param=Param(), ctx=None)
        except typer.BadParameter as err:
            return ("error", err.format_message())
    ours, theirs = outcome(PlainValue(descriptor)), outcome(build_runtime_param(descriptor))
    assert ours == theirs and type(ours) is type(theirs)


def test_a_warm_command_imports_no_pydantic(tmp_path):
    script = ("import sys; from anadyn_cli.cli import main; "
              f"code = main(['simulate', {str(ROOT / 'robots/rr.yaml')!r}, '--t-end', '0.01', "
              f"'--no-plot', '--out', {str(tmp_path)!r}]); "
              "print(code, 'pydantic' in sys.modules)")
    env = {"PATH": "/usr/bin:/bin", "ANADYN_CACHE_DIR": str(tmp_path / "cache"),
           "ANADYN_NATIVE": "0", "ANADYN_PROGRESS": "off", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env=env, timeout=120)
    assert done.stdout.split()[-2:] == ["0", "False"], done.stderr


def test_openblas_runs_on_one_thread_unless_the_user_chose(monkeypatch):
    """Set before NumPy loads OpenBLAS: the command line's modules do not import it."""
    from anadyn_cli import cli
    for name in cli.BLAS_THREADS:
        monkeypatch.delenv(name, raising=False)
    cli._one_blas_thread()
    assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    monkeypatch.delenv("OPENBLAS_NUM_THREADS")
    monkeypatch.setenv("OMP_NUM_THREADS", "4")
    cli._one_blas_thread()
    assert "OPENBLAS_NUM_THREADS" not in os.environ
    done = subprocess.run([sys.executable, "-c", "import sys; import anadyn_cli.__main__, "
                           "anadyn_cli.cli; print('numpy' in sys.modules)"],
                          capture_output=True, text=True, timeout=60,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT)})
    assert done.stdout.strip() == "False", done.stderr
