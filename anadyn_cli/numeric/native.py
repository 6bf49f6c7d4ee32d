"""Native code for the integrators' hot calls: C through the system compiler.

From the traced programs of ``recursive`` this writes one C file with

    int rhs(t, x, out)     out = [dq, ddq], M ddq = F + B tau   0 ok, 1 singular M,
    int acc(t, x, ddq)                                          2 non-finite result
    int factor(t, x, out)  out = [ddq by CRBA, the factor P M P^T = L L^T]
    int ksolve(fac, K, J)  J = [[0, I], [M^-1 K]] (2n x 2n) by sparse triangular solves
    int jac(t, x, J)       factor, K = -dID/dx at fixed ddq, ksolve
    int inverse(count, t, x, w, out)   out[k] = M w[k] - F at (t[k], x[k]) by the RNEA
    int driven(t, x, e, ddq)           M ddq = F + B e for given actuator efforts e

wrapped as a CPython extension module (METH_FASTCALL, buffer protocol: no
NumPy headers, ~0.2 us per call).  Long programs are cut into functions of
CHUNK statements (gcc's register allocation is superlinear in a basic
block's length) and compiled at -O1.  The quick module of a cold run
(``recursive.forward``: no K, no inverse or driven dynamics)
is compiled at -O0 (``QuickBuild``).

When: on a cache miss the run starts with the generated Python, the quick
module compiles on the other core and the run switches to it when it is built
(``RecursiveModel``), and the full library compiles in a detached process at
the lowest priority (``build_in_background``, ``compile_job``), into
``<cache folder>-native/``, named by a hash of its C source, the compile
command, the Python version and the extension suffix; the next run loads it
(``load``) once its bytes match the SHA-256 recorded beside it (a damaged,
truncated or foreign library never reaches the dynamic loader: a warning, and
it is rebuilt).  The compiler and its flags are Python's own (sysconfig: CC,
CFLAGS, CCSHARED, LDSHARED, EXT_SUFFIX; $CC chooses another compiler).  One
build per library at a time: a ``.building`` marker holds the builder's process
id (a dead process's marker is stale).  A failed build is remembered and said
once, not retried.  ``ANADYN_NATIVE=wait`` compiles before running,
``ANADYN_NATIVE=0`` never.  No compiler, no Python headers or a failed
compile: the generated Python runs (``model.native_note`` says why); nothing
else changes, since the Python and the C give the same bits
(``RecursiveModel.jacobian`` follows the C's order of operations).  What is
checked before anything is loaded: ``cache`` and docs/explanation/security.md.

``NativeModel`` is a ``NumericModel`` whose ``rhs``, ``jacobian``,
``accelerations`` and ``demand`` call the extension; the other vectorized
functions (M, F, B, efforts, energy over arrays of states) stay NumPy.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

from . import cache, compile_job
from .model import NumericModel, run_generated

#: -O1: as fast as -O2 on these straight-line kernels (measured: arm7 RHS 0.7-1.0 us
#: against 1.3-2.1 us), compiled in half the time; no fused multiply-add, so that the C
#: gives the bits of the generated Python
#: (after sysconfig's compile flags: ``command``)
FLAGS = ("-O1", "-fno-math-errno", "-ffp-contract=off")
#: the quick build of a cold run (forward dynamics only): unoptimized, it compiles in
#: a third of the time (chain12: 0.11 s against 0.25 s at -O1) and is still ~10x the
#: generated Python; no optimization level changes the IEEE arithmetic, so the bits too
QUICK_FLAGS = ("-O0", *FLAGS[1:])


# ------------------------------------------------------------------ C source --

#: statements per C function: gcc's register allocation grows faster than
#: linearly with the length of a basic block, so long programs are cut into
#: functions that pass values through one array
CHUNK = 300

_ATOM = re.compile(r"\b_(?:[aquwe]\d+|t)\b")


def _chunked(name: str, params: str, inputs: dict[str, str], statements, outputs,
             fail: bool) -> list[str]:
    """``static int name(params)``: inputs (atom -> C expression), the statements
    in functions of at most CHUNK statements, then ``outputs`` (target, Ex)."""
    from .ir import c_expr, c_lines

    chunks = [statements[i:i + CHUNK] for i in range(0, len(statements), CHUNK)] or [[]]
    home = {a: -1 for a in inputs}
    for k, chunk in enumerate(chunks):
        for s in chunk:
            if s.kind != "check":
                home[s.name] = k
    slots: dict[str, int] = {}

    def slot(atom):
        if atom not in slots:
            slots[atom] = len(slots)
        return slots[atom]

    for a in inputs:
        slot(a)
    for k, chunk in enumerate(chunks):
        for s in chunk:
            for a in sorted(s.atoms()):        # sorted: the same C text in every process
                if home.get(a, k) != k:
                    slot(a)
    for _, value in outputs:
        for mono in value.terms:
            for a in mono:
                slot(a)
    lines = []
    for k, chunk in enumerate(chunks):
        local = {s.name for s in chunk if s.kind != "check"}

        def ref(match, local=local):
            atom = match.group(0)
            return atom if atom in local else f"v[{slots[atom]}]"

        lines.append(f"static __attribute__((noinline)) int {name}_{k}(double *restrict v) {{")
        for s in chunk:
            for text in c_lines([s]):
                lhs, sep, rhs = text.partition(" = ")
                lines.append(lhs + sep + _ATOM.sub(ref, rhs) if sep else _ATOM.sub(ref, text))
            if s.kind != "check" and s.name in slots:
                lines.append(f"    v[{slots[s.name]}] = {s.name};")
        lines += ["    return 0;", "}", ""]
    size = max(1, len(slots))
    lines.append(f"static int {name}({params}) {{")
    heap = size > 50000
    if heap:
        lines.append(f"    double *v = (double *)malloc(sizeof(double) * {size});")
        lines.append("    if (!v) return 1;")
    else:
        lines.append(f"    double v[{size}];")
    for a, expr in inputs.items():
        lines.append(f"    v[{slots[a]}] = {expr};")
    for k in range(len(chunks)):
        cleanup = "free(v); " if heap else ""
        lines.append(f"    if ({name}_{k}(v)) {{ {cleanup}return 1; }}")
    for target, value in outputs:
        text = _ATOM.sub(lambda m: f"v[{slots[m.group(0)]}]", c_expr(value))
        lines.append(f"    {target} = {text};")
    if heap:
        lines.append("    free(v);")
    lines += ["    return 0;", "}", ""]
    return lines


def c_source(gen) -> str | None:
    """The C file for ``recursive.Generated`` ``gen`` (module name left as MODULE_NAME);
    None when an expression of the robot file has no C form (the Python runs)."""
    try:
        return _c_source(gen)
    except ValueError:
        return None


def _c_source(gen) -> str:
    """With the Jacobian's K and the inverse dynamics when ``gen`` has them
    (``recursive.complete``), else the quick module of ``recursive.forward``."""
    pl = gen.plan
    n = pl.n
    acc = gen.functions["accelerations"]
    factor = gen.functions["factor"]
    jacobian = "dynamics_jacobian" in gen.functions
    fac = gen.factor
    keys = sorted(fac.L)
    nfac = n + len(keys)
    state = {"_t": "_t", **{f"_q{k}": f"x[{k}]" for k in range(n)},
             **{f"_u{k}": f"x[{n + k}]" for k in range(n)}}
    out = ["/* generated by anadyn (recursive dynamics); see anadyn_cli/numeric/native.py */",
           "#include <math.h>", "#include <stdlib.h>", "#include <string.h>",
           f"#define N {n}", f"#define NFAC {nfac}", ""]
    outputs = [(f"ddq[{k}]", v) for k, v in enumerate(factor.outputs["ddq"])]
    outputs += [(f"fac[{k}]", v) for k, v in enumerate(factor.outputs["inv"])]
    outputs += [(f"fac[{n + k}]", v) for k, v in enumerate(factor.outputs["L"])]
    out += _chunked("fac", "double _t, const double *x, double *ddq, double *fac", state,
                    factor.statements, outputs, True)
    if acc.statements is factor.statements:
        out += ["static int acc(double _t, const double *x, double *ddq) {",
                "    double f[NFAC];", "    return fac(_t, x, ddq, f);", "}", ""]
    else:
        out += _chunked("acc", "double _t, const double *x, double *ddq", state, acc.statements,
                        [(f"ddq[{k}]", v) for k, v in enumerate(acc.outputs["ddq"])], True)
    out += _factor_tables(gen)
    if jacobian:
        out += _k_source(gen, state)
        ID = gen.functions["inverse_dynamics"]
        out += _chunked("idyn", "double _t, const double *x, const double *w, double *out",
                        {**state, **{f"_w{k}": f"w[{k}]" for k in range(n)}}, ID.statements,
                        [(f"out[{k}]", v) for k, v in enumerate(ID.outputs["ID"])], False)
        driven = gen.functions["driven_accelerations"]
        efforts = {a: f"e[{a[2:]}]" for a in driven.args if a.startswith("_e")}
        out += _chunked("drv", "double _t, const double *x, const double *e, double *ddq",
                        {**state, **efforts}, driven.statements,
                        [(f"ddq[{k}]", v) for k, v in enumerate(driven.outputs["ddq"])], True)
        out.append(f"#define M_EFFORTS {len(efforts)}")
    out.append(C_DRIVER.replace("JACOBIAN\n", C_JACOBIAN if jacobian else "")
               .replace("JAC_METHOD\n", C_JAC_METHOD if jacobian else "")
               .replace("    JAC_ENTRY\n", C_JAC_ENTRY if jacobian else ""))
    return "\n".join(out) + "\n"


def _k_source(gen, state: dict) -> list[str]:
    """K's kernel (``kmat``) of ``anadyn_jac``."""
    from .ir import prune

    n = gen.plan.n
    K = gen.functions["dynamics_jacobian"].outputs["K"]
    k_statements = prune(gen.functions["dynamics_jacobian"].statements,
                         [x for row in K for x in row])
    outputs = [(f"K[{r * 2 * n + c}]", v) for r, row in enumerate(K)
               for c, v in enumerate(row) if not v.is_zero()]
    out = _chunked("kfill", "double _t, const double *x, const double *w, double *K",
                   {**state, **{f"_w{k}": f"w[{k}]" for k in range(n)}},
                   k_statements, outputs, False)
    return out + ["static void kmat(double _t, const double *x, const double *w, double *K) {",
                  f"    memset(K, 0, sizeof(double) * {n * 2 * n});",
                  "    kfill(_t, x, w, K);", "}", ""]


