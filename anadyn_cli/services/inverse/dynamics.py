"""The efforts along a prescribed motion, in speed space: ``InverseDynamics`` (tau
solving B tau = M ddq - F on the actuated rows, the wrench on the free ones), a motion of
coordinates given in the speeds (``InSpeeds``), and which rows no actuator reaches
(``free_rows``; on a robot in contact, every idle row: ``contact_rows``)."""
from __future__ import annotations

import numpy as np

from ...errors import ModelError
from ...numeric import contact_inverse
from ...numeric.measured import SpeedMap
from ...numeric.model import NumericModel
from .checks import constant

QUATERNION_FLOOR = 1e-6      # norm below which a prescribed quaternion gives no attitude


class InverseDynamics:
    """tau(t) = B^-1 (M ddq - F) along a prescribed motion.

    ``motion(t) -> q, dq, ddq`` (arrays of shape t.shape + (nq,) for q, + (n,) for the
    speeds dq and their derivatives ddq); M ddq - F and B come from the model's
    ``demand`` (the recursive Newton-Euler algorithm on the recursive path, O(n) a
    point); both take arrays of any shape or scalars.  ``free``: the speeds (rows) no
    actuator reaches whose generalized force M ddq - F - B tau is reported as the
    wrench the motion needs (``free_rows``); B tau = M ddq - F on the other rows.
    """

    def __init__(self, model: NumericModel, motion, free: tuple = (),
                 support: "contact_inverse.ContactSupport | None" = None):
        self.model = model
        self.motion = motion
        self.n = model.n
        self.m = len(model.effort_names)
        self.free = tuple(free)
        self.actuated = [k for k in range(self.n) if k not in self.free]
        self.support = support

    def demand(self, t, q, dq, ddq):
        """(M ddq - F (..., n), B (..., n, m)) with the coordinates last; on a robot in
        contact (``support``) less the contact forces the motion needs."""
        return self.shared(t, q, dq, ddq)[:2]

    def shared(self, t, q, dq, ddq):
        """(``demand``'s two, the contact forces (..., c, 3) or None)."""
        demand, B = self.model.demand(t, *(np.moveaxis(v, -1, 0) for v in (q, dq, ddq)))
        if self.support is None:
            return demand, B, None
        share = self.support.distribute(t, q, dq, demand)
        return share.remainder, B, share.forces

    def efforts(self, t):
        """(q, dq, ddq, tau) over the time array ``t``; tau has shape t.shape + (m,)."""
        q, dq, ddq = self.motion(t)
        return q, dq, ddq, self.apportion(*self.demand(t, q, dq, ddq))[0]

    def forces(self, t):
        """(tau, wrench) over the time array ``t``: shapes t.shape + (m,), + (free,)."""
        q, dq, ddq = self.motion(t)
        return self.apportion(*self.demand(t, q, dq, ddq))

    def apportion(self, demand, B):
        """(tau, wrench): tau solving B tau = demand (= M ddq - F) on the actuated rows
        (square there; one LU when B is constant), and demand - B tau on the free rows."""
        if not self.free:                 # every row actuated: B square (and B as given)
            return self.solve(demand, B), demand[..., :0]
        rows, free = self.actuated, list(self.free)
        if rows:
            tau = self.solve(demand[..., rows], np.take(B, rows, axis=-2))
        else:
            tau = np.zeros(demand.shape[:-1] + (self.m,))
        wrench = demand[..., free] - np.einsum("...im,...m->...i", np.take(B, free, axis=-2),
                                               tau)
        return tau, wrench

    def applied_at(self, t: float) -> tuple:
        """(tau, wrench, contact forces (c, 3) or None) at one time (the round trip's
        exact forcing)."""
        t = np.array(t, dtype=float)
        demand, B, contact = self.shared(t, *self.motion(t))
        return (*self.apportion(demand, B), contact)

    def state_rate(self, t: float, x: np.ndarray, tau, wrench, contact=None) -> np.ndarray:
        """x' = [W(q) u, du] at one state x = [q, u], du solving M du = F + B tau + the
        wrench on the free rows (+ J_c^T ``contact``, the contact forces, in place of the
        compliant law's) (numpy.linalg.LinAlgError if M is singular)."""
        model = self.model
        M, F, B = model.mfb(t, x[:model.nq], x[model.nq:])
        G = F + B @ np.asarray(tau, dtype=float)
        G[list(self.free)] += wrench
        if contact is not None:
            G += self.support.generalized(t, x, contact)
        return np.concatenate([model.coordinate_rates(x), np.linalg.solve(M, G)])

    @staticmethod
    def solve(demand, B):
        """tau solving B tau = demand (= M ddq - F) at every point (B square); one LU
        when B is constant."""
        if B.ndim > 2 and len(B) and constant(B):
            return np.linalg.solve(B[0], demand.T).T
        return np.linalg.solve(B, demand[..., None])[..., 0]


class InSpeeds:
    """A prescribed motion of coordinates (q, dq, ddq of ``motion``, (..., nq)) given in
    the speeds: q, u, du (``SpeedMap.speeds``, exact)."""

    def __init__(self, motion, speed_map: SpeedMap):
        self.motion, self.speed_map = motion, speed_map
        self.kind, self.duration = motion.kind, motion.duration

    def __call__(self, t):
        q, dq, ddq = self.motion(t)
        return (q, *self.speed_map.speeds(q, dq, ddq))


