"""The mass properties of MJCF bodies (a mixin of the importer): a body's <inertial> or
its geoms' solid inertias, as MuJoCo's compiler computes them (inertiafromgeom,
boundmass, boundinertia, settotalmass)."""
from __future__ import annotations

import numpy as np

from ..urdf.inertia import MassProperties, combine, inertia_problem
from . import frames, inertia
from .geoms import GEOM_TYPES


class Masses:
    """The mass properties of a body in its MJCF frame (``mass``) and the scale of
    settotalmass (``total_mass_scale``)."""

    def mass(self, element, where: str, members) -> MassProperties:
        """The body's mass properties in its MJCF frame: its <inertial>, or its geoms'
        (``compiler.inertiafromgeom``), raised to <compiler boundmass> and each
        principal moment to boundinertia, as MuJoCo's compiler raises them."""
        inertial = element.find("inertial")
        mode = self.compiler.inertiafromgeom
        if inertial is not None and mode != "true":
            found = self.inertial(inertial, where)
        elif mode == "false":
            found = MassProperties(0.0, np.zeros(3), np.zeros((3, 3)))
        else:
            geoms = [(child, frame, cls) for child, frame, cls in members if child.tag == "geom"]
            parts = [(self.geom(g, k, where, cls), frame)
                     for k, (g, frame, cls) in enumerate(geoms)]
            found = combine([p.moved(frame) if frame else p for p, frame in parts if p is not None])
        mass, floor = self.compiler.boundmass, self.compiler.boundinertia
        if found.mass >= mass and not floor:
            return found
        moments, axes = np.linalg.eigh(found.inertia)
        return MassProperties(max(found.mass, mass), found.com,
                              axes @ np.diag(np.maximum(moments, floor)) @ axes.T)

    def inertial(self, element, where: str) -> MassProperties:
        where = f"{where}: <inertial>"
        mass = self.number(element, "mass", where)
        if mass < 0:
            raise self.error(where, f'mass="{element.get("mass")}": cannot be negative')
        com = self.numbers(element, "pos", 3, where, "0 0 0")
        R = self.orientation(element, where, "main")
        if element.get("fullinertia") is not None:
            if element.get("diaginertia") is not None or R is not frames.IDENTITY:
                raise self.error(where, "fullinertia (in the body's axes) goes without "
                                        "diaginertia and without an orientation")
            xx, yy, zz, xy, xz, yz = self.numbers(element, "fullinertia", 6, where)
            tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:
            tensor = np.diag(self.numbers(element, "diaginertia", 3, where))
        problem = inertia_problem(np.linalg.eigvalsh(tensor))
        if problem:
            raise self.error(where, f"the inertia {problem}; no rigid body has it")
        return MassProperties(mass, com, R @ tensor @ R.T)

    def geom(self, element, index: int, where: str, cls: str) -> MassProperties | None:
        where = f"{where}: geom {element.get('name') or index + 1!r}"
        kind = self.word(element, "type", GEOM_TYPES, where, "sphere", cls)
        group = self.number(element, "group", where, "0", cls)
        lowest, highest = self.compiler.inertiagroups
        if not lowest <= group <= highest:
            return None
        if self.get(element, "shellinertia", cls) == "true":
            raise self.error(where, 'shellinertia="true": anadyn computes solid geoms\' '
                                    "inertias only; give the body an <inertial>")
        if kind not in inertia.SIZES:
            raise self.error(where, f"a {kind} geom: anadyn computes the inertia of sphere, "
                                    "capsule, cylinder, box and ellipsoid geoms; give the body "
                                    "an <inertial> (inertiafromgeom=\"auto\")")
        size, R, centre = self.shape(element, kind, where, cls)
        given = self.get(element, "mass", cls)
        if given is not None:
            mass = self.number(element, "mass", where, cls=cls)
        else:
            mass = self.number(element, "density", where, "1000", cls) * inertia.volume(kind, size)
        if mass < 0:
            raise self.error(where, "the mass cannot be negative")
        moments = inertia.moments(kind, size, mass)
        return MassProperties(mass, centre, R @ np.diag(moments) @ R.T)

    def shape(self, element, kind: str, where: str, cls: str):
        """(sizes, R, centre) of a sphere, capsule, cylinder, box or ellipsoid geom in its
        body's (or frame's) axes, as MuJoCo's compiler reads them (fromto: the axis z
        from one end to the other, the last size half its length)."""
        fromto = self.get(element, "fromto", cls)
        count = inertia.SIZES[kind]
        size = self.numbers(element, "size", (1 if fromto and count > 1 else count, 3),
                            where, None, cls)
        if fromto is not None:
            if kind == "sphere":
                raise self.error(where, "fromto is for capsule, cylinder, box and ellipsoid geoms")
            ends = self.numbers(element, "fromto", 6, where, cls=cls)
            along = ends[3:] - ends[:3]
            if not np.linalg.norm(along) > 1e-12:
                raise self.error(where, f'fromto="{fromto}": the two ends coincide')
            size = np.array(list(size[:count - 1]) + [0.0] * (count - 1 - len(size[:count - 1]))
                            + [np.linalg.norm(along) / 2])
            R, centre = frames.z_to(along), (ends[:3] + ends[3:]) / 2
        else:
            size = size[:count]
            if len(size) < count:
                raise self.error(where, f'size="{self.get(element, "size", cls)}": a {kind} '
                                        f"needs {count} numbers")
            R = self.orientation(element, where, cls)
            centre = self.numbers(element, "pos", 3, where, "0 0 0", cls)
        if any(s <= 0 for s in size):
            raise self.error(where, f'size="{self.get(element, "size", cls)}": sizes must be '
                                    "positive")
        return size, R, centre

    def total_mass_scale(self) -> float:
        """MuJoCo's settotalmass: every body's mass and inertia scaled by this."""
        wanted = self.compiler.settotalmass
        if wanted <= 0:
            return 1.0
        total = sum(m.mass for b in self.bodies for _, m in b.parts) + sum(
            m.mass for m in self.static_mass)
        if total <= 0:
            raise self.error("<compiler>", "settotalmass: the model has no mass to scale")
        return wanted / total
