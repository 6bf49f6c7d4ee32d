"""Closed chains and constraints in a robot file: what they say, checked, and a
consistent start.

A closed chain is written as a tree (one joint of each loop cut) plus what
closes it; the coordinates marked ``dependent: true`` are solved for:

    coordinates.Q.dependent   true: Q follows from the constraints; its
                              ``initial`` is a guess (it picks the assembly mode)
    loops[i]                  {a: {body, point}, b: {body | ground, point},
                               directions: [x, y, z], name}: point a of body A
                              and point b of body B (or of the world) coincide
                              along the listed world axes
    constraints[i]            {position: f(q, t)}:  f = 0 (holonomic), or
                              {velocity: {dQ: a_Q, ..., t: a_0}}:
                              sum_k a_k dq_k + a_0 = 0 (nonholonomic, eq. 6.8),
                              with a_k, a_0 expressions of q and t; ``name``
                              optional in both

Holonomic equations f(q, t) = 0 (h of them): a loop gives
(r_a - r_b) . e for each listed world axis e, r the world position of the
point; a position entry gives its expression.  The degrees of freedom of the
configuration are n - h, and exactly h coordinates must be marked dependent.
Velocity entries (p of them) take further speeds away but no coordinate.

What is checked here, each with one line naming the file, line and key:
unknown bodies, coordinates and keys; loops joining a body to itself;
the count of dependent coordinates against the holonomic equations (the
message names both counts); redundant equations (rank of the constraint
Jacobian at random configurations; a direction along which the points never
move apart is named as such); inconsistent ones (a direction along which
they are apart whatever the coordinates; a loop that cannot close at the
start); a start at a dead point (dependent coordinates not determined by the
independent ones); initial rates that break the constraints; trajectories
that prescribe a dependent coordinate.

The consistent start: the dependent coordinates are solved from f(q, 0) = 0
by Newton's method from their guesses, the independent ones held (the
Jacobian by central differences; the residual itself is exact, so the result
is as accurate as f can be evaluated).  Then the rates: the dependent
coordinates' rates and, for each velocity constraint, one more (the rate
left out of the file, else given, with the largest coefficient) are solved
from A dq + a_0 = 0; a rate the file gives for one of them must agree.  The
robot then carries the solved values as the coordinates' initial values and
rates, so every run starts on the constraints.

This module computes positions by its own forward kinematics in floating
point (like ``massmatrix``), not by ``symbolic.kinematics``: the loader runs
before any symbolic work.
"""
from __future__ import annotations

from ...errors import ModelError
from .equations import Constraints, Loop, LoopPoint, PositionConstraint, Row, VelocityConstraint
from .geometry import Geometry
from .reading import build, wanted
from .start import random_states

__all__ = ["Constraints", "Loop", "LoopPoint", "PositionConstraint", "Row",
           "VelocityConstraint", "Geometry", "build", "wanted", "random_states",
           "refuse_closed_chain"]


def refuse_closed_chain(robot, command: str) -> None:
    """Closed chains are refused: their reduced equations are not M ddq = F + B tau in
    the coordinates, and exporting the cut tree would be silently wrong."""
    if getattr(robot, "constraints", None) is not None:
        raise ModelError(f"{robot.source}: {robot.name} has constraints (closed loops); "
                         f"{command} handles open chains only")
