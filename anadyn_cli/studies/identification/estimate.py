"""The base parameters estimated from measured motion and efforts (``anadyn identify``).

Data: a CSV with the columns of ``inverse.csv``: ``t``, each coordinate,
optionally every ``d<q>`` and ``dd<q>`` (else from the positions by the
Savitzky-Golay differentiator of ``numeric.measured``), and each actuator's
effort.  The last ``holdout`` fraction of the samples (by time) is held out:
not used by the estimate, only to judge its predictions.

Estimate (two-step weighted least squares, as Gautier's): with the actuator
regressor restricted to the base parameters, Y_b (``base``), and the measured
efforts less the joint springs' (known) efforts,

1. ordinary least squares;
2. each actuator's residual standard deviation sigma_a = sqrt(RSS_a / (N - r/m))
   (N training samples, m actuators, r base parameters; at least 1e-12 of the
   largest effort), the rows divided by their sigma_a, least squares again;
3. covariance s^2 (W^T W)^{-1} with W the weighted regressor and s^2 its residual
   sum of squares over (N m - r); the standard deviations are its diagonal's
   roots; the condition number is W's (largest over smallest singular value).

Full parameters for the robot file: the parameters nearest the file's (in the
Euclidean norm) that have the estimated base parameters,
pi = pi0 + K^T (K K^T)^{-1} (beta - K pi0).  Optionally (``physical``) the
physically consistent estimate instead: every body's pseudo-inertia
J = [[Sigma, h], [h^T, m]] (Sigma = tr(I_O)/2 1 - I_O) positive definite (``realizable``), which
gives m > 0 and a central inertia that meets the triangle inequalities, by the
log-Cholesky parametrization J = U U^T (Rucker and Wensing, 2022), friction and
armature >= 0 (bounds), minimizing |W (K pi) - W-weighted efforts|^2, i.e.
|R (K pi - beta)|^2 with R the triangular factor of W, plus |w (pi - pi0)|^2,
w = 1e-3 of W's smallest singular value, for the directions the data do not
fix (a bias below 1e-6 of pi - pi0 in those they fix), by
``scipy.optimize.least_squares`` (trust-region reflective; the Jacobian of the
parametrization by central differences, body by body), started from the
least-squares parameters with each pseudo-inertia's eigenvalues raised to
1e-6 of its largest.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import ModelError, SettingError
from ...files import one_set, prepare_dir, write_json, write_text
from ...numeric import measured
from ...output.csv_table import write_csv
from .base import BaseParameters, base_parameters
from .regressor import INERTIA_ENTRIES, ParametricModel
from .robotfile import body_entries, number, source_data, text_of

HOLDOUT = 0.2
SIGMA_FLOOR = 1e-12
REGULARIZATION = 1e-3
LOG_BOUND = 30.0             # |log| of the log-Cholesky exponentials, clipped
DIFFERENCE_STEP = 1e-6       # of the log-Cholesky coordinates' difference quotients


@dataclass(frozen=True, eq=False)
class Measurements:
    """Measured motion and efforts at N samples (rows)."""
    source: str
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    efforts: np.ndarray                # (N, m) in the robot's actuator order
    motion: str                        # how rates and accelerations were obtained


def read_measurements(path, model: ParametricModel,
                      differentiator: measured.Differentiator | None = None) -> Measurements:
    """The data file's motion (``measured.read_motion``) and the actuators' efforts."""
    motion = measured.read_motion(path, model.coordinates, differentiator)
    table = measured.read_table(path, ("t", *model.coordinates, *model.actuators), (),
                                " (the robot's coordinates and actuators, as inverse.csv "
                                "has them)")
    efforts = np.stack([table[a] for a in model.actuators], -1)
    return Measurements(motion.source, motion.t, motion.q, motion.dq, motion.ddq, efforts,
                        motion.describe())


@dataclass(frozen=True, eq=False)
class Identification:
    model: ParametricModel
    base: BaseParameters
    data: Measurements
    train: np.ndarray                  # (N,) bool: used by the estimate
    estimate: np.ndarray               # (r,) base parameters
    std: np.ndarray                    # (r,) their standard deviations
    sigma: np.ndarray                  # (m,) residual standard deviation per actuator
    condition: float
    predicted: np.ndarray              # (N, m) by the estimate
    pi: np.ndarray                     # (p,) full parameters of the robot file
    file_rms: np.ndarray               # (m,) training residual RMS of those parameters
    physical: bool
    consistent: bool                   # every body ``realizable``
    robot_text: str | None
    note: str = ""
    method: dict = field(default_factory=dict)

    def rms(self, held_out: bool = False) -> np.ndarray:
        """Residual RMS per actuator on the training (or held-out) samples."""
        rows = ~self.train if held_out else self.train
        if not rows.any():
            return np.full(len(self.model.actuators), math.nan)
        return np.sqrt(np.mean((self.data.efforts[rows] - self.predicted[rows]) ** 2, 0))


def identify(model: ParametricModel, data: Measurements, base: BaseParameters | None = None,
             holdout: float = HOLDOUT, physical: bool = False) -> Identification:
    """The estimate (module docstring); ModelError for too few samples or a motion
    that leaves a base parameter unexcited."""
    from scipy.linalg import qr

    if not 0 <= holdout < 1:
        raise SettingError("holdout", f"must be at least 0 and below 1, got {holdout!r}")
    base = base or base_parameters(model)
    N, m = data.efforts.shape
    r = base.rank
    train = np.arange(N) < N - int(round(holdout * N))
    count = int(train.sum())
    if count * m <= r:
        need = r // m + 1
        raise ModelError(f"{count} samples{' left after the held-out part' * (count < N)} "
                         f"give {count * m} equations for {r} base parameters: give at "
                         f"least {math.ceil(need / (1 - holdout))} samples", source=data.source)
    Yb = model.actuator_regressor(data.q, data.dq, data.ddq)[:, :, list(base.independent)]
    tau = data.efforts - model.spring_efforts(data.q)
    A, y = Yb[train], tau[train]
    first = np.linalg.lstsq(A.reshape(-1, r), y.ravel(), rcond=None)[0]
    rss = np.sum((y - A @ first) ** 2, 0)
    sigma = np.sqrt(rss / (count - r / m))
    sigma = np.maximum(sigma, SIGMA_FLOOR * max(1.0, float(np.abs(y).max())))
    W = (A / sigma[None, :, None]).reshape(-1, r)
    yw = (y / sigma).ravel()
    singular = np.linalg.svd(W, compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else math.inf
    if singular[-1] <= 1e-10 * singular[0]:
        raise ModelError(f"the motion does not excite every base parameter (condition "
                         f"number {condition:.3g} of the weighted regressor): move every "
                         "joint, faster and further (anadyn excite)", source=data.source)
    estimate = np.linalg.lstsq(W, yw, rcond=None)[0]
    residual = yw - W @ estimate
    s2 = float(residual @ residual) / max(count * m - r, 1)
    R = qr(W, mode="r")[0][:r]
    R_inv = np.linalg.inv(R)
    std = np.sqrt(s2 * np.sum(R_inv ** 2, 1))
    K = base.K
    pi = model.nominal + K.T @ np.linalg.solve(K @ K.T, estimate - K @ model.nominal)
    if physical:
        pi = consistent_parameters(model, K, estimate, R, singular[-1], pi)
    springs = model.spring_efforts(data.q)
    predicted = np.einsum("nar,r->na", Yb, estimate) + springs
    by_file = np.einsum("nar,r->na", Yb[train], K @ pi) + springs[train]
    text, note = _robot_text(model, pi, physical)
    return Identification(
        model, base, data, train, estimate, std, sigma, condition, predicted, pi,
        np.sqrt(np.mean((data.efforts[train] - by_file) ** 2, 0)), physical,
        all(realizable(pi[10 * b:10 * b + 10]) for b in range(len(model.bodies))), text,
        note,
        {"estimate": "two-step weighted least squares (per-actuator residual deviation)",
         "full parameters": ("physically consistent: log-Cholesky least squares"
                             if physical else "nearest to the file's with these base "
                                              "parameters"),
         "rates and accelerations": data.motion})


def pseudo_inertia(pi10) -> np.ndarray:
    """J = [[Sigma, h], [h^T, m]], Sigma = tr(I_O)/2 1 - I_O."""
    I_O = np.zeros((3, 3))
    for value, (r, k) in zip(pi10[4:], INERTIA_ENTRIES):
        I_O[r, k] = I_O[k, r] = value
    J = np.zeros((4, 4))
    J[:3, :3] = np.trace(I_O) / 2 * np.eye(3) - I_O
    J[:3, 3] = J[3, :3] = pi10[1:4]
    J[3, 3] = pi10[0]
    return J


def realizable(pi10) -> bool:
    """Whether a rigid body has these ten parameters: the pseudo-inertia positive
    semidefinite, to 1e-12 of its largest eigenvalue, and the mass positive."""
    eigenvalues = np.linalg.eigvalsh(pseudo_inertia(pi10))
    return bool(pi10[0] > 0 and eigenvalues[0] >= -1e-12 * eigenvalues[-1])


def _from_log_cholesky(z) -> np.ndarray:
    """The ten parameters of each body (B, 10) from its log-Cholesky parameters (B, 10):
    alpha, d1, d2, d3, s12, s23, s13, t1, t2, t3 with
    U = e^alpha [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3], [0, 0, 0, 1]]
    and the pseudo-inertia J = U U^T."""
    z = np.asarray(z, float).reshape(-1, 10)
    e = np.exp(np.clip(z[:, :4], -LOG_BOUND, LOG_BOUND))
    U = np.zeros((len(z), 4, 4))
    U[:, 0, 0], U[:, 1, 1], U[:, 2, 2], U[:, 3, 3] = e[:, 1], e[:, 2], e[:, 3], 1.0
    U[:, 0, 1], U[:, 1, 2], U[:, 0, 2] = z[:, 4], z[:, 5], z[:, 6]
    U[:, :3, 3] = z[:, 7:]
    U *= e[:, :1, None]
    J = np.einsum("bik,bjk->bij", U, U)
    Sigma = J[:, :3, :3]
    I_O = np.trace(Sigma, axis1=1, axis2=2)[:, None, None] * np.eye(3) - Sigma
    return np.column_stack([J[:, 3, 3], J[:, :3, 3],
                            *(I_O[:, r, k] for r, k in INERTIA_ENTRIES)])


def _to_log_cholesky(pi10) -> np.ndarray:
    """The log-Cholesky parameters of the body's pseudo-inertia, its eigenvalues first
    raised to 1e-6 of the largest."""
    w, V = np.linalg.eigh(pseudo_inertia(pi10))
    w = np.maximum(w, 1e-6 * max(w.max(), 1e-12))
    J = (V * w) @ V.T
    flip = J[::-1, ::-1]
    U = np.linalg.cholesky(flip)[::-1, ::-1]
    scale = U[3, 3]
    U = U / scale
    return np.array([math.log(scale), *np.log(np.diag(U)[:3]), U[0, 1], U[1, 2], U[0, 2],
                     *U[:3, 3]])


def consistent_parameters(model: ParametricModel, K, estimate, R, smallest, start) -> np.ndarray:
    """The physically consistent parameters (module docstring)."""
    from scipy.optimize import least_squares

    bodies = len(model.bodies)
    drive = len(model.names) - 10 * bodies
    weight = REGULARIZATION * smallest

    def unpack(z):
        return np.concatenate([_from_log_cholesky(z[:10 * bodies]).ravel(), z[10 * bodies:]])

    def residual(z):
        pi = unpack(z)
        return np.concatenate([R @ (K @ pi - estimate), weight * (pi - model.nominal)])

    outer = np.vstack([R @ K, weight * np.eye(len(model.names))])

    def jacobian(z):
        """outer times d(pi)/dz: block-diagonal (a body's parameters depend on its own
        ten), by central differences in each of the ten coordinates of all bodies at
        once; the identity for the drive parameters."""
        D = np.zeros((len(z), len(z)))
        D[10 * bodies:, 10 * bodies:] = np.eye(drive)
        blocks = z[:10 * bodies].reshape(bodies, 10)
        for c in range(10):
            step = np.zeros_like(blocks)
            step[:, c] = DIFFERENCE_STEP
            change = (_from_log_cholesky(blocks + step) - _from_log_cholesky(blocks - step)) / (
                2 * DIFFERENCE_STEP)
            for b in range(bodies):
                D[10 * b:10 * b + 10, 10 * b + c] = change[b]
        return outer @ D

    z0 = np.concatenate([*(_to_log_cholesky(start[10 * b:10 * b + 10]) for b in range(bodies)),
                         np.maximum(start[10 * bodies:], 0.0)])
    lower = np.concatenate([np.full(10 * bodies, -np.inf), np.zeros(drive)])
    solution = least_squares(residual, z0, jac=jacobian, bounds=(lower, np.inf),
                             max_nfev=100 * len(z0))
    return unpack(solution.x)


def _robot_text(model: ParametricModel, pi, physical: bool) -> tuple[str | None, str]:
    """The identified robot file's text, or None and why not."""
    if not Path(model.robot.source).is_file():
        return None, f"no robot file: the robot's source {model.robot.source} is not a file"
    data = source_data(model.robot)
    data["name"] = f"{model.name}_identified"
    data["description"] = (f"{model.name} with identified inertial parameters and joint "
                           "friction (anadyn identify)")
    if [body.get("name") for body in data.get("bodies", ())] != list(model.bodies):
        return None, ("no robot file: the robot has bodies its file does not list (the "
                      "massless links of compound joints, the rotors of drives)")
    drive = 10 * len(model.bodies)
    moving = model.moving
    for b, body in enumerate(data["bodies"]):
        for key in ("com", "inertia"):
            body.pop(key, None)
        body.update(body_entries(pi[10 * b:10 * b + 10]))
        if b in moving:
            j = model.joint_of_body[b]
            body["joint"]["damping"] = number(pi[drive + 3 * j + 1])
            body["joint"]["friction"] = number(pi[drive + 3 * j + 2])
    try:
        return text_of(data, f"{model.name}_identified.yaml"), ""
    except ModelError as err:
        return None, (f"no robot file: the estimate is not a valid robot ({err})"
                      + ("" if physical else "; ask for the physically consistent estimate"))


