"""Names in a robot file: what they may look like and which are taken.

Light on purpose (no SymPy): a cached run names its robot from the file
name without loading the model.  Names become Python identifiers in
generated code, CSV columns and folder names, hence the strict pattern.
"""
from __future__ import annotations

import keyword
import re
from pathlib import Path

GROUND = "ground"
IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}\Z")
#: the expression functions and constants (``expressions.FUNCTIONS``, ``CONSTANTS``)
FUNCTION_NAMES = frozenset({"sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh",
                            "cosh", "tanh", "exp", "log", "sqrt", "abs", "sign", "min", "max"})
CONSTANT_NAMES = frozenset({"pi"})
RESERVED_NAMES = (FUNCTION_NAMES | CONSTANT_NAMES | {"t", GROUND, "math", "numpy", "functools"}
                  | set(keyword.kwlist) | set(keyword.softkwlist))


def default_name(source: str) -> str:
    """The robot name taken from a file name: made an identifier (it names a folder)."""
    stem = Path(source).stem if source.endswith((".yaml", ".yml")) else "robot"
    name = re.sub(r"[^A-Za-z0-9_]", "_", stem)[:64]
    if not name or not name[0].isalpha():
        name = ("robot_" + name)[:64]
    return name if name not in RESERVED_NAMES else f"robot_{name}"


#: the default names of a spherical joint's quaternion and speeds: <body>_qw ... <body>_wx ...
QUATERNION = ("qw", "qx", "qy", "qz")
ANGULAR = ("wx", "wy", "wz")
#: the joint type words whose coordinates end with a quaternion, and how many come before it
ORIENTED = {"spherical": 0, "floating": 3}


def quaternion_names(body: object) -> list[str]:
    """The quaternion's coordinates of a body item read from a robot file (any value)
    when its joint is spherical or floating, given or default, else []: coordinates
    that no joint takes by default, and that count no degree of freedom apart."""
    joint = body.get("joint") if isinstance(body, dict) else None
    word = joint.get("type") if isinstance(joint, dict) else None
    if not isinstance(word, str) or word not in ORIENTED:
        return []
    listed = joint.get("coordinates")
    if isinstance(listed, list):
        return [name for name in listed[ORIENTED[word]:] if isinstance(name, str)]
    name = body.get("name")
    return [f"{name}_{part}" for part in QUATERNION] if isinstance(name, str) else []


def nearest_key(path: str, keys) -> str:
    """The longest key path among ``keys`` that ``path`` starts with, parent by parent
    (``bodies[2].joint.axis`` -> ``bodies[2].joint`` -> ``bodies[2]`` -> ``bodies``),
    "" when there is none."""
    while path and path not in keys:
        shorter = re.sub(r"(\.[^.\[]*|\[\d+\])$", "", path)
        path = shorter if shorter != path else ""
    return path
