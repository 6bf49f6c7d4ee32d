"""The mass matrix M(q) in numbers, by a recursion of its own, to spot robots
whose M is singular everywhere before anything is derived.

    M(q) = sum_i  m_i V_i^T V_i + W_i^T (R_i I_i R_i^T) W_i

with W_i, V_i the partial angular velocities of body i and the partial
velocities of its mass centre (3 x n, world axes), built from the root out:

    W_i  = W_p [+ s_w (d theta/dq)]
    Vo_i = Vo_p + W_p x (o_i - o_p) [+ v_w (d theta/dq)]
    V_i  = Vo_i + W_i x (c_i - o_i)

((s_w, v_w) the joint's motion subspace in world axes, ``joints``: (a_w, -) for
a revolute joint, (-, a_w) for a prismatic one, none for a fixed one; a_w the
joint axis in world axes, theta the displacement, o the body origins, c the mass
centre).
It shares no code with ``anadyn_cli.kinematics``: the loader uses it before
any symbolic work, and the tests compare it with the derived M.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import sympy as sp

from .expressions import approximate
from .names import GROUND
from .robot import Robot

#: M is taken as singular when, scaled to a unit diagonal, its smallest
#: eigenvalue is below SINGULAR, or when a diagonal entry is below ZERO times
#: the largest (rounding leaves about 1e-32 where a coordinate moves nothing)
SINGULAR = 1e-10
ZERO = 1e-24
RANDOM_STATES = 2


def _number(expr: sp.Expr, values: dict) -> float:
    if expr.is_Symbol and expr in values:             # a joint's own coordinate
        expr = values[expr]
    if isinstance(expr, (sp.Float, sp.Rational)):     # most entries: the number itself,
        value = float(expr)                           # rounded once (as evalf does)
        if math.isfinite(value):
            return value
    approximate(expr, values)        # ExpressionError (a ValueError) where it overflows
    value = complex(expr.xreplace(values).evalf())
    if value.imag != 0 or not math.isfinite(value.real):
        raise ValueError(f"not a finite real number: {expr}")
    return value.real


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: cos I + sin [a]x + (1 - cos) a a^T for a unit axis."""
    x, y, z = axis
    skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return (math.cos(angle) * np.eye(3) + math.sin(angle) * skew
            + (1 - math.cos(angle)) * np.outer(axis, axis))


def _rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    e = np.eye(3)
    return _rotation(e[2], yaw) @ _rotation(e[1], pitch) @ _rotation(e[0], roll)


def _cross_columns(W: np.ndarray, r: np.ndarray) -> np.ndarray:
    return np.cross(W.T, r).T


class MassMatrix:
    """M(q) of ``robot`` at numeric states; constants are evaluated once."""

    def __init__(self, robot: Robot):
        self.robot = robot
        self.values = robot.parameter_substitution()
        self.q = robot.q
        self.bodies = []
        for body in robot.bodies:
            joint = body.joint
            number = lambda e: _number(e, self.values)   # noqa: E731
            displacement = joint.displacement.xreplace(self.values)
            rates = [sp.diff(displacement, s) if s in displacement.free_symbols
                     else sp.Integer(0) for s in self.q]
            self.bodies.append(dict(
                name=body.name, parent=body.parent, joint_type=joint.joint_type,
                axis=np.array([number(a) for a in joint.axis]),
                origin=np.array([number(a) for a in joint.origin]),
                C=_rpy(*(number(a) for a in joint.rpy)),
                displacement=displacement, rates=rates,
                mass=number(body.mass), com=np.array([number(c) for c in body.com]),
                inertia=np.array([[number(e) for e in row] for row in body.inertia.tolist()])))

    def __call__(self, q: Sequence[float]) -> np.ndarray:
        """M at the coordinates ``q``; ValueError where the joints are not defined."""
        with np.errstate(all="ignore"):
            return self._evaluate(q)

    def _evaluate(self, q: Sequence[float]) -> np.ndarray:
        n = len(self.q)
        state = {s: sp.Float(v) for s, v in zip(self.q, q)}
        frames = {GROUND: (np.eye(3), np.zeros(3), np.zeros((3, n)), np.zeros((3, n)))}
        M = np.zeros((n, n))
        for b in self.bodies:
            R_p, o_p, W_p, Vo_p = frames[b["parent"]]
            R_j = R_p @ b["C"]
            o_i = o_p + R_p @ b["origin"]
            W, Vo = W_p, Vo_p + _cross_columns(W_p, o_i - o_p)
            R_i = R_j
            kind = b["joint_type"]
            if kind.moving:
                angular, linear = kind.subspace(R_j @ b["axis"])        # world axes
                d = _number(b["displacement"], state)
                grad = np.array([_number(r, state) for r in b["rates"]])
                if angular is not None:
                    R_i = R_j @ _rotation(b["axis"], d)
                    W = W_p + np.outer(angular, grad)
                if linear is not None:
                    o_i = o_i + linear * d
                    Vo = Vo_p + _cross_columns(W_p, o_i - o_p) + np.outer(linear, grad)
            frames[b["name"]] = (R_i, o_i, W, Vo)
            r = R_i @ b["com"]
            V = Vo + _cross_columns(W, r)
            inertia = R_i @ b["inertia"] @ R_i.T
            M += b["mass"] * V.T @ V + W.T @ inertia @ W
        if not np.isfinite(M).all():
            raise ValueError("mass matrix not finite")
        return M


def null_motion(M: np.ndarray) -> np.ndarray | None:
    """A unit rate vector dq with dq^T M dq = 0 (largest entry positive), or None."""
    diagonal = np.diag(M).copy()
    scale_max = float(diagonal.max(initial=0.0))
    n = len(M)
    for i in range(n):
        if diagonal[i] <= ZERO * scale_max or diagonal[i] <= 0:
            v = np.zeros(n)
            v[i] = 1.0
            return v
    s = 1 / np.sqrt(diagonal)
    scaled = s[:, None] * M * s[None, :]
    if not np.isfinite(scaled).all():
        raise ValueError("mass matrix not finite")
    eigenvalues, vectors = np.linalg.eigh(scaled)
    if eigenvalues[0] > SINGULAR:
        return None
    v = s * vectors[:, 0]
    v /= np.abs(v).max()
    return v if v[np.argmax(np.abs(v))] > 0 else -v


def singular_everywhere(robot: Robot, initial: Sequence[float], seed: int = 20240607
                        ) -> np.ndarray | None:
    """The motion that moves no mass if M is singular at ``initial`` and at
    RANDOM_STATES random states near it (each coordinate moved by up to 1),
    else None.  States where the joints are not defined are skipped; fewer
    than RANDOM_STATES usable random states mean no verdict (None)."""
    mass_matrix = MassMatrix(robot)
    try:
        motion = null_motion(mass_matrix(initial))
    except (ValueError, ArithmeticError, TypeError, np.linalg.LinAlgError):
        return None
    if motion is None:
        return None
    rng = np.random.default_rng(seed)
    singular = 0
    for _ in range(4 * RANDOM_STATES):
        q = np.asarray(initial, dtype=float) + rng.uniform(-1.0, 1.0, len(initial))
        try:
            found = null_motion(mass_matrix(q))
        except (ValueError, ArithmeticError, TypeError, np.linalg.LinAlgError):
            continue
        if found is None:
            return None
        singular += 1
        if singular == RANDOM_STATES:
            return motion
    return None
