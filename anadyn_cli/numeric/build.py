"""Robot -> compiled numeric functions, through the derivation cache.

Derivation and code generation need SymPy; they are imported only on a
cache miss.  On a hit, ``prepare`` reads the file, hashes it and loads the
stored code and robot info: no YAML validation, no SymPy.
"""
from __future__ import annotations

import hashlib
import time
from pathlib import Path

from . import cache
from .model import CompiledRobot
from ..model.info import RobotInfo


def compile_robot(robot, formulation: str = "kane", timings: dict | None = None,
                  use_cache: bool = True, eom=None) -> CompiledRobot:
    """The numeric functions of ``robot``'s equations by ``formulation``
    (``eom``: those equations, when the caller has derived them already)."""
    timings = {} if timings is None else timings
    if use_cache:
        hit = _cached(robot.digest, formulation, robot.source)
        if hit is not None:
            timings["cache"] = "hit"
            return hit[1]
        timings["cache"] = "miss"
    from . import closed_form
    from ..symbolic.formulations import derive

    if eom is None:
        start = time.perf_counter()
        eom = derive(robot, formulation)
        timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    code = closed_form.source(robot, eom)
    compiled = CompiledRobot(code)
    timings["compile"] = time.perf_counter() - start
    if use_cache:
        cache.store(robot.digest, formulation,
                    {"code": code, "robot": RobotInfo.from_robot(robot).to_dict()})
    return compiled


def prepare(path: str | Path, formulation: str = "kane", use_cache: bool = True,
            timings: dict | None = None) -> tuple[RobotInfo, CompiledRobot]:
    """Robot info and compiled functions for the file at ``path``."""
    from ..model.yamlsource import read_text

    timings = {} if timings is None else timings
    text, source = read_text(path)
    if use_cache:
        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()
        hit = _cached(digest, formulation, source)
        if hit is not None:
            timings["cache"] = "hit"
            return hit
    from ..model import robot_from_text

    start = time.perf_counter()
    robot = robot_from_text(text, source)
    timings["load"] = time.perf_counter() - start
    compiled = compile_robot(robot, formulation, timings, use_cache)
    return RobotInfo.from_robot(robot), compiled


def _cached(digest: str, formulation: str, source: str) -> tuple[RobotInfo, CompiledRobot] | None:
    """The cache entry's robot info and functions; None on a miss or a damaged entry."""
    entry = cache.load(digest, formulation)
    if entry is None:
        return None
    try:
        return RobotInfo.from_dict(entry["robot"], source), CompiledRobot(entry["code"])
    except Exception:           # noqa: BLE001  anything wrong with a stored entry is a miss
        return None
