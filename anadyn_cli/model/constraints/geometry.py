"""The constraint equations in floating point: world poses of the body frames at
numeric q (forward kinematics of their own: the loader runs before any symbolic
work), f(q, t), its Jacobian by central differences and the velocity rows."""
from __future__ import annotations

import math

import numpy as np
import sympy as sp

from ..names import GROUND
from ..robot import Body
from .equations import DIRECTIONS, TIME


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return (math.cos(angle) * np.eye(3) + math.sin(angle) * skew
            + (1 - math.cos(angle)) * np.outer(axis, axis))


def number(expr, values) -> float:
    return float(expr.xreplace(values)) if isinstance(expr, sp.Basic) else float(expr)


class Geometry:
    """World poses of the body frames at numeric q (floating point)."""

    def __init__(self, bodies: tuple[Body, ...], values: dict, q_symbols: list):
        self.items = []
        e = np.eye(3)
        for body in bodies:
            joint = body.joint
            roll, pitch, yaw = (number(a, values) for a in joint.rpy)
            C = rotation(e[2], yaw) @ rotation(e[1], pitch) @ rotation(e[0], roll)
            axis = np.array([number(a, values) for a in joint.axis])
            norm = np.linalg.norm(axis)
            axis = axis / norm if norm > 0 else axis
            origin = np.array([number(a, values) for a in joint.origin])
            kind = joint.joint_type
            move = (sp.lambdify(q_symbols, joint.displacement.xreplace(values), modules="math")
                    if kind.moving else None)
            self.items.append((body.name, body.parent, kind, C, axis, origin, move))

    def poses(self, q) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Body name -> (R, p): body axes to world axes, body origin in world axes."""
        poses = {GROUND: (np.eye(3), np.zeros(3))}
        for name, parent, kind, C, axis, origin, move in self.items:
            R_p, p_p = poses[parent]
            R_l, o = kind.transform(C, origin, axis, float(move(*q)) if move else 0.0, rotation)
            poses[name] = (R_p @ R_l, p_p + R_p @ o)
        return poses


class System:
    """The constraint equations in numbers: holonomic f(q, t) and velocity rows."""

    def __init__(self, geometry: Geometry, loops, positions, velocities, values, coordinates):
        self.geometry, self.loops = geometry, loops
        symbols = [c.symbol for c in coordinates] + [TIME]
        self.n = len(coordinates)
        self.points = [(loop, np.array([number(v, values) for v in loop.a.point]),
                        np.array([number(v, values) for v in loop.b.point])) for loop in loops]
        self.positions = [sp.lambdify(symbols, p.expression.xreplace(values), modules="math")
                          for p in positions]
        def compiled(expr):
            return sp.lambdify(symbols, expr.xreplace(values), modules="math")

        self.velocities = [([compiled(v.coefficients.get(c.name, sp.Integer(0)))
                             for c in coordinates],
                            compiled(v.constant)) for v in velocities]
        self.paths = ([loop.path for loop in loops for _ in loop.directions]
                      + [p.path for p in positions] + [v.path for v in velocities])
        self.h = sum(len(loop.directions) for loop in loops) + len(positions)
        # a length scale for "closed": the largest distance in the file's geometry
        lengths = [np.abs(origin).sum() for *_, origin, _ in geometry.items]
        lengths += [np.abs(a).sum() + np.abs(b).sum() for _, a, b in self.points]
        self.scale = max(1.0, *lengths) if lengths else 1.0

    def f(self, q, t: float = 0.0) -> np.ndarray:
        q = [float(v) for v in q]
        out = []
        if self.points:
            poses = self.geometry.poses(q)
            for loop, a, b in self.points:
                R_a, p_a = poses[loop.a.body]
                R_b, p_b = poses[loop.b.body]
                gap = (p_a + R_a @ a) - (p_b + R_b @ b)
                out += [gap[DIRECTIONS.index(axis)] for axis in loop.directions]
        out += [float(function(*q, t)) for function in self.positions]
        return np.array(out, dtype=float)

    def jacobian(self, q, t: float = 0.0) -> np.ndarray:
        """df/dq by central differences (h x n)."""
        q = np.asarray(q, dtype=float)
        J = np.zeros((self.h, self.n))
        for k in range(self.n):
            step = 1e-6 * max(1.0, abs(q[k]))
            up, down = q.copy(), q.copy()
            up[k] += step
            down[k] -= step
            J[:, k] = (self.f(up, t) - self.f(down, t)) / (2 * step)
        return J

    def time_rate(self, q, t: float = 0.0) -> np.ndarray:
        step = 1e-6
        return (self.f(q, t + step) - self.f(q, t - step)) / (2 * step)

    def velocity_rows(self, q, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        q = [float(v) for v in q]
        A = np.array([[float(a(*q, t)) for a in row] for row, _ in self.velocities],
                     dtype=float).reshape(len(self.velocities), self.n)
        a0 = np.array([float(c(*q, t)) for _, c in self.velocities], dtype=float)
        return A, a0

    def pfaffian(self, q, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """A (c x n), a0 (c,): all constraints in velocity form, holonomic rows first."""
        A_nh, a_nh = self.velocity_rows(q, t)
        return (np.vstack([self.jacobian(q, t), A_nh]),
                np.concatenate([self.time_rate(q, t), a_nh]))

