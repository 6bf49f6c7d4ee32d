"""Reducing the URDF tree to anadyn bodies: locked joints (--lock, held at a value),
fixed joints folded into the body before them, and the joints that move no mass."""
from __future__ import annotations

from ...errors import ModelError
from ..joints import Compound
from ..names import GROUND
from .frames import IDENTITY, compose
from .options import _lock_value
from .parse import _Joint
from .tree import _listed


class _Reduce:
    """The importer's lock and fold steps (part of ``importer._Importer``)."""

    def locks(self, joints: dict[str, _Joint], masters) -> dict[str, float]:
        """Joint -> the displacement it is held at: each ``--lock`` joint (a moving
        joint, not a mimic, within its limits) and the mimics of a locked joint."""
        result: dict[str, float] = {}
        for name, given in self.options.lock:
            shown = f"--lock {name}={given}"
            joint = joints.get(name)
            if joint is None or not joint.moving:
                movable = [j.name for j in joints.values() if j.moving and j.name not in masters]
                what = "no such joint" if joint is None else f"joint {name!r} is {joint.type}"
                raise self.error(None, f"{shown}: {what}; the joints that can be locked are "
                                       f"{_listed(movable, 8)}")
            where = f"joint {name!r}"
            if isinstance(joint.kind, Compound):
                raise self.error(where, f"{shown}: a {joint.type} joint has several "
                                        "coordinates and cannot be locked at one value")
            if name in masters:
                raise self.error(where, f"{shown}: the joint mimics {masters[name][0]!r}; lock "
                                        "that joint (its mimics follow it)")
            if name in result:
                raise self.error(where, f"{shown}: the joint is locked twice")
            try:
                value = _lock_value(given, shown)
            except ModelError as err:
                raise self.error(where, err.reason) from None
            lower, upper = joint.limit.get("lower"), joint.limit.get("upper")
            if lower is not None and not lower <= value <= upper:
                raise self.error(where, f"{shown}: {value:.6g} is outside the joint's <limit> "
                                        f"[{lower:g}, {upper:g}]")
            result[name] = value
        for name, (master, k, c) in masters.items():
            if master in result:
                result[name] = k * result[master] + c
        return result

    def placement(self, base: str, order: list[_Joint], locks: dict[str, float]):
        """(owner, pose, folded, moving): link -> the link whose body it belongs to
        (the child of a moving joint) or GROUND; link -> its frame in that body's
        axes; body -> [(link, joint)] folded into it; the moving joints (the bodies)
        in tree order.  A fixed or locked joint folds its child into its parent's
        body, a locked one at its displacement."""
        owner = {base: GROUND}
        pose = {base: IDENTITY}
        folded: dict[str, list[tuple[str, _Joint]]] = {GROUND: []}
        moving: list[_Joint] = []
        for joint in order:
            if joint.moving and joint.name not in locks:
                owner[joint.child] = joint.child
                pose[joint.child] = IDENTITY
                folded[joint.child] = []
                moving.append(joint)
                continue
            owner[joint.child] = owner[joint.parent]
            relative = joint.moved(locks[joint.name]) if joint.name in locks else joint.pose
            pose[joint.child] = compose(pose[joint.parent], relative)
            folded[owner[joint.child]].append((joint.child, joint))
        return owner, pose, folded, moving

    def motionless(self, moving: list[_Joint], owner, folded, links) -> list[_Joint]:
        """The moving joints that move nothing: no link on their body or beyond it
        has mass (anadyn's moving bodies have mass, but for a massless body that
        carries others); their speeds would leave M singular.  A massless link
        between joints (URDF's ball joints written as three revolute joints with
        virtual links) moves the massive links beyond it: that is fine."""
        heavy = {j.child: any(links[name].inertial is not None and links[name].inertial.mass > 0
                              for name, _ in [(j.child, None)] + folded[j.child])
                 for j in moving}
        for joint in reversed(moving):           # children before parents
            parent = owner[joint.parent]
            if parent != GROUND:
                heavy[parent] = heavy[parent] or heavy[joint.child]
        return [j for j in moving if not heavy[j.child]]
