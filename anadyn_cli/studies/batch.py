"""Many anadyn runs from one YAML file, in parallel, with one summary and a CI exit code.

A batch file lists jobs; each runs one command on one robot in its own
process and is judged by its exit code and the key figures the command
writes to ``<command>.json``:

    description: what this batch is for            # optional
    timeout: 600                                   # optional, s per job (default: none)
    jobs:
      - command: inverse                           # any command that takes a robot
        robot: ../robots/rr.yaml                   # relative to this file's folder, or a
                                                   # library name (ur5)
        name: rr                                   # optional; default: the robot file's stem
        options: [--no-plot, --dt, 0.05]           # or a mapping {no-plot: true, dt: 0.05}
        expect:
          exit_code: 0                             # default 0
          max: {roundtrip.max_error: 1e-6}         # value <= bound
          min: {points: 100}                       # value >= bound
          equal: {roundtrip.passed: true}          # value == given
      - command: simulate
        robot: ../robots/broken.yaml
        must_fail: 2                               # shorthand for expect.exit_code: 2

Keys under max/min/equal are dotted paths into ``<command>.json``
(``rows.0.max_error`` indexes a list); a key that is missing there is a
miss that names it.  A mapping of options becomes ``--key value``
(``--key`` for true, ``--no-key`` for false); the job's folder is set by
the batch: ``OUT/<command>/<name>/`` (``--out``; ``import`` writes
``<name>.yaml`` there, ``equations`` prints only), which also receives
``stdout.txt`` and ``stderr.txt``.

Each job runs ``python -m anadyn_cli COMMAND OPTIONS --out FOLDER -- ROBOT``
(after ``--`` a robot named like an option is still a robot) in a process
group of its own; ``run`` starts up to ``workers`` of them at a time (threads
waiting on processes) and returns every result.  A job over its timeout is
killed with its whole group (its own workers too).  An interruption of the
batch (``Interrupted``, KeyboardInterrupt) stops every running job's group
(SIGTERM, then SIGKILL after ``STOP_GRACE`` s) and writes nothing more.
``write`` gives summary.csv, summary.json and junit.xml (a miss is a
``<failure>``, a job that timed out or could not start an ``<error>``, each
with the job's whole output, cut in the middle beyond ``OUTPUT_KEPT``
characters); ``raise_if_failed`` raises ``CheckFailed`` naming each job that
missed its expectation.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from . import executors
from .. import files as output
from ..errors import CheckFailed

#: what a job may run: every command that takes a robot
COMMANDS = ("simulate", "inverse", "compare", "accuracy", "check", "sweep", "linearize",
            "export", "equations", "show", "animate", "view", "import")
#: where a command writes its results: --out FOLDER, except these
OUTPUT_OPTION = {"equations": None, "import": "--output"}
TOP_KEYS = ("description", "timeout", "jobs")
JOB_KEYS = ("command", "robot", "name", "options", "expect", "must_fail", "timeout")
EXPECT_KEYS = ("exit_code", "max", "min", "equal")
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}\Z")
MAX_TIMEOUT = 7 * 86400.0            # s: a week (the system's waits end at ~24 days)
OUTPUT_KEPT = 200_000                # characters of a job's stdout (and stderr) in the reports
STOP_GRACE = 1.0                     # s a stopped job's group gets after SIGTERM, then SIGKILL


@dataclass(frozen=True)
class Expectation:
    exit_code: int | None = 0                    # None: any non-zero code
    max: tuple[tuple[str, float], ...] = ()
    min: tuple[tuple[str, float], ...] = ()
    equal: tuple[tuple[str, object], ...] = ()

    @property
    def paths(self) -> list[str]:
        return [p for group in (self.max, self.min, self.equal) for p, _ in group]

    def describe_exit(self) -> str:
        return "non-zero" if self.exit_code is None else str(self.exit_code)


@dataclass(frozen=True)
class Job:
    command: str
    robot: str                                   # path as given to the command
    name: str
    options: tuple[str, ...]
    expect: Expectation
    timeout: float | None = None
    line: int | None = None

    @property
    def key(self) -> str:
        return f"{self.command} {self.name}"

    def folder(self, out: Path) -> Path:
        return Path(out) / self.command / self.name

    def argv(self, out: Path) -> list[str]:
        flag = OUTPUT_OPTION.get(self.command, "--out")
        where = ([] if flag is None else
                 [flag, str(self.folder(out) / f"{self.name}.yaml")] if flag == "--output" else
                 [flag, str(self.folder(out))])
        return [sys.executable, "-m", "anadyn_cli", self.command, *self.options, *where,
                "--", self.robot]


@dataclass(frozen=True)
class Batch:
    source: str
    jobs: tuple[Job, ...]
    description: str = ""


@dataclass
class JobResult:
    job: Job
    exit_code: int | None                        # None: timed out or could not start
    wall: float
    stdout: str = ""
    stderr: str = ""
    figures: dict = field(default_factory=dict)  # expectation path -> value found
    failures: list[str] = field(default_factory=list)
    timed_out: bool = False

    @property
    def ok(self) -> bool:
        return not self.failures

    @property
    def status(self) -> str:
        return "ok" if self.ok else "FAIL"

    @property
    def error(self) -> bool:
        """Did not finish (timed out, or could not start): an error, not a miss."""
        return self.exit_code is None


@dataclass
class BatchResult:
    batch: Batch
    results: list[JobResult]                     # in the file's order
    workers: int
    wall: float
    started: str                                 # ISO time

    @property
    def failed(self) -> list[JobResult]:
        return [r for r in self.results if not r.ok]


# ----------------------------------------------------------------------------
# the batch file
# ----------------------------------------------------------------------------
def load_batch(path: str | Path) -> Batch:
    """Read and validate a batch file; ModelError (exit 2) naming file, line and key path."""
    from ..model.yamlschema import load
    from ..model.yamlsource import read_text

    text, source = read_text(path)
    data, lines = load(text, source)
    from ..model.loader import Cursor

    root = Cursor(data, "", source, lines)
    top = root.mapping(TOP_KEYS, required=("jobs",))
    description = top["description"].text() if "description" in top else ""
    timeout = _seconds(top["timeout"]) if "timeout" in top else None
    items = top["jobs"].sequence()
    if not items:
        raise top["jobs"].error("expected at least one job")
    folder = Path(source).parent
    jobs: list[Job] = []
    taken: dict[str, int] = {}
    for item in items:
        job = _job(item, folder, timeout)
        if job.key in taken:
            raise (item.mapping()["name"] if "name" in item.value else item).error(
                f"a second job {job.key!r}; give one of them a different name")
        taken[job.key] = 1
        jobs.append(job)
    return Batch(source, tuple(jobs), description)


def _job(cursor, folder: Path, timeout: float | None) -> Job:
    keys = cursor.mapping(JOB_KEYS, required=("command", "robot"))
    command = keys["command"].choice(COMMANDS)
    robot = _robot(keys["robot"], folder)
    if "name" in keys:
        name = keys["name"].value
        if not isinstance(name, str) or not NAME.match(name):
            raise keys["name"].error("a job name is a letter or digit followed by up to 63 "
                                     f"letters, digits, '_', '.' or '-', got {name!r}")
    else:
        name = re.sub(r"[^A-Za-z0-9_.-]", "_", robot.stem).lstrip("._-")[:64]
        if not NAME.match(name):
            raise keys["robot"].error(f"the file name {robot.name!r} makes no job name; "
                                      "give the job a name (a letter or digit followed by "
                                      "letters, digits, '_', '.' or '-')")
    options = _options(keys["options"]) if "options" in keys else ()
    expect = _expectation(keys["expect"]) if "expect" in keys else Expectation()
    if "must_fail" in keys:
        cursor_fail = keys["must_fail"]
        if "expect" in keys and "exit_code" in keys["expect"].value:
            raise cursor_fail.error("give either must_fail or expect.exit_code, not both")
        value = cursor_fail.value
        if value is True:
            code = None
        elif isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= 255:
            code = value
        else:
            raise cursor_fail.error(f"must be an exit code from 1 to 255 or true (any "
                                    f"non-zero code), got {value!r}")
        expect = Expectation(code, expect.max, expect.min, expect.equal)
    job_timeout = _seconds(keys["timeout"]) if "timeout" in keys else timeout
    return Job(command, str(robot), name, options, expect, job_timeout,
               cursor.lines.get(cursor.path))


def _robot(cursor, folder: Path) -> Path:
    """The robot file of a job: relative to the batch file's folder, else (a bare name)
    the library's robot of that name; always an absolute path."""
    from ..model import library

    given = cursor.text()
    robot = Path(os.path.abspath(folder / given))
    if robot.is_file():
        return robot
    found = library.find(given) if len(Path(given).parts) == 1 else None
    if found is not None:
        return Path(os.path.abspath(found))
    raise cursor.error(f"no such file {str(robot)!r} (robot paths are relative to the batch "
                       f"file's folder){library.missing_hint(given)}")


