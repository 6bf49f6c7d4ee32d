"""CasADi export: ``casadi.Function``s built from anadyn's traced statements.

``functions(traced)`` builds, for the functions of ``traced`` (forward and inverse
dynamics, the mass matrix), CasADi SX expression graphs by walking the
straight-line statements one by one (sums of products, sin/cos/sqrt/tanh, 1/x,
and the SymPy statements of control-free loads or nonlinear displacements
translated node by node); nothing calls NumPy or anadyn at evaluation time, so
CasADi differentiates them (``jacobian``, ``hessian``) and generates C from
them.  ``files`` serializes each (``Function.serialize``) as
``NAME_FUNCTION.casadi``, which ``casadi.Function.deserialize(text)`` reads
with no anadyn installed.  The Cholesky pivot
checks of the traced code are dropped: a singular M gives NaN or inf.
CasADi is an optional extra (``pip install anadyn[casadi]``).
"""
from __future__ import annotations

import operator
from functools import reduce

import sympy as sp

from ...errors import ModelError
from .traced import Function, Traced

#: CasADi's names of the call statements' functions
CALLS = {"sin": "sin", "cos": "cos", "sqrt": "sqrt", "tanh": "tanh"}

#: SymPy function -> CasADi function name (n-ary Min/Max folded pairwise)
SYMPY_CALLS = {sp.sin: "sin", sp.cos: "cos", sp.tan: "tan", sp.asin: "asin", sp.acos: "acos",
               sp.atan: "atan", sp.exp: "exp", sp.log: "log", sp.tanh: "tanh",
               sp.sinh: "sinh", sp.cosh: "cosh", sp.Abs: "fabs", sp.sign: "sign",
               sp.atan2: "atan2", sp.Min: "fmin", sp.Max: "fmax"}
RELATIONS = {sp.StrictLessThan: operator.lt, sp.LessThan: operator.le,
             sp.StrictGreaterThan: operator.gt, sp.GreaterThan: operator.ge,
             sp.Equality: operator.eq, sp.Unequality: operator.ne}


def require():
    """The casadi module, or ModelError naming the extra to install."""
    try:
        import casadi
    except ImportError:
        raise ModelError("CasADi is not installed; pip install 'anadyn[casadi]' (or casadi)"
                         ) from None
    return casadi


def _sympy(ca, expr, env: dict):
    """A SymPy expression of atoms as a CasADi SX (ModelError: no CasADi form)."""
    if isinstance(expr, sp.Symbol):
        return env[expr.name]
    if expr.is_Number or expr in (sp.pi, sp.E):
        return float(expr)
    if expr in (sp.true, sp.false):
        return 1.0 if expr == sp.true else 0.0
    if isinstance(expr, sp.Piecewise):      # no branch true: NaN, as SymPy's undefined
        result = ca.SX.nan()
        for value, condition in reversed(expr.args):
            result = ca.if_else(_sympy(ca, condition, env), _sympy(ca, value, env), result)
        return result
    args = [_sympy(ca, a, env) for a in expr.args]
    if isinstance(expr, sp.Add):
        return reduce(operator.add, args)
    if isinstance(expr, sp.Mul):
        return reduce(operator.mul, args)
    if isinstance(expr, sp.Pow):
        return args[0] ** args[1]
    if expr.func in RELATIONS:
        return RELATIONS[expr.func](args[0], args[1])
    if isinstance(expr, sp.And):
        return reduce(ca.logic_and, args)
    if isinstance(expr, sp.Or):
        return reduce(ca.logic_or, args)
    if isinstance(expr, sp.Not):
        return ca.logic_not(args[0])
    if expr.func in SYMPY_CALLS:
        function = getattr(ca, SYMPY_CALLS[expr.func])
        return function(*args) if len(args) <= 2 else reduce(function, args)
    raise ModelError(f"no CasADi form for {expr.func.__name__} in {expr}")


def _build(ca, function: Function) -> object:
    """``function`` as a casadi.Function of SX, by walking its statements."""
    inputs, env = [], {}
    for arg, size in function.args:
        symbol = ca.SX.sym(arg, size)
        inputs.append(symbol)
        env.update({atom: symbol[k] for k, atom in enumerate(function.atoms(arg, size))})

    def value(terms: dict):
        return reduce(operator.add, (coef * reduce(operator.mul, (env[a] for a in mono), 1.0)
                                     for mono, coef in terms.items()), ca.SX(0.0))

    for s in function.statements:
        if s.kind == "sum":
            env[s.name] = value(s.payload)
        elif s.kind == "call":
            name, atom = s.payload
            env[s.name] = (1.0 / env[atom] if name == "recip"
                           else getattr(ca, CALLS[name])(env[atom]))
        elif s.kind == "sympy":
            env[s.name] = _sympy(ca, s.payload, env)
    out = ca.vertcat(*[value(x.terms) for x in function.outputs])
    if len(function.shape) == 2:
        rows, cols = function.shape
        out = ca.reshape(out, cols, rows).T         # outputs are row-major
    names = [arg for arg, _ in function.args]
    return ca.Function(function.name, inputs, [out], names, [function.output])


def functions(traced: Traced) -> dict:
    """name -> casadi.Function for every function of ``traced``."""
    ca = require()
    return {name: _build(ca, f) for name, f in traced.functions.items()}


def files(traced: Traced) -> dict[str, str]:
    """{"NAME_FUNCTION.casadi": serialized casadi.Function} (``Function.deserialize``)."""
    return {f"{traced.robot_name}_{name}.casadi": f.serialize()
            for name, f in functions(traced).items()}
