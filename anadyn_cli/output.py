"""Result files, written whole or not at all.

Each file goes to a temporary name in the same folder, is flushed to disk and
then renamed over its target (``os.replace`` is atomic on one file system),
so a failed or interrupted run never leaves a half-written file or clobbers
an earlier good one.  Plots use Matplotlib's Agg backend (no display).
"""
from __future__ import annotations

import io
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from .errors import ModelError


class WriteError(ModelError, OSError):
    """A result file cannot be written: one line and exit 2 for the user, and
    still an OSError for callers that skip what they cannot write (the cache)."""


def check_dir(out: Path, label: str = "--out") -> None:
    """Say in one line, before any work, why ``out`` cannot take results: a
    file, or a folder that cannot be written or created.  Creates nothing."""
    out = Path(out)
    try:
        if out.exists() and not out.is_dir():
            raise ModelError(f"{label} {out}: is a file, expected a folder")
        existing = out
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent      # the folder that would hold the new ones
    except OSError as err:                  # e.g. a name too long, a folder we may not see
        raise ModelError(f"{label} {out}: cannot use it as a folder ({err.strerror})") from None
    if not existing.is_dir():
        raise ModelError(f"{label} {out}: cannot create the folder, {existing} is a file")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ModelError(f"{label} {out}: " + ("folder is not writable" if existing == out else
                                               f"cannot create the folder, {existing} is not "
                                               "writable"))


def prepare_dir(out: Path) -> Path:
    """Create the output folder, or say in one line why it cannot be used."""
    out = Path(out)
    check_dir(out, "output folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ModelError(f"output folder {out}: cannot create it ({err.strerror}); "
                         "give a folder that can be created or written with --out") from None
    return out


def write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically; ModelError (one line) if the folder refuses."""
    path = Path(path)
    try:
        _write_atomically(path, data)
    except OSError as err:
        raise WriteError(f"cannot write {path}: {err.strerror or err}; earlier results there "
                         "are left as they were") from None


def _write_atomically(path: Path, data: bytes) -> None:
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_text(path: Path, text: str) -> None:
    write_bytes(path, text.encode("utf-8"))


def write_json(path: Path, data: dict) -> None:
    """A command's key figures (read by ``anadyn batch``)."""
    write_text(path, json.dumps(data, indent=2, sort_keys=True, default=float) + "\n")


def csv_text(header: list[str], columns: list[np.ndarray]) -> str:
    """CSV with a header row; numbers in full double precision (%.17g)."""
    table = np.column_stack([np.asarray(c, dtype=float) for c in columns]) if columns else []
    buffer = io.StringIO()
    buffer.write(",".join(header) + "\n")
    np.savetxt(buffer, table, fmt="%.17g", delimiter=",")
    return buffer.getvalue()


def write_csv(path: Path, header: list[str], columns: list[np.ndarray]) -> None:
    write_text(path, csv_text(header, columns))


def write_plot(path: Path, t: np.ndarray, panels: list[tuple[str, list[tuple[str, np.ndarray]]]],
               title: str) -> None:
    """One panel per (y label, [(legend, values)]), sharing the time axis."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    figure = Figure(figsize=(7, 1.9 * len(panels) + 0.6), layout="constrained")
    axes = figure.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (label, series) in zip(axes, panels):
        for name, values in series:
            ax.plot(t, values, label=name, linewidth=1.2)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.4)
        if len(series) > 1:
            ax.legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("t (s)")
    figure.suptitle(title)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110)
    write_bytes(path, buffer.getvalue())
