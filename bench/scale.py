"""How anadyn's recursive numeric path scales, beside Pinocchio, in one run.

    python bench/scale.py [--quick] [--only NAME ...] [--callgrind] [--json FILE]

Robots (``bench/scale_robots.py``, each written as anadyn YAML and as URDF
with the same numbers): spatial chains of n = 2..16 and 24 links, a branched
tree of 30 joints, a 7-joint arm with full inertia tensors (Panda-like) and the
Panda's own arm (its URDF's seven joints and links).  For each:

- generation: YAML validation + tracing + writing the Python and C sources
  (s), and the C compile (s, once per robot: cached beside the derivation);
- operation counts (multiplications + additions) of the generated forward
  dynamics (``accelerations``: CRBA + RNEA + sparse Cholesky), inverse
  dynamics (RNEA) and Jacobian (M and K by forward mode); Pinocchio's own
  counts are not exposed, so its work is given as machine instructions per
  ABA call when ``--callgrind`` is given (valgrind), beside ours per RHS call;
- RHS: microseconds per call from Python at the start state (best of
  several timeit runs), ours native and generated Python, Pinocchio's
  ``aba`` + PD law + concatenate; the same inside the solver (mean over its
  calls, timed around each call);
- solve: scipy odeint (LSODA) with the analytic Jacobian at anadyn's default
  tolerances (rtol 1e-10, atol 1e-12), both sides; RHS and Jacobian calls,
  and the largest difference of the two trajectories;
- ``anadyn simulate ROBOT --no-plot`` from process start: cold (an empty
  cache, as on an installation's very first run: the generic kernel is
  compiled, ~0.5 s, then serves the run while the robot's own code builds in
  the background; ``bench/cold.py`` measures first runs with the kernel
  built) and warm (after that build: cached derivation and library), each
  the best of 3 runs, against
  ``bench/pinocchio_job.py`` doing the same job (import, load the URDF,
  integrate, write the CSV), the best of 3.

Ratios are anadyn / Pinocchio (below 1: anadyn faster).  Growth exponents
are least-squares slopes of log(cost) against log(n) over the chains.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import scale_robots as sr  # noqa: E402
from cold import building  # noqa: E402

CHAINS = [2, 3, 4, 6, 8, 10, 12, 16, 24]
QUICK_CHAINS = [2, 4, 6, 12]
RTOL, ATOL = 1e-10, 1e-12
CALLGRIND = False          # --callgrind


def per_call(f, min_time=0.2) -> float:
    """Microseconds per call: best of 5 runs of a count that lasts ~min_time/5."""
    f()
    number = 1
    while True:
        elapsed = timeit.timeit(f, number=number)
        if elapsed > min_time / 5 or number > 10**6:
            break
        number *= 4
    return min(timeit.repeat(f, number=number, repeat=5)) / number * 1e6


class Timed:
    """A callable timed around each call (mean microseconds over its calls)."""

    def __init__(self, f):
        self.f, self.calls, self.total = f, 0, 0.0

    def __call__(self, *args):
        start = time.perf_counter()
        out = self.f(*args)
        self.total += time.perf_counter() - start
        self.calls += 1
        return out

    @property
    def mean_us(self) -> float:
        return self.total / max(1, self.calls) * 1e6


def job_of(spec: sr.Spec) -> dict:
    return {"joints": [f"j_{l.name}" for l in spec.links], "gravity": list(spec.gravity),
            "initial": [l.initial for l in spec.links], "target": [l.target for l in spec.links],
            "damping": [l.gains[0] for l in spec.links],
            "stiffness": [l.gains[1] for l in spec.links],
            "t_end": spec.t_end, "dt": spec.dt, "rtol": RTOL, "atol": ATOL}


def pinocchio_side(spec: sr.Spec, urdf: Path):
    import pinocchio as pin
    model = pin.buildModelFromUrdf(str(urdf))
    model.gravity.linear = np.array(spec.gravity)
    data = model.createData()
    job = job_of(spec)
    n = model.nv
    order = np.array([model.joints[model.getJointId(j)].idx_v for j in job["joints"]])
    place = np.empty(n, dtype=int)
    place[order] = np.arange(n)
    b, k = np.array(job["damping"])[place], np.array(job["stiffness"])[place]
    target = np.array(job["target"])[place]

    def f(x, t):
        q, v = x[:n], x[n:]
        return np.concatenate((v, pin.aba(model, data, q, v, -b * v - k * (q - target))))

    def jac(x, t):
        q, v = x[:n], x[n:]
        dq, dv, Minv = pin.computeABADerivatives(model, data, q, v, -b * v - k * (q - target))
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        J[n:, :n] = dq - Minv * k
        J[n:, n:] = dv - Minv * b
        return J

    x0 = np.concatenate((np.array(job["initial"])[place], np.zeros(n)))
    return f, jac, x0, order


def solve(f, jac, x0, grid):
    from scipy.integrate import odeint
    rhs, J = Timed(f), Timed(jac)
    start = time.perf_counter()
    x = odeint(f, x0, grid, Dfun=jac, rtol=RTOL, atol=ATOL, mxstep=10**6)
    wall = time.perf_counter() - start
    odeint(rhs, x0, grid, Dfun=J, rtol=RTOL, atol=ATOL, mxstep=10**6)
    return x, wall, rhs.calls, J.calls, rhs.mean_us


def run_cli(args: list[str], env: dict) -> float:
    start = time.perf_counter()
    result = subprocess.run(args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed:\n{result.stderr[-2000:]}")
    return wall


def measure(spec: sr.Spec, work: Path, pin_available: bool) -> dict:
    from anadyn_cli import robot_from_text
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import native, recursive

    folder = work / spec.name
    folder.mkdir(parents=True, exist_ok=True)
    yaml_path, urdf_path = folder / f"{spec.name}.yaml", folder / f"{spec.name}.urdf"
    yaml_path.write_text(sr.to_yaml(spec))
    urdf_path.write_text(sr.to_urdf(spec))
    row: dict = {"name": spec.name, "n": len(spec.links)}

    start = time.perf_counter()
    robot = robot_from_text(yaml_path.read_text(), str(yaml_path))
    gen = recursive.generate(robot)
    code, c_text = recursive.module_source(gen), native.c_source(gen)
    row["generate_s"] = time.perf_counter() - start
    for name in ("accelerations", "inverse_dynamics", "dynamics_jacobian"):
        c = gen.counts(name)
        row[f"ops_{name}"] = (c.mul, c.add)
    os.environ["ANADYN_CACHE_DIR"] = str(folder / "cache-inprocess")
    timings: dict = {}
    start = time.perf_counter()
    module, note = native.build(c_text, timings)
    row["compile_s"] = time.perf_counter() - start
    info = RobotInfo.from_robot(robot)
    python_model = native.NumericModel(info, code, "recursive")
    model = native.NativeModel(info, code, "recursive", module) if module else python_model
    row["native"] = module is not None
    x0 = python_model.initial_state()
    grid = np.arange(int(round(spec.t_end / spec.dt)) + 1) * spec.dt
    row["rhs_us"] = per_call(lambda: model.rhs(0.0, x0))
    row["rhs_python_us"] = per_call(lambda: python_model.rhs(0.0, x0))
    row["jac_us"] = per_call(lambda: model.jacobian(0.0, x0))
    x, row["solve_s"], row["rhs_calls"], row["jac_calls"], row["rhs_in_solver_us"] = solve(
        lambda x, t: model.rhs(t, x), lambda x, t: model.jacobian(t, x), x0, grid)

    if pin_available:
        f, jac, px0, order = pinocchio_side(spec, urdf_path)
        row["pin_rhs_us"] = per_call(lambda: f(px0, 0.0))
        row["pin_jac_us"] = per_call(lambda: jac(px0, 0.0))
        px, row["pin_solve_s"], row["pin_rhs_calls"], row["pin_jac_calls"], \
            row["pin_rhs_in_solver_us"] = solve(f, jac, px0, grid)
        n = len(order)
        theirs = np.concatenate((px[:, order], px[:, n + order]), 1)    # anadyn's order
        row["trajectory_difference"] = float(np.abs(x - theirs).max())

    if CALLGRIND and module is not None and pin_available:
        row["instructions"], row["pin_instructions"] = instructions(
            urdf_path, native.library_path(c_text), len(spec.links), folder)

    # whole runs from process start; cold: the best of 3, each with an empty cache,
    # started once the previous one's background builds are done
    command = [sys.executable, "-m", "anadyn_cli", "simulate", str(yaml_path), "--no-plot",
               "--method", "odeint", "--out", str(folder / "out")]
    colds = []
    for k in range(3):
        env = {**os.environ, "ANADYN_CACHE_DIR": str(folder / f"cache-cli{k}")}
        env.pop("ANADYN_NATIVE", None)
        colds.append(run_cli(command, env))
        wait = time.perf_counter()
        while any(building(folder / place)                  # the robot's code, its library
                  for place in (f"cache-cli{k}", f"cache-cli{k}-native")):
            time.sleep(0.05)
        row["background_build_s"] = time.perf_counter() - wait
    row["cold_s"] = min(colds)
    row["warm_s"] = min(run_cli(command, env) for _ in range(3))
    if pin_available:
        job = folder / "job.json"
        job.write_text(json.dumps(job_of(spec)))
        pin_command = [sys.executable, str(HERE / "pinocchio_job.py"), str(urdf_path), str(job),
                       str(folder / "pin.csv")]
        row["pin_job_s"] = min(run_cli(pin_command, dict(os.environ)) for _ in range(3))
    return row


CALLGRIND_CHILD = """
import importlib.util, sys
import numpy as np
import pinocchio as pin
urdf, library, name, n, calls = sys.argv[1:6]
n, calls = int(n), int(calls)
model = pin.buildModelFromUrdf(urdf)
data = model.createData()
q, v, tau = np.full(model.nq, 0.1), np.full(model.nv, 0.2), np.zeros(model.nv)
for _ in range(calls):
    pin.aba(model, data, q, v, tau)
