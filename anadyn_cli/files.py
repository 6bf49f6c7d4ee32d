"""Result files, written whole or not at all.

Each file goes to a temporary name in the same folder, is flushed to disk and
then renamed over its target (``os.replace`` is atomic on one file system),
so a failed or interrupted run never leaves a half-written file or clobbers
an earlier good one.  Files get the permissions the user's umask gives any new
file (0644 under the usual 022), not the temporary file's private 0600.
Plots are drawn by ``output.plots`` and written here as bytes.
"""
from __future__ import annotations

import json
import os
import tempfile
import threading
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


def file_mode() -> int:
    """The mode a new file gets from the user's umask (0o666 & ~umask)."""
    global _FILE_MODE
    if _FILE_MODE is None:
        with _UMASK_LOCK:
            if _FILE_MODE is None:
                _FILE_MODE = 0o666 & ~_umask()
    return _FILE_MODE


_FILE_MODE: int | None = None
_UMASK_LOCK = threading.Lock()


def _umask() -> int:
    """The process umask, read without changing it where the system tells it."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)          # elsewhere: set and restore, once per process
    os.umask(mask)
    return mask


def _write_atomically(path: Path, data: bytes) -> None:
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(handle, file_mode())     # mkstemp makes 0600; results are for everyone the
        with os.fdopen(handle, "wb") as stream:   # umask allows
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
    """CSV with a header row; each number as the shortest text that reads back to
    the same double (Python's ``repr``: 0.08, not 0.080000000000000002), and
    never a negative zero."""
    lines = [",".join(header)]
    if columns:
        table = np.column_stack([np.asarray(c, dtype=float) for c in columns]) + 0.0
        lines += [",".join(map(float.__repr__, row)) for row in table.tolist()]
    return "\n".join(lines) + "\n"


def write_csv(path: Path, header: list[str], columns: list[np.ndarray]) -> None:
    write_text(path, csv_text(header, columns))
