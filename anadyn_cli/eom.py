"""The one contract between the formulations and everything else:

    M(q) ddq = F(q, dq) + B(q) tau

M is n x n, F is n x 1 (gravity and velocity-product terms), B is n x m
(actuator efforts tau, in the order of the robot's actuators).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp


@dataclass(frozen=True)
class EquationsOfMotion:
    method: str                          # "kane" or "lagrange"
    q: tuple[sp.Symbol, ...]
    dq: tuple[sp.Symbol, ...]
    ddq: tuple[sp.Symbol, ...]
    efforts: tuple[sp.Symbol, ...]       # tau, one symbol per actuator
    M: sp.ImmutableMatrix
    F: sp.ImmutableMatrix
    B: sp.ImmutableMatrix
    symbolic: bool = False               # parameters left as symbols

    @property
    def residuals(self) -> list[sp.Expr]:
        """Left-hand sides of ``M ddq - F - B tau = 0``, one per coordinate."""
        lhs = self.M * sp.Matrix(self.ddq) - self.F - self.B * sp.Matrix(self.efforts)
        return list(lhs)

    @property
    def parameters(self) -> set[sp.Symbol]:
        """Symbols other than q, dq, tau (non-empty only when symbolic)."""
        known = set(self.q) | set(self.dq) | set(self.efforts)
        found: set[sp.Symbol] = set()
        for matrix in (self.M, self.F, self.B):
            found |= matrix.free_symbols
        return found - known
