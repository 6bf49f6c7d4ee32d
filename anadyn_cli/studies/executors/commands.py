"""Commands (a batch's jobs): local processes, each in a process group of its own,
killed with its group at its timeout or on an interruption."""
from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass
from typing import Callable

from . import Run, check_jobs
from .local import STOP_GRACE


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
