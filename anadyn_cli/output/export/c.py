"""C99 export: NAME.h and NAME.c, no allocation, no dependency but <math.h>.

Compiles cleanly with ``gcc -std=c99 -Wall -Wextra -Werror -pedantic``.
Matrices are row-major arrays the caller provides; the equations' leaf
functions (mass matrix, forcing, input matrix, control laws, partials) are
generated with common subexpressions eliminated; the linear algebra (an
in-place Cholesky factorization of M over its factor's structural nonzeros, the
text of anadyn's derivatives, and a Jacobi SVD for B's pseudo-inverse) is
fixed-size loops over local arrays.  With a spherical joint
(x = [q, u], ``ExportModel``) the speeds' arguments are ``u`` and ``du``,
``NAME_N_SPEEDS`` sizes them, and ``NAME_rates`` (dq = W(q) u) is added.
"""
from __future__ import annotations

from typing import Callable

import sympy as sp
from sympy.printing.c import C99CodePrinter

from .model import (Block, ExportModel, Named, block, inputs_used, leaf_note, local_names, quiet,
                    row_major, temporary_prefix)
from .templates import template

C_KEYWORDS = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef",
    "union", "unsigned", "void", "volatile", "while", "_Bool", "_Complex", "_Imaginary",
    "bool", "complex", "true", "false", "NULL", "NAN", "INFINITY", "HUGE_VAL", "errno",
    "main", "asm", "fortran", "entry"}
C_MATH = {
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh",
    "acosh", "atanh", "exp", "exp2", "expm1", "log", "log2", "log10", "log1p", "sqrt", "cbrt",
    "pow", "fabs", "fmin", "fmax", "floor", "ceil", "round", "trunc", "fmod", "hypot", "erf",
    "erfc", "tgamma", "lgamma", "copysign", "signbit", "isnan", "isinf", "isfinite"}
#: arguments of the generated leaf functions
ARGUMENTS = {"t", "q", "dq", "ddq", "p", "M", "F", "B", "K", "tau", "J"}


class _Printer(Named, C99CodePrinter):
    """C99 without the non-standard M_PI macros: constants as exact double literals."""

    def __init__(self, names: dict):
        super().__init__(names, {"math_macros": {}})

    def _print_NumberSymbol(self, expr):
        return repr(float(expr))

    _print_Pi = _print_NumberSymbol
    _print_Exp1 = _print_NumberSymbol


def _names(model: ExportModel) -> dict:
    """Local variable (and params member) names of the robot's symbols."""
    return local_names(model, C_KEYWORDS | C_MATH | ARGUMENTS | set(model.arrays))


def files(model: ExportModel, note: Callable[[str], None] = quiet) -> dict[str, str]:
    """{"NAME.h": ..., "NAME.c": ...}; ``note`` hears which function is being generated."""
    return {f"{model.name}.h": header(model), f"{model.name}.c": source(model, note)}


def _params(model: ExportModel, pointer: bool = True) -> str:
    return f", const {model.name}_params *p" if model.symbolic and pointer else (
        ", p" if model.symbolic else "")


def _comment(lines: list[str]) -> str:
    """A C block comment of ``lines`` (user text already made ``printable``): a ``*/``
    or ``/*`` inside becomes ``* /`` or ``/ *`` (so a path such as ``a/*/b`` neither
    ends the comment nor trips -Wcomment), and ``??`` becomes ``? ?`` (no trigraph)."""
    body = "\n".join((" * " + line).rstrip() for line in lines)
    while "*/" in body or "/*" in body or "??" in body:
        body = body.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
    return "/*\n" + body + "\n */"


