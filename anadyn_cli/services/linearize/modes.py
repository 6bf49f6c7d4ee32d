"""Modes (eigenvalues, natural frequencies, damping ratios, the PBH test) and the
controllability rank of a linear system."""
from __future__ import annotations

import math

import numpy as np

#: relative size under which a Krylov direction or a PBH singular value counts as zero
RANK_TOL = 1e-9


def modes(A: np.ndarray, B: np.ndarray | None = None) -> list[dict]:
    """Eigenvalues with natural frequency, damping ratio, time constant; PBH test with B
    (A and B real: in real arithmetic for a real lambda, once per pair of complex
    conjugates, [A - conj(lambda) I, B] being the conjugate of [A - lambda I, B],
    with its singular values)."""
    values = np.linalg.eigvals(A)
    order = np.lexsort((values.imag, np.abs(values)))
    scale = max(np.linalg.norm(A, 2), np.linalg.norm(B, 2) if B is not None and B.size else 0.0,
                1e-300)
    smallest: dict = {}          # lambda (real, or with imag > 0) -> its PBH singular value
    result = []
    for lam in values[order]:
        size = abs(lam)
        entry = {"real": float(lam.real), "imag": float(lam.imag),
                 "natural_frequency": float(size), "frequency_hz": float(size / (2 * math.pi)),
                 "damping_ratio": float(-lam.real / size) if size > 0 else None,
                 "time_constant": float(1 / abs(lam.real)) if lam.real != 0 else None}
        if B is not None:
            if B.size == 0:
                entry["controllable"] = False
            else:
                key = complex(lam.real, abs(lam.imag)) if lam.imag else float(lam.real)
                if key not in smallest:
                    pbh = np.hstack([A - key * np.eye(len(A)), B])
                    smallest[key] = np.linalg.svd(pbh, compute_uv=False)[-1]
                entry["controllable"] = bool(smallest[key] > RANK_TOL * max(scale, size))
        result.append(entry)
    return result


def controllability_rank(A: np.ndarray, B: np.ndarray) -> int:
    """Dimension of the controllable subspace of (A, B): orthonormal Krylov blocks."""
    size = len(A)
    if B.size == 0:
        return 0
    scale = max(np.linalg.norm(A, 2), np.linalg.norm(B, 2))
    U, s, _ = np.linalg.svd(B, full_matrices=False)
    basis = U[:, s > RANK_TOL * scale]
    new = basis
    while new.shape[1] and basis.shape[1] < size:
        W = A @ new
        for _ in range(2):                      # project out twice (Gram-Schmidt, again)
            W = W - basis @ (basis.T @ W)
        U, s, _ = np.linalg.svd(W, full_matrices=False)
        new = U[:, s > RANK_TOL * scale]
        basis = np.hstack([basis, new])
    return int(min(basis.shape[1], size))
