"""Benchmark: ``anadyn simulate`` against the chapter's seed-style pipeline (rr, rrt).

    python bench/simulate.py [--repeats 5]

The seed-style pipeline is the chapter's MATLAB Programs 6.1 (RR) and 6.3
(RRT) redone in Python, written here and independent of anadyn's code:
positions of the mass centres in sympy with q(t) as functions of time,
velocities by differentiation, kinetic energy from the velocities and the
chapter's inertias, Lagrange's equations by differentiating T, the chapter's
generalized forces Q (gravity and the joint torques, dotted with partial
derivatives), the feedback laws and the numbers substituted, ``sympy.solve``
for the accelerations, ``sympy.lambdify`` of the first-order right-hand side
(state ordered as the chapter's x = [q1, dq1, q2, dq2, ...]), then
``scipy.integrate.solve_ivp(method="RK45", rtol=1e-3, atol=1e-6)`` (MATLAB
ode45's defaults) over 0..15 s with output on the 0.01 s grid, and a PNG
of the coordinates (the chapter's subplot figure).  The RHS is lambdified
with ``modules="math"`` and called with Python floats, the fastest plain
lambdify, so the baseline is not handicapped.

anadyn's side is the robot's default settings (``simulate.resolve``: the
file's horizon and step, anadyn's method ``auto`` and rtol 1e-10, atol
1e-12) through ``integrators.integrate`` on ``build.numeric_model``'s
robot (Kane, the command's default).

Measured, one thing at a time (2 noisy cores):

* solve time: min of ``--repeats`` runs of the integration only
  (seed: the ``solve_ivp`` call; anadyn: ``integrators.integrate``,
  including its stiffness analysis), RHS and Jacobian calls, steps;
* error: max over the 0.01 s grid of |q - q_ref| and |dq - dq_ref| against
  a DOP853 rtol 1e-13, atol 1e-15 reference on anadyn's compiled RHS (the two
  models are first compared at 20 random states; Radau rtol 1e-12 with
  anadyn's analytic Jacobian checks the reference);
* end to end for rr (min of ``--repeats`` whole processes, interleaved):
  (a) the seed-style pipeline as a standalone process (this file with
  ``--seed-run``; its module level imports only the standard library):
  imports, derivation, symbolic solve, lambdify, solve, PNG written;
  (b) ``anadyn simulate robots/rr.yaml --out TMP`` with an empty derivation
  cache each run, (c) the same with a warm cache;
* anadyn's own split: the ``time:`` line it prints (load, derive, compile,
  solve, write; reported ``solve`` includes importing scipy.integrate and
  ``write`` importing matplotlib), the process time outside it, and what each
  package's import costs in that very command, from extra runs under
  ``python -X importtime``; ``python -c pass`` gives the interpreter start,
  and the integration and write in a warm process are shown beside them.
"""
from __future__ import annotations

import argparse
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ("rr", "rrt")
T_END, DT = 15.0, 0.01                      # the chapter's 0..15 s, 0.01 s output grid
ODE45 = {"rtol": 1e-3, "atol": 1e-6}       # MATLAB ode45's default tolerances
REFERENCE = {"method": "DOP853", "rtol": 1e-13, "atol": 1e-15}
CHECK = {"rtol": 1e-12, "atol": 1e-14}      # Radau, to check the reference
ERROR_TARGET, SPEEDUP_TARGET, E2E_TARGET = 1e-8, 50.0, 0.3


# ============================================================================
# the seed-style pipeline (the chapter's way; nothing from anadyn)
# ============================================================================
def _to_first_order(sp, t, q, eqs):
    """Replace q'' by ddq_r, q' by x(2r), q by x(2r-1) (the chapter's lists), solve for ddq."""
    n = len(q)
    x = sp.symbols(f"x1:{2 * n + 1}", real=True)
    ddq = sp.symbols(f"ddq1:{n + 1}", real=True)
    pairs = ([(q[r].diff(t, 2), ddq[r]) for r in range(n)]
             + [(q[r].diff(t), x[2 * r + 1]) for r in range(n)]
             + [(q[r], x[2 * r]) for r in range(n)])
    eqs = [e.subs(pairs) for e in eqs]
    start = time.perf_counter()
    sol = sp.solve(eqs, ddq, dict=True)[0]
    solve_time = time.perf_counter() - start
    rhs = []
    for r in range(n):
        rhs += [x[2 * r + 1], sol[ddq[r]]]
    return x, rhs, solve_time


