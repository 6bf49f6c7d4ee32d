"""Code generation of a constrained robot: ``source``, the constraint functions
appended to the tree's generated module after ``MARKER`` (see the package
docstring for what they give).  SymPy is imported inside ``source``."""
from __future__ import annotations

MARKER = "# -- constraints (anadyn_cli.numeric.constrained) --"


def source(robot, eom) -> str:
    """Source of the constraint functions, appended to the tree's generated module."""
    import sympy as sp

    from ..closed_form import control_laws
    from ..codegen import Function, module_source
    from ...symbolic import constraints as equations, kinematics

    kin = kinematics.build(robot, symbolic=eom.symbolic)
    cons = equations.build(robot, kin)
    t = sp.Symbol("t", real=True)
    q, dq = list(eom.q), list(eom.dq)
    state = (t, *q, *dq)
    c, h = cons.count, cons.holonomic
    f = list(cons.f) if h else []
    functions = [
        Function("constrained_terms", state,
                 (("M", sp.Matrix(eom.M)), ("F", list(eom.F)),
                  ("B", sp.Matrix(eom.B) if eom.B.cols else sp.zeros(len(q), 0)),
                  ("tau", list(control_laws(robot))), ("A", sp.Matrix(cons.A)), ("f", f),
                  ("g", list(cons.velocity_residual)), ("b", list(cons.b))), False,
                 "M, F, B, tau (control laws), A, f (holonomic residuals), "
                 "g = A dq + a0, b (A ddq = b)."),
        Function("pfaffian", (t, *q), (("A", sp.Matrix(cons.A)), ("a0", list(cons.a0)),
                                      ("f", f)), False,
                 "A, a0 (A dq + a0 = 0) and f (holonomic residuals)."),
        Function("acceleration_bias", state, (("b", list(cons.b)),), False,
                 "b with A ddq = b."),
    ]
    closing = robot.constraints
    names = [cc.name for cc in robot.coordinates]
    rows = tuple((r.column, r.source, r.kind, r.meaning, r.unit) for r in closing.rows)
    text = module_source(functions, MARKER + f"\n{c} constraint equations, {h} holonomic")
    constants = (f"CONSTRAINT_ROWS = {rows!r}\n"
                 f"HOLONOMIC = {h!r}\n"
                 f"DEPENDENT = {tuple(names.index(d) for d in closing.dependent)!r}\n"
                 f"DEPENDENT_SPEEDS = "
                 f"{tuple(names.index(d) for d in closing.dependent_speeds)!r}\n")
    return "\n" + text + "\n" + constants
