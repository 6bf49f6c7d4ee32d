"""The link/joint tree of a URDF: one root link, no closed loops, floating and
planar joints imported as anadyn's (or the one that carries the root link welded,
--fix-base), the root link freed (--floating-base), joints in tree order, mimic
chains resolved."""
from __future__ import annotations

import numpy as np

from ..joints import COMPOUND_TYPES, Floating
from .parse import WELDED, _Joint, _Link

#: the name of the world link and of the joint that --floating-base puts between it and
#: the root link (a URDF name is never empty)
WORLD = ""


class _Tree:
    """The importer's tree steps (part of ``importer._Importer``)."""

    def tree(self, root) -> tuple[dict[str, _Link], dict[str, _Joint], str]:
        """The links and joints of the file and its root link (floating and planar
        joints welded or refused: ``free_joints``)."""
        links: dict[str, _Link] = {}
        for i, element in enumerate(root.findall("link")):
            link = self.link(element, i)
            if link.name in links:
                raise self.error(f"link {link.name!r}", "defined twice")
            links[link.name] = link
        if not links:
            raise self.error(None, "no <link> elements: nothing to import")
        joints: dict[str, _Joint] = {}
        parent_joint: dict[str, _Joint] = {}
        for i, element in enumerate(root.findall("joint")):
            joint = self.joint(element, links, i)
            if joint.name in joints:
                raise self.error(f"joint {joint.name!r}", "defined twice")
            if joint.child in parent_joint:
                raise self.error(f"link {joint.child!r}",
                                 f"child of two joints, {parent_joint[joint.child].name!r} and "
                                 f"{joint.name!r}: a closed loop (anadyn's robots are trees)")
            joints[joint.name] = joint
            parent_joint[joint.child] = joint
        base = self.root(links, joints, parent_joint)
        self.free_joints(joints, base)
        if self.options.floating_base:
            base = self.freed(joints, base)
        return links, joints, base

    def freed(self, joints: dict[str, _Joint], base: str) -> str:
        """--floating-base: a floating joint between the world (WORLD) and the root
        link, which becomes a body; the world is the new root.  A root link that a
        floating joint of the file already carries is left as it is, with a warning."""
        carried = [j.name for j in joints.values() if j.parent == base
                   and isinstance(j.kind, Floating)]
        if carried:
            self.warnings.append(f"{self.source}: --floating-base: the root link {base!r} "
                                 f"already carries the floating joint {carried[0]!r}; no "
                                 "joint added")
            return base
        zero = np.zeros(3)
        joints[WORLD] = _Joint(WORLD, Floating.word, COMPOUND_TYPES[Floating.word], WORLD, base,
                               zero, zero, zero, {}, {}, None)
        return WORLD

    def root(self, links, joints, parent_joint) -> str:
        roots = [name for name in links if name not in parent_joint]
        if not roots:
            raise self.error(None, "no root link: every link is the child of a joint, so the "
                                   f"joints form a cycle ({_listed(joints)})")
        if len(roots) > 1:
            raise self.error(None, f"{len(roots)} root links ({_listed(roots)}): links that no "
                                   "joint has as child; a robot must be one tree joined by joints")
        return roots[0]

    def free_joints(self, joints: dict[str, _Joint], base: str) -> None:
        """Floating and planar joints: anadyn's joints of the same names
        (``model.joints``), but the one that carries the root link, welded by fix_base."""
        carrying = [j.name for j in joints.values() if j.kind is None and j.parent == base]
        if self.fix_base and not carrying:
            self.warnings.append(f"{self.source}: --fix-base: no floating or planar joint "
                                 f"carries the root link {base!r}; nothing welded (the root "
                                 "link is fixed to the world in every import)")
        for joint in joints.values():
            if joint.kind is not None:
                continue
            where = f"joint {joint.name!r}"
            if self.fix_base and len(carrying) > 1 and joint.parent == base:
                raise self.error(where, f"--fix-base welds the one joint that carries the root "
                                        f"link; {base!r} carries {len(carrying)} floating or "
                                        f"planar joints ({_listed(carrying)})")
            if joint.parent == base and self.fix_base:
                self.warnings.append(f"{self.source}: {where}: {joint.type} joint of the base "
                                     f"welded: link {joint.child!r} fixed to {base!r} where "
                                     "the joint's origin puts it (--fix-base)")
                joint.kind = WELDED
                continue
            if joint.mimic is not None:
                raise self.error(where, f"a {joint.type} joint cannot mimic another (it has "
                                        "several coordinates)")
            joint.kind = COMPOUND_TYPES[joint.type]

    def tree_order(self, base: str, joints) -> list[_Joint]:
        """Joints from the root out, depth first, children in file order; cycles refused."""
        children: dict[str, list[_Joint]] = {}
        for joint in joints.values():
            children.setdefault(joint.parent, []).append(joint)
        order: list[_Joint] = []
        stack = list(reversed(children.get(base, [])))
        while stack:
            joint = stack.pop()
            order.append(joint)
            stack.extend(reversed(children.get(joint.child, [])))
        if len(order) < len(joints):
            reached = {j.name for j in order}
            loop = [name for name in joints if name not in reached]
            raise self.error(f"joint {loop[0]!r}", f"joints {_listed(loop)} form a cycle not "
                                                   f"connected to the root link {base!r}")
        return order

    def resolve_mimics(self, joints: dict[str, _Joint]) -> dict[str, tuple[str, float, float]]:
        """Mimic joint -> (independent joint, multiplier, offset), chains composed:
        theta_j = k_j theta_m + c_j with theta_m = k_m theta_i + c_m gives
        theta_j = k_j k_m theta_i + (k_j c_m + c_j)."""
        result = {}
        for joint in joints.values():
            if joint.mimic is None or not joint.moving:
                continue
            where = f"joint {joint.name!r}"
            master, k, c = joint.mimic
            seen = [joint.name]
            while True:
                if master not in joints:
                    raise self.error(where, f'<mimic joint="{master}">: no such joint')
                other = joints[master]
                if not other.moving:
                    raise self.error(where, f'<mimic joint="{master}">: that joint is '
                                            f"{other.type}; it must move")
                if master in seen:
                    raise self.error(where, f"mimic joints {', '.join(map(repr, seen))} mimic "
                                            "each other in a cycle")
                if other.mimic is None:
                    break
                seen.append(master)
                master, k, c = other.mimic[0], k * other.mimic[1], k * other.mimic[2] + c
            if k == 0:
                raise self.error(where, "<mimic multiplier=\"0\">: the joint would not move; "
                                        "make it fixed")
            result[joint.name] = (master, k, c)
        return result


def _listed(names, most: int = 5) -> str:
    """'a', 'b', 'c', ... (at most ``most`` names shown)."""
    names = list(names)
    return ", ".join(map(repr, names[:most])) + (", ..." if len(names) > most else "")
