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

import hashlib
import math
import os
import signal
import subprocess
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any, Callable

from .. import errors
from ..errors import ModelError

ENVIRONMENT = "ANADYN_SCHEDULER"     # a Dask scheduler address, when --scheduler is not given
RETRIES = 2                          # Dask: reruns of a piece that raised
ANSWER_TIMEOUT = 10.0                # s a scheduler has to connect, or to answer a request
ALIVE_EVERY = 30.0                   # s without a result before asking if the scheduler lives
NO_WORKERS_TIMEOUT = 120.0           # s a run waits for a cluster that has no workers
STOP_GRACE = 1.0                     # s local workers (and commands) get after SIGTERM,
                                     # then SIGKILL
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
    return (os.cpu_count() or 1) if jobs is None else errors.check("jobs", jobs)


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


def _install_in_worker(key: str, setup: Callable, payload: Any) -> None:
    """A local worker process's start: its payload, and SIGINT ignored (the main
    process stops its workers; a terminal's Ctrl-C reaches the whole group)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _install(key, setup, payload)


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


# ----------------------------------------------------------------------------
# commands: local processes, each in a process group of its own
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Command:
    """``argv`` run as a process; killed with its group after ``timeout`` s (None: no limit)."""
    argv: tuple
    timeout: float | None = None


@dataclass
class Finished:
    """How a command ended: ``code`` is None when it timed out or could not start."""
    code: int | None
    stdout: str
    stderr: str
    wall: float
    timed_out: bool = False
    started: bool = True


class Commands:
    """The command processes running now; ``stop`` ends them all, each with its group."""

    def __init__(self):
        self.lock = threading.Lock()
        self.processes: set = set()
        self.stopped = False

    def run(self, command: Command) -> Finished:
        """Run ``command`` to its end (or its timeout, or ``stop``); an OSError from
        starting it comes back as a ``Finished`` that did not start."""
        start = time.perf_counter()
        with self.lock:
            if self.stopped:
                return Finished(None, "", "", 0.0)
            try:
                process = subprocess.Popen(
                    list(command.argv), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE, text=True, errors="replace",
                    start_new_session=True)
            except OSError as err:
                return Finished(None, "", str(err), 0.0, started=False)
            self.processes.add(process)
        try:
            try:
                stdout, stderr = process.communicate(timeout=command.timeout)
                code, timed_out = process.returncode, False
            except subprocess.TimeoutExpired:
                _signal_group(process, signal.SIGKILL)
                stdout, stderr = process.communicate()
                code, timed_out = None, True
        finally:
            with self.lock:
                self.processes.discard(process)
        return Finished(code, stdout, stderr, time.perf_counter() - start, timed_out)

    def stop(self) -> None:
        """SIGTERM to every running command's group, SIGKILL ``STOP_GRACE`` s later to
        those still there; later commands do not start."""
        with self.lock:
            self.stopped = True
            processes = list(self.processes)
        for process in processes:
            _signal_group(process, signal.SIGTERM)
        deadline = time.monotonic() + STOP_GRACE
        for process in processes:
            try:
                process.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
            _signal_group(process, signal.SIGKILL)     # its workers too, if it left any


def _signal_group(process, signum: int) -> None:
    try:
        os.killpg(process.pid, signum)
    except (ProcessLookupError, PermissionError):
        pass


def run_command(command: Command) -> Finished:
    """One command in a process group of its own (see ``Commands.run``)."""
    return Commands().run(command)


def run_commands(commands: list, jobs: int | None = None,
                 on_start: Callable[[int], None] | None = None,
                 on_done: Callable[[int, Finished], None] | None = None) -> Run:
    """Run every ``Command``, ``jobs`` at a time (default: all cores).

    ``on_start(index)`` runs on a waiting thread just before a command starts (an
    exception there ends the run); ``on_done(index, finished)`` in this thread as
    each ends.  Any BaseException while waiting (an interruption) stops them all.
    """
    start = time.perf_counter()
    workers = check_jobs(jobs)
    running = Commands()
    results: list = [None] * len(commands)

    def one(index: int) -> Finished | None:
        if running.stopped:
            return None
        if on_start is not None:
            on_start(index)
        return running.run(commands[index])

    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="anadyn-command")
    try:
        pending = {pool.submit(one, i): i for i in range(len(commands))}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                index = pending.pop(future)
                results[index] = future.result()
                if on_done is not None:
                    on_done(index, results[index])
    except BaseException:                  # interrupted (or on_start refused): stop all
        running.stop()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return Run(results, "local processes", workers, wall=time.perf_counter() - start)


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


def _dask(work: Work, pieces: list, scheduler, on_done) -> Run:
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
