"""An exciting trajectory for identification (``anadyn excite``).

Each coordinate follows a finite Fourier series of period T and L harmonics
(Swevers et al., 1997), w = 2 pi / T:

    q_k(t) = o_k + sum_l  a_kl/(w l) sin(w l t) - b_kl/(w l) cos(w l t)

so the motion is periodic and smooth, and dq, ddq are exact.  The offsets o
and the coefficients a, b minimize log cond(Y_b), the condition number of the
regressor of the base parameters (``base``) stacked over ``samples`` times of
one period (from the eigenvalues of Y_b^T Y_b), by SLSQP
(``scipy.optimize.minimize``), with inequality constraints at those times:
every joint displacement within its limits (lower, upper), its rate within
its velocity limit, and every actuator's
effort (the file's parameters) within its effort limit (``Actuator.effort_limit``:
its drive's, else its joint's), each limit scaled by ``margin`` (the position
range about its middle).  A joint without position limits keeps within pi rad
(0.5 m) of its initial value, times its largest coordinate factor (a drive's
rotor turns N times the joint: N pi); a missing velocity or effort limit does
not constrain.  The start is random
(seeded) at a quarter of the ranges.  The result is then checked on the
output grid; where it leaves a limit there, the coefficients a, b are scaled
down by 2% steps until it does not.

Written as ``excite.csv`` (t, each coordinate, d<q>, dd<q> and the actuators'
efforts by the file's parameters: what ``inverse --motion`` and ``identify``
read) and ``NAME_excite.yaml``: the robot file with this trajectory (kind
expression, the series written out) and the initial state q(0), dq(0), for
``inverse``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import ModelError, SettingError
from ...files import one_set, prepare_dir, write_json, write_text
from ...output.csv_table import write_csv
from .base import BaseParameters, base_parameters
from .regressor import ParametricModel, value_of
from .robotfile import source_data, text_of

DEFAULT_SPAN = {"rad": math.pi, "m": 0.5}


@dataclass(frozen=True, eq=False)
class Excitation:
    model: ParametricModel
    base: BaseParameters
    period: float
    offsets: np.ndarray          # (n,)
    a: np.ndarray                # (n, L)
    b: np.ndarray                # (n, L)
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    efforts: np.ndarray          # (N, m) by the file's parameters
    condition: float
    success: bool
    message: str

    def expressions(self) -> dict[str, str]:
        """q_k(t) as the robot file's expression text, numbers to 12 digits."""
        w = 2 * math.pi / self.period
        out = {}
        for k, name in enumerate(self.model.coordinates):
            terms = [f"{self.offsets[k]:.12g}"]
            for l in range(self.a.shape[1]):
                f, angle = w * (l + 1), f"{2 * (l + 1) / self.period:.12g}*pi*t"
                terms += [f"{self.a[k, l] / f:+.12g}*sin({angle})",
                          f"{-self.b[k, l] / f:+.12g}*cos({angle})"]
            out[name] = " ".join(terms).replace("+-", "-").replace(" +", " + ").replace(
                " -", " - ")
        return out


def series(t, period, offsets, a, b):
    """q, dq, ddq (N, n) of the Fourier series at times t."""
    w = 2 * math.pi / period
    harmonics = w * np.arange(1, a.shape[1] + 1)            # (L,)
    phase = np.outer(t, harmonics)                          # (N, L)
    s, c = np.sin(phase), np.cos(phase)
    q = offsets + (s / harmonics) @ a.T - (c / harmonics) @ b.T
    dq = c @ a.T + s @ b.T
    ddq = -(s * harmonics) @ a.T + (c * harmonics) @ b.T
    return q, dq, ddq