def _factor_tables(gen) -> list[str]:
    """The sparse factor's tables for ``anadyn_ksolve``: row i of L (k < i) and
    column i of L (k > i), and the elimination order."""
    n, fac = gen.plan.n, gen.factor
    position = {key: n + k for k, key in enumerate(sorted(fac.L))}
    rows = [[(k, position[i, k]) for k in range(i) if (i, k) in fac.L] for i in range(n)]
    cols = [[(k, position[k, i]) for k in range(i + 1, n) if (k, i) in fac.L] for i in range(n)]

    def table(name, lists):
        ptr, a, b = [0], [], []
        for entries in lists:
            a += [e[0] for e in entries]
            b += [e[1] for e in entries]
            ptr.append(len(a))
        return [f"static const int {name}_PTR[{n + 1}] = {{{', '.join(map(str, ptr))}}};",
                f"static const int {name}_IDX[{max(1, len(a))}] = {{{', '.join(map(str, a or [0]))}}};",
                f"static const int {name}_POS[{max(1, len(b))}] = {{{', '.join(map(str, b or [0]))}}};"]

    return (table("ROW", rows) + table("COL", cols)
            + [f"static const int ORDER[N] = {{{', '.join(map(str, fac.order))}}};"])


C_DRIVER = r"""
static int finite_all(const double *v, int k) {
    for (int i = 0; i < k; i++) if (!isfinite(v[i])) return 0;
    return 1;
}

int anadyn_rhs(double t, const double *x, double *out) {
    for (int i = 0; i < N; i++) out[i] = x[N + i];
    if (acc(t, x, out + N)) return 1;
    return finite_all(out, 2 * N) ? 0 : 2;
}

int anadyn_acc(double t, const double *x, double *ddq) {
    if (acc(t, x, ddq)) return 1;
    return finite_all(ddq, N) ? 0 : 2;
}

/* out = [ddq, fac]: the accelerations by CRBA and the factor P M P^T = L L^T
   (fac: 1/L_jj, then L_ij) that anadyn_ksolve takes. */
int anadyn_factor(double t, const double *x, double *out) {
    if (fac(t, x, out, out + N)) return 1;
    return finite_all(out, N + NFAC) ? 0 : 2;
}

/* J = [[0, I], [M^-1 K]] from K (N x 2N) and the factor of M, column by column. */
int anadyn_ksolve(const double *fac_, const double *K, double *J) {
    double y[N];
    memset(J, 0, sizeof(double) * 4 * N * N);
    for (int i = 0; i < N; i++) J[i * 2 * N + N + i] = 1.0;
    for (int c = 0; c < 2 * N; c++) {
        for (int i = 0; i < N; i++) {
            double v = K[ORDER[i] * 2 * N + c];
            for (int e = ROW_PTR[i]; e < ROW_PTR[i + 1]; e++) v -= fac_[ROW_POS[e]] * y[ROW_IDX[e]];
            y[i] = v * fac_[i];
        }
        for (int i = N - 1; i >= 0; i--) {
            double v = y[i];
            for (int e = COL_PTR[i]; e < COL_PTR[i + 1]; e++) v -= fac_[COL_POS[e]] * y[COL_IDX[e]];
            y[i] = v * fac_[i];
        }
        for (int i = 0; i < N; i++) J[(N + ORDER[i]) * 2 * N + c] = y[i];
    }
    return finite_all(J, 4 * N * N) ? 0 : 2;
}

JACOBIAN
#ifdef ANADYN_PYEXT
#define PY_SSIZE_T_CLEAN
#include <Python.h>

static int buffer(PyObject *o, Py_buffer *b, Py_ssize_t items, int writable) {
    if (PyObject_GetBuffer(o, b, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0)) < 0)
        return -1;
    if (b->itemsize != 8 || (b->format && strcmp(b->format, "d") != 0) || b->len != items * 8) {
        PyBuffer_Release(b);
        PyErr_SetString(PyExc_TypeError, "expected a contiguous float64 array of the right size");
        return -1;
    }
    return 0;
}

typedef int (*kernel)(double, const double *, double *);

static PyObject *call(PyObject *const *args, Py_ssize_t nargs, kernel f, Py_ssize_t nout) {
    if (nargs != 3) { PyErr_SetString(PyExc_TypeError, "expected (t, x, out)"); return NULL; }
    double t = PyFloat_AsDouble(args[0]);
    if (t == -1.0 && PyErr_Occurred()) return NULL;
    Py_buffer bx, bo;
    if (buffer(args[1], &bx, 2 * N, 0) < 0) return NULL;
    if (buffer(args[2], &bo, nout, 1) < 0) { PyBuffer_Release(&bx); return NULL; }
    int code = f(t, (const double *)bx.buf, (double *)bo.buf);
    PyBuffer_Release(&bx);
    PyBuffer_Release(&bo);
    return PyLong_FromLong(code);
}

static PyObject *py_rhs(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return call(args, nargs, anadyn_rhs, 2 * N);
}
static PyObject *py_acc(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return call(args, nargs, anadyn_acc, N);
}
static PyObject *py_factor(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return call(args, nargs, anadyn_factor, N + NFAC);
}
static PyObject *py_ksolve(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 3) { PyErr_SetString(PyExc_TypeError, "expected (fac, K, J)"); return NULL; }
    Py_buffer bf, bk, bj;
    if (buffer(args[0], &bf, NFAC, 0) < 0) return NULL;
    if (buffer(args[1], &bk, 2 * N * N, 0) < 0) { PyBuffer_Release(&bf); return NULL; }
    if (buffer(args[2], &bj, 4 * N * N, 1) < 0) {
        PyBuffer_Release(&bf); PyBuffer_Release(&bk); return NULL; }
    int code = anadyn_ksolve((const double *)bf.buf, (const double *)bk.buf, (double *)bj.buf);
    PyBuffer_Release(&bf); PyBuffer_Release(&bk); PyBuffer_Release(&bj);
    return PyLong_FromLong(code);
}
JAC_METHOD

static PyMethodDef methods[] = {
    {"rhs", (PyCFunction)(void (*)(void))py_rhs, METH_FASTCALL, "rhs(t, x, out) -> 0 ok, 1 singular, 2 non-finite"},
    {"acc", (PyCFunction)(void (*)(void))py_acc, METH_FASTCALL, "acc(t, x, ddq) -> code"},
    {"factor", (PyCFunction)(void (*)(void))py_factor, METH_FASTCALL, "factor(t, x, out) -> code"},
    {"ksolve", (PyCFunction)(void (*)(void))py_ksolve, METH_FASTCALL, "ksolve(fac, K, J) -> code"},
    JAC_ENTRY
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, MODULE_NAME, NULL, -1, methods};

PyMODINIT_FUNC INIT_FUNCTION(void) { return PyModule_Create(&module); }
#endif
"""

