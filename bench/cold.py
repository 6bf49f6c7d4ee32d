"""Cold, second and warm runs of ``anadyn simulate``, ``inverse``, ``check`` and
``linearize`` against a Pinocchio script doing the same job, in one run, on
every robot of issue 25's table.

    python bench/cold.py [--repeat K] [--only NAME ...] [--jobs JOB ...] [--timeout S]
                         [--markdown FILE]

Robots: example-robot-data's UR5, Panda, Solo12, Baxter, G1 (29 DOF), Talos
(reduced), iCub and TIAGo (from the installed package), root welded
(``--fix-base``; Pinocchio's fixed-base model, ``buildModelFromUrdf``), and
``bench/scale_robots.py``'s 24-link chain and 30-joint tree (their URDFs).  A
continuous joint is written as a revolute one for Pinocchio (one coordinate,
as in anadyn).  Jobs:

- simulate: ``anadyn simulate URDF --fix-base --t-end 1 --no-plot``; Pinocchio
  (``bench/pinocchio_job.py``): import Pinocchio and SciPy, load the URDF,
  integrate the same robot (gravity, joint damping and friction) with odeint
  (LSODA) at anadyn's tolerances, write the CSV;
- inverse: ``anadyn inverse URDF --fix-base --motion MOTION.csv --no-roundtrip
  --no-plot``, MOTION.csv 1 s of sinusoids sampled at 1 kHz with their rates
  and accelerations (nothing to differentiate); Pinocchio
  (``pinocchio_job.py --inverse``): read the CSV, RNEA at every sample plus the
  joint damping and friction, write the CSV.  The two efforts are compared
  (largest difference over the largest effort);
- check: ``anadyn check URDF --fix-base --t-end 1`` (exit 0 or 1: a check may
  fail); Pinocchio (``--check``): the simulation with the dissipated energy as
  a state, the mass matrix's conditioning at every row, the energy balance,
  the Jacobian's eigenvalues at 200 rows, RK45 at two tolerances;
- linearize: ``anadyn linearize URDF --fix-base`` (the initial state, holding
  efforts); Pinocchio (``--linearize``): A and B from the ABA derivatives, the
  eigenvalues of A, the controllability rank.

anadyn runs in a new process each time: *first*, with a new cache folder in
which what an installation does once is done (``install``: anadyn's modules
compiled to bytecode, as pip does, the generic kernel built and SciPy's odeint
self-check recorded beforehand, copied in); *second*, straight after the first
(the robot's own code may still be building in the background); *warm*, after
that build has ended (best of K).  Pinocchio: best of K.  A run that fails is
shown as ``exit N`` (its error on stderr), one stopped after --timeout seconds
as ``> S s``.  Both sides run OpenBLAS on one thread (anadyn sets it for
itself, ``cli.BLAS_THREADS``; the script is given OPENBLAS_NUM_THREADS=1), so
that no CPU time is that of threads spinning idle.  Wall time and CPU time
(user + system of the process and the children it waits for); the detached
background build is not among them: its own CPU and wall time, reported by
the next run (``background_build_cpu``, ``background_build_wall`` in its
JSON), are columns of their own.  Ratios are anadyn / Pinocchio.  DOF is
Pinocchio's (``nv``); a robot with coupled joints (mimic) has fewer
coordinates in anadyn, and Pinocchio moves every joint on its own (marked *,
efforts not compared).  Prints Markdown.
"""
from __future__ import annotations

import argparse
import fcntl
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))
from anadyn_cli.cli import BLAS_THREADS  # noqa: E402


def example_robot(path: str) -> Path | None:
    base = next((Path(p) / "cmeel.prefix/share/example-robot-data/robots"
                 for p in sys.path if Path(p, "cmeel.prefix").is_dir()), None)
    return base / path if base is not None and (base / path).exists() else None


ROBOTS = {"UR5": "ur_description/urdf/ur5_robot.urdf",
          "Panda": "panda_description/urdf/panda.urdf",
          "Solo12": "solo_description/robots/solo12.urdf",
          "Baxter": "baxter_description/urdf/baxter.urdf",
          "G1": "g1_description/urdf/g1_29dof_rev_1_0.urdf",
          "Talos": "talos_data/robots/talos_reduced.urdf",
          "iCub": "icub_description/robots/icub.urdf",
          "TIAGo": "tiago_description/robots/tiago.urdf"}


