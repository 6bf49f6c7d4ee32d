"""``check``'s integrands over a robot's tables, by the generic kernel's ``energies``
(kernel.c), at states x = [q, u]:

    T   = 1/2 sum_i v_i . I_i v_i             v_i the body velocity, I_i its spatial
                                              inertia about the body origin
    V   = -sum_i g . (m_i p_i + R_i h_i) + sum_j 1/2 k_j (theta_j - rest_j)^2
                                              p_i, R_i the body's origin and axes in
                                              the world, h_i = m_i c_i
    P_d = sum_j dtheta_j (b_j dtheta_j + f_j tanh(dtheta_j / v_j))
                                              what joint damping and friction dissipate

from the kinematics (positions, velocities, joint rates), not from the force terms
of the dynamics, so that ``check``'s energy balance still tests the accelerations.
The tables hold no loads: the loads' power is zero.  They serve a cold run
(``GenericModel``) and a warm run of a robot whose cache entry holds its tables
(``build``), in place of the generated Python's ``potential`` and ``powers``
(the same numbers to rounding, ~1e-15 relative, and ~10x faster a call).
"""
from __future__ import annotations

import numpy as np

from .tables import Tables


class Energies:
    """The kernel's T, V and P_d of one robot (module docstring); ``module`` the
    kernel, or None to load it when first asked for (``available``)."""

    def __init__(self, tables: Tables, module=None):
        self._kernel, self._ints, self._doubles = module, tables.ints, tables.doubles
        self._asked = module is not None
        #: damping, friction, friction velocity, stiffness, rest of each moving joint
        self.passive = tables.passive()

    def available(self) -> bool:
        """Whether the kernel is there: loaded when first asked for (built then, the
        first time ever in this cache folder), so that a run that never asks for an
        energy loads nothing; False when native code cannot be built."""
        if not self._asked:
            from . import kernel

            self._asked, self._kernel = True, kernel()
        return self._kernel is not None

    def _evaluate(self, q, dq) -> tuple[np.ndarray, tuple]:
        """[T, V, P_d] over broadcast arrays q (nq, ...) and dq (n, ...) -> ((count, 3),
        the states' shape)."""
        if isinstance(q, np.ndarray) and isinstance(dq, np.ndarray) and q.shape[1:] == dq.shape[1:]:
            shape = q.shape[1:]                 # the states as arrays (check's path)
            states = np.concatenate((q, dq)).reshape(len(q) + len(dq), -1).T
        else:
            arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (*q, *dq)))
            shape = arrays[0].shape
            states = np.stack([a.reshape(-1) for a in arrays], axis=1)
        states = np.ascontiguousarray(states, dtype=float)
        out = np.empty((len(states), 3))
        if self._kernel.energies(self._ints, self._doubles, len(states), states, out) == 1:
            raise MemoryError("the generic kernel's energies")
        return out, shape

    def energy(self, q, dq) -> tuple[np.ndarray, np.ndarray]:
        """(T, V) over arrays of states."""
        out, shape = self._evaluate(q, dq)
        return out[:, 0].reshape(shape), out[:, 1].reshape(shape)

    def powers(self, t, q, dq) -> np.ndarray:
        """(2, ...): the loads' power (zero) and P_d."""
        out, shape = self._evaluate(q, dq)
        powers = np.zeros((2, *(np.broadcast_shapes(np.shape(t), shape) if np.ndim(t) else shape)))
        powers[1] = out[:, 2].reshape(shape)
        return powers
