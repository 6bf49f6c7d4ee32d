"""How results show themselves in Jupyter (IPython's rich display protocol).

``Displayed`` is a mixin for result classes that have ``table()`` (the CSV's
header and columns) and ``figure()``: ``_repr_html_`` is a caption, the
first and last rows and each column's minimum and maximum; ``_repr_png_``
is the figure at 100 dpi.  Nothing is written to disk and the global
Matplotlib backend is not touched.
"""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .csv_table import write_csv

HEAD = TAIL = 3


def table_html(caption: str, header: list[str], columns: list, head: int = HEAD,
               tail: int = TAIL) -> str:
    """An HTML table: the first ``head`` and last ``tail`` rows, then min and max."""
    data = np.column_stack([np.asarray(c, dtype=float) for c in columns]) if columns \
        else np.zeros((0, len(header)))
    count = len(data)
    shown = list(range(count)) if count <= head + tail else \
        [*range(head), None, *range(count - tail, count)]
    cell = lambda v: f"<td>{v:.6g}</td>"                                   # noqa: E731
    lines = [f"<table><caption>{html.escape(caption)}</caption>",
             "<tr><th></th>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>"]
    for k in shown:
        if k is None:
            lines.append(f"<tr><th>…</th><td colspan=\"{len(header)}\">"
                         f"{count - head - tail} more rows</td></tr>")
        else:
            lines.append(f"<tr><th>{k}</th>" + "".join(cell(v) for v in data[k]) + "</tr>")
    if count:
        for name, values in (("min", data.min(axis=0)), ("max", data.max(axis=0))):
            lines.append(f"<tr><th>{name}</th>" + "".join(cell(v) for v in values) + "</tr>")
    return "\n".join(lines + ["</table>"])


class Displayed:
    """Mixin: ``to_csv`` and ``_repr_html_`` from ``table()``, ``_repr_png_`` from
    ``figure()``."""

    def to_csv(self, path) -> Path:
        """Write the command's CSV columns (``table()``) to ``path``, whole or not at all."""
        write_csv(Path(path), *self.table())
        return Path(path)

    def _repr_html_(self) -> str:
        header, columns = self.table()
        rows = len(columns[0]) if columns else 0
        caption = f"{self.robot.name}: {type(self).__name__}, {rows} rows x {len(header)} columns"
        return table_html(caption, header, columns)

    def _repr_png_(self) -> bytes:
        from .plots import figure_bytes

        return figure_bytes(self.figure(), "png", dpi=100)
