"""C99 export: NAME.h and NAME.c, no allocation, no dependency but <math.h>.

Compiles cleanly with ``gcc -std=c99 -Wall -Wextra -Werror -pedantic``.
Matrices are row-major arrays the caller provides; the equations' leaf
functions (mass matrix, forcing, input matrix, control laws, partials) are
generated with common subexpressions eliminated; the linear algebra (an
in-place Cholesky factorization of M, and a Jacobi SVD for B's
pseudo-inverse) is fixed-size loops over local arrays.  With a spherical joint
(x = [q, u], ``ExportModel``) the speeds' arguments are ``u`` and ``du``,
``NAME_N_SPEEDS`` sizes them, and ``NAME_rates`` (dq = W(q) u) is added.
"""
from __future__ import annotations

from importlib import resources
from string import Template
from typing import Callable

import sympy as sp
from sympy.printing.c import C99CodePrinter

from .model import (Block, ExportModel, Named, block, inputs_used, leaf_note, local_names, quiet,
                    row_major, temporary_prefix)

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


def source(model: ExportModel, note: Callable[[str], None] = quiet) -> str:
    N, P = model.name, _params(model)
    Pa = _params(model, pointer=False)
    n, m = model.n, model.m
    up = N.upper()
    _, dq, ddq = model.arrays
    spherical = model.kinematic is not None
    # NQ sizes the speeds (M is NQ x NQ); NC the coordinates, more than NQ with a quaternion
    NQ, NE = f"{up}_N_SPEEDS" if spherical else f"{up}_N_COORDINATES", f"{up}_N_EFFORTS"
    NC = f"{up}_N_COORDINATES"
    names = _names(model)
    prefix = temporary_prefix(set(names.values()))
    extra = ["p"] if model.symbolic else []
    lines = [_comment([f"{N}.c -- {model.title()}", "",
                       f"See {N}.h for the functions, their arguments and units."]),
             "#include <float.h>", "#include <math.h>", "", f'#include "{N}.h"', ""]
    if model.symbolic:
        values = ", ".join(repr(p.value) for p in model.parameters) or "0.0"
        lines += [f"const {N}_params {N}_default_params = {{{values}}};", ""]
    # -- the equations -------------------------------------------------------
    lower = sp.Matrix(model.n, model.n, lambda i, j: model.M[i, j] if j <= i else 0)
    lines += _leaf(model, names, prefix, f"void {N}_mass_matrix(const double *q, double *M{P})",
                   {"M": lower}, ["q", *extra], symmetric="M", note=note) + [""]
    lines += _leaf(model, names, prefix,
                   f"void {N}_forcing(double t, const double *q, const double *{dq}, "
                   f"double *F{P})", {"F": model.F}, ["t", "q", dq, *extra], note=note) + [""]
    if m:
        lines += _leaf(model, names, prefix,
                       f"void {N}_input_matrix(const double *q, double *B{P})",
                       {"B": model.B}, ["q", *extra], note=note) + [""]
        lines += _leaf(model, names, prefix,
                       f"void {N}_efforts(double t, const double *q, const double *{dq}, "
                       f"double *tau{P})", {"tau": model.laws}, ["t", "q", dq, *extra],
                       note=note) + [""]
    else:
        lines += [f"void {N}_input_matrix(const double *q, double *B{P})", "{",
                  "    (void)q;", "    (void)B;", *(["    (void)p;"] if extra else []), "}", "",
                  f"void {N}_efforts(double t, const double *q, const double *{dq}, "
                  f"double *tau{P})",
                  "{", "    (void)t;", "    (void)q;", f"    (void){dq};", "    (void)tau;",
                  *(["    (void)p;"] if extra else []), "}", ""]
    if spherical:
        lines += _leaf(model, names, prefix,
                       f"void {N}_rates(const double *q, const double *u, double *dq)",
                       {"dq": model.kinematic}, ["q", "u"], note=note) + [""]
        lines.append("/* R = d(W(q) u)/dx: the first nq rows of the state Jacobian J */")
        lines += _leaf(model, names, prefix,
                       f"static void {N}_rates_jacobian(const double *q, const double *u, "
                       "double *J)", {"J": model.R}, ["q", "u"], note=note) + [""]
        lines.append("/* K = [dG/dq - (dM/dq) du | dG/du], G = F + B tau(t, q, u): "
                     "n x (nq + n) */")
    else:
        lines.append("/* K = [dG/dq - (dM/dq) ddq | dG/d(dq)], G = F + B tau(t, q, dq): "
                     "n x 2n */")
    lines += _leaf(model, names, prefix,
                   f"static void {N}_partials(double t, const double *q, const double *{dq}, "
                   f"const double *{ddq}, double *K{P})", {"K": model.K},
                   ["t", "q", dq, ddq, *extra], note=note) + [""]
    # -- linear algebra ------------------------------------------------------
    lines += _linear_algebra(N, NQ, NE, n, m)
    # -- the dynamics ----------------------------------------------------------
    # NX: the state's size (row length of J); NJ: J's entries
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
    lines += [
        f"/* {ddq} solving M {ddq} = F + B tau; L gets the Cholesky factor of M (lower "
        "triangle) */",
        f"static int {N}_solve(double t, const double *q, const double *{dq}, const double *tau,",
        f"                     double *{ddq}, double *L{P})",
        "{",
        *([f"    double B[{NQ} * {NE}];", "    int i, k;"] if m else ["    int i;"]),
        f"    {N}_mass_matrix(q, L{Pa});",
        f"    {N}_forcing(t, q, {dq}, {ddq}{Pa});",
        *tau_loop,
        f"    if ({N}_cholesky(L) != 0) {{",
        f"        for (i = 0; i < {NQ}; ++i)",
        f"            {ddq}[i] = NAN;",
        "        return -1;",
        "    }",
        f"    {N}_cholesky_solve(L, {ddq});",
        "    return 0;",
        "}",
        "",
        f"int {N}_accelerations(double t, const double *q, const double *{dq}, const double *tau,",
        f"                     double *{ddq}{P})",
        "{",
        f"    double L[{NQ} * {NQ}];",
        f"    return {N}_solve(t, q, {dq}, tau, {ddq}, L{Pa});",
        "}",
        "",
        f"void {N}_rhs(double t, const double *x, double *dx{P})",
        "{",
        *([f"    double tau[{NE}];"] if m else []),
        *([] if spherical else ["    int i;"]),
        *([f"    {N}_efforts(t, x, x + {NC}, tau{Pa});"] if m else []),
        *rates,
        f"    (void){N}_accelerations(t, x, x + {NC}, {'tau' if m else '0'}, dx + {NC}{Pa});",
        "}",
        "",
        f"void {N}_jacobian(double t, const double *x, double *J{P})",
        "{",
        f"    double L[{NQ} * {NQ}], {ddq}[{NQ}], K[{NQ} * {NX}], column[{NQ}];",
        *([f"    double tau[{NE}];"] if m else []),
        "    int i, j;",
        *([f"    {N}_efforts(t, x, x + {NC}, tau{Pa});"] if m else []),
        f"    if ({N}_solve(t, x, x + {NC}, {'tau' if m else '0'}, {ddq}, L{Pa}) != 0) {{",
        f"        for (i = 0; i < {NJ}; ++i)",
        "            J[i] = NAN;",
        "        return;",
        "    }",
        f"    {N}_partials(t, x, x + {NC}, {ddq}, K{Pa});",
        *rate_rows,
        f"    for (j = 0; j < {NX}; ++j) {{",
        f"        for (i = 0; i < {NQ}; ++i)",
        f"            column[i] = K[i * {NX} + j];",
        f"        {N}_cholesky_solve(L, column);",
        f"        for (i = 0; i < {NQ}; ++i)",
        f"            J[({NC} + i) * {NX} + j] = column[i];",
        "    }",
        "}",
        "",
    ]
    if m:
        lines += [
            f"void {N}_inverse(double t, const double *q, const double *{dq}, "
            f"const double *{ddq},",
            f"                 double *tau{P})",
            "{",
            f"    double M[{NQ} * {NQ}], r[{NQ}], B[{NQ} * {NE}];",
            "    int i, j;",
            f"    {N}_mass_matrix(q, M{Pa});",
            f"    {N}_forcing(t, q, {dq}, r{Pa});",
            f"    {N}_input_matrix(q, B{Pa});",
            f"    for (i = 0; i < {NQ}; ++i) {{",
            "        double s = -r[i];",
            f"        for (j = 0; j < {NQ}; ++j)",
            f"            s += M[i * {NQ} + j] * {ddq}[j];",
            "        r[i] = s;",
            "    }",
            f"    {N}_pseudo_solve(B, r, tau);",
            "}",
            ""]
    else:
        lines += [
            f"void {N}_inverse(double t, const double *q, const double *{dq}, "
            f"const double *{ddq},",
            f"                 double *tau{P})",
            "{", "    (void)t;", "    (void)q;", f"    (void){dq};", f"    (void){ddq};",
            "    (void)tau;",
            *(["    (void)p;"] if extra else []), "}", ""]
    return "\n".join(lines)


