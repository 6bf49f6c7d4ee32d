"""The open-loop derivatives of one robot's dynamics, traced like ``trace_jacobian``:
the actuators' efforts are inputs (atoms _e0, ...), not their control laws.

Two functions of (t, q, dq, ddq, e), with ID(t, q, dq, ddq, e) = M ddq - F - B e
(recursive Newton-Euler, joint springs, dampers and friction in F):

    open_loop_residual   M and ID                       (the forward dynamics:
                                                         ddq = -M^-1 ID(ddq = 0))
    open_loop_jacobian   M and K = -dID/d[q, dq, e] at fixed ddq (n x (2n + m)),
                         forward mode over the traced RNEA (``Program.derivatives``)

so that d(ddq)/d[q, dq, e] = M^-1 K at ddq = M^-1 (F + B e), and at e = 0 the
inverse dynamics' derivatives are dID/dq = -K[:, :n], dID/ddq = -K[:, n:2n],
dID/dddq = M.  ``module_source`` writes both as Python, scalar (floats) and
vectorized (NumPy arrays of states, ``_v`` names).
"""
from __future__ import annotations

from ..ir import ZERO, Ex, Program
from .crba import mass_matrix
from .emit import PY_HEADER, VEC_HEADER, _python_function
from .plan import Plan
from .rnea import inverse_dynamics
from .trace import Traced, _finish, state_args
from .tracer import Tracer


def _args(pl: Plan) -> list[str]:
    n, m = pl.n, len(pl.actuator_joint)
    return state_args(pl) + [f"_w{k}" for k in range(n)] + [f"_e{k}" for k in range(m)]


def _residual(pl: Plan):
    """The Program, M and ID at ddq = _w with the efforts _e as inputs."""
    P = Program()
    with P:
        T = Tracer(pl, P)
        T.given_efforts = [Ex.atom(f"_e{k}") for k in range(len(pl.actuator_joint))]
        M = mass_matrix(T)
        ID = inverse_dynamics(T, [Ex.atom(f"_w{k}") for k in range(pl.n)], actuators=True)
    return P, M, ID


def trace_residual(pl: Plan) -> Traced:
    """M and ID = M ddq - F - B e."""
    P, M, ID = _residual(pl)
    return _finish("open_loop_residual", _args(pl), P, {"M": M, "ID": [P.emit(x) for x in ID]})


def trace_open_loop_jacobian(pl: Plan, with_M: bool = True) -> Traced:
    """M and K = -dID/d[q, dq, e] at fixed ddq (forward mode, seeds _q, _u, _e);
    ``with_M`` False: K alone (the C takes M from the residual)."""
    n, m = pl.n, len(pl.actuator_joint)
    P, M, ID = _residual(pl)
    with P:
        seeds = {f"_q{k}": k for k in range(n)}
        seeds.update({f"_u{k}": n + k for k in range(n)})
        seeds.update({f"_e{k}": 2 * n + k for k in range(m)})
        D = P.derivatives(seeds)
        K = []
        for r in range(n):
            d = P.derivative_of(ID[r], D)
            K.append([P.emit(-d[k]) if k in d else ZERO for k in range(2 * n + m)])
    return _finish("open_loop_jacobian", _args(pl), P, {"M": M, "K": K} if with_M else {"K": K})


def _vectorized_lines(tr: Traced) -> list[str]:
    """``tr`` over NumPy arrays, named ``<name>_v``."""
    vector = Traced(tr.name + "_v", tr.args, tr.statements, tr.outputs, tr.counts)
    lines = _python_function(vector, True, "The same over arrays of states (NumPy).")
    for f in ("sin", "cos", "sqrt", "tanh"):
        lines = [line.replace(f"_{f}(", f"_v{f}(") for line in lines]
    return lines


