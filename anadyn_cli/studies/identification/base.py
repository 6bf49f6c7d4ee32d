"""Base parameters: the identifiable combinations beta = K pi of the parameters.

Numerically (every open tree): the regressor Y stacked over random states
(coordinates uniform in [-pi, pi] rad or [-0.5, 0.5] m, rates and
accelerations standard normal, seeded), its columns scaled to unit norm (those
below 1e-12 of the largest are zero columns), and a rank-revealing QR with
column pivoting (``scipy.linalg.qr``): the rank r is the number of |R_ii|
above 1e-9 |R_00|.  The *independent* parameters are then the columns kept
going through them in the parameters' order (kept when their part orthogonal
to those kept is above 1e-6), if that gives r of them, else the first r
pivoted ones; every other column is Y_dep = Y_ind beta by least squares
(coefficients below 1e-10 of the largest put to 0), and

    Y pi = Y_ind (pi_ind + beta pi_dep),    K = [1 | beta] (columns re-ordered).

Parameters whose column is zero (they do not act at all) are dependent with
coefficients 0.  Coefficients print as fractions (denominator up to 1000)
where they are one to 1e-9, else with 10 digits.

Exactly (``exact_coefficients``, robots of up to three coordinates whose numbers
are rational or multiples of pi): Y derived again symbolically, the inertial
columns from anadyn's Kane equations with the ten standard parameters of each
body as symbols and the numbers as rationals, the drive columns as J^T times
ddtheta, dtheta and a symbol for the smoothed sign; each column written as a
polynomial in sin q, cos q, q, dq, ddq reduced modulo sin^2 + cos^2 = 1, and
beta solved over the rationals from the polynomials' coefficients, checked to
reproduce every dependent column exactly and compared with the numeric beta.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import sympy as sp

from .regressor import INERTIA_ENTRIES, INERTIAL, ParametricModel

RANK_TOLERANCE = 1e-9
STATES = 60                  # random states of the numeric base parameters
EXACT_MAX_COORDINATES = 3


@dataclass(frozen=True, eq=False)
class BaseParameters:
    """beta = K pi; ``independent``/``dependent``: indices into the parameters."""
    names: tuple[str, ...]              # the parameters pi
    independent: tuple[int, ...]
    dependent: tuple[int, ...]
    beta: np.ndarray                    # (r, p - r)
    exact: sp.Matrix | None = None      # beta over the rationals, where computed
    note: str = ""                      # why there is no exact beta

    @property
    def rank(self) -> int:
        return len(self.independent)

    @property
    def K(self) -> np.ndarray:
        K = np.zeros((self.rank, len(self.names)))
        K[:, list(self.independent)] = np.eye(self.rank)
        K[:, list(self.dependent)] = self.beta
        return K

    @property
    def base_names(self) -> tuple[str, ...]:
        """Each base parameter by its independent parameter, with an R when others
        are regrouped into it."""
        return tuple(self.names[i] + ("R" if np.any(self.beta[k]) else "")
                     for k, i in enumerate(self.independent))

    def of(self, pi) -> np.ndarray:
        return self.K @ np.asarray(pi, float)

    def expressions(self) -> list[str]:
        """``name = combination`` per base parameter, coefficients as fractions
        where they are (to 1e-9), else 10 digits."""
        out = []
        for k, (name, i) in enumerate(zip(self.base_names, self.independent)):
            terms = [self.names[i]]
            for c, j in zip(self.beta[k], self.dependent):
                if c:
                    terms.append(_term(float(c), self.names[j]))
            out.append(f"{name} = " + " ".join([terms[0], *terms[1:]]))
        return out

    def text(self, robot_name: str) -> str:
        """What ``anadyn equations --base-parameters`` prints."""
        lines = [f"{robot_name}: {self.rank} base parameters of {len(self.names)} "
                 "(10 per body: m, m*c, inertia about the body origin in body axes "
                 "Ixx Ixy Iyy Ixz Iyz Izz; per moving joint Ia armature, Fv viscous, "
                 "Fc Coulomb friction)", *self.expressions()]
        if self.exact is not None:
            lines.append(f"exact coefficients (Kane, rational): numeric ones agree to "
                         f"{self.exact_difference:.1e}")
        else:
            lines.append(f"numeric coefficients only ({self.note or 'not asked for'})")
        return "\n".join(lines)

    @property
    def exact_difference(self) -> float | None:
        """Largest |numeric beta - exact beta|, None without an exact beta."""
        if self.exact is None:
            return None
        return float(np.max(np.abs(np.array(self.exact, float) - self.beta), initial=0.0))


def _term(c: float, name: str) -> str:
    sign = "-" if c < 0 else "+"
    text = _number(abs(c))
    return f"{sign} {name}" if text == "1" else f"{sign} {text}*{name}"


def _number(x: float) -> str:
    f = Fraction(x).limit_denominator(1000)
    if abs(float(f) - x) <= 1e-9 * max(1.0, x):
        return str(f)
    return f"{x:.10g}"


def random_states(model: ParametricModel, count: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    n = len(model.coordinates)
    span = np.array([np.pi if u == "rad" else 0.5 for u in model.units])
    return (rng.uniform(-1, 1, (count, n)) * span, rng.normal(0, 1, (count, n)),
            rng.normal(0, 1, (count, n)))


def base_parameters(model: ParametricModel, states: int = STATES, seed: int = 0,
                    exact: bool | None = None) -> BaseParameters:
    """The base parameters of ``model`` (module docstring); ``exact``: also solve
    them exactly (None: when the robot has at most three coordinates)."""
    from scipy.linalg import qr

    Y = np.concatenate(model.regressor(*random_states(model, states, seed)))
    norms = np.linalg.norm(Y, axis=0)
    acting = np.flatnonzero(norms > 1e-12 * norms.max())
    scaled = Y[:, acting] / norms[acting]
    _, R, pivots = qr(scaled, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(R))
    rank = int(np.sum(diagonal > RANK_TOLERANCE * diagonal[0]))
    chosen = _first_independent(scaled, rank)
    independent = tuple(sorted(int(acting[k]) for k in (
        pivots[:rank] if chosen is None else chosen)))
    dependent = tuple(j for j in range(Y.shape[1]) if j not in independent)
    beta = np.linalg.lstsq(Y[:, list(independent)], Y[:, list(dependent)], rcond=None)[0]
    beta[np.abs(beta) < 1e-10 * max(1.0, np.abs(beta).max())] = 0.0
    result = BaseParameters(model.names, independent, dependent, beta)
    if exact is None:
        exact = len(model.coordinates) <= EXACT_MAX_COORDINATES
    return exact_coefficients(model, result) if exact else result


def _first_independent(columns: np.ndarray, rank: int) -> list[int] | None:
    """The columns kept going through them in order (a column is kept when its part
    orthogonal to those kept is above the rank tolerance), if that gives ``rank``
    of them: the base parameters then regroup later bodies into earlier ones and
    drive parameters into inertial ones, as usually written."""
    basis, kept = np.zeros((len(columns), 0)), []
    for k in range(columns.shape[1]):
        residual = columns[:, k] - basis @ (basis.T @ columns[:, k])
        size = np.linalg.norm(residual)
        if size > 1e-6:
            basis = np.column_stack([basis, residual / size])
            kept.append(k)
    return kept if len(kept) == rank else None


def exact_coefficients(model: ParametricModel, result: BaseParameters) -> BaseParameters:
    """``result`` with ``exact``: beta over the rationals (module docstring), or with
    ``note`` saying why not."""
    symbolic_Y, ddq = symbolic_regressor(model)
    if symbolic_Y is None:
        return dataclasses.replace(result, note=ddq)
    rows = _coefficient_rows(symbolic_Y, model.robot, ddq)
    if rows is None:
        return dataclasses.replace(result, note="the coefficients are not all rational")
    from sympy.polys.matrices import DomainMatrix

    ind, dep = list(result.independent), list(result.dependent)
    A = DomainMatrix.from_Matrix(rows[:, ind]).convert_to(sp.QQ)
    Bm = DomainMatrix.from_Matrix(rows[:, dep]).convert_to(sp.QQ)
    At = A.transpose()
    try:
        X = (At * A).inv() * (At * Bm)
    except (ValueError, ZeroDivisionError):
        return dataclasses.replace(result, note="the exact columns of the independent "
                                                "parameters are dependent")
    if A * X != Bm:
        return dataclasses.replace(result, note="the exact regressor has a higher rank than "
                                                "the numeric one")
    return dataclasses.replace(result, exact=X.to_Matrix())


def _rational(value):
    return sp.nsimplify(value, rational=True)


def symbolic_regressor(model: ParametricModel):
    """(Y, ddq): the generalized forces' Jacobian with respect to the ten standard
    parameters of every body, from Kane's equations of the robot with those
    parameters as symbols and its numbers as rationals, and the drive parameters'
    columns (J^T times ddtheta, dtheta and a symbol for the smoothed sign of
    dtheta); (None, reason) when that does not apply."""
    from ...symbolic.formulations import derive

    robot = model.robot

    if len(robot.coordinates) > EXACT_MAX_COORDINATES:
        return None, f"more than {EXACT_MAX_COORDINATES} coordinates"
    symbols, bodies = [], []
    for body in robot.bodies:
        s = sp.symbols(" ".join(f"{p}_{body.name}" for p in INERTIAL), real=True)
        symbols += s
        m, h = s[0], sp.Matrix(s[1:4])
        I_O = sp.zeros(3)
        for (r, c), value in zip(INERTIA_ENTRIES, s[4:]):
            I_O[r, c] = I_O[c, r] = value
        inertia = I_O - ((h.T * h)[0] * sp.eye(3) - h * h.T) / m
        joint = dataclasses.replace(
            body.joint, origin=tuple(map(_rational, body.joint.origin)),
            rpy=tuple(map(_rational, body.joint.rpy)), axis=tuple(map(_rational, body.joint.axis)),
            damping=sp.Integer(0), friction=sp.Integer(0), stiffness=sp.Integer(0))
        bodies.append(dataclasses.replace(body, joint=joint, mass=m, com=tuple(h / m),
                                          inertia=sp.ImmutableMatrix(inertia)))
    bare = dataclasses.replace(
        robot, bodies=tuple(bodies), controller=None, loads=(),
        gravity=tuple(map(_rational, robot.gravity)),
        parameters={k: _rational(v) for k, v in robot.parameters.items()})
    eom = derive(bare, "kane", tidy=False)
    demand = eom.M * sp.Matrix(eom.ddq) - eom.F
    columns = [sp.Matrix(demand).jacobian(symbols).applyfunc(sp.cancel)]
    J = sp.Matrix(model.J.shape[0], model.J.shape[1], [_rational(x) for x in model.J.flat])
    for j in range(J.shape[0]):
        row = J[j, :]
        sign = sp.Symbol(f"_sign{j}", real=True)
        rate, acc = (row * sp.Matrix(robot.dq))[0], (row * sp.Matrix(eom.ddq))[0]
        columns.append(row.T * sp.Matrix([[acc, rate, sign]]))
    return sp.Matrix.hstack(*columns), eom.ddq


def _coefficient_rows(Y: sp.Matrix, robot, ddq) -> sp.Matrix | None:
    """The columns of Y as vectors of polynomial coefficients: one row per (output,
    monomial) in sin q, cos q, q, dq, ddq, reduced modulo sin^2 + cos^2 = 1; None
    when a coefficient is not rational."""
    q = robot.q
    s = sp.symbols(f"_s0:{len(q)}", real=True)
    c = sp.symbols(f"_c0:{len(q)}", real=True)
    dq = robot.dq
    trig = {sp.sin(x): si for x, si in zip(q, s)} | {sp.cos(x): ci for x, ci in zip(q, c)}
    signs = sp.symbols(f"_sign0:{len(robot.bodies)}", real=True)
    gens = (*s, *c, *q, *dq, *ddq, *signs)
    ideal = [si ** 2 + ci ** 2 - 1 for si, ci in zip(s, c)]
    table: dict[tuple, dict[int, sp.Rational]] = {}
    for col in range(Y.shape[1]):
        for row in range(Y.shape[0]):
            e = sp.expand(sp.expand_trig(Y[row, col])).xreplace(trig)
            if e == 0:
                continue
            if not all(a.is_Rational for a in sp.Poly(e, *gens).coeffs()):
                return None
            reduced = sp.reduced(e, ideal, *gens)[1] if ideal else e
            for monomial, coeff in sp.Poly(reduced, *gens).terms():
                table.setdefault((row, monomial), {})[col] = coeff
    out = sp.zeros(len(table), Y.shape[1])
    for k, entries in enumerate(table.values()):
        for col, coeff in entries.items():
            out[k, col] = coeff
    return out