def report(result: Identification) -> dict:
    """identify.json's content."""
    model, base = result.model, result.base
    names = base.base_names
    n_held = int((~result.train).sum())
    drive = 10 * len(model.bodies)
    return {
        "robot": model.name, "data": result.data.source,
        "samples": {"training": int(result.train.sum()), "held_out": n_held},
        "method": result.method, "condition_number": result.condition,
        "base_parameters": {
            name: {"estimate": float(v), "std": float(s),
                   "relative_std_percent": float(100 * s / abs(v)) if v else None,
                   "nominal": float(nv), "expression": text}
            for name, v, s, nv, text in zip(names, result.estimate, result.std,
                                            base.of(model.nominal), base.expressions())},
        "residual_std": dict(zip(model.actuators, map(float, result.sigma))),
        "rms_training": dict(zip(model.actuators, map(float, result.rms()))),
        "rms_held_out": (dict(zip(model.actuators, map(float, result.rms(True))))
                         if n_held else None),
        "parameters": dict(zip(model.names, map(float, result.pi))),
        "rms_training_of_parameters": dict(zip(model.actuators, map(float, result.file_rms))),
        "armature": {model.bodies[b]: float(result.pi[drive + 3 * j])
                     for j, b in enumerate(model.moving)},
        "physically_consistent": result.consistent,
        "robot_file": None if result.robot_text is None else f"{model.name}_identified.yaml",
        "note": result.note or None}