def module_source(pl: Plan, parameters: tuple[Traced, Traced] | None = None) -> str:
    """Python source of ``open_loop_residual`` and ``open_loop_jacobian``, each
    scalar and vectorized (``_v``), with N and M_EFFORTS; with ``parameters`` (the
    ``parameter_jacobian`` and ``law_slopes`` of ``recursive.parameters``) those too
    and N_PARAMETERS."""
    lines = [PY_HEADER, VEC_HEADER]
    functions = [(trace_residual(pl), "M and ID = M ddq - F - B e (scalar)."),
                 (trace_open_loop_jacobian(pl),
                  "M and K = -dID/d[q, dq, e] at fixed ddq (scalar).")]
    if parameters is not None:
        functions += [(parameters[0], "P = dID/dp at fixed ddq (scalar)."),
                      (parameters[1], "tau under the laws and L = B dtau/dp (scalar).")]
    for tr, doc in functions:
        lines += _python_function(tr, False, doc) + [""] + _vectorized_lines(tr) + [""]
    lines.append(f"N = {pl.n}")
    lines.append(f"M_EFFORTS = {len(pl.actuator_joint)}")
    lines.append(PY_DRIVER)
    if parameters is not None:
        lines.append(f"N_PARAMETERS = {len(parameters[0].outputs['P'][0])}")
        lines.append(PY_PARAMETERS)
    return "\n".join(lines) + "\n"


#: the fixed part of the Python module: the derivatives from the generated functions,
#: at one state (q of shape (N,)) or at many (rows of (count, N) arrays), NumPy solves
PY_DRIVER = '''
def _call(scalar, vectorized, t, q, dq, w, e):
    if q.ndim == 1:
        return scalar(float(t), *q, *dq, *w, *e)
    t = numpy.broadcast_to(numpy.asarray(t, dtype=float), q.shape[:1])
    return vectorized(t, *q.T, *dq.T, *w.T, *e.T)


def _arrays(*values):
    return [numpy.asarray(v, dtype=float) for v in values]


def _forward(t, q, dq, tau):
    M, ID = _call(open_loop_residual, open_loop_residual_v, t, q, dq, numpy.zeros_like(q), tau)
    return numpy.linalg.solve(M, -numpy.asarray(ID)[..., None])[..., 0], M


def forward_dynamics(t, q, dq, tau):
    """ddq solving M ddq = F + B tau: (N,) at one state, (count, N) at count states."""
    return _forward(t, *_arrays(q, dq, tau))[0]


def forward_derivatives(t, q, dq, tau):
    """d(ddq)/dq (N, N), d(ddq)/d(dq) (N, N), d(ddq)/dtau = M^-1 B (N, M_EFFORTS),
    with a leading count at count states."""
    q, dq, tau = _arrays(q, dq, tau)
    ddq, _ = _forward(t, q, dq, tau)
    M, K = _call(open_loop_jacobian, open_loop_jacobian_v, t, q, dq, ddq, tau)
    D = numpy.linalg.solve(M, K)
    return D[..., :N], D[..., N:2 * N], D[..., 2 * N:]


def inverse_derivatives(t, q, dq, ddq):
    """d(ID)/dq, d(ID)/d(dq), d(ID)/d(ddq) = M (N, N each; a leading count at count
    states), ID = M ddq - F."""
    q, dq, ddq = _arrays(q, dq, ddq)
    e = numpy.zeros(q.shape[:-1] + (M_EFFORTS,))
    M, K = _call(open_loop_jacobian, open_loop_jacobian_v, t, q, dq, ddq, e)
    return -K[..., :N], -K[..., N:2 * N], M


def mass_matrix_inverse(q):
    """M(q)^-1 (N, N), or (count, N, N) for count rows of q."""
    q, = _arrays(q)
    z = numpy.zeros_like(q)
    e = numpy.zeros(q.shape[:-1] + (M_EFFORTS,))
    M, _ = _call(open_loop_residual, open_loop_residual_v, 0.0, q, z, z, e)
    return numpy.linalg.inv(M)
'''

