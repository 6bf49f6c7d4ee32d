"""The options for native speed in the integrator's hot call, measured in one run.

    python bench/native_options.py [--robots chain6 chain12 arm7 panda]

For each robot of ``bench/scale_robots.py``, the forward dynamics ddq(t, q, dq)
(the RHS's work) by each option, with its one-off cost (compile or JIT) and
its cost per call from Python (best of 5 timeit runs):

  python      the generated Python (anadyn's fallback, and a cold run's start)
  numba       the same generated source compiled by ``numba.njit`` (tuple out)
  symengine   SymEngine's ``Lambdify`` with the LLVM backend and its own CSE,
              over the traced program's outputs (an expression DAG)
  C -O0       anadyn's quick build of a cold run (forward dynamics alone)
  C -O1       anadyn's full library (what warm runs call)
  C loop      the -O1 kernel called from a C loop: no Python per call, what a
              solver whose stepping loop calls compiled code would pay

The last line per robot bounds what such a solver would save: the Python
overhead per call (C from Python - C loop) times odeint's RHS calls, as a
share of anadyn's solve at rtol 1e-10.  numba and symengine are bench-only
(``pip install numba symengine``); a missing one is reported, not fatal.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import scale_robots as sr  # noqa: E402
from scale import per_call  # noqa: E402

SPECS = sr.SPECS
LOOP_CALLS = 200_000


def timed(f):
    start = time.perf_counter()
    value = f()
    return value, time.perf_counter() - start


def numba_option(code: str, args):
    """(compile s, us per call): the generated ``accelerations`` under numba.njit."""
    import numba
    head = code.partition("# ---- vectorized functions ----")[0]
    start = head.index("\ndef accelerations(")
    end = head.find("\ndef ", start + 1)
    source = head[:head.index("\ndef ")] + head[start:end]
    source = re.sub(r"_out_ddq = \[(.*)\]", r"_out_ddq = (\1,)", source)     # a tuple out
    namespace: dict = {}
    exec(compile(source, "<bench numba>", "exec"), namespace)              # noqa: S102
    jitted = numba.njit(namespace["accelerations"])
    _, seconds = timed(lambda: jitted(*args))
    return seconds, per_call(lambda: jitted(*args))


def symengine_option(traced, n: int, values):
    """(build + compile s, us per call): Lambdify(llvm, cse) of the traced outputs."""
    import symengine as se
    atoms = {name: se.Symbol(name) for name in traced.args}
    functions = {"sin": se.sin, "cos": se.cos, "sqrt": se.sqrt, "tanh": se.tanh,
                 "recip": lambda x: 1 / x}

    def of(terms):
        total = se.Integer(0)
        for mono, coef in terms.items():
            product = se.RealDouble(coef)
            for atom in mono:
                product = product * atoms[atom]
            total = total + product
        return total

    def build():
        for s in traced.statements:
            if s.kind == "sum":
                atoms[s.name] = of(s.payload)
            elif s.kind == "call":
                function, atom = s.payload
                atoms[s.name] = functions[function](atoms[atom])
            elif s.kind == "sympy":
                raise ValueError("a SymPy statement: not in this bench")
        outputs = [of(x.terms) for x in traced.outputs["ddq"]]
        inputs = [se.Symbol(name) for name in traced.args]
        return se.Lambdify(inputs, outputs, backend="llvm", cse=True)

    f, seconds = timed(build)
    x = np.array(values, dtype=float)
    return seconds, per_call(lambda: f(x))


C_LOOP = r"""
#include <stdio.h>
#include <time.h>
int main(void) {
    double x[2 * N], ddq[N], sink = 0.0;
    for (int i = 0; i < 2 * N; i++) x[i] = XVALUES[i];
    struct timespec a, b;
    double best = 1e30;
    for (int r = 0; r < 5; r++) {
        clock_gettime(CLOCK_MONOTONIC, &a);
        for (long k = 0; k < CALLS; k++) { x[0] += 1e-300; anadyn_acc(0.0, x, ddq); sink += ddq[0]; }
        clock_gettime(CLOCK_MONOTONIC, &b);
        double us = ((b.tv_sec - a.tv_sec) * 1e6 + (b.tv_nsec - a.tv_nsec) * 1e-3) / CALLS;
        if (us < best) best = us;
    }
    printf("%.6f %g\n", best, sink);
    return 0;
}
"""


def c_loop_option(c_text: str, x0, folder: Path) -> float:
    """us per call of anadyn_acc from a C loop (the library's flags, no Python)."""
    from anadyn_cli.numeric import native
    source = folder / "loop.c"
    values = ", ".join(repr(float(v)) for v in x0)
    source.write_text(c_text.replace("MODULE_NAME", '"loop"').replace("INIT_FUNCTION", "init")
                      + f"\nstatic const double XVALUES[] = {{{values}}};\n#define CALLS "
                        f"{LOOP_CALLS}L\n" + C_LOOP)
    binary = folder / "loop"
    flags = [f for f in native.FLAGS if f not in ("-fPIC", "-shared")]
    subprocess.run([native.compiler(), *flags, str(source), "-o", str(binary), "-lm"],
                   check=True, capture_output=True)
    return float(subprocess.run([str(binary)], check=True, capture_output=True,
                                text=True).stdout.split()[0])


def measure(spec, folder: Path) -> dict:
    from anadyn_cli import robot_from_text
    from anadyn_cli.model.info import RobotInfo
    from anadyn_cli.numeric import native, recursive
    from scipy.integrate import odeint

    robot = robot_from_text(sr.to_yaml(spec), f"{spec.name}.yaml")
    gen = recursive.generate(robot)
    code, info = recursive.module_source(gen), RobotInfo.from_robot(robot)
    n = len(robot.coordinates)
    row = {"name": spec.name, "n": n}
    python, row["python_s"] = timed(lambda: native.RecursiveModel(info, code))
    x0 = python.initial_state() + 0.1
    args = (0.0, *x0.tolist())
    f, seconds = timed(lambda: python.scalar("accelerations"))
    row["python_s"] += seconds
    row["python_us"] = per_call(lambda: f(*args))
    for name, option in (("numba", lambda: numba_option(code, args)),
                         ("symengine", lambda: symengine_option(
                             gen.functions["accelerations"], n, args))):
        try:
            row[f"{name}_s"], row[f"{name}_us"] = option()
        except ImportError:
            row[f"{name}_note"] = "not installed"
    quick_text, full_text = native.c_source(recursive.forward(gen.plan)), native.c_source(gen)
    for key, text in (("quick", quick_text), ("full", full_text)):
        (module, why), row[f"{key}_s"] = timed(lambda text=text: native.build(text))
        if module is None:
            raise SystemExit(f"no C build: {why}")
        out = np.empty(n)
        row[f"{key}_us"] = per_call(lambda module=module: module.acc(0.0, x0, out))
    row["loop_us"] = c_loop_option(full_text, x0, folder)
    model = native.NativeModel(info, code, "recursive", module)
    grid = np.arange(int(round(spec.t_end / spec.dt)) + 1) * spec.dt
    calls = [0]

    def rhs(x, t):
        calls[0] += 1
        return model.rhs(t, x)

    start = time.perf_counter()
    odeint(rhs, model.initial_state(), grid, Dfun=lambda x, t: model.jacobian(t, x),
           rtol=1e-10, atol=1e-12, mxstep=10**6)
    row["solve_s"], row["rhs_calls"] = time.perf_counter() - start, calls[0]
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="*", default=["chain6", "chain12", "arm7", "panda"],
                        choices=sorted(SPECS))
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="anadyn-native-") as tmp:
        os.environ["ANADYN_CACHE_DIR"] = tmp                # the C builds, then gone
        for name in args.robots:
            rows.append(measure(SPECS[name](), Path(tmp)))
    print(f"python {sys.version.split()[0]}, {sysconfig.get_platform()}; one-off cost (s) "
          "and microseconds per ddq call from Python")
    print(f"{'robot':>8} {'option':>10} {'one-off s':>10} {'us/call':>9} {'vs C -O1':>9}")
    for r in rows:
        for key, label in (("python", "python"), ("numba", "numba"), ("symengine", "symengine"),
                           ("quick", "C -O0"), ("full", "C -O1")):
            if f"{key}_us" not in r:
                print(f"{r['name']:>8} {label:>10}  {r.get(f'{key}_note', '-')}")
                continue
            print(f"{r['name']:>8} {label:>10} {r[f'{key}_s']:10.3f} {r[f'{key}_us']:9.3f} "
                  f"{r[f'{key}_us'] / r['full_us']:9.2f}")
        print(f"{r['name']:>8} {'C loop':>10} {'-':>10} {r['loop_us']:9.3f} "
              f"{r['loop_us'] / r['full_us']:9.2f}")
        saved = (r["full_us"] - r["loop_us"]) * 1e-6 * r["rhs_calls"]
        print(f"{'':>8} a solver calling the C kernel from its own loop would save at most "
              f"{saved * 1e3:.1f} ms of {r['solve_s'] * 1e3:.1f} ms ({saved / r['solve_s']:.0%}) "
              f"over {r['rhs_calls']} RHS calls")
    return 0


if __name__ == "__main__":
    sys.exit(main())
