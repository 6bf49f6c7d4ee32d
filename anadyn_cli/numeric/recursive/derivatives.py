"""The open-loop derivatives of one robot's dynamics, traced like ``trace_jacobian``:
the actuators' efforts are inputs (atoms _e0, ...), not their control laws.

Two functions of (t, q, dq, ddq, e), with ID(t, q, dq, ddq, e) = M ddq - F - B e
(recursive Newton-Euler, joint springs, dampers and friction in F):

    open_loop_residual   M and ID                       (the forward dynamics:
                                                         ddq = -M^-1 ID(ddq = 0))
    open_loop_jacobian   M and K = -dID/d[q, dq, e] at fixed ddq (n x (2n + m)):
                         the analytic RNEA derivatives (``rnea_derivatives``,
                         Carpentier and Mansard 2018) or forward mode over the
                         traced RNEA (``Program.derivatives``), whichever costs
                         fewer operations (``ir.count``) where both apply

so that d(ddq)/d[q, dq, e] = M^-1 K at ddq = M^-1 (F + B e), and at e = 0 the
inverse dynamics' derivatives are dID/dq = -K[:, :n], dID/ddq = -K[:, n:2n],
dID/dddq = M.  ``module_source`` writes both as Python, scalar (floats) and
vectorized (NumPy arrays of states, ``_v`` names).
"""
from __future__ import annotations

from importlib import resources

from ..ir import ZERO, Ex, Program
from . import rnea_derivatives
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


def trace_forward_mode_jacobian(pl: Plan) -> Traced:
    """M (CRBA) and K = -dID/d[q, dq, e] at fixed ddq, forward mode over the traced
    RNEA (seeds _q, _u, _e)."""
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
    return _finish("open_loop_jacobian", _args(pl), P, {"M": M, "K": K})


def trace_analytic_jacobian(pl: Plan) -> Traced | None:
    """The same by the analytic RNEA derivatives (``rnea_derivatives``), None where
    they do not cover the robot: of the axes the passes may run in (each group's
    first body or one or two joints below it, or the world's: ``reference_at``), the
    one that costs fewer operations (``ir.count``)."""
    if not rnea_derivatives.covered(pl):
        return None
    best = None
    for depth in (0, 1, 2, None):
        P = Program()
        with P:
            M, K = rnea_derivatives.jacobian(Tracer(pl, P), [Ex.atom(f"_w{k}")
                                                             for k in range(pl.n)], depth)
        traced = _finish("open_loop_jacobian", _args(pl), P, {"M": M, "K": K})
        if best is None or traced.counts.total < best.counts.total:
            best = traced
    return best


def trace_open_loop_jacobian(pl: Plan) -> Traced:
    """M and K = -dID/d[q, dq, e] at fixed ddq: the analytic RNEA derivatives where
    they cover the robot and cost fewer operations (``ir.count``), else forward
    mode."""
    forward = trace_forward_mode_jacobian(pl)
    analytic = trace_analytic_jacobian(pl)
    if analytic is None or analytic.counts.total >= forward.counts.total:
        return forward
    return analytic


def _vectorized_lines(tr: Traced) -> list[str]:
    """``tr`` over NumPy arrays, named ``<name>_v``."""
    vector = Traced(tr.name + "_v", tr.args, tr.statements, tr.outputs, tr.counts)
    lines = _python_function(vector, True, "The same over arrays of states (NumPy).")
    for f in ("sin", "cos", "sqrt", "tanh"):
        lines = [line.replace(f"_{f}(", f"_v{f}(") for line in lines]
    return lines