#: ... and with respect to the chosen parameters (``parameters``)
PY_PARAMETERS = '''
def forward_parameter_derivatives(t, q, dq, tau):
    """d(ddq)/dp (N, N_PARAMETERS) at fixed tau (a leading count at count states)."""
    q, dq, tau = _arrays(q, dq, tau)
    ddq, M = _forward(t, q, dq, tau)
    return numpy.linalg.solve(M, -inverse_parameter_derivatives(t, q, dq, ddq))


def inverse_parameter_derivatives(t, q, dq, ddq):
    """d(ID)/dp (N, N_PARAMETERS) at fixed ddq (a leading count at count states)."""
    q, dq, ddq = _arrays(q, dq, ddq)
    none = numpy.zeros(q.shape[:-1] + (0,))
    return numpy.asarray(_call(parameter_jacobian, parameter_jacobian_v, t, q, dq, ddq, none))


def closed_loop_parameter_derivatives(t, q, dq):
    """d(ddq)/dp (N, N_PARAMETERS) in closed loop, the efforts under the control laws:
    M^-1 (B dtau/dp - dID/dp) (a leading count at count states)."""
    q, dq = _arrays(q, dq)
    none = numpy.zeros(q.shape[:-1] + (0,))
    tau, L = _call(law_slopes, law_slopes_v, t, q, dq, none, none)
    ddq, M = _forward(t, q, dq, numpy.asarray(tau, dtype=float))
    P = numpy.asarray(_call(parameter_jacobian, parameter_jacobian_v, t, q, dq, ddq, none))
    return numpy.linalg.solve(M, numpy.asarray(L) - P)
'''



def c_source(pl: Plan, parameters: tuple[Traced, Traced] | None = None) -> str | None:
    """The C extension of the derivatives (``C_DRIVER``; module name left as
    MODULE_NAME; with ``parameters`` (``module_source``), NPAR, ``pfill``: P = dID/dp
    and ``lfill``: tau and L = B dtau/dp), None when an expression of the robot file
    has no C form."""
    from ..native.emit import _chunked

    n, m = pl.n, len(pl.actuator_joint)
    inputs = {"_t": "_t", **{f"_q{k}": f"x[{k}]" for k in range(n)},
              **{f"_u{k}": f"x[{n + k}]" for k in range(n)},
              **{f"_w{k}": f"w[{k}]" for k in range(n)}, **{f"_e{k}": f"e[{k}]" for k in range(m)}}
    if not m:          # e is then read nowhere: a use that never dereferences it (-Wextra)
        inputs["_e_unused"] = "(double)(e == 0)"
    state = {a: c for a, c in inputs.items() if a[:2] in ("_t", "_q", "_u")}
    params = "double _t, const double *x, const double *w, const double *e, double *M, double *out"
    residual, jacobian = trace_residual(pl), trace_open_loop_jacobian(pl, with_M=False)
    P, M, _ = _residual(pl)
    mass = _finish("mass_matrix", _args(pl), P, {"M": M})

    def chunk(name, params, inputs, statements, outputs):
        """``native.emit._chunked``; with no statements (the outputs constants) a plain
        function, every argument marked used (-Wextra)."""
        if statements:
            return _chunked(name, params, inputs, statements, outputs)
        from ..ir import c_expr
        used = [f"    (void){p.split('*')[-1].split()[-1]};" for p in params.split(",")]
        return ([f"static int {name}({params}) {{", *used]
                + [f"    {target} = {c_expr(value)};" for target, value in outputs]
                + ["    return 0;", "}", ""])

    def cells(name, matrix, width):
        return [(f"{name}[{r * width + c}]", v) for r, row in enumerate(matrix)
                for c, v in enumerate(row) if not v.is_zero()]

    try:
        out = ["/* generated by anadyn: open-loop derivatives; see "
               "anadyn_cli/numeric/recursive/derivatives.py */",
               "#include <math.h>", "#include <stdlib.h>", "#include <string.h>",
               f"#define N {n}", f"#define MEFF {m}"]
        if parameters is not None:
            k = len(parameters[0].outputs["P"][0])
            out.append(f"#define NPAR {k}")
        out.append("")
        out += _chunked("resid", params, inputs, residual.statements,
                        cells("M", residual.outputs["M"], n)
                        + [(f"out[{k}]", v) for k, v in enumerate(residual.outputs["ID"])])
        out += _chunked("mfill", "double _t, const double *x, const double *w, const double *e, "
                        "double *M", inputs, mass.statements, cells("M", mass.outputs["M"], n))
        out += _chunked("kfill", "double _t, const double *x, const double *w, const double *e, "
                        "double *out", inputs, jacobian.statements,
                        cells("out", jacobian.outputs["K"], 2 * n + m))
        if parameters is not None:          # out and tau may be written nowhere: used
            jacobian, slopes = parameters
            out += chunk("pfill", "double _t, const double *x, const double *w, double *out",
                            {**state, **{f"_w{r}": f"w[{r}]" for r in range(n)},
                             "_out_unused": "(double)(out == 0)"},
                            jacobian.statements, cells("out", jacobian.outputs["P"], k))
            out += chunk("lfill", "double _t, const double *x, double *tau, double *out",
                            {**state, "_tau_unused": "(double)(tau == 0)",
                             "_out_unused": "(double)(out == 0)"}, slopes.statements,
                            [(f"tau[{a}]", v) for a, v in enumerate(slopes.outputs["tau"])
                             if not v.is_zero()] + cells("out", slopes.outputs["L"], k))
    except ValueError:
        return None
    return "\n".join(out) + "\n" + C_DRIVER


