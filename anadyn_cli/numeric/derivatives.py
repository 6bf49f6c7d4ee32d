"""Open-loop derivatives of one robot's forward and inverse dynamics, from the
generated code of ``recursive.derivatives`` (``Derivatives``; ``anadyn.derivatives``).

M(q) ddq = F(t, q, dq) + B(t, q) tau with the actuators' efforts tau given (not
their control laws); F holds gravity, loads and the joint springs, dampers and
friction.  Shapes, n coordinates and m efforts (``coordinates``, ``effort_names``):

    forward_dynamics(t, q, dq, tau)    -> ddq (n,)
    forward_derivatives(t, q, dq, tau) -> d(ddq)/dq (n, n), d(ddq)/d(dq) (n, n),
                                          d(ddq)/dtau (n, m) = M^-1 B
    inverse_derivatives(t, q, dq, ddq) -> d(ID)/dq (n, n), d(ID)/d(dq) (n, n),
                                          d(ID)/d(ddq) = M (n, n)
    mass_matrix_inverse(q)             -> M^-1 (n, n)

where ID = M ddq - F = B tau are the generalized forces of the inverse dynamics.
Batched: q, dq, tau (or ddq) of shape (N, n), (N, n), (N, m) (row-major, one state
per row; t a number or shape (N,)) give arrays (N, n), (N, n, n), (N, n, m), C order;
one call runs the N states.  Entry [i, j] is d(out_i)/d(in_j).

d(ddq)/dx = M^-1 K with K = -dID/dx at fixed ddq (forward-mode differentiation
of the traced recursive Newton-Euler algorithm).  Native: the C extension of
``recursive.derivatives.c_source`` (a dense Cholesky solve, a loop over the states
in C), compiled on first use through ``native.build`` and cached like the
dynamics' library; without a compiler (or ``ANADYN_NATIVE=0``, or
``native=False``) the generated Python runs, vectorized over the states by
NumPy, and LAPACK solves.  Both raise numpy.linalg.LinAlgError where M is not
positive definite.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .model import run_generated


class Derivatives:
    """The generated derivative functions of one robot (open trees): ``source`` is
    the generated Python module, ``native`` the C extension or None (``note`` says
    why)."""

    def __init__(self, source: str, coordinates, effort_names, native=None, note: str = ""):
        namespace = run_generated(source)
        self.source, self.native, self.note = source, native, note
        self.coordinates: tuple[str, ...] = tuple(coordinates)
        self.effort_names: tuple[str, ...] = tuple(effort_names)
        self.n, self.m = namespace["N"], namespace["M_EFFORTS"]
        self._residual, self._residual_v = (namespace["open_loop_residual"],
                                            namespace["open_loop_residual_v"])
        self._jacobian, self._jacobian_v = (namespace["open_loop_jacobian"],
                                            namespace["open_loop_jacobian_v"])

    def _states(self, q, dq, last, width: int, what: str):
        """q, dq, ``last`` as float arrays, all 1-D (one state) or all 2-D (N states)."""
        arrays = [np.asarray(a, dtype=float) for a in (q, dq, last)]
        one = arrays[0].ndim == 1
        rows = arrays[0].shape[:-1]
        for a, name, w in zip(arrays, ("q", "dq", what), (self.n, self.n, width)):
            if a.shape != (*rows, w) or len(rows) > 1:
                raise ModelError(f"{name}: shape {a.shape}; expected ({w},) for one state or "
                                 f"(N, {w}) for N states, N the same for every argument")
        return one, arrays

    def _rows(self, kernel, t, q, dq, y, shape: tuple):
        """The C kernel over the rows of (t, [q, dq], y): out of shape (N, *shape),
        or shape alone for one state."""
        one = q.ndim == 1
        count = 1 if one else q.shape[0]
        x = np.concatenate((q, dq), axis=-1)
        t = (np.full(1, float(t)) if one else
             np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), (count,))))
        out = np.empty((count, *shape))
        failed = kernel(count, t, x, np.ascontiguousarray(y), out)
        if failed >= 0:
            raise np.linalg.LinAlgError(f"mass matrix not positive definite, or a non-finite "
                                        f"result, at state {failed}")
        return out[0] if one else out

    def _call(self, one: bool, scalar, vectorized, t, q, dq, w, e):
        if one:
            return scalar(float(t), *q, *dq, *w, *e)
        N = q.shape[0]
        t = np.broadcast_to(np.asarray(t, dtype=float), (N,))
        return vectorized(t, *q.T, *dq.T, *w.T, *e.T)

    def _forward(self, one: bool, t, q, dq, tau):
        M, ID = self._call(one, self._residual, self._residual_v, t, q, dq, np.zeros_like(q), tau)
        return np.linalg.solve(M, -np.asarray(ID)[..., None])[..., 0]

    def forward_dynamics(self, t, q, dq, tau):
        """ddq solving M ddq = F + B tau: (n,) at one state, (N, n) at N states."""
        one, (q, dq, tau) = self._states(q, dq, tau, self.m, "tau")
        if self.native is not None:
            return self._rows(self.native.dynamics, t, q, dq, tau, (self.n,))
        return self._forward(one, t, q, dq, tau)

    def forward_derivatives(self, t, q, dq, tau):
        """(d(ddq)/dq, d(ddq)/d(dq), d(ddq)/dtau): (n, n), (n, n), (n, m) at one
        state, (N, n, n), (N, n, n), (N, n, m) at N states (rows of q, dq, tau)."""
        n = self.n
        one, (q, dq, tau) = self._states(q, dq, tau, self.m, "tau")
        if self.native is not None:
            D = self._rows(self.native.forward, t, q, dq, tau, (n, 2 * n + self.m))
        else:
            ddq = self._forward(one, t, q, dq, tau)
            M, K = self._call(one, self._jacobian, self._jacobian_v, t, q, dq, ddq, tau)
            D = np.linalg.solve(M, K)
        return D[..., :n], D[..., n:2 * n], D[..., 2 * n:]

    def inverse_derivatives(self, t, q, dq, ddq):
        """(d(ID)/dq, d(ID)/d(dq), M), ID = M ddq - F: (n, n) each at one state,
        (N, n, n) at N states."""
        n = self.n
        one, (q, dq, ddq) = self._states(q, dq, ddq, n, "ddq")
        if self.native is not None:
            out = self._rows(self.native.inverse, t, q, dq, ddq, (3, n, n))
            return out[..., 0, :, :], out[..., 1, :, :], out[..., 2, :, :]
        e = np.zeros(q.shape[:-1] + (self.m,))
        M, K = self._call(one, self._jacobian, self._jacobian_v, t, q, dq, ddq, e)
        return -K[..., :n], -K[..., n:2 * n], M

    def mass_matrix_inverse(self, q):
        """M(q)^-1: (n, n) for q of shape (n,), (N, n, n) for (N, n)."""
        q = np.asarray(q, dtype=float)
        zero = np.zeros_like(q)
        one, (q, _, e) = self._states(q, zero, np.zeros(q.shape[:-1] + (self.m,)), self.m, "tau")
        if self.native is not None:
            return self._rows(self.native.minv, 0.0, q, zero, e, (self.n, self.n))
        M, _ = self._call(one, self._residual, self._residual_v, 0.0, q, zero, zero, e)
        return np.linalg.inv(M)


def derivatives(robot, native: bool = True) -> Derivatives:
    """The ``Derivatives`` of a validated ``Robot`` (an open tree: the recursive path;
    a closed chain is a ModelError); ``native``: compile the C extension now when it
    is not cached (unless ANADYN_NATIVE=0 or no compiler)."""
    from . import native as cc
    from .recursive import derivatives as traced, plan

    if robot.constraints is not None:
        raise ModelError(f"{robot.source}: derivatives need an open tree; {robot.name} has "
                         "closed loops (constraints)")
    pl = plan(robot)
    module, note = None, "native=False"
    if native:
        c_text = traced.c_source(pl)
        module, note = ((None, "an expression has no C form") if c_text is None
                        else cc.load(c_text, how="off" if cc.mode() == "off" else "wait"))
    return Derivatives(traced.module_source(pl), pl.coordinates, pl.efforts, module, note)
