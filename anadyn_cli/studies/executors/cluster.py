"""Pieces on a Dask cluster: the payload as a worker plugin, every wait bounded
(``ANSWER_TIMEOUT``, ``ALIVE_EVERY``, ``NO_WORKERS_TIMEOUT``), pieces cancelled on an
interruption."""
from __future__ import annotations

import os
import threading
import time
from typing import Any, Callable

from ...errors import ModelError
from . import Run, Work
from .local import _PAYLOADS, install, run_piece

RETRIES = 2                          # Dask: reruns of a piece that raised
ANSWER_TIMEOUT = 10.0                # s a scheduler has to connect, or to answer a request
ALIVE_EVERY = 30.0                   # s without a result before asking if the scheduler lives
NO_WORKERS_TIMEOUT = 120.0           # s a run waits for a cluster that has no workers


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
            install(self.key, self.setup_function, self.payload)

        def teardown(self, worker=None):
            _PAYLOADS.pop(self.key, None)

    return Payload


def workers(client) -> int:
    """How many workers the Dask cluster of ``client`` has now (``ANSWER_TIMEOUT``)."""
    def ask():
        info = (client.scheduler_info(n_workers=-1)
                if _takes(client.scheduler_info, "n_workers") else client.scheduler_info())
        return len(info.get("workers", {}))

    return _answered(_address(client), "did not answer a request", ask)


def connect(address: str):
    """A Dask client of the scheduler at ``address`` (ModelError in one line if none
    answers within ``ANSWER_TIMEOUT`` s); connect before any work, so that a wrong
    address costs nothing."""
    distributed = _distributed()

    def client():
        return distributed.Client(address, timeout=ANSWER_TIMEOUT, set_as_default=False)

    try:
        return _answered(address, "cannot reach a Dask scheduler", client)
    except (OSError, ValueError) as err:
        why = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ModelError(f"--scheduler {address}: cannot reach a Dask scheduler ({why})"
                         ) from None


def _answered(address: str, what: str, call: Callable):
    """``call()``, run on a helper thread and given up after ``ANSWER_TIMEOUT`` s with a
    ModelError (Dask bounds a TCP connect, not the handshake that follows, nor every
    request); the thread of a call given up on is a daemon, left to end with the process."""
    box: dict = {}

    def attempt() -> None:
        try:
            box["value"] = call()
        except BaseException as err:          # noqa: BLE001  handed to the caller
            box["error"] = err

    thread = threading.Thread(target=attempt, name="anadyn-scheduler", daemon=True)
    thread.start()
    thread.join(ANSWER_TIMEOUT)
    if thread.is_alive() or isinstance(box.get("error"), TimeoutError):
        raise ModelError(f"--scheduler {address}: {what} (no answer within "
                         f"{ANSWER_TIMEOUT:g} s)")
    if "error" in box:
        raise box["error"]
    return box["value"]


def _address(client) -> str:
    scheduler = getattr(client, "scheduler", None)
    return str(getattr(scheduler, "address", None) or client)


def run(work: Work, pieces: list, scheduler, on_done) -> Run:
    own = isinstance(scheduler, str)
    client = connect(scheduler) if own else scheduler
    address = scheduler if own else _address(client)
    name = f"{work.label}-{work.key[:16]}"
    futures = []
    try:
        count = workers(client)
        _answered(address, "did not answer a request", lambda: client.register_plugin(
            _plugin_class()(work.key, work.setup, work.payload), name=name))
        token = os.urandom(4).hex()
        futures = client.map(run_piece, [work.key] * len(pieces), [work.work] * len(pieces),
                             pieces, key=[f"{name}-{token}-{i}" for i in range(len(pieces))],
                             retries=RETRIES, pure=False)
        results: list = [None] * len(pieces)
        for i, result in _finished(client, address, futures):
            results[i] = result
            if on_done is not None:
                on_done(i, results[i])
        return Run(results, "dask", count, address=address)
    except BaseException:                     # interrupted or given up: drop the pieces
        if futures:
            _quietly(lambda: _answered(address, "", lambda: client.cancel(futures)))
        raise
    finally:
        _quietly(lambda: _answered(address, "", lambda: client.unregister_worker_plugin(name)))
        if own:
            _quietly(lambda: client.close(timeout=ANSWER_TIMEOUT))


def _finished(client, address: str, futures: list):
    """(index, result) of each piece as it finishes; an exception in place of a piece lost
    for good.  Every wait is bounded: with no result for ``ALIVE_EVERY`` s the scheduler
    must answer and, within ``NO_WORKERS_TIMEOUT`` s, have workers."""
    import queue

    index = {f.key: i for i, f in enumerate(futures)}
    finished: queue.Queue = queue.Queue()
    for future in futures:
        future.add_done_callback(finished.put)
    workers_seen = time.monotonic()
    for _ in futures:
        while True:
            try:
                future = finished.get(timeout=ALIVE_EVERY)
                break
            except queue.Empty:
                if workers(client):
                    workers_seen = time.monotonic()
                elif time.monotonic() - workers_seen > NO_WORKERS_TIMEOUT:
                    raise ModelError(f"--scheduler {address}: the cluster has had no "
                                     f"workers for {NO_WORKERS_TIMEOUT:g} s") from None
        yield index[future.key], _outcome(address, future)


def _outcome(address: str, future):
    """A finished piece's result, or the exception it failed with for good."""
    what = "did not send a result"
    if future.status == "finished":
        return _answered(address, what, lambda: future.result(timeout=ANSWER_TIMEOUT))
    if future.status == "error":              # lost for good (retries, workers): kept as data
        error = _answered(address, what, lambda: future.exception(timeout=ANSWER_TIMEOUT))
        if isinstance(error, BaseException):
            return error
    return RuntimeError(f"piece {future.status}")


def _quietly(call: Callable) -> None:
    """Cleanup that must not hide why a run ended."""
    try:
        call()
    except Exception:                         # noqa: BLE001  cleanup only
        pass


def _takes(function, name: str) -> bool:
    import inspect

    try:
        return name in inspect.signature(function).parameters
    except (TypeError, ValueError):
        return False
