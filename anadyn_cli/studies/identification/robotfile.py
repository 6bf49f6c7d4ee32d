"""Robot files written by identification: the source robot's data (its YAML, or
what ``anadyn import`` makes of its URDF) with entries replaced, emitted by a
safe YAML dumper (no name can change the structure) and loaded back before it
is returned, so what is written is a valid robot."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from ...model import robot_from_text
from ...model.yamlschema import Dumper
from .regressor import INERTIA_ENTRIES


def source_data(robot) -> dict:
    """The robot file's data as loaded (a URDF: as imported)."""
    path = Path(robot.source)
    if path.suffix.lower() == ".urdf":
        from ...model.urdf import import_file

        return import_file(path).data
    return yaml.safe_load(path.read_text(encoding="utf-8"))


def text_of(data: dict, source: str) -> str:
    """The YAML text of ``data``, checked to load as a robot (ModelError if not)."""
    text = yaml.dump(data, Dumper=Dumper, sort_keys=False, allow_unicode=True,
                     default_flow_style=None, width=100)
    robot_from_text(text, source)
    return text


def body_entries(pi10) -> dict:
    """mass, com and central inertia entries of a body from its ten parameters."""
    m = float(pi10[0])
    c = np.asarray(pi10[1:4], float) / m
    I_O = np.zeros((3, 3))
    for value, (r, k) in zip(pi10[4:], INERTIA_ENTRIES):
        I_O[r, k] = I_O[k, r] = value
    I_c = I_O - m * (c @ c * np.eye(3) - np.outer(c, c))
    names = {(0, 0): "ixx", (1, 1): "iyy", (2, 2): "izz", (0, 1): "ixy", (0, 2): "ixz",
             (1, 2): "iyz"}
    return {"mass": number(m), "com": [number(x) for x in c],
            "inertia": {name: number(I_c[rc]) for rc, name in names.items()}}


def number(x) -> float:
    """``x`` to 12 digits, 0 below 1e-30 in size (the loader's smallest number)."""
    value = float(f"{float(x):.12g}") + 0.0
    return value if abs(value) >= 1e-30 else 0.0
