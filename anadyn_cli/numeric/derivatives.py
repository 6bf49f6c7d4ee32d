"""Derivatives of one robot's forward and inverse dynamics (open loop, and in closed
loop with respect to parameters and gains), from the generated code of
``recursive.derivatives`` (``Derivatives``; ``anadyn.derivatives``).

M(q) ddq = F(t, q, dq) + B(t, q) tau with the actuators' efforts tau given (not
their control laws); F holds gravity, loads and the joint springs, dampers and
friction.  Shapes, n coordinates and m efforts (``coordinates``, ``effort_names``):

    forward_dynamics(t, q, dq, tau)    -> ddq (n,)
    forward_derivatives(t, q, dq, tau) -> d(ddq)/dq (n, n), d(ddq)/d(dq) (n, n),
                                          d(ddq)/dtau (n, m) = M^-1 B
    inverse_derivatives(t, q, dq, ddq) -> d(ID)/dq (n, n), d(ID)/d(dq) (n, n),
                                          d(ID)/d(ddq) = M (n, n)
    mass_matrix_inverse(q)             -> M^-1 (n, n)

and, for the k parameters or gains of the robot file chosen by
``derivatives(robot, parameters=[...])`` (``parameters``, in that order;
``recursive.parameters`` says which a parameter may enter):

    forward_parameter_derivatives(t, q, dq, tau) -> d(ddq)/dp (n, k), tau fixed
    inverse_parameter_derivatives(t, q, dq, ddq) -> d(ID)/dp (n, k), ddq fixed
    closed_loop_parameter_derivatives(t, q, dq)  -> d(ddq)/dp (n, k), tau under the
                                                    file's control laws (gains too)

where ID = M ddq - F = B tau are the generalized forces of the inverse dynamics.
Batched: q, dq, tau (or ddq) of shape (N, n), (N, n), (N, m) (row-major, one state
per row; t a number or shape (N,)) give arrays (N, n), (N, n, n), (N, n, m), C order;
one call runs the N states (the parameter derivatives: (N, n, k)).  Entry [i, j]
is d(out_i)/d(in_j).

d(ddq)/dx = M^-1 K with K = -dID/dx at fixed ddq (the analytic derivatives of the
recursive Newton-Euler algorithm, or forward-mode differentiation of the traced
algorithm, whichever costs fewer operations: ``recursive.derivatives``),
d(ddq)/dp = -M^-1 dID/dp.  Native:
the C extension of ``recursive.derivatives.c_source`` (a Cholesky solve over M's
structural nonzeros, a loop over the states in C), compiled on first use through
``native.build`` and cached like the dynamics' library; one state given as
float64 vectors is one call of its ``one_*`` functions (the checks and the result
arrays in C), anything else is converted and checked here first.  The results are
new arrays either way.  Without a compiler (or ``ANADYN_NATIVE=0``, or
``native=False``) the generated Python runs, vectorized over the states by
NumPy, and LAPACK solves.  Both raise numpy.linalg.LinAlgError where M is not
positive definite.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .model import run_generated


def _no_shortcut(*_):
    """Without C: no one-state shortcut (the general path runs)."""
    return None


class Derivatives:
    """The generated derivative functions of one robot (open trees): ``source`` is
    the generated Python module (standalone but for NumPy: ``export --derivatives``
    writes it), ``native`` the C extension or None (``note`` says why)."""

    def __init__(self, source: str, coordinates, effort_names, native=None, note: str = "",
                 parameters=()):
        self._python = run_generated(source)
        self.source, self.native, self.note = source, native, note
        self.coordinates: tuple[str, ...] = tuple(coordinates)
        self.effort_names: tuple[str, ...] = tuple(effort_names)
        self.parameters: tuple[str, ...] = tuple(parameters)
        self.n, self.m = self._python["N"], self._python["M_EFFORTS"]
        # one state given as float64 arrays: the C alone (None otherwise, or without C)
        self._one_forward, self._one_inverse, self._one_dynamics = (
            (native.one_forward, native.one_inverse, native.one_dynamics)
            if native is not None else (_no_shortcut,) * 3)

    def _states(self, q, dq, last, width: int, what: str):
        """q, dq, ``last`` as contiguous float arrays, all 1-D (one state) or all 2-D
        (N states)."""
        q, dq, last = (np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(dq, dtype=float),
                       np.ascontiguousarray(last, dtype=float))
        rows = q.shape[:-1]
        if q.shape != (*rows, self.n) or dq.shape != q.shape or last.shape != (*rows, width) \
                or len(rows) > 1:                      # the first argument that is wrong
            for a, name, w in zip((q, dq, last), ("q", "dq", what), (self.n, self.n, width)):
                if a.shape != (*rows, w) or len(rows) > 1:
                    raise ModelError(f"{name}: shape {a.shape}; expected ({w},) for one state "
                                     f"or (N, {w}) for N states, N the same for every argument")
        return q, dq, last

    def _rows(self, kernel, t, q, dq, y, shape: tuple):
        """The C kernel over the rows of (t, q, dq, y): out of shape (N, *shape), or
        shape alone for one state."""
        count = 1 if q.ndim == 1 else q.shape[0]
        if isinstance(t, (float, int)) or np.ndim(t) == 0:
            t = float(t)
        else:
            t = np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), (count,)))
        out = np.empty(shape if q.ndim == 1 else (count, *shape))
        failed = kernel(count, t, q, dq, y, out)
        if failed >= 0:
            raise np.linalg.LinAlgError(f"mass matrix not positive definite, or a non-finite "
                                        f"result, at state {failed}")
        return out

    def forward_dynamics(self, t, q, dq, tau):
        """ddq solving M ddq = F + B tau: (n,) at one state, (N, n) at N states."""
        ddq = self._one_dynamics(t, q, dq, tau)
        if ddq is not None:
            return ddq
        q, dq, tau = self._states(q, dq, tau, self.m, "tau")
        if self.native is not None:
            return self._rows(self.native.dynamics, t, q, dq, tau, (self.n,))
        return self._python["forward_dynamics"](t, q, dq, tau)

    def forward_derivatives(self, t, q, dq, tau):
        """(d(ddq)/dq, d(ddq)/d(dq), d(ddq)/dtau): (n, n), (n, n), (n, m) at one
        state, (N, n, n), (N, n, n), (N, n, m) at N states (rows of q, dq, tau)."""
        fast = self._one_forward(t, q, dq, tau)
        if fast is not None:
            return fast
        n = self.n
        q, dq, tau = self._states(q, dq, tau, self.m, "tau")
        if self.native is None:
            return self._python["forward_derivatives"](t, q, dq, tau)
        D = self._rows(self.native.forward, t, q, dq, tau, (n, 2 * n + self.m))
        return D[..., :n], D[..., n:2 * n], D[..., 2 * n:]

    def inverse_derivatives(self, t, q, dq, ddq):
        """(d(ID)/dq, d(ID)/d(dq), M), ID = M ddq - F: (n, n) each at one state,
        (N, n, n) at N states."""
        fast = self._one_inverse(t, q, dq, ddq)
        if fast is not None:
            return fast
        n = self.n
        q, dq, ddq = self._states(q, dq, ddq, n, "ddq")
        if self.native is None:
            return self._python["inverse_derivatives"](t, q, dq, ddq)
        out = self._rows(self.native.inverse, t, q, dq, ddq, (3, n, n))
        return out[..., 0, :, :], out[..., 1, :, :], out[..., 2, :, :]

    def _parameter_derivatives(self, which: str, t, q, dq, y, width: int, what: str):
        """The ``which`` ("forward", "inverse") parameter derivatives at the rows of
        (t, q, dq, y): (n, k) or (N, n, k)."""
        q, dq, y = self._states(q, dq, y, width, what)
        if not self.parameters:
            raise ModelError("no parameters chosen: derivatives(robot, parameters=[...])")
        if self.native is not None:
            return self._rows(getattr(self.native, f"{which}_parameters"), t, q, dq, y,
                              (self.n, len(self.parameters)))
        if which == "closed":
            return self._python["closed_loop_parameter_derivatives"](t, q, dq)
        return self._python[f"{which}_parameter_derivatives"](t, q, dq, y)

    def forward_parameter_derivatives(self, t, q, dq, tau):
        """d(ddq)/dp at fixed tau for the chosen ``parameters``: (n, k) at one state,
        (N, n, k) at N states."""
        return self._parameter_derivatives("forward", t, q, dq, tau, self.m, "tau")

    def inverse_parameter_derivatives(self, t, q, dq, ddq):
        """d(ID)/dp at fixed ddq for the chosen ``parameters``: (n, k) at one state,
        (N, n, k) at N states."""
        return self._parameter_derivatives("inverse", t, q, dq, ddq, self.n, "ddq")

    def closed_loop_parameter_derivatives(self, t, q, dq):
        """d(ddq)/dp in closed loop (the efforts under the file's control laws, which
        the parameters and gains may enter): (n, k) at one state, (N, n, k) at N."""
        q = np.asarray(q, dtype=float)
        return self._parameter_derivatives("closed", t, q, dq, np.zeros(q.shape[:-1] + (self.m,)),
                                           self.m, "tau")

    def mass_matrix_inverse(self, q):
        """M(q)^-1: (n, n) for q of shape (n,), (N, n, n) for (N, n)."""
        q = np.asarray(q, dtype=float)
        q, zero, e = self._states(q, np.zeros_like(q), np.zeros(q.shape[:-1] + (self.m,)),
                                  self.m, "tau")
        if self.native is not None:
            return self._rows(self.native.minv, 0.0, q, zero, e, (self.n, self.n))
        return self._python["mass_matrix_inverse"](q)


@dataclass
class Generated:
    """The derivatives' code of one robot: the Python module, the parameter trace
    (None without parameters), the open-loop Jacobian's trace (which both texts
    print) and the names; ``c()`` the C text."""
    python: str
    plan: object                       # recursive.Plan
    extra: object                      # recursive.Traced parameter Jacobian and law slopes
    parameters: tuple[str, ...]
    jacobian: object                   # recursive.Traced: trace_open_loop_jacobian(plan)

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.plan.coordinates

    @property
    def efforts(self) -> tuple[str, ...]:
        return self.plan.efforts

    def c(self) -> str | None:
        """The C extension's text (module name left as MODULE_NAME), None when an
        expression of the robot file has no C form."""
        from .recursive import derivatives as traced

        return traced.c_source(self.plan, self.extra, self.jacobian)


def generate(robot, parameters=()) -> Generated:
    """The code of ``derivatives`` for a validated ``Robot`` (an open tree: a closed
    chain is a ModelError; a parameter it does not have, a gain or a parameter in a
    place ``recursive.parameters`` does not cover is a ModelError)."""
    from .recursive import derivatives as traced, plan
    from .recursive.parameters import chosen, trace_law_slopes, trace_parameter_jacobian

    if robot.constraints is not None:
        raise ModelError(f"{robot.source}: derivatives need an open tree; {robot.name} has "
                         "closed loops (constraints)")
    robot.refuse_spherical("derivatives (anadyn.derivatives, export --derivatives)")
    robot.refuse_contacts("derivatives (anadyn.derivatives, export --derivatives)")
    names = chosen(robot, parameters)
    pl = plan(robot)
    extra = ((trace_parameter_jacobian(robot, pl, names), trace_law_slopes(robot, pl, names))
             if names else None)
    jacobian = traced.trace_open_loop_jacobian(pl)
    return Generated(traced.module_source(pl, extra, jacobian), pl, extra, names, jacobian)


def derivatives(robot, native: bool = True, parameters=()) -> Derivatives:
    """The ``Derivatives`` of a validated ``Robot`` (``generate``); ``native``: compile
    the C extension now when it is not cached (unless ANADYN_NATIVE=0 or no
    compiler); ``parameters``: names of the robot file's parameters to differentiate
    with respect to."""
    from . import native as cc

    code = generate(robot, parameters)
    module, note = None, "native=False"
    if native:
        c_text = code.c()
        module, note = ((None, "an expression has no C form") if c_text is None
                        else cc.load(c_text, how="off" if cc.mode() == "off" else "wait"))
    return Derivatives(code.python, code.coordinates, code.efforts, module, note,
                       code.parameters)
