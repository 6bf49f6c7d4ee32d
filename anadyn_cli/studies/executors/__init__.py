"""Where the pieces of a sweep (or a batch) run: this process, local processes, or Dask.

A ``Work`` names what every worker needs once (``payload``, turned into a
worker-side state by ``setup``) and what each piece does with it
(``work(state, piece) -> result``).  ``setup`` and ``work`` are module-level
functions, so they travel by reference; the payload travels once per worker
process, never once per piece:

    local, --jobs 1     this process; the state is built once
    local, --jobs J     J processes (fork where available), the payload handed
                        over when each starts, the state built on its first piece
    Dask                ``--scheduler ADDRESS`` or $ANADYN_SCHEDULER: the payload
                        goes to every worker (and to workers that join later)
                        as a worker plugin; each worker thread builds its own
                        state on its first piece and keeps it

Every wait on a Dask scheduler is bounded: connecting (TCP connect, Dask's
handshake and the client's registration, all told) and each request must be
answered within ``ANSWER_TIMEOUT`` s; while no result comes, the scheduler is
asked every ``ALIVE_EVERY`` s whether it still answers and has workers (none
for ``NO_WORKERS_TIMEOUT`` s ends the run).  Each of these is a ``ModelError``
(one line, exit 2) naming the address.

An interruption (any BaseException while waiting: ``progress.Interrupted``
from SIGINT or SIGTERM, KeyboardInterrupt) stops the local worker processes
at once (SIGTERM, SIGKILL ``STOP_GRACE`` s later; they ignore SIGINT
themselves, since a terminal's Ctrl-C reaches the whole process group and the
main process ends them) and cancels the pieces on Dask.

Commands (``run_commands``: a batch's jobs, each a ``Command``: an argv and a
timeout) run as local processes, up to ``jobs`` at a time, each in a process
group of its own (threads wait on them); one over its timeout is killed with
its whole group (its own workers too).  An interruption stops every running
command's group (SIGTERM, then SIGKILL after ``STOP_GRACE`` s) and starts no
more.  ``run_command`` runs one the same way (a batch job on a Dask worker).

A piece's result depends only on the payload and the piece, so the executors
give identical results.  Dask reruns the pieces of a worker that is lost
(its scheduler's ``allowed-failures``, default 3) and retries a piece that
raised (``RETRIES`` times).  A piece that fails for good (locally: at once;
a local worker process that dies takes the pool's unfinished pieces with it)
comes back as the exception in its place, and every other piece's result is
kept.
"""
from __future__ import annotations
from __future__ import annotations

import hashlib
import math
import os
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from ... import errors

ENVIRONMENT = "ANADYN_SCHEDULER"     # a Dask scheduler address, when --scheduler is not given


@dataclass(frozen=True)
class Work:
    """``setup(payload) -> state`` once per worker thread; ``work(state, piece)`` per piece."""
    setup: Callable[[Any], Any]
    work: Callable[[Any, Any], Any]
    payload: Any
    label: str = "anadyn"
    key: str = field(default="")

    def __post_init__(self):
        if not self.key:
            named = (f"{self.setup.__module__}.{self.setup.__qualname__}|"
                     f"{self.work.__module__}.{self.work.__qualname__}|{self.payload!r}")
            digest = hashlib.sha256(named.encode("utf-8", "surrogatepass")).hexdigest()
            object.__setattr__(self, "key", digest)


@dataclass
class Run:
    """What ran where: ``results`` in the order of the pieces (an exception in
    place of a piece that failed for good)."""
    results: list
    executor: str                  # "this process", "local processes", "dask"
    workers: int
    address: str = ""
    wall: float = 0.0
    notes: list = field(default_factory=list)


def scheduler_address(given: str | None) -> str | None:
    """--scheduler, else $ANADYN_SCHEDULER, else None (run locally)."""
    address = given if given is not None else os.environ.get(ENVIRONMENT)
    address = address.strip() if address else None
    return address or None


def check_jobs(jobs: int | None) -> int:
    return (os.cpu_count() or 1) if jobs is None else errors.check("jobs", jobs)


def chunks(count: int, processes: int, most: int = 50, per_worker: int = 16) -> list[range]:
    """Split ``count`` items into pieces: ~``per_worker`` pieces per worker (load
    balance, progress, little lost with a worker), at most ``most`` items each."""
    size = max(1, min(most, math.ceil(count / max(1, processes * per_worker))))
    return [range(start, min(start + size, count)) for start in range(0, count, size)]


def run(work: Work, pieces: list, jobs: int | None = None, scheduler=None,
        on_done: Callable[[int, Any], None] | None = None) -> Run:
    """Run ``work`` on every piece; ``on_done(index, result)`` as each finishes.

    ``scheduler``: a Dask scheduler's address or a connected ``distributed.Client``
    (see ``connect``); None runs locally on ``jobs`` processes.
    """
    start = time.perf_counter()
    if scheduler:
        result = cluster.run(work, pieces, scheduler, on_done)
    else:
        count = min(check_jobs(jobs), max(1, len(pieces)))
        result = (local.here(work, pieces, on_done) if count == 1
                  else local.processes(work, pieces, count, on_done))
    result.wall = time.perf_counter() - start
    return result


__all__ = ["ENVIRONMENT", "Work", "Run", "scheduler_address", "check_jobs", "chunks", "run",
           "connect", "workers", "Command", "Finished", "run_command", "run_commands"]

from . import cluster, local                # noqa: E402  (they use Work and Run)
from .cluster import connect, workers       # noqa: E402
from .commands import Command, Finished, run_command, run_commands   # noqa: E402