def header(model: ExportModel) -> str:
    N, P = model.name, _params(model)
    n, m = model.n, model.m
    up = N.upper()
    _, u, _ = model.arrays
    x_names = ", ".join([c.name for c in model.coordinates] + [s.name for s in model.rates])
    if model.kinematic is None:
        doc = [f"{N}.h -- {model.title()}", "",
               "    M(q) ddq = F(t, q, dq) + B(q) tau,   state x = [q, dq] = [" + x_names + "]",
               "", f"n = {n} coordinates, m = {m} actuator efforts.  Every matrix is a "
               "row-major array"]
    else:
        doc = [f"{N}.h -- {model.title()}", "",
               "    M(q) du = F(t, q, u) + B(q) tau,   dq = W(q) u,", "",
               "    state x = [q, u] = [" + x_names + "]", "",
               f"nq = {model.nq} coordinates, n = {n} speeds, m = {m} actuator efforts.  Every "
               "matrix is a row-major array"]
    doc += ["that the caller provides (n x n: M[i*n + j]); nothing is allocated.  Output arrays",
            "must not overlap the inputs.", "", *model.units_lines(), "", *model.law_lines(), "",
            *model.parameter_lines(), ""]
    if model.symbolic:
        doc += [f"Every function takes the parameters last, as `const {N}_params *p` (as GSL's",
                f"ODE functions do); NULL means {N}_default_params, the robot file's values.", ""]
    p0 = ", NULL" if model.symbolic else ""
    doc += ["C99, needs only <math.h> (link with -lm).  For example, one explicit Euler step:",
            "",
            f"    double x[{up}_N_STATES] = {up}_INITIAL_STATE, dx[{up}_N_STATES];",
            f"    {N}_rhs(0.0, x, dx{p0});",
            f"    for (int i = 0; i < {up}_N_STATES; ++i) x[i] += 1e-3 * dx[i];"]
    lines = [_comment(doc), f"#ifndef {up}_H", f"#define {up}_H", "",
             f"#define {up}_N_COORDINATES {model.nq}",
             *([f"#define {up}_N_SPEEDS {n}"] if model.kinematic is not None else []),
             f"#define {up}_N_EFFORTS {m}",
             f"#define {up}_N_STATES {model.nq + n}",
             f"/* x(0) = [q, {u}] of the robot file, as an initializer */",
             f"#define {up}_INITIAL_STATE {{"
             + ", ".join(repr(v) for v in model.initial_state) + "}", ""]
    if model.symbolic:
        lines.append(f"/* parameters and gains; {N}_default_params holds the robot file's "
                     "values */")
        lines.append("typedef struct {")
        names = _names(model)
        for p in model.parameters:
            lines.append(f"    double {names[p.symbol]};  /* {p.kind} {p.name}, file value "
                         f"{p.value!r} */")
        if not model.parameters:
            lines.append("    double unused;  /* no parameter appears in the equations */")
        lines += [f"}} {N}_params;", "", f"extern const {N}_params {N}_default_params;", ""]
    lines += ['#ifdef __cplusplus', 'extern "C" {', '#endif', ""]
    for doc_lines, signature in _declarations(model, P):
        lines.append(_comment(doc_lines).replace("/*\n * ", "/* ", 1))
        lines.append(signature + ";")
        lines.append("")
    lines += ["#ifdef __cplusplus", "}", "#endif", "", f"#endif /* {up}_H */", ""]
    return "\n".join(lines)