def module_source(pl: Plan, parameters: tuple[Traced, Traced] | None = None,
                  jacobian: Traced | None = None) -> str:
    """Python source of ``open_loop_residual`` and ``open_loop_jacobian``, each
    scalar and vectorized (``_v``), with N and M_EFFORTS; with ``parameters`` (the
    ``parameter_jacobian`` and ``law_slopes`` of ``recursive.parameters``) those too
    and N_PARAMETERS; ``jacobian``: ``trace_open_loop_jacobian(pl)`` when already
    traced."""
    lines = [PY_HEADER, VEC_HEADER]
    functions = [(trace_residual(pl), "M and ID = M ddq - F - B e (scalar)."),
                 (jacobian or trace_open_loop_jacobian(pl),
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


def _template(name: str) -> str:
    """The text of the template ``name`` beside this file."""
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


#: the fixed part of the Python module: the derivatives from the generated functions,
#: at one state (q of shape (N,)) or at many (rows of (count, N) arrays), NumPy solves
PY_DRIVER = _template("derivatives_driver.py.in")

#: ... and with respect to the chosen parameters (``parameters``)
PY_PARAMETERS = _template("derivatives_parameters.py.in")



def _factor_pattern(nonzero: list[list[bool]]) -> list[str]:
    """The C tables of the structural nonzeros of M's Cholesky factor L below the
    diagonal (M's nonzeros and their fill-in), from ``nonzero`` (M's): by rows,
    LOWER[LOWER_START[i]:LOWER_START[i + 1]] the columns k < i of row i, and by
    columns, UPPER[UPPER_START[i]:...] the rows k > i of column i, ascending."""
    n = len(nonzero)
    nz = [list(row) for row in nonzero]
    for j in range(n):
        for i in range(j + 1, n):
            nz[i][j] = nz[i][j] or any(nz[i][k] and nz[j][k] for k in range(j))
    lower = [[k for k in range(i) if nz[i][k]] for i in range(n)]
    upper = [[k for k in range(i + 1, n) if nz[k][i]] for i in range(n)]
    lines = []
    for name, lists in (("LOWER", lower), ("UPPER", upper)):
        starts = [0]
        for entries in lists:
            starts.append(starts[-1] + len(entries))
        flat = [k for entries in lists for k in entries] or [0]
        lines += [f"static const int {name}_START[N + 1] = {{{', '.join(map(str, starts))}}};",
                  f"static const int {name}[{len(flat)}] = {{{', '.join(map(str, flat))}}};"]
    return lines


def c_source(pl: Plan, parameters: tuple[Traced, Traced] | None = None,
             jacobian: Traced | None = None) -> str | None:
    """The C extension of the derivatives (``C_DRIVER``; module name left as
    MODULE_NAME; the tables of M's factor's structural nonzeros, ``_factor_pattern``;
    with ``parameters`` (``module_source``), NPAR, ``pfill``: P = dID/dp and
    ``lfill``: tau and L = B dtau/dp), None when an expression of the robot file
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
    residual, jacobian = trace_residual(pl), jacobian or trace_open_loop_jacobian(pl)

    def chunk(name, params, inputs, statements, outputs):
        """``native.emit._chunked``; with no statements (the outputs constants) a plain
        function, every argument marked used (-Wextra)."""
        if statements:
            return _chunked(name, params, inputs, statements, outputs, "CLONED")
        from ..printers import c_expr
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
               f"#define N {n}", f"#define MEFF {m}", CLONED]
        if parameters is not None:
            k = len(parameters[0].outputs["P"][0])
            out.append(f"#define NPAR {k}")
        out += _factor_pattern([[not v.is_zero() for v in row] for row in residual.outputs["M"]])
        out.append("")
        out += _chunked("resid", params, inputs, residual.statements,
                        cells("M", residual.outputs["M"], n)
                        + [(f"out[{k}]", v) for k, v in enumerate(residual.outputs["ID"])],
                        "CLONED")
        out += _chunked("kfill", params, inputs, jacobian.statements,
                        cells("M", jacobian.outputs["M"], n)
                        + cells("out", jacobian.outputs["K"], 2 * n + m), "CLONED")
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


#: the generated functions and the solves also compiled for processors with AVX, the
#: version chosen when the module loads (GCC's function multi-versioning, x86-64
#: Linux): its three-operand instructions need fewer copies between registers, a
#: third less time at n = 7; the same arithmetic (no contraction), so the same bits
CLONED = """#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define CLONED __attribute__((target_clones("avx", "default")))
#else
#define CLONED
#endif"""

#: Cholesky over M's structural nonzeros (``_factor_pattern``'s tables): ``cholesky``
#: and ``chosolve``, the one text of the C export's too (``output.export.c``)
CHOLESKY = _template("cholesky.c.in")

#: the fixed part of the C extension: ``CHOLESKY``, the forward dynamics, the forward
#: and inverse derivatives at ``count`` states (rows) per call, and at one state from
#: NumPy vectors into new arrays (``one_*``)
C_DRIVER = CHOLESKY + _template("derivatives_driver.c.in")
