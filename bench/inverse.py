"""Benchmark: inverse dynamics over a time grid, vectorized against a per-point loop.

    python bench/inverse.py [--robot robots/rrt.yaml] [--points 100000] [--repeats 5]

Both paths use the same compiled functions: the trajectory's generated
``motion(t) -> q, dq, ddq`` and the robot's generated ``mfb(t, q, dq) -> M, F, B``,
then tau = B^-1 (M ddq - F).

  vectorized   one call of each over the whole grid, one batched solve
               (``InverseDynamics.efforts``, what ``anadyn inverse`` runs)
  loop         a Python loop calling the same functions on one time point at a
               time (scalars in, small arrays out) and numpy.linalg.solve

Each is timed as the minimum of ``--repeats`` runs (the machine is noisy);
points/s and their ratio come from the same run.  The two results must agree
to 1e-12 relative, or the script exits 1.  For scale: Pinocchio's RNEA called
once per point from Python manages about 3-5 x 10^5 points/s on these machines.
"""
from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from anadyn_cli import load_robot                      # noqa: E402
from anadyn_cli.numeric.build import numeric_model             # noqa: E402
from anadyn_cli.services.inverse import InverseDynamics         # noqa: E402
from anadyn_cli.numeric.trajectory import motion               # noqa: E402


def best_of(repeats: int, run) -> tuple[float, object]:
    best, value = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        value = run()
        best = min(best, time.perf_counter() - start)
    return best, value


def loop(dynamics: InverseDynamics, t: np.ndarray) -> np.ndarray:
    """The per-point baseline: the same generated functions, one time at a time."""
    prescribed, mfb = dynamics.motion, dynamics.compiled.mfb
    out = np.empty((len(t), dynamics.m))
    for k, moment in enumerate(t.tolist()):
        q, dq, ddq = prescribed(moment)
        M, F, B = mfb(moment, q, dq)
        out[k] = np.linalg.solve(B, M @ ddq - F)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default=str(ROOT / "robots" / "rrt.yaml"))
    parser.add_argument("--formulation", default="kane", choices=("kane", "lagrange"))
    parser.add_argument("--points", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--loop-repeats", type=int, default=3)
    args = parser.parse_args()

    robot = load_robot(args.robot)
    compiled = numeric_model(robot, args.formulation)
    dynamics = InverseDynamics(compiled, motion(robot))
    duration = float(robot.trajectory.duration)
    t = np.linspace(0.0, duration, args.points)
    print(f"robot {robot.name} ({args.formulation}): n = {dynamics.n} coordinates, "
          f"m = {dynamics.m} actuators, {robot.trajectory.kind} motion over {duration:g} s, "
          f"{args.points} time points")
    print(f"python {platform.python_version()}, numpy {np.__version__}, "
          f"{platform.machine()}; minimum of {args.repeats} (vectorized) and "
          f"{args.loop_repeats} (loop) runs")

    dynamics.efforts(t[:10])                                   # warm up
    vector_time, result = best_of(args.repeats, lambda: dynamics.efforts(t))
    tau = result[3]
    parts = {}
    parts["motion"], (q, dq, ddq) = best_of(args.repeats, lambda: dynamics.motion(t))
    parts["mfb"], (M, F, B) = best_of(args.repeats, lambda: dynamics.matrices(t, q, dq))
    parts["solve"], _ = best_of(args.repeats, lambda: dynamics.solve(M, F, B, ddq))
    loop_time, looped = best_of(args.loop_repeats, lambda: loop(dynamics, t))

    scale = np.abs(tau).max(axis=0)
    worst = float((np.abs(tau - looped) / scale).max())
    vector_rate, loop_rate = args.points / vector_time, args.points / loop_time
    print()
    print(f"{'path':<12}{'calls of mfb':>14}{'time (s)':>12}{'points/s':>14}{'us/point':>11}")
    print(f"{'vectorized':<12}{1:>14}{vector_time:>12.4f}{vector_rate:>14.3e}"
          f"{1e6 / vector_rate:>11.3f}")
    print(f"{'loop':<12}{args.points:>14}{loop_time:>12.4f}{loop_rate:>14.3e}"
          f"{1e6 / loop_rate:>11.3f}")
    print()
    print(f"vectorized / loop: {vector_rate / loop_rate:.1f}x; target >= 1e6 points/s: "
          f"{'met' if vector_rate >= 1e6 else 'NOT met'}")
    print("vectorized split: " + ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in parts.items()))
    print(f"largest difference between the paths: {worst:.2e} (relative to each effort's range)")
    return 0 if worst <= 1e-12 else 1


if __name__ == "__main__":
    sys.exit(main())