def _declarations(model: ExportModel, P: str) -> list[tuple[list[str], str]]:
    N, n, m = model.name, model.n, model.m
    _, dq, ddq = model.arrays
    lsq = (f"B is square: tau = B^-1 (M {ddq} - F) (B's pseudo-inverse, so NaN-free even "
           "if B is singular)." if n == m else
           f"B is {n} x {m}: tau = pinv(B) (M {ddq} - F), the least-squares efforts (exact only "
           "if the motion is feasible; check with _accelerations)" if m < n else
           f"B is {n} x {m}: tau = pinv(B) (M {ddq} - F), the smallest efforts that produce "
           f"{ddq}.")
    if model.kinematic is None:
        rates = []
        state = ["dx/dt = [dq, ddq] at x = [q, dq] (2n values) under the control laws; NaN if M is",
                 "not positive definite.  Fits gsl_odeiv2_system's function once wrapped."]
        jacobian = ["J = d(dx/dt)/dx, 2n x 2n row-major, analytic, under the control laws:",
                    "[[0, I], [M^-1 K]] with K = [dG/dq - (dM/dq) ddq | dG/d(dq)], "
                    "G = F + B tau(t, q, dq)."]
    else:
        nx = model.nq + n
        rates = [([f"dq = W(q) u: the {model.nq} coordinates' rates (the kinematic differential "
                   "equations;", "a quaternion's: 1/2 q (x) (0, w))."],
                  f"void {N}_rates(const double *q, const double *u, double *dq)")]
        state = [f"dx/dt = [W(q) u, du] at x = [q, u] ({nx} values) under the control laws; "
                 "NaN in du if M", "is not positive definite.  Fits gsl_odeiv2_system's "
                 "function once wrapped."]
        jacobian = [f"J = d(dx/dt)/dx, {nx} x {nx} row-major, analytic, under the control laws:",
                    "[[R], [M^-1 K]] with R = d(W(q) u)/dx, K = [dG/dq - (dM/dq) du | dG/du], "
                    "G = F + B tau(t, q, u)."]
    return [
        ([f"M(q): mass matrix, n x n = {n} x {n}, row-major, symmetric positive definite."],
         f"void {N}_mass_matrix(const double *q, double *M{P})"),
        ([f"F(t, q, {dq}): n forcing terms: gravity, velocity products, and any joint forces",
          "and loads of the robot file (everything but the actuators)."],
         f"void {N}_forcing(double t, const double *q, const double *{dq}, double *F{P})"),
        ([f"B(q): input matrix, n x m = {n} x {m}, row-major; B tau are the generalized",
          "forces of the actuator efforts." + (" (m = 0: writes nothing.)" if m == 0 else "")],
         f"void {N}_input_matrix(const double *q, double *B{P})"),
        ([f"tau(t, q, {dq}): the m actuator efforts under the robot file's control laws",
          "(zeros without a controller)."],
         f"void {N}_efforts(double t, const double *q, const double *{dq}, double *tau{P})"),
        *rates,
        ([f"{ddq} solving M(q) {ddq} = F(t, q, {dq}) + B(q) tau for given efforts tau (open "
          "loop).", f"Returns 0, or -1 ({ddq} all NaN) if M is not positive definite."],
         f"int {N}_accelerations(double t, const double *q, const double *{dq}, "
         f"const double *tau, double *{ddq}{P})"),
        (state, f"void {N}_rhs(double t, const double *x, double *dx{P})"),
        (jacobian, f"void {N}_jacobian(double t, const double *x, double *J{P})"),
        ([f"Inverse dynamics: the m efforts that give accelerations {ddq} at (t, q, {dq}).",
          lsq],
         f"void {N}_inverse(double t, const double *q, const double *{dq}, "
         f"const double *{ddq}, double *tau{P})"),
    ]


def _leaf(model: ExportModel, names: dict, prefix: str, signature: str,
          outputs: dict[str, sp.Matrix], arrays: list[str], symmetric: str | None = None,
          note: Callable[[str], None] = quiet) -> list[str]:
    """One generated function: unpack the inputs it uses, temporaries, outputs."""
    note(leaf_note(outputs))
    blk: Block = block({k: row_major(v) for k, v in outputs.items()}, names, prefix)
    printer = _Printer(blk.names)
    lines = [signature, "{"]
    states, parameters = inputs_used(model, names, blk)
    parameters = parameters if model.symbolic else []
    if parameters:
        lines.append(f"    if (p == 0) p = &{model.name}_default_params;")
    lines += [f"    const double {local} = {array}[{index}];" for local, array, index in states]
    lines += [f"    const double {local} = p->{local};" for local, _ in parameters]
    used_arrays = {array for _, array, _ in states} | ({"p"} if parameters else set())
    if "t" in blk.used:
        used_arrays.add("t")
    for array in arrays:
        if array not in used_arrays:
            lines.append(f"    (void){array};")
    for name, expr in blk.temporaries:
        lines.append(f"    const double {name} = {printer.doprint(expr)};")
    for key, exprs in blk.outputs.items():
        rows, cols = outputs[key].shape
        for i in range(rows):
            for j in range(cols):
                if key != symmetric or j <= i:
                    value = printer.doprint(exprs[i * cols + j])
                    lines.append(f"    {key}[{i * cols + j}] = {value};")
        if key == symmetric:        # the upper triangle from the lower
            lines += [f"    {key}[{i * cols + j}] = {key}[{j * cols + i}];"
                      for i in range(rows) for j in range(i + 1, cols)]
    lines.append("}")
    return lines


