"""The derivatives' export (``anadyn export --lang c|python --derivatives``): the code
that ``anadyn.derivatives`` runs, as standalone files beside the equations'.

C (NAME_derivatives.h, NAME_derivatives.c; C99 and <math.h>, <stdlib.h>,
<string.h>): with x = [q, dq] (2n), n coordinates, m efforts and k parameters,
every output a row-major array the caller provides, every function returning 0,
1 (M not positive definite) or 2 (a non-finite result):

    NAME_forward_dynamics(t, x, tau, ddq)              ddq (n)
    NAME_forward_derivatives(t, x, tau, out)           n x (2n + m):
                                                       [d(ddq)/dq | d(ddq)/d(dq) | d(ddq)/dtau]
    NAME_inverse_derivatives(t, x, ddq, out)           3n x n: [dID/dq; dID/d(dq); M]
    NAME_mass_matrix_inverse(t, x, tau, out)           n x n (t, dq, tau unused)
    NAME_forward_parameter_derivatives(t, x, tau, out) n x k (with parameters)
    NAME_inverse_parameter_derivatives(t, x, ddq, out) n x k (with parameters)
    NAME_closed_loop_parameter_derivatives(t, x, tau, out)   n x k, the efforts under
                                                       the control laws (tau unused)

and for each a batch ``NAME_..._batch(count, t, x, y, out)`` over ``count`` states,
row-major: t (count), x (count x 2n), y (count x m or count x n, the third
argument's rows) and out (count x the function's output), returning -1 when every
state succeeded, else the first failing row.

Python (NAME_derivatives.py; needs NumPy): ``forward_dynamics``,
``forward_derivatives``, ``inverse_derivatives``, ``mass_matrix_inverse`` (and the
three parameter derivatives), at one state or at rows of states, as
``anadyn.derivatives`` with ``native=False``.
"""
from __future__ import annotations

import re

from ...errors import ModelError
from ...numeric.derivatives import generate
from .c import _comment

#: kernel of ``recursive.derivatives.C_DRIVER`` -> exported name, its third argument
#: and its output's size in terms of n, m and k
KERNELS = {
    "dynamics": ("forward_dynamics", "tau", "n"),
    "forward": ("forward_derivatives", "tau", "n * (2 * n + m)"),
    "inverse": ("inverse_derivatives", "ddq", "3 * n * n"),
    "minv": ("mass_matrix_inverse", "tau", "n * n"),
    "forward_parameters": ("forward_parameter_derivatives", "tau", "n * k"),
    "inverse_parameters": ("inverse_parameter_derivatives", "ddq", "n * k"),
    "closed_parameters": ("closed_loop_parameter_derivatives", "tau", "n * k"),
}

DOCS = {
    "forward_dynamics": "ddq (n) solving M ddq = F + B tau.",
    "forward_derivatives": "[d(ddq)/dq | d(ddq)/d(dq) | d(ddq)/dtau], n x (2n + m); "
                           "d(ddq)/dtau = M^-1 B.",
    "inverse_derivatives": "[d(ID)/dq; d(ID)/d(dq); M], 3n x n, ID = M ddq - F.",
    "mass_matrix_inverse": "M(q)^-1, n x n, q = x[0..n-1] (t, dq and tau unused: one "
                           "signature for every function).",
    "forward_parameter_derivatives": "d(ddq)/dp, n x k, tau fixed.",
    "inverse_parameter_derivatives": "d(ID)/dp, n x k, ddq fixed.",
    "closed_loop_parameter_derivatives": "d(ddq)/dp, n x k, in closed loop: the efforts "
                                         "under the file's control laws (tau unused).",
}


def files(robot, name: str, lang: str, parameters=()) -> dict[str, str]:
    """{file name: text} of ``robot``'s derivatives in ``lang`` ("c" or "python");
    ``name`` is the export's C/Python identifier of the robot."""
    code = generate(robot, parameters)
    if lang == "python":
        return {f"{name}_derivatives.py": _python(code, name)}
    c_text = code.c()
    if c_text is None:
        raise ModelError(f"{robot.name}: an expression of the robot file has no C form; "
                         "export the derivatives with --lang python")
    kernels = [k for k in KERNELS if code.parameters or "parameters" not in k]
    return {f"{name}_derivatives.h": _header(code, name, kernels),
            f"{name}_derivatives.c": _source(c_text, name, kernels)}


def _sizes(code) -> dict[str, int]:
    return {"n": len(code.coordinates), "m": len(code.efforts), "k": len(code.parameters)}


def _about(code, name: str) -> list[str]:
    n, m, k = _sizes(code).values()
    lines = [f"Derivatives of {name}'s dynamics M(q) ddq = F(t, q, dq) + B(q) tau, generated "
             "by anadyn", "from the recursive Newton-Euler algorithm (its analytic derivatives or "
             "forward-mode", "differentiation, whichever costs fewer operations; no finite "
             "differences).", "The efforts tau are given (open loop, not the file's control "
             "laws) but in the closed-loop", "parameter derivatives.", "",
             f"n = {n} coordinates: {', '.join(code.coordinates)}",
             f"m = {m} efforts: {', '.join(code.efforts) or 'none'}"]
    if k:
        lines.append(f"k = {k} parameters and gains: {', '.join(code.parameters)}")
    return lines + ["Entry [i][j] of a derivative is d(out_i)/d(in_j)."]


