"""The contact forces a prescribed motion needs: inverse dynamics of a robot in contact.

Along the motion (q, u, u') the generalized forces of inverse dynamics without the
contacts, tau_id = M u' - F (F: joint forces, loads, gravity and bias, no contact
force), must be what the actuators and the contacts give:

    tau_id = B tau + J_c^T lambda,    lambda = (f_n, f_t1, f_t2) per active contact

J_c: per contact, the rows of the velocity of its material point at the contact point
along the normal n and the ground's tangents t1, t2 (world axes), as
``numeric.contact`` traces them (vn, vt1, vt2, linear in the speeds: evaluated at unit
speeds, the Jacobian's columns, the way ``numeric.impacts`` takes it).  The compliant
model's F holds the law's forces at the state, so J_c^T f_law(q, u) is added back to
the model's M u' - F first; the rigid model traces none.

**Active**: a contact whose penetration d >= -gap (``DEFAULT_GAP``, 1 micrometre: a
rigid contact rests at d = 0 to its stabilization's drift, far below it; a compliant
one carries force only where d > 0).  An inactive contact gets no force.

**Redundancy**: the rows no actuator reaches (a floating base's six, a passive body's
slides) must be produced by the contacts: lambda is the minimum-norm least-squares
solution of J_c^T[rows] lambda = tau_id[rows] (``numpy.linalg.pinv``, rcond
``RCOND``); with more contact components than such rows the forces are not unique and
this picks the one of least Euclidean norm (no internal squeezing between the feet, no
friction the motion does not need).  The actuators then solve
B tau = tau_id - J_c^T lambda on their rows, and what is left on the unreached rows is
the **residual**: a generalized force neither the contacts nor the actuators give.
With every row actuated the minimum-norm forces are zero (the motion says nothing about
how hard the robot pushes).

**In the cone** (``resolution="cone"``): where the least-norm forces leave a friction
cone (or pull), the forces of least norm among those that give the same rows and lie in
the linearized cones: f_n >= 0 and f_t inside the regular polygon of ``SIDES`` sides
inscribed in |f_t| <= mu f_n (within 2 % of the cone: cos(pi/16) mu).  That is a
least-distance problem min |z| s.t. G N z >= -G lambda_0 over the null space N of the
rows (lambda = lambda_0 + N z, lambda_0 the least-norm forces, which lie in the rows'
span: |lambda|^2 = |lambda_0|^2 + |z|^2), solved exactly through
non-negative least squares (Lawson and Hanson's LDP, ``scipy.optimize.nnls``), sample
by sample.  Where no forces in the cones give the rows, the least-norm ones stay (and
are flagged).

A sample the contacts cannot support (``assess``) needs a normal force that pulls
(f_n < 0), a friction outside the cone |f_t| > mu f_n, or leaves a residual; each test
allows ``SUPPORT_TOLERANCE`` times the motion's largest force (``assess``).
Between two bodies' spheres only the normal force is resolved (their tangents are not
traced): a compliant pair whose friction acts is refused.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

DEFAULT_GAP = 1e-6          # m: a contact this close to its ground (or inside) is active
RESOLUTIONS = ("least-norm", "cone")     # how redundant contact forces are chosen
SIDES = 16                  # the linearized cone: a regular polygon inscribed in |f_t| = mu f_n
RCOND = 1e-10               # pinv's cut of small singular values (relative)
SUPPORT_TOLERANCE = 1e-9    # relative to the motion's (or the sample's) largest force


@dataclass
class Distribution:
    """The contacts' share at the samples (leading shape ...): ``forces`` (..., c, 3) f_n,
    f_t1, f_t2 per contact; ``active`` (..., c); ``remainder`` (..., n) =
    tau_id - J_c^T lambda, what the actuators (and the residual) must give."""
    forces: np.ndarray
    active: np.ndarray
    remainder: np.ndarray


class ContactSupport:
    """The contacts of ``model`` supporting the ``rows`` no actuator reaches (module
    docstring).  ``gap``: the largest gap of an active contact, m; ``friction``: mu per
    contact (None: the model's, ``CONTACT_FRICTION``)."""

    def __init__(self, model, rows, gap: float = DEFAULT_GAP, friction=None,
                 resolution: str = "least-norm"):
        self.model, self.rows, self.gap = model, list(rows), float(gap)
        self.resolution = resolution
        self.names = model.contact_names
        self.friction = np.asarray(model.contact_friction if friction is None else friction,
                                   dtype=float)

    def kinematics(self, t, q, u):
        """(depth (N, c), J (N, c, 3, n), the law's generalized force J^T f_law (N, n)) at
        N states (t (N,), q (N, nq), u (N, n))."""
        model, n = self.model, self.model.n
        N = len(q)
        Q = np.broadcast_to(q.T[:, :, None], (model.nq, N, n + 1))
        U = np.concatenate([np.broadcast_to(np.eye(n)[:, None, :], (n, N, n)),
                            u.T[:, :, None]], axis=2)
        V = np.broadcast_to(np.asarray(model.contacts(np.reshape(t, (N, 1)), Q, U), float),
                            (len(self.names), 9, N, n + 1))
        J = np.transpose(V[:, 6:9, :, :n], (2, 0, 1, 3))
        law = np.transpose(V[:, 0:3, :, n], (2, 0, 1))
        unseen = (np.abs(J[:, :, 1:]).max(axis=(0, 2, 3)) == 0) & (
            np.abs(law[:, :, 1:]).max(axis=(0, 2)) > 0)
        if unseen.any():
            raise ModelError(f"contact {self.names[int(np.argmax(unseen))]}: its friction acts "
                             "but its direction is not traced (two bodies' spheres): inverse "
                             "dynamics resolves their normal force only; give it friction: 0",
                             source=model.info.source, path="contacts")
        return (V[:, 3, :, n].T, J, np.einsum("Nckj,Nck->Nj", J, law))

    def distribute(self, t, q, u, demand) -> Distribution:
        """The minimum-norm contact forces at samples of any leading shape (q (..., nq),
        u (..., n), ``demand`` = the model's M u' - F (..., n), contact forces included)."""
        lead, n, c = demand.shape[:-1], self.model.n, len(self.names)
        q, u = np.reshape(q, (-1, self.model.nq)), np.reshape(u, (-1, n))
        t = np.broadcast_to(np.asarray(t, dtype=float), lead).reshape(-1)
        depth, J, law = self.kinematics(t, q, u)
        tau_id = np.reshape(demand, (-1, n)) + law
        active = depth >= -self.gap
        forces = np.zeros((len(q), c, 3))
        if self.rows:
            A = np.transpose(J[..., self.rows], (0, 3, 1, 2)) * active[:, None, :, None]
            A = A.reshape(len(q), len(self.rows), 3 * c)
            forces = (np.linalg.pinv(A, rcond=RCOND) @ tau_id[:, self.rows, None]).reshape(
                len(q), c, 3)
            if self.resolution == "cone":
                for k in np.flatnonzero(self.outside(forces, active).any(axis=1)):
                    forces[k] = self._in_cone(A[k], forces[k], active[k])
        remainder = tau_id - np.einsum("Nckj,Nck->Nj", J, forces)
        return Distribution(forces.reshape(lead + (c, 3)), active.reshape(lead + (c,)),
                            remainder.reshape(lead + (n,)))

    def excess(self, forces: np.ndarray, active: np.ndarray) -> dict:
        """Per reason, (..., c): by how much each active contact's force pulls (-f_n) or
        leaves its friction cone (|f_t| - mu f_n)."""
        fn, ft = forces[..., 0], np.hypot(forces[..., 1], forces[..., 2])
        return {"pulling": np.where(active, -fn, 0.0),
                "outside_cone": np.where(active, ft - self.friction * fn, 0.0)}

    def outside(self, forces: np.ndarray, active: np.ndarray) -> np.ndarray:
        """(..., c): the active contacts whose forces pull or leave their friction cone
        (beyond ``SUPPORT_TOLERANCE`` of the sample's largest force)."""
        tol = SUPPORT_TOLERANCE * np.abs(forces).max(axis=(-2, -1), initial=0.0)[..., None]
        return np.any([e > tol for e in self.excess(forces, active).values()], axis=0)

    def _in_cone(self, A: np.ndarray, least: np.ndarray, active: np.ndarray) -> np.ndarray:
        """The forces (c, 3) of least norm that give what the least-norm ``least`` give on
        the rows (A (rows, 3 c)) inside the active contacts' linearized cones (module
        docstring); ``least`` when there are none."""
        from scipy.optimize import nnls

        used = np.repeat(active, 3)
        lam0, A = least.reshape(-1)[used], A[:, used]
        _, s, vt = np.linalg.svd(A)
        rank = int((s > RCOND * s[0]).sum()) if len(s) and s[0] > 0 else 0
        N = vt[rank:].T
        G = _faces(self.friction[active])
        if not N.shape[1]:
            return least
        E = np.vstack([(G @ N).T, -(G @ lam0)[None, :]])
        goal = np.zeros(len(E))
        goal[-1] = 1.0
        r = E @ nnls(E, goal)[0] - goal
        if abs(r[-1]) <= 1e-12:                        # no z: the cones cannot give the rows
            return least
        out = np.zeros(least.size)
        out[used] = lam0 + N @ (-r[:-1] / r[-1])
        return out.reshape(least.shape)

    def generalized(self, t: float, x: np.ndarray, forces: np.ndarray) -> np.ndarray:
        """J_c(q)^T lambda - J_c(q)^T f_law(q, u) at one state x = [q, u]: what turns the
        model's F (with the compliant law) into F plus the prescribed contact forces
        ``forces`` (c, 3) (the round trip's)."""
        nq = self.model.nq
        _, J, law = self.kinematics(np.array([t]), x[None, :nq], x[None, nq:])
        return np.einsum("ckj,ck->j", J[0], forces) - law[0]

    def assess(self, t: np.ndarray, forces: np.ndarray, active: np.ndarray,
               residual: np.ndarray, scale: float) -> dict:
        """The samples the contacts cannot support (module docstring): their counts per
        reason and the worst of each (inverse.json's ``contact.unsupported``); ``scale``:
        the motion's largest force, which ``SUPPORT_TOLERANCE`` multiplies."""
        tol = SUPPORT_TOLERANCE * max(scale, 1e-300)
        excess = self.excess(forces, active)
        excess["residual"] = np.abs(residual).max(axis=1, initial=0.0)[:, None]
        reasons, flagged = {}, np.zeros(len(t), bool)
        for reason, values in excess.items():
            bad = (values > tol).any(axis=1)
            if bad.any():
                k, c = np.unravel_index(int(np.argmax(values)), values.shape)
                reasons[reason] = {"samples": int(bad.sum()), "t": float(t[k]),
                                   "by": float(values[k, c])}
                if reason != "residual":
                    reasons[reason]["contact"] = self.names[c]
            flagged |= bad
        return {"samples": int(flagged.sum()), "tolerance": tol, "reasons": reasons,
                "friction_cone": "checked"}


def _faces(mu: np.ndarray) -> np.ndarray:
    """G (blocks of 1 + SIDES rows per contact, 3 columns each) with G lambda >= 0 inside
    the contacts' linearized cones: f_n >= 0, and f_t . e_j <= mu cos(pi/SIDES) f_n along
    the polygon's SIDES normals e_j (its corners on |f_t| = mu f_n)."""
    angles = 2 * np.pi * np.arange(SIDES) / SIDES
    out = np.zeros((len(mu) * (SIDES + 1), 3 * len(mu)))
    for c, friction in enumerate(mu):
        block = np.zeros((SIDES + 1, 3))
        block[:, 0] = [1.0] + [friction * np.cos(np.pi / SIDES)] * SIDES
        block[1:, 1], block[1:, 2] = -np.cos(angles), -np.sin(angles)
        out[c * (SIDES + 1):(c + 1) * (SIDES + 1), 3 * c:3 * c + 3] = block
    return out