#: the Jacobian's driver (modules with the Jacobian only)
C_JACOBIAN = r"""int anadyn_driven(double t, const double *x, const double *e, double *ddq) {
    if (drv(t, x, e, ddq)) return 1;
    return finite_all(ddq, N) ? 0 : 2;
}

int anadyn_jac(double t, const double *x, double *J) {
    double ddq[N], factor[NFAC], K[2 * N * N];
    if (fac(t, x, ddq, factor)) return 1;
    kmat(t, x, ddq, K);
    return anadyn_ksolve(factor, K, J);
}
"""

C_JAC_METHOD = r"""static PyObject *py_jac(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return call(args, nargs, anadyn_jac, 4 * N * N);
}

/* driven(t, x, e, ddq): ddq solving M ddq = F + B e for the actuators' efforts e. */
static PyObject *py_driven(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 4) { PyErr_SetString(PyExc_TypeError, "expected (t, x, e, ddq)"); return NULL; }
    double t = PyFloat_AsDouble(args[0]);
    if (t == -1.0 && PyErr_Occurred()) return NULL;
    Py_buffer bx, be, bd;
    if (buffer(args[1], &bx, 2 * N, 0) < 0) return NULL;
    if (buffer(args[2], &be, M_EFFORTS, 0) < 0) { PyBuffer_Release(&bx); return NULL; }
    if (buffer(args[3], &bd, N, 1) < 0) { PyBuffer_Release(&bx); PyBuffer_Release(&be); return NULL; }
    int code = anadyn_driven(t, (const double *)bx.buf, (const double *)be.buf, (double *)bd.buf);
    PyBuffer_Release(&bx); PyBuffer_Release(&be); PyBuffer_Release(&bd);
    return PyLong_FromLong(code);
}

/* inverse(count, t, x, w, out): out[k] = ID(t[k], x[k], w[k]) = M w - F, k < count
   (x rows [q, dq], w rows ddq): the recursive Newton-Euler algorithm at every point. */
static PyObject *py_inverse(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 5) { PyErr_SetString(PyExc_TypeError, "expected (count, t, x, w, out)"); return NULL; }
    Py_ssize_t count = PyLong_AsSsize_t(args[0]);
    if (count < 0) { if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "count < 0"); return NULL; }
    Py_buffer bt, bx, bw, bo;
    if (buffer(args[1], &bt, count, 0) < 0) return NULL;
    if (buffer(args[2], &bx, 2 * N * count, 0) < 0) { PyBuffer_Release(&bt); return NULL; }
    if (buffer(args[3], &bw, N * count, 0) < 0) {
        PyBuffer_Release(&bt); PyBuffer_Release(&bx); return NULL; }
    if (buffer(args[4], &bo, N * count, 1) < 0) {
        PyBuffer_Release(&bt); PyBuffer_Release(&bx); PyBuffer_Release(&bw); return NULL; }
    const double *t = (const double *)bt.buf, *x = (const double *)bx.buf, *w = (const double *)bw.buf;
    double *o = (double *)bo.buf;
    int code = 0;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t k = 0; k < count && !code; k++)
        code = idyn(t[k], x + 2 * N * k, w + N * k, o + N * k);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&bt); PyBuffer_Release(&bx); PyBuffer_Release(&bw); PyBuffer_Release(&bo);
    return PyLong_FromLong(code);
}
"""
C_JAC_ENTRY = ("""    {"jac", (PyCFunction)(void (*)(void))py_jac, METH_FASTCALL, "jac(t, x, J) -> code"},\n"""
               """    {"inverse", (PyCFunction)(void (*)(void))py_inverse, METH_FASTCALL, """
               """"inverse(count, t, x, w, out) -> code"},\n"""
               """    {"driven", (PyCFunction)(void (*)(void))py_driven, METH_FASTCALL, """
               """"driven(t, x, e, ddq) -> code"},\n""")


