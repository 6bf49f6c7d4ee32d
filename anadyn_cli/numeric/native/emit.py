"""The C text of the recursive path: from the traced programs of ``recursive``
one C file with

    int rhs(t, x, out)     out = [dq, ddq], M ddq = F + B tau   0 ok, 1 singular M,
    int acc(t, x, ddq)                                          2 non-finite result
    int factor(t, x, out)  out = [ddq by CRBA, the factor P M P^T = L L^T]
    int ksolve(fac, K, J)  J = [[0, I], [M^-1 K]] (2n x 2n) by sparse triangular solves
    int jac(t, x, J)       factor, K = -dID/dx at fixed ddq, ksolve
    int inverse(count, t, x, w, out)   out[k] = M w[k] - F at (t[k], x[k]) by the RNEA
    int driven(t, x, e, ddq)           M ddq = F + B e for given actuator efforts e

wrapped as a CPython extension module (METH_FASTCALL, buffer protocol: no
NumPy headers, ~0.2 us per call).  The robot's programs are printed here
(``printers.c_lines``), cut into functions of CHUNK statements (gcc's register
allocation is superlinear in a basic block's length); the fixed part (the
drivers, the sparse triangular solves, the Python wrappers) is the template
``driver.c.in`` beside this file, whose lines ``JACOBIAN``, ``JAC_METHOD`` and
``JAC_ENTRY`` take ``jacobian*.c.in`` in a module with the Jacobian
(``recursive.complete``) and nothing in the quick module of ``recursive.forward``.
MODULE_NAME and INIT_FUNCTION are left for the build (``builder``) to fill in.
"""
from __future__ import annotations

import re
from importlib import resources


def _template(name: str) -> str:
    """The text of the template ``name`` beside this file."""
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


#: statements per C function: gcc's register allocation grows faster than
#: linearly with the length of a basic block, so long programs are cut into
#: functions that pass values through one array
CHUNK = 300

_ATOM = re.compile(r"\b_(?:[aquwe]\d+|t)\b")


def _chunked(name: str, params: str, inputs: dict[str, str], statements,
             outputs, attributes: str = "") -> list[str]:
    """``static int name(params)``: inputs (atom -> C expression), the statements
    in functions of at most CHUNK statements (declared with ``attributes``, a
    macro of the C text, before ``int``), then ``outputs`` (target, Ex)."""
    from ..printers import c_expr, c_lines

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

        lines.append(f"static __attribute__((noinline)) {attributes + ' ' if attributes else ''}"
                     f"int {name}_{k}(double *restrict v) {{")
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
    (``recursive.complete``), else the quick module of ``recursive.forward``.  With a
    spherical joint the state is x = [q (NQ), u (N)], ``rhs`` gives [W(q) u, du]
    (``_spherical_driver``), and the module is the quick one: the Jacobian, inverse
    and driven dynamics run in the generated Python."""
    pl = gen.plan
    n, nq = pl.n, pl.nq
    acc = gen.functions["accelerations"]
    factor = gen.functions["factor"]
    jacobian = "dynamics_jacobian" in gen.functions and not pl.spherical
    fac = gen.factor
    keys = sorted(fac.L)
    nfac = n + len(keys)
    state = {"_t": "_t", **{f"_q{k}": f"x[{k}]" for k in range(nq)},
             **{f"_u{k}": f"x[{nq + k}]" for k in range(n)}}
    # the first line names the module before it became this package: the C text (and the
    # hash that names its cached library) stays the same
    out = ["/* generated by anadyn (recursive dynamics); see anadyn_cli/numeric/native.py */",
           "#include <math.h>", "#include <stdlib.h>", "#include <string.h>",
           f"#define N {n}", f"#define NFAC {nfac}", *([f"#define NQ {nq}"] * pl.spherical),
           ""]
    outputs = [(f"ddq[{k}]", v) for k, v in enumerate(factor.outputs["ddq"])]
    outputs += [(f"fac[{k}]", v) for k, v in enumerate(factor.outputs["inv"])]
    outputs += [(f"fac[{n + k}]", v) for k, v in enumerate(factor.outputs["L"])]
    out += _chunked("fac", "double _t, const double *x, double *ddq, double *fac", state,
                    factor.statements, outputs)
    if acc.statements is factor.statements:
        out += ["static int acc(double _t, const double *x, double *ddq) {",
                "    double f[NFAC];", "    return fac(_t, x, ddq, f);", "}", ""]
    else:
        out += _chunked("acc", "double _t, const double *x, double *ddq", state, acc.statements,
                        [(f"ddq[{k}]", v) for k, v in enumerate(acc.outputs["ddq"])])
    out += _factor_tables(gen)
    if pl.spherical:
        from ..recursive.trace import trace_rates

        rates = gen.functions.get("rates") or trace_rates(pl)      # ``forward``: traced here
        out += _chunked("rates", "double _t, const double *x, double *dq", state,
                        rates.statements, [(f"dq[{k}]", v)
                                           for k, v in enumerate(rates.outputs["dq"])])
    if jacobian:
        out += _k_source(gen, state)
        ID = gen.functions["inverse_dynamics"]
        out += _chunked("idyn", "double _t, const double *x, const double *w, double *out",
                        {**state, **{f"_w{k}": f"w[{k}]" for k in range(n)}}, ID.statements,
                        [(f"out[{k}]", v) for k, v in enumerate(ID.outputs["ID"])])
        driven = gen.functions["driven_accelerations"]
        efforts = {a: f"e[{a[2:]}]" for a in driven.args if a.startswith("_e")}
        out += _chunked("drv", "double _t, const double *x, const double *e, double *ddq",
                        {**state, **efforts}, driven.statements,
                        [(f"ddq[{k}]", v) for k, v in enumerate(driven.outputs["ddq"])])
        out.append(f"#define M_EFFORTS {len(efforts)}")
    out.append(_spherical_driver(driver(jacobian)) if pl.spherical else driver(jacobian))
    return "\n".join(out) + "\n"


def _k_source(gen, state: dict) -> list[str]:
    """K's kernel (``kmat``) of ``anadyn_jac``."""
    from ..ir import prune

    n = gen.plan.n
    K = gen.functions["dynamics_jacobian"].outputs["K"]
    k_statements = prune(gen.functions["dynamics_jacobian"].statements,
                         [x for row in K for x in row])
    outputs = [(f"K[{r * 2 * n + c}]", v) for r, row in enumerate(K)
               for c, v in enumerate(row) if not v.is_zero()]
    out = _chunked("kfill", "double _t, const double *x, const double *w, double *K",
                   {**state, **{f"_w{k}": f"w[{k}]" for k in range(n)}},
                   k_statements, outputs)
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


