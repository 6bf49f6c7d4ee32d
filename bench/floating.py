"""Floating-base robots against Pinocchio's free-flyer, in one run (issue 24, item 6).

    python bench/floating.py [--repeat K] [--calls N]

Robots: example-robot-data's Solo12 (18 DOF) and G1 (29 joints, 35 DOF), imported
with ``--floating-base``; Pinocchio reads the same URDFs with a
``JointModelFreeFlyer`` root.  Figures per robot, each a ratio anadyn /
Pinocchio measured in the same run (CPU time, user + system, of the process and
the children it waits for; wall time):

- per call: the state derivative x' = [dq, du] at N random states, one Python
  call each: anadyn's ``NumericModel.rhs`` (native C) against what a Pinocchio
  user writes, ``pin.aba`` plus the free-flyer's position and quaternion rates
  (dp = R v, dq_quat = 1/2 q (x) (0, w)) in NumPy;
- first: ``anadyn simulate URDF --floating-base --t-end 1 --no-plot`` in a new
  process with a new derivation cache in which what an installation does once is
  done (the generic kernel built, SciPy's odeint self-check recorded:
  ``bench/cold.py``'s ``install``), against ``bench/pinocchio_fall.py``, which imports Pinocchio and
  SciPy, loads the URDF, integrates the same free fall for 1 s with odeint
  (LSODA) at anadyn's tolerances (1e-10, 1e-12) calling ABA, and writes the CSV;
- second: the same command straight after it (the robot's own code may still be
  building in the background);
- warm: the same command once that build has ended (best of K), against the
  same script (best of K);
- the background build that the first run forked (the robot's own code,
  generated and compiled at the lowest priority, once per robot): its CPU and
  wall seconds as the next run reported them, and the first run's CPU with it
  (first + build) as a ratio.

The free fall starts at rest at the identity pose: both integrate the same
equations, and the bench checks that the two end states agree.
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
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import pinocchio_fall  # noqa: E402  (bench/, beside this file)
from cold import anadyn_runs, example_robot, install, timed  # noqa: E402

ROBOTS = {"solo12": "solo_description/robots/solo12.urdf",
          "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf"}



def per_call(urdf: Path, calls: int) -> tuple[float, float]:
    """(anadyn, Pinocchio) CPU seconds per state derivative."""
    import pinocchio as pin

    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.model.loader import robot_from_text
    from anadyn_cli.model.urdf import import_file
    from anadyn_cli.numeric import native, recursive

    robot = robot_from_text(import_file(urdf, floating_base=True, inertia="accept").text,
                            urdf.name)
    gen = recursive.generate(robot)
    code = recursive.module_source(gen)
    module, note = native.build(native.c_source(gen), {})
    if module is None:
        raise SystemExit(f"no native library: {note}")
    model = native.NativeModel(RobotInfo.from_robot(robot), code, "recursive", module)
    n = len(model.initial_state())
    rng = np.random.default_rng(0)
    states = rng.uniform(-0.5, 0.5, (calls, n))
    start = time.process_time()
    for x in states:
        model.rhs(0.0, x)
    ours = (time.process_time() - start) / calls
    pmodel = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    rhs = pinocchio_fall.derivative(pmodel, pmodel.createData())
    qs = [pin.randomConfiguration(pmodel, -np.ones(pmodel.nq), np.ones(pmodel.nq))
          for _ in range(calls)]
    xs = [np.concatenate([q, v]) for q, v in zip(qs, rng.uniform(-0.5, 0.5, (calls, pmodel.nv)))]
    start = time.process_time()
    for x in xs:
        rhs(x)
    theirs = (time.process_time() - start) / calls
    return ours, theirs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--calls", type=int, default=2000)
    args = parser.parse_args()
    import pinocchio as pin

    work = Path(tempfile.mkdtemp(prefix="anadyn-floating-"))
    base_env = {k: v for k, v in os.environ.items()
                if k not in ("ANADYN_NATIVE", "ANADYN_GENERIC")}
    installed = install(work)
    os.environ["ANADYN_CACHE_DIR"] = str(work / "cache-inprocess")       # per_call's build
    script = HERE / "pinocchio_fall.py"
    print("| robot | DOF | per call anadyn / Pinocchio | first: wall, CPU | second: wall, CPU "
          "| warm: wall, CPU | background build CPU / wall s | first + build CPU "
          "| end states agree |")
    print("|---|---|---|---|---|---|---|---|---|", flush=True)
    for name, relative in ROBOTS.items():
        urdf = example_robot(relative)
        ours, theirs = per_call(urdf, args.calls)
        cache = work / f"cache-{name}"
        command = [sys.executable, "-m", "anadyn_cli", "simulate", str(urdf),
                   "--floating-base", "--inertia", "accept", "--t-end", "1", "--no-plot"]
        row = anadyn_runs(command, cache, installed, {**base_env, "ANADYN_PROGRESS": "off"},
                          args.repeat)
        pin_runs = [timed([sys.executable, str(script), str(urdf), str(work / f"{name}.csv")],
                          base_env) for _ in range(args.repeat)]
        pw, pc = min(r[0] for r in pin_runs), min(r[1] for r in pin_runs)
        ours_end = np.genfromtxt(cache / "out" / "simulate.csv", delimiter=",", names=True)
        theirs_end = np.loadtxt(work / f"{name}.csv", delimiter=",")[-1]
        base = [c for c in ours_end.dtype.names if c.endswith("_z")][0]
        agree = abs(ours_end[base][-1] - theirs_end[3]) < 1e-8
        nv = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer()).nv
        cells = [f"{row[k][0] / pw:.2f}x, {row[k][1] / pc:.2f}x"
                 for k in ("first", "second", "warm")]
        bg = row["background"]
        total = "-" if bg is None else f"{(row['first'][1] + bg[0]) / pc:.2f}x"
        print(f"| {name} | {nv} | {ours / theirs:.2f} ({ours * 1e6:.1f} / {theirs * 1e6:.1f} "
              f"us) | {' | '.join(cells)} | "
              f"{'-' if bg is None else f'{bg[0]:.1f} / {bg[1]:.1f}'} | {total} "
              f"| {'yes' if agree else 'NO'} |", flush=True)


if __name__ == "__main__":
    main()
