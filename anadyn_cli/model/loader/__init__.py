"""YAML robot file -> validated, frozen ``Robot``.

Every mistake raises ``ModelError`` naming the file, line, key path, what is
wrong and what is allowed; nothing else escapes (``tests/test_fuzz.py``).
The README documents each key read here.

Beyond the types and ranges of single values, the robot as a whole is
checked where that is cheap and certain:

- every displacement, its rates and every control law are finite real
  numbers at the initial state (else the first step of any run fails);
- the mass matrix is not singular everywhere (``massmatrix``): a coordinate,
  or a combination of coordinates, that moves no mass leaves M(q) q'' = ...
  without a solution.  M is computed numerically, by its own recursion,
  at the initial state and at two random states; the robot is refused only
  if M is singular at all three.

The package, one module per group of sections: ``cursor`` (a value and its key
path), ``numbers`` (parameters, coordinates), ``bodies`` (bodies, joints, the
tree), ``forces`` (joint forces and limits, loads), ``actuators`` (actuators,
controller), ``motion`` (trajectory, simulation), ``checks`` (the whole-robot
checks) and ``builder`` (the sections in order).
"""
from __future__ import annotations

import hashlib
import sys
from pathlib import Path
from typing import Mapping

from ...errors import ModelError
from ..names import default_name
from ..robot import Robot
from ..yamlschema import load
from ..yamlsource import read_text
from .bodies import MAX_BODIES, MOVING_WORDS
from .builder import TOP_KEYS, _RobotBuilder
from .cursor import Cursor
from .forces import JOINT_FORCE_KEYS, LOAD_FRAMES
from .motion import MAX_ROWS, TRAJECTORY_KINDS
from .numbers import LARGEST, MAX_COORDINATES, SMALLEST

__all__ = ["JOINT_FORCE_KEYS", "LARGEST", "LOAD_FRAMES", "MAX_BODIES", "MAX_COORDINATES",
           "MAX_ROWS", "MOVING_WORDS", "SMALLEST", "TOP_KEYS", "TRAJECTORY_KINDS", "Cursor",
           "_RobotBuilder", "load_robot", "robot_from_text"]


def load_robot(path: str | Path, parameters: Mapping[str, object] | None = None) -> Robot:
    """Read and validate a robot file (``parameters``: see ``robot_from_text``)."""
    text, source = read_text(path)
    return robot_from_text(text, source, parameters)


def robot_from_text(text: str, source: str = "<robot>",
                    parameters: Mapping[str, object] | None = None) -> Robot:
    """Validate YAML text describing a robot (``source`` names it in errors).

    ``parameters``: values (numbers, or expressions as the file writes them) that
    replace those of parameters the file defines, validated as if written there;
    the robot's digest covers them.

    Text that a URDF import produced (``urdf.place``) is reported at its place
    in the URDF (joint and link names), never at a line of the generated YAML;
    when that import ran in this process, its description is taken as it is
    (``urdf.description``), not parsed from the text again."""
    importer = sys.modules.get("anadyn_cli.model.urdf.importer")    # loaded: imports ran
    data = None if importer is None else importer.description(text)
    try:
        data, lines = (data, {}) if data is not None else load(text, source)
        overrides = dict(parameters or {})
        keyed = text + (f"\n# parameters {sorted(overrides.items())!r}" if overrides else "")
        digest = hashlib.sha256(keyed.encode("utf-8", "surrogatepass")).hexdigest()
        return _RobotBuilder(Cursor(data, "", source, lines), digest,
                             default_name(source), overrides).build()
    except ModelError as err:
        from ..urdf import place

        where = place(text, err.path)
        if where is None:
            raise
        raise ModelError(err.reason, source=err.source, path=where + (
            f" (imported as {err.path})" if err.path else "")) from None