spec = importlib.util.spec_from_file_location(name, library)
module = importlib.util.module_from_spec(spec)
spec.loader.exec_module(module)
x, out = np.full(2 * n, 0.1), np.empty(2 * n)
for _ in range(calls):
    module.rhs(0.0, x, out)
"""


def instructions(urdf: Path, library: Path, n: int, folder: Path, calls: int = 1000):
    """Machine instructions per call (valgrind callgrind, inclusive): Pinocchio's
    ``aba`` and anadyn's ``anadyn_rhs`` kernel; (None, None) without valgrind."""
    import re
    import shutil
    if not shutil.which("valgrind") or not shutil.which("callgrind_annotate"):
        return None, None
    child, out = folder / "callgrind_child.py", folder / "callgrind.out"
    child.write_text(CALLGRIND_CHILD)
    name = library.name.split(".")[0]
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                    sys.executable, str(child), str(urdf), str(library), name, str(n),
                    str(calls)], capture_output=True)
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                          capture_output=True, text=True).stdout
    found = {}
    for line in text.splitlines():
        count, kernel = re.match(r"\s*([\d,]+) ", line), re.search(
            r"pinocchio::aba<|:anadyn_rhs \[", line)
        if count and kernel:
            key = "pin" if kernel[0].startswith("pinocchio") else "ours"
            found[key] = max(found.get(key, 0), int(count[1].replace(",", "")))
    per = {k: v / calls for k, v in found.items()}
    return per.get("ours"), per.get("pin")


