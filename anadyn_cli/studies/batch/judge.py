"""How a job ended, judged against its expectation: ``JobResult``, ``BatchResult``,
``judge`` (exit code and the figures of ``<command>.json``)."""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

from ...errors import CheckFailed
from .plan import Batch, Job


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
            result.failures.append(f"{path} = {show_value(value)}, expected {show_value(wanted)}")


def _bound(result: JobResult, data, name: str, path: str, bound: float, kind: str) -> None:
    found, value = lookup(data, path)
    if not found:
        result.failures.append(f"{path}: missing in {name}")
        return
    result.figures[path] = value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        result.failures.append(f"{path} = {show_value(value)} in {name}, expected a number")
    elif kind == "max" and not value <= bound:
        result.failures.append(f"{path} = {show_value(value)} > max {bound:g}")
    elif kind == "min" and not value >= bound:
        result.failures.append(f"{path} = {show_value(value)} < min {bound:g}")


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


def show_value(value) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    return json.dumps(value) if not isinstance(value, str) else repr(value)


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else ""


def raise_if_failed(result: BatchResult) -> None:
    """CheckFailed naming each job that missed its expectation."""
    failed = result.failed
    if failed:
        names = "; ".join(f"{r.job.key} ({r.failures[0]})" for r in failed)
        raise CheckFailed(f"batch: {len(failed)} of {len(result.results)} jobs missed "
                          f"their expectations: {names}")
