"""Benchmark: anadyn's derive() against sympy.physics.mechanics on spatial n-link chains.

    python bench/derive.py [--sizes 2 4 6 8] [--cap 120] [--seed 1]

The chain: n revolute joints with alternating axes z, y, z, y, ... (each axis
fixed in the parent link), every link a slender rod of length L = 0.5 m and
mass m = 1 kg with its mass centre at mid-length (ixx = iyy = m L^2/12,
izz = 1e-3), each joint at the previous link's tip, gravity g = 9.81 along -z
and one torque per joint (reaction on the parent link).  Both tools get the
same exact (rational) numbers.

Every measurement runs in its own freshly *spawned* process (no fork, so no
SymPy cache is inherited), one at a time, and the wall time is recorded inside
the child with ``time.perf_counter``:

  anadyn Kane / Lagrange   the whole ``derive(robot, method)`` call, on a robot
                           freshly built from the YAML text in that process.
  KanesMethod              KanesMethod(...) + kanes_equations + mass_matrix + forcing
  LagrangesMethod          Lagrangian(...) (potential energies set on the bodies)
                           + LagrangesMethod(...) + form_lagranges_equations
                           + mass_matrix + forcing
  (building the frames, points, bodies and loads of the mechanics model is
  timed separately and reported as "setup"; it is not in the table.)

A measurement that does not finish within ``--cap`` seconds is killed and
shown as "over".  After the timing the child evaluates its M and forcing at
one random state (for the correctness guard) and, for anadyn, counts the
operations of M and F after ``sympy.cse``; these steps are capped too.
"""
from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import os
import platform
import queue as queue_module
import sys
import time
import traceback

L_TEXT, IXX_TEXT, IZZ_TEXT, G_TEXT = "0.5", "m*L**2/12", "0.001", "9.81"
START_TIMEOUT = 120.0      # seconds allowed for a child to start and import
TOL = 1e-9                 # relative tolerance of the correctness guard


# ----------------------------------------------------------------------------
# the chain for anadyn
# ----------------------------------------------------------------------------
def chain_yaml(n: int) -> str:
    lines = [f"name: chain{n}",
             f"parameters: {{g: {G_TEXT}, L: {L_TEXT}, m: 1, Ixx: {IXX_TEXT}, Izz: {IZZ_TEXT}}}",
             "gravity: [0, 0, -g]",
             "coordinates:"]
    lines += [f"  q{i + 1}: {{initial: 0}}" for i in range(n)]
    lines.append("bodies:")
    for i in range(n):
        axis = "[0, 0, 1]" if i % 2 == 0 else "[0, 1, 0]"
        origin = "[0, 0, 0]" if i == 0 else "[0, 0, L]"
        lines.append(f"  - name: l{i + 1}")
        if i:
            lines.append(f"    parent: l{i}")
        lines += [f"    joint: {{type: revolute, axis: {axis}, origin: {origin}}}",
                  "    mass: m",
                  "    com: [0, 0, L/2]",
                  "    inertia: {ixx: Ixx, iyy: Ixx, izz: Izz}"]
    lines.append("actuators:")
    lines += [f"  T{i + 1}: {{joint: l{i + 1}}}" for i in range(n)]
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------
# numeric evaluation of large SymPy expressions (memoised: linear in the DAG)
# ----------------------------------------------------------------------------
def evaluate_all(exprs, env):
    import sympy as sp
    functions = {sp.sin: math.sin, sp.cos: math.cos, sp.tan: math.tan, sp.exp: math.exp,
                 sp.log: math.log, sp.Abs: abs}
    memo = dict(env)

    def value(e):
        try:
            return memo[e]
        except KeyError:
            pass
        if e.is_Number:
            result = float(e)
        elif e.is_Symbol or e.is_Function and not e.args:
            raise ValueError(f"no value for {e}")
        else:
            args = [value(a) for a in e.args]
            if e.is_Add:
                result = math.fsum(args)
            elif e.is_Mul:
                result = math.prod(args)
            elif e.is_Pow:
                base, exponent = args
                result = base ** (int(exponent) if exponent == int(exponent) else exponent)
            elif e.func in functions:
                result = functions[e.func](*args)
            elif isinstance(e, sp.Derivative) or e.free_symbols and not args:
                raise ValueError(f"no value for {e}")
            else:
                result = float(e.func(*map(sp.Float, args)).evalf(30))
        memo[e] = result
        return result

    return [value(sp.sympify(e)) for e in exprs]


