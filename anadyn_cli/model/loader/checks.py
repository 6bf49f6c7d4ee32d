"""Whole-robot checks: every displacement, its rates and every law finite at the
initial state, and a mass matrix that is not singular everywhere."""
from __future__ import annotations

import math
import warnings

import sympy as sp

from .. import expressions, massmatrix
from ..robot import Body, Coordinate, Robot
from .cursor import Cursor


class _Checks:
    """The builder's whole-robot checks (part of ``builder._RobotBuilder``)."""

    def initial_state(self, coordinates: tuple[Coordinate, ...]) -> dict[sp.Symbol, sp.Expr]:
        state: dict[sp.Symbol, sp.Expr] = {sp.Symbol("t", real=True): sp.Integer(0)}
        for c in coordinates:
            state[c.symbol] = c.initial
            state[c.rate_symbol] = c.rate
        state.update(self.speed_initial)          # a spherical joint's speeds
        return state

    def defined_at(self, cursor: Cursor, expr: sp.Expr, state: dict, what: str) -> None:
        """``expr`` (parameters and gains given their values here) must be a
        finite real number at ``state`` (the initial state), evaluated as the
        generated code will: in floating point, term by term (so sqrt(-1)*0
        fails as it will in a run)."""
        try:         # first in double precision: exact evaluation of a huge number hangs
            expressions.approximate(expr, {**self.values, **self.gain_values, **state})
            fine = True
        except expressions.ExpressionError:
            fine = False
        expr = expr.xreplace(self.values).xreplace(self.gain_values) if fine else expr
        used = sorted(expr.free_symbols & set(state), key=str)
        if fine and _defined(expr, used, [state[s] for s in used]):
            return
        where = ", ".join(f"{s} = {float(state[s]):.6g}" for s in used)
        raise cursor.error(f"{what} is not a finite real number at the initial state "
                           f"({where or 't = 0'}); it must be defined where the motion starts")

    def check_displacements(self, bodies: tuple[Body, ...], cursors: dict[str, Cursor],
                            coordinates: tuple[Coordinate, ...]) -> None:
        state = self.initial_state(coordinates)
        for body in bodies:
            joint = body.joint
            if not joint.joint_type.axial:
                continue
            joint_value = cursors[body.name].value["joint"]
            cursor = cursors[body.name].child("joint", joint_value)
            if "displacement" in joint_value:
                cursor = cursor.child("displacement", joint_value["displacement"])
            self.defined_at(cursor, joint.displacement, state, "the displacement")
            displacement = joint.displacement.xreplace(self.values)
            for symbol in sorted(displacement.free_symbols & set(self.q.values()), key=str):
                self.defined_at(cursor, sp.diff(displacement, symbol), state,
                                f"its rate d/d{symbol}")

    def check_mass_matrix(self, robot: Robot, cursor: Cursor,
                          items: dict[str, Cursor]) -> None:
        if robot.spherical:      # the check's recursion knows one speed per coordinate;
            return               # the forward dynamics refuse a singular M (ABA, Cholesky)
        initial = [float(c.initial) for c in robot.coordinates]
        motion = massmatrix.singular_everywhere(robot, initial)
        if motion is None:
            return
        names = [c.name for c in robot.coordinates]
        moving = [(name, v) for name, v in zip(names, motion) if abs(v) > 1e-6]
        where = (f"the mass matrix is singular at the initial state and at "
                 f"{massmatrix.RANDOM_STATES} random states")
        if len(moving) == 1:
            name = moving[0][0]
            raise items[name].error(
                f"moving {name} moves no mass ({where}); every coordinate must move a body "
                "with mass off the joint axis or with inertia about it")
        ratio = " : ".join(f"{v:.3g}" for _, v in moving)
        raise cursor.error(
            f"moving {', '.join(n for n, _ in moving)} with rates in the ratio {ratio} moves "
            f"no mass ({where}); the coordinates must be independent: no combination of "
            "them may leave every body at rest")


def _defined(expr: sp.Expr, symbols: list, values: list) -> bool:
    """Whether ``expr`` at ``symbols = values`` is a finite real number, in
    floating point with ``math`` (as the generated code computes it)."""
    try:
        exact = expr.xreplace(dict(zip(symbols, values)))
        number = complex(exact.evalf())
    except (TypeError, ValueError, ArithmeticError, RecursionError):
        return False
    if number.imag != 0 or not math.isfinite(number.real):
        return False
    try:   # SymPy's own printer on an expression built from the whitelist: no file text
        function = sp.lambdify(symbols, expr, modules="math")
    except Exception:               # noqa: BLE001 (a form the printer lacks: exact check only)
        return True
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            number = complex(function(*(float(v) for v in values)))
    except (TypeError, ValueError, ArithmeticError, RecursionError):
        return False
    return number.imag == 0 and math.isfinite(number.real)