# ------------------------------------------------------------ compile, load --

#: the generated module's scalar functions come before this line, the vectorized after
VECTOR_MARK = "# ---- vectorized functions ----"
#: sysconfig's CFLAGS left out: optimization and debug info (anadyn sets -O itself;
#: debug info only slows the compile), warnings, link-time optimization, profiling,
#: and unsafe math, which would change the bits
DROPPED_CFLAGS = ("-O", "-g", "-W", "-flto", "-fprofile", "-ffast-math", "-funsafe-math")
#: the C file's name in the private build folder
SOURCE = "module.c"
#: the native folder's record of the build failures already said (``failed_before``)
REPORTED = "failures-said.json"
#: the folder above ``anadyn_cli``: where the detached build imports compile_job from
ROOT = str(Path(__file__).resolve().parents[2])
_HEX = re.compile(r"[0-9a-f]{64}")


def light_source(source: str) -> str:
    """``source`` without its scalar functions (``accelerations`` and
    ``dynamics_jacobian`` None): all a native model compiles from Python."""
    head, mark, tail = source.partition(VECTOR_MARK)
    if not mark:
        return source
    header = head[:head.index("\ndef ") + 1] if "\ndef " in head else head
    return header + "accelerations = dynamics_jacobian = None\n" + tail


def _compiler_words() -> list[str] | None:
    """The C compiler's command: $CC, else the compiler Python was built with
    (sysconfig's CC), else cc; its program resolved on PATH; None if none is found."""
    for command in filter(None, (os.environ.get("CC"), sysconfig.get_config_var("CC"), "cc")):
        words = shlex.split(command)
        path = shutil.which(words[0]) if words else None
        if path:
            return [path, *words[1:]]
    return None


