"""Running a sweep's samples through ``studies.executors``: locally on worker
processes or on Dask, then judging each against the bounds and the file's limits."""
from __future__ import annotations

import math
from typing import Callable

from .. import executors
from .plan import Plan
from .report import SweepResult
from .sample import setup, work


def run(plan: Plan, jobs: int | None = None, scheduler=None,
        on_progress: Callable[[int, int, int], None] | None = None) -> SweepResult:
    """Run every sample, locally on ``jobs`` processes or on Dask (``scheduler``: an
    address or a ``distributed.Client``); ``on_progress(done, failed, total)`` as
    pieces finish."""
    import scipy.integrate  # noqa: F401  forked workers start with it (and the services) loaded

    from ...services import check, inverse, simulate  # noqa: F401

    design = plan.design
    total = design.count
    if isinstance(scheduler, str):             # an address: connect for this run only
        client = executors.connect(scheduler)
        try:
            return run(plan, scheduler=client, on_progress=on_progress)
        finally:
            client.close()
    work_ = executors.Work(setup, work, plan.payload, label="anadyn-sweep")
    workers = (executors.workers(scheduler) if scheduler is not None
               else min(executors.check_jobs(jobs), total))
    samples = [(i, tuple(float(v) for v in design.values[i])) for i in range(total)]
    pieces = [[samples[i] for i in r] for r in executors.chunks(total, max(1, workers))]
    done = [0, 0]

    def finished(index: int, result) -> None:
        if isinstance(result, BaseException):
            done[0] += len(pieces[index])
            done[1] += len(pieces[index])
        else:
            done[0] += len(result)
            done[1] += sum(row["status"] != "ok" for _, row, _, _ in result)
        if on_progress is not None:
            on_progress(done[0], done[1], total)

    ran = executors.run(work_, pieces, jobs=workers, scheduler=scheduler, on_done=finished)
    rows: list = [None] * total
    solve = sample = 0.0
    for piece, result in zip(pieces, ran.results):
        if isinstance(result, BaseException):      # lost for good (Dask gave up)
            why = f"{type(result).__name__}: {result}".splitlines()[0]
            for index, _ in piece:
                rows[index] = {"status": "error", "reason": f"not run ({why})"}
            continue
        for index, row, seconds, whole in result:
            rows[index] = row
            solve += seconds
            sample += whole
    for index, row in enumerate(rows):
        for name, value in zip(design.names, design.values[index]):
            row[name] = float(value)
        _judge_limits(plan, row)
    return SweepResult(plan, rows, ran.executor, ran.workers, ran.address, ran.wall, solve,
                       sample, dict(plan.timings))


def _judge_limits(plan: Plan, row: dict) -> None:
    """within_limits: every --max/--min bound holds and the run passes none of the
    file's joint limits; limit_miss says which do not."""
    file_limit = row.pop("_file_limit", "")
    if not plan.judged:
        return
    if row["status"] != "ok":
        row["within_limits"], row["limit_miss"] = 0, f"not run ({row['status']})"
        return
    misses = [f"file limit {file_limit}"] if file_limit else []
    for metric, kind, bound in plan.bounds:
        value = row.get(metric, math.nan)
        if not (value <= bound if kind == "max" else value >= bound):
            misses.append(f"{metric} {value:.4g} {'>' if kind == 'max' else '<'} {bound:g}")
    row["within_limits"] = int(not misses)
    row["limit_miss"] = "; ".join(misses)