# ----------------------------------------------------------------------------
# children
# ----------------------------------------------------------------------------
def _anadyn(n, method, state, post):
    import sympy as sp
    from anadyn_cli import derive, robot_from_text
    robot = robot_from_text(chain_yaml(n), "chain.yaml")
    post(("ready",))
    t0 = time.perf_counter()
    eom = derive(robot, method)
    elapsed = time.perf_counter() - t0
    post(("timed", elapsed, {}))

    q, dq, tau = state
    env = {**dict(zip(eom.q, q)), **dict(zip(eom.dq, dq))}
    M, F, B = eom.M, eom.F, eom.B
    values = evaluate_all(list(M) + list(F) + list(B), env)
    k = n * n
    Mv = [values[i * n:(i + 1) * n] for i in range(n)]
    Fv = values[k:k + n]
    Bv = [values[k + n + i * B.cols:k + n + (i + 1) * B.cols] for i in range(n)]
    Ftau = [Fv[i] + sum(Bv[i][j] * tau[j] for j in range(B.cols)) for i in range(n)]
    post(("eval", {"M": Mv, "F": Fv, "Ftau": Ftau}))

    t0 = time.perf_counter()
    replacements, reduced = sp.cse(list(M) + list(F))
    t_cse = time.perf_counter() - t0
    t0 = time.perf_counter()
    ops = (sum(sp.count_ops(rhs) for _, rhs in replacements)
           + sum(sp.count_ops(e) for e in reduced))
    t_count = time.perf_counter() - t0
    post(("cse", int(ops), t_cse, t_count, len(replacements)))


def _mechanics(n, method, state, post):
    import sympy as sp
    import sympy.physics.mechanics as me

    L, m = sp.Rational(L_TEXT), sp.Integer(1)
    Ixx, Izz, g = m * L ** 2 / 12, sp.Rational(IZZ_TEXT), sp.Rational(G_TEXT)
    kane = method == "kane"
    post(("ready",))

    t0 = time.perf_counter()
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    T = sp.symbols(f"T1:{n + 1}", real=True)
    t = me.dynamicsymbols._t
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    bodies, gravity_loads, torques, centres = [], [], [], []
    parent, joint = N, O
    for i in range(n):
        A = me.ReferenceFrame(f"A{i + 1}")
        axis = parent.z if i % 2 == 0 else parent.y
        A.orient_axis(parent, axis, q[i])
        if kane:
            A.set_ang_vel(parent, u[i] * axis)
        G = joint.locatenew(f"G{i + 1}", L / 2 * A.z)
        G.v2pt_theory(joint, N, A)
        tip = joint.locatenew(f"P{i + 2}", L * A.z)
        tip.v2pt_theory(joint, N, A)
        body = me.RigidBody(f"B{i + 1}", G, A, m, (me.inertia(A, Ixx, Ixx, Izz), G))
        bodies.append(body)
        centres.append(G)
        gravity_loads.append((G, -m * g * N.z))
        torques.append((A, T[i] * axis))
        if i:
            torques.append((parent, -T[i] * axis))
        parent, joint = A, tip
    setup = time.perf_counter() - t0

    t0 = time.perf_counter()
    if kane:
        kd = [q[i].diff(t) - u[i] for i in range(n)]
        KM = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
        KM.kanes_equations(bodies, gravity_loads + torques)
        M, F = KM.mass_matrix, KM.forcing
        t_lagrangian = None
    else:
        for body, G in zip(bodies, centres):
            body.potential_energy = m * g * G.pos_from(O).dot(N.z)
        lagrangian = me.Lagrangian(N, *bodies)
        t_lagrangian = time.perf_counter() - t0
        LM = me.LagrangesMethod(lagrangian, q, forcelist=torques, frame=N)
        LM.form_lagranges_equations()
        M, F = LM.mass_matrix, LM.forcing
    elapsed = time.perf_counter() - t0
    post(("timed", elapsed, {"setup": setup, "lagrangian": t_lagrangian}))

    qv, dqv, tau = state
    env = {}
    for i in range(n):
        env[q[i]] = qv[i]
        env[q[i].diff(t)] = dqv[i]
        env[u[i]] = dqv[i]
    zero = {**env, **{T[i]: 0.0 for i in range(n)}}
    loaded = {**env, **{T[i]: tau[i] for i in range(n)}}
    Mflat = evaluate_all(list(M), zero)
    Fv = evaluate_all(list(F), zero)
    Ftau = evaluate_all(list(F), loaded)
    post(("eval", {"M": [Mflat[i * n:(i + 1) * n] for i in range(n)], "F": Fv, "Ftau": Ftau}))


