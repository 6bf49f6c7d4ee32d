"""The worker side of every executor (a payload installed once per worker, a state
built from it once per thread) and the local executors: this process, or a pool of
local processes stopped at once on an interruption."""
from __future__ import annotations

import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any, Callable

from . import Run, Work

STOP_GRACE = 1.0                     # s local workers (and commands) get after SIGTERM,
                                     # then SIGKILL
STATES_KEPT = 4                      # worker-side states kept per thread (LRU)

_PAYLOADS: dict[str, tuple[Callable, Any]] = {}      # key -> (setup, payload), per process
_LOCAL = threading.local()                            # per thread: key -> state


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


def install(key: str, setup: Callable, payload: Any) -> None:
    _PAYLOADS[key] = (setup, payload)


def _install_in_worker(key: str, setup: Callable, payload: Any) -> None:
    """A local worker process's start: its payload, and SIGINT ignored (the main
    process stops its workers; a terminal's Ctrl-C reaches the whole group)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    install(key, setup, payload)


def run_piece(key: str, work: Callable, piece: Any) -> Any:
    """One piece, on a worker that has the payload ``key``."""
    return work(_state(key), piece)


# ----------------------------------------------------------------------------
# local
# ----------------------------------------------------------------------------
def here(work: Work, pieces: list, on_done) -> Run:
    install(work.key, work.setup, work.payload)
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


def processes(work: Work, pieces: list, workers: int, on_done) -> Run:
    results: list = [None] * len(pieces)
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=_context(),
                               initializer=_install_in_worker,
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
    except BaseException:                     # interrupted: stop the workers now
        _stop(list((getattr(pool, "_processes", None) or {}).values()))
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return Run(results, "local processes", workers)


def _stop(processes: list) -> None:
    """SIGTERM to each worker process, SIGKILL to those alive ``STOP_GRACE`` s later."""
    for process in processes:
        process.terminate()
    deadline = time.monotonic() + STOP_GRACE
    for process in processes:
        process.join(max(0.0, deadline - time.monotonic()))
    for process in processes:
        if process.is_alive():
            process.kill()
            process.join(STOP_GRACE)

