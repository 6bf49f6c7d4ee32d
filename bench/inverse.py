"""Inverse dynamics over many points: anadyn's recursive path against Pinocchio's RNEA.

    python bench/inverse.py [--robots chain6 chain12 tree30 arm7] [--points 20000]
                            [--repeats 3]

Robots from ``bench/scale_robots.py`` (anadyn YAML and URDF with the same
numbers); ``points`` random states (q, dq, ddq).  For each robot, in one run:

  rnea C      tau = B^-1 (M ddq - F) with M ddq - F by the generated recursive
              Newton-Euler algorithm, the C kernel looping over the points, and
              B alone (``NativeModel.demand``: what a warm ``anadyn inverse`` runs)
  rnea py     the same in the generated NumPy code, vectorized over the points
              (a cold run, or no compiler)
  mfb         the same efforts from the full M, F, B (what ``inverse`` ran
              before: O(n^2) a point for M)
  pinocchio   ``pin.rnea`` called once per point from Python (what a user
              would write), with its own load time excluded

Times are the minimum of ``--repeats`` runs (the machine is noisy), printed as
microseconds per point and as ratios against Pinocchio from the same run;
operation counts (multiplications + additions) of the generated functions
beside them.  The efforts must agree with Pinocchio's to 1e-9 relative, or the
script exits 1.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import scale_robots as sr  # noqa: E402

SPECS = sr.SPECS


def best_of(repeats: int, run):
    best, value = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        value = run()
        best = min(best, time.perf_counter() - start)
    return best, value


def measure(spec: sr.Spec, folder: Path, points: int, repeats: int) -> dict:
    import pinocchio as pin
    from anadyn_cli import robot_from_text
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import native, recursive
    from anadyn_cli.services.inverse import InverseDynamics

    urdf = folder / f"{spec.name}.urdf"
    urdf.write_text(sr.to_urdf(spec))
    robot = robot_from_text(sr.to_yaml(spec), f"{spec.name}.yaml")
    gen = recursive.generate(robot)
    code, info = recursive.module_source(gen), RobotInfo.from_robot(robot)
    model = native.RecursiveModel(info, code)                      # generated NumPy
    module, why = native.build(native.c_source(gen))
    if module is None:
        raise SystemExit(f"no native build: {why}")
    fast = native.NativeModel(info, code, "recursive", module)     # C
    n = model.n
    rng = np.random.default_rng(1)
    q, dq, ddq = (rng.uniform(-1, 1, (points, n)) for _ in range(3))

    def rnea(model=model):
        demand, B = model.demand(0.0, q.T, dq.T, ddq.T)
        return InverseDynamics.solve(demand, np.broadcast_to(B, (points, n, n)))

    def mfb():
        M, F, B = model.mfb(0.0, q.T, dq.T)
        return InverseDynamics.solve(np.einsum("kij,kj->ki", M, ddq) - F, B)

    pmodel = pin.buildModelFromUrdf(str(urdf))
    pmodel.gravity.linear = np.array(spec.gravity)
    data = pmodel.createData()
    order = np.array([pmodel.joints[pmodel.getJointId(f"j_{link.name}")].idx_v
                      for link in spec.links])            # anadyn's k -> Pinocchio's index
    place = np.empty(n, dtype=int)
    place[order] = np.arange(n)
    pq, pdq, pddq = (np.ascontiguousarray(v[:, place]) for v in (q, dq, ddq))

    def pinocchio():
        out = np.empty((points, n))
        for k in range(points):
            out[k] = pin.rnea(pmodel, data, pq[k], pdq[k], pddq[k])
        return out[:, order]

    row = {"name": spec.name, "n": n}
    row["c_s"], tau_c = best_of(repeats, lambda: rnea(fast))
    row["rnea_s"], tau = best_of(repeats, rnea)
    row["mfb_s"], tau_mfb = best_of(repeats, mfb)
    row["pin_s"], tau_pin = best_of(repeats, pinocchio)
    scale = max(np.abs(tau_pin).max(), 1e-300)
    row["error"] = float(max(np.abs(tau - tau_pin).max(), np.abs(tau_c - tau_pin).max()) / scale)
    row["error_mfb"] = float(np.abs(tau_mfb - tau_pin).max() / scale)
    for name in ("inverse_dynamics", "mfb"):
        c = gen.counts(name)
        row[f"ops_{name}"] = c.mul + c.add
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="*", default=["chain6", "chain12", "tree30", "arm7", "panda"],
                        choices=sorted(SPECS))
    parser.add_argument("--points", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        print("bench/inverse.py needs Pinocchio (pip install pin)")
        return 2
    rows = []
    with tempfile.TemporaryDirectory(prefix="anadyn-inverse-") as tmp:
        os.environ["ANADYN_CACHE_DIR"] = tmp              # the C builds, then gone
        for name in args.robots:
            rows.append(measure(SPECS[name](), Path(tmp), args.points, args.repeats))
    print(f"{args.points} random states a robot; us per point (minimum of {args.repeats} runs); "
          "ratio = anadyn / Pinocchio (< 1: anadyn faster)")
    print(f"{'robot':>8} {'n':>3} {'C us':>7} {'py us':>7} {'mfb us':>7} {'pin us':>7} "
          f"{'C/pin':>6} {'py/pin':>7} {'mfb/pin':>8} {'ops ID':>7} {'ops mfb':>8} "
          f"{'|tau - pin|':>12}")
    ok = True
    for r in rows:
        us = {k: r[f"{k}_s"] / args.points * 1e6 for k in ("c", "rnea", "mfb", "pin")}
        print(f"{r['name']:>8} {r['n']:>3} {us['c']:7.3f} {us['rnea']:7.3f} {us['mfb']:7.3f} "
              f"{us['pin']:7.3f} {us['c'] / us['pin']:6.2f} {us['rnea'] / us['pin']:7.2f} "
              f"{us['mfb'] / us['pin']:8.2f} {r['ops_inverse_dynamics']:>7} {r['ops_mfb']:>8} "
              f"{r['error']:12.1e}")
        ok = ok and r["error"] <= 1e-9 and r["error_mfb"] <= 1e-9
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
