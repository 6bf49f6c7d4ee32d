"""The path examined: the power integrals that join the state (actuators' work, loads'
work, what joint forces dissipate), the Jacobian's eigenvalues along the path, the
explicit probe, a free robot's momentum and the mass matrix's conditioning."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...numeric import integrators
from ...numeric.integrators import Problem
from ...numeric.model import NumericModel, scaled_condition

PROBE_CALLS = 5_000           # RHS calls for the loose explicit probe (4x for the tight one)
PROBE_RTOLS = (1e-3, 1e-7)
STABILITY_LIMITED = 0.5       # calls(loose) / calls(tight) above this: stability-limited
CONDITION_ROWS = 20_000


@dataclass
class Probe:
    window: float                 # s, from the start
    loose_calls: int
    tight_calls: int
    loose_capped: bool
    tight_capped: bool

    @property
    def ratio(self) -> float:
        return self.loose_calls / max(self.tight_calls, 1)

    @property
    def limited(self) -> bool:
        return self.ratio > STABILITY_LIMITED


def actuator_power(model: NumericModel, t: float, x: np.ndarray) -> np.ndarray:
    """P = tau . (B^T dq) = dq . (B tau): the actuators' power at the states x
    (nq + n, ...) -> (...).  B is the recursive path's ``actuation`` (B alone, the
    same numbers as ``mfb``'s, kept once when constant: no M per call), else the
    closed forms' ``mfb``."""
    n, nq = model.n, model.nq
    q, dq = x[:nq], x[nq:]
    tau = np.moveaxis(np.asarray(model.efforts(t, q, dq), dtype=float), 0, -1)   # (..., m)
    B = (model.actuation(t, q, dq) if model.evaluator == "recursive"
         else model.mfb(t, q, dq)[2])
    B = np.asarray(B, dtype=float).reshape(*np.shape(B)[:-2], n, -1)              # (..., n, m)
    return np.einsum("...ij,...j,i...->...", B, tau, dq)


def external_powers(model: NumericModel, t: float, x: np.ndarray) -> np.ndarray:
    """[P_loads, P_dissipated] at the states x (nq + n, ...) -> (2, ...): the loads'
    power and the power that joint damping and friction dissipate (>= 0)."""
    nq = model.nq
    out = np.array(model.powers(t, x[:nq], x[nq:]), dtype=float)
    if out.shape != (2, *np.shape(x)[1:]):           # a constant power
        out = np.array(np.broadcast_to(out, (2, *np.shape(x)[1:])))
    if model.contact_names:                   # what the contacts dissipate
        out[1] += np.sum(model.contacts(t, x[:nq], x[nq:])[:, 5], axis=0)
    return out


def forced(model: NumericModel) -> bool:
    """Whether W_loads and E_d are carried: loads, joint forces or contacts."""
    return model.has_forces or bool(model.contact_names)


def with_work(model: NumericModel, actuated: bool) -> Problem:
    """The direct dynamics with the actuators' work W as one more state, W' = P; with
    loads or joint forces also their work W_loads and the dissipated energy E_d.
    ``actuated``: whether the efforts can be non-zero (actuators under control laws),
    else W stays 0 and P is not evaluated.

    The Jacobian is the model's, bordered by the rows dP/dx of forward differences
    (step 1.5e-8 max(1, |x_j|)) taken in one vectorized evaluation of the powers at
    the n + 1 states; the work states feed back into nothing, so their columns are
    zero (the rows steer only the Newton iteration of states that follow x)."""
    n2 = model.nq + model.n
    extra = 3 if forced(model) else 1

    def powers(t, X):
        """(extra, ...) at the states X (n2, ...)."""
        out = np.zeros((extra, *np.shape(X)[1:]))
        if actuated:
            out[0] = actuator_power(model, t, X)
        if extra > 1:
            out[1:] = external_powers(model, t, X)
        return out

    def rhs(t, y):
        out = np.empty(n2 + extra)
        out[:n2] = model.rhs(t, y[:n2])
        out[n2:] = powers(t, y[:n2])
        return out

    def jacobian(t, y):
        J = np.zeros((n2 + extra, n2 + extra))
        x = y[:n2]
        J[:n2, :n2] = model.jacobian(t, x)
        if actuated or extra > 1:
            h = 1.5e-8 * np.maximum(1.0, np.abs(x))
            X = np.repeat(x[:, None], n2 + 1, axis=1)
            X[np.arange(n2), np.arange(n2)] += h
            P = powers(t, X)
            J[n2:, :n2] = (P[:, :n2] - P[:, n2:]) / ((x + h) - x)
        return J

    names = ("W", "W_loads", "E_d")[:extra]
    return Problem(rhs, jacobian, (*model.state_names(), *names), model.diagnose)