def _bounds(model: ParametricModel, margin: float):
    """Per moving joint: (lower, upper, velocity) with the margin, inf where not
    limited."""
    values = model.robot.parameter_substitution()
    initial = np.array([value_of(c.initial, values)
                        for c in model.robot.coordinates])
    theta0 = model.J @ initial + model.theta0
    rows = []
    for j, (limits, body) in enumerate(zip(model.limits, model.moving)):
        def num(e):
            return math.inf if e is None else value_of(e, values)

        lower, upper = num(limits.lower), num(limits.upper)
        unit = "rad" if model.joint_types[body].angular else "m"
        if not math.isfinite(lower) or not math.isfinite(upper):   # (a rotor's: N times)
            span = DEFAULT_SPAN[unit] * np.abs(model.J[j]).max()
            lower, upper = theta0[j] - span, theta0[j] + span
        middle, half = (lower + upper) / 2, (upper - lower) / 2 * margin
        rows.append((middle - half, middle + half, num(limits.velocity) * margin))
    return np.array(rows).reshape(-1, 3), initial


def _check_settings(period, harmonics, samples, margin, iterations, output_step) -> None:
    """SettingError for a setting of ``excite`` out of its range."""
    for name, value, low in (("period", period, 0), ("harmonics", harmonics, 0),
                             ("samples", samples, 1), ("iterations", iterations, 0),
                             ("output_step", output_step, 0)):
        if not value > low or not math.isfinite(value):
            raise SettingError(name, f"must be above {low}, got {value!r}")
    if not 0 < margin <= 1:
        raise SettingError("margin", f"must be above 0 and at most 1, got {margin!r}")


def _start(model: ParametricModel, limits: np.ndarray, offsets: np.ndarray,
           t: np.ndarray, period: float, harmonics: int, seed: int) -> np.ndarray:
    """The optimizer's first point: the ``offsets`` and random coefficients (``seed``)
    scaled so that the motion at ``t`` spans a quarter of the narrowest range."""
    n = len(model.coordinates)
    rng = np.random.default_rng(seed)
    a0, b0 = rng.normal(size=(n, harmonics)), rng.normal(size=(n, harmonics))
    q0 = series(t, period, np.zeros(n), a0, b0)[0] @ model.J.T
    half = (limits[:, 1] - limits[:, 0]) / 2
    scale = 0.25 * np.min(half / np.maximum(np.abs(q0).max(0), 1e-12))
    return np.concatenate([offsets, (a0 * scale).ravel(), (b0 * scale).ravel()])


