"""MATLAB / Octave export: one function file per function, NAME_*.m.

Vectors are columns (inputs may be rows or columns); the linear algebra is
MATLAB's own (M \\ G, pinv).  With symbolic parameters every function takes a
struct p last, defaulting to NAME_params() (the robot file's values).  With a
spherical joint (x = [q, u], ``ExportModel``) the speeds' arguments are u and du
and NAME_rates.m (dq = W(q) u) is added.
"""
from __future__ import annotations

from typing import Callable

import sympy as sp
from sympy.printing.octave import OctaveCodePrinter

from .model import (ExportModel, Named, block, inputs_used, leaf_note, local_names, quiet,
                    row_major, temporary_prefix, wrap)

MATLAB_KEYWORDS = {
    "break", "case", "catch", "classdef", "continue", "else", "elseif", "end", "for",
    "function", "global", "if", "otherwise", "parfor", "persistent", "return", "spmd",
    "switch", "try", "while", "do", "until", "unwind_protect", "unwind_protect_cleanup",
    "end_try_catch", "end_unwind_protect", "endfor", "endfunction", "endif", "endparfor",
    "endswitch", "endwhile", "endclassdef", "endmethods", "endproperties", "endevents",
    "endenumeration", "methods", "properties", "events", "enumeration", "__FILE__",
    "__LINE__"}
MATLAB_BUILTINS = {
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp",
    "log", "sqrt", "abs", "sign", "min", "max", "pi", "e", "i", "j", "I", "J", "eps", "Inf",
    "inf", "NaN", "nan", "NA", "zeros", "ones", "eye", "pinv", "size", "numel", "nargin",
    "nargout", "isempty", "true", "false", "ans", "heaviside", "double", "struct", "rcond",
    "power", "times", "mtimes", "rdivide", "plus", "minus", "mod", "rem", "floor", "ceil",
    "round", "fix", "real", "imag", "conj", "isfield", "error", "warning", "disp", "norm",
    "hypot", "sum", "prod", "length", "ndims", "reshape", "repmat", "cat", "horzcat",
    "vertcat", "transpose", "ctranspose", "rank", "chol", "lu", "qr", "svd", "det", "inv"}
ARGUMENTS = {"t", "q", "dq", "ddq", "p", "x", "dx", "M", "F", "B", "K", "J", "tau", "G", "r"}


class _Printer(Named, OctaveCodePrinter):
    def __init__(self, names: dict):
        super().__init__(names, {"inline": True})

    def _print_Float(self, expr):
        return repr(float(expr))


def _names(model: ExportModel) -> dict:
    reserved = MATLAB_KEYWORDS | MATLAB_BUILTINS | ARGUMENTS | {
        f"{model.name}_{s}" for s in ("mass_matrix", "forcing", "input_matrix", "efforts",
                                      "accelerations", "rhs", "jacobian", "inverse", "params",
                                      "partials", "rates", "rates_jacobian")}
    return local_names(model, reserved | set(model.arrays))


def _help(name: str, summary: str, lines: list[str]) -> list[str]:
    """MATLAB help text: H1 line, then the rest."""
    out = [f"%{name.upper()}  {summary}"]
    out += [("%   " + line).rstrip() for line in wrap(lines, 88)]
    return out


class _Files:
    """The files of one export: the model, its local names, ``P`` (the parameters'
    argument, or empty), the help text every file ends with (``common``)."""

    def __init__(self, model: ExportModel, note: Callable[[str], None]):
        self.model, self.note, self.N = model, note, model.name
        self.names = _names(model)
        self.prefix = temporary_prefix(set(self.names.values()), "w")
        self.P = ", p" if model.symbolic else ""
        self.common = [""] + [model.title(), "", *model.units_lines(1, "(", ")"), "",
                              *model.law_lines(), "", *model.parameter_lines()]
        if model.symbolic:
            self.common += ["", f"p: parameters struct, default {self.N}_params() (the robot "
                            "file's values)."]

    def default_p(self, count: int) -> list[str]:
        """p = NAME_params() when the function gets fewer than ``count`` arguments
        (count 0: a function without p)."""
        if not (self.model.symbolic and count):
            return []
        return [f"  if nargin < {count}", f"    p = {self.N}_params();", "  end"]

    def leaf(self, fname, outvar, args, summary, doc, matrix, nargs, symmetric=False):
        """One generated function: unpack the inputs it uses, temporaries, the output's
        nonzero entries (``symmetric``: the lower triangle, mirrored)."""
        self.note(leaf_note({outvar: matrix}))
        blk = block({"X": row_major(matrix)}, self.names, self.prefix)
        printer = _Printer(blk.names)
        lines = [f"function {outvar} = {self.N}_{fname}({args})",
                 *_help(f"{self.N}_{fname}", summary, doc + self.common)]
        lines += self.default_p(nargs)
        states, parameters = inputs_used(self.model, self.names, blk)
        lines += [f"  {local} = {array}({index + 1});" for local, array, index in states]
        lines += [f"  {local} = p.{local};" for local, _ in parameters]
        for temp, expr in blk.temporaries:
            lines.append(f"  {temp} = {printer.doprint(expr)};")
        rows, cols = matrix.shape
        lines.append(f"  {outvar} = zeros({rows}, {cols});")
        for i in range(rows):
            for j in range(cols):
                expr = blk.outputs["X"][i * cols + j]
                if symmetric and j > i:
                    continue
                if expr != 0:
                    lines.append(f"  {outvar}({i + 1}, {j + 1}) = {printer.doprint(expr)};")
        if symmetric:
            lines += [f"  {outvar}({i + 1}, {j + 1}) = {outvar}({j + 1}, {i + 1});"
                      for i in range(rows) for j in range(i + 1, cols)
                      if blk.outputs["X"][j * cols + i] != 0]
        lines.append("end")
        return lines