def child(tool, n, method, state, q):
    sys.setrecursionlimit(200000)

    def post(message):
        q.put(message)

    try:
        (_anadyn if tool == "anadyn" else _mechanics)(n, method, state, post)
    except BaseException:
        q.put(("error", traceback.format_exc()))
    q.put(("exit",))


# ----------------------------------------------------------------------------
# parent
# ----------------------------------------------------------------------------
class Run:
    """The outcome of one child: time (None if over/error) and what followed."""

    def __init__(self):
        self.time = None        # seconds, or None
        self.status = "error"   # "ok", "over", "error"
        self.extra = {}
        self.eval = None
        self.cse = None         # (ops, cse s, count s, replacements) | "over" | None
        self.eval_status = None
        self.error = ""


def measure(tool, n, method, state, cap):
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=child, args=(tool, n, method, state, q), daemon=True)
    p.start()
    run = Run()

    def receive(timeout):
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                return q.get(timeout=min(left, 1.0))
            except queue_module.Empty:
                if not p.is_alive():
                    try:    # drain anything posted just before exit
                        return q.get(timeout=1.0)
                    except queue_module.Empty:
                        return ("died", p.exitcode)

    def stop():
        if p.is_alive():
            p.terminate()
            p.join(5)
            if p.is_alive():
                p.kill()
        p.join()

    try:
        message = receive(START_TIMEOUT)
        if not message or message[0] != "ready":
            run.error = f"child did not start: {message!r}"
            return run
        message = receive(cap + 2.0)        # +2 s for passing the message
        if message is None:
            run.status = "over"
            return run
        if message[0] != "timed":
            run.error = str(message[1]) if len(message) > 1 else str(message)
            return run
        run.time, run.extra = message[1], message[2]
        run.status = "over" if run.time > cap else "ok"
        if run.status == "over":
            run.time = None
            return run
        message = receive(cap)
        if message is None:
            run.eval_status = "over"
            return run
        if message[0] != "eval":
            run.eval_status = "error"
            run.error = str(message[1]) if len(message) > 1 else str(message)
            return run
        run.eval, run.eval_status = message[1], "ok"
        if tool == "anadyn":
            message = receive(cap)
            if message is None:
                run.cse = "over"
            elif message[0] == "cse":
                run.cse = message[1:]
            else:
                run.cse = "error"
                run.error = str(message[1]) if len(message) > 1 else str(message)
        return run
    finally:
        stop()


def relative_error(a, b):
    import numpy as np
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(float(np.max(np.abs(b))), 1e-300)
    return float(np.max(np.abs(a - b))) / scale


def compare(ours, theirs):
    """(verdict, errors) for anadyn vs mechanics numbers, or (None, '') if unavailable."""
    if not ours or not theirs:
        return None, ""
    errors = {k: relative_error(ours[k], theirs[k]) for k in ("M", "F", "Ftau")}
    verdict = "ok" if all(e <= TOL for e in errors.values()) else "MISMATCH"
    text = ", ".join(f"{k if k != 'Ftau' else 'F+B*tau'} {v:.1e}" for k, v in errors.items())
    return verdict, text


def fmt_time(run):
    if run.status == "ok":
        return f"{run.time:.3f}"
    return "over" if run.status == "over" else "error"


def fmt_ratio(ours, theirs, cap):
    if ours.status != "ok":
        return "-"
    if theirs.status == "ok":
        return f"{theirs.time / ours.time:.1f}x"
    if theirs.status == "over":
        return f">{cap / ours.time:.1f}x"
    return "-"


def fmt_ops(run):
    if isinstance(run.cse, tuple):
        return str(run.cse[0])
    return run.cse or "-"


