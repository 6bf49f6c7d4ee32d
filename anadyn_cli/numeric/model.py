"""The numeric model: a robot's generated functions and what a run needs to know.

Every numeric service takes a ``NumericModel``.  It is built one way
(``numeric.build.numeric_model``) from a path, a validated ``Robot`` or a
cache entry, and holds no state: counting, budgets and failure capture belong
to the integrators (``integrators.integrate``), which get ``problem()``.

Only NumPy is imported here: a robot whose generated source is cached runs
without importing SymPy.  The source is anadyn's own output (from
``closed_form.source``), never text from a robot file.  State x = [q, u], the
coordinates (nq) and the speeds (n; ``Robot.speeds``): u = dq unless the robot has
a spherical joint, whose speeds are its angular velocity in body axes:

    rhs(t, x)      -> dx/dt = [dq = W(q) u, du], M du = G = F + B tau(t, q, u)
    jacobian(t, x) -> [[0, I], [M^-1 K]],  K = [dG/dq - (dM/dq) du | dG/du]
                      (with a spherical joint the first rows are R = d(W(q) u)/dx)

W(q) is the identity on the coordinates' rates and each spherical joint's
dq = 1/2 q (x) (0, w) (``model.joints.Spherical.coordinate_rates``, traced into the
generated module's ``rates``, which the C library runs too).  Its
rotation is written for a quaternion of any norm, so the motion does not depend
on the norm; ``on_manifold`` makes the quaternions of a run's rows unit and
measures how far the integration took them off.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..model.info import RobotInfo
from .integrators import Problem


class PrescribedMotion:
    """q(t), dq(t), ddq(t) of the robot file's trajectory (exact derivatives):
    ``motion(t)`` gives arrays of shape t.shape + (n,)."""

    def __init__(self, kind: str, duration: float, function):
        self.kind, self.duration, self._function = kind, float(duration), function

    def __call__(self, t):
        return self._function(t)


def run_generated(source: str) -> dict:
    """The namespace of anadyn's own generated module ``source`` (never user text:
    expressions reach generated code only through the whitelist parser).  Source
    from the cache gets here only from files ``cache.read_record`` trusts: the
    user's own, in folders no one else can write, matching their SHA-256; so does
    a compiled code object kept there (``cache.compiled``)."""
    from .cache import compiled

    namespace: dict[str, object] = {}
    exec(compiled(source, "<anadyn generated>"), namespace)   # noqa: S102
    return namespace


class NumericModel:
    """Compiled functions of one robot's equations: ``evaluator`` "recursive" (the
    Newton-Euler recursions' code, with its RNEA) or "closed-form" (the closed forms of
    ``formulation``, "kane" or "lagrange"; None on the recursive path)."""
    #: the generic kernel's T, V and P_d over the robot's tables (``generic.Energies``),
    #: in place of the generated ``potential`` and ``powers`` where the kernel is
    #: available; None: the generated ones
    integrands = None

    def __init__(self, info: RobotInfo, source: str, formulation: str | None = "kane"):
        namespace = run_generated(source)
        self.info, self.source = info, source
        self.evaluator = "recursive" if "inverse_dynamics" in namespace else "closed-form"
        self.formulation = None if self.evaluator == "recursive" else formulation
        self.coordinates: tuple[str, ...] = namespace["COORDINATES"]
        self.effort_names: tuple[str, ...] = namespace["EFFORTS"]
        #: the speeds u (``Robot.speeds``): the coordinates' rates d<q> unless the
        #: module names others (a spherical joint's)
        self.speeds: tuple[str, ...] = namespace.get(
            "SPEEDS", tuple("d" + c for c in self.coordinates))
        #: the coordinate indices of each spherical joint's quaternion
        self.quaternions: tuple = namespace.get("QUATERNIONS", ())
        self.n = len(self.speeds)              # speeds: the size of M
        self.nq = len(self.coordinates)        # coordinates: n, or more with quaternions
        self._accelerations = namespace["accelerations"]
        self._jacobian = namespace.get("dynamics_jacobian")     # None: not generated
        self._efforts = namespace["efforts"]
        self._mfb = namespace["mfb"]
        self._inverse = namespace.get("inverse_dynamics")   # the recursive path's RNEA
        self._actuation = namespace.get("actuation")        # and its B alone
        self._constant_actuation = namespace.get("CONSTANT_ACTUATION", False)
        self._constant_B: np.ndarray | None = None          # B once, when constant
        self._potential = namespace["potential"]
        self._rates = namespace.get("rates")        # only with a spherical joint
        self._motion = (PrescribedMotion(*namespace["TRAJECTORY"], namespace["motion"])
                        if "TRAJECTORY" in namespace else None)
        self._motion_error = namespace.get("MOTION_ERROR")
        self._powers = namespace.get("powers")    # only with loads or joint forces
        self._momentum = namespace.get("momentum")   # only for a free robot (Plan.free)
        #: a free robot's gravity and whether loads or contacts act on it (``conserved``)
        self._outside = (namespace.get("GRAVITY"), namespace.get("EXTERNAL"))
        #: the contacts' names, in file order (``numeric.contact``; () without contacts)
        self.contact_names: tuple[str, ...] = namespace.get("CONTACTS", ())
        self._contacts = namespace.get("contacts")
        #: per contact: stiffness k, exponent p and its body's mass (check's time constant)
        self.contact_laws: tuple = namespace.get("CONTACT_LAWS", ())
        self.contact_friction: tuple = namespace.get("CONTACT_FRICTION", ())   # mu per contact
        #: the rigid contact model's (restitution, friction, bodies) per contact; None: the
        #: robot has none, or compliant ones (``numeric.impacts`` runs the rigid model)
        self.rigid_contacts: tuple | None = namespace.get("RIGID_CONTACTS")
        self._namespace = namespace               # the whole module (numeric.constrained)

    @property
    def motion(self) -> PrescribedMotion:
        """The prescribed motion; ModelError when the file has none, or a wrong one."""
        if self._motion_error:
            raise ModelError(self._motion_error)
        if self._motion is None:
            raise ModelError("no trajectory section: inverse dynamics needs a prescribed "
                             "motion (trajectory: kind cycloidal, quintic or expression)",
                             source=self.info.source)
        return self._motion

    @property
    def name(self) -> str:
        return self.info.name

    def initial_state(self) -> np.ndarray:
        """x0 = [q(0), u(0)] from the robot file."""
        speeds = ([u.initial for u in self.info.speeds] if self.info.speeds
                  else [c.rate for c in self.info.coordinates])
        return np.array([c.initial for c in self.info.coordinates] + speeds, dtype=float)

    def state_names(self) -> tuple[str, ...]:
        return (*self.coordinates, *self.speeds)

    def coordinate_rates(self, x) -> np.ndarray:
        """dq = W(q) u (nq, ...) at the states x = [q, u] (nq + n, ...)."""
        x = np.asarray(x, dtype=float)
        if self._rates is None:
            return x[self.nq:]
        with np.errstate(all="ignore"):
            return np.moveaxis(self._rates(0.0, *x), -1, 0)

    def on_manifold(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        """(rows ``x`` (N, nq + n) with each quaternion made unit, the largest
        | |quaternion| - 1 | before): the projection of a run's rows on the unit
        sphere, and the drift the integrator left (0 without spherical joints)."""
        drift = 0.0
        if self.quaternions:
            x = np.array(x, dtype=float)
            for coordinates in self.quaternions:
                index = list(coordinates)
                norm = np.linalg.norm(x[:, index], axis=1)
                drift = max(drift, float(np.abs(norm - 1).max(initial=0.0)))
                x[:, index] /= norm[:, None]
        return x, drift

    def problem(self, open_contacts: bool = False) -> Problem:
        """The direct dynamics under the control laws, for ``integrators.integrate``;
        ModelError with rigid contacts (``refuse_rigid_contacts``) unless
        ``open_contacts``: then the field while every contact is open (no contact force),
        which the rigid model integrates between its events."""
        if not open_contacts:
            self.refuse_rigid_contacts()
        jacobian = self.jacobian if self._jacobian is not None else None
        return Problem(self.rhs, jacobian, self.state_names(), self.diagnose)

    def refuse_rigid_contacts(self) -> None:
        """ModelError (one line, exit 2) when the robot's contacts are rigid: their
        impacts and constraints run in simulate only (``numeric.impacts``), never in the
        smooth field that the other services integrate."""
        if self.rigid_contacts is not None:
            raise ModelError("the rigid contact model runs from event to event in simulate, "
                             "accuracy and check only (its impacts are no smooth field); "
                             "use model: compliant for this command", source=self.info.source)

    def accelerations(self, t: float, x) -> list[float]:
        """ddq solving M ddq = G at one state (numpy.linalg.LinAlgError if M is singular)."""
        return self._accelerations(t, *x.tolist())

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        values = x.tolist()
        if self._rates is not None:
            return np.array(self._rates(t, *values).tolist() + self._accelerations(t, *values))
        return np.array(values[self.n:] + self._accelerations(t, *values))

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        n, nq = self.n, self.nq
        values = x.tolist()
        J = np.zeros((nq + n, nq + n))
        M, K, *R = self._jacobian(t, *values, *self._accelerations(t, *values))
        self.rate_rows(J, R)
        J[nq:, :] = np.linalg.solve(M, K)
        return J

    def rate_rows(self, J: np.ndarray, R: list) -> None:
        """The coordinates' rows of the state Jacobian J: [0, 1] (dq = u), or R =
        d(W(q) u)/dx from ``dynamics_jacobian`` with a spherical joint."""
        if R:
            J[:self.nq] = R[0]
        else:
            J[:self.n, self.n:] = np.eye(self.n)

    def efforts(self, t, q, dq) -> np.ndarray:
        """Efforts under the control laws; q, dq of shape (n, ...) -> (m, ...)."""
        with np.errstate(all="ignore"):      # overflow or a domain error: NaN, reported
            tau = self._efforts(t, *q, *dq)   # by the caller, never a stray warning line
        return np.moveaxis(tau, -1, 0)

    def mfb(self, t, q, dq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """M (..., n, n), F (..., n), B (..., n, m) over arrays of times and states
        (F depends on t through the loads)."""
        with np.errstate(all="ignore"):
            return self._mfb(t, *q, *dq)

    def demand(self, t, q, dq, ddq) -> tuple[np.ndarray, np.ndarray]:
        """(B tau, B) of M ddq = F + B tau: B tau = M ddq - F (..., n) and B
        (..., n, m) over arrays of times and states (coordinates first).  The
        recursive path computes M ddq - F by the recursive Newton-Euler
        algorithm, O(n) a point; the closed forms from M, F and B."""
        with np.errstate(all="ignore"):
            if self._inverse is not None and self._actuation is not None:
                return self._inverse(t, *q, *dq, *ddq), self.actuation(t, q, dq)
            M, F, B = self._mfb(t, *q, *dq)
            rates = np.moveaxis(np.asarray(ddq, dtype=float), 0, -1)
            return np.einsum("...ij,...j->...i", M, rates) - F, B

    def actuation(self, t, q, dq) -> np.ndarray:
        """B (..., n, m) of the recursive path; (n, m), evaluated once, when it is
        constant (joints actuated directly or through fixed combinations)."""
        if not self._constant_actuation:
            return self._actuation(t, *q, *dq)
        if self._constant_B is None:
            self._constant_B = self._actuation(0.0, *[0.0] * (self.nq + self.n))
            self._constant_B.setflags(write=False)
        return self._constant_B

    def driven_accelerations(self, t: float, x: np.ndarray, efforts) -> np.ndarray:
        """ddq solving M ddq = F + B e at one state x = [q, dq] for given actuator
        efforts e (numpy.linalg.LinAlgError if M is singular)."""
        nq = self.nq
        M, F, B = self.mfb(t, x[:nq], x[nq:])
        return np.linalg.solve(M, F + B @ np.asarray(efforts, dtype=float))

    @property
    def has_forces(self) -> bool:
        """Whether the robot has loads or joint damping, friction or springs."""
        return self._powers is not None

    def powers(self, t, q, dq) -> np.ndarray:
        """(2, ...): the loads' power and the power dissipated by joint damping and
        friction (>= 0), W; zeros for a robot without them.  From ``integrands``
        when the model has them."""
        if not self.has_forces:
            return np.zeros((2, *np.broadcast_shapes(np.shape(t), np.shape(q)[1:])))
        if self.integrands is not None and self.integrands.available():
            return self.integrands.powers(t, q, dq)
        with np.errstate(all="ignore"):
            return np.moveaxis(self._powers(t, *q, *dq), -1, 0)

    def momentum(self, t, q, u) -> np.ndarray | None:
        """(8, ...): a free robot's linear momentum P (kg m/s) and angular momentum L
        about the world origin (kg m^2/s), world axes, then their scales sum |p_i|
        and sum |l_i| + d_i |p_i| (``recursive.momentum``); None for a robot that is
        not free (held by the ground through a joint)."""
        if self._momentum is None:
            return None
        return np.moveaxis(self._momentum(t, *q, *u), -1, 0)

    def conserved(self) -> np.ndarray | None:
        """The momentum's conserved directions, rows of a (k, 6) matrix C (C h is
        constant): all six without gravity; under gravity g the linear momentum normal
        to g and the angular momentum along g; none with loads or contacts; None for a
        robot that is not free."""
        gravity, external = self._outside
        if self._momentum is None:
            return None
        if external:
            return np.zeros((0, 6))
        g = np.asarray(gravity, float)
        if not np.any(g):
            return np.eye(6)
        down = g / np.linalg.norm(g)
        normal = np.linalg.svd(down[None, :])[2][1:]          # two unit vectors normal to g
        return np.vstack([np.hstack([normal, np.zeros((2, 3))]),
                          np.hstack([np.zeros(3), down])[None, :]])

    def contacts(self, t, q, dq) -> np.ndarray:
        """(contacts, 9, ...) per contact: normal force, friction along the ground's
        tangents t1, t2 (N), penetration (m, < 0: the gap), spring energy (J),
        dissipated power (W) and the contact point's velocity along n, t1, t2 (m/s)
        (``numeric.contact``)."""
        with np.errstate(all="ignore"):
            return np.moveaxis(self._contacts(t, *q, *dq), (-2, -1), (0, 1))

    def energy(self, q, dq) -> tuple[np.ndarray, np.ndarray]:
        """(T, V) over arrays of states: T = 1/2 dq^T M dq, V of gravity and springs;
        from ``integrands`` when the model has them."""
        if self.integrands is not None and self.integrands.available():
            return self.integrands.energy(q, dq)
        with np.errstate(all="ignore"):
            M, _, _ = self._mfb(0.0, *q, *dq)
            rates = np.moveaxis(np.asarray(dq, dtype=float), 0, -1)
            kinetic = 0.5 * np.einsum("...i,...ij,...j->...", rates, M, rates)
            return kinetic, self._potential(*q)[..., 0]

    def diagnose(self, x: np.ndarray) -> str:
        """A note when the mass matrix at ``x`` is nearly singular (the usual cause
        of a failed step)."""
        nq = self.nq
        M = self.mfb(0.0, x[:nq, None], x[nq:, None])[0][0]
        if not np.isfinite(M).all() or not np.diag(M).all():
            return "; the mass matrix is singular there"
        condition = scaled_condition(M)
        return (f"; the mass matrix is nearly singular there, condition number {condition:.3g}"
                if condition > 1e10 else "")


def scaled_condition(M: np.ndarray) -> np.ndarray:
    """cond(D^-1/2 M D^-1/2), D = diag(M), over a stack (..., n, n) of mass matrices:
    the conditioning that costs digits in a solve, free of units and link sizes
    (van der Sluis).  The one conditioning routine of anadyn."""
    d = np.sqrt(np.abs(np.diagonal(M, axis1=-2, axis2=-1)))
    d = np.where(d == 0, 1.0, d)
    return np.linalg.cond(M / (d[..., :, None] * d[..., None, :]))