def _options(cursor) -> tuple[str, ...]:
    result: list[str] = []
    if isinstance(cursor.value, dict):
        for key, item in cursor.mapping().items():
            flag = "--" + key.lstrip("-").replace("_", "-")
            value = item.value
            if value is True:
                result.append(flag)
            elif value is False:
                result.append("--no-" + flag[2:])
            elif isinstance(value, (str, int, float)):
                result += [flag, str(value)]
            else:
                raise item.error("an option's value is text, a number, true or false")
    else:
        for item in cursor.sequence():
            if isinstance(item.value, bool) or not isinstance(item.value, (str, int, float)):
                raise item.error("each option is text or a number, e.g. [--dt, 0.05]")
            result.append(str(item.value))
    for word in result:
        if word in ("--out", "--output", "-o") or word.startswith(("--out=", "--output=")):
            raise cursor.error(f"{word.partition('=')[0]} is set by the batch "
                               "(OUT/<command>/<name>/); leave it out")
        if word == "--":
            raise cursor.error("'--' is set by the batch (before the robot); leave it out")
    return tuple(result)


def _expectation(cursor) -> Expectation:
    keys = cursor.mapping(EXPECT_KEYS)
    code = 0
    if "exit_code" in keys:
        value = keys["exit_code"].value
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 255:
            raise keys["exit_code"].error(f"must be an exit code from 0 to 255, got {value!r}")
        code = value
    bounds = {}
    for group in ("max", "min"):
        pairs = []
        if group in keys:
            for path, item in keys[group].mapping().items():
                pairs.append((path, _number(item)))
        bounds[group] = tuple(pairs)
    equal = []
    if "equal" in keys:
        for path, item in keys["equal"].mapping().items():
            if isinstance(item.value, (dict, list)):
                raise item.error("expected a single value (text, number, true, false or null)")
            equal.append((path, item.value))
    return Expectation(code, bounds["max"], bounds["min"], tuple(equal))


