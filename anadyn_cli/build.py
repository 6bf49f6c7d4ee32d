"""Robot -> compiled numeric functions, timing each stage.

Derivation and code generation need SymPy; they are imported only here and
only when the compiled source is not already at hand.
"""
from __future__ import annotations

import time

from .compiled import CompiledRobot
from .model.robot import Robot


def compile_robot(robot: Robot, formulation: str = "kane",
                  timings: dict | None = None) -> CompiledRobot:
    """The numeric functions of ``robot``'s equations by ``formulation``."""
    from . import numeric
    from .formulations import derive

    timings = {} if timings is None else timings
    start = time.perf_counter()
    eom = derive(robot, formulation)
    timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    compiled = CompiledRobot(numeric.source(robot, eom))
    timings["compile"] = time.perf_counter() - start
    return compiled