def seed_equations_rr():
    """Program 6.1: planar RR arm, absolute angles; returns (x, rhs, x0, times)."""
    import sympy as sp

    start = time.perf_counter()
    t = sp.Symbol("t", real=True)
    L1, L2, m1, m2, g = sp.symbols("L1 L2 m1 m2 g", real=True)
    q1, q2 = sp.Function("q1")(t), sp.Function("q2")(t)
    c1, s1, c2, s2 = sp.cos(q1), sp.sin(q1), sp.cos(q2), sp.sin(q2)
    rB = sp.Matrix([L1 * c1, L1 * s1, 0])
    rC1 = rB / 2
    rD = rB + sp.Matrix([L2 * c2, L2 * s2, 0])
    rC2 = (rB + rD) / 2
    vC2 = rC2.diff(t)
    omega1 = sp.Matrix([0, 0, q1.diff(t)])
    omega2 = sp.Matrix([0, 0, q2.diff(t)])
    IA, IC2 = m1 * L1**2 / 3, m2 * L2**2 / 12         # bar 1 about A, bar 2 about C2
    T1 = IA * omega1.dot(omega1) / 2
    T2 = m2 * vC2.dot(vC2) / 2 + IC2 * omega2.dot(omega2) / 2
    T = sp.expand(T1 + T2)                              # total kinetic energy

    G1, G2 = sp.Matrix([0, -m1 * g, 0]), sp.Matrix([0, -m2 * g, 0])
    T01z, T12z = sp.symbols("T01z T12z", real=True)
    T01, T12 = sp.Matrix([0, 0, T01z]), sp.Matrix([0, 0, T12z])
    q = [q1, q2]
    lagrange = []
    for qr in q:
        dqr = qr.diff(t)
        Q = (rC1.diff(qr).dot(G1) + omega1.diff(dqr).dot(T01) + omega1.diff(dqr).dot(-T12)
             + rC2.diff(qr).dot(G2) + omega2.diff(dqr).dot(T12))
        LHS = T.diff(dqr).diff(t) - T.diff(qr)
        lagrange.append(LHS - Q)

    b01, g01, b12, g12 = 450, 300, 200, 300
    q1f, q2f = sp.pi / 6, sp.pi / 3
    data = {L1: 1, L2: 1, m1: 1, m2: 1, g: 9.81}
    T01zc = (-b01 * q1.diff(t) - g01 * (q1 - q1f) + 0.5 * g * L1 * m1 * c1
             + g * L1 * m2 * c1).subs(data)
    T12zc = (-b12 * q2.diff(t) - g12 * (q2 - q2f) + 0.5 * g * L2 * m2 * c2).subs(data)
    lagrange = [e.subs({T01z: T01zc, T12z: T12zc}).subs(data) for e in lagrange]
    derive = time.perf_counter() - start

    x, rhs, solve_time = _to_first_order(sp, t, q, lagrange)
    x0 = [-math.pi / 18, 0.0, math.pi / 6, 0.0]
    return x, rhs, x0, {"derive": derive, "sympy.solve": solve_time}