def _number(cursor) -> float:
    """A number; YAML 1.1 reads 1e-6 as text, so numeric text is accepted too."""
    value = cursor.value
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        raise cursor.error(f"expected a number, got {cursor.value!r}")
    return float(value)


def _seconds(cursor) -> float:
    """A job's timeout: more than 0 s, at most ``MAX_TIMEOUT``."""
    value = _number(cursor)
    if not 0 < value <= MAX_TIMEOUT:
        raise cursor.error(f"must be a number of seconds more than 0 and at most "
                           f"{MAX_TIMEOUT:g} (a week), got {value:g}")
    return value


# ----------------------------------------------------------------------------
# running
# ----------------------------------------------------------------------------
def run_job(job: Job, out: Path, running: "Running | None" = None) -> JobResult | None:
    """Run one job in its own process group and judge it; None if ``running`` was stopped
    meanwhile (nothing is written then)."""
    running = Running() if running is None else running
    folder = output.prepare_dir(job.folder(out))
    figures_file = folder / f"{job.command}.json"
    before = _identity(figures_file)
    start = time.perf_counter()
    try:
        code, stdout, stderr = running.run(job.argv(out), job.timeout)
        timed_out = code is None
        if timed_out:
            stderr += f"\nanadyn batch: timed out after {job.timeout:g} s"
    except OSError as err:
        code, stdout, stderr, timed_out = None, "", f"anadyn batch: cannot start: {err}", False
    if running.stopped:
        return None
    wall = time.perf_counter() - start
    result = JobResult(job, code, wall, stdout, stderr, timed_out=timed_out)
    for name, text in (("stdout.txt", stdout), ("stderr.txt", stderr)):
        output.write_text(folder / name, text)
    judge(result, figures_file if _identity(figures_file) != before else None)
    return result