def slope(ns, values) -> float:
    ok = [(math.log(n), math.log(v)) for n, v in zip(ns, values) if v and v > 0]
    if len(ok) < 2:
        return float("nan")
    x, y = np.array(ok).T
    return float(np.polyfit(x, y, 1)[0])


def ratio(a, b) -> str:
    return f"{a / b:.2f}" if a is not None and b else "-"


def report(rows: list[dict]) -> None:
    print("\n== generation and size ==")
    print(f"{'robot':>8} {'n':>3} {'gen s':>7} {'cc s':>7} {'acc mul+add':>13} "
          f"{'ID mul+add':>12} {'jac mul+add':>13}")
    for r in rows:
        print(f"{r['name']:>8} {r['n']:>3} {r['generate_s']:7.2f} {r['compile_s']:7.2f} "
              f"{sum(r['ops_accelerations']):>13} {sum(r['ops_inverse_dynamics']):>12} "
              f"{sum(r['ops_dynamics_jacobian']):>13}")
    if any(r.get("pin_instructions") for r in rows):
        print("\n== work per call, machine instructions (valgrind): anadyn_rhs vs pinocchio::aba ==")
        for r in rows:
            if r.get("pin_instructions") and r.get("instructions"):
                print(f"{r['name']:>8} {r['instructions']:10.0f} {r['pin_instructions']:10.0f} "
                      f"ratio {r['instructions'] / r['pin_instructions']:.2f}")
    print("\n== speed, anadyn / Pinocchio (ratio < 1: anadyn faster) ==")
    print(f"{'robot':>8} {'rhs us':>7} {'pin us':>7} {'ratio':>6} {'in-solver':>9} "
          f"{'jac ratio':>9} {'solve ms':>9} {'pin ms':>7} {'ratio':>6} {'calls ours/pin':>15} "
          f"{'max |dx|':>9} {'py rhs us':>9}")
    for r in rows:
        if "pin_rhs_us" not in r:
            continue
        print(f"{r['name']:>8} {r['rhs_us']:7.2f} {r['pin_rhs_us']:7.2f} "
              f"{ratio(r['rhs_us'], r['pin_rhs_us']):>6} "
              f"{ratio(r['rhs_in_solver_us'], r['pin_rhs_in_solver_us']):>9} "
              f"{ratio(r['jac_us'], r['pin_jac_us']):>9} {r['solve_s'] * 1e3:9.1f} "
              f"{r['pin_solve_s'] * 1e3:7.1f} {ratio(r['solve_s'], r['pin_solve_s']):>6} "
              f"{r['rhs_calls']:>7}/{r['pin_rhs_calls']:<7} {r['trajectory_difference']:9.1e} "
              f"{r['rhs_python_us']:9.1f}")
    print("\n== anadyn simulate from process start vs the Pinocchio script ==")
    print(f"{'robot':>8} {'cold s':>7} {'warm s':>7} {'pin s':>7} {'cold ratio':>10} "
          f"{'warm ratio':>10} {'bg build s':>10}")
    for r in rows:
        print(f"{r['name']:>8} {r['cold_s']:7.2f} {r['warm_s']:7.2f} {r.get('pin_job_s', 0):7.2f} "
              f"{ratio(r['cold_s'], r.get('pin_job_s')):>10} "
              f"{ratio(r['warm_s'], r.get('pin_job_s')):>10} {r['background_build_s']:10.2f}")
    chains = [r for r in rows if r["name"].startswith("chain")]
    if len(chains) >= 2:
        ns = [r["n"] for r in chains]
        print("\n== growth over the chains: cost ~ n^k ==")
        for label, key in [("generation time", "generate_s"), ("C compile time", "compile_s"),
                           ("ops accelerations", "ops_accelerations"),
                           ("ops inverse dynamics", "ops_inverse_dynamics"),
                           ("ops Jacobian", "ops_dynamics_jacobian"),
                           ("RHS us (native)", "rhs_us"), ("Jacobian us", "jac_us"),
                           ("RHS us Pinocchio", "pin_rhs_us"), ("solve time", "solve_s"),
                           ("solve time Pinocchio", "pin_solve_s")]:
            values = [sum(r[key]) if isinstance(r.get(key), (tuple, list)) else r.get(key)
                      for r in chains]
            if all(v is not None for v in values):
                print(f"  {label:>22}: k = {slope(ns, values):.2f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="chains 2, 4, 6, 12 and the arm")
    parser.add_argument("--only", nargs="*", help="robot names (chain6, tree30, arm7, ...)")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--callgrind", action="store_true",
                        help="count instructions per call with valgrind (slow)")
    args = parser.parse_args(argv)
    global CALLGRIND
    CALLGRIND = args.callgrind
    # anadyn's bytecode, as ``pip install`` leaves it (Pinocchio's is in site-packages):
    # from a checkout with PYTHONDONTWRITEBYTECODE set, every run would compile the
    # package again (~0.1 s)
    import compileall
    compileall.compile_dir(str(HERE.parent / "anadyn_cli"), quiet=1)
    try:
        import pinocchio  # noqa: F401
        pin_available = True
    except ImportError:
        pin_available = False
        print("pinocchio not installed: anadyn figures only")
    specs = [sr.chain(n) for n in (QUICK_CHAINS if args.quick else CHAINS)]
    specs += [sr.arm7(), sr.panda()] + ([] if args.quick else [sr.tree()])
    if args.only:
        specs = [s for s in specs if s.name in args.only]
    rows = []
    with tempfile.TemporaryDirectory(prefix="anadyn-scale-") as tmp:
        for spec in specs:
            start = time.perf_counter()
            rows.append(measure(spec, Path(tmp), pin_available))
            print(f"{spec.name}: measured in {time.perf_counter() - start:.1f} s", flush=True)
    report(rows)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
