"""The numeric model of a bindable module (``numeric.bindable``): NumPy only.

Workers of a sweep import this, never SymPy: the module they receive is
already generated.  ``bind(values)`` sets the free names (module globals of
the generated code) for the calls that follow, so one ``BoundModel`` must
not be bound from two threads at once: executors give each thread its own.
"""
from __future__ import annotations

import numpy as np

from ..model.info import RobotInfo
from .model import NumericModel, PrescribedMotion


class BoundModel(NumericModel):
    """A ``NumericModel`` whose free names are set by ``bind`` (see the module)."""

    def __init__(self, info: RobotInfo, source: str, formulation: str = "kane"):
        super().__init__(info, source, formulation)
        namespace = self._accelerations.__globals__      # the generated module
        self.parameters: tuple[str, ...] = namespace["PARAMETERS"]
        self.inertial_bodies: tuple[str, ...] = namespace["INERTIAL_BODIES"]
        #: bodies whose inertia the file exempts from the triangle inequality
        self.triangle_unchecked = frozenset(namespace.get("TRIANGLE_UNCHECKED", ()))
        self._bind, self._start = namespace["bind"], namespace["start"]
        self._inertial = namespace["inertial"]
        self._motion_function = namespace.get("motion")
        self._duration = namespace.get("duration")
        self._kind = namespace["TRAJECTORY"][0] if "TRAJECTORY" in namespace else None
        self.values: tuple[float, ...] | None = None

    def bind(self, values) -> "BoundModel":
        values = tuple(float(v) for v in values)
        if len(values) != len(self.parameters):
            raise ValueError(f"{len(values)} values for {len(self.parameters)} parameters")
        self._bind(values)
        self.values = values
        return self

    def initial_state(self) -> np.ndarray:
        with np.errstate(all="ignore"):
            return np.asarray(self._start(), dtype=float)

    def inertial(self) -> list[tuple[str, float, np.ndarray]]:
        """(body, mass, inertia 3x3) of the bodies whose mass properties are bound."""
        with np.errstate(all="ignore"):
            mass, inertia = self._inertial()
        return [(name, float(mass[k]), np.asarray(inertia[9 * k: 9 * k + 9]).reshape(3, 3))
                for k, name in enumerate(self.inertial_bodies)]

    @property
    def motion(self) -> PrescribedMotion:
        """The prescribed motion at the bound values (ModelError without a trajectory)."""
        if self._duration is None:
            return super().motion
        return PrescribedMotion(self._kind, self.duration(), self._motion_function)

    def duration(self) -> float:
        """Duration of the prescribed motion at the bound values, s."""
        with np.errstate(all="ignore"):
            return float(self._duration()[0])