class Running:
    """The job processes running now; ``stop`` ends them all, each with its group."""

    def __init__(self):
        self.lock = threading.Lock()
        self.processes: set = set()
        self.stopped = False

    def run(self, argv: list[str], timeout: float | None) -> tuple[int | None, str, str]:
        """(exit code, stdout, stderr) of ``argv``; the exit code is None when it ran over
        ``timeout`` s (its process group is killed) or was stopped."""
        with self.lock:
            if self.stopped:
                return None, "", ""
            process = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                       stderr=subprocess.PIPE, text=True, errors="replace",
                                       start_new_session=True)
            self.processes.add(process)
        try:
            try:
                stdout, stderr = process.communicate(timeout=timeout)
                return process.returncode, stdout, stderr
            except subprocess.TimeoutExpired:
                _signal_group(process, signal.SIGKILL)
                stdout, stderr = process.communicate()
                return None, stdout, stderr
        finally:
            with self.lock:
                self.processes.discard(process)

    def stop(self) -> None:
        """SIGTERM to every running job's group, SIGKILL ``STOP_GRACE`` s later to those
        still there; later jobs do not start."""
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


def _identity(path: Path):
    try:
        stat = path.stat()
    except OSError:
        return None
    return (stat.st_ino, stat.st_mtime_ns, stat.st_size)


