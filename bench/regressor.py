"""The joint-torque regressor (``anadyn.parametric_model(robot).regressor``) on many
states, against Pinocchio, in one run.

    python3 bench/regressor.py [--states N] [--robots ur5,panda] [--before REV]

For N states (default 1,000) of each robot (the UR5, n = 6, p = 78; the Panda with
its fingers, n = 8, p = 117), Y (N x n x p) by

- ``native``: the generated C (``numeric.recursive.regressor``), one call over the
  rows of the states;
- ``numpy``: the generated Python, vectorized over the states by NumPy (what runs
  without a compiler, ANADYN_NATIVE=0);
- ``native loop``: the C called once per state from Python;
- ``pinocchio loop``: Pinocchio's ``computeJointTorqueRegressor`` called once per
  state from Python (its n x 10 nb block only, no drive columns);
- ``old numpy``: the hand-written NumPy regressor that the generated one replaced,
  vectorized over the states, as the repository's commit REV (default BEFORE) has
  it in ``studies/identification/regressor.py`` (``git show``; left out where git
  or the commit is missing).

Before the timings, Y is checked against Pinocchio's (each moving body's ten columns;
``tests/test_regressor.py`` has the full check) and the native against the NumPy.
Also printed: the traced operations per state and the time to trace and compile the
regressor into an empty cache (a first use).  Times are the best of a few repeats
(the machine is noisy); ratios are against ``native``.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

from anadyn_cli.numeric.recursive import plan  # noqa: E402
from anadyn_cli.numeric.recursive.regressor import Regressor, trace_regressor  # noqa: E402
from test_identification import Pinocchio, _states  # noqa: E402

#: robot -> its URDF in the test data (Pinocchio reads the same file)
URDF = {"ur5": "ur5_robot.urdf", "panda": "panda.urdf"}
#: the last commit with the hand-written NumPy regressor
BEFORE = "19ac0db"
OLD = "anadyn_cli/studies/identification/regressor.py"


def old_regressor(rev: str):
    """``parametric_model`` of the NumPy regressor at commit ``rev`` of this repository
    (run in its package, whose modules it imports, as they are now), or None."""
    try:
        text = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:{OLD}"], check=True,
                              capture_output=True, text=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    name = "anadyn_cli.studies.identification.regressor_before"
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(name, None))
    module.__package__ = "anadyn_cli.studies.identification"
    sys.modules[name] = module                 # dataclasses look their module up
    exec(compile(text, f"{rev}:{OLD}", "exec"), module.__dict__)   # noqa: S102 (own history)
    return module.parametric_model


def best(f, repeat: int = 5) -> float:
    """Seconds of f(), the best of ``repeat`` runs."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return min(times)


def cold_build(robot) -> float:
    """Seconds to trace and compile the regressor with an empty native cache."""
    before = os.environ.get("ANADYN_CACHE_DIR")
    with tempfile.TemporaryDirectory() as folder:
        os.environ["ANADYN_CACHE_DIR"] = folder
        try:
            start = time.perf_counter()
            Regressor(plan(robot))
            return time.perf_counter() - start
        finally:
            if before is None:
                del os.environ["ANADYN_CACHE_DIR"]
            else:
                os.environ["ANADYN_CACHE_DIR"] = before


def run(name: str, count: int, before) -> None:
    oracle = Pinocchio(ROOT / "tests" / "data" / "urdf" / URDF[name])
    model, robot = oracle.model, oracle.robot
    os.environ["ANADYN_NATIVE"] = "wait"
    native = Regressor(model.plan)
    python = Regressor(model.plan, native=False)
    if native.native is None:
        sys.exit(f"no native regressor: {native.note}")
    q, dq, ddq = _states(model, count, 1)
    Y = native(q, dq, ddq)
    scale = np.abs(Y).max()
    worst = 0.0
    for k in range(min(count, 50)):
        pin_Y = oracle.regressor(q[k], dq[k], ddq[k])
        for j, row in enumerate(oracle.rows):
            b = model.moving[row]
            worst = max(worst, np.abs(Y[k][:, 10 * b:10 * b + 10]
                                      - pin_Y[:, 10 * j:10 * j + 10]).max())
    numpy_difference = np.abs(python(q, dq, ddq) - Y).max()
    counts = trace_regressor(model.plan).counts
    n, p = Y.shape[1:]
    print(f"{name}: n = {n}, p = {p}, {count} states; per state {counts.mul} mul, "
          f"{counts.add} add, {counts.calls} calls")
    print(f"  check: |Y - Pinocchio| / max|Y| = {worst / scale:.1e} (50 states); "
          f"|native - numpy| / max|Y| = {numpy_difference / scale:.1e}")
    print(f"  first use (trace + compile, empty cache): {cold_build(robot):.2f} s")
    joints = [oracle.joints(q[k], dq[k], ddq[k]) for k in range(count)]
    configurations = [oracle.configuration(theta) for theta, _, _ in joints]

    def pinocchio_loop():
        for config, (_, rate, acc) in zip(configurations, joints):
            pin.computeJointTorqueRegressor(oracle.pin, oracle.data, config, rate, acc)

    rows = [tuple(a[k:k + 1] for a in (q, dq, ddq)) for k in range(count)]

    def native_loop():
        for state in rows:
            native(*state)

    timings = {"native": best(lambda: native(q, dq, ddq)),
               "numpy": best(lambda: python(q, dq, ddq)),
               "native loop": best(native_loop, 3),
               "pinocchio loop": best(pinocchio_loop, 3)}
    if before is not None:
        old = before(robot)
        assert np.abs(old.regressor(q, dq, ddq) - Y).max() <= 1e-12 * scale
        timings["old numpy"] = best(lambda: old.regressor(q, dq, ddq), 3)
    base = timings["native"]
    for label, seconds in timings.items():
        print(f"  {label:<15} {seconds * 1e3:9.3f} ms  {seconds / count * 1e6:8.2f} us/state  "
              f"{seconds / base:7.2f} x native")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=1000)
    parser.add_argument("--robots", default="ur5,panda")
    parser.add_argument("--before", default=BEFORE, help="the commit of the old regressor")
    args = parser.parse_args()
    before = old_regressor(args.before)
    if before is None:
        print(f"old numpy: left out (no git, or no {OLD} at {args.before})")
    for name in args.robots.split(","):
        run(name.strip(), args.states, before)


if __name__ == "__main__":
    main()
