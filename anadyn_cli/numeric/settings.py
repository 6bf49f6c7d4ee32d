"""Run settings: given values, then the robot file's, then anadyn's defaults.

Messages name the settings as the library knows them (``output_step``); the
command line names its flags instead (``errors.SettingError``).

Each given setting is checked against its range in ``errors.ALLOWED``, the
table the command line checks its options by when it is read.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import ModelError, check
from ..model.info import RobotInfo, Simulation
from .integrators import METHODS

DEFAULTS = Simulation(t_end=10.0, output_step=0.01, method="auto", rtol=1e-10, atol=1e-12)
MAX_ROWS = 1_000_000     # output rows; the robot file is held to the same (model.loader)


def resolve(robot: RobotInfo, **given) -> Simulation:
    """Settings for a run of ``robot``: ``given`` values (None: not given), then
    the file's ``simulation`` section, then DEFAULTS."""
    chosen = {k: v for k, v in given.items() if v is not None}
    for key in ("t_end", "output_step", "rtol", "atol"):   # the file's are checked on load
        if key in chosen:
            chosen[key] = check(key, chosen[key])
    settings = replace(DEFAULTS, **{k: v for k, v in robot.simulation.__dict__.items()
                                    if v is not None})
    settings = replace(settings, **chosen)
    method = next((m for m in METHODS if m.lower() == str(settings.method).lower()), None)
    if method is None:
        raise ModelError(f"unknown method {settings.method!r}; choose one of "
                         f"{', '.join(METHODS)}")
    settings = replace(settings, method=method)
    if settings.output_step > settings.t_end:
        raise ModelError(f"output step {settings.output_step:g} s is longer than "
                         f"t_end {settings.t_end:g} s")
    if settings.t_end / settings.output_step > MAX_ROWS:
        raise ModelError(f"t_end / output step = {settings.t_end / settings.output_step:.3g} "
                         f"rows; at most {MAX_ROWS:,} (raise the output step or shorten t_end)")
    return settings


def output_grid(t_end: float, step: float) -> np.ndarray:
    """t = k * step for k = 0, 1, ... up to t_end (inclusive when it is a multiple)."""
    count = int(math.floor(t_end / step * (1 + 1e-12))) + 1
    return np.arange(count) * step


def trajectory_grid(duration: float, step: float) -> np.ndarray:
    """t = k * step for k = 0, 1, ... up to ``duration``, which is always the last row."""
    count = int(np.floor(duration / step * (1 + 1e-12))) + 1
    t = np.arange(count) * step
    if abs(duration - t[-1]) <= 1e-9 * step:
        t[-1] = duration
    elif t[-1] < duration:
        t = np.append(t, duration)
    return t