def _template(name: str, **fields) -> list[str]:
    """The lines of the template ``name`` (beside this file), its ``${field}``s filled in
    (string.Template)."""
    text = resources.files(__package__).joinpath(name).read_text(encoding="utf-8")
    return Template(text).substitute(fields).split("\n")


def _linear_algebra(N: str, NQ: str, NE: str, n: int, m: int) -> list[str]:
    """``N_cholesky`` and ``N_cholesky_solve`` (cholesky.c.in) and, with
    actuators, ``N_pseudo_solve`` (pseudo_solve.c.in): the Jacobi SVD of
    A = B (m <= n) or B^T (m > n), rows x cols with rows >= cols, and
    pinv(B) r = V S^+ U^T r (m <= n) or U S^+ V^T r (m > n)."""
    lines = _template("cholesky.c.in", N=N, NQ=NQ)
    if not m:
        return lines
    rows, cols = (n, m) if m <= n else (m, n)
    first, second = (("U", rows), ("V", cols)) if m <= n else (("V", cols), ("U", rows))
    return lines + _template(
        "pseudo_solve.c.in", N=N, n=n, m=m, rows=rows, cols=cols, largest=max(n, m),
        b_index=f"i * {NE} + j" if m <= n else f"j * {NE} + i",
        first=first[0], first_rows=first[1], second=second[0], second_rows=second[1])
