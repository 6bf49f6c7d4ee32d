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
