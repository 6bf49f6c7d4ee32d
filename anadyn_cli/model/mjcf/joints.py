"""MJCF joints as anadyn bodies (a mixin of the importer): a hinge or slide joint
becomes a revolute or prismatic joint with its forces (``joint``, ``joint_forces``), a
ball or free joint a spherical or floating one (``several_joint``)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..joints import Floating, Prismatic, Revolute, Spherical
from ..names import ANGULAR, GROUND, QUATERNION
from ..robottext import _angle, _format
from ..urdf.frames import _snap, matrix_rpy
from . import frames

#: MJCF joint types anadyn represents -> its joint type word (``model.joints``)
JOINTS = {"hinge": Revolute.word, "slide": Prismatic.word}
#: the MJCF joints of several coordinates (``several_joint``)
SEVERAL = ("ball", "free")


@dataclass
class _Body:
    """One anadyn body: an MJCF joint, the MJCF bodies it carries (parts, in its axes)."""
    name: str
    parent: str
    joint: dict
    mjcf_joint: str
    mjcf_body: str
    parts: list = field(default_factory=list)


class Joints:
    """Turns each MJCF joint into an anadyn body (``bodies``) and its coordinates."""

    def joint(self, element, body: str, owner: str, pending, cls: str, last: bool, frame):
        """The anadyn body of one MJCF joint (in the <frame> of pose ``frame`` when not
        None); returns it as the new owner and the MJCF body's frame in its axes."""
        count = sum(b.mjcf_body == body for b in self.bodies)
        name = element.get("name") or f"{body}_joint{count + 1}"
        where = f"joint {name!r}"
        if name in self.coordinates:
            raise self.error(where, "a second joint of this name (MuJoCo's names are unique)")
        kind = "free" if element.tag == "freejoint" else self.word(
            element, "type", ("free", "ball", "slide", "hinge"), where, "hinge", cls)
        if kind == "free":
            if self.fix_base and owner == GROUND:
                self.warnings.append(f"{self.source}: {where}: free joint welded to the world "
                                     "(--fix-base)")
                return owner, pending
            if owner != GROUND:
                raise self.error(where, "a free joint on a body that is not on the world body "
                                        "(MuJoCo allows it only there)")
        if kind in SEVERAL:
            return self.several_joint(element, kind, name, body, owner, pending, cls, last,
                                      frame, where)
        R, t = pending
        p = self.numbers(element, "pos", 3, where, "0 0 0", cls)
        axis = self.numbers(element, "axis", 3, where, "0 0 1", cls)
        self.nonzero(axis, element, "axis", where)
        if frame is not None:
            p, axis = frame[1] + frame[0] @ p, _snap(frame[0] @ axis)
        unit = axis / np.linalg.norm(axis)
        angle = math.pi / 180 if kind == "hinge" and self.compiler.degrees else 1.0
        ref = self.number(element, "ref", where, "0", cls) * angle
        if kind == "hinge":
            origin, C, after = t + R @ p, R @ frames.axis_angle(unit, -ref), -p
        else:
            origin, C, after = t - R @ unit * ref, R, np.zeros(3)
        q = self.names.coordinate(name)
        self.coordinates[name] = (q, ref)
        self.kinds[name] = kind
        spec = {"type": JOINTS[kind]}
        origin = _snap(origin)
        if origin.any():
            spec["origin"] = self.vector(origin)
        rpy = _snap(matrix_rpy(C), math.pi)
        if rpy.any():
            spec["rpy"] = [_angle(self.value(a)) for a in rpy]
        spec["axis"] = self.vector(axis)
        spec["displacement"] = q
        if self.get(element, "springdamper", cls) is not None and self.numbers(
                element, "springdamper", 2, where, cls=cls).any():
            raise self.error(where, "springdamper: give stiffness and damping instead (anadyn "
                                    "imports them as they are)")
        spec.update(self.joint_forces(element, kind, angle, where, cls))
        armature = self.nonnegative(element, "armature", where, cls)
        if armature:
            self.rotors.append({"coordinate": q, "joint": name, "armature": armature})
        anadyn_name = self.names.body(body if last else f"{body}_{name}")
        self.bodies.append(_Body(anadyn_name, owner, spec, name, body))
        return anadyn_name, (np.eye(3), after)

    def several_joint(self, element, kind: str, name: str, body: str, owner: str, pending,
                      cls: str, last: bool, frame, where: str):
        """A ball joint (anadyn's spherical: the quaternion and the angular velocity in
        body axes, MuJoCo's qpos and qvel) turning about its ``pos`` in the body, or a
        free joint (anadyn's floating: x, y, z and the quaternion, MuJoCo's qpos, the
        body's placement at the start; speeds the origin's velocity in the world and
        the angular velocity in body axes, MuJoCo's qvel).  Neither takes forces,
        limits or actuators here."""
        for key in ("damping", "stiffness", "frictionloss", "armature"):
            if self.number(element, key, where, "0", cls):
                raise self.error(where, f'{key}="{self.get(element, key, cls)}" on a {kind} '
                                        "joint: not imported (anadyn's joint forces act along "
                                        "one coordinate)")
        R, t = pending
        stem = self.names.coordinate(name)
        if kind == "free":
            spec = {"type": Floating.word}
            initial = [*t, *frames.quaternion_of(R)]
            parts, after = ("x", "y", "z", *QUATERNION), (np.eye(3), np.zeros(3))
        else:
            p = self.numbers(element, "pos", 3, where, "0 0 0", cls)
            if frame is not None:
                p = frame[1] + frame[0] @ p
            spec, initial = {"type": Spherical.word}, [1, 0, 0, 0]
            parts, after = QUATERNION, (np.eye(3), -p)
            origin, rpy = _snap(t + R @ p), _snap(matrix_rpy(R), math.pi)
            if origin.any():
                spec["origin"] = self.vector(origin)
            if rpy.any():
                spec["rpy"] = [_angle(self.value(a)) for a in rpy]
        names = [self.names.coordinate(f"{stem}_{part}") for part in parts]
        speeds = [self.names.coordinate(f"{stem}_{part}") for part in ANGULAR]
        spec.update(coordinates=names, speeds=speeds)
        self.several[name] = (names, [self.value(v) for v in initial])
        self.kinds[name] = kind
        anadyn_name = self.names.body(body if last else f"{body}_{name}")
        self.bodies.append(_Body(anadyn_name, owner, spec, name, body))
        return anadyn_name, after

    def joint_forces(self, element, kind: str, angle: float, where: str, cls: str) -> dict:
        spec = {}
        limited = self.word(element, "limited", ("true", "false", "auto"), where, "auto", cls)
        has_range = self.get(element, "range", cls) is not None
        if limited == "true" or (limited == "auto" and self.compiler.autolimits and has_range):
            lower, upper = self.numbers(element, "range", 2, where, "0 0", cls) * angle
            if lower > upper:
                raise self.error(where, f'range="{self.get(element, "range", cls)}": the lower '
                                        "end is above the upper one")
            if lower < upper:
                spec["limits"] = {"lower": self.value(lower), "upper": self.value(upper)}
        damping = self.nonnegative(element, "damping", where, cls)
        if damping and "damper" not in self.disabled:
            spec["damping"] = self.value(damping)
        friction = self.nonnegative(element, "frictionloss", where, cls)
        if friction:
            spec["friction"] = self.value(friction)
            self.warnings.append(
                f"{self.source}: {where}: frictionloss {_format(friction)} becomes anadyn's "
                "smoothed Coulomb friction (friction * tanh(rate / 0.01)); MuJoCo's is a "
                "constraint, so the motions differ near rest")
        stiffness = self.nonnegative(element, "stiffness", where, cls)
        if stiffness and "spring" not in self.disabled:
            spec["stiffness"] = self.value(stiffness)
            rest = self.number(element, "springref", where, "0", cls) * angle
            if rest:
                spec["rest"] = self.value(rest)
        return spec

    def nonnegative(self, element, key: str, where: str, cls: str) -> float:
        value = self.number(element, key, where, "0", cls)
        if value < 0:
            raise self.error(where, f'{key}="{self.get(element, key, cls)}": cannot be negative')
        return value