def seed_equations_rrt():
    """Program 6.3: spatial RRT arm, i0 vertical; returns (x, rhs, x0, times)."""
    import sympy as sp

    start = time.perf_counter()
    t = sp.Symbol("t", real=True)
    L1, L2, m1, m2, m3, g = sp.symbols("L1 L2 m1 m2 m3 g", real=True)
    I3x, I3y, I3z = sp.symbols("I3x I3y I3z", real=True)
    q1, q2, q3 = (sp.Function(f"q{i}")(t) for i in (1, 2, 3))
    c2, s2 = sp.cos(q2), sp.sin(q2)
    R21 = sp.Matrix([[c2, 0, -s2], [0, 1, 0], [s2, 0, c2]])   # frame-1 -> frame-2 components
    # angular velocities: w10 in frame 1, w20 in frame 2 (w201 * R21.' in MATLAB)
    w10 = sp.Matrix([q1.diff(t), 0, 0])
    w20 = R21 * sp.Matrix([q1.diff(t), q2.diff(t), 0])
    # mass centres and their velocities (frame-1 / frame-2 components)
    rC1 = sp.Matrix([0, 0, L1])
    vC1 = rC1.diff(t) + w10.cross(rC1)
    rC2 = R21 * sp.Matrix([0, 0, 2 * L1]) + sp.Matrix([0, 0, L2])
    vC2 = rC2.diff(t) + w20.cross(rC2)
    rC3 = rC2 + sp.Matrix([0, 0, q3])
    vC3 = rC3.diff(t) + w20.cross(rC3)
    vC32 = vC2 + w20.cross(sp.Matrix([0, 0, q3]))       # point of link 2 at C3
    # forces and torques (gravity along -i0 = -i1)
    G1 = sp.Matrix([-m1 * g, 0, 0])
    G2 = R21 * sp.Matrix([-m2 * g, 0, 0])
    G3 = R21 * sp.Matrix([-m3 * g, 0, 0])
    T01x, T01y, T01z, T12x, T12y, T12z, F23x, F23y, F23z = sp.symbols(
        "T01x T01y T01z T12x T12y T12z F23x F23y F23z", real=True)
    T01 = sp.Matrix([T01x, T01y, T01z])                  # frame 1
    T12 = sp.Matrix([T12x, T12y, T12z])                  # frame 2
    F23 = sp.Matrix([F23x, F23y, F23z])                  # frame 2
    # kinetic energy with the chapter's central inertias
    I1 = sp.diag(m1 * (2 * L1)**2 / 12, m1 * (2 * L1)**2 / 12, 0)
    I2 = sp.diag(m2 * (2 * L2)**2 / 12, m2 * (2 * L2)**2 / 12, 0)
    I3 = sp.diag(I3x, I3y, I3z)
    T1 = m1 * vC1.dot(vC1) / 2 + (w10.T * I1 * w10)[0] / 2
    T2 = m2 * vC2.dot(vC2) / 2 + (w20.T * I2 * w20)[0] / 2
    T3 = m3 * vC3.dot(vC3) / 2 + (w20.T * I3 * w20)[0] / 2
    T = sp.expand(T1 + T2 + T3)

    q = [q1, q2, q3]
    lagrange = []
    for qr in q:
        dqr = qr.diff(t)
        w1r, w2r = w10.diff(dqr), w20.diff(dqr)
        Q = (w1r.dot(T01) + vC1.diff(dqr).dot(G1) + w1r.dot(R21.T * -T12)
             + w2r.dot(T12) + vC2.diff(dqr).dot(G2) + vC32.diff(dqr).dot(-F23)
             + vC3.diff(dqr).dot(F23) + vC3.diff(dqr).dot(G3))
        LHS = T.diff(dqr).diff(t) - T.diff(qr)
        lagrange.append(LHS - Q)

    q1f, q2f, q3f = sp.pi / 3, sp.pi / 3, 0.3
    b01, g01, b12, g12, b23, g23 = 450, 300, 200, 300, 150, 50
    data = {L1: 0.4, L2: 0.4, I3x: 5, I3y: 4, I3z: 1, m1: 90, m2: 60, m3: 40, g: 9.81}
    laws = {T01x: -b01 * q1.diff(t) - g01 * (q1 - q1f),
            T12y: -b12 * q2.diff(t) - g12 * (q2 - q2f) + g * (m2 * L2 + m3 * (L2 + q3)) * c2,
            F23z: -b23 * q3.diff(t) - g23 * (q3 - q3f) + g * m3 * s2,
            # components with no actuator: zero (they cancel from Q anyway, eq. 6.41)
            T01y: 0, T01z: 0, T12x: 0, T12z: 0, F23x: 0, F23y: 0}
    lagrange = [sp.expand(e).subs(laws).subs(data) for e in lagrange]
    derive = time.perf_counter() - start

    x, rhs, solve_time = _to_first_order(sp, t, q, lagrange)
    x0 = [math.pi / 18, 0.0, math.pi / 6, 0.0, 0.25, 0.0]
    return x, rhs, x0, {"derive": derive, "sympy.solve": solve_time}


def seed_rhs(name):
    """(rhs(t, x), calls, x0, times): the lambdified first-order system with a call counter."""
    import sympy as sp

    x, rhs_exprs, x0, times = (seed_equations_rr if name == "rr" else seed_equations_rrt)()
    start = time.perf_counter()
    t = sp.Symbol("t", real=True)
    f = sp.lambdify([t, *x], rhs_exprs, modules="math")
    times["lambdify"] = time.perf_counter() - start
    calls = [0]

    def rhs(tt, xx):
        calls[0] += 1
        return f(tt, *xx.tolist())

    return rhs, calls, x0, times


def seed_solve(rhs, x0, grid):
    from scipy.integrate import solve_ivp

    return solve_ivp(rhs, (0.0, T_END), x0, method="RK45", t_eval=grid, **ODE45)