def files(model: ExportModel, note: Callable[[str], None] = quiet) -> dict[str, str]:
    """One file per function, NAME_*.m; ``note`` hears which one is being generated."""
    f = _Files(model, note)
    out, partials = _equations(f)
    out.update(_dynamics(f, partials))
    out[f"{f.N}_inverse.m"] = _inverse(f)
    if model.symbolic:
        fields = [f"  p.{f.names[par.symbol]} = {par.value!r};  % {par.kind} {par.name}"
                  for par in model.parameters]
        out[f"{f.N}_params.m"] = [
            f"function p = {f.N}_params()",
            *_help(f"{f.N}_params", "Parameters and gains of the robot file, as a struct.",
                   ["p = " + f"{f.N.upper()}_PARAMS()"] + f.common),
            "  p = struct();", *fields, "end"]
    return {k: "\n".join(v) + "\n" for k, v in out.items()}


def _equations(f: _Files) -> tuple[dict[str, list[str]], list[str]]:
    """The files of M, F, B, the control laws (and the rates), and the lines of the
    partials K (and R) that NAME_jacobian.m carries as local functions."""
    model, N, P, leaf = f.model, f.N, f.P, f.leaf
    n, (_, dq, _) = model.n, model.arrays
    out: dict[str, list[str]] = {}
    lower = sp.Matrix(n, n, lambda i, j: model.M[i, j] if j <= i else 0)
    out[f"{N}_mass_matrix.m"] = leaf(
        "mass_matrix", "M", f"q{P}", "Mass matrix M(q), n x n, symmetric positive definite.",
        [f"M = {N.upper()}_MASS_MATRIX(q{P})"], lower, 2, symmetric=True)
    out[f"{N}_forcing.m"] = leaf(
        "forcing", "F", f"t, q, {dq}{P}",
        f"Forcing F(t, q, {dq}): gravity, velocity products, joint forces and loads (n x 1).",
        [f"F = {N.upper()}_FORCING(t, q, {dq}{P})"], model.F, 4)
    out[f"{N}_input_matrix.m"] = leaf(
        "input_matrix", "B", f"q{P}", "Input matrix B(q), n x m (B tau: generalized forces).",
        [f"B = {N.upper()}_INPUT_MATRIX(q{P})"], model.B, 2)
    out[f"{N}_efforts.m"] = leaf(
        "efforts", "tau", f"t, q, {dq}{P}",
        "Actuator efforts under the robot file's control laws (m x 1; zeros without).",
        [f"tau = {N.upper()}_EFFORTS(t, q, {dq}{P})"], model.laws, 4)
    if model.kinematic is None:
        partials = leaf("partials", "K", f"t, q, dq, ddq{P}",
                        "K = [dG/dq - (dM/dq) ddq, dG/d(dq)], G = F + B tau(t, q, dq), n x 2n.",
                        [], model.K, 5)
    else:
        partials = leaf("partials", "K", f"t, q, u, du{P}",
                        "K = [dG/dq - (dM/dq) du, dG/du], G = F + B tau(t, q, u), "
                        "n x (nq + n).", [], model.K, 5)
        partials += ["", *leaf("rates_jacobian", "J", "q, u",
                               "R = d(W(q) u)/dx, nq x (nq + n).", [], model.R, 0)]
        out[f"{N}_rates.m"] = leaf(
            "rates", "dq", "q, u",
            "Coordinates' rates dq = W(q) u (nq x 1; a quaternion's: 1/2 q (x) (0, w)).",
            [f"dq = {N.upper()}_RATES(q, u), the kinematic differential equations."],
            model.kinematic, 0)
    return out, [line for line in partials if not line.startswith("%")]


