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
from typing import Callable

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from .model import (ExportModel, Named, block, inputs_used, leaf_note, local_names, quiet,
                    row_major, temporary_prefix)
from .templates import template

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
    lines = _constants(model)
    for name, args, doc, key, matrix, shape in _leaves(model):
        note(leaf_note({key: matrix}))
        extra = p if name not in ("rates", "_rates_jacobian") else ""
        lines += _leaf(model, names, prefix, name, f"{args}{extra}", doc, {key: matrix},
                       {key: shape}) + ["", ""]
    fields = {"p": p, "pp": ", p" if model.symbolic else "", "n": n, "n2": 2 * n, "m": m,
              "nq": nq, "nx": nq + n, "dq": dq, "ddq": ddq}
    dynamics = template("dynamics.py.in" if model.kinematic is None else
                        "dynamics_spherical.py.in", **fields)[:-1]   # the file's last newline
    return "\n".join(lines + template("solve.py.in", dynamics=dynamics, **fields))


def _constants(model: ExportModel) -> list[str]:
    """The module's docstring, import and constants (names, units, sizes, x(0) and the
    parameters' values)."""
    _, dq, _ = model.arrays
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
             f"N_COORDINATES = {model.nq}",
             *([f"N_SPEEDS = {model.n}"] if model.kinematic is not None else []),
             f"N_EFFORTS = {model.m}",
             f"INITIAL_STATE = {model.initial_state!r}     # x(0) = [q, {dq}] of the robot file"]
    if model.symbolic:
        lines.append("PARAMETERS = {" + ", ".join(f"{q.name!r}: {q.value!r}"
                                                  for q in model.parameters) + "}")
    return lines + ["", ""]


def _leaves(model: ExportModel) -> list[tuple]:
    """The generated functions: (name, arguments, docstring, output, its matrix, its
    shape: vector or matrix)."""
    _, dq, _ = model.arrays
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
        return leaves + [("_partials", "t, q, dq, ddq", "K = [dG/dq - (dM/dq) ddq | dG/d(dq)], "
                          "G = F + B tau(t, q, dq): n x 2n.", "K", model.K, "matrix")]
    return leaves + [
        ("_partials", "t, q, u, du", "K = [dG/dq - (dM/dq) du | dG/du], G = F + B "
         "tau(t, q, u): n x (nq + n).", "K", model.K, "matrix"),
        ("rates", "q, u", "dq = W(q) u: the coordinates' rates (nq; a quaternion's: "
         "1/2 q (x) (0, w)).", "dq", model.kinematic, "vector"),
        ("_rates_jacobian", "q, u", "R = d(W(q) u)/dx: nq x (nq + n), the coordinates' "
         "rows of the state Jacobian.", "R", model.R, "matrix")]