def excite(model: ParametricModel, base: BaseParameters | None = None, period: float = 10.0,
           harmonics: int = 5, samples: int = 100, margin: float = 0.9, seed: int = 0,
           iterations: int = 100, output_step: float = 0.01) -> Excitation:
    """The exciting trajectory (module docstring)."""
    from scipy.optimize import minimize

    _check_settings(period, harmonics, samples, margin, iterations, output_step)
    base = base or base_parameters(model)
    n, L = len(model.coordinates), harmonics
    limits, initial = _bounds(model, margin)
    middle_theta = (limits[:, 0] + limits[:, 1]) / 2
    start_offsets = np.linalg.lstsq(model.J, middle_theta - model.theta0, rcond=None)[0]
    t_opt = np.linspace(0, period, samples, endpoint=False)
    effort_limits = np.array([math.inf if a.effort_limit is None else float(a.effort_limit)
                              for a in model.robot.actuators]) * margin   # the actuators'
    B_inv = np.linalg.inv(model.B) if model.B.shape[0] == model.B.shape[1] else None
    independent = list(base.independent)

    def unpack(x):
        return x[:n], x[n:n + n * L].reshape(n, L), x[n + n * L:].reshape(n, L)

    cache: dict = {}             # the objective's and the constraints' difference
                                 # quotients take the same points: computed once

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            if len(cache) > 4 * len(x):
                cache.clear()
            q, dq, ddq = series(t_opt, period, *unpack(x))
            Y = model.regressor(q, dq, ddq)
            tau = (Y @ model.nominal + (model.stiffness * (q @ model.J.T + model.theta0
                                                             - model.rest)) @ model.J)
            efforts = tau @ B_inv.T if B_inv is not None else np.zeros((len(q), 0))
            cache[key] = (q @ model.J.T + model.theta0, dq @ model.J.T,
                          efforts, np.concatenate(Y[:, :, independent]))
        return cache[key]

    def objective(x):
        """log cond from the eigenvalues of the Gram matrix (r x r: cheaper than the
        SVD of the stacked regressor; the result's condition number is the SVD's)."""
        Y = evaluate(x)[3]
        eigenvalues = np.linalg.eigvalsh(np.einsum("ij,ik->jk", Y, Y))
        return 0.5 * (math.log(max(eigenvalues[-1], 1e-300))      # no overflow where
                      - math.log(max(eigenvalues[0], 1e-300)))     # the Gram is singular

    def constraints(x):
        theta, rate, efforts, _ = evaluate(x)
        parts = [(theta - limits[:, 0]).ravel(), (limits[:, 1] - theta).ravel()]
        finite = np.isfinite(limits[:, 2])
        parts.append((limits[finite, 2] - np.abs(rate[:, finite])).ravel())
        if B_inv is not None:
            bounded = np.isfinite(effort_limits)
            parts.append((effort_limits[bounded] - np.abs(efforts[:, bounded])).ravel())
        return np.concatenate(parts)

    x0 = _start(model, limits, start_offsets, t_opt, period, L, seed)
    solution = minimize(objective, x0, method="SLSQP",
                        constraints=[{"type": "ineq", "fun": constraints}],
                        options={"maxiter": iterations, "ftol": 1e-6})
    offsets, a, b = unpack(solution.x)
    t = np.arange(0, period + output_step / 2, output_step)
    cache.clear()
    t_opt = t                                           # check on the output grid
    x = solution.x.copy()
    for _ in range(200):
        if constraints(x).min() >= 0:
            break
        x[n:] *= 0.98
        cache.clear()
    else:
        raise ModelError("no exciting trajectory keeps the limits on the output grid: try "
                         "fewer harmonics or a longer period", source=model.source)
    offsets, a, b = unpack(x)
    q, dq, ddq = series(t, period, offsets, a, b)
    _, _, efforts, stacked = evaluate(x)
    s = np.linalg.svd(stacked, compute_uv=False)
    return Excitation(model, base, period, offsets, a, b, t, q, dq, ddq, efforts,
                      float(s[0] / s[-1]), bool(solution.success), str(solution.message))


def robot_text(result: Excitation) -> str:
    """The robot file with the exciting trajectory and its initial state."""
    model = result.model
    data = source_data(model.robot)
    data["name"] = f"{model.name}_excite"
    data["description"] = (f"{model.name} on an exciting trajectory for identification "
                           "(anadyn excite)")
    coordinates = data.setdefault("coordinates", {})
    for k, name in enumerate(model.coordinates):
        entry = coordinates.get(name) or {}
        entry.update(initial=float(result.q[0, k]), rate=float(result.dq[0, k]))
        coordinates[name] = entry
    data["trajectory"] = {"kind": "expression", "duration": float(result.period),
                          "expressions": result.expressions()}
    return text_of(data, f"{model.name}_excite.yaml")


@one_set
def write(result: Excitation, out: Path) -> list[Path]:
    """excite.csv, NAME_excite.yaml and excite.json in ``out``."""
    model = result.model
    out = prepare_dir(out)
    names = model.coordinates
    header = ["t", *names, *(f"d{c}" for c in names), *(f"dd{c}" for c in names),
              *model.actuators]
    columns = [result.t, *result.q.T, *result.dq.T, *result.ddq.T, *result.efforts.T]
    written = [out / "excite.csv", out / f"{model.name}_excite.yaml", out / "excite.json"]
    write_csv(written[0], header, columns)
    write_text(written[1], robot_text(result))
    write_json(written[2], {
        "robot": model.name, "period": result.period, "harmonics": int(result.a.shape[1]),
        "condition_number": result.condition, "base_parameters": result.base.rank,
        "optimizer": {"method": "SLSQP", "success": result.success,
                      "message": result.message},
        "largest": {"|q|": dict(zip(names, map(float, np.abs(result.q).max(0)))),
                    "|dq|": dict(zip(names, map(float, np.abs(result.dq).max(0)))),
                    "|effort|": dict(zip(model.actuators,
                                         map(float, np.abs(result.efforts).max(0))))}})
    return written
