"""Running a batch's jobs through ``studies.executors``: local processes
(``run_commands``), or a Dask cluster (``run``, one piece per job), with its
progress shown through ``anadyn_cli.progress``."""
from __future__ import annotations

import threading
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

from ... import files as output
from ... import progress
from .. import executors
from .judge import BatchResult, JobResult, judge
from .plan import Batch, Job
from .reports import job_line


def run(batch: Batch, out: Path, workers: int | None = None, scheduler=None) -> BatchResult:
    """Run every job, ``workers`` at a time (default: all cores), or on the Dask
    cluster of ``scheduler`` (an address or a ``distributed.Client``; see
    ``run_on_cluster``); the progress goes to ``anadyn_cli.progress``."""
    if scheduler is None:
        workers = executors.check_jobs(workers)      # before anything is written
    out = output.prepare_dir(out)
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    shown = _Shown(len(batch.jobs))
    try:
        if scheduler is not None:
            results, ran = _on_cluster(batch, out, scheduler, shown)
        else:
            results, ran = _locally(batch, out, workers, shown)
    except BaseException:
        shown.close(finished=False)
        raise
    shown.close(finished=True)
    return BatchResult(batch, results, ran.workers, ran.wall, started)


def _locally(batch: Batch, out: Path, workers: int | None, shown: "_Shown"):
    """Each job a local process (``executors.run_commands``); its folder is prepared
    when it starts, its files written and judged here as it ends."""
    before: dict[int, tuple] = {}
    results: list = [None] * len(batch.jobs)

    def start(index: int) -> None:
        job = batch.jobs[index]
        folder = output.prepare_dir(job.folder(out))
        before[index] = (folder, _identity(folder / f"{job.command}.json"))
        shown.started(job)

    def done(index: int, finished: executors.Finished) -> None:
        results[index] = _judged(batch.jobs[index], *before[index], finished)
        shown.done(results[index])

    commands = [executors.Command(tuple(job.argv(out)), job.timeout) for job in batch.jobs]
    ran = executors.run_commands(commands, workers, on_start=start, on_done=done)
    return results, ran


def run_job(job: Job, out: Path) -> JobResult:
    """Run one job in its own process group (``executors.run_command``) and judge it."""
    folder = output.prepare_dir(job.folder(out))
    before = _identity(folder / f"{job.command}.json")
    finished = executors.run_command(executors.Command(tuple(job.argv(out)), job.timeout))
    return _judged(job, folder, before, finished)


def _judged(job: Job, folder: Path, before, finished: executors.Finished) -> JobResult:
    """A job's result: its stdout.txt and stderr.txt written, judged against its
    expectation (``<command>.json`` counts only if the job wrote it)."""
    stderr = finished.stderr
    if not finished.started:
        stderr = f"anadyn batch: cannot start: {finished.stderr}"
    elif finished.timed_out:
        stderr += f"\nanadyn batch: timed out after {job.timeout:g} s"
    result = JobResult(job, finished.code, finished.wall, finished.stdout, stderr,
                       timed_out=finished.timed_out)
    for name, text in (("stdout.txt", result.stdout), ("stderr.txt", result.stderr)):
        output.write_text(folder / name, text)
    figures = folder / f"{job.command}.json"
    judge(result, figures if _identity(figures) != before else None)
    return result


def _identity(path: Path):
    try:
        stat = path.stat()
    except OSError:
        return None
    return (stat.st_ino, stat.st_mtime_ns, stat.st_size)


