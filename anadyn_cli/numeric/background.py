"""The robot's own code, built in a detached process while the generic kernel
serves a cold run (``generic.first_run``): one build per robot at a time, its
cost reported by the next run, a failure said once and not retried.

Beside the derivation cache entry ``KEY.json`` (``cache.key``) a build uses

    KEY.building   an empty file on which the build holds an exclusive lock
                   (flock) while it runs: a run that cannot take the lock leaves
                   the build alone; a build that dies loses its lock with it
    KEY.build      sealed {"cpu_s", "wall_s", "failed", "note"}: the build's CPU
                   time (its own and its compiler's) and its wall time from the
                   fork to its end; why it failed (None: the entry is stored); a
                   note when the entry is stored but its C was not built

The next run reports the cost once (``report``: ``background_build_cpu`` and
``background_build_wall`` in its timings, so in its ``<command>.json`` and its
time line) and says the failure or the note once, in one warning line.  A
failed build keeps its record, so later runs are served by the kernel without
forking again, until the record is removed (or anadyn changes: another key).
A C library that did not build is remembered by the native build itself
(``native.failed_before``).
"""
from __future__ import annotations

import os
import time

from . import cache

#: the lock file and the record beside the cache entry KEY.json
LOCK, RECORD = ".building", ".build"
_OPEN = os.O_WRONLY | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


def _cpu() -> float:
    """CPU seconds of this process and of the children it waited for."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def start(entry: str, work, fork) -> str:
    """Run ``work()`` (the robot's own code, generated, compiled and stored under
    the cache entry ``entry``; it returns None, or a note on why its C was not
    built) through ``fork(job)`` unless a build of ``entry`` is running or has
    failed: what becomes of the robot's own code, in words for the run's note."""
    folder = cache.trusted_folder(cache.directory(), create=True)
    if folder is None:
        return "is not built (the cache folder cannot be written)"
    record = cache.read_record(folder, entry + RECORD, "background build record")
    if isinstance(record, dict) and isinstance(record.get("failed"), str):
        return (f"failed to build before ({record['failed']}); to try again, remove "
                f"{folder / (entry + RECORD)}")
    try:
        fd = os.open(folder / (entry + LOCK), _OPEN, 0o600)
    except OSError as err:
        return f"is not built (the cache folder cannot be written: {err.strerror or err})"
    try:
        import fcntl

        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return "is being built by an earlier run"
    started = time.monotonic()
    try:
        fork(lambda: _job(folder, entry, work, started))
    finally:
        os.close(fd)                    # the forked build holds the lock until it ends
    return "is built for the next run"


def _job(folder, entry: str, work, started: float) -> None:
    """The build: ``work()``, then its record (cost, and why it failed)."""
    before = _cpu()
    failed = note = None
    try:
        note = work()
    except Exception as err:            # noqa: BLE001  recorded, said once by the next run
        failed = f"{type(err).__name__}: {err}"
    record = {"cpu_s": _cpu() - before, "wall_s": time.monotonic() - started,
              "failed": failed, "note": note}
    try:
        cache.write_record(folder, entry + RECORD, record)
    except OSError:
        pass


def report(entry: str, name: str, timings: dict) -> None:
    """Once per build of the cache entry ``entry`` (robot ``name``): its cost into
    ``timings`` and, when it failed or its C was not built, one warning line.  The
    record of a build that stored its entry is removed; a failed one is kept
    (marked said), so that no run retries it."""
    folder = cache.trusted_folder(cache.directory(), create=False)
    if folder is None:
        return
    record = cache.read_record(folder, entry + RECORD, "background build record")
    if not (isinstance(record, dict) and not record.get("said")
            and all(isinstance(record.get(k), (int, float)) for k in ("cpu_s", "wall_s"))):
        return
    failed, note = record.get("failed"), record.get("note")
    try:
        if isinstance(failed, str):
            cache.write_record(folder, entry + RECORD, {**record, "said": True})
        else:
            os.remove(folder / (entry + RECORD))
    except OSError:                     # another run has reported it
        return
    timings["background_build_cpu"] = float(record["cpu_s"])
    timings["background_build_wall"] = float(record["wall_s"])
    if isinstance(failed, str):
        cache.warn(f"the background build of {name}'s own code failed ({failed}); runs use "
                   f"the generic kernel; to try again, remove {folder / (entry + RECORD)}")
    elif isinstance(note, str):
        cache.warn(f"{name}'s own code was built in the background without its C library: "
                   f"{note}")
