"""What inverse dynamics needs of the robot: one independent actuator per coordinate
(B square and non-singular at every point), and finite efforts; each failure one line
naming what is not actuated."""
from __future__ import annotations

import numpy as np

from ...errors import ModelError, NumericalError
from ...model.info import RobotInfo

SINGULAR = 1e-10             # |det B| / prod |columns of B| below this: B singular
NEEDS = "inverse dynamics needs one independent actuator per coordinate (B square and non-singular)"


def check_counts(info: RobotInfo) -> None:
    if not info.actuators:
        names = [c.name for c in info.coordinates]
        raise ModelError(f"{len(names)} coordinate{'s' * (len(names) != 1)}, no actuators: "
                         f"{NEEDS}; "
                         f"not actuated: {', '.join(names)}", source=info.source,
                         path="actuators")


def constant(B: np.ndarray) -> bool:
    """Whether the stack B (N, n, m) is one matrix (a broadcast one is, unread)."""
    return B.strides[0] == 0 or bool((B == B[:1]).all())


def check_actuation(info: RobotInfo, t: np.ndarray, B: np.ndarray, names: list[str],
                     hint: str = "") -> None:
    """B (N, n, m) must be square and non-singular at every point; say what is not actuated
    (``names``: of its rows; ``hint`` follows that list)."""
    n, m = B.shape[1:]
    if n == m == 0:               # spherical and floating joints alone: nothing to solve
        return
    counts = f"{n} coordinate{'s' * (n != 1)}, {m} actuator{'s' * (m != 1)}"
    if m != n:
        lost = _not_actuated(B[0], names)
        if lost:
            raise ModelError(f"{counts}: {NEEDS}; not actuated: {lost}{hint}",
                             source=info.source, path="actuators")
        idle = describe(null_space(B[0]), [a.name for a in info.actuators])
        raise ModelError(f"{counts}: {NEEDS}; the efforts are not unique (efforts {idle} "
                         "produce no generalized force)", source=info.source, path="actuators")
    if len(B) and constant(B):
        bad = 0 if _singular(B[:1])[0] else None
    else:
        flags = np.flatnonzero(_singular(B))
        bad = int(flags[0]) if len(flags) else None
    if bad is not None:
        raise ModelError(f"{counts}, but B is singular at t = {t[bad]:g} s: {NEEDS}; "
                         f"not actuated: {_not_actuated(B[bad], names)}{hint}",
                         source=info.source, path="actuators")


def _singular(B: np.ndarray) -> np.ndarray:
    """Per point: |det B| small against the product of its column lengths (Hadamard)."""
    with np.errstate(all="ignore"):
        scale = np.prod(np.linalg.norm(B, axis=-2), axis=-1)
        ratio = np.abs(np.linalg.det(B)) / scale
    return ~(ratio > SINGULAR)


def null_space(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis (columns) of {v : A v = 0}."""
    _, s, vt = np.linalg.svd(A)
    tol = max(A.shape) * np.finfo(float).eps * 1e3 * (s[0] if len(s) else 0.0)
    rank = int((s > tol).sum())
    return vt[rank:].T


def _not_actuated(B: np.ndarray, names: list[str]) -> str:
    """Coordinates (or combinations) along which B^T v = 0: no effort reaches them."""
    basis = null_space(B.T)
    if basis.shape[1] == 0:
        return ""
    size = np.abs(B).max(axis=1, initial=0.0)
    zero = [i for i in range(len(names)) if size[i] <= 1e-12 * max(size.max(), 1.0)]
    words = [names[i] for i in zero]
    if len(zero) < basis.shape[1]:
        rest = basis.copy()
        rest[zero] = 0
        u, s, _ = np.linalg.svd(rest, full_matrices=False)
        rest = u[:, s > 1e-9][:, : basis.shape[1] - len(zero)]
        words.append("the combined motion " + describe(rest, ["d" + n for n in names]))
    return ", ".join(words)


def describe(basis: np.ndarray, names: list[str]) -> str:
    """Columns of ``basis`` as ratios of ``names``, e.g. 'q1:q2 = 1:1'."""
    out = []
    for v in basis.T:
        v = v / v[np.argmax(np.abs(v))]
        used = [(name, c) for name, c in zip(names, v) if abs(c) > 1e-9]
        out.append(":".join(name for name, _ in used) + " = "
                   + ":".join(f"{c:.4g}" for _, c in used))
    return ", ".join(out)


def finite(info: RobotInfo, t, values, what: str) -> None:
    bad = ~np.isfinite(values).all(axis=-1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise NumericalError(f"{info.source}: {what} are not finite at t = {t[k]:g} s")
