"""The contact geoms of an MJCF model, as the robot's ``contacts`` section (a mixin of the
importer): every sphere, capsule or box geom on a moving body against each plane of the
world it collides with (contype/conaffinity), MuJoCo's soft law mapped onto the
compliant one (``contact.law``)."""
from __future__ import annotations

import math

import numpy as np

from ..names import GROUND
from ..robottext import _angle
from ..urdf.frames import _snap, compose, matrix_rpy
from . import contact

GEOM_TYPES = ("plane", "hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh",
              "sdf")


class ContactGeoms:
    """Collects the geoms while the body tree is walked (``collect``) and writes the
    contacts at the end (``contacts``); ``touching`` None: contacts not asked for."""

    def collect(self, body: str | None, owner: str, pending, members) -> None:
        """With contacts: the geoms of the MJCF ``body`` (None: the world body), its
        planes when it is part of the world (``owner`` the ground), else every geom,
        with the frame ``pending`` of the body in the anadyn body ``owner``'s axes and
        the geom's <frame>."""
        if self.touching is None:
            return
        geoms = [(g, frame, cls) for g, frame, cls in members if g.tag == "geom"]
        for k, (element, frame, cls) in enumerate(geoms):
            label = element.get("name") or f"{body or 'world'}_geom{k + 1}"
            place = (f"body {body!r}" if body else "<worldbody>") + (
                f": geom {element.get('name') or k + 1!r}")
            kind = self.word(element, "type", GEOM_TYPES, place, "sphere", cls)
            if owner == GROUND and kind == "plane":
                pose = self.pose(element, place, cls)
                self.planes.append((element, cls, place, label,
                                    compose(pending, compose(frame, pose) if frame else pose)))
            elif owner != GROUND:
                self.touching.append((owner, element, cls, place, label, kind,
                                      compose(pending, frame) if frame else pending))

    def contact_terms(self, element, where: str, cls: str) -> dict:
        """A geom's collision attributes, MuJoCo's defaults where not given."""
        solref = self.numbers(element, "solref", 2, where, " ".join(map(str, contact.SOLREF)),
                              cls)
        if solref[0] <= 0 or solref[1] <= 0:
            raise self.error(where, f'solref="{self.get(element, "solref", cls)}": anadyn maps '
                                    "(timeconst, dampratio) > 0, not direct stiffness and "
                                    "damping")
        solimp = self.numbers(element, "solimp", (3, 5), where,
                              " ".join(map(str, contact.SOLIMP)), cls)
        return {"bits": (int(self.number(element, "contype", where, "1", cls)),
                         int(self.number(element, "conaffinity", where, "1", cls))),
                "condim": self.number(element, "condim", where, "3", cls),
                "friction": self.numbers(element, "friction", (1, 3), where, "1", cls)[0],
                "solmix": self.number(element, "solmix", where, "1", cls),
                "margin": self.number(element, "margin", where, "0", cls),
                "solref": solref, "solimp": [*solimp, *contact.SOLIMP[len(solimp):]]}

    def contacts(self, gravity, scale: float) -> dict | None:
        """The ``contacts`` section (``contact``): each sphere, capsule or box geom on a
        moving body against each plane of the world it collides with; None when no
        pair does.  Other geom types that would touch a plane are left out with a
        warning."""
        if not self.touching or not self.planes or "contact" in self.disabled:
            return None
        g = float(np.linalg.norm(gravity)) or 9.81
        mass = scale * sum(m.mass for b in self.bodies for _, m in b.parts)
        planes = [(label, R[:, 2], float(R[:, 2] @ p), self.contact_terms(e, where, cls))
                  for e, cls, where, label, (R, p) in self.planes]
        entries, left_out, used, depths = [], [], set(), set()
        for owner, element, cls, where, label, kind, pose in self.touching:
            terms = self.contact_terms(element, where, cls)
            pairs = [plane for plane in planes if contact.collides(terms["bits"], plane[3]["bits"])]
            if not pairs:
                continue
            if kind not in contact.CONTACT_GEOMS:
                left_out.append(where)
                continue
            size, R, centre = self.shape(element, kind, where, cls)
            R, centre = compose(pose, (R, centre))
            parts = {"sphere": 1, "capsule": 2, "box": 8}[kind]
            scale = max(np.abs(centre).max(), max(size))
            if kind == "sphere":
                shape = {"radius": self.value(size[0]),
                         "point": self.vector(_snap(centre, scale))}
            elif kind == "capsule":
                half = R[:, 2] * size[1]
                shape = {"shape": "capsule", "radius": self.value(size[0]),
                         "from": self.vector(_snap(centre - half, scale)),
                         "to": self.vector(_snap(centre + half, scale))}
            else:
                shape = {"shape": "box", "size": self.vector(size),
                         "point": self.vector(_snap(centre, scale)),
                         "rpy": [_angle(self.value(a)) for a in _snap(matrix_rpy(R), math.pi)]}
            for plane, normal, height, other in pairs:
                share = other["solmix"] / (terms["solmix"] + other["solmix"]) if (
                    terms["solmix"] + other["solmix"]) > 0 else 0.5
                mix = [share * np.asarray(other[key]) + (1 - share) * np.asarray(terms[key])
                       for key in ("solref", "solimp")]
                stiffness, damping, depth = contact.law(mass, g, *mix)
                depths.add(depth)
                name = self.names.unique(
                    self.names.clean(label if len(pairs) == 1 else f"{label}_{plane}", "c_"),
                    lambda n: not ({n} | {f"{n}_{j}" for j in range(1, parts + 1)}) & used)
                used |= {name} | {f"{name}_{j}" for j in range(1, parts + 1)}
                entries.append({"name": name, "body": owner, **shape, "ground": {
                    "normal": self.vector(_snap(normal)),
                    "height": self.value(height + max(terms["margin"], other["margin"]))},
                    "stiffness": self.value(stiffness), "damping": self.value(damping),
                    "friction": self.value(0 if max(terms["condim"], other["condim"]) == 1
                                           else max(terms["friction"], other["friction"]))})
        if left_out:
            self.warnings.append(f"{self.source}: {', '.join(left_out)}: left out of the "
                                 "contacts (anadyn's contact shapes are spheres, capsules and "
                                 "boxes)")
        if not entries:
            return None
        section = {}
        for key in ("ground", "stiffness", "damping", "friction"):
            if all(e[key] == entries[0][key] for e in entries):
                section[key] = entries[0][key]
                for e in entries:
                    del e[key]
        self.warnings.append(
            f"{self.source}: contacts: {len(entries)} geom-plane pair(s) with anadyn's "
            "compliant law, not MuJoCo's soft contact: stiffness sinks a contact carrying "
            f"the whole weight ({mass * g:.4g} N) to MuJoCo's resting depth "
            f"({', '.join(f'{d * 1e3:.4g}' for d in sorted(depths))} mm), "
            "damping at its dampratio there; transients differ (docs: how-to/mjcf)")
        return {**section, "geometry": entries}

