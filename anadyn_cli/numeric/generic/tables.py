"""A robot's numeric tables, as the generic kernel (``kernel.c``) reads them.

``pack(plan)`` gives ``Tables`` (the integer and double arrays laid out as the
top of kernel.c says), or None with the reason when the kernel cannot serve
the robot: external loads or contacts, a joint displacement that is not affine in
the coordinates (theta = A q + c; nonlinear couplings stay with the generated
code).  Joints: revolute, prismatic, fixed and spherical (its quaternion in the
coordinates, its three speeds the angular velocity in body axes: unit rows of A,
``plan.Plan``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: kernel.c's joint kinds
KINDS = {"fixed": 0, "revolute": 1, "prismatic": 2, "spherical": 3}
#: kernel.c's doubles per body and per moving joint
BODY, PASSIVE = 28, 5
#: MODE: theta = q + c; A square and invertible; otherwise (CRBA + Cholesky)
IDENTITY, INVERTIBLE, GENERAL = 0, 1, 2


@dataclass(frozen=True)
class Tables:
    ints: np.ndarray              # int32
    doubles: np.ndarray           # float64
    A: np.ndarray                 # d(theta)/dq, (moving joints, n)
    actuator_joint: tuple[int, ...]
    mode: int
    actuator_scale: tuple[float, ...] = ()   # generalized force per unit effort (a drive's N k_t)

    def effort_map(self) -> np.ndarray:
        """S (moving joints x efforts): the joint forces per unit effort, each effort on
        its joint with its scale (a drive's N k_t, else 1); B = A^T S."""
        S = np.zeros((self.A.shape[0], len(self.actuator_joint)))
        S[list(self.actuator_joint), np.arange(len(self.actuator_joint))] = self.actuator_scale
        return S

    def to_dict(self) -> dict:
        """Plain lists and numbers (a cache record's form)."""
        return {"ints": self.ints.tolist(), "doubles": self.doubles.tolist(),
                "A": self.A.tolist(), "mode": self.mode,
                "actuator_joint": list(self.actuator_joint),
                "actuator_scale": [float(s) for s in self.actuator_scale]}

    @classmethod
    def from_dict(cls, t: dict) -> "Tables":
        """The tables of ``to_dict``'s form (KeyError, TypeError, ValueError if not)."""
        return cls(np.array(t["ints"], dtype=np.int32), np.array(t["doubles"], dtype=float),
                   np.array(t["A"], dtype=float), tuple(int(j) for j in t["actuator_joint"]),
                   int(t["mode"]), tuple(float(s) for s in t["actuator_scale"]))

    def passive(self) -> np.ndarray:
        """(moving joints, 5): damping, friction, friction velocity, stiffness, rest
        (kernel.c's PASSIVE doubles, after the gravity and the bodies)."""
        start = 3 + BODY * int(self.ints[0])
        return self.doubles[start:start + PASSIVE * self.A.shape[0]].reshape(-1, PASSIVE)


def affine_map(pl) -> tuple[np.ndarray, np.ndarray] | None:
    """(A, c) with theta = A q + c for the moving joints, None when a displacement
    is not affine in the coordinates (its gradient depends on q)."""
    import sympy as sp

    n, rows, offsets = pl.n, [], []
    zero = {sp.Symbol(f"_q{k}", real=True): sp.S.Zero for k in range(n)}
    for displacement, grad, _ in pl.joint_expressions():
        if any(g.free_symbols for g in grad):
            return None
        offset = displacement.xreplace(zero)   # a SymPy expression (plan)
        if offset.free_symbols:               # e.g. t in a displacement
            return None
        rows.append([float(g) for g in grad])
        offsets.append(float(offset))
    return np.array(rows, dtype=float).reshape(len(rows), n), np.array(offsets, dtype=float)


def _in_order(b, A: np.ndarray) -> bool:
    """Whether spherical joint ``b``'s quaternion is four coordinates in a row and its
    joint rows of A are unit rows on its three speeds, in order (as kernel.c reads)."""
    first = b.quaternion[0]
    return (list(b.quaternion) == list(range(first, first + 4))
            and np.array_equal(A[b.joint:b.joint + 3], np.eye(A.shape[1])[b.speed:b.speed + 3]))


def pack(pl) -> tuple[Tables | None, str]:
    """(Tables, "") for ``recursive.plan`` ``pl``, or (None, why not)."""
    if pl.loads:
        return None, "external loads"
    if pl.contacts:
        return None, "contacts"
    if not pl.moving or pl.n == 0:
        return None, "no moving joint"
    words = [b.joint_type.word for b in pl.bodies]
    if any(w not in KINDS for w in words):
        return None, "a joint type the kernel does not know"
    if any(b.parent is not None and b.parent >= i for i, b in enumerate(pl.bodies)):
        return None, "bodies not listed parents first"
    joint_map = affine_map(pl)
    if joint_map is None:
        return None, "a joint displacement that is not affine in the coordinates"
    A, c = joint_map
    if any(b.quaternion is not None and not _in_order(b, A) for b in pl.bodies):
        return None, "a quaternion's coordinates or speeds out of order"
    nm, n = A.shape
    if nm == n and np.array_equal(A, np.eye(n)):
        mode, extra = IDENTITY, []
    elif nm == n and abs(np.linalg.det(A)) > 1e-12:
        mode, extra = INVERTIBLE, [np.linalg.inv(A).ravel()]
    else:
        mode, extra = GENERAL, []
    ints = [len(pl.bodies), n, nm, mode, pl.nq]
    doubles = [np.asarray(pl.gravity, dtype=float)]
    for i, b in enumerate(pl.bodies):
        ints += [-1 if b.parent is None else b.parent, KINDS[words[i]],
                 -1 if b.joint is None else b.joint,
                 *((b.quaternion[0], b.speed) if b.quaternion else (-1, -1))]
        doubles += [np.array(b.C, dtype=float).T.ravel(), b.origin, b.axis, [b.mass], b.h,
                    np.array(b.I_O, dtype=float).ravel()]
    for body in pl.moving:
        b = pl.bodies[body]
        doubles.append([b.damping, b.friction, b.friction_velocity, b.stiffness, b.rest])
    doubles += [A.ravel(), c, *extra]
    return Tables(np.array(ints, dtype=np.int32),
                  np.concatenate([np.asarray(d, dtype=float).ravel() for d in doubles]),
                  A, tuple(pl.actuator_joint), mode,
                  tuple(pl.actuator_scale) or (1.0,) * len(pl.actuator_joint)), ""