def _header(code, name: str, kernels: list[str]) -> str:
    up = name.upper()
    n, m, k = _sizes(code).values()
    doc = _about(code, name) + [
        "", "x = [q, dq] (2n).  Outputs are row-major arrays the caller provides.  Each",
        "function returns 0, 1 (M not positive definite) or 2 (a non-finite result);",
        "each _batch runs count states, row-major: t[count], x[count][2n], the third",
        "argument's rows and out[count][output size], and returns -1 when every state",
        "succeeded, else the first failing row (the rows before it are written).",
        "C99; link with -lm."]
    lines = [_comment(doc), f"#ifndef {up}_DERIVATIVES_H", f"#define {up}_DERIVATIVES_H", "",
             f"#define {up}_DERIVATIVES_N {n}", f"#define {up}_DERIVATIVES_M {m}"]
    if k:
        lines.append(f"#define {up}_DERIVATIVES_K {k}")
    lines += ["", '#ifdef __cplusplus', 'extern "C" {', '#endif', ""]
    for kernel in kernels:
        public, third, size = KERNELS[kernel]
        lines.append(f"/* {DOCS[public]} out: {size} values */")
        lines.append(f"int {name}_{public}(double t, const double *x, const double *{third}, "
                     "double *out);")
        lines.append(f"long {name}_{public}_batch(long count, const double *t, const double *x, "
                     f"const double *{third}, double *out);")
        lines.append("")
    lines += ["#ifdef __cplusplus", "}", "#endif", "", f"#endif /* {up}_DERIVATIVES_H */", ""]
    return "\n".join(lines)


def _source(c_text: str, name: str, kernels: list[str]) -> str:
    """The extension's C without its Python part, the kernels renamed, and the
    batch loops."""
    body = c_text[:c_text.index("#ifdef ANADYN_PYEXT")].rstrip() + "\n"
    body = re.sub(r"\banadyn_jacobians_(\w+)\b",
                  lambda match: f"{name}_{KERNELS[match.group(1)][0]}", body)
    body = body.replace("#include <math.h>",
                        f'#include <math.h>\n#include "{name}_derivatives.h"', 1)
    sizes = {"tau": "MEFF", "ddq": "N"}
    outputs = {"dynamics": "N", "forward": "N * NK", "inverse": "3 * N * N", "minv": "N * N",
               "forward_parameters": "N * NPAR", "inverse_parameters": "N * NPAR",
               "closed_parameters": "N * NPAR"}
    lines = [body, "/* the batches: count states, row-major */"]
    for kernel in kernels:
        public, third, _ = KERNELS[kernel]
        lines += [f"long {name}_{public}_batch(long count, const double *t, const double *x, "
                  f"const double *{third}, double *out) {{",
                  "    for (long k = 0; k < count; k++)",
                  f"        if ({name}_{public}(t[k], x + k * 2 * N, {third} + k * {sizes[third]}, "
                  f"out + k * ({outputs[kernel]})))",
                  "            return k;",
                  "    return -1;", "}", ""]
    return "\n".join(lines)


def _python(code, name: str) -> str:
    doc = _about(code, name) + [
        "", "Needs NumPy.  At one state q, dq of shape (n,); at count states, rows: (count, n)",
        "(t a number or (count,)), results with a leading count.  numpy.linalg.LinAlgError",
        "where M is not positive definite.", "",
        "    forward_dynamics(t, q, dq, tau)     ddq (n)",
        "    forward_derivatives(t, q, dq, tau)  d(ddq)/dq (n, n), d(ddq)/d(dq) (n, n), "
        "d(ddq)/dtau (n, m)",
        "    inverse_derivatives(t, q, dq, ddq)  d(ID)/dq, d(ID)/d(dq), M (n, n each), "
        "ID = M ddq - F",
        "    mass_matrix_inverse(q)              M^-1 (n, n)"]
    if code.parameters:
        doc += ["    forward_parameter_derivatives(t, q, dq, tau)  d(ddq)/dp (n, k), tau fixed",
                "    inverse_parameter_derivatives(t, q, dq, ddq)  d(ID)/dp (n, k), ddq fixed",
                "    closed_loop_parameter_derivatives(t, q, dq)   d(ddq)/dp (n, k), tau under "
                "the control laws"]
    names = (f"COORDINATES = {tuple(code.coordinates)!r}\nEFFORTS = {tuple(code.efforts)!r}\n"
             f"PARAMETERS = {tuple(code.parameters)!r}\n")
    return '"""' + "\n".join(doc).replace("\\", "\\\\") + '\n"""\n' + code.python + names
