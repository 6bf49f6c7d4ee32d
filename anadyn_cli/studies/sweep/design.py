"""The samples of a sweep: grids and lists combined in full, Monte-Carlo draws
from one seeded generator, the same draws at every grid point."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import errors
from ...errors import MAX_SAMPLES, ModelError, SettingError
from .grammar import EXAMPLES, Spec

DEFAULT_SAMPLES = 100          # Monte-Carlo draws when --samples is not given


@dataclass(frozen=True)
class Design:
    """The samples: ``values`` (N x k, columns in the order of ``specs``)."""
    specs: tuple[Spec, ...]
    values: np.ndarray
    kind: str                      # "grid", "monte-carlo" or "grid x monte-carlo"
    shape: tuple[int, ...]         # grid sizes of the grid and list specs, in order
    draws: int                     # Monte-Carlo draws per grid point (0: none)
    seed: int | None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.specs)

    @property
    def count(self) -> int:
        return len(self.values)


def design(specs: list[Spec], samples: int | None = None, seed: int = 0) -> Design:
    """The samples of ``specs``: the full grid of the grids and lists (the first
    varies slowest), times ``samples`` draws of each distribution (seeded by ``seed``)."""
    if not specs:
        raise ModelError("nothing to vary: give one or more --vary NAME=SPEC, " + EXAMPLES)
    fixed = [s for s in specs if not s.random]
    random = [s for s in specs if s.random]
    if samples is not None and not random:
        raise SettingError("samples", "is the number of draws from a distribution "
                           "(normal(...), uniform(...)); grids and lists run every value once")
    errors.check("samples", samples)
    draws = (DEFAULT_SAMPLES if samples is None else samples) if random else 0
    shape = tuple(len(s.values) for s in fixed)
    total = math.prod(shape) * max(draws, 1)
    if total > MAX_SAMPLES:
        raise ModelError(f"{total:,} samples ({' x '.join(map(str, shape + ((draws,) if draws else ())))}"
                         f"); at most {MAX_SAMPLES:,}")
    rng = np.random.default_rng(seed)
    drawn = {}
    for s in random:
        a, b = s.arguments
        drawn[s.name] = rng.normal(a, b, draws) if s.kind == "normal" else rng.uniform(a, b, draws)
    points = np.indices(shape).reshape(len(shape), -1).T if shape else np.zeros((1, 0), int)
    repeat = max(draws, 1)
    columns = []
    fixed_index = {s.name: k for k, s in enumerate(fixed)}
    for s in specs:
        if s.random:
            columns.append(np.tile(drawn[s.name], len(points)))
        else:
            column = np.asarray(s.values)[points[:, fixed_index[s.name]]]
            columns.append(np.repeat(column, repeat))
    values = np.column_stack(columns) if columns else np.zeros((total, 0))
    kind = "monte-carlo" if not fixed else "grid" if not random else "grid x monte-carlo"
    return Design(tuple(specs), values, kind, shape, draws, seed if random else None)

