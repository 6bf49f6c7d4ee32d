"""MJCF ``connect`` and ``weld`` equalities as the robot's ``loops`` (a mixin of the
importer): where each body and site sits in anadyn's bodies (``place``, while the tree
is walked), and the loops with their dependent coordinates (``close_loops``, by
``equality.close``)."""
from __future__ import annotations

from ..urdf.frames import _snap, compose
from . import equality


class Loops:
    """Records the bodies' and sites' places, then closes the loops."""

    def place(self, name: str, owner: str, pending, members) -> None:
        """Record where the MJCF body ``name`` and its sites sit in the anadyn body
        ``owner`` (the body's frame ``pending`` in its axes), for the equalities."""
        self.placed[name] = (owner, pending)
        for child, frame, cls in members:
            if child.tag == "site" and child.get("name"):
                where = f"site {child.get('name')!r}"
                pose = self.pose(child, where, cls)
                self.sites[child.get("name")] = (owner, compose(
                    pending, compose(frame, pose) if frame else pose))

    def close_loops(self, data: dict, actuators: dict) -> None:
        """The equalities as ``loops`` in ``data``, with their dependent coordinates
        marked (``equality.close`` on the tree as written), and one warning."""
        if self.several:
            raise self.error(self.equalities[0].where, "an equality in a model with ball or "
                             "free joints: anadyn's loops take hinge and slide joints only")
        joints = {b["name"]: b["joint"].get("displacement") for b in data["bodies"]}
        actuated = {joints[a["joint"]] for a in actuators.values()}
        candidates = [q for q, _ in self.coordinates.values()]
        loops, guesses = equality.close(self.equalities, data, candidates, actuated,
                                        self.error)
        entries, names = [], {}
        for item, (body_a, a), (body_b, b), directions in loops:
            count = names[id(item)] = names.get(id(item), 0) + 1
            base = item.name if item.kind == "connect" else f"{item.name}_{count}"
            name = self.names.unique(self.names.clean(base, "eq_"), lambda n: n not in
                                     self.names.taken and n not in self.names.bodies)
            self.names.taken.add(name)
            entries.append({"name": name, "a": {"body": body_a, "point": self.vector(_snap(a))},
                            "b": {"body": body_b, "point": self.vector(_snap(b))},
                            "directions": directions})
        data["loops"] = entries
        for q, guess in guesses.items():
            data["coordinates"][q].update(initial=self.value(guess), dependent=True)
        self.warnings.append(
            f"{self.source}: <equality>: {len(self.equalities)} connect/weld constraint(s) "
            f"became {len(entries)} loop(s), exact: MuJoCo's are soft (solref, solimp), so "
            f"the motions differ by their compliance; dependent coordinates "
            f"{', '.join(guesses)} (pivoted QR at the reference configuration, "
            "unactuated joints first)")

