"""What the API's functions share: settings left at None, a pose as items, and a robot
given as a path, a library name or a validated ``Robot``."""
from __future__ import annotations

from pathlib import Path
from typing import Mapping


def given(**settings) -> dict:
    """The settings that are not None (the others keep the service's defaults)."""
    return {k: v for k, v in settings.items() if v is not None}


def items(at) -> list[str]:
    """A pose as "name=value" items (``show``'s ``at``)."""
    if isinstance(at, Mapping):
        return [f"{name}={float(value)!r}" for name, value in at.items()]
    return [at] if isinstance(at, str) else list(at)


def robot_source(robot):
    """A ``Robot`` as it is, else the path (a library name resolved)."""
    return robot if is_robot(robot) else path_of(robot)


def is_robot(value) -> bool:
    from ..model.robot import Robot

    return isinstance(value, Robot)


def path_of(value) -> Path:
    return value if isinstance(value, Path) else Path(str(value))
