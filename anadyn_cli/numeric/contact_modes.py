"""The rigid contact model at one state (``impacts`` runs it and its docstring states
the model): each contact's mode (open, stick, slide), the contacts' kinematics
(``_Kinematics``), the mode's accelerations and forces (``Rigid.solve``), its event
functions, the impacts and the selection of a consistent mode."""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

STABILIZATION = 10.0     # 1/s: gamma of the constraint stabilization
DIFFERENCE = 1e-5        # the central difference's step of q (coordinate units) for (dA/dt) u
GAP = 1e-8               # m: a contact this close (or inside) touches
SPEED = 1e-7             # m/s: a normal or slip speed below this is rest
OPEN, STICK, SLIDE = "open", "stick", "slide"


@dataclass
class Event:
    """A contact event (simulate.json's ``contact.events``)."""
    t: float
    contact: str
    bodies: tuple[str, ...]
    kind: str        # touch-down (an impact), impulse (a closed contact's share of one),
                     # lift-off, slip, stick
    impulse: tuple[float, float, float] = (0.0, 0.0, 0.0)   # normal, t1, t2 (N s)
    speed_before: float = 0.0        # the normal speed J_n u (m/s; < 0: approaching)
    speed_after: float = 0.0
    energy_lost: float = 0.0         # J, by the impact (all contacts of it, on its first)

    def summary(self) -> dict:
        return {"t": self.t, "contact": self.contact, "bodies": list(self.bodies),
                "event": self.kind, "impulse": list(self.impulse),
                "speed_before": self.speed_before, "speed_after": self.speed_after,
                "energy_lost": self.energy_lost}


@dataclass
class Mode:
    """Each contact's state (OPEN, STICK, SLIDE) and a sliding one's unit slip
    direction (t1, t2 components)."""
    states: list[str]
    slip: dict[int, np.ndarray] = field(default_factory=dict)


class _Kinematics:
    """The contacts at one state: gaps g, J_n (c, n), J_t (c, 2, n), the speeds
    J_n u, J_t u and the bias (dJ/dt) u."""

    def __init__(self, model, t: float, x: np.ndarray):
        nq, n = model.nq, model.n
        q, u = x[:nq], x[nq:nq + n]
        rates = model.coordinate_rates(x[:nq + n])
        fastest = float(np.abs(rates).max(initial=0.0))
        h = DIFFERENCE / fastest if fastest > 0 else 0.0
        Q = np.column_stack([np.repeat(q[:, None], n, axis=1), q + h * rates, q - h * rates])
        U = np.column_stack([np.eye(n), u, u])
        V = np.broadcast_to(np.asarray(model.contacts(t, Q, U), dtype=float),
                            (len(model.contact_names), 9, n + 2))
        self.gap = -V[:, 3, 0]
        self.Jn, self.Jt = V[:, 6, :n], V[:, 7:9, :n]
        self.vn, self.vt = self.Jn @ u, self.Jt @ u
        if h:
            self.bias_n = (V[:, 6, n] - V[:, 6, n + 1]) / (2 * h)
            self.bias_t = (V[:, 7:9, n] - V[:, 7:9, n + 1]) / (2 * h)
        else:
            self.bias_n, self.bias_t = np.zeros(len(self.gap)), np.zeros((len(self.gap), 2))