@one_set
def write(result: Identification, out: Path, plot: bool = True) -> list[Path]:
    """identify.csv (measured and predicted efforts, held-out flag), identify.png and
    identify_residuals.png, NAME_identified.yaml (when the estimate is a valid robot)
    and identify.json, in ``out``."""
    from ...output.plots import Panel, time_figure, unit_text, write_figure

    out = prepare_dir(out)
    model, data = result.model, result.data
    header, columns = ["t", "held_out"], [data.t, (~result.train).astype(float)]
    for k, a in enumerate(model.actuators):
        header += [a, f"{a}_predicted"]
        columns += [data.efforts[:, k], result.predicted[:, k]]
    written = [out / "identify.csv"]
    write_csv(written[0], header, columns)
    if plot:
        split = data.t[~result.train][0] if (~result.train).any() else None
        residual = data.efforts - result.predicted
        units = [unit_text(a.unit) for a in model.robot.actuators]
        for stem, what, panels in (
                ("identify", "measured and predicted efforts",
                 [Panel(f"{a} ({u})", (("measured", data.efforts[:, k]),
                                       ("predicted", result.predicted[:, k])))
                  for k, (a, u) in enumerate(zip(model.actuators, units))]),
                ("identify_residuals", "residuals, measured - predicted",
                 [Panel(f"{a} ({u})", ((a, residual[:, k]),))
                  for k, (a, u) in enumerate(zip(model.actuators, units))])):
            held = "; held out after the dotted line" if split is not None else ""
            figure = time_figure(data.t, panels, f"{model.name}: {what}{held}")
            if split is not None:
                for ax in figure.axes:
                    ax.axvline(split, color="k", linestyle=":", linewidth=1)
            written.append(write_figure(out / f"{stem}.png", figure))
    if result.robot_text is not None:
        written.append(out / f"{model.name}_identified.yaml")
        write_text(written[-1], result.robot_text)
    written.append(out / "identify.json")
    write_json(written[-1], report(result))
    return written