#: the drivers and the extension module's wrappers
C_DRIVER = _template("driver.c.in")
#: the Jacobian's and the inverse and driven dynamics' drivers, wrappers and method
#: table entries (modules with the Jacobian only)
C_JACOBIAN = _template("jacobian.c.in")
C_JAC_METHOD = _template("jacobian_methods.c.in")
C_JAC_ENTRY = _template("jacobian_entries.c.in")


#: the driver's lines that take a state of 2N numbers, and what they become with a
#: spherical joint: x = [q (NQ), u (N)], dx/dt = [rates(t, x), acc(t, x)]
SPHERICAL_STATE = (
    ("    for (int i = 0; i < N; i++) out[i] = x[N + i];\n"
     "    if (acc(t, x, out + N)) return 1;\n"
     "    return finite_all(out, 2 * N) ? 0 : 2;\n",
     "    if (rates(t, x, out) || acc(t, x, out + NQ)) return 1;\n"
     "    return finite_all(out, NQ + N) ? 0 : 2;\n"),
    ("    if (buffer(args[1], &bx, 2 * N, 0) < 0) return NULL;\n"
     "    if (buffer(args[2], &bo, nout, 1) < 0)",
     "    if (buffer(args[1], &bx, NQ + N, 0) < 0) return NULL;\n"
     "    if (buffer(args[2], &bo, nout, 1) < 0)"),
    ("call(args, nargs, anadyn_rhs, 2 * N);", "call(args, nargs, anadyn_rhs, NQ + N);"),
)


def _spherical_driver(text: str) -> str:
    """The driver ``text`` for the state [q, u] of a robot with a spherical joint."""
    for old, new in SPHERICAL_STATE:
        if text.count(old) != 1:
            raise AssertionError(f"driver.c.in changed: {old!r}")
        text = text.replace(old, new)
    return text


def driver(jacobian: bool) -> str:
    """C_DRIVER with (``jacobian``) or without the Jacobian's parts."""
    return (C_DRIVER.replace("JACOBIAN\n", C_JACOBIAN if jacobian else "")
            .replace("JAC_METHOD\n", C_JAC_METHOD if jacobian else "")
            .replace("    JAC_ENTRY\n", C_JAC_ENTRY if jacobian else ""))