#: the jobs, and the exit codes a run of each may end with (check: 1, a check failed)
JOBS = {"simulate": (0,), "inverse": (0,), "check": (0, 1), "linearize": (0,)}


def robots(work: Path) -> dict[str, Path]:
    """Name -> URDF: the example-robot-data ones installed, and scale.py's chain and tree."""
    import scale_robots as sr

    found = {name: example_robot(path) for name, path in ROBOTS.items()}
    out = {name: path for name, path in found.items() if path is not None}
    for name, spec in (("chain24", sr.chain(24)), ("tree30", sr.tree())):
        path = work / f"{name}.urdf"
        path.write_text(sr.to_urdf(spec))
        out[name] = path
    return out


def for_pinocchio(urdf: Path, work: Path) -> Path:
    """``urdf`` with continuous joints written as revolute ones without limits (one
    coordinate each, as anadyn has them; Pinocchio's continuous joint has two)."""
    text = urdf.read_text()
    if 'type="continuous"' not in text:
        return urdf
    text = text.replace('type="continuous"', 'type="revolute"')

    def limited(match):
        body = match.group(0)
        if 'type="revolute"' in body and "<limit" not in body:
            body = body.replace("</joint>", '<limit lower="-1e9" upper="1e9" effort="1e9" '
                                'velocity="1e9"/></joint>')
        return body

    text = re.sub(r"<joint\b.*?</joint>", limited, text, flags=re.S)
    path = work / f"pin-{urdf.name}"
    path.write_text(text)
    return path


class Failed(Exception):
    """A run that did not end as expected: ``str`` is the table's cell."""