def compiler() -> str | None:
    """The C compiler's path (``_compiler_words``), or None."""
    words = _compiler_words()
    return words[0] if words else None


def python_include() -> str | None:
    include = sysconfig.get_paths().get("include")
    return include if include and Path(include, "Python.h").exists() else None


def flags(c_text: str) -> tuple[str, ...]:
    """FLAGS for a module with the Jacobian and for the generic kernel
    (``generic``), QUICK_FLAGS for a quick one."""
    return FLAGS if "anadyn_jac" in c_text or "anadyn_generic" in c_text else QUICK_FLAGS


def _config(name: str) -> list[str]:
    return shlex.split(sysconfig.get_config_var(name) or "")


def command(options: tuple[str, ...]) -> list[str]:
    """The compile-and-link line of a CPython extension, as Python's own build
    configuration gives it (sysconfig): the compiler (``_compiler_words``),
    CFLAGS less DROPPED_CFLAGS, CCSHARED, ``options``, the Python headers, SOURCE
    into ``compile_job.OUTPUT`` (run in the build folder), LDSHARED's flags
    (-shared; -bundle on macOS) and -lm."""
    cc, base = _compiler_words() or ["cc"], _config("CC")
    ldshared = _config("LDSHARED")
    link = ldshared[len(base):] if base and ldshared[:len(base)] == base else ldshared[1:]
    if not {"-shared", "-bundle", "-dynamiclib"} & set(link):
        link.insert(0, "-shared")
    cflags = [f for f in _config("CFLAGS") if not f.startswith(DROPPED_CFLAGS)]
    return [*cc, *cflags, *(_config("CCSHARED") or ["-fPIC"]), *options, "-DANADYN_PYEXT",
            f"-I{python_include()}", SOURCE, "-o", compile_job.OUTPUT, *link, "-lm"]


def suffix() -> str:
    """The file name ending of an extension module here (sysconfig's EXT_SUFFIX)."""
    return (sysconfig.get_config_var("EXT_SUFFIX")
            or importlib.machinery.EXTENSION_SUFFIXES[0])


def module_name(c_text: str) -> str:
    """Named by a hash of the C text, the whole compile command, Python's version
    and the extension suffix."""
    key = "|".join([c_text, " ".join(command(flags(c_text))), sys.version, suffix()])
    return "_anadyn_" + hashlib.sha256(key.encode()).hexdigest()[:24]


def folder() -> Path:
    """Beside the derivation cache: <cache folder>-native (``cache.native_directory``)."""
    return cache.native_directory()


def library_path(c_text: str) -> Path | None:
    """The cached library built from ``c_text``, its bytes checked against the
    SHA-256 of its record; None when there is none, or (with a warning) when it
    is damaged, missing or not the user's: the caller rebuilds it.
    UntrustedCache when the folder is not the user's own."""
    place = cache.trusted_folder(folder(), create=False)
    if place is None:
        return None
    name = module_name(c_text)
    record = cache.read_record(place, f"{name}.lib", "native library record")
    if record is None:
        return None
    digest = record.get("sha256") if isinstance(record, dict) else None
    if not (isinstance(digest, str) and _HEX.fullmatch(digest)):
        cache.warn(f"native library record {place / (name + '.lib')} is damaged; "
                   "not used, rebuilt")
        return None
    path = place / compile_job.library_name(name, digest, suffix())
    try:
        data = cache.read_private(path)
    except cache.Untrusted as why:
        cache.warn(f"native library {path} {why}; not used, rebuilt")
        return None
    if data is None or hashlib.sha256(data).hexdigest() != digest:
        cache.warn(f"native library {path} is " + ("missing" if data is None else
                   "damaged (its SHA-256 does not match its record)") + "; not used, rebuilt")
        return None
    return path


