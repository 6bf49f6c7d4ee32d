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

FORMULATIONS = {"kane": kane.equations, "lagrange": lagrange.equations}


def derive(robot: Robot, formulation: str = "kane", symbolic: bool = False,
           tidy: bool = True) -> EquationsOfMotion:
    """M(q) ddq = F(t, q, dq) + B(q) tau for ``robot`` by ``formulation``, in the
    generalized speeds (with a spherical joint M du = F(t, q, u) + B tau and the
    kinematic differential equations dq = W(q) u, ``EquationsOfMotion.kinematic``).

    Numeric parameter values are substituted before any differentiation
    unless ``symbolic``; ``tidy`` puts small entries in canonical form.
    """
    if formulation not in FORMULATIONS:
        raise ModelError(f"unknown formulation {formulation!r}; choose one of "
                         f"{', '.join(FORMULATIONS)}")
    from ... import progress

    with progress.task(f"deriving {formulation} equations of {robot.name}"):
        kin = kinematics.build(robot, symbolic=symbolic, rates=formulation == "lagrange")
        eom = FORMULATIONS[formulation](robot, kin)
    if tidy and fits([*eom.M, *eom.F, *eom.B]):
        if eom.Q is None:
            F, Q = _tidy(eom.F), None
        else:       # the rest of F and Q each in canonical form, so Q can be shown apart
            Q = _tidy(eom.Q)
            F = sp.ImmutableMatrix(_tidy(sp.ImmutableMatrix(eom.F - eom.Q)) + Q)
        eom = EquationsOfMotion(**{**eom.__dict__, "M": _tidy(eom.M, symmetric=True),
                                   "F": F, "B": _tidy(eom.B), "Q": Q})
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
