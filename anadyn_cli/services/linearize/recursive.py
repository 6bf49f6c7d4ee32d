"""The recursive evaluator of a linearization: the interface of ``equations.Road`` on
the recursive Newton-Euler algorithm, no symbolic equations of motion, by one of two
codes (``road`` chooses; ``code`` says which ran):

- ``KernelEquations``, the generic kernel (``numeric.generic``: the recursions
  compiled once per installation, reading the robot's numeric tables; no code is
  generated or compiled for the robot), whenever it can serve the robot: native
  code on in its default mode and ANADYN_GENERIC not 0 (``generic.enabled``), a
  kernel built, and tables that hold the robot (``generic.pack``: no external
  loads, joint displacements affine in the coordinates);
- ``RecursiveEquations``, the derivatives generated for the robot
  (``numeric.derivatives``: the analytic derivatives of the traced recursions or
  their forward-mode differentiation, generated Python), otherwise.

Both are exact up to rounding and agree to ~1e-12 relative (tests/
test_linearize_kernel.py).  Open trees of revolute and prismatic joints (their
couplings, springs, dampers, friction and, on the generated road, loads); a
spherical joint is the closed forms' (``covers``)."""
from __future__ import annotations

import os

import numpy as np
import sympy as sp

from .equations import Road, positive_definite


def covers(robot) -> bool:
    """Whether the recursive evaluator linearizes ``robot`` (an open tree without
    contacts, which linearize refuses anyway): no spherical joint."""
    return not robot.spherical


def road(robot, timings: dict | None = None, use_cache: bool = False) -> Road:
    """The recursive evaluator of ``robot`` (covered; or a ``RecordedRobot``, read
    only when the kernel is built: ``numeric.build.robot_of``): ``KernelEquations`` when the generic kernel can serve it (built now
    the first time ever, its compile in ``timings``), else ``RecursiveEquations``
    with the reason in its ``code``.  ``use_cache``: the kernel's tables are kept
    beside the robot's cache entry (``generic.keep``) when the next run can
    linearize from them (``recorded.serves``: its ``RecordedRobot``)."""
    from ...numeric import cache, generic, native, recursive as traced
    from ...model.info import RobotInfo
    from .recorded import RecordedRobot, serves

    if isinstance(robot, RecordedRobot):         # read only with the kernel built
        return KernelEquations(robot, robot.record.tables, generic.kernel(timings))
    if not generic.enabled():
        switch = "ANADYN_NATIVE" if native.mode() != "auto" else "ANADYN_GENERIC"
        why = f"the generic kernel is off: {switch}={os.environ.get(switch, '')}"
    else:
        pl = traced.plan(robot)
        tables, why = generic.pack(pl)
        module = None if tables is None else generic.kernel(timings)
        if module is not None:
            record = (generic.Record.of(robot, pl, RobotInfo.from_robot(robot), tables)
                      if use_cache else None)
            if record is not None and serves(record):       # the next run reads it
                generic.keep(cache.key(robot.digest, "recursive"), record)
            return KernelEquations(robot, tables, module)
        why = why or "no generic kernel: native code cannot be built here"
    return RecursiveEquations(robot, f"generated Python ({why})")


def _efforts(robot) -> list[sp.Symbol]:
    return [sp.Symbol(a.name, real=True) for a in robot.actuators]


def _finite(*arrays):
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise ValueError("a value that is not a finite number")
    return arrays if len(arrays) > 1 else arrays[0]


class RecursiveEquations(Road):
    """``equations.Road`` by ``numeric.derivatives.Derivatives`` (generated Python,
    vectorized by NumPy: a linearization needs a handful of points, so no C is
    compiled): M from the inverse dynamics' d(ID)/d(ddq), ddq and M^-1 B from the
    forward dynamics and its derivatives, F = M ddq(tau = 0) and B = M (M^-1 B).
    ``code``: what ran, and why not the generic kernel."""
    evaluator = "recursive"

    def __init__(self, robot, code: str = "generated Python"):
        from ...numeric.derivatives import derivatives

        super().__init__(robot, robot.q, robot.dq, _efforts(robot))
        self.code = code
        self.derivatives = derivatives(robot, native=False)

    def _state(self, q, dq):
        return np.asarray(q, dtype=float), np.asarray(dq, dtype=float)

    def terms(self, t, q, dq):
        q, dq = self._state(q, dq)
        d = self.derivatives
        M = _finite(d.inverse_derivatives(t, q, dq, np.zeros(self.n))[2])
        positive_definite(M)
        free = self.accelerations(t, q, dq, np.zeros(self.m))
        G = self.slopes(t, q, dq, np.zeros(self.m))[1]
        return M, M @ free, M @ G

    def accelerations(self, t, q, dq, tau) -> np.ndarray:
        q, dq = self._state(q, dq)
        return _finite(self.derivatives.forward_dynamics(t, q, dq, np.asarray(tau, dtype=float)))

    def slopes(self, t, q, dq, tau):
        q, dq = self._state(q, dq)
        Dq, Ddq, G = _finite(*self.derivatives.forward_derivatives(
            t, q, dq, np.asarray(tau, dtype=float)))
        return np.hstack([Dq, Ddq]), G


class KernelEquations(Road):
    """``equations.Road`` by the generic kernel's functions over the robot's tables
    (``generic.Tables``; the time does not enter them: no loads): M by composite
    rigid bodies (``mass``), F = -ID(q, dq, 0) by Newton-Euler (``inverse``), ddq by
    articulated bodies (``rhs``), d(ddq)/dx = M^-1 K at fixed joint efforts
    (``jac``), and B = A^T S, constant (theta = A q + c the joint map, S each
    effort's joint and generalized force per unit effort), M^-1 B solved with M."""
    evaluator = "recursive"
    code = "generic kernel"

    def __init__(self, robot, tables, module):
        super().__init__(robot, robot.q, robot.dq, _efforts(robot))
        self._kernel, self._ints, self._doubles = module, tables.ints, tables.doubles
        self._select = tables.effort_map()                           # efforts -> joints
        self.B = tables.A.T @ self._select

    def _run(self, function: str, *args) -> None:
        code = getattr(self._kernel, function)(self._ints, self._doubles, *args)
        if code == 1:
            raise np.linalg.LinAlgError("mass matrix not positive definite")
        if code:
            raise ValueError("a value that is not a finite number")

    def _mass(self, q) -> np.ndarray:
        M = np.empty((self.n, self.n))
        self._run("mass", np.ascontiguousarray(q, dtype=float), M)
        positive_definite(_finite(M))
        return M

    def _x(self, q, dq) -> np.ndarray:
        return np.ascontiguousarray(np.concatenate([q, dq]), dtype=float)

    def _joint_efforts(self, tau) -> np.ndarray:
        return np.ascontiguousarray(self._select @ np.asarray(tau, dtype=float))

    def terms(self, t, q, dq):
        M = self._mass(q)
        F = np.empty((1, self.n))
        self._run("inverse", 1, self._x(q, dq), np.zeros(self.n), F)
        return M, -F[0], self.B

    def accelerations(self, t, q, dq, tau) -> np.ndarray:
        out = np.empty(self.nq + self.n)
        self._run("rhs", self._x(q, dq), self._joint_efforts(tau), out)
        return out[self.nq:]

    def slopes(self, t, q, dq, tau):
        ns = self.nq + self.n
        J = np.empty((ns, ns))
        self._run("jac", self._x(q, dq), self._joint_efforts(tau), J)
        return J[self.nq:], np.linalg.solve(self._mass(q), self.B)
