"""A run's contacts: simulate.csv's contact columns and simulate.json's contact events
(NumPy only: a cached robot runs without SymPy).  The values, per contact and row:
normal force, friction along the ground's tangents t1 and t2 (N), penetration (m;
< 0: the gap), spring energy (J), dissipated power (W), the contact point's velocity
along n, t1, t2 (m/s); from the generated ``contacts`` function (``numeric.contact``)
for the compliant model, from the rigid model's multipliers (``numeric.impacts``),
whose events the integrator located, for the rigid one."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the columns of simulate.csv per contact (``<contact>_<column>``): the first four values
CONTACT_COLUMNS = ("fn", "ft1", "ft2", "depth")


@dataclass
class ContactRun:
    """The contacts over a run's rows: ``values`` (contacts, 9, N) as ``NumericModel.contacts``
    gives them at the times ``t``; under the ``model`` "rigid", ``located``: the events
    the integrator located (``impacts.Event.summary``)."""
    names: tuple[str, ...]
    t: np.ndarray
    values: np.ndarray
    model: str = "compliant"
    located: list[dict] | None = None
    balance: float | None = None     # rigid: the energy balance's largest relative residual

    def columns(self) -> tuple[list[str], list[np.ndarray]]:
        """simulate.csv's columns after the contract: per contact ``<name>_<column>``
        (``CONTACT_COLUMNS``)."""
        header = [f"{name}_{column}" for name in self.names for column in CONTACT_COLUMNS]
        data = [self.values[c, k] for c in range(len(self.names))
                for k in range(len(CONTACT_COLUMNS))]
        return header, data

    def events(self) -> list[dict]:
        """Touch-downs (the penetration turns positive) and lift-offs (it turns negative),
        from the output rows: the time where the line between two rows crosses 0."""
        out = []
        for c, name in enumerate(self.names):
            depth = self.values[c, 3]
            inside = depth > 0
            for k in np.flatnonzero(inside[1:] != inside[:-1]):
                share = depth[k] / (depth[k] - depth[k + 1])
                out.append({"t": float(self.t[k] + share * (self.t[k + 1] - self.t[k])),
                            "contact": name,
                            "event": "touch-down" if inside[k + 1] else "lift-off"})
        return sorted(out, key=lambda e: e["t"])

    def summary(self) -> dict:
        """simulate.json's ``contact``: the model, the events, the largest penetration and
        normal force per contact (rigid: the energy the impacts took too)."""
        located = self.located is not None
        return {"model": self.model,
                "events_from": ("located by the integrator (rigid model)" if located else
                                "output rows (penetration crossing 0, linear in between)"),
                "events": self.located if located else self.events(),
                **({"impact_losses": sum(e["energy_lost"] for e in self.located)}
                   if located else {}),
                **({} if self.balance is None else {"energy_balance": self.balance}),
                "max_penetration": {n: float(max(self.values[c, 3].max(initial=0.0), 0.0))
                                    for c, n in enumerate(self.names)},
                "max_normal_force": {n: float(self.values[c, 0].max(initial=0.0))
                                     for c, n in enumerate(self.names)}}


def run_report(model, t: np.ndarray, x: np.ndarray) -> ContactRun | None:
    """The contacts of ``model`` (a ``NumericModel``) on the rows ``x`` (N, nq + n) at
    ``t``; None without contacts."""
    if not model.contact_names:
        return None
    values = model.contacts(t, x[:, :model.nq].T, x[:, model.nq:].T)
    return ContactRun(model.contact_names, t, np.broadcast_to(values, values.shape[:2] + t.shape))


def event_error(run: list[dict], reference: list[dict]) -> float:
    """The largest difference in time between a run's contact events and the reference
    run's (``ContactRun.events``), matched in order; inf when the two runs do not have
    the same events (a bounce more or less)."""
    if [(e["contact"], e["event"]) for e in run] != [(e["contact"], e["event"])
                                                    for e in reference]:
        return float("inf")
    return max((abs(a["t"] - b["t"]) for a, b in zip(run, reference)), default=0.0)
