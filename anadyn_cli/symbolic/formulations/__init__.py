"""Equations of motion by Kane's method or Lagrange's equations.

Both take the shared kinematics and return the same EquationsOfMotion;
they share nothing else.  A small system (one a person can read) is put in
canonical form (``anadyn_cli.canonical``) so that identically zero terms
vanish; a large one is left as derived, compact and shared for cse.
"""
from __future__ import annotations

import sympy as sp

from .. import kinematics
from ..canonical import canonical, fits
from ..eom import EquationsOfMotion
from ...errors import ModelError
from ...model.robot import Robot
from . import kane, lagrange

METHODS = {"kane": kane.equations, "lagrange": lagrange.equations}


def derive(robot: Robot, method: str = "kane", symbolic: bool = False,
           tidy: bool = True) -> EquationsOfMotion:
    """M(q) ddq = F(q, dq) + B(q) tau for ``robot`` by ``method``.

    Numeric parameter values are substituted before any differentiation
    unless ``symbolic``; ``tidy`` puts small entries in canonical form.
    """
    if method not in METHODS:
        raise ModelError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    eom = METHODS[method](robot, kinematics.build(robot, symbolic=symbolic))
    if tidy and fits([*eom.M, *eom.F, *eom.B]):
        eom = EquationsOfMotion(**{**eom.__dict__, "M": _tidy(eom.M, symmetric=True),
                                   "F": _tidy(eom.F), "B": _tidy(eom.B)})
    if symbolic:
        eom = EquationsOfMotion(**{**eom.__dict__, "symbolic": True})
    return eom


def _tidy(matrix: sp.ImmutableMatrix, symmetric: bool = False) -> sp.ImmutableMatrix:
    result = sp.zeros(*matrix.shape)
    for i in range(matrix.rows):
        for j in range(matrix.cols):
            if symmetric and j < i:
                result[i, j] = result[j, i]
            else:
                result[i, j] = canonical(matrix[i, j])
    return sp.ImmutableMatrix(result)
