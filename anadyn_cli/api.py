"""The Python API: the domain's verbs over the library, for scripts and notebooks.

    import anadyn
    robot = anadyn.load("rr")                  # a path (YAML or URDF), or a library name
    eom = anadyn.derive(robot, "lagrange")     # M(q) ddq = F(t, q, dq) + B(q) tau
    run = anadyn.simulate(robot, t_end=5)      # rows are times: run.t, run.x, run.efforts
    run.to_csv("rr.csv"); run.figure()         # a Matplotlib Figure; no backend switched
    inv = anadyn.inverse(robot)                # efforts along the file's trajectory
    anadyn.compare(robot).passed               # Lagrange against Kane

Every function takes a robot as a path, a library name, a validated
``Robot`` or (simulate, inverse, check) an already built ``NumericModel``.
The derivation cache is off unless ``cache=True``; nothing is printed and no
file is written unless asked (``to_csv``).
"""
from __future__ import annotations

from pathlib import Path


def load(robot):
    """The validated ``Robot`` for a file path (YAML or URDF) or a library name."""
    from .model import load_robot

    return robot if _is_robot(robot) else load_robot(robot)


def derive(robot, formulation: str = "kane", symbolic: bool = False):
    """The ``EquationsOfMotion`` of ``robot`` by ``formulation`` ("kane" or "lagrange");
    ``symbolic`` keeps the parameters as symbols."""
    from .symbolic.formulations import derive as derive_equations

    return derive_equations(load(robot), formulation, symbolic=symbolic)


def numeric_model(robot, formulation: str = "kane", cache: bool = False):
    """The compiled ``NumericModel`` of ``robot`` (the input of the numeric services)."""
    from .numeric.build import numeric_model as build
    from .numeric.model import NumericModel

    if isinstance(robot, NumericModel):
        return robot
    return build(robot if _is_robot(robot) else _path(robot), formulation, use_cache=cache)


def simulate(robot, formulation: str = "kane", cache: bool = False, **settings):
    """Direct dynamics under the file's control laws; ``settings``: method, rtol, atol,
    t_end, output_step, estimate_error.  A failed run is returned, not raised
    (``result.solution.success``)."""
    from .services.simulate import simulate as run

    return run(numeric_model(robot, formulation, cache), **settings)


def inverse(robot, formulation: str = "kane", cache: bool = False, **settings):
    """Efforts along the file's trajectory; ``settings``: step, roundtrip, tolerance,
    segment."""
    from .services.inverse import inverse as run

    return run(numeric_model(robot, formulation, cache), **settings)


def check(robot, formulation: str = "kane", cache: bool = False, **settings):
    """Stability report: eigenvalues, conditioning, energy balance."""
    from .services.check import check as run

    return run(numeric_model(robot, formulation, cache), **settings)


def compare(*robots, **settings):
    """Lagrange against Kane on each robot: symbolic, numeric and trajectory checks."""
    from .services.compare import compare as run

    return run([load(r) for r in robots], **settings)


def _is_robot(value) -> bool:
    from .model.robot import Robot

    return isinstance(value, Robot)


def _path(value) -> Path:
    return value if isinstance(value, Path) else Path(str(value))