#: the fixed part of the C extension: dense Cholesky, the forward dynamics, the
#: forward and inverse derivatives at ``count`` states (rows) per call
C_DRIVER = r"""
#define NK (2 * N + MEFF)
#define MAX(a, b) ((a) > (b) ? (a) : (b))

/* L L^T = M in place (lower triangle); 1 when M is not positive definite */
static int cholesky(double *M) {
    for (int j = 0; j < N; j++) {
        double d = M[j * N + j];
        for (int k = 0; k < j; k++) d -= M[j * N + k] * M[j * N + k];
        if (!(d > 0.0)) return 1;
        d = sqrt(d);
        M[j * N + j] = d;
        for (int i = j + 1; i < N; i++) {
            double v = M[i * N + j];
            for (int k = 0; k < j; k++) v -= M[i * N + k] * M[j * N + k];
            M[i * N + j] = v / d;
        }
    }
    return 0;
}

/* B (N x cols, row-major) := (L L^T)^-1 B, by rows (the inner loops run along a row) */
static void chosolve(const double *L, double *B, int cols) {
    double inverse[N];
    for (int i = 0; i < N; i++) inverse[i] = 1.0 / L[i * N + i];
    for (int i = 0; i < N; i++) {
        double *row = B + i * cols;
        for (int k = 0; k < i; k++) {
            const double l = L[i * N + k], *other = B + k * cols;
            for (int c = 0; c < cols; c++) row[c] -= l * other[c];
        }
        for (int c = 0; c < cols; c++) row[c] *= inverse[i];
    }
    for (int i = N - 1; i >= 0; i--) {
        double *row = B + i * cols;
        for (int k = i + 1; k < N; k++) {
            const double l = L[k * N + i], *other = B + k * cols;
            for (int c = 0; c < cols; c++) row[c] -= l * other[c];
        }
        for (int c = 0; c < cols; c++) row[c] *= inverse[i];
    }
}

static int finite_all(const double *v, int k) {
    for (int i = 0; i < k; i++) if (!isfinite(v[i])) return 0;
    return 1;
}

/* ddq solving M ddq = F + B e, and the factor of M in L */
static int forward(double t, const double *x, const double *e, double *ddq, double *L) {
    double w[N];
    memset(w, 0, sizeof w);
    memset(L, 0, sizeof(double) * N * N);
    if (resid(t, x, w, e, L, ddq) || cholesky(L)) return 1;
    for (int i = 0; i < N; i++) ddq[i] = -ddq[i];
    chosolve(L, ddq, 1);
    return finite_all(ddq, N) ? 0 : 2;
}

/* out = [d(ddq)/dq | d(ddq)/d(dq) | d(ddq)/de] (N x NK) = M^-1 K */
int anadyn_jacobians_forward(double t, const double *x, const double *e, double *out) {
    double ddq[N], L[N * N];
    int code = forward(t, x, e, ddq, L);
    if (code) return code;
    memset(out, 0, sizeof(double) * N * NK);
    if (kfill(t, x, ddq, e, out)) return 1;
    chosolve(L, out, NK);
    return finite_all(out, N * NK) ? 0 : 2;
}

/* out = [d(ID)/dq, d(ID)/d(dq), M] (3 N x N) at the accelerations w, no efforts */
int anadyn_jacobians_inverse(double t, const double *x, const double *w, double *out) {
    double e[MAX(MEFF, 1)], K[N * NK];
    memset(e, 0, sizeof e);
    memset(K, 0, sizeof K);
    memset(out, 0, sizeof(double) * 3 * N * N);
    if (mfill(t, x, w, e, out + 2 * N * N) || kfill(t, x, w, e, K)) return 1;
    for (int r = 0; r < N; r++)
        for (int c = 0; c < N; c++) {
            out[r * N + c] = -K[r * NK + c];
            out[N * N + r * N + c] = -K[r * NK + N + c];
        }
    return finite_all(out, 3 * N * N) ? 0 : 2;
}

#ifdef NPAR
/* out = d(ddq)/dp (N x NPAR) = -M^-1 dID/dp at the forward accelerations */
int anadyn_jacobians_forward_parameters(double t, const double *x, const double *e, double *out) {
    double ddq[N], L[N * N];
    int code = forward(t, x, e, ddq, L);
    if (code) return code;
    memset(out, 0, sizeof(double) * N * NPAR);
    if (pfill(t, x, ddq, out)) return 1;
    for (int i = 0; i < N * NPAR; i++) out[i] = -out[i];
    chosolve(L, out, NPAR);
    return finite_all(out, N * NPAR) ? 0 : 2;
}

/* out = d(ddq)/dp (N x NPAR) = M^-1 (L - dID/dp) in closed loop: the efforts under
   the control laws (e unused) */
int anadyn_jacobians_closed_parameters(double t, const double *x, const double *e, double *out) {
    double tau[MAX(MEFF, 1)], slopes[N * NPAR], ddq[N], L[N * N];
    (void)e;
    memset(tau, 0, sizeof tau);
    memset(slopes, 0, sizeof slopes);
    if (lfill(t, x, tau, slopes)) return 1;
    int code = forward(t, x, tau, ddq, L);
    if (code) return code;
    memset(out, 0, sizeof(double) * N * NPAR);
    if (pfill(t, x, ddq, out)) return 1;
    for (int i = 0; i < N * NPAR; i++) out[i] = slopes[i] - out[i];
    chosolve(L, out, NPAR);
    return finite_all(out, N * NPAR) ? 0 : 2;
}

/* out = d(ID)/dp (N x NPAR) at the accelerations w */
int anadyn_jacobians_inverse_parameters(double t, const double *x, const double *w, double *out) {
    memset(out, 0, sizeof(double) * N * NPAR);
    if (pfill(t, x, w, out)) return 1;
    return finite_all(out, N * NPAR) ? 0 : 2;
}
#endif

int anadyn_jacobians_dynamics(double t, const double *x, const double *e, double *ddq) {
    double L[N * N];
    return forward(t, x, e, ddq, L);
}

/* out = M^-1 (N x N) at q = x[:N] (e unused: one signature for the four kernels) */
int anadyn_jacobians_minv(double t, const double *x, const double *e, double *out) {
    double L[N * N], z[2 * N], w[N], r[N], f[MAX(MEFF, 1)];
    (void)e;
    memcpy(z, x, sizeof(double) * N);
    memset(z + N, 0, sizeof(double) * N);
    memset(w, 0, sizeof w);
    memset(f, 0, sizeof f);
    memset(L, 0, sizeof L);
    if (resid(t, z, w, f, L, r) || cholesky(L)) return 1;
    memset(out, 0, sizeof(double) * N * N);
    for (int i = 0; i < N; i++) out[i * N + i] = 1.0;
    chosolve(L, out, N);
    return finite_all(out, N * N) ? 0 : 2;
}

#ifdef ANADYN_PYEXT
#define PY_SSIZE_T_CLEAN
#include <Python.h>

typedef int (*kernel)(double, const double *, const double *, double *);

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

/* f over the rows k < count of t (a float for every row, or count values), q and dq
   (count x N each), y (count x ny) into out (count x nout); returns -1 when every row
   succeeded, else the first failing row */
static PyObject *rows(PyObject *const *args, Py_ssize_t nargs, kernel f, Py_ssize_t ny,
                      Py_ssize_t nout) {
    if (nargs != 6) { PyErr_SetString(PyExc_TypeError, "expected (count, t, q, dq, y, out)"); return NULL; }
    Py_ssize_t count = PyLong_AsSsize_t(args[0]);
    if (count < 0) { if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "count < 0"); return NULL; }
    int one_t = PyFloat_Check(args[1]);
    double t0 = one_t ? PyFloat_AS_DOUBLE(args[1]) : 0.0;
    Py_buffer b[5];
    PyObject *objects[5] = {args[1], args[2], args[3], args[4], args[5]};
    Py_ssize_t sizes[5] = {count, count * N, count * N, count * ny, count * nout};
    int held = 0;
    for (int i = one_t ? 1 : 0; i < 5; i++, held++)
        if (buffer(objects[i], &b[i], sizes[i], i == 4) < 0) {
            for (int j = i - 1; j >= (one_t ? 1 : 0); j--) PyBuffer_Release(&b[j]);
            return NULL;
        }
    const double *t = one_t ? NULL : b[0].buf, *q = b[1].buf, *dq = b[2].buf, *y = b[3].buf;
    double *o = b[4].buf, x[2 * N];
    Py_ssize_t failed = -1;
    for (Py_ssize_t k = 0; k < count; k++) {
        memcpy(x, q + k * N, sizeof(double) * N);
        memcpy(x + N, dq + k * N, sizeof(double) * N);
        if (f(one_t ? t0 : t[k], x, y + k * ny, o + k * nout)) { failed = k; break; }
    }
    for (int i = 5 - held; i < 5; i++) PyBuffer_Release(&b[i]);
    return PyLong_FromSsize_t(failed);
}

/* py_NAME: anadyn_jacobians_NAME over rows, y rows of ny values, out rows of nout */
#define WRAP(name, ny, nout) \
    static PyObject *py_##name(PyObject *self, PyObject *const *args, Py_ssize_t nargs) { \
        (void)self; return rows(args, nargs, anadyn_jacobians_##name, ny, nout); }
WRAP(forward, MEFF, N * NK)
WRAP(inverse, N, 3 * N * N)
WRAP(dynamics, MEFF, N)
WRAP(minv, MEFF, N * N)
#ifdef NPAR
WRAP(forward_parameters, MEFF, N * NPAR)
WRAP(inverse_parameters, N, N * NPAR)
WRAP(closed_parameters, MEFF, N * NPAR)
#endif

#define METHOD(name, arguments) \
    {#name, (PyCFunction)(void (*)(void))py_##name, METH_FASTCALL, #name "(count, t, q, dq, " arguments}
static PyMethodDef methods[] = {
#ifdef NPAR
    METHOD(forward_parameters, "tau, out)"),
    METHOD(inverse_parameters, "ddq, out)"),
    METHOD(closed_parameters, "tau (unused), out)"),
#endif
    METHOD(forward, "tau, out)"),
    METHOD(inverse, "ddq, out)"),
    METHOD(dynamics, "tau, out)"),
    METHOD(minv, "tau (unused), out)"),
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, MODULE_NAME, NULL, -1, methods};

PyMODINIT_FUNC INIT_FUNCTION(void) { return PyModule_Create(&module); }
#endif
"""
