"""Three-vector algebra on traced expressions (``ir.Ex``), SymPy -> Ex, and the
projections on a joint's motion subspace that every recursion shares.

A vector is a list of three Ex; a 3x3 matrix a list of three rows.  A motion
subspace S is a pair (angular, linear) of vectors (``model.joints``:
``subspace``), a part None where the joint allows no motion of that kind.
"""
from __future__ import annotations

import sympy as sp

from ..ir import ONE, ZERO, Ex, Program, as_expr

Vec = list  # three Ex


def cross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a: Vec, b: Vec) -> Ex:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def add(*vectors: Vec) -> Vec:
    return [sum((v[k] for v in vectors), ZERO) for k in range(3)]


def sub(a: Vec, b: Vec) -> Vec:
    return [a[k] - b[k] for k in range(3)]


def scale(a: Vec, s) -> Vec:
    return [x * s for x in a]


def matvec(E, v: Vec) -> Vec:
    return [E[i][0] * v[0] + E[i][1] * v[1] + E[i][2] * v[2] for i in range(3)]


def matTvec(E, v: Vec) -> Vec:
    return [E[0][i] * v[0] + E[1][i] * v[1] + E[2][i] * v[2] for i in range(3)]


def emitv(P: Program, v: Vec) -> Vec:
    return [P.emit(x) for x in v]


def const_vec(values) -> Vec:
    return [Ex.const(float(v)) for v in values]


def skew(v) -> list[list[float]]:
    """[v]x, floats."""
    return [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]


def skew_ex(v: Vec) -> list[list[Ex]]:
    """[v]x, Ex."""
    return [[ZERO, -v[2], v[1]], [v[2], ZERO, -v[0]], [-v[1], v[0], ZERO]]


def product(P: Program, A, B, transpose_B: bool = False) -> list[list[Ex]]:
    """A B, or A B^T (3 x 3, entries emitted)."""
    return [[P.emit(sum((A[r][k] * (B[c][k] if transpose_B else B[k][c]) for k in range(3)),
                        ZERO)) for c in range(3)] for r in range(3)]


def congruence(P: Program, A, E, symmetric: bool):
    """E^T A E (entries emitted; symmetric: the upper triangle, mirrored)."""
    AE = product(P, A, E)
    out = [[None] * 3 for _ in range(3)]
    for r in range(3):
        for c in range(3):
            if symmetric and c < r:
                out[r][c] = out[c][r]
            else:
                out[r][c] = P.emit(sum((E[k][r] * AE[k][c] for k in range(3)), ZERO))
    return out


def rotation_transpose(P: Program, axis, theta: Ex) -> list[list[Ex]]:
    """Rot(a, theta)^T = c 1 - s [a]x + (1 - c) a a^T (entries emitted; ``axis`` floats)."""
    c, s = P.call("cos", theta), P.call("sin", theta)
    a, k = axis, skew(axis)
    RT = [[(c if i == j else ZERO) - s * k[i][j] + (ONE - c) * (a[i] * a[j])
           for j in range(3)] for i in range(3)]
    return [[P.emit(x) for x in row] for row in RT]


# motion subspaces ---------------------------------------------------------------

def combine(*parts: Vec | None) -> Vec:
    """The sum of the parts that are not None (one part: itself)."""
    present = [p for p in parts if p is not None]
    return present[0] if len(present) == 1 else add(*present)


def columns(body) -> list[tuple[Vec | None, Vec | None]]:
    """The motion subspace S of ``body``'s joint (a ``plan.BodyPlan``), one (angular,
    linear) pair of Ex vectors per joint speed (``joints.JointType.columns``)."""
    return [(None if s is None else const_vec(s), None if v is None else const_vec(v))
            for s, v in body.joint_type.columns(body.axis)]


def project(angular: Vec | None, linear: Vec | None, n: Vec, f: Vec) -> Ex:
    """S^T (n, f) = angular . n + linear . f, the parts present."""
    if linear is None:
        return dot(angular, n)
    if angular is None:
        return dot(linear, f)
    return dot(angular, n) + dot(linear, f)


# SymPy -> Ex ---------------------------------------------------------------------

_CALLS = {sp.sin: "sin", sp.cos: "cos", sp.tanh: "tanh"}


def to_ex(P: Program, e) -> Ex:
    """A SymPy expression of the internal symbols as an Ex: sums, products, integer
    powers, sin, cos, tanh and sqrt are traced; anything else is one SymPy statement."""
    e = as_expr(e)
    if e.is_number:
        return Ex.const(float(e))
    if isinstance(e, sp.Symbol):
        return Ex.atom(e.name)
    if isinstance(e, sp.Add):
        return sum((to_ex(P, a) for a in e.args), ZERO)
    if isinstance(e, sp.Mul):
        result = ONE
        for a in e.args:
            result = result * to_ex(P, a)
        return result
    if isinstance(e, sp.Pow) and e.exp.is_Integer and 1 <= int(e.exp) <= 4:
        base = P.emit(to_ex(P, e.base))
        result = base
        for _ in range(int(e.exp) - 1):
            result = P.emit(result * base)
        return result
    if isinstance(e, sp.Pow) and e.exp == -1:
        return P.call("recip", P.emit(to_ex(P, e.base)))
    if isinstance(e, sp.Pow) and e.exp == sp.Rational(1, 2):
        return P.call("sqrt", P.emit(to_ex(P, e.base)))
    if type(e) in _CALLS:
        return P.call(_CALLS[type(e)], P.emit(to_ex(P, e.args[0])))
    return P.sympy(e)
