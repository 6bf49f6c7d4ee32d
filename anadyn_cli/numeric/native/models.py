"""The recursive path's runtime models: ``RecursiveModel`` runs the generated
Python, ``NativeModel`` the compiled C (``builder``); ``recursive_model`` gives
the one the cache allows.

``NativeModel`` is a ``NumericModel`` whose ``rhs``, ``jacobian``,
``accelerations`` and ``demand`` call the extension; the other vectorized
functions (M, F, B, efforts, energy over arrays of states) stay NumPy.  Without
a library nothing else changes, since the Python and the C give the same bits
(``RecursiveModel.jacobian`` follows the C's order of operations);
``model.native_note`` says which runs and why.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ..model import NumericModel, run_generated
from .builder import QuickBuild, load

#: the generated module's scalar functions come before this line, the vectorized after
VECTOR_MARK = "# ---- vectorized functions ----"


def light_source(source: str) -> str:
    """``source`` without its scalar functions (``accelerations`` and
    ``dynamics_jacobian`` None): all a native model compiles from Python."""
    head, mark, tail = source.partition(VECTOR_MARK)
    if not mark:
        return source
    header = head[:head.index("\ndef ") + 1] if "\ndef " in head else head
    return header + "accelerations = dynamics_jacobian = None\n" + tail


def _call(kernel, t: float, x, out: np.ndarray) -> np.ndarray:
    """``kernel(t, x, out)`` of the extension; LinAlgError for a singular M."""
    try:
        code = kernel(t, x, out)
    except TypeError:                    # not a contiguous float64 array
        code = kernel(t, np.ascontiguousarray(x, dtype=float), out)
    if code == 1:
        raise np.linalg.LinAlgError("mass matrix not positive definite")
    return out


def _driven(kernel, t: float, x, efforts, out: np.ndarray) -> np.ndarray:
    """``kernel(t, x, e, out)`` of the extension; LinAlgError for a singular M."""
    if kernel(t, np.ascontiguousarray(x, dtype=float),
              np.ascontiguousarray(efforts, dtype=float), out) == 1:
        raise np.linalg.LinAlgError("mass matrix not positive definite")
    return out


class RecursiveModel(NumericModel):
    """The generated Python of the recursive path.  Its Jacobian solves
    M (d ddq/dx) = K with the factor that ``factor`` computes, column by column
    in the order of the C kernel, so that Python and C give the same bits (a
    run does not depend on whether the library was built).

    The scalar functions (``accelerations``, ``factor``, ``dynamics_jacobian``:
    most of the source) are each compiled from Python when first called.  With
    a ``QuickBuild``, the run switches to its C as soon as the compiler is
    done, mid-run: the RHS, and the factor of M and the solve with it in the
    Jacobian (K stays Python); the same bits, sooner.

    ``source`` is the generated module, or a function that gives it, called
    when a scalar function is first asked for (a warm run reads it from the
    cache only then), with ``light`` its ``light_source``."""

    def __init__(self, info, source: str | Callable[[], str], formulation: str = "recursive",
                 quick: QuickBuild | None = None, light: str | None = None):
        self._full = source
        super().__init__(info, light_source(self.full_source) if light is None else light,
                         formulation)
        self._factor_tables = self._namespace.get("FACTOR")
        self._scalars: dict = {}
        self._accelerations = self._first_accelerations
        self._jacobian = self._first_jacobian
        self._quick, self._quick_module = quick, None
        self._n2 = self.nq + self.n               # the state [q, u]

    @property
    def full_source(self) -> str:
        """The whole generated module (``source``, asked for once)."""
        if callable(self._full):
            self._full = self._full()
        return self._full

    def scalar(self, name: str):
        """The generated module's scalar function ``name``, compiled on first use."""
        if name not in self._scalars:
            head = self.full_source.partition(VECTOR_MARK)[0]
            start = head.index(f"\ndef {name}(")
            end = head.find("\ndef ", start + 1)
            header = head[:head.index("\ndef ")]
            self._scalars[name] = run_generated(
                header + head[start:end if end > 0 else len(head)])[name]
        return self._scalars[name]

    def _first_accelerations(self, *args):
        self._accelerations = self.scalar("accelerations")
        return self._accelerations(*args)

    def _first_jacobian(self, *args):
        self._jacobian = self.scalar("dynamics_jacobian")
        return self._jacobian(*args)

    def _poll(self) -> None:
        module = self._quick.module()
        if module is not None:
            self._quick_module, self._quick = module, None
            self.native_note = ("native C (compiled during the run; the full library in "
                                "the background for the next run)")

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        if self._quick is not None:
            self._poll()
        if self._quick_module is not None:
            return _call(self._quick_module.rhs, t, x, np.empty(self._n2))
        return super().rhs(t, x)

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        n = self.n
        if self._quick_module is not None and not self.quaternions:   # C factor and solve
            # around Python's K (the C's ksolve takes the state [q, dq] only)
            factor = _call(self._quick_module.factor, t, x, np.empty(n + self._nfac))
            _, K = self._jacobian(t, *np.asarray(x, dtype=float).tolist(), *factor[:n].tolist())
            J = np.empty((self._n2, self._n2))
            self._quick_module.ksolve(factor[n:], np.ascontiguousarray(K, dtype=float), J)
            return J
        order, rows, cols = self._factor_tables
        values = np.asarray(x, dtype=float).tolist()
        ddq, inv, L = self.scalar("factor")(t, *values)
        _, K, *R = self._jacobian(t, *values, *ddq)
        y = [None] * n
        for i in range(n):
            v = K[order[i]].copy()
            for k, e in rows[i]:
                v -= L[e] * y[k]
            y[i] = v * inv[i]
        for i in reversed(range(n)):
            v = y[i]
            for k, e in cols[i]:
                v = v - L[e] * y[k]
            y[i] = v * inv[i]
        J = np.zeros((self._n2, self._n2))
        self.rate_rows(J, R)
        for i in range(n):
            J[self.nq + order[i]] = y[i]
        return J

    def problem(self, open_contacts: bool = False):
        """``NumericModel.problem``; with a spherical joint (its C library has no
        Jacobian) the integrators' Jacobian is ``generic.differences`` of
        ``rhs`` (the same bits from C or Python), not the generated Python's,
        which is compiled first (~0.3 s for a humanoid); ``jacobian`` stays exact."""
        problem = super().problem(open_contacts)
        if not self.quaternions:
            return problem
        from dataclasses import replace

        from ..generic.differences import central_differences
        return replace(problem, jacobian=lambda t, x: central_differences(
            lambda y: self.rhs(t, y), np.asarray(x, dtype=float)))

    def driven_accelerations(self, t: float, x: np.ndarray, efforts) -> np.ndarray:
        return np.array(self.scalar("driven_accelerations")(
            t, *np.asarray(x, dtype=float).tolist(), *np.asarray(efforts, dtype=float).tolist()))

    @property
    def _nfac(self) -> int:
        """n + the stored entries of L (``factor``'s output after ddq)."""
        _, rows, _ = self._factor_tables
        return self.n + sum(len(r) for r in rows)