def row_names(model: NumericModel, speed_map: SpeedMap) -> list[str]:
    """The speeds' rows by name: a coordinate whose rate it is, or the speed itself (a
    spherical joint's)."""
    return [*(model.coordinates[i] for i in speed_map.plain),
            *model.speeds[len(speed_map.plain):]]


def free_rows(model: NumericModel, B: np.ndarray) -> tuple[tuple, tuple]:
    """(rows, (column, unit) pairs): the speeds of spherical and floating joints that no
    actuator reaches (zero rows of B (N, n, m)), whose generalized force the motion needs
    from outside the actuators: per joint, in order, the force along a floating joint's
    slides (``<stem>_fx`` ..., N) and the moment about its body axes (``<stem>_mx`` ...,
    N*m; a speed not named ``<stem>_w<axis>`` gives ``m_<speed>``).  A floating joint's
    slides are the coordinates ``<stem>_x``, ``<stem>_y``, ``<stem>_z`` beside its
    quaternion ``<stem>_qw`` ... (``x``, ``y``, ``z`` beside ``qw`` ...), the names the
    loader and the importers give."""
    speed_map = SpeedMap(model.nq, model.quaternions)
    plain = [model.coordinates[i] for i in speed_map.plain]
    units = {c.name: c.unit for c in model.info.coordinates}
    idle = ~np.any(B != 0, axis=(0, 2)) if B.size else np.ones(model.n, bool)
    taken = {*model.coordinates, *model.speeds, *("d" + u for u in model.speeds),
             *model.effort_names}
    rows, columns = [], []
    for j, group in enumerate(model.quaternions):
        first = model.coordinates[group[0]]
        stem = first[:-2] if first.endswith("qw") else None
        slides = ([f"{stem}{axis}" for axis in "xyz"] if stem is not None else [])
        if all(name in plain and units[name] == "m" for name in slides):
            for name in slides:
                rows.append(plain.index(name))
                columns.append((f"{name[:-1]}f{name[-1]}", "N"))
        for k in range(*speed_map.angular(j).indices(model.n)):
            speed = model.speeds[k]
            rows.append(k)
            columns.append((f"{speed[:-2]}m{speed[-1]}" if speed[-2:-1] == "w"
                            and speed[-1] in "xyz" else f"m_{speed}", "N*m"))
    keep = [i for i, k in enumerate(rows) if idle[k]]
    rows, columns = [rows[i] for i in keep], [columns[i] for i in keep]
    clash = [name for name, _ in columns if name in taken]
    if clash:
        raise ModelError(f"the wrench column {clash[0]} would repeat a name the robot has; "
                         "rename that coordinate, speed or actuator", source=model.info.source)
    return tuple(rows), tuple(columns)


def contact_rows(model: NumericModel, speed_map: SpeedMap, B: np.ndarray, free: tuple,
                  columns: tuple) -> tuple[tuple, tuple]:
    """On a robot with contacts, ``free_rows`` and every other row no actuator reaches
    (zero rows of B): the contacts must give them (``numeric.contact_inverse``); what
    they cannot is that row's residual, column ``f_<coordinate>`` (N) or
    ``m_<coordinate>`` (N*m, an angle's; a speed's without a coordinate)."""
    idle = ~np.any(B != 0, axis=(0, 2)) if B.size else np.ones(model.n, bool)
    units = {c.name: c.unit for c in model.info.coordinates}
    rows = row_names(model, speed_map)
    extra = [k for k in range(model.n) if idle[k] and k not in free]
    named = [(("f_" if units.get(rows[k]) == "m" else "m_") + rows[k],
              "N" if units.get(rows[k]) == "m" else "N*m") for k in extra]
    taken = {*model.coordinates, *model.speeds, *("d" + u for u in model.speeds),
             *model.effort_names, *(name for name, _ in columns)}
    clash = [name for name, _ in named if name in taken]
    if clash:
        raise ModelError(f"the residual column {clash[0]} would repeat a name the robot has; "
                         "rename that coordinate, speed or actuator", source=model.info.source)
    return (*free, *extra), (*columns, *named)


def slides_hint(model: NumericModel, speed_map: SpeedMap, B: np.ndarray, free) -> str:
    """How a floating joint's slides are recognized (``free_rows``), when a robot with a
    quaternion has slides that no actuator reaches and that were not recognized."""
    units = {c.name: c.unit for c in model.info.coordinates}
    idle = [k for k, i in enumerate(speed_map.plain) if k not in free
            and units[model.coordinates[i]] == "m" and not np.any(B[:, k])]
    if not (model.quaternions and idle):
        return ""
    return (" (a floating joint's slides get the base wrench when named <stem>_x, <stem>_y, "
            "<stem>_z beside its quaternion <stem>_qw, ...)")


def check_quaternions(model: NumericModel, speed_map: SpeedMap, t, q) -> None:
    """A prescribed quaternion must not vanish (its direction is the attitude)."""
    for group in speed_map.quaternions:
        norm = np.linalg.norm(q[:, list(group)], axis=1)
        if (norm < QUATERNION_FLOOR).any():
            k = int(np.argmax(norm < QUATERNION_FLOOR))
            names = ", ".join(model.coordinates[i] for i in group)
            raise ModelError(f"the prescribed quaternion ({names}) is zero at t = {t[k]:g} s "
                             "(it must give an attitude all along: a path from q to -q "
                             "passes through zero)", source=model.info.source,
                             path="trajectory")
