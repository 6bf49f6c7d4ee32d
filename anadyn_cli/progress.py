"""What a long command is doing, on stderr, while it does it.

    from anadyn_cli import progress

    with progress.task("deriving kane equations of rr"):
        ...
    with progress.task("work-precision study", total=len(runs)) as step:
        for run in runs:
            step.advance(detail=f"{run.method} rtol {run.rtol:g}")

Work whose parts end in another order than they start (a batch's jobs) opens
each part with ``start(description, plain=False)`` (a line of its own with its
own clock on a terminal, nothing in a log), closes it with ``finish`` and
tells how it ended with ``report(line, keep)`` on the whole task: in a log
that line is printed at once (one line per finished job); on a terminal it is
printed above the bars when ``keep`` (a miss stays on screen).

Three modes, chosen once per command (``session``, opened by the CLI):

- ``live``: stderr is a terminal and ``CI`` is not set: a line per running
  task drawn by rich (spinner, what it does, a bar when the amount of work is
  known, the elapsed time, ticking on its own thread), shown once a task has
  run LIVE_DELAY s and erased when it ends;
- ``plain``: stderr is not a terminal, or ``CI`` is set: one line when a task
  has run PLAIN_DELAY s (``anadyn: deriving ... (2 s)``), another every
  PLAIN_EVERY s while it runs, and one when it ends, so a CI log says what
  took the time and nothing about what did not;
- ``off``: ``ANADYN_PROGRESS=off`` (``live`` and ``plain`` force a mode).

Outside a session (anadyn used as a library) tasks cost nothing and print
nothing.

Interruptions: ``stop_on_signals`` (the command line installs it before
anything else) makes SIGINT and SIGTERM raise ``Interrupted`` in the main
thread, once: a BaseException, so that every ``finally`` runs (workers and
jobs are stopped there) and neither typer nor click turns it into their own
exit; later signals are ignored while that unwinds.  Inside
``uninterrupted()`` (a command writing the files of one result) a signal waits
until the block ends, so a result's files are all written or none is.
``interruption`` gives the one line and the exit code, 128 + the signal's
number (130, 143).
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
from contextlib import contextmanager
from typing import Callable

LIVE_DELAY = 0.3       # s a task runs before its live line appears
PLAIN_DELAY = 2.0      # s a task runs before its first plain line
PLAIN_EVERY = 15.0     # s between plain lines of a running task
TICK = 0.1             # s between checks of the running tasks

_lock = threading.RLock()
_session: "_Session | None" = None


def choose_mode(stream=None) -> str:
    """``live``, ``plain`` or ``off`` for ``stream`` (default: stderr)."""
    forced = os.environ.get("ANADYN_PROGRESS", "").strip().lower()
    if forced in ("0", "off", "no", "false", "never"):
        return "off"
    if forced in ("live", "plain"):
        return forced
    stream = sys.stderr if stream is None else stream
    tty = bool(getattr(stream, "isatty", lambda: False)())
    return "live" if tty and not os.environ.get("CI") else "plain"


class Task:
    """A running piece of work; ``advance`` and ``note`` tell how far it is, ``report``
    how a part of it ended.  ``plain=False``: shown on a terminal only."""

    def __init__(self, description: str, total: int | None, plain: bool = True):
        self.description, self.total, self.plain = description, total, plain
        self.completed, self.detail = 0, ""
        self.start = time.monotonic()
        self.announced = False          # plain: first line printed
        self.last_line = 0.0            # plain: when the last line was printed
        self.live_id = None             # live: rich task id
        self.session = None             # the session it was started in

    def advance(self, step: int = 1, detail: str | None = None) -> None:
        raise_lost()
        with _lock:
            self.completed += step
            if detail is not None:
                self.detail = detail
            if _session is not None:
                _session.changed(self)

    def note(self, detail: str) -> None:
        """Say what part of the task runs now."""
        raise_lost()
        with _lock:
            self.detail = detail
            if _session is not None:
                _session.changed(self)

    def report(self, line: str, keep: bool = False) -> None:
        """How a part of the task ended: in ``plain`` mode a line at once, on a terminal
        a line above the bars that stays when ``keep``."""
        with _lock:
            if _session is not None:
                _session.reported(self, line, keep)

    def elapsed(self) -> float:
        return time.monotonic() - self.start

    def count(self) -> str:
        return f"{self.completed}/{self.total}" if self.total else ""

    def status(self) -> str:
        parts = []
        if self.total:
            parts.append(f"{self.completed}/{self.total}")
        if self.detail:
            parts.append(self.detail)
        parts.append(f"{self.elapsed():.0f} s")
        return ", ".join(parts)


def start(description: str, total: int | None = None, plain: bool = True) -> Task:
    """A task named ``description`` (``total`` steps, if known) running from now until
    ``finish``; ``plain=False`` shows it on a terminal only."""
    raise_lost()
    job = Task(description, total, plain)
    with _lock:
        job.session = _session
        if job.session is not None:
            job.session.add(job)
    return job


def finish(job: Task, finished: bool = True) -> None:
    """End ``job`` (``finished=False``: it was stopped)."""
    if job.session is not None:
        with _lock:
            job.session.remove(job, finished)


@contextmanager
def task(description: str, total: int | None = None):
    """Run the body as a task named ``description`` (``total`` steps, if known)."""
    job = start(description, total)
    finished = False
    try:
        yield job
        finished = True
    finally:
        finish(job, finished)


def active() -> bool:
    """Whether a command is running (the CLI's session is open), not a library call."""
    return _session is not None


@contextmanager
def session(stream=None, mode: str | None = None):
    """Report the tasks run inside to ``stream`` (default: stderr) in ``mode``
    (default: ``choose_mode``).  Nested sessions use the outer one."""
    global _session
    with _lock:
        outer = _session
        if outer is None:
            _session = _Session(sys.stderr if stream is None else stream,
                                mode or choose_mode(stream))
        current = _session
    try:
        yield current
    finally:
        if outer is None:
            current.close()
            with _lock:
                _session = None


class _Session:
    def __init__(self, stream, mode: str):
        self.stream, self.mode = stream, mode
        self.tasks: list[Task] = []
        self.live = None                 # rich Progress while shown
        self.stop = threading.Event()
        self.thread = None

    # -- bookkeeping (called with _lock held) --------------------------------
    def add(self, job: Task) -> None:
        if self.mode == "off":
            return
        self.tasks.append(job)
        if self.thread is None:
            self.thread = threading.Thread(target=self._run, name="anadyn-progress",
                                           daemon=True)
            self.thread.start()

    def remove(self, job: Task, finished: bool = True) -> None:
        if job not in self.tasks:
            return
        self.tasks.remove(job)
        if self.mode == "plain" and job.announced:
            self._write(f"anadyn: {job.description}: "
                        f"{'done in' if finished else 'stopped after'} {job.elapsed():.1f} s")
        if self.live is not None and job.live_id is not None:
            self.live.remove_task(job.live_id)
        if not self.tasks:
            self._hide()

    def reported(self, job: Task, line: str, keep: bool) -> None:
        if self.mode == "plain":
            job.announced, job.last_line = True, time.monotonic()
            self._write(line)
        elif self.mode == "live" and keep:
            if self.live is not None:
                self.live.console.print(line, markup=False, highlight=False)
            else:
                self._write(line)

    def changed(self, job: Task) -> None:
        if self.live is not None and job.live_id is not None:
            self.live.update(job.live_id, completed=job.completed, detail=job.detail,
                             count=job.count())

    # -- output ---------------------------------------------------------------
    def _write(self, line: str) -> None:
        try:
            self.stream.write(line + "\n")
            self.stream.flush()
        except (OSError, ValueError):     # a closed or broken stream: progress is optional
            pass

    def _show(self) -> None:
        from rich.console import Console
        from rich.progress import (BarColumn, Progress, SpinnerColumn, TextColumn,
                                   TimeElapsedColumn)

        console = Console(file=self.stream, stderr=self.stream is sys.stderr)
        self.live = Progress(SpinnerColumn(), TextColumn("{task.description}", markup=False),
                             BarColumn(bar_width=24), TextColumn("{task.fields[count]}"),
                             TextColumn("{task.fields[detail]}", markup=False),
                             TimeElapsedColumn(), console=console, transient=True,
                             refresh_per_second=8)
        self.live.start()

    def _hide(self) -> None:
        if self.live is not None:
            live, self.live = self.live, None
            for job in self.tasks:
                job.live_id = None
            live.stop()

    def _run(self) -> None:
        while not self.stop.wait(TICK):
            with _lock:
                if self.mode == "live":
                    self._tick_live()
                else:
                    self._tick_plain()

    def _tick_live(self) -> None:
        due = [job for job in self.tasks if job.live_id is None and job.elapsed() >= LIVE_DELAY]
        if not due:
            return
        if self.live is None:
            self._show()
        for job in due:
            job.live_id = self.live.add_task(job.description, total=job.total,
                                             completed=job.completed, detail=job.detail,
                                             count=job.count())

    def _tick_plain(self) -> None:
        now = time.monotonic()
        for job in self.tasks:
            if not job.plain:
                continue
            if not job.announced and job.elapsed() >= PLAIN_DELAY:
                job.announced, job.last_line = True, now
                self._write(f"anadyn: {job.description} ... ({job.status()})")
            elif job.announced and now - job.last_line >= PLAIN_EVERY:
                job.last_line = now
                self._write(f"anadyn: {job.description}: {job.status()}")

    def close(self) -> None:
        self.stop.set()
        with _lock:
            self._hide()
        if self.thread is not None:
            self.thread.join(timeout=1.0)


# ----------------------------------------------------------------------------
# interruptions
# ----------------------------------------------------------------------------
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(BaseException):
    """SIGINT or SIGTERM (``signum``) stopped the command."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: the first signal; the one held by open uninterrupted() blocks, and how many are
#: open; the one whose Interrupted Python swallowed
_signals = {"received": None, "held": None, "deferring": 0, "lost": None}


def _on_signal(signum: int, frame) -> None:
    if _signals["received"] is not None:
        return                                     # already stopping
    _signals["received"] = signum
    if _signals["deferring"]:
        _signals["held"] = signum
    else:
        raise Interrupted(signum)


def _keep_lost(unraisable) -> None:
    """``sys.unraisablehook`` while anadyn's handlers are in.  An ``Interrupted`` raised
    where Python can only print it and go on (a weakref callback of the import
    machinery, a ``__del__``) is kept, silently, and raised at the next checkpoint
    (``raise_lost``).  Anything else goes to the default hook."""
    if isinstance(unraisable.exc_value, Interrupted):
        _signals["lost"] = unraisable.exc_value.signum
    else:
        sys.__unraisablehook__(unraisable)


def raise_lost() -> None:
    """Raise the ``Interrupted`` that Python swallowed (``_keep_lost``), if any: called
    in the main thread whenever a task starts or moves on, after an ``uninterrupted``
    block and when the command line's command returns."""
    if _signals["lost"] is not None and not _signals["deferring"] \
            and threading.current_thread() is threading.main_thread():
        signum, _signals["lost"] = _signals["lost"], None
        raise Interrupted(signum)


def stop_on_signals() -> Callable[[], None]:
    """Make SIGINT and SIGTERM raise ``Interrupted`` (in the main thread; elsewhere a
    no-op); returns what puts the earlier handlers back.  Installed a second time
    (the console script, then ``cli.main``), a signal already received is kept."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    earlier = {signum: signal.signal(signum, _on_signal) for signum in SIGNALS}
    earlier_hook, sys.unraisablehook = sys.unraisablehook, _keep_lost
    if any(handler is not _on_signal for handler in earlier.values()):
        _signals.update(received=None, held=None, lost=None)

    def restore() -> None:
        for signum, handler in earlier.items():
            signal.signal(signum, handler)
        sys.unraisablehook = earlier_hook
    return restore


@contextmanager
def uninterrupted():
    """The block runs to its end; a signal received meanwhile stops the command after it."""
    _signals["deferring"] += 1
    try:
        yield
    finally:
        _signals["deferring"] -= 1
    if not _signals["deferring"] and _signals["held"] is not None:
        signum, _signals["held"] = _signals["held"], None
        raise Interrupted(signum)
    raise_lost()


def interruption(signum: int) -> tuple[str, int]:
    """The one line on stderr and the exit code (128 + ``signum``) of a stopped command."""
    what = "interrupted" if signum == signal.SIGINT else \
        f"stopped by {signal.Signals(signum).name}"
    return (f"anadyn: {what}; results written before the interruption are complete, "
            "none is half-written"), 128 + signum