class NativeModel(RecursiveModel):
    """``NumericModel`` whose ``rhs``, ``jacobian`` and ``accelerations`` run in C.

    As in the generated Python, a mass matrix that is not positive definite
    raises numpy.linalg.LinAlgError; a non-finite result is returned as is
    (the integrators test every result).  Only the vectorized functions are
    compiled from Python up front; the scalar Python ``dynamics_jacobian``
    (M and K) is compiled when first asked for.  The library of a robot with a
    spherical joint has ``rhs`` and ``acc`` only (no Jacobian, inverse or driven
    dynamics): those run as in ``RecursiveModel``."""

    def __init__(self, info, source: str | Callable[[], str], formulation: str, module,
                 light: str | None = None):
        super().__init__(info, source, formulation, light=light)
        self.native = module
        self._rhs_c, self._acc_c = module.rhs, module.acc
        self._jac_c = getattr(module, "jac", None)
        self._accelerations = self._native_accelerations

    def _native_accelerations(self, t, *state) -> list[float]:
        return _call(self._acc_c, t, np.array(state, dtype=float), np.empty(self.n)).tolist()

    def accelerations(self, t: float, x) -> list[float]:
        return _call(self._acc_c, t, x, np.empty(self.n)).tolist()

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        return _call(self._rhs_c, t, x, np.empty(self._n2))

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        if self._jac_c is None:
            return super().jacobian(t, x)
        J = np.empty((self._n2, self._n2))
        if self._jac_c(t, np.ascontiguousarray(x, dtype=float), J) == 1:
            raise np.linalg.LinAlgError("mass matrix not positive definite")
        return J

    def driven_accelerations(self, t: float, x: np.ndarray, efforts) -> np.ndarray:
        if self._jac_c is None:
            return super().driven_accelerations(t, x, efforts)
        return _driven(self.native.driven, t, x, efforts, np.empty(self.n))

    def demand(self, t, q, dq, ddq) -> tuple[np.ndarray, np.ndarray]:
        """As ``NumericModel.demand``, M ddq - F by the C kernel over all points."""
        if self._jac_c is None:
            return super().demand(t, q, dq, ddq)
        n = self.n
        if np.ndim(t) == 0 and np.ndim(q) == 1:            # one point (the round trip)
            out = np.empty((1, n))
            self.native.inverse(1, np.array([t], dtype=float),
                                np.concatenate([q, dq]).astype(float),
                                np.ascontiguousarray(ddq, dtype=float), out)
            return out[0], self.actuation(t, q, dq)
        with np.errstate(all="ignore"):
            arrays = np.broadcast_arrays(np.asarray(t, dtype=float),
                                         *(np.asarray(v, dtype=float) for v in (*q, *dq, *ddq)))
            shape = arrays[0].shape
            columns = np.stack([a.reshape(-1) for a in arrays[1:]], axis=1)   # (count, 3n)
            count = len(columns)
            out = np.empty((count, n))
            self.native.inverse(count, np.ascontiguousarray(arrays[0].reshape(-1)),
                                np.ascontiguousarray(columns[:, :2 * n]),
                                np.ascontiguousarray(columns[:, 2 * n:]), out)
            return out.reshape(shape + (n,)), self.actuation(t, q, dq)


def recursive_model(info, code: str | Callable[[], str], c_text: str | Callable[[], str] | None,
                    formulation: str = "recursive", timings: dict | None = None,
                    how: str | None = None, quick: QuickBuild | None = None,
                    light: str | None = None, name: str | None = None):
    """A NativeModel when the C library is cached (or ``how`` "wait" builds it),
    else the generated Python's RecursiveModel, which takes ``quick``'s C for its
    RHS once built; ``model.native_note`` says which.  A warm run gives the texts
    as functions (read when first needed), the ``light_source`` of ``code`` and
    the C's module ``name`` (``load``)."""
    module, why = ((None, "no C source") if c_text is None
                   else load(c_text, timings, how, name))
    if module is None:
        model = RecursiveModel(info, code, formulation, quick, light)
        model.native_note = f"generated Python ({why})"
    else:
        model = NativeModel(info, code, formulation, module, light)
        model.native_note = f"native C ({why})"
    return model
