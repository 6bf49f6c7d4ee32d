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

A piece's result depends only on the payload and the piece, so the executors
give identical results.  Dask reruns the pieces of a worker that is lost
(its scheduler's ``allowed-failures``, default 3) and retries a piece that
raised (``RETRIES`` times).  A piece that fails for good (locally: at once;
a local worker process that dies takes the pool's unfinished pieces with it)
comes back as the exception in its place, and every other piece's result is
kept.
"""
from __future__ import annotations

import hashlib
import math
import os
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import ModelError

ENVIRONMENT = "ANADYN_SCHEDULER"     # a Dask scheduler address, when --scheduler is not given
RETRIES = 2                          # Dask: reruns of a piece that raised
CONNECT_TIMEOUT = 10.0               # s to reach a scheduler
STATES_KEPT = 4                      # worker-side states kept per thread (LRU)

_PAYLOADS: dict[str, tuple[Callable, Any]] = {}      # key -> (setup, payload), per process
_LOCAL = threading.local()                            # per thread: key -> state


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
    workers = (os.cpu_count() or 1) if jobs is None else jobs
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ModelError(f"--jobs must be 1 or more, got {workers}")
    return workers


def chunks(count: int, workers: int, most: int = 50, per_worker: int = 16) -> list[range]:
    """Split ``count`` items into pieces: ~``per_worker`` pieces per worker (load
    balance, progress, little lost with a worker), at most ``most`` items each."""
    size = max(1, min(most, math.ceil(count / max(1, workers * per_worker))))
    return [range(start, min(start + size, count)) for start in range(0, count, size)]


def run(work: Work, pieces: list, jobs: int | None = None, scheduler=None,
        on_done: Callable[[int, Any], None] | None = None) -> Run:
    """Run ``work`` on every piece; ``on_done(index, result)`` as each finishes.

    ``scheduler``: a Dask scheduler's address or a connected ``distributed.Client``
    (see ``connect``); None runs locally on ``jobs`` processes.
    """
    start = time.perf_counter()
    if scheduler:
        result = _dask(work, pieces, scheduler, on_done)
    else:
        workers = min(check_jobs(jobs), max(1, len(pieces)))
        result = (_here(work, pieces, on_done) if workers == 1
                  else _processes(work, pieces, workers, on_done))
    result.wall = time.perf_counter() - start
    return result


# ----------------------------------------------------------------------------
# the worker side (every executor)
# ----------------------------------------------------------------------------
def _state(key: str):
    states = getattr(_LOCAL, "states", None)
    if states is None:
        states = _LOCAL.states = {}
    if key in states:
        states[key] = states.pop(key)            # most recently used last
        return states[key]
    if key not in _PAYLOADS:
        raise RuntimeError(f"this worker has no payload {key[:12]} (anadyn's worker plugin "
                           "did not run here; is anadyn installed on the workers?)")
    setup, payload = _PAYLOADS[key]
    states[key] = setup(payload)
    while len(states) > STATES_KEPT:
        states.pop(next(iter(states)))
    return states[key]


def _install(key: str, setup: Callable, payload: Any) -> None:
    _PAYLOADS[key] = (setup, payload)


def run_piece(key: str, work: Callable, piece: Any) -> Any:
    """One piece, on a worker that has the payload ``key``."""
    return work(_state(key), piece)


# ----------------------------------------------------------------------------
# local
# ----------------------------------------------------------------------------
def _here(work: Work, pieces: list, on_done) -> Run:
    _install(work.key, work.setup, work.payload)
    results = []
    for index, piece in enumerate(pieces):
        try:
            results.append(run_piece(work.key, work.work, piece))
        except Exception as err:              # noqa: BLE001  kept as data, as Dask keeps it
            results.append(err)
        if on_done is not None:
            on_done(index, results[-1])
    return Run(results, "this process", 1)


def _context():
    import multiprocessing

    methods = multiprocessing.get_all_start_methods()
    # fork: a worker starts in milliseconds with everything imported; elsewhere spawn
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def _processes(work: Work, pieces: list, workers: int, on_done) -> Run:
    results: list = [None] * len(pieces)
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=_context(),
                               initializer=_install,
                               initargs=(work.key, work.setup, work.payload))
    try:
        pending = {pool.submit(run_piece, work.key, work.work, piece): i
                   for i, piece in enumerate(pieces)}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                index = pending.pop(future)
                try:
                    results[index] = future.result()
                except Exception as err:      # noqa: BLE001  e.g. a worker process killed
                    results[index] = err      # (BrokenProcessPool): its pieces are lost
                if on_done is not None:
                    on_done(index, results[index])
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return Run(results, "local processes", workers)


# ----------------------------------------------------------------------------
# Dask distributed
# ----------------------------------------------------------------------------
def _distributed():
    try:
        import distributed
    except ImportError:
        raise ModelError("--scheduler needs Dask distributed, which is not installed: "
                         "pip install 'anadyn[distributed]'") from None
    return distributed


def _plugin_class():
    """A WorkerPlugin that installs a payload on every worker, present and future."""
    distributed = _distributed()

    class Payload(distributed.WorkerPlugin):
        idempotent = True

        def __init__(self, key: str, setup: Callable, payload: Any):
            self.key, self.setup_function, self.payload = key, setup, payload

        def setup(self, worker=None):
            _install(self.key, self.setup_function, self.payload)

        def teardown(self, worker=None):
            _PAYLOADS.pop(self.key, None)

    return Payload


def workers(client) -> int:
    """How many workers the Dask cluster of ``client`` has now."""
    info = (client.scheduler_info(n_workers=-1) if _takes(client.scheduler_info, "n_workers")
            else client.scheduler_info())
    return len(info.get("workers", {}))


def connect(address: str):
    """A Dask client of the scheduler at ``address`` (ModelError in one line if none);
    connect before any work, so that a wrong address costs nothing."""
    distributed = _distributed()
    try:
        return distributed.Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as err:
        why = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ModelError(f"--scheduler {address}: cannot reach a Dask scheduler ({why})"
                         ) from None


def _dask(work: Work, pieces: list, scheduler, on_done) -> Run:
    distributed = _distributed()
    own = isinstance(scheduler, str)
    client = connect(scheduler) if own else scheduler
    address = scheduler if own else str(client.scheduler.address)
    name = f"{work.label}-{work.key[:16]}"
    try:
        count = workers(client)
        client.register_plugin(_plugin_class()(work.key, work.setup, work.payload), name=name)
        token = os.urandom(4).hex()
        futures = client.map(run_piece, [work.key] * len(pieces), [work.work] * len(pieces),
                             pieces, key=[f"{name}-{token}-{i}" for i in range(len(pieces))],
                             retries=RETRIES, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        results: list = [None] * len(pieces)
        for future, result in distributed.as_completed(futures, loop=client.loop,
                                                       with_results=True, raise_errors=False):
            i = index[future.key]
            if future.status != "finished":   # lost for good (retries, workers): kept as data
                error = future.exception() if future.status == "error" else None
                result = error if isinstance(error, BaseException) else RuntimeError(
                    f"piece {future.status}")
            results[i] = result
            if on_done is not None:
                on_done(i, results[i])
        return Run(results, "dask", count, address=address)
    finally:
        try:
            client.unregister_worker_plugin(name)
        except Exception:                     # noqa: BLE001  cleanup only
            pass
        if own:
            client.close()


def _takes(function, name: str) -> bool:
    import inspect

    try:
        return name in inspect.signature(function).parameters
    except (TypeError, ValueError):
        return False