class Rigid:
    """The rigid model of one ``NumericModel`` (with ``rigid_contacts``): the mode's
    field, its events, impacts and mode selection (``impacts``' docstring)."""

    def __init__(self, model):
        self.model, self.n, self.nq = model, model.n, model.nq
        self.names = model.contact_names
        self.e = np.array([r[0] for r in model.rigid_contacts], dtype=float)
        self.mu = np.array([r[1] for r in model.rigid_contacts], dtype=float)   # kinetic
        self.mu_s = np.array([r[4] for r in model.rigid_contacts], dtype=float)  # static
        self.bodies = [tuple(r[2]) for r in model.rigid_contacts]
        self.size = np.array([r[3] for r in model.rigid_contacts], dtype=float)
        self.calls = 0
        self._memo: dict = {}

    # -- one state --------------------------------------------------------------
    def mass(self, t: float, x: np.ndarray) -> np.ndarray:
        q, u = x[:self.nq], x[self.nq:self.nq + self.n]
        return np.asarray(self.model.mfb(t, q, u)[0], dtype=float).reshape(self.n, self.n)

    def _rows(self, kin: _Kinematics, mode: Mode):
        """(A, F, b, who): constraint rows, force rows, the acceleration right side and
        per row (contact, 0 normal | 1, 2 tangent)."""
        A, F, b, who = [], [], [], []
        g = STABILIZATION
        for c, state in enumerate(mode.states):
            if state == OPEN:
                continue
            force = kin.Jn[c].copy()
            if state == SLIDE and self.mu[c]:
                force -= self.mu[c] * (mode.slip[c] @ kin.Jt[c])
            A.append(kin.Jn[c])
            F.append(force)
            b.append(-kin.bias_n[c] - 2 * g * kin.vn[c] - g * g * kin.gap[c])
            who.append((c, 0))
            if state == STICK:
                for k in range(2):
                    A.append(kin.Jt[c, k])
                    F.append(kin.Jt[c, k])
                    b.append(-kin.bias_t[c, k] - g * kin.vt[c, k])
                    who.append((c, k + 1))
        return np.array(A).reshape(-1, self.n), np.array(F).reshape(-1, self.n), \
            np.array(b), who

    def forces(self, kin: _Kinematics, mode: Mode, who, lam) -> np.ndarray:
        """(contacts, 3): f_n, f_t1, f_t2 per contact from the multipliers."""
        out = np.zeros((len(self.names), 3))
        for (c, k), value in zip(who, lam):
            out[c, k] = value
        for c, state in enumerate(mode.states):
            if state == SLIDE and self.mu[c]:
                out[c, 1:] = -self.mu[c] * out[c, 0] * mode.slip[c]
        return out

    def solve(self, t: float, x: np.ndarray, mode: Mode):
        """(dx/dt without E_d, the forces (contacts, 3), the kinematics, each contact's
        power f_n J_n u + f_t . J_t u) at ``x`` in ``mode``; memoized for the events."""
        x = np.ascontiguousarray(x, dtype=float)       # the native code's layout
        key = (t, x.tobytes(), tuple(mode.states),
               tuple((c, tuple(s)) for c, s in sorted(mode.slip.items()) if s is not None))
        if key in self._memo:
            return self._memo[key]
        self.calls += 1
        m = self.model
        state = x[:self.nq + self.n]
        free = m.rhs(t, state)
        kin = _Kinematics(m, t, state)
        A, F, b, who = self._rows(kin, mode)
        forces = np.zeros((len(self.names), 3))
        if len(b):
            M = self.mass(t, state)
            Y = np.linalg.solve(M, F.T)
            a = free[self.nq:]
            lam = np.linalg.lstsq(A @ Y, b - A @ a, rcond=1e-12)[0]
            free = free.copy()
            free[self.nq:] = a + Y @ lam
            forces = self.forces(kin, mode, who, lam)
        power = forces[:, 0] * kin.vn + (forces[:, 1:] * kin.vt).sum(axis=1)
        out = (free, forces, kin, power)
        if len(self._memo) > 64:
            self._memo.clear()
        self._memo[key] = out
        return out

    def field(self, mode: Mode):
        def rhs(t, y):
            dx, _, _, power = self.solve(t, y, mode)
            return np.append(dx, -power.sum())
        return rhs

    def max_step(self, mode: Mode, kin: _Kinematics) -> float:
        """The segment's largest step: half the time an open sphere pair approaching at
        its start takes to close the sum of its radii (the gap of two spheres is not
        monotone: a longer step could carry one through the other unseen)."""
        times = [0.5 * self.size[c] / -kin.vn[c] for c, state in enumerate(mode.states)
                 if state == OPEN and self.size[c] and kin.vn[c] < 0]
        return min(times, default=math.inf)

    def events(self, mode: Mode, t0: float, y0: np.ndarray) -> list:
        """solve_ivp's event functions of ``mode`` from (t0, y0), each with ``.why``
        (contact, kind)."""
        out = []
        for c, state in enumerate(mode.states):
            if state == OPEN:
                out.append(self._event(mode, lambda f, k, c=c: k.gap[c], c, "touch-down",
                                       t0, y0, GAP))
                continue
            out.append(self._event(mode, lambda f, k, c=c: f[c, 0], c, "lift-off", t0, y0))
            if state == STICK:
                out.append(self._event(mode, lambda f, k, c=c: self.mu_s[c] * f[c, 0]
                                       - math.hypot(*f[c, 1:]), c, "slip", t0, y0))
            elif self.mu_s[c]:
                out.append(self._event(mode, lambda f, k, c=c: float(mode.slip[c] @ k.vt[c]),
                                       c, "stick", t0, y0, SPEED))
        return out

    def _event(self, mode: Mode, value, c: int, kind: str, t0: float, y0: np.ndarray,
               zero: float | None = None):
        """The event function ``value(forces, kinematics)`` of contact ``c`` in ``mode``:
        terminal, where it falls through 0.  A value that starts at 0 (within ``zero``;
        forces: 1e-9 of the largest) is divided by t - t0 (and is 1 at t0): its root at
        the start, where the contact has just lifted off, touched or begun to slide, is
        not an event; the next one is (a ball rebounding within the first step)."""
        forces, kin = self.solve(t0, y0, mode)[1:3]
        start = value(forces, kin)
        zero = 1e-9 * (1.0 + np.abs(forces).max(initial=0.0)) if zero is None else zero

        def event(t, y):
            _, forces, kin, _ = self.solve(t, y, mode)
            return value(forces, kin)

        def leaving(t, y):
            return event(t, y) / (t - t0) if t > t0 else 1.0
        chosen = leaving if abs(start) <= zero else event
        chosen.terminal, chosen.direction, chosen.why = True, -1, (c, kind)
        return chosen

    # -- events -----------------------------------------------------------------
    def impact(self, t: float, x: np.ndarray, kin: _Kinematics, touching: list[int]):
        """(x after, events) of an impact at the ``touching`` contacts (module
        docstring of ``impacts``); x unchanged and no events when none approaches."""
        if not any(kin.vn[c] < -SPEED for c in touching):
            return x, []
        u = x[self.nq:self.nq + self.n]
        M = self.mass(t, x)
        target = np.zeros(len(self.names))
        for c in touching:
            rebound = -self.e[c] * kin.vn[c] if kin.vn[c] < 0 else 0.0
            target[c] = rebound if rebound > SPEED else 0.0
        best = None
        for closed in _subsets(touching):
            states = [STICK if c in closed and self.mu_s[c] else SLIDE if c in closed else OPEN
                      for c in range(len(self.names))]
            mode = Mode(states)
            for _ in range(len(closed) + 1):
                A, F, _, who = self._rows(kin, mode)
                goal = np.array([target[c] if k == 0 else 0.0 for c, k in who])
                Y = np.linalg.solve(M, F.T)
                lam = np.linalg.lstsq(A @ Y, goal - A @ u, rcond=1e-12)[0]
                impulses = self.forces(kin, mode, who, lam)
                outside = [c for c in closed if mode.states[c] == STICK and
                           math.hypot(*impulses[c, 1:]) > self.mu_s[c] * impulses[c, 0]]
                if not outside:
                    break
                c = outside[0]
                slip = kin.vt[c] if np.hypot(*kin.vt[c]) > SPEED else -impulses[c, 1:]
                mode.states[c] = SLIDE
                mode.slip[c] = slip / np.hypot(*slip)
            u_after = u + Y @ lam
            vn_after = kin.Jn @ u_after
            violation = max([-impulses[c, 0] for c in closed] +
                            [target[c] - vn_after[c] for c in touching if c not in closed]
                            + [0.0])
            if best is None or violation < best[0]:
                best = (violation, u_after, impulses, vn_after)
            if violation <= 1e-9 * (1.0 + np.abs(impulses).max(initial=0.0)):
                break
        _, u_after, impulses, vn_after = best
        lost = 0.5 * (u @ M @ u - u_after @ M @ u_after)
        after = x.copy()
        after[self.nq:self.nq + self.n] = u_after
        events = [Event(t, self.names[c], self.bodies[c],
                        "touch-down" if kin.vn[c] < -SPEED else "impulse",
                        tuple(float(v) for v in impulses[c]), float(kin.vn[c]),
                        float(vn_after[c]))
                  for c in touching if impulses[c, 0] > 0 or kin.vn[c] < -SPEED]
        if events:
            events[0].energy_lost = float(lost)
        return after, events

    def select(self, t: float, x: np.ndarray, kin: _Kinematics, hints: dict[int, str]) -> Mode:
        """The consistent mode at ``x`` (``impacts``' docstring); ``hints``: contact -> the
        event it just had (after a lift-off it is not offered closed, after a slip not
        sticking)."""
        resting = [c for c in range(len(self.names)) if kin.gap[c] <= GAP and
                   abs(kin.vn[c]) <= SPEED and hints.get(c) != "lift-off"]
        best = None
        for closed in _subsets(resting):
            mode = Mode([OPEN] * len(self.names))
            for c in closed:
                slow = np.hypot(*kin.vt[c]) <= SPEED
                if not self.mu_s[c]:
                    mode.states[c] = SLIDE
                elif slow and hints.get(c) != "slip":
                    mode.states[c] = STICK
                else:
                    mode.states[c] = SLIDE
                    mode.slip[c] = kin.vt[c] / np.hypot(*kin.vt[c]) if not slow else None
            violation = self._consistent(t, x, kin, mode, closed, resting)
            if best is None or violation < best[0]:
                best = (violation, mode)
            if violation <= 0.0:
                break
        return best[1]

    def _consistent(self, t, x, kin, mode: Mode, closed, resting) -> float:
        """How far ``mode`` is from consistent (<= 0: it is), sticking contacts outside
        the cone turned to sliding along -f_t on the way."""
        for _ in range(len(closed) + 1):
            pending = [c for c in closed if mode.states[c] == SLIDE and self.mu[c]
                       and mode.slip.get(c) is None]
            if pending:              # from rest: against the friction sticking would need
                probe = Mode(list(mode.states), dict(mode.slip))
                for c in pending:
                    probe.states[c] = STICK
                forces = self.solve(t, x, probe)[1]
                for c in pending:
                    slip = -forces[c, 1:]
                    mode.slip[c] = (slip / np.hypot(*slip) if np.hypot(*slip) > 0
                                    else np.array([1.0, 0.0]))
            dx, forces, _, _ = self.solve(t, x, mode)
            outside = [c for c in closed if mode.states[c] == STICK and
                       math.hypot(*forces[c, 1:]) > self.mu_s[c] * forces[c, 0]]
            if not outside:
                break
            c = outside[0]
            mode.states[c] = SLIDE
            mode.slip[c] = -forces[c, 1:] / math.hypot(*forces[c, 1:])
        du = dx[self.nq:]
        scale = 1.0 + np.abs(forces).max(initial=0.0)
        gap_acc = kin.Jn @ du + kin.bias_n
        pull = max([-forces[c, 0] for c in closed] + [0.0])
        sink = max([-gap_acc[c] for c in resting if c not in closed] + [0.0])
        return max(pull / scale, sink - 1e-9 * (1.0 + np.abs(gap_acc).max(initial=0.0)))


def _subsets(items: list[int]):
    """Every subset of ``items``, the largest first."""
    for size in range(len(items), -1, -1):
        yield from (set(s) for s in itertools.combinations(items, size))
