"""Central differences (step ~eps^(1/3)): for the control laws' derivatives in a
``GenericModel`` (the kernel's own Jacobian is exact, forward mode) and the
integrators' Jacobian of a robot with a spherical joint (``native.models``)."""
from __future__ import annotations

import numpy as np

#: the relative step, times max(1, |x_k|) (~eps^(1/3))
STEP = 6e-6


def central_differences(f, x: np.ndarray) -> np.ndarray:
    """df/dx (len(f(x)) x len(x)) by central differences of ``f`` (an array of the
    array x), step STEP max(1, |x_k|)."""
    columns = []
    for k in range(len(x)):
        up, down = x.copy(), x.copy()
        up[k] += STEP * max(1.0, abs(x[k]))
        down[k] -= STEP * max(1.0, abs(x[k]))
        columns.append((np.asarray(f(up), dtype=float) - np.asarray(f(down), dtype=float))
                       / (up[k] - down[k]))
    return np.stack(columns, axis=1)
