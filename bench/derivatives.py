"""Open-loop derivatives (``anadyn.derivatives``) against Pinocchio, in one run.

    python3 bench/derivatives.py [--batch N] [--robots ur5,panda,solo12,baxter]
                                 [--rounds R]

Per call (one state, from Python): anadyn's ``forward_derivatives`` and
``inverse_derivatives`` (the C extension; the generated Python in its own column)
against Pinocchio's ``computeABADerivatives`` and ``computeRNEADerivatives``
(goal: anadyn / Pinocchio <= 0.5), and against central differences of anadyn's own
forward dynamics (2 (2n + m) calls of ``forward_dynamics``), on the UR5 (n = 6),
the Panda with its fingers locked (n = 7; Pinocchio's model reduced the same way),
Solo-12 (n = 12, a tree of four legs) and, with --robots, example-robot-data's
Baxter (n = 17), roots welded.  Where a call's time goes: ``C entry`` is the
extension's one-state function called directly (its argument checks, the result
arrays and the kernel), ``kernel`` the kernel alone, per state of a batch of
BATCH_KERNEL states in one call (no Python, warm caches); the Python method adds
the rest.  The calls of one robot are timed in turns, R rounds of bursts of calls,
the thread's CPU time, the best burst of each (the machine is shared and noisy).
Batched, N states (default 10,000): ``forward_dynamics`` and ``forward_derivatives``
in one call against a Python loop of Pinocchio's ``aba`` / ``computeABADerivatives``
and against a Python loop of anadyn's single-state call (timed on N/10 states and
scaled).  Prints times (microseconds per call, seconds per N states) and ratios,
and the multiplications and additions of the generated K and M by each algorithm
(forward mode over the traced RNEA, the analytic RNEA derivatives; the cheaper runs).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

import anadyn  # noqa: E402
from anadyn_cli import robot_from_text  # noqa: E402
from anadyn_cli.model.urdf import import_file  # noqa: E402
from anadyn_cli.numeric.recursive import derivatives as traced, plan  # noqa: E402
from test_generic_kernel import URDFS, erd  # noqa: E402


def best(f, repeat: int = 5, number: int = 20) -> float:
    """CPU seconds (this thread) per call of f(), the best of ``repeat`` runs of
    ``number`` calls."""
    times = []
    for _ in range(repeat):
        start = time.thread_time()
        for _ in range(number):
            f()
        times.append((time.thread_time() - start) / number)
    return min(times)


def in_turns(calls: dict, rounds: int, number: int = 50) -> dict:
    """CPU seconds (this thread) per call of each of ``calls`` (name -> f), timed in
    turns: ``rounds`` rounds of a burst of ``number`` calls of each, the best burst."""
    times = dict.fromkeys(calls, float("inf"))
    for _ in range(rounds):
        for name, f in calls.items():
            start = time.thread_time()
            for _ in range(number):
                f()
            times[name] = min(times[name], (time.thread_time() - start) / number)
    return times


#: states per call when timing the C kernel alone
BATCH_KERNEL = 100


#: robot -> (URDF key, joints locked at 0): the Panda's fingers make n = 8 otherwise
ROBOTS = {"ur5": ("ur5", ()), "panda": ("panda", ("panda_finger_joint1",)),
          "solo12": ("solo12", ()), "baxter": ("baxter", ())}


def pair(name: str):
    """anadyn's robot and Pinocchio's model and data of the same URDF, root welded,
    the locked joints removed from both; None where the URDF is missing."""
    key, locked = ROBOTS[name]
    path = URDFS.get(key) or erd("solo_description/robots/solo12.urdf")
    if path is None or not path.exists():
        return None
    imported = import_file(path, fix_base=True, lock={j: 0 for j in locked})
    robot = robot_from_text(imported.text, path.name)
    model = pin.buildModelFromUrdf(str(path))
    if locked:
        # the locked joints and their mimics (panda_finger_joint1 and 2): same stem
        ids = [model.getJointId(j) for j in model.names[1:]
               if any(j.startswith(k.rstrip("0123456789")) for k in locked)]
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    return robot, model, model.createData()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=10_000)
    parser.add_argument("--robots", default="ur5,panda,solo12")
    parser.add_argument("--rounds", type=int, default=200)
    args = parser.parse_args(argv)
    N = args.batch
    rng = np.random.default_rng(0)
    print(f"{'robot':8} {'n':>3} {'function':8} {'anadyn us':>10} {'C entry us':>11} "
          f"{'kernel us':>10} {'pinocchio us':>13} {'ratio':>6} {'kernel ratio':>13} "
          f"{'central diff us':>16} {'ratio':>6} {'python us':>10}")
    batched, operations = [], []
    for name in args.robots.split(","):
        found = pair(name)
        if found is None:
            print(f"{name}: URDF not installed")
            continue
        robot, model, data = found
        d = anadyn.derivatives(robot)
        if d.native is None:
            print(f"{name}: no C ({d.note}): the generated Python runs")
            continue
        python = anadyn.derivatives(robot, native=False)
        pl = plan(robot)
        operations.append((name, d.n, *(None if tr is None else tr.counts.mul + tr.counts.add
                                        for tr in (traced.trace_forward_mode_jacobian(pl),
                                                   traced.trace_analytic_jacobian(pl)))))
        n, m = d.n, d.m
        assert model.nv == n, (model.nv, n)
        q, dq, tau, ddq = (rng.uniform(-1, 1, k) for k in (n, n, m, n))
        qp, vp, tp = (rng.uniform(-1, 1, model.nv) for _ in range(3))
        x = np.concatenate([q, dq, tau])
        h = 1e-6

        def central():
            for k in range(2 * n + m):
                for s in (h, -h):
                    y = x.copy()
                    y[k] += s
                    d.forward_dynamics(0.0, y[:n], y[n:2 * n], y[2 * n:])

        fd = best(central, number=20)
        K = BATCH_KERNEL
        Qk, DQk, TAUk, DDQk = (rng.uniform(-1, 1, (K, k)) for k in (n, n, m, n))
        out = {"forward": np.empty((K, n * (2 * n + m))), "inverse": np.empty((K, 3 * n * n))}
        calls = {
            ("forward", "anadyn"): lambda: d.forward_derivatives(0.0, q, dq, tau),
            ("forward", "entry"): lambda: d.native.one_forward(0.0, q, dq, tau),
            ("forward", "kernel"): lambda: d.native.forward(K, 0.0, Qk, DQk, TAUk,
                                                            out["forward"]),
            ("forward", "pinocchio"): lambda: pin.computeABADerivatives(model, data, qp, vp, tp),
            ("inverse", "anadyn"): lambda: d.inverse_derivatives(0.0, q, dq, ddq),
            ("inverse", "entry"): lambda: d.native.one_inverse(0.0, q, dq, ddq),
            ("inverse", "kernel"): lambda: d.native.inverse(K, 0.0, Qk, DQk, DDQk,
                                                            out["inverse"]),
            ("inverse", "pinocchio"): lambda: pin.computeRNEADerivatives(model, data, qp, vp, tp)}
        times = in_turns(calls, args.rounds)
        for what, py_call in (("forward", lambda: python.forward_derivatives(0.0, q, dq, tau)),
                              ("inverse", lambda: python.inverse_derivatives(0.0, q, dq, ddq))):
            ours, entry, theirs = (times[what, k] for k in ("anadyn", "entry", "pinocchio"))
            bare = times[what, "kernel"] / K
            slow = best(py_call, repeat=3)
            print(f"{name:8} {n:3d} {what:8} {ours * 1e6:10.2f} {entry * 1e6:11.2f} "
                  f"{bare * 1e6:10.2f} {theirs * 1e6:13.2f} {ours / theirs:6.2f} "
                  f"{bare / theirs:13.2f} "
                  + (f"{fd * 1e6:16.1f} {ours / fd:6.3f}" if what == "forward" else
                     f"{'':16} {'':6}") + f" {slow * 1e6:10.0f}")

        Q, DQ, TAU = (rng.uniform(-1, 1, (N, k)) for k in (n, n, m))
        QP = rng.uniform(-1, 1, (N, model.nv))
        rows = []
        for what, call, pin_call in (
                ("forward_dynamics", d.forward_dynamics,
                 lambda i: pin.aba(model, data, QP[i], vp, tp)),
                ("forward_derivatives", d.forward_derivatives,
                 lambda i: pin.computeABADerivatives(model, data, QP[i], vp, tp))):
            one_call = best(lambda call=call: call(0.0, Q, DQ, TAU), repeat=2, number=1)
            pin_loop = best(lambda pin_call=pin_call: [pin_call(i) for i in range(N)], 2, 1)
            k = max(1, N // 10)
            loop = best(lambda call=call: [call(0.0, Q[i], DQ[i], TAU[i]) for i in range(k)],
                        2, 1) * N / k
            rows.append((name, n, what, one_call, pin_loop, loop))
        batched += rows
    print(f"\nbatched, N = {N} states (seconds per N states)")
    print(f"{'robot':8} {'n':>3} {'function':20} {'one call':>9} {'pinocchio loop':>15} "
          f"{'ratio':>6} {'anadyn loop':>12} {'ratio':>6}")
    for name, n, what, one_call, pin_loop, loop in batched:
        print(f"{name:8} {n:3d} {what:20} {one_call:9.3f} {pin_loop:15.3f} "
              f"{one_call / pin_loop:6.2f} {loop:12.3f} {one_call / loop:6.3f}")
    print("\nmultiplications and additions of K and M (the cheaper is generated)")
    print(f"{'robot':8} {'n':>3} {'forward mode':>13} {'analytic':>9}")
    for name, n, forward, analytic in operations:
        print(f"{name:8} {n:3d} {forward:13,d} "
              f"{'-' if analytic is None else format(analytic, ',d'):>9}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