def failed_before(place: Path | None, name: str) -> str | None:
    """Why an earlier build of module ``name`` failed (None: none did).  Each
    reason is said once, in one warning line, by the first run that finds it
    (REPORTED keeps the reasons said); later runs use the generated Python
    without trying again (until the record is removed)."""
    if place is None:
        return None
    record = cache.read_record(place, f"{name}.failed", "native build record")
    if not (isinstance(record, dict) and isinstance(record.get("why"), str)):
        return None
    why = " ".join(record["why"].split())
    said = cache.read_record(place, REPORTED, "native build record")
    said = said if isinstance(said, list) else []
    if why not in said:
        cache.warn(f"native code not built: {why}; runs use the generated Python (the same "
                   f"results, slower); to try again, remove {place / '*.failed'}")
        try:
            cache.write_record(place, REPORTED, [*said, why][-100:])
        except OSError:
            pass
    return why


def mode() -> str:
    """ANADYN_NATIVE: "0" off; "wait" compile before running; otherwise
    (default) use a cached build, else build in the background for next time."""
    value = os.environ.get("ANADYN_NATIVE", "1").strip().lower()
    return {"0": "off", "off": "off", "no": "off", "wait": "wait", "sync": "wait"}.get(value, "auto")


def unavailable() -> str | None:
    """Why native code cannot be built here (None: it can)."""
    if compiler() is None:
        return "no C compiler found (set CC)"
    if python_include() is None:
        return "no Python.h (install the Python headers)"
    return None


def _work_folder(place: Path | None, c_text: str, name: str) -> Path:
    """A new private (0700) build folder holding the C file: inside the cache
    folder when there is one, so that the library is renamed into place."""
    work = None
    if place is not None:
        try:
            work = Path(tempfile.mkdtemp(prefix=".build-", dir=place))
        except OSError:
            pass
    work = work or Path(tempfile.mkdtemp(prefix="anadyn-cc-"))
    cache.write_private(work, SOURCE, c_text.replace("MODULE_NAME", f'"{name}"')
                        .replace("INIT_FUNCTION", f"PyInit_{name}").encode())
    return work


