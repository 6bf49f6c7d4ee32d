"""A cold ``anadyn linearize`` of a URDF against a short Pinocchio script doing the
same job, in one run (issue 25).

    python bench/linearize.py [--closed-form] [--repeat K] [URDF ...]

Default robots: robots/ur5.urdf and robots/panda.urdf, and example-robot-data's Talos
(reduced) and TIAGo when the package is installed.  anadyn: ``anadyn linearize URDF
--out DIR`` in a new process with a new, empty cache folder (``ANADYN_CACHE_DIR``),
at the file's initial state with static holding efforts (the default for a robot
without a controller); by the recursive evaluator (the default), and with
``--closed-form`` also by ``--evaluator closed-form`` (Kane's equations
differentiated symbolically: minutes on 30-48 DOF).  Pinocchio: import it, load the
URDF (``buildModelFromUrdf``), the holding efforts by RNEA at rest and
``computeABADerivatives`` at that point, A assembled.  Wall time and CPU time (user +
system of the process and the children it waits for), best of K; ratios are anadyn /
Pinocchio.  The largest difference between the two d(ddq)/dq blocks of A (relative to
the largest entry) is printed too, joints mapped by name (not with coupled joints,
which Pinocchio moves apart: "-"); d(ddq)/d(dq) differs by the URDF's joint damping
and friction, which anadyn's dynamics have and Pinocchio's do not.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

PINOCCHIO = """
import sys, json
import numpy as np
import pinocchio as pin
model = pin.buildModelFromUrdf(sys.argv[1])
data = model.createData()
q, v = pin.neutral(model), np.zeros(model.nv)
tau = pin.rnea(model, data, q, v, np.zeros(model.nv))
pin.computeABADerivatives(model, data, q, v, tau)
n = model.nv
A = np.block([[np.zeros((n, n)), np.eye(n)], [data.ddq_dq, data.ddq_dv]])
names = [model.names[j] for j in range(1, model.njoints) if model.joints[j].nv == 1]
order = [model.joints[model.getJointId(j)].idx_v for j in names]
json.dump({"A": A.tolist(), "names": names, "order": order}, open(sys.argv[2], "w"))
"""


def example_robot(path: str) -> Path | None:
    base = next((Path(p) / "cmeel.prefix/share/example-robot-data/robots"
                 for p in sys.path if Path(p, "cmeel.prefix").is_dir()), None)
    return base / path if base is not None and (base / path).exists() else None


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


def best(runs: list[tuple[float, float]]) -> tuple[float, float]:
    return min(r[0] for r in runs), min(r[1] for r in runs)


def cold(urdf: Path, work: Path, options: list[str], repeat: int) -> tuple[float, float, dict]:
    """Best (wall, CPU) of ``repeat`` cold runs and the last run's linearize.json."""
    runs = []
    for k in range(repeat):
        cache = Path(tempfile.mkdtemp(dir=work, prefix="cache-"))
        env = {**os.environ, "ANADYN_CACHE_DIR": str(cache), "PYTHONWARNINGS": "ignore"}
        out = work / f"out-{k}"
        runs.append(timed([sys.executable, "-m", "anadyn_cli", "linearize", str(urdf),
                           *options, "--out", str(out)], env))
    return (*best(runs), json.loads((out / "linearize.json").read_text()))


def difference(anadyn: dict, pinocchio: dict) -> str:
    """max |d(ddq)/dq - Pinocchio's| / max |Pinocchio's|, Pinocchio's joints taken by
    anadyn's names; "-" when the two have different coordinates (coupled joints)."""
    import numpy as np

    names = anadyn["state"][:len(anadyn["state"]) // 2]
    n = len(names)
    if sorted(names) != sorted(pinocchio["names"]):
        return "-"
    place = [pinocchio["order"][pinocchio["names"].index(name)] for name in names]
    P = np.array(pinocchio["A"])[len(names):, :n][np.ix_(place, place)]
    A = np.array(anadyn["A"])[n:, :n]
    return f"{np.max(np.abs(A - P)) / np.max(np.abs(P)):.1e}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("urdf", nargs="*", type=Path)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--closed-form", action="store_true")
    args = parser.parse_args()
    robots = args.urdf or [ROOT / "robots/ur5.urdf", ROOT / "robots/panda.urdf",
                           *filter(None, (example_robot("talos_data/robots/talos_reduced.urdf"),
                                          example_robot("tiago_description/robots/tiago.urdf")))]
    closed = " closed-form CPU / wall (s) | ratio CPU |" if args.closed_form else ""
    print("| robot | DOF | Pinocchio CPU / wall (s) | recursive CPU / wall (s) | ratio CPU / wall "
          "| d(ddq)/dq vs Pinocchio |" + closed)
    print("|---|---|---|---|---|---|" + ("---|---|" if args.closed_form else ""))
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        script = work / "pinocchio_linearize.py"
        script.write_text(PINOCCHIO)
        for urdf in robots:
            env = {**os.environ, "PYTHONWARNINGS": "ignore"}
            pin = best([timed([sys.executable, str(script), str(urdf), str(work / "pin.json")],
                              env) for _ in range(args.repeat)])
            pinocchio = json.loads((work / "pin.json").read_text())
            wall, cpu, figures = cold(urdf, work, [], args.repeat)
            row = (f"| {urdf.stem} | {len(figures['state']) // 2} | {pin[1]:.2f} / {pin[0]:.2f} "
                   f"| {cpu:.2f} / {wall:.2f} | {cpu / pin[1]:.1f}x / {wall / pin[0]:.1f}x "
                   f"| {difference(figures, pinocchio)} |")
            if args.closed_form:
                wall, cpu, _ = cold(urdf, work, ["--evaluator", "closed-form"], 1)
                row += f" {cpu:.2f} / {wall:.2f} | {cpu / pin[1]:.1f}x |"
            print(row, flush=True)


if __name__ == "__main__":
    main()