def timed(command: list[str], env: dict, codes=(0,),
          timeout: float | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of ``command``, which must end with one of ``codes`` within
    ``timeout`` seconds (else Failed, its error line printed)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        done = subprocess.run(command, env=env, capture_output=True, text=True,
                              timeout=timeout)
    except subprocess.TimeoutExpired:
        raise Failed(f"> {timeout:.0f} s") from None
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in codes:
        print(f"{' '.join(command)[:200]} failed: {done.stderr.strip()[-300:]}",
              file=sys.stderr)
        raise Failed(f"exit {done.returncode}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def job(urdf: Path, pin_urdf: Path) -> tuple[dict, list[str]]:
    """Pinocchio's job (every joint of Pinocchio's model; a coupled joint of anadyn's,
    such as a mimic finger, moves on its own there) with anadyn's gravity, initial
    values and joint damping and friction where the names match; anadyn's coordinates."""
    import pinocchio as pin
    from anadyn_cli import robot_from_text
    from anadyn_cli.model.urdf import import_file
    from anadyn_cli.numeric import recursive
    from anadyn_cli.numeric.generic.tables import affine_map

    robot = robot_from_text(import_file(urdf, fix_base=True).text, urdf.name)
    pl = recursive.plan(robot)
    initial = {c.name: float(c.initial) for c in robot.coordinates}
    A, _ = affine_map(pl)                   # joint displacements = A q + c
    bodies = ({pl.coordinates[int(np.argmax(np.abs(A[j])))]: pl.bodies[b]
               for j, b in enumerate(pl.moving)}
              if len(pl.moving) == pl.n else {})       # coupled: undamped on both sides
    names = list(pin.buildModelFromUrdf(str(pin_urdf)).names[1:])

    def each(f, default):
        return [f(bodies[j]) if j in bodies else default for j in names]

    spec = {"joints": names, "gravity": [float(g) for g in pl.gravity],
            "initial": [initial.get(j, 0.0) for j in names], "target": [0.0] * len(names),
            "damping": each(lambda b: float(b.damping), 0.0),
            "friction": each(lambda b: float(b.friction), 0.0),
            "friction_velocity": each(lambda b: float(b.friction_velocity), 1.0),
            "stiffness": [0.0] * len(names),
            "t_end": 1.0, "dt": 0.01, "rtol": 1e-10, "atol": 1e-12,
            "coupled": pl.n != len(names)}
    return spec, list(pl.coordinates)


def motion(coordinates: list[str], path: Path) -> None:
    """1 s of sinusoids at 1 kHz: t, q, dq, ddq of every coordinate."""
    t = np.arange(1001) / 1000.0
    w = 2 * np.pi * (0.5 + 0.2 * np.arange(len(coordinates)))
    phase = 0.3 * np.arange(len(coordinates))
    arg = np.outer(t, w) + phase
    q, dq, ddq = 0.2 * np.sin(arg), 0.2 * w * np.cos(arg), -0.2 * w ** 2 * np.sin(arg)
    header = ["t", *coordinates, *("d" + c for c in coordinates), *("dd" + c for c in coordinates)]
    np.savetxt(path, np.column_stack((t, q, dq, ddq)), delimiter=",", fmt="%.17g",
               header=",".join(header), comments="")


def install(work: Path) -> Path:
    """A cache folder as an installation has it after its first runs: the
    generic kernel and the CSV writer (``output.csv_table``, which a first run
    compiles in the background) compiled and SciPy's odeint self-check recorded
    (``numeric.odepack``: else each first run imports scipy.integrate), all once
    per installation; ``anadyn_runs`` copies its native folder.  Sets
    ANADYN_CACHE_DIR to it for this process."""
    installed = work / "installed"
    os.environ["ANADYN_CACHE_DIR"] = str(installed)
    os.environ.pop("ANADYN_NATIVE", None)
    import compileall

    import anadyn_cli
    compileall.compile_dir(Path(anadyn_cli.__file__).parent, quiet=1)
    from anadyn_cli.numeric import generic, odepack
    from anadyn_cli.output import csv_table
    if generic.kernel() is None:
        sys.exit("no generic kernel: no C compiler or Python headers")
    if csv_table.writer() is None:
        sys.exit("no CSV writer: it does not compile")
    odepack.extension()
    return installed


def building(folder: Path) -> bool:
    """Whether a background build holds a lock in the cache ``folder``."""
    for marker in folder.glob("*.building"):
        with open(marker, "rb") as handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                return True
    return False


def anadyn_runs(command: list[str], cache: Path, installed: Path, env: dict,
                repeat: int, codes=(0,), timeout: float | None = None) -> dict:
    """first, second, warm (wall, CPU; or why not, a str: ``Failed``) and the
    background build's (CPU, wall)."""
    shutil.copytree(f"{installed}-native", f"{cache}-native")
    env = {**env, "ANADYN_CACHE_DIR": str(cache)}
    out = cache / "out"
    row, background = {}, None
    runs = [("first", 1), ("second", 1), ("warm", repeat)]
    for label, count in runs:
        if label == "warm":
            deadline = time.monotonic() + 900
            while building(cache) and time.monotonic() < deadline:
                time.sleep(0.2)
        best = None
        for _ in range(count):
            try:
                result = timed([*command, "--out", str(out)], env, codes, timeout)
            except Failed as why:
                best = best or str(why)
                continue
            best = result if not isinstance(best, tuple) or result[0] < best[0] else best
            timings = json.loads(next(out.glob("*.json")).read_text()).get("timings", {})
            if background is None and "background_build_cpu" in timings:
                background = (timings["background_build_cpu"], timings["background_build_wall"])
        row[label] = best
    row["background"] = background
    return row


def difference(anadyn_csv: Path, pin_csv: Path, urdf: Path) -> float:
    """Largest difference of the joint efforts over the largest one: anadyn's efforts
    are its actuators' (a URDF ``<transmission>`` makes a drive whose effort acts
    through its gear N: the joint's is N times it), Pinocchio's the joints'."""
    from anadyn_cli.model import load_robot
    from anadyn_cli.model.urdf.options import ReadingOptions, reading

    with reading(ReadingOptions(fix_base=True)):
        robot = load_robot(urdf)
    values = robot.parameter_substitution()
    gear = {a.name[4:]: float(a.scale.xreplace(values)) for a in robot.actuators}

    def efforts(path):
        with open(path) as handle:
            header = handle.readline().strip().split(",")
        table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
        return {h[4:]: table[:, i] for i, h in enumerate(header) if h.startswith("tau_")}
    a, p = efforts(anadyn_csv), efforts(pin_csv)
    scale = max(np.abs(v).max() for v in p.values())
    return max(float(np.abs(gear.get(j, 1.0) * a[j] - p[j]).max()) for j in a) / scale


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--jobs", nargs="*", default=list(JOBS), choices=list(JOBS))
    parser.add_argument("--timeout", type=float, default=300.0,
                        help="Seconds after which an anadyn run is stopped (shown as '>').")
    parser.add_argument("--markdown", type=Path, default=None)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="anadyn-cold-"))
    base = {k: v for k, v in os.environ.items() if k not in ("ANADYN_NATIVE", "ANADYN_GENERIC")}
    if not any(base.get(name) for name in BLAS_THREADS):   # as anadyn sets it for itself
        base["OPENBLAS_NUM_THREADS"] = "1"
    installed = install(work)
    lines = ["| robot | DOF | job | Pinocchio wall / CPU s | first: wall, CPU | "
             "second: wall, CPU | warm: wall, CPU | background build CPU / wall s | "
             "efforts vs Pinocchio |", "|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    rows = []
    for name, urdf in robots(work).items():
        if args.only and name not in args.only:
            continue
        pin_urdf = for_pinocchio(urdf, work)
        spec, coordinates = job(urdf, pin_urdf)
        spec_path, motion_path = work / f"{name}-job.json", work / f"{name}-motion.csv"
        spec_path.write_text(json.dumps(spec))
        motion(coordinates, motion_path)
        pin_script = [sys.executable, str(HERE / "pinocchio_job.py")]
        jobs = {"simulate": ([*pin_script, str(pin_urdf), str(spec_path), str(work / "pin.csv")],
                             ["simulate", str(urdf), "--fix-base", "--t-end", "1", "--no-plot"]),
                "inverse": ([*pin_script, "--inverse", str(pin_urdf), str(spec_path),
                             str(motion_path), str(work / "pin.csv")],
                            ["inverse", str(urdf), "--fix-base", "--motion", str(motion_path),
                             "--no-roundtrip", "--no-plot"]),
                "check": ([*pin_script, "--check", str(pin_urdf), str(spec_path),
                           str(work / "pin.csv")],
                          ["check", str(urdf), "--fix-base", "--t-end", "1"]),
                "linearize": ([*pin_script, "--linearize", str(pin_urdf), str(spec_path),
                               str(work / "pin.csv")],
                              ["linearize", str(urdf), "--fix-base"])}
        for label in args.jobs:
            pin_command, anadyn_args = jobs[label]
            pin = min((timed(pin_command, base) for _ in range(args.repeat)), key=lambda r: r[0])
            cache = work / f"{name}-{label}"
            row = {"robot": name, "dof": len(spec["joints"]), "job": label, "pinocchio": pin,
                   **anadyn_runs([sys.executable, "-m", "anadyn_cli", *anadyn_args], cache,
                                 installed, base, args.repeat, JOBS[label], args.timeout)}
            row["difference"] = (None if label != "inverse" or spec["coupled"]
                                 or not isinstance(row["warm"], tuple)
                                 else difference(cache / "out/inverse.csv", work / "pin.csv",
                                                 urdf))
            rows.append(row)
            pw, pc = pin
            cells = [row[k] if isinstance(row[k], str)
                     else f"{row[k][0] / pw:.2f}x, {row[k][1] / pc:.2f}x"
                     for k in ("first", "second", "warm")]
            bg, diff = row["background"], row["difference"]
            line = (f"| {name}{'*' if spec['coupled'] else ''} | {row['dof']} | {label} | "
                    f"{pw:.2f} / {pc:.2f} | {' | '.join(cells)} | "
                    f"{'-' if bg is None else f'{bg[0]:.1f} / {bg[1]:.1f}'} | "
                    f"{'-' if diff is None else f'{diff:.0e}'} |")
            lines.append(line)
            print(line, flush=True)
    note = (f"\nRatios anadyn / Pinocchio (wall, CPU); first and second runs once each, "
            f"Pinocchio and warm the best of {args.repeat}; rows in {work / 'cold.json'}.")
    print(note)
    (work / "cold.json").write_text(json.dumps(rows, indent=1))
    if args.markdown is not None:
        args.markdown.write_text("\n".join(lines) + "\n" + note + "\n")


if __name__ == "__main__":
    main()