def _on_cluster(batch: Batch, out: Path, scheduler, shown: "_Shown"):
    """Every job on a Dask cluster (``executors.run``), one piece each.

    No shared file system is needed: the robot file travels with its job, the
    job runs in a temporary folder on a worker (``run_remote``), and its
    results, stdout.txt and stderr.txt come back and are written here, to
    ``OUT/<command>/<name>/``, then judged as a local job is.  A job whose worker
    is lost reruns elsewhere; one that cannot run at all is a miss that says why.
    """
    pieces = [(job, Path(job.robot).name, Path(job.robot).read_bytes()) for job in batch.jobs]
    results: list = [None] * len(batch.jobs)
    for job in batch.jobs:
        shown.started(job)

    def finished(index: int, value) -> None:
        results[index] = _collect(batch.jobs[index], value, out)
        shown.done(results[index])

    ran = executors.run(executors.Work(_no_setup, run_remote, None, label="anadyn-batch"),
                        pieces, scheduler=scheduler, on_done=finished)
    return results, ran


def _no_setup(payload) -> None:
    return None


def run_remote(state, piece) -> tuple:
    """On a worker: one job in a temporary folder; (exit code, wall, stdout, stderr,
    {file name: bytes} of its result folder, timed out)."""
    import tempfile

    job, robot_name, robot_bytes = piece
    with tempfile.TemporaryDirectory(prefix="anadyn-batch-") as folder:
        robot = Path(folder) / "robot" / robot_name
        robot.parent.mkdir()
        robot.write_bytes(robot_bytes)
        here = replace(job, robot=str(robot))
        result = run_job(here, Path(folder) / "out")
        results = here.folder(Path(folder) / "out")
        files = {p.name: p.read_bytes() for p in sorted(results.iterdir()) if p.is_file()}
    text = [t.replace(str(robot), job.robot) for t in (result.stdout, result.stderr)]
    for name in ("stdout.txt", "stderr.txt"):
        files[name] = files.get(name, b"").decode("utf-8", "replace").replace(
            str(robot), job.robot).encode("utf-8")
    return result.exit_code, result.wall, text[0], text[1], files, result.timed_out


def _collect(job: Job, value, out: Path) -> JobResult:
    """A job's result from the cluster: files written here, then judged."""
    folder = output.prepare_dir(job.folder(out))
    if isinstance(value, BaseException):
        why = f"{type(value).__name__}: {value}".splitlines()[0]
        result = JobResult(job, None, 0.0, "", f"anadyn batch: not run on the cluster: {why}")
        output.write_text(folder / "stderr.txt", result.stderr)
        judge(result, None)
        return result
    code, wall, stdout, stderr, files, timed_out = value
    for name, data in files.items():
        output.write_bytes(folder / name, data)
    result = JobResult(job, code, wall, stdout, stderr, timed_out=timed_out)
    figures = f"{job.command}.json"
    judge(result, folder / figures if figures in files else None)
    return result


class _Shown:
    """A batch's progress: the batch as a task of ``total`` jobs (``N/M``, how many run
    and failed), a line per running job with its clock on a terminal, and per finished
    job ``job_line``: printed in a log, kept on a terminal when the job missed."""

    def __init__(self, total: int):
        self.total, self.running, self.failed, self.finished = total, 0, 0, 0
        self.lock = threading.Lock()           # jobs start on the executor's threads
        self.rows: dict[str, progress.Task] = {}
        self.whole = progress.start("batch", total=max(1, total))
        self.whole.note(self._status())

    def _status(self) -> str:
        return f"{self.running} running, {self.failed} failed"

    def started(self, job: Job) -> None:
        with self.lock:
            self.running += 1
            self.rows[job.key] = progress.start(f"  {job.command} {job.name}", plain=False)
            self.whole.note(self._status())

    def done(self, result: JobResult) -> None:
        with self.lock:
            self.running -= 1
            self.finished += 1
            self.failed += not result.ok
            row = self.rows.pop(result.job.key, None)
            if row is not None:
                progress.finish(row)
            self.whole.report(job_line(result, self.finished, self.total), keep=not result.ok)
            self.whole.advance(detail=self._status())

    def close(self, finished: bool) -> None:
        with self.lock:
            for row in self.rows.values():
                progress.finish(row, finished=False)
            self.rows.clear()
        progress.finish(self.whole, finished)