def judge(result: JobResult, figures_file: Path | None) -> None:
    """Fill in ``failures`` and ``figures`` from the exit code and ``<command>.json``."""
    job, expect = result.job, result.job.expect
    if result.exit_code is None:
        result.failures.append(last_line(result.stderr) or "did not finish")
    elif expect.exit_code is None and result.exit_code == 0:
        result.failures.append("exit code 0, expected a failure (non-zero)")
    elif expect.exit_code is not None and result.exit_code != expect.exit_code:
        why = last_line(result.stderr)
        result.failures.append(f"exit code {result.exit_code}, expected {expect.exit_code}"
                               + (f" ({why})" if why else ""))
    if not expect.paths:
        return
    name = f"{job.command}.json"
    if figures_file is None:
        result.failures.append(f"{name} not written, so {', '.join(expect.paths)} "
                               f"cannot be checked")
        return
    try:
        data = json.loads(figures_file.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        result.failures.append(f"{name} unreadable: {err}")
        return
    for path, bound in expect.max:
        _bound(result, data, name, path, bound, "max")
    for path, bound in expect.min:
        _bound(result, data, name, path, bound, "min")
    for path, wanted in expect.equal:
        found, value = lookup(data, path)
        if not found:
            result.failures.append(f"{path}: missing in {name}")
            continue
        result.figures[path] = value
        same = (value == wanted and isinstance(value, bool) == isinstance(wanted, bool))
        if not same:
            result.failures.append(f"{path} = {_show(value)}, expected {_show(wanted)}")


def _bound(result: JobResult, data, name: str, path: str, bound: float, kind: str) -> None:
    found, value = lookup(data, path)
    if not found:
        result.failures.append(f"{path}: missing in {name}")
        return
    result.figures[path] = value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        result.failures.append(f"{path} = {_show(value)} in {name}, expected a number")
    elif kind == "max" and not value <= bound:
        result.failures.append(f"{path} = {_show(value)} > max {bound:g}")
    elif kind == "min" and not value >= bound:
        result.failures.append(f"{path} = {_show(value)} < min {bound:g}")


def lookup(data, path: str) -> tuple[bool, object]:
    """(found, value) of a dotted path; a number indexes a list."""
    value = data
    for part in path.split("."):
        if isinstance(value, dict) and part in value:
            value = value[part]
        elif isinstance(value, list) and re.fullmatch(r"-?\d+", part) and \
                -len(value) <= int(part) < len(value):
            value = value[int(part)]
        else:
            return False, None
    return True, value


def _show(value) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    return json.dumps(value) if not isinstance(value, str) else repr(value)


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else ""


def excerpt(text: str, kept: int = OUTPUT_KEPT) -> str:
    """``text`` whole, or beyond ``kept`` characters its first and last lines around one
    saying how much was left out between them (table headers and the final error stay)."""
    text = text.rstrip("\n")
    if len(text) <= kept:
        return text
    head, tail = text[: kept // 2], text[len(text) - kept // 2:]
    head = head[: head.rfind("\n") + 1] or head          # whole lines, where there are any
    tail = tail[tail.find("\n") + 1:] or tail
    return f"{head}[... {len(text) - len(head) - len(tail)} characters left out ...]\n{tail}"


def run(batch: Batch, out: Path, workers: int | None = None, on_start=None,
        on_done=None, scheduler=None) -> BatchResult:
    """Run every job, ``workers`` at a time (default: all cores), or on the Dask
    cluster of ``scheduler`` (an address or a ``distributed.Client``; see
    ``run_on_cluster``).

    ``on_start(job)`` and ``on_done(result, finished, total)`` report progress.
    """
    if scheduler is not None:
        return run_on_cluster(batch, out, scheduler, on_start, on_done)
    workers = executors.check_jobs(workers)
    out = output.prepare_dir(out)
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    start = time.perf_counter()
    results: dict[int, JobResult] = {}
    running = Running()

    def task(index: int, job: Job) -> tuple[int, JobResult | None]:
        if running.stopped:
            return index, None
        if on_start is not None:
            on_start(job)
        return index, run_job(job, out, running)

    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        futures = [pool.submit(task, i, job) for i, job in enumerate(batch.jobs)]
        for future in as_completed(futures):
            index, result = future.result()
            results[index] = result
            if on_done is not None:
                on_done(result, len(results), len(batch.jobs))
    except BaseException:                  # interrupted (or a job's folder refused): stop all
        running.stop()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return BatchResult(batch, [results[i] for i in range(len(batch.jobs))], workers,
                       time.perf_counter() - start, started)


def run_on_cluster(batch: Batch, out: Path, scheduler, on_start=None,
                   on_done=None) -> BatchResult:
    """Every job on a Dask cluster (``studies.executors``), one task each.

    No shared file system is needed: the robot file travels with its job, the
    job runs in a temporary folder on a worker (``run_remote``), and its
    results, stdout.txt and stderr.txt come back and are written here, to
    ``OUT/<command>/<name>/``, then judged as a local job is.  A job whose worker
    is lost reruns elsewhere; one that cannot run at all is a miss that says why.
    """
    out = output.prepare_dir(out)
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    start = time.perf_counter()
    pieces = [(job, Path(job.robot).name, Path(job.robot).read_bytes()) for job in batch.jobs]
    results: dict[int, JobResult] = {}
    for job in batch.jobs:
        if on_start is not None:
            on_start(job)

    def finished(index: int, value) -> None:
        results[index] = _collect(batch.jobs[index], value, out)
        if on_done is not None:
            on_done(results[index], len(results), len(batch.jobs))

    ran = executors.run(executors.Work(_no_setup, run_remote, None, label="anadyn-batch"),
                        pieces, scheduler=scheduler, on_done=finished)
    return BatchResult(batch, [results[i] for i in range(len(batch.jobs))], ran.workers,
                       time.perf_counter() - start, started)


def _no_setup(payload) -> None:
    return None


def run_remote(state, piece) -> tuple:
    """On a worker: one job in a temporary folder; (exit code, wall, stdout, stderr,
    {file name: bytes} of its result folder, timed out)."""
    import tempfile
    from dataclasses import replace

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


def raise_if_failed(result: BatchResult) -> None:
    """CheckFailed naming each job that missed its expectation."""
    failed = result.failed
    if failed:
        names = "; ".join(f"{r.job.key} ({r.failures[0]})" for r in failed)
        raise CheckFailed(f"batch: {len(failed)} of {len(result.results)} jobs missed "
                          f"their expectations: {names}")


# ----------------------------------------------------------------------------
# reports
# ----------------------------------------------------------------------------
def job_line(result: JobResult, finished: int, total: int) -> str:
    """``[3/12] ok   simulate rr  0.9 s`` (the first miss after a colon)."""
    line = (f"[{finished}/{total}] {result.status:<4} {result.job.command} {result.job.name}"
            f"  {result.wall:.1f} s")
    return line + (f": {'; '.join(result.failures)}" if result.failures else "")


def figures_text(result: JobResult) -> str:
    return "; ".join(f"{k}={_show(v)}" for k, v in result.figures.items())


def table(result: BatchResult) -> str:
    header = ["job", "status", "exit", "expected", "wall s", "figures"]
    body = [[r.job.key, r.status, "-" if r.exit_code is None else str(r.exit_code),
             r.job.expect.describe_exit(), f"{r.wall:.1f}", figures_text(r)]
            for r in result.results]
    widths = [max(len(row[i]) for row in [header, *body]) for i in range(len(header) - 1)]
    return "\n".join("  ".join(f"{c:<{w}}" for c, w in zip(row, widths)) + "  " + row[-1]
                     for row in [header, *body])


def totals_line(result: BatchResult) -> str:
    failed = len(result.failed)
    return (f"batch {result.batch.source}: {len(result.results)} jobs, "
            f"{len(result.results) - failed} ok, {failed} failed, {result.wall:.1f} s "
            f"on {result.workers} worker{'s' if result.workers != 1 else ''}")


def _job_dict(result: JobResult, out: Path) -> dict:
    job = result.job
    return {"name": job.name, "command": job.command, "robot": job.robot,
            "options": list(job.options), "status": result.status, "ok": result.ok,
            "exit_code": result.exit_code, "expected_exit_code": job.expect.exit_code,
            "wall_s": result.wall, "figures": result.figures, "failures": result.failures,
            "folder": str(job.folder(out)), "argv": job.argv(out)[1:],
            "stdout": excerpt(result.stdout), "stderr": excerpt(result.stderr)}


def summary(result: BatchResult, out: Path) -> dict:
    """``summary.json``."""
    return {"batch": result.batch.source, "description": result.batch.description,
            "started": result.started, "wall_s": result.wall, "workers": result.workers,
            "jobs_total": len(result.results), "jobs_failed": len(result.failed),
            "passed": not result.failed,
            "failed": [r.job.key for r in result.failed],
            "jobs": [_job_dict(r, out) for r in result.results]}


def csv_text(result: BatchResult, out: Path) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["command", "name", "robot", "status", "exit_code", "expected_exit_code",
                     "wall_s", "figures", "failures", "folder"])
    for r in result.results:
        writer.writerow([r.job.command, r.job.name, r.job.robot, r.status,
                         "" if r.exit_code is None else r.exit_code,
                         r.job.expect.describe_exit(), f"{r.wall:.3f}", figures_text(r),
                         "; ".join(r.failures), str(r.job.folder(out))])
    return buffer.getvalue()


_NOT_XML = re.compile("[^\t\n\r\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _xml_text(text: str) -> str:
    """``text`` with what XML 1.0 forbids, or discourages (controls, noncharacters),
    as ``?``: a control character in a job's output cannot break the report."""
    return _NOT_XML.sub("?", str(text))


def junit_text(result: BatchResult) -> str:
    """One <testsuite>, one <testcase> per job (classname = command, name = job name): a
    miss is a <failure>, a job that did not finish (timed out, could not start) an
    <error>; every text and attribute goes through ``_xml_text``."""
    import xml.etree.ElementTree as ET

    def element(parent, tag: str, text: str | None = None, **attributes):
        node = (ET.Element(tag) if parent is None else ET.SubElement(parent, tag))
        node.attrib.update({k: _xml_text(v) for k, v in attributes.items()})
        if text is not None:
            node.text = _xml_text(text)
        return node

    errors = [r for r in result.failed if r.error]
    suite = element(None, "testsuite", name=f"anadyn batch {result.batch.source}",
                    tests=str(len(result.results)),
                    failures=str(len(result.failed) - len(errors)), errors=str(len(errors)),
                    skipped="0", time=f"{result.wall:.3f}", timestamp=result.started)
    for r in result.results:
        case = element(suite, "testcase", classname=r.job.command, name=r.job.name,
                       time=f"{r.wall:.3f}")
        if r.failures:
            kind = (("error", "timeout" if r.timed_out else "not-run") if r.error
                    else ("failure", "expectation"))
            element(case, kind[0], "\n".join(r.failures) + "\n\nstderr:\n" + excerpt(r.stderr),
                    message=r.failures[0], type=kind[1])
        if r.figures:
            properties = element(case, "properties")
            for key, value in r.figures.items():
                element(properties, "property", name=key, value=_show(value))
        element(case, "system-out", excerpt(r.stdout))
        if r.stderr.strip():
            element(case, "system-err", excerpt(r.stderr))
    ET.indent(suite)
    return ET.tostring(suite, encoding="unicode", xml_declaration=True) + "\n"


def write(result: BatchResult, out: Path) -> list[Path]:
    """summary.csv, summary.json and junit.xml in ``out``, written with signals held."""
    from .. import progress

    out = output.prepare_dir(out)
    written = [out / "summary.csv", out / "summary.json", out / "junit.xml"]
    texts = (csv_text(result, out), summary(result, out), junit_text(result))
    with progress.uninterrupted():        # the three of this batch, or those there before
        output.write_text(written[0], texts[0])
        output.write_json(written[1], texts[1])
        output.write_text(written[2], texts[2])
    return written


class Progress:
    """Progress of a batch.  On a terminal (``live``): a bar with the jobs done and
    failed and the elapsed time, and one line per running job naming it with its
    own clock, all redrawn several times a second by rich on its own thread (so
    the clocks tick while jobs run); a missed job's line stays on screen.  Else
    (a pipe, a file, or ``CI`` set): one plain line per finished job, for CI logs."""

    def __init__(self, stream, live: bool, total: int):
        import threading

        self.stream, self.live, self.total = stream, live, total
        self.start, self.failed, self.finished, self.running = time.perf_counter(), 0, 0, 0
        self.lock = threading.Lock()            # jobs start on worker threads
        self.bars = None
        self.rows: dict[int, object] = {}       # id(job) -> its line
        if live:
            from rich.console import Console
            from rich.progress import (BarColumn, Progress as Bars, SpinnerColumn,
                                       TextColumn, TimeElapsedColumn)

            console = Console(file=stream, force_terminal=True)
            self.bars = Bars(SpinnerColumn(), TextColumn("{task.description}", markup=False),
                             BarColumn(bar_width=24), TextColumn("{task.fields[status]}",
                                                                 markup=False),
                             TimeElapsedColumn(), console=console, transient=True,
                             refresh_per_second=4)
            self.overall = self.bars.add_task("batch", total=max(1, total),
                                              status=self._status())
            self.bars.start()

    @staticmethod
    def wanted(stream) -> bool:
        return bool(getattr(stream, "isatty", lambda: False)()) and not os.environ.get("CI")

    def _status(self) -> str:
        return (f"{self.finished}/{self.total} done, {self.running} running, "
                f"{self.failed} failed")

    def started(self, job: Job) -> None:
        with self.lock:
            self.running += 1
            if self.bars is not None:
                self.rows[id(job)] = self.bars.add_task(f"  {job.command} {job.name}",
                                                        total=None, status="running")
                self.bars.update(self.overall, status=self._status())

    def done(self, result: JobResult, finished: int, total: int) -> None:
        with self.lock:
            self.running -= 1
            self.finished = finished
            self.failed += not result.ok
            if self.bars is not None:
                row = self.rows.pop(id(result.job), None)
                if row is not None:
                    self.bars.remove_task(row)
                if not result.ok:          # keep the misses on screen
                    self.bars.console.print(job_line(result, finished, total), markup=False,
                                            highlight=False)
                self.bars.update(self.overall, completed=finished, status=self._status())
            else:
                self.stream.write(job_line(result, finished, total) + "\n")
                self.stream.flush()

    def close(self) -> None:
        if self.bars is not None:
            self.bars.stop()
            self.bars = None

