"""Python export: one module NAME.py that needs only the standard library.

Inputs are any sequences of floats (lists, tuples, NumPy arrays); results are
lists (matrices as lists of rows), so ``numpy.array(...)`` turns them into
arrays when NumPy is at hand.  The equations' functions are generated with
common subexpressions eliminated, on ``math``; the linear algebra is a
Cholesky factorization of M and a one-sided Jacobi SVD for B's pseudo-inverse,
in plain Python.  With a spherical joint (x = [q, u], ``ExportModel``) the speeds'
arguments are ``u`` and ``du`` and ``rates(q, u)`` (dq = W(q) u) is added.
"""
from __future__ import annotations

import builtins
import keyword
import textwrap
from typing import Callable

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from .model import (ExportModel, Named, block, inputs_used, leaf_note, local_names, quiet,
                    row_major, temporary_prefix)

#: arguments and module-level names the generated functions use
ARGUMENTS = {"t", "q", "dq", "ddq", "p", "x", "tau", "math", "PARAMETERS"}
RESERVED = set(keyword.kwlist) | set(dir(builtins)) | ARGUMENTS


class _Printer(Named, PythonCodePrinter):
    """math.* functions; floats as the shortest repr that reads back exactly."""

    def __init__(self, names: dict):
        super().__init__(names, {"fully_qualified_modules": True})

    def _print_Float(self, expr):
        return repr(float(expr))


def files(model: ExportModel, note: Callable[[str], None] = quiet) -> dict[str, str]:
    """{"NAME.py": ...}; ``note`` hears which function is being generated."""
    return {f"{model.name}.py": source(model, note)}


def _doc(model: ExportModel) -> str:
    n, m = model.n, model.m
    _, dq, ddq = model.arrays
    names = [c.name for c in model.coordinates] + [u.name for u in model.rates]
    if model.kinematic is None:
        lines = [f"{model.name}.py -- {model.title()}", "",
                 "    M(q) ddq = F(t, q, dq) + B(q) tau,   state x = [q, dq] = "
                 f"[{', '.join(names)}]", "",
                 f"n = {n} coordinates, m = {m} actuator efforts.  Needs only the standard "
                 "library (math)."]
    else:
        lines = [f"{model.name}.py -- {model.title()}", "",
                 "    M(q) du = F(t, q, u) + B(q) tau,   dq = W(q) u,", "",
                 f"    state x = [q, u] = [{', '.join(names)}]", "",
                 f"nq = {model.nq} coordinates, n = {n} speeds, m = {m} actuator efforts.  "
                 "Needs only the", "standard library (math)."]
    lines += ["Arguments are sequences of floats (lists, tuples or NumPy arrays); "
              "results are lists,", "matrices as lists of rows.", "",
              *model.units_lines(), "", *model.law_lines(), "", *model.parameter_lines(), ""]
    if model.symbolic:
        lines += ["Every function takes the parameters last, p: a mapping name -> value "
                  "(default", "PARAMETERS, the robot file's values).", ""]
    p = ", p" if model.symbolic else ""
    lines += ["Functions:",
              f"    mass_matrix(q{p})                 M, n x n, symmetric positive definite",
              f"    forcing(t, q, {dq}{p})              F, n: gravity, velocity products, joint "
              "forces, loads",
              f"    input_matrix(q{p})                B, n x m",
              f"    efforts(t, q, {dq}{p})              tau under the file's control laws (zeros "
              "without)"]
    if model.kinematic is None:
        lines += [
            f"    accelerations(t, q, dq, tau{p})   ddq solving M ddq = F + B tau (open loop)",
            f"    rhs(t, x{p})                      dx/dt = [dq, ddq] under the control laws",
            f"    jacobian(t, x{p})                 d(dx/dt)/dx, 2n x 2n, analytic"]
    else:
        lines += [
            "    rates(q, u)                      dq = W(q) u, nq: the kinematic differential "
            "equations",
            f"    accelerations(t, q, u, tau{p})    du solving M du = F + B tau (open loop)",
            f"    rhs(t, x{p})                      dx/dt = [W(q) u, du] under the control laws",
            f"    jacobian(t, x{p})                 d(dx/dt)/dx, (nq + n) x (nq + n), analytic"]
    lines += [f"    inverse(t, q, {dq}, {ddq}{p})         tau = pinv(B) (M {ddq} - F): the "
              f"efforts for {ddq}",
              "ValueError when M is not positive definite.  rhs(t, x) suits "
              "scipy.integrate.solve_ivp."]
    if m and m < n:
        lines.append("B is not square (m < n): inverse() gives the least-squares efforts, "
                     "exact only if the motion is feasible.")
    elif m > n:
        lines.append("B is not square (m > n): inverse() gives the smallest efforts that "
                     f"produce {ddq}.")
    return "\n".join(lines)


