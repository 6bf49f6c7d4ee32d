"""CSV tables (``output.csv_table``, issue 25): the compiled writer (``csv_rows.c``)
and the Python path give the same bytes for any doubles, the C is taken when it is
at hand and the Python path under ANADYN_NATIVE=0, for small tables and with an
untrusted cache folder, and a command's CSV reads back to the doubles of its result."""
from __future__ import annotations

import numpy as np
import pytest

import anadyn
from anadyn_cli.cli import main
from anadyn_cli.output import csv_table

SPECIAL = [0.0, -0.0, np.inf, -np.inf, np.nan, -np.nan, 1e-300, -1e-300, 1e16, -1e16, 1e-5,
           1e-4, 9.999999999999999e-05, 123456789012345678.0, 1234567890123456.7, 5e-324,
           -5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, 0.1, 0.08, 1.0, -1.0,
           1e15 + 0.3, 1e22, 1 / 3, -2 / 3]


@pytest.fixture(scope="module")
def compiled():
    """The compiled writer, built in this session's cache (skipped without a compiler)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(csv_table, "_WRITER", [])
        patch.delenv("ANADYN_NATIVE", raising=False)       # the tests' 0 lifted
        module = csv_table.writer()
    if module is None:
        pytest.skip("no C compiler or Python headers: the CSV writer cannot be built")
    return module


@pytest.fixture
def taken(compiled, monkeypatch):
    """The compiled writer in use for tables of any size, its tables recorded as they
    are written."""
    tables = []

    class Recording:
        @staticmethod
        def rows(table):
            tables.append(table.shape)
            return compiled.rows(table)

    monkeypatch.setattr(csv_table, "_WRITER", [Recording])
    monkeypatch.setattr(csv_table, "LARGE", 1)
    return tables


def random_doubles(rng, count: int) -> np.ndarray:
    """Every bit pattern as likely: all magnitudes, subnormals, infinities, NaNs, -0.0."""
    return rng.integers(0, 2**64, size=count, dtype=np.uint64, endpoint=False).view(float)


def test_c_and_python_rows_are_the_same_bytes(compiled):
    rng = np.random.default_rng(25)
    patterns = random_doubles(rng, 60_000)
    finite = patterns[np.isfinite(patterns)]
    scaled = rng.uniform(-1, 1, 30_000) * 10.0 ** rng.integers(-30, 30, 30_000)
    tables = [patterns.reshape(-1, 60), finite[: len(finite) // 7 * 7].reshape(-1, 7),
              scaled.reshape(-1, 1), scaled.reshape(1, -1), np.array(SPECIAL).reshape(1, -1),
              np.array(SPECIAL).reshape(-1, 1), np.array([[0.0]]), np.array([[-0.0]])]
    for table in tables:
        assert compiled.rows(table) == csv_table.python_rows(table)
    text = compiled.rows(np.array(SPECIAL).reshape(1, -1))
    assert text.startswith("0.0,0.0,inf,-inf,nan,nan,1e-300,-1e-300,1e+16,-1e+16,1e-05,0.0001,")
    assert "-0.0" not in text and text.count("\n") == 1


def test_the_rows_of_any_table_read_back(taken):
    """Non-contiguous tables (a transposed or strided view) are copied first; the text
    reads back to the same doubles (NaN to NaN, -0.0 to 0.0)."""
    rng = np.random.default_rng(7)
    base = random_doubles(rng, 12_000).reshape(200, 60)
    for table in (base.T, base[::3, ::2], np.asfortranarray(base)):
        text = csv_table.csv_text([f"c{k}" for k in range(table.shape[1])], list(table.T))
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(csv_table, "_WRITER", [None])
            assert csv_table.csv_text([f"c{k}" for k in range(table.shape[1])],
                                      list(table.T)) == text
        back = np.array([[float(v) for v in line.split(",")] for line in text.splitlines()[1:]])
        assert np.array_equal(back, np.where(table == 0, 0.0, table), equal_nan=True)
        assert not np.signbit(back[back == 0]).any()
    assert taken == [(60, 200), (67, 30), (200, 60)]


def test_empty_tables(compiled, monkeypatch):
    assert compiled.rows(np.zeros((0, 4))) == compiled.rows(np.zeros((3, 0))) == ""
    monkeypatch.setattr(csv_table, "LARGE", 1)
    for writer in ([compiled], [None]):
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(csv_table, "_WRITER", writer)
            assert csv_table.csv_text(["t", "x"], []) == "t,x\n"
            assert csv_table.csv_text(["t", "x"], [np.array([]), np.array([])]) == "t,x\n"
            assert csv_table.csv_text([], []) == "\n"
            assert csv_table.csv_text(["t"], [np.array([2.5])]) == "t\n2.5\n"


def test_the_writer_refuses_what_is_not_a_table_of_doubles(compiled):
    for wrong in (np.zeros(3), np.zeros((2, 2), dtype=np.float32), np.zeros((2, 2), dtype=int),
                  np.zeros((2, 2, 2)), b"12345678"):
        with pytest.raises(TypeError, match="2-D C-contiguous array of doubles"):
            compiled.rows(wrong)
    with pytest.raises((ValueError, BufferError)):
        compiled.rows(np.zeros((4, 4))[:, ::2])       # not contiguous: rows_text copies it


def test_a_command_writes_its_csv_with_the_c_writer(taken, repo, tmp_path):
    """``anadyn inverse`` writes inverse.csv through the compiled writer; the file reads
    back with NumPy to the doubles of the library's result, and the Python path
    writes the same bytes."""
    assert main(["inverse", str(repo / "robots" / "rr.yaml"), "--no-plot",
                 "--out", str(tmp_path)]) == 0
    assert len(taken) == 1 and taken[0][0] > 100
    written = (tmp_path / "inverse.csv").read_text()
    header, columns = anadyn.inverse(repo / "robots" / "rr.yaml").table()
    assert written.splitlines()[0] == ",".join(header)
    assert np.array_equal(np.loadtxt(tmp_path / "inverse.csv", delimiter=",", skiprows=1),
                          np.column_stack(columns))
    assert len(taken) == 1                     # .table() wrote nothing
    csv_table._WRITER[:] = [None]
    assert csv_table.csv_text(header, columns) == written


def test_the_python_path_under_native_off(monkeypatch, tmp_path):
    """ANADYN_NATIVE=0 (the tests' default): no writer is looked for or built, the
    rows come from ``python_rows``."""
    monkeypatch.setenv("ANADYN_NATIVE", "0")
    monkeypatch.setattr(csv_table, "_WRITER", [])
    calls = []
    python_rows = csv_table.python_rows
    monkeypatch.setattr(csv_table, "python_rows", lambda table: calls.append(table.shape)
                        or python_rows(table))
    rows = csv_table.LARGE // 2
    csv_table.write_csv(tmp_path / "a.csv", ["t", "x"], [np.arange(rows, dtype=float),
                                                         -np.zeros(rows)])
    assert (tmp_path / "a.csv").read_text().startswith("t,x\n0.0,0.0\n1.0,0.0\n2.0,0.0\n")
    assert calls == [(rows, 2)] and csv_table._WRITER == [None]


def test_small_tables_do_not_look_for_the_writer(monkeypatch):
    """Below LARGE numbers the Python rows are cheaper than finding the writer."""
    looked = []
    monkeypatch.setattr(csv_table, "writer", lambda: looked.append(1))
    small = np.ones((csv_table.LARGE // 2 - 1, 2))
    assert csv_table.csv_text(["a", "b"], list(small.T)) == "a,b\n" + "1.0,1.0\n" * len(small)
    assert looked == []
    csv_table.csv_text(["a", "b"], list(np.ones((csv_table.LARGE // 2, 2)).T))
    assert looked == [1]


def test_an_untrusted_cache_folder_leaves_the_python_path(monkeypatch, tmp_path):
    """The writer is loaded from no folder others could write; the table is written."""
    from anadyn_cli.numeric import cache, native

    def untrusted(*args):
        raise cache.UntrustedCache("cache folder: others can write it")

    monkeypatch.setattr(native, "load", untrusted)
    monkeypatch.setattr(csv_table, "_WRITER", [])
    text = csv_table.csv_text(["t"], [np.full(csv_table.LARGE, -0.0)])
    assert text == "t\n" + "0.0\n" * csv_table.LARGE and csv_table._WRITER == [None]