def _fields(model: ExportModel) -> dict:
    """The names the source's parts share: N the robot's, P (Pa) the parameters'
    argument in a signature (a call), dq and ddq the speeds' and accelerations' arrays,
    NQ the speeds' count (M is NQ x NQ), NC the coordinates' (more than NQ with a
    quaternion), NE the efforts'."""
    up = model.name.upper()
    _, dq, ddq = model.arrays
    NQ = f"{up}_N_SPEEDS" if model.kinematic is not None else f"{up}_N_COORDINATES"
    return {"N": model.name, "P": _params(model), "Pa": _params(model, pointer=False),
            "dq": dq, "ddq": ddq, "NQ": NQ, "NC": f"{up}_N_COORDINATES",
            "NE": f"{up}_N_EFFORTS"}


def source(model: ExportModel, note: Callable[[str], None] = quiet) -> str:
    N = model.name
    lines = [_comment([f"{N}.c -- {model.title()}", "",
                       f"See {N}.h for the functions, their arguments and units."]),
             "#include <float.h>", "#include <math.h>", "", f'#include "{N}.h"', ""]
    if model.symbolic:
        values = ", ".join(repr(p.value) for p in model.parameters) or "0.0"
        lines += [f"const {N}_params {N}_default_params = {{{values}}};", ""]
    f = _fields(model)
    lines += _equations(model, f, note)
    lines += _linear_algebra(model, f)
    lines += _dynamics(model, f)
    if model.m:
        lines += template("inverse.c.in", **f)
    else:
        lines += _unused(f"void {N}_inverse(double t, const double *q, const double *{f['dq']}, "
                         f"const double *{f['ddq']},\n                 double *tau{f['P']})",
                         ["t", "q", f["dq"], f["ddq"], "tau", *(["p"] if model.symbolic else [])])
    return "\n".join(lines)


def _unused(signature: str, arguments: list[str]) -> list[str]:
    """A function that does nothing: ``signature`` and each argument marked used."""
    return [*signature.split("\n"), "{", *(f"    (void){a};" for a in arguments), "}", ""]


def _equations(model: ExportModel, f: dict, note: Callable[[str], None]) -> list[str]:
    """The generated leaf functions: M (lower triangle, mirrored), F, B, the control
    laws, with a spherical joint the rates and their Jacobian R, and K."""
    N, P, dq, ddq = f["N"], f["P"], f["dq"], f["ddq"]
    names = _names(model)
    prefix = temporary_prefix(set(names.values()))
    extra = ["p"] if model.symbolic else []

    def leaf(signature, outputs, arrays, symmetric=None):
        return _leaf(model, names, prefix, signature, outputs, arrays, symmetric=symmetric,
                     note=note) + [""]
    lower = sp.Matrix(model.n, model.n, lambda i, j: model.M[i, j] if j <= i else 0)
    lines = leaf(f"void {N}_mass_matrix(const double *q, double *M{P})", {"M": lower},
                 ["q", *extra], symmetric="M")
    lines += leaf(f"void {N}_forcing(double t, const double *q, const double *{dq}, "
                  f"double *F{P})", {"F": model.F}, ["t", "q", dq, *extra])
    if model.m:
        lines += leaf(f"void {N}_input_matrix(const double *q, double *B{P})", {"B": model.B},
                      ["q", *extra])
        lines += leaf(f"void {N}_efforts(double t, const double *q, const double *{dq}, "
                      f"double *tau{P})", {"tau": model.laws}, ["t", "q", dq, *extra])
    else:
        lines += _unused(f"void {N}_input_matrix(const double *q, double *B{P})",
                         ["q", "B", *extra])
        lines += _unused(f"void {N}_efforts(double t, const double *q, const double *{dq}, "
                         f"double *tau{P})", ["t", "q", dq, "tau", *extra])
    if model.kinematic is not None:
        lines += leaf(f"void {N}_rates(const double *q, const double *u, double *dq)",
                      {"dq": model.kinematic}, ["q", "u"])
        lines.append("/* R = d(W(q) u)/dx: the first nq rows of the state Jacobian J */")
        lines += leaf(f"static void {N}_rates_jacobian(const double *q, const double *u, "
                      "double *J)", {"J": model.R}, ["q", "u"])
        lines.append("/* K = [dG/dq - (dM/dq) du | dG/du], G = F + B tau(t, q, u): "
                     "n x (nq + n) */")
    else:
        lines.append("/* K = [dG/dq - (dM/dq) ddq | dG/d(dq)], G = F + B tau(t, q, dq): "
                     "n x 2n */")
    lines += leaf(f"static void {N}_partials(double t, const double *q, const double *{dq}, "
                  f"const double *{ddq}, double *K{P})", {"K": model.K},
                  ["t", "q", dq, ddq, *extra])
    return lines


