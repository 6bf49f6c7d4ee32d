"""Cold ``anadyn simulate`` (1 s) against a Pinocchio + SciPy script doing the
same job, before and after the generic kernel, in one run.

    python bench/cold.py [--repeat K] [ROBOT.urdf ...]

For each robot (default: robots/ur5.urdf and example-robot-data's UR10,
Baxter (17 DOF), Talos (32, root welded), when installed): the best of K runs
(default 2) of

- ``anadyn simulate URDF --t-end 1 --no-plot`` in a new process with an empty
  derivation cache, ``ANADYN_GENERIC=0`` (before: the robot's own code is
  generated, a quick C build serves the run) and ``ANADYN_GENERIC=1`` (after:
  the generic kernel serves the run; its library is built once, beforehand,
  as an installation would, and copied into each new cache);
- ``bench/pinocchio_job.py``: import Pinocchio and SciPy, load the URDF,
  integrate the same robot (gravity, joint damping, no control) with odeint
  (LSODA) at anadyn's tolerances, write the CSV;

wall time and CPU time (user + system of the process and the children it
waits for; the detached process that generates and compiles the robot's own
code for the next run is not waited for, and not counted).  Ratios are anadyn
/ Pinocchio.  DOF is Pinocchio's; a robot with coupled joints (mimic) has
fewer coordinates in anadyn, and Pinocchio's job integrates every joint on
its own (marked *).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))


def example_robot(path: str) -> Path | None:
    base = next((Path(p) / "cmeel.prefix/share/example-robot-data/robots"
                 for p in sys.path if Path(p, "cmeel.prefix").is_dir()), None)
    return base / path if base is not None and (base / path).exists() else None


DEFAULT = [HERE.parent / "robots/ur5.urdf",
           example_robot("ur_description/urdf/ur10_joint_limited_robot.urdf"),
           example_robot("baxter_description/urdf/baxter.urdf"),
           example_robot("talos_data/robots/talos_reduced.urdf")]


def timed(command: list[str], env: dict) -> tuple[float, float]:
    """(wall, CPU) seconds of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{done.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def job(urdf: Path) -> dict:
    """Pinocchio's job: every joint of Pinocchio's model (a coupled joint of anadyn's,
    such as a mimic finger, moves on its own there), with anadyn's gravity, initial
    values and joint damping where the names match."""
    import pinocchio as pin
    from anadyn_cli import robot_from_text
    from anadyn_cli.model.urdf import import_file
    from anadyn_cli.numeric import recursive

    robot = robot_from_text(import_file(urdf, fix_base=True).text, urdf.name)
    pl = recursive.plan(robot)
    initial = {c.name: float(c.initial) for c in robot.coordinates}
    damping = ({c: pl.bodies[pl.moving[k]].damping for k, c in enumerate(pl.coordinates)}
               if len(pl.moving) == pl.n else {})       # coupled: undamped on both sides
    names = [name for name in pin.buildModelFromUrdf(str(urdf)).names[1:]]
    return {"joints": names, "gravity": [float(g) for g in pl.gravity],
            "initial": [initial.get(j, 0.0) for j in names], "target": [0.0] * len(names),
            "damping": [damping.get(j, 0.0) for j in names], "stiffness": [0.0] * len(names),
            "t_end": 1.0, "dt": 0.01, "rtol": 1e-10, "atol": 1e-12, "coupled": pl.n != len(names)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("urdfs", nargs="*", type=Path)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    urdfs = args.urdfs or [p for p in DEFAULT if p is not None]
    work = Path(tempfile.mkdtemp(prefix="anadyn-cold-"))
    base = {k: v for k, v in os.environ.items() if k not in ("ANADYN_NATIVE", "ANADYN_GENERIC")}
    installed = work / "installed"
    os.environ["ANADYN_CACHE_DIR"] = str(installed)       # the kernel, built once
    from anadyn_cli.numeric import generic
    os.environ.pop("ANADYN_NATIVE", None)
    if generic.kernel() is None:
        sys.exit("no generic kernel: no C compiler or Python headers")
    print(f"{'robot':<28}{'DOF':>4}  {'Pinocchio wall/CPU s':>21}  "
          f"{'before: wall, CPU x':>20}  {'after: wall, CPU x':>19}")
    rows = []
    for urdf in urdfs:
        spec = job(urdf)
        (work / "job.json").write_text(json.dumps(spec))
        pin = min((timed([sys.executable, str(HERE / "pinocchio_job.py"), str(urdf),
                          str(work / "job.json"), str(work / "pin.csv")], base)
                   for _ in range(args.repeat)), key=lambda r: r[0])
        row = {"robot": urdf.name, "dof": len(spec["joints"]), "pinocchio": pin}
        for label, flag in (("before", "0"), ("after", "1")):
            runs = []
            for k in range(args.repeat):
                cache = work / f"{urdf.stem}-{label}-{k}"
                shutil.copytree(f"{installed}-native", f"{cache}-native")
                env = {**base, "ANADYN_CACHE_DIR": str(cache), "ANADYN_GENERIC": flag}
                runs.append(timed([sys.executable, "-m", "anadyn_cli", "simulate", str(urdf),
                                   "--t-end", "1", "--no-plot", "--out", str(cache / "out")],
                                  env))
            row[label] = min(runs, key=lambda r: r[0])
        rows.append(row)
        (pw, pc), (bw, bc), (aw, ac) = pin, row["before"], row["after"]
        print(f"{urdf.name + ('*' if spec['coupled'] else ''):<28}{row['dof']:>4}  {pw:>10.2f} /{pc:>6.2f}     "
              f"{bw / pw:>8.2f}x, {bc / pc:>5.2f}x     {aw / pw:>8.2f}x, {ac / pc:>5.2f}x")
    (work / "cold.json").write_text(json.dumps(rows, indent=1))
    print(f"(ratios anadyn / Pinocchio, best of {args.repeat}; rows in {work / 'cold.json'})")


if __name__ == "__main__":
    main()
