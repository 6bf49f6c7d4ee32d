"""Result files, written whole or not at all.

Each file goes to a temporary name in the same folder, is flushed to disk and
then renamed over its target (``os.replace`` is atomic on one file system),
so a failed or interrupted run never leaves a half-written file or clobbers
an earlier good one.  Files get the permissions the user's umask gives any new
file (0644 under the usual 022), not the temporary file's private 0600.
Plots are drawn by ``output.plots`` and written here as bytes, CSV tables
formatted by ``output.csv_table`` and written here as text.

The files of one run can form a set (``file_set``; a service's ``write``
decorated with ``one_set``): all are written to temporary names first and
renamed into place together at the end, in the order written (the JSON of key
figures last), under an exclusive lock on each folder, so two runs into one
``--out`` leave every file of one run or the other, never the CSV of one
beside the JSON of the other.
"""
from __future__ import annotations

import contextvars
import functools
import json
import os
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

from .errors import CheckFailed, ModelError, NumericalError
from .progress import uninterrupted

try:
    import fcntl
except ImportError:          # not POSIX: the renames of a set are not serialized
    fcntl = None


class WriteError(ModelError, OSError):
    """A result file cannot be written: one line and exit 2 for the user, and
    still an OSError for callers that skip what they cannot write (the cache)."""


def check_dir(out: Path, label: str = "--out") -> None:
    """Say in one line, before any work, why ``out`` cannot take results: a
    file, or a folder that cannot be written or created.  Creates nothing."""
    out = Path(out)
    try:
        if out.is_symlink() and not out.exists():
            raise ModelError(f"{label} {out}: is a symbolic link to {os.readlink(out)}, which "
                             "does not exist; give an existing folder or a new name")
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
        staged = _SET.get()
        if staged is None:
            os.replace(temporary, path)
        else:
            staged.add(Path(temporary), path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


class _Staged:
    """The files of a set so far: (temporary file, target) in the order written."""

    def __init__(self):
        self.files: dict[Path, Path] = {}          # target -> its temporary file

    def add(self, temporary: Path, target: Path) -> None:
        earlier = self.files.pop(target, None)     # written twice: the last one counts
        if earlier is not None:
            earlier.unlink(missing_ok=True)
        self.files[target] = temporary

    def commit(self) -> None:
        """Rename every file into place, holding an exclusive lock on each folder; a
        signal meanwhile stops the command only after the last rename
        (``progress.uninterrupted``), so a set is never half in place."""
        with uninterrupted():
            self._commit()

    def _commit(self) -> None:
        folders = sorted({target.parent for target in self.files}, key=str)
        locks = []
        try:
            for folder in folders:          # always in the same order: no deadlock
                locks.append(_lock_folder(folder))
            for target, temporary in self.files.items():
                os.replace(temporary, target)
            for lock in locks:
                if lock is not None:
                    os.fsync(lock)          # the renames are on disk before the lock goes
        except OSError as err:
            self.discard()
            raise WriteError(f"cannot put the results in place in "
                             f"{', '.join(map(str, folders))}: {err.strerror or err}") from None
        finally:
            for lock in locks:
                if lock is not None:
                    os.close(lock)          # closing releases the lock
        self.files.clear()

    def discard(self) -> None:
        for temporary in self.files.values():
            temporary.unlink(missing_ok=True)
        self.files.clear()


_SET: contextvars.ContextVar[_Staged | None] = contextvars.ContextVar("anadyn_file_set",
                                                                        default=None)


def _lock_folder(folder: Path) -> int | None:
    """An open descriptor of ``folder`` holding its exclusive lock (None without flock)."""
    if fcntl is None:
        return None
    handle = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX)
    except OSError:
        os.close(handle)
        raise
    return handle


@contextmanager
def file_set():
    """Files written in this block (in this thread) form one set: each is written
    whole to a temporary name beside its target, and at the end of the block all
    are renamed into place, in the order written, while an exclusive lock
    (``flock``) is held on each of their folders; another run's set goes in
    wholly before or after.  If the block raises, nothing is put in place and
    earlier files stay, unless the error is the run's own verdict
    (NumericalError, CheckFailed): the files written before it (a partial CSV)
    are its result and are put in place.  A block inside another joins it."""
    if _SET.get() is not None:
        yield
        return
    staged = _Staged()
    token = _SET.set(staged)
    try:
        yield
    except (NumericalError, CheckFailed):
        _SET.reset(token)
        staged.commit()
        raise
    except BaseException:
        _SET.reset(token)
        staged.discard()
        raise
    _SET.reset(token)
    staged.commit()


def one_set(write):
    """Decorator for a service's ``write``: the files it writes form one set
    (``file_set``)."""
    @functools.wraps(write)
    def written(*args, **kwargs):
        with file_set():
            return write(*args, **kwargs)
    return written


def write_text(path: Path, text: str) -> None:
    write_bytes(path, text.encode("utf-8"))


def write_json(path: Path, data: dict) -> None:
    """A command's key figures (read by ``anadyn batch``)."""
    write_text(path, json.dumps(data, indent=2, sort_keys=True, default=float) + "\n")
