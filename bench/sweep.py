"""Benchmark: what a sweep costs beyond its solves, locally and on Dask.

    python bench/sweep.py [--robot robots/rr.yaml] [--vary m2=uniform(0.5,2)] [--samples 1000]
                          [--workers 2] [--no-dask]

One plan (the robot derived and compiled once with the varied name free),
then the same samples run four ways:

  baseline     a bare loop in this process: bind the sample's value, integrate
               (``integrators.integrate``, what simulate runs), nothing else;
               its summed wall time is the sum of the solve times, measured
               apart from any sweep machinery
  this process ``sweep.run(jobs=1)``: setup, binding, the simulate service,
               the metrics, collecting the rows
  processes    ``sweep.run(jobs=W)``: W forked worker processes
  dask         a Dask ``LocalCluster`` of W worker processes on loopback, started
               here (its start-up is timed apart), run twice: on fresh workers
               (each imports anadyn and SciPy and compiles the robot on its first
               piece) and again on the same, warm workers

Cost is counted in CPU seconds: every process a run involves (this one, with
Dask's scheduler and nannies, the forked workers once they exit, the Dask
workers as psutil sees them) over the CPU seconds of the baseline's bare
solves; the issue asks for at most 1.3.  Wall time x workers over the
baseline's wall time is printed beside it, but on these 2 shared cores other
people's jobs inflate every wall time of a run with 2 workers (the load
average is printed before and after).  Every executor must give the same
sweep.csv byte for byte and the same RHS-call total as the baseline, or the
script exits 1.
"""
from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from anadyn_cli.numeric import integrators                  # noqa: E402
from anadyn_cli.studies import sweep                       # noqa: E402

LIMIT = 1.3
TUNING = {"distributed.worker.profile.enabled": False,
          "distributed.admin.tick.interval": "200ms",
          "distributed.admin.system-monitor.interval": "2s",
          "distributed.worker.memory.monitor-interval": "1s",
          "distributed.scheduler.work-stealing-interval": "1s"}


def baseline(plan) -> tuple[float, float, int]:
    """(summed solve seconds, their CPU seconds, RHS calls) of bare solves of every
    sample, in this process."""
    runner = sweep.Runner(plan.payload)
    model, options = runner.model, runner.options
    from anadyn_cli.numeric.settings import output_grid

    grid = output_grid(options["t_end"], options["output_step"])
    seconds, cpu, calls = 0.0, 0.0, 0
    for values in plan.design.values:
        model.bind(values)
        moment = time.process_time()
        solution = integrators.integrate(model.problem(), model.initial_state(), grid,
                                         options["method"], options["rtol"], options["atol"])
        cpu += time.process_time() - moment
        seconds += solution.wall
        calls += solution.rhs_calls
    return seconds, cpu, calls


class CPU:
    """CPU seconds of this process, its finished children and the given live processes."""

    def __init__(self, pids=()):
        self.pids = list(pids)
        self.start = self._now()

    def _now(self) -> float:
        import resource

        import psutil

        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        total = time.process_time() + children.ru_utime + children.ru_stime
        for pid in self.pids:
            times = psutil.Process(pid).cpu_times()
            total += times.user + times.system
        return total

    def used(self) -> float:
        return self._now() - self.start


def line(label: str, result, cpu: float, solve: float, solve_cpu: float) -> str:
    return (f"{label:<22} {result.wall:6.2f} s x{result.workers} {result.samples_per_second:6.1f}"
            f" samples/s | CPU {cpu:6.2f} s = {cpu / solve_cpu:4.2f} x solves' CPU | wall x "
            f"workers = {result.wall * result.workers / solve:4.2f} x solves' wall")


def calls(result) -> int:
    return sum(int(r.get("rhs_calls", 0)) for r in result.rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default=str(ROOT / "robots" / "rr.yaml"))
    parser.add_argument("--vary", default="m2=uniform(0.5,2)")
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--no-dask", action="store_true")
    args = parser.parse_args()

    print(f"python {platform.python_version()}, {platform.machine()}, "
          f"{args.samples} samples of {args.robot} with {args.vary}, {args.workers} workers")
    start = time.perf_counter()
    plan = sweep.plan(args.robot, [args.vary], samples=args.samples, seed=1,
                      metrics="effort,tracking,settling,final,calls")
    print(f"plan: load, derive and compile once in {time.perf_counter() - start:.2f} s "
          f"({', '.join(f'{k} {v:.3f} s' for k, v in plan.timings.items() if isinstance(v, float))})")
    import os

    print(f"load average before: {', '.join(f'{v:.2f}' for v in os.getloadavg())} "
          f"on {os.cpu_count()} cores")
    solve, solve_cpu, base_calls = baseline(plan)
    print(f"{'baseline (bare solves)':<22} {solve:6.2f} s x1 {args.samples / solve:6.1f} "
          f"samples/s | CPU {solve_cpu:6.2f} s | {base_calls} RHS calls")
    runs, ratios = {}, {}

    def timed(label: str, pids=(), **how) -> None:
        cpu = CPU(pids)
        runs[label] = sweep.run(plan, **how)
        used = cpu.used()
        ratios[label] = used / solve_cpu
        print(line(label, runs[label], used, solve, solve_cpu))

    timed("sweep, this process", jobs=1)
    timed(f"sweep, {args.workers} processes", jobs=args.workers)
    if not args.no_dask:
        import distributed

        moment = time.perf_counter()
        import dask

        # a cluster set up for many short tasks: anadyn imported when a worker starts
        # (--preload), no statistical profiler (it samples every thread's stack every
        # 10 ms), and slower housekeeping ticks; idle, Dask's defaults cost ~6 % of a
        # core across scheduler and 2 workers, these ~1.7 % (measured here)
        with dask.config.set(TUNING), \
                distributed.LocalCluster(n_workers=args.workers, threads_per_worker=1,
                                         processes=True, host="127.0.0.1",
                                         dashboard_address=None,
                                         preload=["anadyn_cli.studies.sweep"]
                                         ) as cluster, \
                distributed.Client(cluster, set_as_default=False) as client:
            print(f"dask LocalCluster of {args.workers} processes started in "
                  f"{time.perf_counter() - moment:.2f} s (not counted)")
            pids = list(client.run(os.getpid).values())
            timed("dask, first sweep", pids, scheduler=client)
            timed("dask, second sweep", pids, scheduler=client)
    reference = sweep.csv_text(runs["sweep, this process"])
    ok = True
    for label, result in runs.items():
        if sweep.csv_text(result) != reference or calls(result) != base_calls:
            print(f"MISMATCH: {label} differs from this process's sweep.csv or RHS calls")
            ok = False
        if result.counts["ok"] != args.samples:
            print(f"{label}: {result.counts}")
    print(f"every executor: the same sweep.csv, byte for byte, and {base_calls} RHS calls "
          f"as the bare solves" if ok else "executors disagree")
    print(f"load average after: {', '.join(f'{v:.2f}' for v in os.getloadavg())}")
    for label, ratio in ratios.items():
        print(f"{label:<22} costs {ratio:.2f} x the CPU of its solves "
              f"({'within' if ratio <= LIMIT else 'OVER'} {LIMIT})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
