"""Robot -> ``NumericModel``, through the derivation cache.

``numeric_model`` is the one way in, from a path, a validated ``Robot``, or
(internally) a cache entry.  Derivation and code generation need SymPy; they
are imported only on a cache miss.  On a hit, a path is read and hashed, and
the stored code and robot info are loaded: no YAML validation, no SymPy.
The cache is opt-in (``use_cache``): the command line turns it on, library
calls leave it off unless asked.
"""
from __future__ import annotations

import hashlib
import time
from pathlib import Path

from . import cache, constrained
from ..model.info import RobotInfo
from .model import NumericModel


#: formulations served by the recursive path (numeric.recursive, numeric.native)
#: unless the caller hands over closed-form equations (``eom``)
RECURSIVE = ("kane", "recursive")


def _cache_key(formulation: str, eom) -> str:
    """What the cache entry is filed under: "recursive" for the recursive path."""
    return "recursive" if formulation in RECURSIVE and eom is None else formulation


def numeric_model(robot, formulation: str = "kane", use_cache: bool = False,
                  timings: dict | None = None, eom=None, jacobian: bool = True) -> NumericModel:
    """The numeric model of ``robot`` (a path or a validated ``Robot``) by
    ``formulation``; ``eom``: the robot's equations, when the caller has them.

    "kane" (the default) and "recursive" without ``eom`` build the recursive
    path: Kane's equations evaluated by Newton-Euler recursions, O(n) code,
    native C when cached (``numeric.native``); closed chains and "lagrange"
    (or a given ``eom``) build the closed forms, with the analytic Jacobian
    unless ``jacobian`` is off (then never cached: every cached model has it)."""
    use_cache = use_cache and jacobian
    timings = {} if timings is None else timings
    if isinstance(robot, (str, Path)):
        return _from_path(robot, formulation, use_cache, timings)
    key = _cache_key(formulation, eom)
    if use_cache:
        hit = _cached(robot.digest, key, robot.source)
        if hit is not None:
            timings["cache"] = "hit"
            return hit
        timings["cache"] = "miss"
    if key == "recursive" and robot.constraints is None:
        return _recursive_model(robot, use_cache, timings)
    if formulation == "recursive":
        formulation = "kane"                        # closed chains: the closed forms
    from . import closed_form, trajectory
    from ..symbolic.formulations import derive

    if eom is None:
        start = time.perf_counter()
        eom = derive(robot, formulation)
        timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    code = closed_form.source(robot, eom, jacobian) + trajectory.motion_source(robot)
    if robot.constraints is not None:               # closed chains (numeric.constrained)
        code += constrained.source(robot, eom)
    info = RobotInfo.from_robot(robot)
    model = constrained.model_type(code)(info, code, formulation)
    timings["compile"] = time.perf_counter() - start
    if use_cache:
        cache.store(robot.digest, key, {"code": code, "robot": info.to_dict()})
    return model


def _recursive_model(robot, use_cache: bool, timings: dict) -> NumericModel:
    """Recursive path: generated Python now, the C library when cached (or built
    in the background for the next run; see ``native.mode``).  On a cold run
    the forward dynamics are traced first and compiled alone (``QuickBuild``)
    while the rest is generated: the run switches to that C when it is built."""
    from . import native, recursive, trajectory

    start = time.perf_counter()
    forward = recursive.forward(recursive.plan(robot))
    quick = native.QuickBuild.start(native.c_source(forward)) if use_cache else None
    generated = recursive.complete(forward)
    code = recursive.module_source(generated) + trajectory.motion_source(robot)
    if "def powers(" not in code:     # check's loads' power, dissipation, springs' energy
        from .closed_form import forces_source
        code += forces_source(robot)
    c_text = native.c_source(generated)
    timings["derive"] = time.perf_counter() - start       # the recursive equations
    info = RobotInfo.from_robot(robot)
    start = time.perf_counter()
    model = native.numeric_model(info, code, c_text, "recursive", timings,
                                 how=None if use_cache else "off", quick=quick)
    timings["compile"] = time.perf_counter() - start
    if use_cache:
        cache.store(robot.digest, "recursive", {"code": code, "c": c_text,
                                                "robot": info.to_dict()})
    return model


def _from_path(path: str | Path, formulation: str, use_cache: bool,
               timings: dict) -> NumericModel:
    from ..model.yamlsource import read_text

    text, source = read_text(path)
    if use_cache:
        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()
        hit = _cached(digest, _cache_key(formulation, None), source)
        if hit is not None:
            timings["cache"] = "hit"
            return hit
    from ..model import robot_from_text

    start = time.perf_counter()
    robot = robot_from_text(text, source)
    timings["load"] = time.perf_counter() - start
    return numeric_model(robot, formulation, use_cache, timings)


def _cached(digest: str, formulation: str, source: str) -> NumericModel | None:
    """The cache entry's model; None on a miss or a damaged entry."""
    entry = cache.load(digest, formulation)
    if entry is None:
        return None
    try:
        if "c" in entry:                            # the recursive path
            from . import native
            return native.numeric_model(RobotInfo.from_dict(entry["robot"], source),
                                        entry["code"], entry["c"], "recursive")
        return constrained.model_type(entry["code"])(
            RobotInfo.from_dict(entry["robot"], source), entry["code"], formulation)
    except Exception:           # noqa: BLE001  anything wrong with a stored entry is a miss
        return None
