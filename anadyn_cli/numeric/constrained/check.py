"""The constraint Jacobian's conditioning and the drift along a path, for
``check`` (and the drift of a run, for ``accuracy``)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .dynamics import ConstrainedModel

DEAD_POINT = 100.0            # |A_h| / sigma_min(A_h,d) above this: near a dead point, warn


@dataclass
class ConstraintCheck:
    """The constraint Jacobian's conditioning and the drift along a checked path."""
    t: np.ndarray
    condition: np.ndarray         # cond(A) per row checked
    dead: np.ndarray              # |A_h| / sigma_min(A_h,d) per row (constraint_conditions)
    position_drift: np.ndarray
    velocity_drift: np.ndarray
    dependent: tuple[str, ...]    # the file's dependent coordinates
    stabilization: float

    def worst(self, values: np.ndarray) -> tuple[float, float]:
        k = int(np.nanargmax(values)) if np.isfinite(values).any() else 0
        return float(values[k]), float(self.t[k])

    def line(self) -> str:
        cond, at = self.worst(self.condition)
        dead, dead_at = self.worst(self.dead)
        distance = (f"dead-point measure |A_h| / sigma_min(dA_h/d({', '.join(self.dependent)}))"
                    f" up to {dead:.3g} (t = {dead_at:.4g} s); " if self.dependent else "")
        return (f"constraints: Jacobian condition number up to {cond:.3g} (t = {at:.4g} s); "
                f"{distance}drift up to "
                f"{float(self.position_drift.max(initial=0.0)):.2e} in position, "
                f"{float(self.velocity_drift.max(initial=0.0)):.2e} in velocity "
                f"(stabilized at {self.stabilization:g} 1/s)")

    def summary(self) -> dict:
        cond, at = self.worst(self.condition)
        dead, dead_at = self.worst(self.dead)
        return {"jacobian_condition": cond, "jacobian_condition_t": at,
                "dependent_condition": dead, "dependent_condition_t": dead_at,
                "max_position_drift": float(self.position_drift.max(initial=0.0)),
                "max_velocity_drift": float(self.velocity_drift.max(initial=0.0)),
                "stabilization": self.stabilization}


def conditioning(model: ConstrainedModel, t: np.ndarray, x: np.ndarray,
                 rows: int = 20_000) -> ConstraintCheck:
    """cond(A), cond(A_d) and the drift at up to ``rows`` rows of a path."""
    index = np.arange(0, len(t), max(1, math.ceil(len(t) / rows)))
    condition, dead = np.empty(len(index)), np.empty(len(index))
    position, velocity = np.empty(len(index)), np.empty(len(index))
    for j, k in enumerate(index):
        condition[j], dead[j] = model.constraint_conditions(float(t[k]), x[k])
        f, g = model.residuals(float(t[k]), x[k])
        position[j] = float(np.abs(f).max(initial=0.0))
        velocity[j] = float(np.abs(g).max(initial=0.0))
    names = tuple(model.info.coordinates[k].name for k in model.dependent)
    return ConstraintCheck(t[index], condition, dead, position, velocity, names,
                           model.stabilization)


def drift(model: ConstrainedModel, t: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """(largest |f|, largest |A dq + a0|) over the rows of a run."""
    position = velocity = 0.0
    for k in range(len(t)):
        f, g = model.residuals(float(t[k]), x[k])
        position = max(position, float(np.abs(f).max(initial=0.0)))
        velocity = max(velocity, float(np.abs(g).max(initial=0.0)))
    return position, velocity
