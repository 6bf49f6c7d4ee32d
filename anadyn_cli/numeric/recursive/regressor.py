"""The joint-torque regressor of one robot, traced from the recursive Newton-Euler
algorithm: the generalized forces of the inverse dynamics are linear in the
parameters pi,

    Q = M(q) ddq - F(q, dq) = Y(q, dq, ddq) pi      (springs and loads left out)

Parameters pi, per body (fixed-joint bodies included), in Pinocchio's order
(``Inertia.toDynamicParameters``; ``INERTIAL``):

    m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz

with c the centre of mass and I the inertia about the body frame's origin, both
in body axes (I = I_c + m(|c|^2 1 - c c^T)); then, per moving joint, three drive
parameters (``DRIVE``):

    Ia   armature, the effort Ia * ddtheta (a rotor on the ground turning with the
         joint: Pinocchio's and MuJoCo's armature)
    Fv   viscous friction, Fv * dtheta          (the file's damping)
    Fc   Coulomb friction, Fc * tanh(dtheta/v)  (the file's friction; v its
         friction_velocity)

theta a joint's displacement, dtheta = J dq and ddtheta = J ddq (``refuse``: the
displacements are linear in the coordinates); the joint efforts act as J^T (.).

How: the RNEA (``rnea.inverse_dynamics``) is linear in each body's mass
properties (m, h = m c, I_O), so the column of one of a body's ten parameters is
the RNEA of the robot with that parameter 1 and every other mass property,
damper, spring and friction 0.  The columns are traced into one Program: the
kinematics (hash-consed) are traced once, zeros are folded, so each column
carries one body's wrench to the root, as Pinocchio's
``computeJointTorqueRegressor`` does.

Generated twice from the one trace: Python (``module_source``: ``regressor(q, dq,
ddq)`` over NumPy arrays of states, standalone but for NumPy: ``export
--regressor`` writes it) and C (``c_source``: ``anadyn_regressor`` at one state,
``anadyn_regressor_batch`` over rows, a CPython wrapper); ``Regressor`` runs the
C, compiled and cached through ``native.load`` like the derivatives', or without a
compiler (or ANADYN_NATIVE=0) the generated Python.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import sympy as sp

from ...errors import ModelError
from ..ir import Ex, Program, as_expr
from .emit import PY_HEADER, VEC_HEADER, _python_function
from .plan import Plan
from .rnea import inverse_dynamics
from .trace import Traced, _finish
from .tracer import Tracer

#: names of a body's ten standard parameters (suffix "_<body>")
INERTIAL = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
#: names of a moving joint's drive parameters (suffix "_<body>")
DRIVE = ("Ia", "Fv", "Fc")
#: (row, column) of the inertia matrix for each of the six inertia parameters
INERTIA_ENTRIES = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


def refuse(robot) -> None:
    """ModelError (one line) for a robot the regressor does not take: a closed chain,
    external loads, contacts, a joint type with several coordinates, a displacement
    not linear in the coordinates."""
    where = robot.source
    if robot.constraints is not None:
        raise ModelError("the regressor takes open trees; this robot has loops or "
                         "constraints", source=where)
    if robot.loads:
        raise ModelError("the regressor models no external loads; this robot has "
                         f"{len(robot.loads)} (remove its loads: section)", source=where)
    robot.refuse_contacts("regressors (excite, identify, export --regressor)")
    values = robot.parameter_substitution()
    qs = set(robot.q)
    for body in robot.bodies:
        joint, kind = body.joint, body.joint.joint_type
        if kind.coordinates > 1 or kind.speeds != kind.coordinates:
            raise ModelError(f"joint of {body.name}: the regressor takes joints of one "
                             "coordinate (and fixed ones)", source=where, path="bodies")
        if not kind.moving:
            continue
        d = as_expr(joint.displacement).xreplace(values)
        if not d.free_symbols <= qs or any(sp.diff(d, s).free_symbols for s in qs):
            raise ModelError(f"joint of {body.name}: displacement {joint.displacement} is not "
                             "linear in the coordinates; the regressor takes "
                             "a1*q1 + ... + c with constant a and c", source=where,
                             path="bodies")


def parameter_names(pl: Plan) -> tuple[str, ...]:
    """The names of pi: ten per body, then three per moving joint."""
    names = [b.name for b in pl.bodies]
    return tuple([f"{p}_{b}" for b in names for p in INERTIAL]
                 + [f"{p}_{names[i]}" for i in pl.moving for p in DRIVE])


def nominal(pl: Plan) -> np.ndarray:
    """pi of the robot file: its mass properties, no armature, its damping and friction."""
    inertial = [[b.mass, *b.h, *(b.I_O[r][c] for r, c in INERTIA_ENTRIES)] for b in pl.bodies]
    drive = [[0.0, pl.bodies[i].damping, pl.bodies[i].friction] for i in pl.moving]
    return np.array([x for row in inertial + drive for x in row], dtype=float)


def _unit(k: int) -> tuple[float, list[float], list[list[float]]]:
    """(m, h, I_O) with the k-th of the ten parameters 1, the others 0."""
    I_O = [[0.0] * 3 for _ in range(3)]
    if k >= 4:
        r, c = INERTIA_ENTRIES[k - 4]
        I_O[r][c] = I_O[c][r] = 1.0
    return float(k == 0), [float(k == i) for i in (1, 2, 3)], I_O


def trace_regressor(pl: Plan) -> Traced:
    """``regressor(q, dq, ddq)``: Y (n x p), column by column (module doc)."""
    n = pl.n
    w = [Ex.atom(f"_w{k}") for k in range(n)]
    bare = [replace(b, mass=0.0, h=[0.0] * 3, I_O=[[0.0] * 3] * 3, damping=0.0, friction=0.0,
                    stiffness=0.0) for b in pl.bodies]
    P = Program()
    columns = []
    with P:
        for i, b in enumerate(bare):
            for k in range(len(INERTIAL)):
                m, h, I_O = _unit(k)
                bodies = [*bare[:i], replace(b, mass=m, h=h, I_O=I_O), *bare[i + 1:]]
                unit = replace(pl, bodies=bodies, loads=[], contacts=[])
                columns.append(inverse_dynamics(Tracer(unit, P), w, actuators=False))
        T = Tracer(pl, P)
        _, rows, hterm = T.joint_maps()
        rates = T.joint_rates(T.dq)
        accelerations = [P.emit(a + h) for a, h in zip(T.joint_rates(w), hterm)]
        for j, b in enumerate(pl.moving):
            v = pl.bodies[b].friction_velocity
            coulomb = P.call("tanh", P.emit(rates[j] * (1.0 / v)))
            for effort in (accelerations[j], rates[j], coulomb):
                columns.append([P.emit(rows[j][r] * effort) for r in range(n)])
    Y = [[column[r] for column in columns] for r in range(n)]
    args = [f"_q{k}" for k in range(pl.nq)] + [f"_u{k}" for k in range(n)] + [
        f"_w{k}" for k in range(n)]
    return _finish("regressor_rows", args, P, {"Y": Y})


def module_source(tr: Traced, pl: Plan) -> str:
    """Python source: ``regressor(q, dq, ddq)`` over NumPy arrays (``PY_DRIVER``), N,
    COORDINATES, PARAMETERS and NOMINAL (the file's pi)."""
    c = tr.counts
    doc = (f"Y[..., n, p] at the states of the arrays q0.., dq0.., ddq0.. (NumPy).\n\n"
           f"    Operations: {c.mul} multiplications, {c.add} additions, {c.calls} calls.\n    ")
    lines = [PY_HEADER, VEC_HEADER]
    body = _python_function(tr, True, doc)
    for f in ("sin", "cos", "sqrt", "tanh"):
        body = [line.replace(f"_{f}(", f"_v{f}(") for line in body]
    lines += body + [""]
    lines.append(f"N = {pl.n}")
    lines.append(f"COORDINATES = {tuple(pl.coordinates)!r}")
    lines.append(f"PARAMETERS = {parameter_names(pl)!r}")
    lines.append(f"NOMINAL = {tuple(float(x) for x in nominal(pl))!r}")
    lines.append(PY_DRIVER)
    return "\n".join(lines) + "\n"


#: the fixed part of the Python module
PY_DRIVER = '''
def regressor(q, dq, ddq):
    """Y with Q = Y pi: (N, len(PARAMETERS)) at one state (q, dq, ddq of shape (N,)),
    (count, N, len(PARAMETERS)) at count states (rows of (count, N) arrays)."""
    q, dq, ddq = (numpy.moveaxis(numpy.asarray(a, dtype=float), -1, 0) for a in (q, dq, ddq))
    return regressor_rows(*q, *dq, *ddq)
'''


def c_source(tr: Traced, pl: Plan) -> str | None:
    """The C of ``anadyn_regressor`` and ``anadyn_regressor_batch`` with its CPython
    wrapper (``C_DRIVER``; module name left as MODULE_NAME), None when an expression
    of the robot file has no C form."""
    from ..native.emit import _chunked

    n = pl.n
    inputs = {**{f"_q{k}": f"q[{k}]" for k in range(pl.nq)},
              **{f"_u{k}": f"dq[{k}]" for k in range(n)},
              **{f"_w{k}": f"ddq[{k}]" for k in range(n)}}
    Y = tr.outputs["Y"]
    p = len(Y[0])
    cells = [(f"Y[{r * p + c}]", v) for r, row in enumerate(Y) for c, v in enumerate(row)
             if not v.is_zero()]
    try:
        fill = _chunked("yfill", "const double *q, const double *dq, const double *ddq, "
                        "double *Y", inputs, tr.statements, cells)
    except ValueError:
        return None
    head = ["/* generated by anadyn: the joint-torque regressor; see "
            "anadyn_cli/numeric/recursive/regressor.py */",
            "#include <math.h>", "#include <stdlib.h>", "#include <string.h>",
            f"#define N {n}", f"#define NPI {p}", ""]
    return "\n".join(head + fill) + C_DRIVER


#: the fixed part of the C: one state, a batch of rows, the Python wrapper
C_DRIVER = r"""
/* Y (N x NPI, row-major) at q, dq, ddq (N each): 0, or 1 where an entry is not finite */
int anadyn_regressor(const double *q, const double *dq, const double *ddq, double *Y) {
    memset(Y, 0, sizeof(double) * N * NPI);
    if (yfill(q, dq, ddq, Y)) return 1;
    for (int i = 0; i < N * NPI; i++)
        if (!isfinite(Y[i])) return 1;
    return 0;
}

/* Y at count states (rows of q, dq, ddq: count x N; Y: count x N x NPI): -1, or the
   first row that failed (the rows before it written) */
long anadyn_regressor_batch(long count, const double *q, const double *dq, const double *ddq,
                            double *Y) {
    for (long k = 0; k < count; k++)
        if (anadyn_regressor(q + k * N, dq + k * N, ddq + k * N, Y + k * N * NPI)) return k;
    return -1;
}

#ifdef ANADYN_PYEXT
#define PY_SSIZE_T_CLEAN
#include <Python.h>

/* regressor(count, q, dq, ddq, out): anadyn_regressor_batch on float64 buffers */
static PyObject *py_regressor(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "expected (count, q, dq, ddq, out)");
        return NULL;
    }
    Py_ssize_t count = PyLong_AsSsize_t(args[0]);
    if (count < 0) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "count < 0");
        return NULL;
    }
    Py_buffer b[4];
    int held = 0;
    for (; held < 4; held++) {
        int out = held == 3;
        if (PyObject_GetBuffer(args[held + 1], &b[held],
                               PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (out ? PyBUF_WRITABLE : 0)) < 0)
            break;
        if (b[held].itemsize != 8 || (b[held].format && strcmp(b[held].format, "d") != 0)
                || b[held].len != count * (out ? N * NPI : N) * 8) {
            PyBuffer_Release(&b[held]);
            PyErr_SetString(PyExc_TypeError,
                            "expected contiguous float64 arrays of the right size");
            break;
        }
    }
    long failed = -1;
    if (held == 4) {
        Py_BEGIN_ALLOW_THREADS
        failed = anadyn_regressor_batch((long)count, b[0].buf, b[1].buf, b[2].buf, b[3].buf);
        Py_END_ALLOW_THREADS
    }
    for (int i = 0; i < held; i++) PyBuffer_Release(&b[i]);
    return held == 4 ? PyLong_FromLong(failed) : NULL;
}

static PyMethodDef methods[] = {
    {"regressor", (PyCFunction)(void (*)(void))py_regressor, METH_FASTCALL,
     "regressor(count, q, dq, ddq, out) -> -1 or the first failing row"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, MODULE_NAME, NULL, -1, methods};

PyMODINIT_FUNC INIT_FUNCTION(void) { return PyModule_Create(&module); }
#endif
"""


class Regressor:
    """Y(q, dq, ddq) of one robot (``regressor``): ``source`` is the generated Python
    module, ``native`` the C extension or None (``note`` says why)."""

    def __init__(self, pl: Plan, native: bool = True):
        from .. import native as cc
        from ..model import run_generated

        traced = trace_regressor(pl)
        self.n, self.names = pl.n, parameter_names(pl)
        self.source = module_source(traced, pl)
        self._python = run_generated(self.source)
        self.native, self.note = None, "native=False"
        if native:
            c_text = c_source(traced, pl)
            self.native, self.note = ((None, "an expression has no C form") if c_text is None
                                      else cc.load(c_text, how="off" if cc.mode() == "off"
                                                   else "wait"))

    def __call__(self, q, dq, ddq) -> np.ndarray:
        """Y (count, n, p) at the rows of q, dq, ddq ((count, n) each)."""
        q, dq, ddq = (np.ascontiguousarray(a, dtype=float) for a in (q, dq, ddq))
        if self.native is None:
            out = self._python["regressor"](q, dq, ddq)
            bad = ~np.isfinite(out).all(axis=(1, 2))
            failed = int(np.argmax(bad)) if bad.any() else -1
        else:
            out = np.empty((len(q), self.n, len(self.names)))
            failed = self.native.regressor(len(q), q, dq, ddq, out)
        if failed >= 0:
            raise ModelError(f"the regressor is not finite at state {failed} (a coordinate, "
                             "rate or acceleration that is not finite)")
        return out


def regressor(robot, native: bool = True) -> Regressor:
    """The ``Regressor`` of a validated ``Robot`` (``refuse`` says which it takes);
    ``native``: compile the C now when it is not cached (unless ANADYN_NATIVE=0 or no
    compiler)."""
    from .plan import plan

    refuse(robot)
    return Regressor(plan(robot), native)