def _leaf(model: ExportModel, names: dict, prefix: str, name: str, args: str, doc: str,
          outputs: dict[str, sp.Matrix], shapes: dict[str, str]) -> list[str]:
    blk = block({k: row_major(v) for k, v in outputs.items()}, names, prefix)
    printer = _Printer(blk.names)
    lines = [f"def {name}({args}):", f'    """{doc}"""']
    states, parameters = inputs_used(model, names, blk)
    lines += [f"    {local} = {array}[{index}]" for local, array, index in states]
    lines += [f"    {local} = p[{par.name!r}]" for local, par in parameters]
    for temp, expr in blk.temporaries:
        lines.append(f"    {temp} = {printer.doprint(expr)}")
    returned = []
    for key, exprs in blk.outputs.items():
        rows, cols = outputs[key].shape
        text = [repr(float(e)) if e.is_Number else printer.doprint(e) for e in exprs]
        if shapes[key] == "vector":
            returned.append("[" + ", ".join(text) + "]")
        else:
            returned.append("[" + ", ".join("[" + ", ".join(text[i * cols:(i + 1) * cols]) + "]"
                                            for i in range(rows)) + "]")
    lines.append(f"    return {', '.join(returned)}")
    return lines


def source(model: ExportModel, note: Callable[[str], None] = quiet) -> str:
    n, m, nq = model.n, model.m, model.nq
    _, dq, ddq = model.arrays
    names = local_names(model, RESERVED | set(model.arrays))
    prefix = temporary_prefix(set(names.values()), "_w")
    p = ", p=PARAMETERS" if model.symbolic else ""
    pp = ", p" if model.symbolic else ""
    doc = _doc(model).replace("\\", "\\\\").replace('"""', '\\"\\"\\"')
    lines = ['"""' + doc + '\n"""', "import math", "",
             f"NAME = {model.robot_name!r}",
             f"COORDINATES = {tuple(c.name for c in model.coordinates)!r}",
             f"UNITS = {tuple(c.unit for c in model.coordinates)!r}",
             f"EFFORTS = {tuple(e.name for e in model.efforts)!r}",
             f"EFFORT_UNITS = {tuple(e.unit for e in model.efforts)!r}",
             *([f"SPEEDS = {tuple(u.name for u in model.rates)!r}",
                f"SPEED_UNITS = {tuple(u.unit for u in model.rates)!r}"]
               if model.kinematic is not None else []),
             f"N_COORDINATES = {nq}",
             *([f"N_SPEEDS = {n}"] if model.kinematic is not None else []),
             f"N_EFFORTS = {m}",
             f"INITIAL_STATE = {model.initial_state!r}     # x(0) = [q, {dq}] of the robot file"]
    if model.symbolic:
        lines.append("PARAMETERS = {" + ", ".join(f"{q.name!r}: {q.value!r}"
                                                  for q in model.parameters) + "}")
    lines += ["", ""]
    leaves = [
        ("mass_matrix", "q", "M(q): mass matrix, n x n (list of rows), symmetric positive "
         "definite.", "M", model.M, "matrix"),
        ("forcing", f"t, q, {dq}", f"F(t, q, {dq}): gravity, velocity products, joint forces "
         "and loads (n).", "F", model.F, "vector"),
        ("input_matrix", "q", "B(q): input matrix, n x m (list of rows).", "B", model.B,
         "matrix"),
        ("efforts", f"t, q, {dq}", f"tau(t, q, {dq}): actuator efforts under the robot file's "
         "control laws (m).", "tau", model.laws, "vector")]
    if model.kinematic is None:
        leaves.append(("_partials", "t, q, dq, ddq", "K = [dG/dq - (dM/dq) ddq | dG/d(dq)], "
                       "G = F + B tau(t, q, dq): n x 2n.", "K", model.K, "matrix"))
    else:
        leaves += [
            ("_partials", "t, q, u, du", "K = [dG/dq - (dM/dq) du | dG/du], G = F + B "
             "tau(t, q, u): n x (nq + n).", "K", model.K, "matrix"),
            ("rates", "q, u", "dq = W(q) u: the coordinates' rates (nq; a quaternion's: "
             "1/2 q (x) (0, w)).", "dq", model.kinematic, "vector"),
            ("_rates_jacobian", "q, u", "R = d(W(q) u)/dx: nq x (nq + n), the coordinates' "
             "rows of the state Jacobian.", "R", model.R, "matrix")]
    for name, args, doc, key, matrix, shape in leaves:
        note(leaf_note({key: matrix}))
        extra = p if name not in ("rates", "_rates_jacobian") else ""
        lines += _leaf(model, names, prefix, name, f"{args}{extra}", doc, {key: matrix},
                       {key: shape}) + ["", ""]
    if model.kinematic is None:
        lines += textwrap.dedent(f'''\
            def accelerations(t, q, dq, tau{p}):
                """ddq solving M(q) ddq = F(t, q, dq) + B(q) tau for the given efforts tau."""
                return _solve(t, q, dq, tau{pp})[0]


            def rhs(t, x{p}):
                """dx/dt = [dq, ddq] at x = [q, dq] under the control laws."""
                q, dq = x[:{n}], x[{n}:{2 * n}]
                return [float(v) for v in dq] + _solve(t, q, dq, efforts(t, q, dq{pp}){pp})[0]


            def jacobian(t, x{p}):
                """d(dx/dt)/dx at x = [q, dq] under the control laws: [[0, I], [M^-1 K]], 2n x 2n."""
                q, dq = x[:{n}], x[{n}:{2 * n}]
                ddq, L = _solve(t, q, dq, efforts(t, q, dq{pp}){pp})
                K = _partials(t, q, dq, ddq{pp})
                columns = [_cholesky_solve(L, [row[j] for row in K]) for j in range({2 * n})]
                top = [[1.0 if j == {n} + i else 0.0 for j in range({2 * n})] for i in range({n})]
                return top + [[columns[j][i] for j in range({2 * n})] for i in range({n})]
            ''').splitlines()
    else:
        lines += textwrap.dedent(f'''\
            def accelerations(t, q, u, tau{p}):
                """du solving M(q) du = F(t, q, u) + B(q) tau for the given efforts tau."""
                return _solve(t, q, u, tau{pp})[0]


            def rhs(t, x{p}):
                """dx/dt = [W(q) u, du] at x = [q, u] under the control laws."""
                q, u = x[:{nq}], x[{nq}:{nq + n}]
                return rates(q, u) + _solve(t, q, u, efforts(t, q, u{pp}){pp})[0]


            def jacobian(t, x{p}):
                """d(dx/dt)/dx at x = [q, u] under the control laws: [[R], [M^-1 K]],
                R = d(W(q) u)/dx, {nq + n} x {nq + n}."""
                q, u = x[:{nq}], x[{nq}:{nq + n}]
                du, L = _solve(t, q, u, efforts(t, q, u{pp}){pp})
                K = _partials(t, q, u, du{pp})
                columns = [_cholesky_solve(L, [row[j] for row in K]) for j in range({nq + n})]
                return _rates_jacobian(q, u) + [[columns[j][i] for j in range({nq + n})]
                                                for i in range({n})]
            ''').splitlines()
    lines += ["", ""] + textwrap.dedent(f'''\
        def inverse(t, q, {dq}, {ddq}{p}):
            """Efforts tau = pinv(B) (M {ddq} - F) that give accelerations {ddq} at (t, q, {dq})."""
            M = mass_matrix(q{pp})
            F = forcing(t, q, {dq}{pp})
            r = [sum(M[i][j] * {ddq}[j] for j in range({n})) - F[i] for i in range({n})]
            return _pseudo_solve(input_matrix(q{pp}), r)


        def _solve(t, q, dq, tau{p}):
            """ddq and the Cholesky factor L of M (M ddq = F + B tau)."""
            G = forcing(t, q, dq{pp})
            B = input_matrix(q{pp})
            G = [G[i] + sum(B[i][k] * tau[k] for k in range({m})) for i in range({n})]
            L = _cholesky(mass_matrix(q{pp}))
            return _cholesky_solve(L, G), L


        def _cholesky(A):
            """Lower L with A = L L^T; ValueError unless A is positive definite."""
            n = len(A)
            L = [[0.0] * n for _ in range(n)]
            for j in range(n):
                d = A[j][j] - sum(L[j][k] ** 2 for k in range(j))
                if not d > 0.0:
                    raise ValueError(f"mass matrix not positive definite (pivot {{j}})")
                L[j][j] = math.sqrt(d)
                for i in range(j + 1, n):
                    L[i][j] = (A[i][j] - sum(L[i][k] * L[j][k] for k in range(j))) / L[j][j]
            return L


        def _cholesky_solve(L, b):
            """(L L^T)^-1 b."""
            n = len(L)
            y = [0.0] * n
            for i in range(n):
                y[i] = (b[i] - sum(L[i][k] * y[k] for k in range(i))) / L[i][i]
            for i in reversed(range(n)):
                y[i] = (y[i] - sum(L[k][i] * y[k] for k in range(i + 1, n))) / L[i][i]
            return y


        def _pseudo_solve(B, r):
            """pinv(B) r by a one-sided Jacobi SVD (Hestenes) of B or B^T; singular values
            below max(n, m) eps sigma_max count as zero (MATLAB's pinv tolerance)."""
            n, m = len(B), (len(B[0]) if B else 0)
            if m == 0:
                return []
            wide = m > n
            rows, cols = (m, n) if wide else (n, m)
            U = [[B[j][i] if wide else B[i][j] for j in range(cols)] for i in range(rows)]
            V = [[1.0 if i == j else 0.0 for j in range(cols)] for i in range(cols)]
            eps = 2.220446049250313e-16
            for _ in range(60):
                rotated = False
                for j in range(cols - 1):
                    for k in range(j + 1, cols):
                        alpha = sum(U[i][j] ** 2 for i in range(rows))
                        beta = sum(U[i][k] ** 2 for i in range(rows))
                        gamma = sum(U[i][j] * U[i][k] for i in range(rows))
                        if not abs(gamma) > eps * math.sqrt(alpha * beta):
                            continue
                        rotated = True
                        zeta = (beta - alpha) / (2.0 * gamma)
                        tn = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + math.hypot(1.0, zeta))
                        c = 1.0 / math.hypot(1.0, tn)
                        s = c * tn
                        for W in (U, V):
                            for row in W:
                                a, b = row[j], row[k]
                                row[j], row[k] = c * a - s * b, s * a + c * b
                if not rotated:
                    break
            sigma = [math.sqrt(sum(U[i][j] ** 2 for i in range(rows))) for j in range(cols)]
            tol = max(n, m) * eps * max(sigma)
            for j in range(cols):
                if sigma[j] > tol:
                    for row in U:
                        row[j] /= sigma[j]
            left, right = (V, U) if wide else (U, V)     # pinv(B) = right S^+ left^T
            y = [sum(left[i][j] * r[i] for i in range(len(left))) / sigma[j]
                 if sigma[j] > tol else 0.0 for j in range(cols)]
            return [sum(right[i][j] * y[j] for j in range(cols)) for i in range(len(right))]
        ''').splitlines()
    lines += ["", "", 'if __name__ == "__main__":',
              "    x = INITIAL_STATE",
              '    print("robot", NAME, "at x =", x)',
              f"    print(\"M =\", mass_matrix(x[:{nq}]))",
              "    print(\"dx/dt =\", rhs(0.0, x))", ""]
    return "\n".join(lines)
