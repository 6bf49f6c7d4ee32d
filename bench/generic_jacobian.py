"""The generic kernel's state Jacobian (``kernel.jac``): exact forward mode against
the central differences it replaced, and against Pinocchio, in one run.

    python3 bench/generic_jacobian.py [--rounds R]

Per call from Python (the thread's CPU time, the best burst of R rounds of bursts
timed in turns: the machine is shared and noisy): ``kernel.jac`` of this tree's
kernel.c (forward mode) and of kernel.c at commit OLD (central differences; the
same ``native.load``, another module text), and Pinocchio's
``computeABADerivatives`` on the same URDF (continuous joints written as revolute
ones, ``cold.for_pinocchio``), on example-robot-data's UR5, Panda, Talos (reduced)
and TIAGo (the installed package) and ``scale_robots.py``'s 24-link chain and
30-joint tree, roots welded, at one random state.  Also the largest difference
between the two Jacobians over the largest entry.  n: anadyn's speeds (a mimic
joint is no coordinate of its own), nv: Pinocchio's.  Prints Markdown.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from anadyn_cli import robot_from_text  # noqa: E402
from anadyn_cli.model.urdf import import_file  # noqa: E402
from anadyn_cli.numeric import generic, native, recursive  # noqa: E402
from derivatives import in_turns  # noqa: E402  (bench/derivatives.py)

#: the last commit whose kernel.c took the Jacobian by central differences
OLD = "9acf19e"
NAMES = ("UR5", "Panda", "Talos", "TIAGo")


def old_kernel():
    """The kernel of kernel.c at OLD, compiled (and cached) by ``native.load``."""
    text = subprocess.run(["git", "show", f"{OLD}:anadyn_cli/numeric/generic/kernel.c"],
                          cwd=HERE.parent, capture_output=True, text=True, check=True).stdout
    module, note = native.load(text, how="wait")
    if module is None:
        sys.exit(f"generic_jacobian.py: the old kernel: {note}")
    return module


def row(name: str, urdf: Path, new, old, work: Path, rounds: int) -> str:
    import pinocchio as pin
    import cold

    robot = robot_from_text(import_file(urdf, fix_base=True).text, urdf.name)
    tables, why = generic.pack(recursive.plan(robot))
    if tables is None:
        return f"| {name} | | | {why} | | | | |"
    n, nq, nm = int(tables.ints[1]), int(tables.ints[4]), tables.A.shape[0]
    rng = np.random.default_rng(3)
    x, e = rng.uniform(-1, 1, nq + n), rng.uniform(-1, 1, nm)
    J = {k: np.empty((nq + n, nq + n)) for k in ("new", "old")}
    model = pin.buildModelFromUrdf(str(cold.for_pinocchio(urdf, work)))
    data = model.createData()
    qp, vp, tp = (rng.uniform(-1, 1, model.nv) for _ in range(3))
    times = in_turns({"new": lambda: new.jac(tables.ints, tables.doubles, x, e, J["new"]),
                      "old": lambda: old.jac(tables.ints, tables.doubles, x, e, J["old"]),
                      "pin": lambda: pin.computeABADerivatives(model, data, qp, vp, tp)},
                     rounds, number=20)
    gap = np.abs(J["new"] - J["old"]).max() / np.abs(J["new"]).max()
    us = {k: 1e6 * v for k, v in times.items()}
    return (f"| {name} | {n} | {model.nv} | {us['new']:.1f} | {us['old']:.1f} | "
            f"{us['new'] / us['old']:.2f} | {us['pin']:.1f} | {us['new'] / us['pin']:.1f} | "
            f"{gap:.1e} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=15)
    args = parser.parse_args()
    import cold
    import scale_robots as sr

    new, old = generic.kernel(), old_kernel()
    if new is None:
        sys.exit("generic_jacobian.py: no C compiler")
    print("| robot | n | nv | exact (us) | differences (us) | exact / differences "
          "| Pinocchio ABA derivatives (us) | exact / Pinocchio | max abs diff / max |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        urdfs = {name: cold.example_robot(cold.ROBOTS[name]) for name in NAMES}
        for name, spec in (("chain24", sr.chain(24)), ("tree30", sr.tree())):
            urdfs[name] = work / f"{name}.urdf"
            urdfs[name].write_text(sr.to_urdf(spec))
        for name, urdf in urdfs.items():
            if urdf is None:
                print(f"| {name} | | | not installed | | | | | |")
                continue
            print(row(name, urdf, new, old, work, args.rounds), flush=True)


if __name__ == "__main__":
    main()
