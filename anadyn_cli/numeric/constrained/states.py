"""States on the constraints and the exact constrained accelerations there, for
``compare``."""
from __future__ import annotations

import math

import numpy as np

from ...errors import NumericalError
from .dynamics import ConstrainedModel


def consistent_states(model: ConstrainedModel, count: int, seed: int = 0, steps: int = 16,
                      horizon: float | None = None):
    """(t, x rows, tau rows): ``count`` random states on the constraints near the start.

    The independent coordinates are drawn within +-pi rad (+-max(0.1, |q0|) m) of
    their start and reached from it in ``steps`` steps, closing the constraints at
    each (so the assembly mode is kept); draws the constraints cannot follow to are
    skipped.  Rates: within +-max(2, 2 |dq0|) of the start for the free speeds, the
    dependent ones solved; efforts of the size the control laws give at the start.
    """
    rng = np.random.default_rng([seed, 7])
    n = model.n
    x0 = model.initial_state()
    q0, dq0 = x0[:n], x0[n:]
    info = model.info
    spread = np.array([math.pi if c.unit == "rad" else max(0.1, abs(c.initial))
                       for c in info.coordinates])
    width = np.maximum(2.0, 2 * np.abs(dq0))
    free = [k for k in range(n) if k not in model.dependent]
    scale = np.ones(model.m)
    if model.m and info.has_controller:
        with np.errstate(all="ignore"):
            start = np.asarray(model.efforts(0.0, q0, dq0), dtype=float).reshape(model.m)
        scale = np.where(np.isfinite(start), np.maximum(1.0, np.abs(start)), 1.0)
    horizon = horizon if horizon is not None else (info.simulation.t_end or 10.0)
    times, states, efforts = [], [], []
    for _ in range(count):
        target = q0 + spread * rng.uniform(-1, 1, n)
        moment = float(rng.uniform(0.0, horizon))
        rates = dq0 + width * rng.uniform(-1, 1, n)
        tau = scale * rng.uniform(-1, 1, model.m)
        q = q0.copy()
        try:
            for s in np.linspace(0, 1, steps + 1)[1:]:
                q[free] = q0[free] + s * (target[free] - q0[free])
                q = model.close(s * moment, q)
            dq = model.rates(moment, q, rates)
        except (NumericalError, np.linalg.LinAlgError):
            continue
        times.append(moment)
        states.append(np.concatenate([q, dq]))
        efforts.append(tau)
    return (np.array(times), np.array(states, dtype=float).reshape(len(times), 2 * n),
            np.array(efforts, dtype=float).reshape(len(times), model.m))


def accelerations(model: ConstrainedModel, t, X, tau) -> tuple[np.ndarray, np.ndarray]:
    """(ddq rows, lambda rows) at states on the constraints under efforts ``tau``
    (no stabilization: the exact constrained dynamics)."""
    ddq = np.full((len(t), model.n), np.nan)
    lam = np.full((len(t), model.c), np.nan)
    for k in range(len(t)):
        try:
            M, G, A, _, _, b = model._evaluate(float(t[k]), X[k].tolist(), tau[k])
            ddq[k], lam[k] = model.solve(M, G, A, b)[:2]
        except np.linalg.LinAlgError:
            pass
    return ddq, lam
