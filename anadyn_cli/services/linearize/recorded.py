"""A robot as a cold run's kernel record holds it (``generic.Record``): what a
linearization reads of a ``Robot`` (its names, units, initial state and actuators)
and the numeric tables the generic kernel computes it from, so that a run after
the first linearizes with no robot file parsed, no robot built and no plan made
(``serves`` says which records will do; ``recursive.road`` gives their
``KernelEquations``).  The numbers are those of the robot read anew: the same
tables through the same kernel."""
from __future__ import annotations

import sympy as sp

from ...model.robot import Coordinate, Speed


def serves(record) -> bool:
    """Whether ``record`` holds all a linearization reads of its robot: no control
    laws (their symbolic Jacobian needs the robot), no parameters (``at`` may name
    them, and its values are exact), no spherical joint (its road is the closed
    forms')."""
    return (not record.info.has_controller and record.parameters == ()
            and not record.layout.quaternions)


class RecordedRobot:
    """The ``Robot`` interface a linearization uses, from a ``generic.Record`` that
    ``serves``: an open tree of revolute and prismatic joints without contacts,
    loads, controller or parameters (the kernel's tables refuse the first ones).
    The initial values are the record's floats, which are those of the robot."""
    controller = constraints = contacts = None
    spherical = False

    def __init__(self, record):
        info = record.info
        self.record = record
        self.name, self.source, self.digest = info.name, info.source, info.digest
        self.coordinates = tuple(Coordinate(c.name, sp.Float(c.initial), sp.Float(c.rate), c.unit)
                                 for c in info.coordinates)
        self.speeds = tuple(Speed(c.rate_symbol.name, c.rate, f"{c.unit}/s")
                            for c in self.coordinates)
        self.actuators = info.actuators
        self.q = tuple(c.symbol for c in self.coordinates)
        self.dq = tuple(c.rate_symbol for c in self.coordinates)

    def parameter_substitution(self, symbolic: bool = False) -> dict:
        return {}

    def refuse_contacts(self, what: str) -> None:
        """Nothing to refuse: the kernel's tables hold no contacts."""