def build(c_text: str, timings: dict | None = None) -> tuple[object | None, str]:
    """Compile now (into the cache folder when it can be used) and load."""
    timings = {} if timings is None else timings
    why = unavailable()
    if why:
        return None, why
    name = module_name(c_text)
    place = cache.trusted_folder(folder(), create=True)
    start = time.perf_counter()
    try:
        work = _work_folder(place, c_text, name)
    except OSError as err:
        return None, f"cannot write the C file ({err.strerror or err})"
    try:
        path, note = compile_job.run(command(flags(c_text)), work, name, suffix(), place)
        if path is None:
            if failed_before(place, name) is None:      # not remembered: said here
                cache.warn(f"native code not built: {note}; this run uses the generated Python")
            return None, note
        module = _import(name, path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    timings["native_compile"] = time.perf_counter() - start
    if module is None:
        return None, "the compiled module does not load"
    return module, "compiled"


def _claim(marker: Path) -> bool:
    """Create the build marker ``marker`` with this process's id, unless a build
    that is still alive holds it.  A marker whose process is gone (or older than
    ``compile_job.TIMEOUT``, or not a marker of the user's) is stale: replaced."""
    for _ in range(2):
        try:
            cache.create_private(marker, str(os.getpid()).encode())
            return True
        except FileExistsError:
            if not _stale(marker):
                return False
            try:
                os.remove(marker)
            except FileNotFoundError:
                pass
        except OSError:
            return False
    return False


def _stale(marker: Path) -> bool:
    try:
        data, info = cache.read_private(marker), os.lstat(marker)
    except (OSError, cache.Untrusted):
        return True
    if data is None or time.time() - info.st_mtime > compile_job.TIMEOUT:
        return True
    try:
        pid = int(data)
    except ValueError:
        return True
    return not _alive(pid)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (on Windows: assumed, the age bound decides)."""
    if pid <= 0:
        return False
    if os.name == "nt":
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:               # someone else's process
        return True
    except OSError:
        return False
    return True


def build_in_background(c_text: str, lowest_priority: bool = True):
    """Start the compiler in a detached process (``compile_job``) that leaves the
    library in the cache folder; one build per library at a time (the build
    marker), none after a failed one.  (note, the process or None)."""
    why = unavailable()
    if why:
        return why, None
    name = module_name(c_text)
    place = cache.trusted_folder(folder(), create=True)
    if place is None:
        return "cache folder not writable", None
    failed = failed_before(place, name)
    if failed:
        return f"native build failed before: {failed}", None
    marker = place / f"{name}.building"
    if not _claim(marker):
        return "being compiled in the background", None
    try:
        work = _work_folder(place, c_text, name)
    except OSError as err:
        compile_job.release(marker)
        return f"cache folder not writable ({err})", None
    script = ("import sys; sys.path.insert(0, sys.argv[1]); "
              "from anadyn_cli.numeric.compile_job import main; main(sys.argv[2:])")
    try:
        process = subprocess.Popen(
            [sys.executable, "-I", "-c", script, ROOT, str(place), name, suffix(), str(work),
             *command(flags(c_text))],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True, close_fds=True,
            preexec_fn=_lowest_priority if lowest_priority and hasattr(os, "nice") else None)
    except OSError as err:
        shutil.rmtree(work, ignore_errors=True)
        compile_job.release(marker)
        return f"cannot start the compiler ({err})", None
    return "compiling in the background for the next run", process


class QuickBuild:
    """The forward dynamics alone (``recursive.forward``), compiled at QUICK_FLAGS
    while a cold run goes on: ``start`` launches the compiler (normal priority, on
    another core) or finds the library cached; ``module`` gives it once built,
    None before (a few microseconds a call: at most one ``poll`` per POLL seconds)."""

    POLL = 0.002

    def __init__(self, c_text: str, process, module=None):
        self.c_text, self.process, self._module = c_text, process, module
        self._next = 0.0

    @classmethod
    def start(cls, c_text: str | None) -> "QuickBuild | None":
        """None when native code is off or cannot be built here."""
        if c_text is None or mode() != "auto" or unavailable():
            return None
        path = library_path(c_text)
        if path is not None:
            module = _import(module_name(c_text), path)
            if module is not None:
                return cls(c_text, None, module)
        _, process = build_in_background(c_text, lowest_priority=False)
        return cls(c_text, process) if process is not None else None

    def module(self):
        if self._module is not None or self.process is None:
            return self._module
        now = time.perf_counter()
        if now < self._next:
            return None
        self._next = now + self.POLL
        if self.process.poll() is None:
            return None
        self.process = None                      # built or failed: no more polls
        path = library_path(self.c_text)
        if path is None:
            failed_before(cache.trusted_folder(folder(), create=False),
                          module_name(self.c_text))
            return None
        self._module = _import(module_name(self.c_text), path)
        return self._module


def _lowest_priority() -> None:
    """In the compiler's process: yield the CPU to the run that started it."""
    try:
        os.nice(19)
    except OSError:
        pass


def load(c_text: str, timings: dict | None = None, how: str | None = None):
    """(module, note): the library built from ``c_text`` if cached (and whole);
    else, by ``how`` ("auto", "wait", "off"; default ``mode()``), build it in the
    background (module None: this run uses the generated Python) or now; neither
    after a failed build."""
    timings = {} if timings is None else timings
    how = how or mode()
    if how == "off":
        return None, "native code off (ANADYN_NATIVE=0)"
    why = unavailable()
    if why:
        return None, why
    name, path = module_name(c_text), library_path(c_text)
    if path is not None:
        module = _import(name, path)
        if module is not None:
            timings["native"] = "cached"
            return module, "cached"
    failed = failed_before(cache.trusted_folder(folder(), create=False), name)
    if failed:
        return None, f"native build failed before: {failed}"
    if how == "wait":
        return build(c_text, timings)
    return None, build_in_background(c_text)[0]


def _import(name: str, path: Path):
    """The extension module ``name`` from the library file ``path`` (checked by the caller)."""
    try:
        loader = importlib.machinery.ExtensionFileLoader(name, str(path))
        spec = importlib.util.spec_from_file_location(name, path, loader=loader)
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
        return module
    except (ImportError, OSError):
        return None


# --------------------------------------------------------------- the model --

def _call(kernel, t: float, x, out: np.ndarray) -> np.ndarray:
    """``kernel(t, x, out)`` of the extension; LinAlgError for a singular M."""
    try:
        code = kernel(t, x, out)
    except TypeError:                    # not a contiguous float64 array
        code = kernel(t, np.ascontiguousarray(x, dtype=float), out)
    if code == 1:
        raise np.linalg.LinAlgError("mass matrix not positive definite")
    return out


def _driven(kernel, t: float, x, efforts, out: np.ndarray) -> np.ndarray:
    """``kernel(t, x, e, out)`` of the extension; LinAlgError for a singular M."""
    if kernel(t, np.ascontiguousarray(x, dtype=float),
              np.ascontiguousarray(efforts, dtype=float), out) == 1:
        raise np.linalg.LinAlgError("mass matrix not positive definite")
    return out


class RecursiveModel(NumericModel):
    """The generated Python of the recursive path.  Its Jacobian solves
    M (d ddq/dx) = K with the factor that ``factor`` computes, column by column
    in the order of the C kernel, so that Python and C give the same bits (a
    run does not depend on whether the library was built).

    The scalar functions (``accelerations``, ``factor``, ``dynamics_jacobian``:
    most of the source) are each compiled from Python when first called.  With
    a ``QuickBuild``, the run switches to its C as soon as the compiler is
    done, mid-run: the RHS, and the factor of M and the solve with it in the
    Jacobian (K stays Python); the same bits, sooner."""

    def __init__(self, info, source: str, formulation: str = "recursive",
                 quick: QuickBuild | None = None):
        super().__init__(info, light_source(source), formulation)
        self.full_source = source
        self._factor_tables = self._namespace.get("FACTOR")
        self._scalars: dict = {}
        self._accelerations = self._first_accelerations
        self._jacobian = self._first_jacobian
        self._quick, self._quick_module = quick, None
        self._n2 = 2 * self.n

    def scalar(self, name: str):
        """The generated module's scalar function ``name``, compiled on first use."""
        if name not in self._scalars:
            head = self.full_source.partition(VECTOR_MARK)[0]
            start = head.index(f"\ndef {name}(")
            end = head.find("\ndef ", start + 1)
            header = head[:head.index("\ndef ")]
            self._scalars[name] = run_generated(
                header + head[start:end if end > 0 else len(head)])[name]
        return self._scalars[name]

    def _first_accelerations(self, *args):
        self._accelerations = self.scalar("accelerations")
        return self._accelerations(*args)

    def _first_jacobian(self, *args):
        self._jacobian = self.scalar("dynamics_jacobian")
        return self._jacobian(*args)

    def _poll(self) -> None:
        module = self._quick.module()
        if module is not None:
            self._quick_module, self._quick = module, None
            self.native_note = ("native C (compiled during the run; the full library in "
                                "the background for the next run)")

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        if self._quick is not None:
            self._poll()
        if self._quick_module is not None:
            return _call(self._quick_module.rhs, t, x, np.empty(self._n2))
        return super().rhs(t, x)

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        n = self.n
        if self._quick_module is not None:        # C factor and solve around Python's K
            factor = _call(self._quick_module.factor, t, x, np.empty(n + self._nfac))
            _, K = self._jacobian(t, *np.asarray(x, dtype=float).tolist(), *factor[:n].tolist())
            J = np.empty((self._n2, self._n2))
            self._quick_module.ksolve(factor[n:], np.ascontiguousarray(K, dtype=float), J)
            return J
        order, rows, cols = self._factor_tables
        values = np.asarray(x, dtype=float).tolist()
        ddq, inv, L = self.scalar("factor")(t, *values)
        _, K = self._jacobian(t, *values, *ddq)
        y = [None] * n
        for i in range(n):
            v = K[order[i]].copy()
            for k, e in rows[i]:
                v -= L[e] * y[k]
            y[i] = v * inv[i]
        for i in reversed(range(n)):
            v = y[i]
            for k, e in cols[i]:
                v = v - L[e] * y[k]
            y[i] = v * inv[i]
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        for i in range(n):
            J[n + order[i]] = y[i]
        return J

    def driven_accelerations(self, t: float, x: np.ndarray, efforts) -> np.ndarray:
        return np.array(self.scalar("driven_accelerations")(
            t, *np.asarray(x, dtype=float).tolist(), *np.asarray(efforts, dtype=float).tolist()))

    @property
    def _nfac(self) -> int:
        """n + the stored entries of L (``factor``'s output after ddq)."""
        _, rows, _ = self._factor_tables
        return self.n + sum(len(r) for r in rows)


class NativeModel(RecursiveModel):
    """``NumericModel`` whose ``rhs``, ``jacobian`` and ``accelerations`` run in C.

    As in the generated Python, a mass matrix that is not positive definite
    raises numpy.linalg.LinAlgError; a non-finite result is returned as is
    (the integrators test every result).  Only the vectorized functions are
    compiled from Python up front; the scalar Python ``dynamics_jacobian``
    (M and K) is compiled when first asked for."""

    def __init__(self, info, source: str, formulation: str, module):
        super().__init__(info, source, formulation)
        self.native = module
        self._rhs_c, self._jac_c, self._acc_c = module.rhs, module.jac, module.acc
        self._accelerations = self._native_accelerations

    def _native_accelerations(self, t, *state) -> list[float]:
        return _call(self._acc_c, t, np.array(state, dtype=float), np.empty(self.n)).tolist()

    def accelerations(self, t: float, x) -> list[float]:
        return _call(self._acc_c, t, x, np.empty(self.n)).tolist()

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        return _call(self._rhs_c, t, x, np.empty(self._n2))

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        J = np.empty((self._n2, self._n2))
        if self._jac_c(t, np.ascontiguousarray(x, dtype=float), J) == 1:
            raise np.linalg.LinAlgError("mass matrix not positive definite")
        return J

    def driven_accelerations(self, t: float, x: np.ndarray, efforts) -> np.ndarray:
        return _driven(self.native.driven, t, x, efforts, np.empty(self.n))

    def demand(self, t, q, dq, ddq) -> tuple[np.ndarray, np.ndarray]:
        """As ``NumericModel.demand``, M ddq - F by the C kernel over all points."""
        n = self.n
        if np.ndim(t) == 0 and np.ndim(q) == 1:            # one point (the round trip)
            out = np.empty((1, n))
            self.native.inverse(1, np.array([t], dtype=float),
                                np.concatenate([q, dq]).astype(float),
                                np.ascontiguousarray(ddq, dtype=float), out)
            return out[0], self.actuation(t, q, dq)
        with np.errstate(all="ignore"):
            arrays = np.broadcast_arrays(np.asarray(t, dtype=float),
                                         *(np.asarray(v, dtype=float) for v in (*q, *dq, *ddq)))
            shape = arrays[0].shape
            columns = np.stack([a.reshape(-1) for a in arrays[1:]], axis=1)   # (count, 3n)
            count = len(columns)
            out = np.empty((count, n))
            self.native.inverse(count, np.ascontiguousarray(arrays[0].reshape(-1)),
                                np.ascontiguousarray(columns[:, :2 * n]),
                                np.ascontiguousarray(columns[:, 2 * n:]), out)
            return out.reshape(shape + (n,)), self.actuation(t, q, dq)


def recursive_model(info, code: str, c_text: str | None, formulation: str = "recursive",
                    timings: dict | None = None, how: str | None = None,
                    quick: QuickBuild | None = None):
    """A NativeModel when the C library is cached (or ``how`` "wait" builds it),
    else the generated Python's RecursiveModel, which takes ``quick``'s C for its
    RHS once built; ``model.native_note`` says which."""
    module, why = (None, "no C source") if c_text is None else load(c_text, timings, how)
    if module is None:
        model = RecursiveModel(info, code, formulation, quick)
        model.native_note = f"generated Python ({why})"
    else:
        model = NativeModel(info, code, formulation, module)
        model.native_note = f"native C ({why})"
    return model