def _dynamics(model: ExportModel, f: dict) -> list[str]:
    """``N_solve``, ``N_accelerations``, ``N_rhs`` and ``N_jacobian`` (dynamics.c.in):
    NX the state's size (J's row length), NJ J's entries."""
    N, Pa, NQ, NE, NC, ddq = f["N"], f["Pa"], f["NQ"], f["NE"], f["NC"], f["ddq"]
    up, m, spherical = N.upper(), model.m, model.kinematic is not None
    NX, NJ = (f"{up}_N_STATES", f"{up}_N_STATES * {up}_N_STATES") if spherical else (
        f"2 * {NQ}", f"4 * {NQ} * {NQ}")
    tau_loop = ([f"    {N}_input_matrix(q, B{Pa});",
                 f"    for (i = 0; i < {NQ}; ++i)",
                 f"        for (k = 0; k < {NE}; ++k)",
                 f"            {ddq}[i] += B[i * {NE} + k] * tau[k];"] if m else ["    (void)tau;"])
    rates = ([f"    {N}_rates(x, x + {NC}, dx);"] if spherical else
             [f"    for (i = 0; i < {NQ}; ++i)", f"        dx[i] = x[{NQ} + i];"])
    rate_rows = ([f"    {N}_rates_jacobian(x, x + {NC}, J);"] if spherical else
                 [f"    for (i = 0; i < {NQ}; ++i)",
                  f"        for (j = 0; j < 2 * {NQ}; ++j)",
                  f"            J[i * 2 * {NQ} + j] = (j == {NQ} + i) ? 1.0 : 0.0;"])
    return template(
        "dynamics.c.in", **f, NX=NX, NJ=NJ, tau="tau" if m else "0", tau_loop=tau_loop,
        rates=rates, rate_rows=rate_rows,
        solve_locals=[f"    double B[{NQ} * {NE}];", "    int i, k;"] if m else ["    int i;"],
        tau_local=[f"    double tau[{NE}];"] if m else [],
        rhs_locals=[] if spherical else ["    int i;"],
        tau_call=[f"    {N}_efforts(t, x, x + {NC}, tau{Pa});"] if m else [])


def _linear_algebra(model: ExportModel, f: dict) -> list[str]:
    """M's Cholesky factorization ``cholesky`` and solve ``chosolve`` over the
    structural nonzeros of its factor (factor.c.in around the text the derivatives'
    extension compiles, ``recursive.derivatives.CHOLESKY``, with its tables of M's
    zeros), ``N_cholesky_solve`` of one right side, and, with actuators,
    ``N_pseudo_solve`` (pseudo_solve.c.in): the Jacobi SVD of A = B (m <= n) or B^T
    (m > n), rows x cols with rows >= cols, and pinv(B) r = V S^+ U^T r (m <= n) or
    U S^+ V^T r (m > n)."""
    from ...numeric.recursive.derivatives import CHOLESKY, _factor_pattern

    N, NE, n, m = f["N"], f["NE"], model.n, model.m
    nonzero = [[model.M[i, j] != 0 for j in range(n)] for i in range(n)]
    lines = template("factor.c.in", N=N, NQ=f["NQ"], pattern=_factor_pattern(nonzero),
                     cholesky=CHOLESKY.split("\n"))
    if not m:
        return lines
    rows, cols = (n, m) if m <= n else (m, n)
    first, second = (("U", rows), ("V", cols)) if m <= n else (("V", cols), ("U", rows))
    return lines + template(
        "pseudo_solve.c.in", N=N, n=n, m=m, rows=rows, cols=cols, largest=max(n, m),
        b_index=f"i * {NE} + j" if m <= n else f"j * {NE} + i",
        first=first[0], first_rows=first[1], second=second[0], second_rows=second[1])