def speedup_target(label, ours, theirs, factor, cap):
    if ours is None:
        return f"{label}: n/a (size not run)"
    if ours.status != "ok":
        return f"{label}: FAIL (anadyn {fmt_time(ours)})"
    if theirs.status == "ok":
        ratio = theirs.time / ours.time
        verdict = "PASS" if ratio >= factor else "FAIL"
        return f"{label}: {verdict} ({ratio:.1f}x: {ours.time:.3f} s vs {theirs.time:.3f} s)"
    if theirs.status == "over":
        bound = cap / ours.time
        if bound >= factor:
            return (f"{label}: PASS (>{bound:.1f}x: {ours.time:.3f} s vs over the "
                    f"{cap:g} s cap)")
        return (f"{label}: FAIL (undetermined: mechanics over the {cap:g} s cap only shows "
                f">{bound:.1f}x)")
    return f"{label}: FAIL (mechanics errored; no comparison)"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 4, 6, 8],
                        help="numbers of links (default: 2 4 6 8)")
    parser.add_argument("--cap", type=float, default=120.0,
                        help="seconds allowed per measurement (default: 120)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the random test state")
    args = parser.parse_args(argv)
    if any(n < 1 for n in args.sizes) or args.cap <= 0:
        parser.error("sizes must be >= 1 and the cap positive")

    import numpy as np
    import sympy
    started = time.perf_counter()
    print(f"anadyn derive benchmark: python {platform.python_version()}, sympy "
          f"{sympy.__version__}, {os.cpu_count()} cpu(s), cap {args.cap:g} s, seed {args.seed}; "
          "one spawned process per measurement, run sequentially", flush=True)
    rng = np.random.default_rng(args.seed)
    rows = {}
    for n in args.sizes:
        state = (rng.uniform(-math.pi, math.pi, n).tolist(), rng.uniform(-1, 1, n).tolist(),
                 rng.uniform(-1, 1, n).tolist())
        row = {}
        for key, tool, method in (("ak", "anadyn", "kane"), ("mk", "mechanics", "kane"),
                                  ("al", "anadyn", "lagrange"), ("ml", "mechanics", "lagrange")):
            run = measure(tool, n, method, state, args.cap)
            row[key] = run
            detail = fmt_time(run)
            if run.extra.get("setup") is not None:
                detail += f" (setup {run.extra['setup']:.3f} s"
                if run.extra.get("lagrangian") is not None:
                    detail += f", of which Lagrangian {run.extra['lagrangian']:.3f} s"
                detail += ")"
            if isinstance(run.cse, tuple):
                detail += (f"; cse {run.cse[1]:.2f} s + count_ops {run.cse[2]:.2f} s, "
                           f"{run.cse[0]} ops ({run.cse[3]} subexpressions)")
            elif run.cse:
                detail += f"; cse {run.cse}"
            if run.eval_status not in (None, "ok"):
                detail += f"; numeric evaluation {run.eval_status}"
            if run.error:
                detail += "\n    " + run.error.strip().replace("\n", "\n    ")
            print(f"  n={n} {tool} {method}: {detail}", flush=True)
        rows[n] = row

    header = ("n", "anadyn Kane s", "KanesMethod s", "ratio", "anadyn Lagrange s",
              "LagrangesMethod s", "ratio", "cse ops M+F (Kane, Lagrange)")
    table = [header]
    for n, r in rows.items():
        table.append((str(n), fmt_time(r["ak"]), fmt_time(r["mk"]),
                      fmt_ratio(r["ak"], r["mk"], args.cap), fmt_time(r["al"]),
                      fmt_time(r["ml"]), fmt_ratio(r["al"], r["ml"], args.cap),
                      f"{fmt_ops(r['ak'])}, {fmt_ops(r['al'])}"))
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    print()
    for k, row in enumerate(table):
        print(" | ".join(cell.rjust(w) for cell, w in zip(row, widths)))
        if k == 0:
            print("-+-".join("-" * w for w in widths))

    print()
    print(f"correctness (anadyn vs sympy.physics.mechanics at one random state, "
          f"max relative error <= {TOL:g}):")
    for n, r in rows.items():
        verdict, text = compare(r["ak"].eval, r["mk"].eval)
        line = (f"  n={n} Kane: {verdict} ({text})" if verdict else
                f"  n={n} Kane: not checked (KanesMethod {fmt_time(r['mk'])})")
        verdict, text = compare(r["al"].eval, r["ml"].eval)
        if verdict:
            line += f"; Lagrange vs LagrangesMethod: {verdict} ({text})"
        verdict, text = compare(r["al"].eval, r["ak"].eval)
        if verdict:
            line += f"; anadyn Lagrange vs anadyn Kane: {verdict}"
        print(line)

    print()
    get = lambda n, key: rows[n][key] if n in rows else None
    print(speedup_target("anadyn Kane >= 5x faster than KanesMethod at n = 8",
                         get(8, "ak"), get(8, "mk"), 5, args.cap))
    print(speedup_target("anadyn Lagrange >= 50x faster than LagrangesMethod at n = 6",
                         get(6, "al"), get(6, "ml"), 50, args.cap))
    al8 = get(8, "al")
    label = "anadyn Lagrange done within 10 s at n = 8"
    if al8 is None:
        print(f"{label}: n/a (size not run)")
    elif al8.status == "ok":
        print(f"{label}: {'PASS' if al8.time <= 10 else 'FAIL'} ({al8.time:.3f} s)")
    else:
        print(f"{label}: FAIL ({fmt_time(al8)})")
    print(f"\ntotal wall time {time.perf_counter() - started:.1f} s", flush=True)


if __name__ == "__main__":
    main()