def seed_plot(name, t, y, png):
    """The chapter's figure: one panel per coordinate (deg for angles, m for q3)."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    n = len(y) // 2
    figure = Figure(figsize=(7, 2.2 * n))
    axes = figure.subplots(n, 1, squeeze=False)[:, 0]
    for r, (ax, colour) in enumerate(zip(axes, "rbg")):
        prismatic = name == "rrt" and r == 2
        ax.plot(t, y[2 * r] if prismatic else y[2 * r] * 180 / math.pi, colour)
        ax.set_xlabel("t (s)")
        ax.set_ylabel(f"q{r + 1} ({'m' if prismatic else 'deg'})")
        ax.grid(True)
    figure.savefig(png)


def seed_grid():
    import numpy as np

    return np.arange(int(round(T_END / DT)) + 1) * DT


def seed_run(name, png):
    """The whole seed-style pipeline as one standalone process (end-to-end case (a))."""
    start = time.perf_counter()
    import matplotlib
    import numpy as np  # noqa: F401  (timed with the other imports)
    import scipy.integrate  # noqa: F401
    import sympy  # noqa: F401
    matplotlib.use("Agg")
    import matplotlib.figure  # noqa: F401
    imports = time.perf_counter() - start
    rhs, calls, x0, times = seed_rhs(name)
    grid = seed_grid()
    mark = time.perf_counter()
    sol = seed_solve(rhs, x0, grid)
    integrate = time.perf_counter() - mark
    mark = time.perf_counter()
    seed_plot(name, sol.t, sol.y, png)
    plot = time.perf_counter() - mark
    n = len(x0) // 2
    print("t(s)  " + "  ".join(f"q{r}  dq{r}" for r in range(1, n + 1)))
    for k in range(0, 501, 100):
        print(f"{sol.t[k]:.1f}  " + "  ".join(f"{v:.6f}" for v in sol.y[:, k]))
    print(f"rhs calls {calls[0]}, status {sol.status}")
    print(f"seed-time: import {imports:.3f} s, derive {times['derive']:.3f} s, "
          f"sympy.solve {times['sympy.solve']:.3f} s, lambdify {times['lambdify']:.3f} s, "
          f"integrate {integrate:.3f} s, plot {plot:.3f} s; "
          f"total {time.perf_counter() - start:.3f} s")
    return 0 if sol.status == 0 else 1


# ============================================================================
# measurements in this process
# ============================================================================
def min_time(fn, repeats):
    best, result = math.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def anadyn_setup(name):
    from anadyn_cli.numeric.build import numeric_model
    from anadyn_cli.numeric.settings import output_grid, resolve

    model = numeric_model(ROOT / "robots" / f"{name}.yaml", evaluator="recursive")
    settings = resolve(model.info)
    grid = output_grid(settings.t_end, settings.output_step)
    return model.info, model, settings, grid, model.initial_state()


def reference(rhs, x0, grid):
    from scipy.integrate import solve_ivp

    start = time.perf_counter()
    sol = solve_ivp(rhs, (grid[0], grid[-1]), x0, t_eval=grid, **REFERENCE)
    if sol.status != 0:
        raise RuntimeError(f"reference failed: {sol.message}")
    return sol.y.T, time.perf_counter() - start


def errors(x, ref, n):
    import numpy as np

    d = np.abs(np.asarray(x) - ref)
    return float(d[:, :n].max()), float(d[:, n:].max())


def bench_robot(name, repeats):
    """Everything measured in this process for one robot; returns a dict of figures."""
    import numpy as np
    from scipy.integrate import solve_ivp

    from anadyn_cli.numeric import integrators
    from anadyn_cli.services import simulate as service

    info, compiled, settings, grid, x0 = anadyn_setup(name)
    n = compiled.n
    rhs, calls, x0_seed, seed_times = seed_rhs(name)
    # seed state [q1, dq1, q2, dq2, ...] <-> anadyn state [q1, q2, ..., dq1, dq2, ...]
    order = [2 * r for r in range(n)] + [2 * r + 1 for r in range(n)]
    back = np.argsort(order)
    if not np.allclose(np.asarray(x0_seed)[order], x0, rtol=0, atol=1e-15):
        raise RuntimeError(f"{name}: initial states differ: {x0_seed} vs {x0}")
    if not np.allclose(seed_grid(), grid, rtol=0, atol=1e-12):
        raise RuntimeError(f"{name}: output grids differ")

    # the two models agree? (random states, relative to the size of the derivative)
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(20):
        x = np.concatenate([rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n)])
        if name == "rrt":
            x[2] = rng.uniform(0.0, 0.5)
        a = compiled.rhs(1.0, x)
        b = np.asarray(rhs(1.0, x[back]))[order]
        worst = max(worst, float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(a)))))

    counted = {"rhs": 0}

    def counted_rhs(t, x):
        counted["rhs"] += 1
        return compiled.rhs(t, x)

    ref, ref_time = reference(counted_rhs, x0, grid)
    ref_calls = counted["rhs"]
    # is the reference good to well below 1e-8?  A different (implicit) method agrees?
    start = time.perf_counter()
    check = solve_ivp(compiled.rhs, (grid[0], grid[-1]), x0, method="Radau", t_eval=grid,
                      jac=compiled.jacobian, **CHECK)
    check_time = time.perf_counter() - start
    ref_gap = float(np.max(np.abs(check.y.T - ref))) if check.status == 0 else math.inf

    calls[0] = 0
    seed_best, sol = min_time(lambda: seed_solve(rhs, x0_seed, grid), repeats)
    seed_calls = calls[0] // repeats
    if seed_calls != sol.nfev:
        raise RuntimeError(f"{name}: counted {seed_calls} RHS calls, solve_ivp says {sol.nfev}")
    if sol.status != 0 or sol.y.shape[1] != len(grid):
        raise RuntimeError(f"{name}: seed-style solve failed: {sol.message}")
    seed_x = sol.y.T[:, order]

    walls = []

    def run_anadyn():
        s = integrators.integrate(compiled.problem(), x0, grid, settings.method,
                                  settings.rtol, settings.atol)
        walls.append(s.wall)
        return s

    anadyn_best, solution = min_time(run_anadyn, repeats)
    if not solution.success:
        raise RuntimeError(f"{name}: anadyn failed: {solution.message}")

    # anadyn's write (CSV + PNG + JSON) in this warm process, for the end-to-end split
    result = service.simulate(compiled)
    folder = Path(tempfile.mkdtemp(prefix="anadyn-bench-write-"))
    try:
        write_best, _ = min_time(lambda: service.write(result, folder), repeats)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return {
        "name": name, "n": n, "rows": len(grid), "model_gap": worst,
        "ref_time": ref_time, "ref_calls": ref_calls, "check_time": check_time,
        "ref_gap": ref_gap, "seed_times": seed_times, "write": write_best,
        "seed": {"time": seed_best, "rhs": seed_calls, "jac": 0, "nfev": sol.nfev,
                 "err": errors(seed_x, ref, n),
                 "method": "RK45", "rtol": ODE45["rtol"], "atol": ODE45["atol"]},
        "anadyn": {"time": anadyn_best, "wall": min(walls), "rhs": solution.rhs_calls,
                   "jac": solution.jacobian_calls, "steps": solution.steps,
                   "err": errors(solution.x, ref, n),
                   "method": f"{settings.method} -> {solution.method}",
                   "rtol": settings.rtol, "atol": settings.atol, "reason": solution.reason},
    }


# ============================================================================
# whole processes
# ============================================================================
def anadyn_command():
    script = Path(sys.executable).parent / "anadyn"
    if script.exists():
        return [str(script)]
    found = shutil.which("anadyn")
    return [found] if found else [sys.executable, "-m", "anadyn_cli"]


def run_process(cmd, env=None, png=None):
    """(wall seconds from start to exit, stdout); raises if it failed or wrote no PNG."""
    if png is not None and png.exists():
        png.unlink()
    start = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {done.returncode}:\n{done.stderr}")
    if png is not None and not png.exists():
        raise RuntimeError(f"{' '.join(cmd)} wrote no {png}")
    return wall, done.stdout


def parse_anadyn_time(stdout):
    """{'load': s, ..., 'cache': 'hit'|'miss', 'total': s} from the ``time:`` line."""
    match = re.search(r"^time: (.*?); total ([0-9.]+) s(;.*)?$", stdout, re.MULTILINE)
    if not match:
        raise RuntimeError(f"no time: line in\n{stdout}")
    parts = {"total": float(match.group(2))}
    for item in match.group(1).split(", "):
        words = item.split()
        if words[0] == "cache":
            parts["cache"] = words[1]
        else:
            parts[words[0]] = float(words[1])
    return parts


def parse_seed_time(stdout):
    match = re.search(r"^seed-time: (.*); total ([0-9.]+) s$", stdout, re.MULTILINE)
    if not match:
        raise RuntimeError(f"no seed-time: line in\n{stdout}")
    parts = {"total": float(match.group(2))}
    for item in match.group(1).split(", "):
        key, value, _ = item.rsplit(" ", 2)
        parts[key] = float(value)
    return parts


# the package an import belongs to, by its top-level name (outermost one wins)
IMPORT_GROUPS = {"numpy": "numpy", "sympy": "sympy", "mpmath": "sympy", "scipy": "scipy",
                 "matplotlib": "matplotlib", "PIL": "matplotlib", "kiwisolver": "matplotlib",
                 "fontTools": "matplotlib", "pyparsing": "matplotlib", "cycler": "matplotlib",
                 "dateutil": "matplotlib", "contourpy": "matplotlib", "typer": "typer",
                 "click": "typer", "rich": "typer", "shellingham": "typer", "yaml": "yaml"}


def parse_importtime(stderr, startup):
    """Seconds per IMPORT_GROUPS package and 'other' from ``python -X importtime`` output.

    Each import is charged to the outermost package of interest above it (so numpy
    imported by scipy counts as scipy); top-level imports that a bare interpreter
    also does (``startup``: site, encodings, ...) are left out.
    """
    lines = []
    for line in stderr.splitlines():
        match = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)", line)
        if match:
            lines.append((len(match.group(3)) // 2, match.group(4), int(match.group(2)) * 1e-6))
    groups = dict.fromkeys(sorted(set(IMPORT_GROUPS.values())), 0.0)
    total = 0.0
    stack = []                                   # (depth, inside a group), pre-order
    for depth, name, cumulative in reversed(lines):
        while stack and stack[-1][0] >= depth:
            stack.pop()
        inside = bool(stack) and stack[-1][1]
        group = IMPORT_GROUPS.get(name.split(".")[0])
        if depth == 0 and name not in startup:
            total += cumulative
        if group and not inside and not (depth == 0 and name in startup):
            groups[group] += cumulative
        stack.append((depth, inside or group is not None))
    groups["other"] = total - sum(groups.values())
    return groups


def startup_modules():
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", "pass"],
                          capture_output=True, text=True)
    return {m.group(1) for m in re.finditer(r"\|\s+\d+ \| (\S+)", done.stderr)}


def traced_run(cmd, env, startup):
    """One run of ``cmd`` (under -X importtime) with PYTHONUNBUFFERED: wall, when its
    ``time:`` line arrived, the parts it reports and the import time per package."""
    with tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, env={**env, "PYTHONUNBUFFERED": "1"},
                                stdout=subprocess.PIPE, stderr=err, text=True)
        lines = [(time.perf_counter() - start, line) for line in proc.stdout]
        proc.wait()
        wall = time.perf_counter() - start
        err.seek(0)
        stderr = err.read()
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}:\n{stderr[-2000:]}")
    arrived = next(t for t, line in lines if line.startswith("time: "))
    return {"wall": wall, "time_line": arrived,
            "parts": parse_anadyn_time("".join(line for _, line in lines)),
            "imports": parse_importtime(stderr, startup)}


def end_to_end(repeats, work):
    """Interleaved whole-process runs for rr: seed (a), anadyn cold (b), anadyn warm (c)."""
    robot = str(ROOT / "robots" / "rr.yaml")
    seed_png = work / "seed" / "rr.png"
    seed_png.parent.mkdir()
    seed_cmd = [sys.executable, str(Path(__file__).resolve()), "--seed-run", "rr",
                "--png", str(seed_png)]
    anadyn = anadyn_command()
    out = work / "anadyn"
    png = out / "simulate.png"
    warm_cache = work / "warm-cache"
    env = dict(os.environ)
    env.pop("ANADYN_CACHE_DIR", None)

    def anadyn_run(cache_dir):
        wall, stdout = run_process([*anadyn, "simulate", robot, "--out", str(out)],
                                   {**env, "ANADYN_CACHE_DIR": str(cache_dir)}, png)
        return wall, parse_anadyn_time(stdout)

    def warm_run():
        """A run that hits the warm cache.  The cache key includes a fingerprint of
        anadyn's source, so an edit to anadyn during the bench makes the next run miss
        (and store the new entry): that run is dropped and repeated."""
        for _ in range(5):
            wall, parts = anadyn_run(warm_cache)
            if parts.get("cache") == "hit":
                return wall, parts
            misses[0] += 1
        raise RuntimeError("the warm cache kept missing (anadyn's source keeps changing?)")

    misses = [0]
    _, primed = anadyn_run(warm_cache)                     # fill the warm cache
    if primed.get("cache") != "miss":
        raise RuntimeError("priming run did not miss the empty cache")
    runs = {"seed": [], "cold": [], "warm": []}
    for k in range(repeats):
        wall, stdout = run_process(seed_cmd, env, seed_png)
        runs["seed"].append((wall, parse_seed_time(stdout)))
        cold_cache = work / f"cold-cache-{k}"
        runs["cold"].append(anadyn_run(cold_cache))
        shutil.rmtree(cold_cache, ignore_errors=True)
        runs["warm"].append(warm_run())
    if {r[1].get("cache") for r in runs["cold"]} != {"miss"}:
        raise RuntimeError("a cold run did not miss its empty cache")
    if misses[0]:
        print(f"note: {misses[0]} warm run(s) missed the cache because anadyn's source changed "
              "during the bench; each was dropped and repeated")

    bare = min(run_process([sys.executable, "-c", "pass"])[0] for _ in range(repeats))

    # where the time goes: the same command under -X importtime with unbuffered output,
    # so each stdout line is time-stamped on arrival; the fastest of a few runs is kept
    startup = startup_modules()
    traced_cmd = ([sys.executable, "-X", "importtime", *anadyn] if anadyn[0] != sys.executable
                  else [sys.executable, "-X", "importtime", *anadyn[1:]])
    traced = {}
    for key in ("cold", "warm"):
        found = []
        for k in range(min(3, repeats)):
            cache_dir = warm_cache if key == "warm" else work / f"traced-cache-{k}"
            run = traced_run([*traced_cmd, "simulate", robot, "--out", str(out)],
                             {**env, "ANADYN_CACHE_DIR": str(cache_dir)}, startup)
            if run["parts"].get("cache") == ("hit" if key == "warm" else "miss"):
                found.append(run)        # (a warm miss: anadyn's source changed; dropped)
        if not found:
            raise RuntimeError(f"no {key} importtime run with the expected cache state")
        traced[key] = min(found, key=lambda r: r["wall"])
    return runs, bare, traced, anadyn


# ============================================================================
# report
# ============================================================================
def table(rows, header):
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(str(c).rjust(w) if i else str(c).ljust(w)
                       for i, (c, w) in enumerate(zip(header, widths))) for c in [header]]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(str(c).rjust(w) if i else str(c).ljust(w)
                        for i, (c, w) in enumerate(zip(r, widths))) for r in rows]
    return "\n".join(lines)


def report_robot(r, repeats):
    s, a = r["seed"], r["anadyn"]
    print(f"\n== {r['name']}: 0..{T_END:g} s, {r['rows']} grid rows, n = {r['n']} ==")
    st = r["seed_times"]
    print(f"seed-style derivation in this process: Lagrange + substitutions "
          f"{st['derive']:.3f} s, sympy.solve {st['sympy.solve']:.3f} s, lambdify "
          f"{st['lambdify']:.3f} s")
    print(f"models agree: max |f_seed - f_anadyn| / max(1, |f|) over 20 random states = "
          f"{r['model_gap']:.1e}")
    print(f"reference: DOP853 rtol {REFERENCE['rtol']:g} atol {REFERENCE['atol']:g} on anadyn's "
          f"compiled RHS ({r['ref_calls']} RHS calls, {r['ref_time']:.2f} s); Radau rtol "
          f"{CHECK['rtol']:g} atol {CHECK['atol']:g} ({r['check_time']:.2f} s) differs from it "
          f"by at most {r['ref_gap']:.1e}")
    header = ("pipeline", "method", "rtol", "atol", f"solve s (min of {repeats})",
              "RHS calls", "Jac calls", "solve us/call", "max|q err|", "max|dq err|")
    rows = []
    for label, d in (("seed-style (sympy.solve + lambdify)", s), ("anadyn default", a)):
        per = d["time"] / max(1, d["rhs"] + d["jac"]) * 1e6
        rows.append((label, d["method"], f"{d['rtol']:g}", f"{d['atol']:g}", f"{d['time']:.4f}",
                     d["rhs"], d["jac"], f"{per:.1f}", f"{d['err'][0]:.2e}",
                     f"{d['err'][1]:.2e}"))
    print(table(rows, header))
    print(f"anadyn auto: {a['reason']}")
    print(f"anadyn solve: {a['time']:.4f} s with the stiffness analysis, {a['wall']:.4f} s "
          f"inside the integrator (Solution.wall); {a['steps']} steps")
    print(f"solve time ratio seed/anadyn: {s['time'] / a['time']:.1f}x")


def report_e2e(runs, bare, traced, command, repeats, rr):
    best = {k: min(v, key=lambda r: r[0]) for k, v in runs.items()}
    seed_wall = best["seed"][0]
    print(f"\n== end to end, rr (whole processes, min of {repeats}, interleaved) ==")
    print(f"anadyn command: {' '.join(command)} simulate robots/rr.yaml --out TMP")
    rows = [("(a) seed-style pipeline (python bench/simulate.py --seed-run rr)",
             f"{seed_wall:.3f}", "1.00"),
            ("(b) anadyn simulate, cold cache (fresh ANADYN_CACHE_DIR each run)",
             f"{best['cold'][0]:.3f}", f"{best['cold'][0] / seed_wall:.2f}"),
            ("(c) anadyn simulate, warm cache (primed once)",
             f"{best['warm'][0]:.3f}", f"{best['warm'][0] / seed_wall:.2f}")]
    print(table(rows, ("process", "wall s", "x (a)")))
    print("all runs (s): " + "; ".join(f"{k} " + " ".join(f"{w:.2f}" for w, _ in v)
                                        for k, v in runs.items()))

    sp = best["seed"][1]
    print(f"\n(a)'s split (fastest run, its own timer): imports {sp['import']:.3f} s, derive "
          f"{sp['derive']:.3f} s, sympy.solve {sp['sympy.solve']:.3f} s, lambdify "
          f"{sp['lambdify']:.3f} s, integrate {sp['integrate']:.3f} s, plot {sp['plot']:.3f} s; "
          f"outside its timer (python startup, exit) {seed_wall - sp['total']:.3f} s")

    print(f"\nanadyn's own time, rr: the fastest of {min(3, repeats)} extra runs of each under "
          "`python -X importtime` with unbuffered output (one process per column, so the "
          "parts add up): its time: line, the import time of each package (charged to the "
          "outermost package imported), when the time: line arrived; python startup from "
          f"`python -c pass` (min of {repeats}); [bracketed]: the same work in this warm "
          f"bench process (min of {repeats})")
    lines = {}
    for key in ("cold", "warm"):
        run = traced[key]
        wall, t, imp = run["wall"], run["parts"], run["imports"]
        named = {k: t.get(k, 0.0) for k in ("load", "derive", "compile", "solve", "write")}
        before = run["time_line"] - t["total"]
        pre = bare + imp["typer"] + imp["numpy"] + imp["yaml"] + imp["other"]
        inner = t["total"] - sum(named.values())
        lines[key] = [
            ("process wall (traced run)", wall),
            ("  [untimed-by-importtime fastest run, from the table above]", best[key][0]),
            ("before the command's clock starts", before),
            ("  python startup (python -c pass)", bare),
            ("  import typer/click", imp["typer"]),
            ("  import numpy", imp["numpy"]),
            ("  import yaml, anadyn's modules, stdlib (*)", imp["yaml"] + imp["other"]),
            ("  rest: typer dispatch, importtime overhead", before - pre),
            ("reported total", t["total"]),
            ("  outside the named parts (total - parts)", inner),
            ("    import sympy (a miss only)", imp["sympy"]),
            ("    rest: hashing, cache read/store, efforts, table", inner - imp["sympy"]),
            ("  load (YAML -> validated robot)", named["load"]),
            ("  derive", named["derive"]),
            ("  compile", named["compile"]),
            ("  solve", named["solve"]),
            ("    import scipy.integrate", imp["scipy"]),
            ("    integrating (solve - import)", named["solve"] - imp["scipy"]),
            ("    [integrating: Solution.wall]", rr["anadyn"]["wall"]),
            ("  write (CSV + PNG)", named["write"]),
            ("    import matplotlib (+ PIL)", imp["matplotlib"]),
            ("    drawing + files (write - import)", named["write"] - imp["matplotlib"]),
            ("    [simulate.write(): CSV + PNG + JSON]", rr["write"]),
            ("after the time: line (interpreter exit)", wall - run["time_line"]),
        ]
    rows = [(label, f"{value:.3f}", f"{dict(lines['warm'])[label]:.3f}")
            for label, value in lines["cold"]]
    print(table(rows, ("part (s)", "cold", "warm")))
    print("(*) on a miss part of this is imported inside the command (anadyn's "
          "formulation and code-generation modules, in derive and compile)")
    for key in ("cold", "warm"):
        run = traced[key]
        wall, t, imp = run["wall"], run["parts"], run["imports"]
        importing = bare + sum(imp.values())
        work_s = rr["anadyn"]["wall"] + rr["write"]
        derivation = sum(t.get(k, 0.0) for k in ("load", "derive", "compile"))
        print(f"{key}: of {wall:.3f} s, python startup + imports {importing:.3f} s "
              f"({100 * importing / wall:.0f}%: scipy.integrate {imp['scipy']:.3f}, matplotlib "
              f"{imp['matplotlib']:.3f}, sympy {imp['sympy']:.3f}, typer {imp['typer']:.3f}, "
              f"numpy {imp['numpy']:.3f}); integration + write as in a warm process "
              f"{work_s:.3f} s ({100 * work_s / wall:.0f}%); load + derive + compile "
              f"{derivation:.3f} s ({100 * derivation / wall:.0f}%); interpreter exit "
              f"{wall - run['time_line']:.3f} s")
    return best


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5,
                        help="timed repeats; the minimum is reported (default: 5)")
    parser.add_argument("--seed-run", choices=ROBOTS, help=argparse.SUPPRESS)
    parser.add_argument("--png", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.seed_run:
        return seed_run(args.seed_run, args.png)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")

    import platform

    import matplotlib
    import numpy
    import scipy
    import sympy
    started = time.perf_counter()
    print(f"anadyn simulate benchmark: python {platform.python_version()}, sympy "
          f"{sympy.__version__}, scipy {scipy.__version__}, numpy {numpy.__version__}, "
          f"matplotlib {matplotlib.__version__}, {os.cpu_count()} cpu(s), repeats "
          f"{args.repeats}; everything sequential", flush=True)
    results = {}
    for name in ROBOTS:
        results[name] = bench_robot(name, args.repeats)
        report_robot(results[name], args.repeats)
        sys.stdout.flush()

    work = Path(tempfile.mkdtemp(prefix="anadyn-bench-"))
    try:
        runs, bare, traced, command = end_to_end(args.repeats, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    best = report_e2e(runs, bare, traced, command, args.repeats, results["rr"])

    print("\n== summary ==")
    verdict = lambda ok: "PASS" if ok else "FAIL"
    for name in ROBOTS:
        err = max(results[name]["anadyn"]["err"])
        print(f"{verdict(err <= ERROR_TARGET)}  {name}: anadyn default max error "
              f"{err:.2e} <= {ERROR_TARGET:g}")
    rr, rrt = results["rr"], results["rrt"]
    ratio = rr["seed"]["time"] / rr["anadyn"]["time"]
    print(f"{verdict(ratio >= SPEEDUP_TARGET)}  rr: solve time seed/anadyn {ratio:.1f}x >= "
          f"{SPEEDUP_TARGET:g}x ({rr['seed']['time']:.4f} s vs {rr['anadyn']['time']:.4f} s)")
    ratio = rrt["seed"]["time"] / rrt["anadyn"]["time"]
    print(f"{verdict(ratio >= 1)}  rrt: anadyn no slower, seed/anadyn {ratio:.2f}x >= 1x "
          f"({rrt['seed']['time']:.4f} s vs {rrt['anadyn']['time']:.4f} s)")
    seed_wall = best["seed"][0]
    for key, label in (("cold", "cold cache (derives)"), ("warm", "warm cache (no SymPy)")):
        ratio = best[key][0] / seed_wall
        print(f"{verdict(ratio <= E2E_TARGET)}  rr end to end, {label}: {best[key][0]:.3f} s "
              f"= {ratio:.2f}x the seed-style {seed_wall:.3f} s (target <= {E2E_TARGET:g}x)")
    print(f"\ntotal bench time {time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
