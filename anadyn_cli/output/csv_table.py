"""CSV result tables: a header row, then one row of numbers per time.

Each number is the shortest text that reads back to the same double (Python's
``repr``: 0.08, not 0.080000000000000002; "inf", "-inf", "nan"), never a
negative zero ("0.0").  The rows come from ``csv_rows.c`` (``rows``: one C loop
over ``PyOS_double_to_string``, the function ``float.__repr__`` calls, into one
buffer; 1000 x 193 numbers in ~0.75x the time of the Python path), or, for a
table of fewer than LARGE numbers or when the compiled module is not at hand,
from ``python_rows`` (the text of the table's list, in CPython's own loop),
with the same bytes.

The C is compiled like the generic kernel (``native.load``: the cache's
``-native`` folder, hashed, checked, owner-only), once per installation and
cache folder, in the foreground of the first run that writes a large table
(about 0.1 s, part of that run's write time: no detached build whose cost no
run reports), and loaded once per process (``writer``).  ``ANADYN_NATIVE=0``,
no compiler or a failed build keep ``python_rows``.  bench/cold.py's
``install`` builds it, as an installation's first runs do.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np

from ..files import write_text

__all__ = ["LARGE", "c_text", "csv_text", "python_rows", "rows_text", "write_csv", "writer"]


def c_text() -> str:
    """The writer's C file (module name and init function left as placeholders)."""
    return resources.files(__package__).joinpath("csv_rows.c").read_text(encoding="utf-8")


_WRITER: list = []


def writer(timings: dict | None = None):
    """The compiled writer module, looked for once per process and built the first
    time ever (``native.load``; never under ANADYN_NATIVE=0), or None: then the
    rows are ``python_rows``.  A cache folder others could write gives None too:
    nothing is loaded from it, and the table is written all the same."""
    if not _WRITER:
        from ..numeric import native
        from ..numeric.cache import UntrustedCache

        try:
            module, _ = native.load(c_text(), timings,
                                    "off" if native.mode() == "off" else "wait")
        except UntrustedCache:
            module = None
        _WRITER.append(module)
    return _WRITER[0]


def python_rows(table: np.ndarray) -> str:
    """The rows of a 2-D float table with at least one row and one column, each
    ended by a newline: the text of its list (``repr`` of every float, in
    CPython's loop) with the brackets and spaces taken out; -0.0 + 0.0 is 0.0 (and
    a signaling NaN a quiet one, without a warning)."""
    with np.errstate(invalid="ignore"):
        table = table + 0.0
    return str(table.tolist())[2:-2].replace(", ", ",").replace("],[", "\n") + "\n"


#: tables of fewer numbers are written by ``python_rows`` without looking for the
#: writer: the C saves ~0.12 us a number, finding and loading it costs 1 ms (4-5 ms
#: in a run that has not imported the native builder)
LARGE = 20_000


def rows_text(table: np.ndarray) -> str:
    """The rows of a 2-D float table with at least one row and one column: by the
    compiled writer when the table has LARGE numbers or more and there is one
    (``writer``), else by ``python_rows``."""
    module = writer() if table.size >= LARGE else None
    if module is None:
        return python_rows(table)
    return module.rows(np.ascontiguousarray(table, dtype=float))


def csv_text(header: list[str], columns: list[np.ndarray]) -> str:
    """CSV with a header row and the columns side by side (``rows_text``)."""
    text = ",".join(header) + "\n"
    if columns:
        table = np.column_stack([np.asarray(c, dtype=float) for c in columns])
        if len(table):
            text += rows_text(table)
    return text


def write_csv(path: Path, header: list[str], columns: list[np.ndarray]) -> None:
    """``csv_text`` written to ``path`` whole or not at all (``files.write_text``)."""
    write_text(path, csv_text(header, columns))