def _dynamics(f: _Files, partials: list[str]) -> dict[str, list[str]]:
    """NAME_accelerations.m, NAME_rhs.m and NAME_jacobian.m (with the ``partials``)."""
    model, N, P, common = f.model, f.N, f.P, f.common
    n, nq, (_, dq, ddq) = model.n, model.nq, model.arrays
    out = {f"{N}_accelerations.m": [
        f"function {ddq} = {N}_accelerations(t, q, {dq}, tau{P})",
        *_help(f"{N}_accelerations",
               f"Accelerations solving M(q) {ddq} = F(t, q, {dq}) + B(q) tau (open loop).",
               [f"{ddq} = {N.upper()}_ACCELERATIONS(t, q, {dq}, tau{P}), tau: m efforts."]
               + common),
        *f.default_p(5),
        f"  {ddq} = {N}_mass_matrix(q{P}) \\ ({N}_forcing(t, q, {dq}{P}) + "
        f"{N}_input_matrix(q{P}) * tau(:));",
        "end"]}
    if model.kinematic is None:
        rhs_doc = ("State derivative dx/dt = [dq; ddq] under the control laws.",
                   f"dx = {N.upper()}_RHS(t, x{P}), x = [q; dq] (2n x 1); suits ode45 and "
                   "ode15s (with the Jacobian " + f"{N}_jacobian).")
        jacobian_doc = ("Analytic Jacobian d(dx/dt)/dx (2n x 2n) under the control laws.",
                        f"J = {N.upper()}_JACOBIAN(t, x{P}) = [0, I; M^-1 K], K = [dG/dq - "
                        "(dM/dq) ddq, dG/d(dq)], G = F + B tau(t, q, dq).")
        rates, rate_rows = "dq", f"zeros({n}), eye({n})"
    else:
        rhs_doc = ("State derivative dx/dt = [W(q) u; du] under the control laws.",
                   f"dx = {N.upper()}_RHS(t, x{P}), x = [q; u] ({nq + n} x 1); suits ode45 "
                   "and ode15s (with the Jacobian " + f"{N}_jacobian).")
        jacobian_doc = (f"Analytic Jacobian d(dx/dt)/dx ({nq + n} x {nq + n}) under the control "
                        "laws.", f"J = {N.upper()}_JACOBIAN(t, x{P}) = [R; M^-1 K], R = "
                        "d(W(q) u)/dx, K = [dG/dq - (dM/dq) du, dG/du], G = F + B tau(t, q, u).")
        rates, rate_rows = f"{N}_rates(q, u)", f"{N}_rates_jacobian(q, u)"
    unpack = ["  x = x(:);", f"  q = x(1:{nq});", f"  {dq} = x({nq + 1}:{nq + n});"]
    out[f"{N}_rhs.m"] = [
        f"function dx = {N}_rhs(t, x{P})",
        *_help(f"{N}_rhs", rhs_doc[0], [rhs_doc[1]] + common),
        *f.default_p(3),
        *unpack,
        f"  dx = [{rates}; {N}_accelerations(t, q, {dq}, {N}_efforts(t, q, {dq}{P}){P})];",
        "end"]
    out[f"{N}_jacobian.m"] = [
        f"function J = {N}_jacobian(t, x{P})",
        *_help(f"{N}_jacobian", jacobian_doc[0], [jacobian_doc[1]] + common),
        *f.default_p(3),
        *unpack,
        f"  {ddq} = {N}_accelerations(t, q, {dq}, {N}_efforts(t, q, {dq}{P}){P});",
        f"  J = [{rate_rows}; {N}_mass_matrix(q{P}) \\ "
        f"{N}_partials(t, q, {dq}, {ddq}{P})];",
        "end", "", *partials]
    return out


def _inverse(f: _Files) -> list[str]:
    """NAME_inverse.m: B \\ r when B is square, else pinv(B) r."""
    model, N, P = f.model, f.N, f.P
    n, m, (_, dq, ddq) = model.n, model.m, model.arrays
    solve = ("B \\ r" if n == m else "pinv(B) * r")
    how = (f"tau = B \\ (M {ddq} - F) (B is square)." if n == m else
           f"tau = pinv(B) (M {ddq} - F): " + (
               "least squares, exact only if the motion is feasible." if m < n else
               f"the smallest efforts that give {ddq}."))
    return [
        f"function tau = {N}_inverse(t, q, {dq}, {ddq}{P})",
        *_help(f"{N}_inverse", f"Inverse dynamics: the efforts that give accelerations {ddq}.",
               [f"tau = {N.upper()}_INVERSE(t, q, {dq}, {ddq}{P}); " + how] + f.common),
        *f.default_p(5),
        f"  B = {N}_input_matrix(q{P});",
        f"  r = {N}_mass_matrix(q{P}) * {ddq}(:) - {N}_forcing(t, q, {dq}{P});",
        f"  tau = {solve};" if m else "  tau = zeros(0, 1);",
        "end"]