def eigen_samples(model: NumericModel, t: np.ndarray, x: np.ndarray, samples: int):
    """(sample times, decay, growth, speed, classic ratio) of the state Jacobian."""
    floor = 1.0 / max(t[-1] - t[0], 1e-300)
    index = np.unique(np.linspace(0, len(t) - 1, min(samples, len(t))).round().astype(int))
    decay, growth, speed, classic = [], [], [], []
    for k in index:
        lam = integrators.eigenvalues(model.jacobian, t[k], x[k])
        if lam is None:
            decay.append(np.nan), growth.append(np.nan), speed.append(np.nan)
            classic.append(np.nan)
            continue
        re = lam.real
        size = np.abs(lam).max(initial=0.0)
        decaying = -re[re < -1e-9 * max(size, 1.0)]
        decay.append(decaying.max(initial=0.0))
        growth.append(max(re.max(initial=0.0), 0.0))
        speed.append(size)
        classic.append(decaying.max() / max(decaying.min(), floor) if len(decaying) else 1.0)
    return (t[index], np.array(decay), np.array(growth), np.array(speed), np.array(classic))


def explicit_probe(problem: Problem, x0: np.ndarray, t0: float, t_end: float,
                   calls: int = PROBE_CALLS) -> Probe:
    """RK45 at a loose and a tight tolerance over the same window; see the module docstring."""
    loose, tight = PROBE_RTOLS
    solution = integrators.integrate(problem, x0, np.array([t0, t_end]), "RK45", loose,
                                     loose * 1e-2, budget=calls)
    if solution.over_budget is not None:
        window, loose_calls, loose_capped = solution.over_budget.t, calls, True
    else:
        window = solution.t[-1] if not solution.success else t_end
        loose_calls, loose_capped = solution.rhs_calls, False
    if window <= t0:
        return Probe(0.0, loose_calls, loose_calls, loose_capped, False)
    solution = integrators.integrate(problem, x0, np.array([t0, window]), "RK45", tight,
                                     tight * 1e-2, budget=4 * calls)
    over = solution.over_budget is not None
    tight_calls = 4 * calls if over else solution.rhs_calls
    return Probe(window - t0, loose_calls, tight_calls, loose_capped, over)


@dataclass
class Momentum:
    """A free robot's momentum along the path: ``h`` (rows, 6) = (P, L) in world axes,
    ``conserved`` the rows of C (``NumericModel.conserved``) and the relative drift of
    the conserved linear and angular parts (0 where none is conserved)."""
    h: np.ndarray
    conserved: np.ndarray
    linear: float
    angular: float

    @property
    def drift(self) -> float:
        return max(self.linear, self.angular)


def momentum(model: NumericModel, t: np.ndarray, x: np.ndarray) -> Momentum | None:
    """The momentum check of a free robot (module docstring); None for another."""
    C = model.conserved()
    if C is None:
        return None
    nq = model.nq
    values = np.asarray(model.momentum(t, x[:, :nq].T, x[:, nq:].T), dtype=float).T
    h, scales = values[:, :6], values[:, 6:].max(axis=0)
    change = np.abs((h - h[0]) @ C.T)
    drifts = []
    for part, scale in zip((slice(0, 3), slice(3, 6)), scales):
        rows = np.any(C[:, part] != 0, axis=1)
        drifts.append(float(change[:, rows].max()) / scale if rows.any() and scale > 0
                      else 0.0)
    return Momentum(h, C, *drifts)


def mass_conditions(model: NumericModel, t: np.ndarray, x: np.ndarray):
    """(times, raw, scaled) condition numbers of M at up to 20,000 rows."""
    stride = max(1, math.ceil(len(t) / CONDITION_ROWS))
    rows = np.arange(0, len(t), stride)
    n, nq = model.n, model.nq
    q, dq = x[rows, :nq].T, x[rows, nq:].T
    M = np.asarray(model.mfb(t[rows], q, dq)[0], dtype=float).reshape(len(rows), n, n)
    return t[rows], np.linalg.cond(M), scaled_condition(M)
