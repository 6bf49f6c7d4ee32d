"""What closes a chain, as data: loops (points that coincide along world axes),
position constraints f(q, t) = 0, velocity constraints sum_k a_k dq_k + a_0 = 0, and
the rows of their multipliers (holonomic first)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import sympy as sp

DIRECTIONS = ("x", "y", "z")
TIME = sp.Symbol("t", real=True)


@dataclass(frozen=True)
class LoopPoint:
    body: str                     # a body name or GROUND
    point: tuple                  # body axes (world axes for ground), m


@dataclass(frozen=True)
class Loop:
    a: LoopPoint
    b: LoopPoint
    directions: tuple[str, ...]   # world axes along which the points coincide
    name: str
    path: str                     # "loops[0]", for messages


@dataclass(frozen=True)
class PositionConstraint:
    expression: sp.Expr           # f(q, t), parameters as symbols
    name: str
    path: str


@dataclass(frozen=True)
class VelocityConstraint:
    coefficients: Mapping[str, sp.Expr]   # coordinate name -> a_k(q, t)
    constant: sp.Expr                     # a_0(q, t)
    name: str
    path: str


@dataclass(frozen=True)
class Row:
    """One constraint equation: its multiplier's CSV column, what it is, its unit."""
    column: str                   # e.g. lambda_loop1_x
    source: str                   # "loops[0]", "constraints[1]"
    kind: str                     # "loop", "position", "velocity"
    meaning: str
    unit: str                     # of the multiplier (N for a loop)


@dataclass(frozen=True)
class Constraints:
    """Everything that closes the chain; rows are ordered holonomic first (loops in
    file order, then position entries), then the velocity entries."""
    loops: tuple[Loop, ...]
    positions: tuple[PositionConstraint, ...]
    velocities: tuple[VelocityConstraint, ...]
    dependent: tuple[str, ...]            # coordinates solved from f = 0, file order
    dependent_speeds: tuple[str, ...]     # rates solved from A dq + a0 = 0: the dependent
    #                                       coordinates', then one per velocity constraint
    rows: tuple[Row, ...]

    @property
    def holonomic(self) -> int:
        return sum(len(loop.directions) for loop in self.loops) + len(self.positions)

    @property
    def count(self) -> int:
        return self.holonomic + len(self.velocities)

