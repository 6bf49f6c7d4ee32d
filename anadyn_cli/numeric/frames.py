"""Forward kinematics as numbers, from the same symbolic kinematics as the dynamics.

``symbolic.kinematics.build`` gives every body's rotation R_i (body axes ->
world) and mass-centre position r_i; the equations of motion are derived
from exactly these.  Here they become one generated, vectorized function
(``codegen``), so a drawing or an animation shows the robot the equations
describe, not a second model of it:

    frames(q1, ..., qn) -> origin  (..., b, 3)  body frame origins, world axes
                           R       (..., b, 3, 3) body axes -> world axes
                           com     (..., b, 3)  mass centres r_i
                           joint   (..., b, 3)  joint locations: the parent's
                                                origin + R_parent * joint origin
                                                (a prismatic body slides away from it)
                           axis    (..., b, 3)  joint axes, world axes (zero: fixed)
                           tip     (..., b, 3)  where a body's link is drawn to when
                                                no child marks its end: 2 com
                                                (the far end of a uniform bar)

with origin = r_i - R_i c_i.  The generated code and a plain-types
``Skeleton`` (names, tree, joint types, the contacts' numbers) are stored in the
derivation cache under the key "frames", so an animation of a cached robot needs
no SymPy.  A contact's sphere centre in world axes is origin_b + R_b c (``Contact``:
its body b and centre c in body axes, as ``numeric.contact`` plans it).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from . import cache

CACHE_KEY = "frames"


@dataclass(frozen=True)
class Skeleton:
    """What a drawing needs to know besides the numbers (JSON-storable)."""
    name: str
    coordinates: tuple[str, ...]
    units: tuple[str, ...]                  # "rad" or "m" per coordinate
    initial: tuple[float, ...]              # q(0)
    bodies: tuple[str, ...]
    parents: tuple[int, ...]                # index of the parent body, -1 for ground
    joint_types: tuple[str, ...]            # type words of model.joints.JOINT_TYPES
    displacements: tuple[str, ...]          # the joint displacement as written, "q2 - q1"
    gravity: tuple[float, float, float]     # world axes, m/s^2
    contacts: tuple = ()                    # ``Contact`` fields as dicts (JSON-storable)

    def children(self, i: int) -> list[int]:
        return [k for k, p in enumerate(self.parents) if p == i]

    @classmethod
    def from_dict(cls, data: dict) -> "Skeleton":
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})

    def contact_list(self) -> list["Contact"]:
        return [Contact(**c) for c in self.contacts]


@dataclass(frozen=True)
class Contact:
    """What a drawing needs of a contact: a sphere of ``radius`` (0: a point) centred at
    ``centre`` (body axes) on body ``body`` (an index), against the plane
    ``normal`` . x = ``height`` (world axes; the force along normal, t1 and t2) or, when
    ``partner`` is an index, against the sphere of ``partner_radius`` at
    ``partner_centre`` on that body."""
    name: str
    body: int
    centre: list
    radius: float
    normal: list                      # [] for a pair (its normal turns)
    tangents: list
    height: float
    partner: int | None = None
    partner_centre: list | None = None
    partner_radius: float = 0.0

    def world_centre(self, poses: "Poses") -> np.ndarray:
        """(..., 3): the sphere's centre at every configuration of ``poses``."""
        return poses.origin[..., self.body, :] + np.einsum(
            "...ij,j->...i", poses.R[..., self.body, :, :], np.asarray(self.centre, float))

    def partner_world_centre(self, poses: "Poses") -> np.ndarray:
        return poses.origin[..., self.partner, :] + np.einsum(
            "...ij,j->...i", poses.R[..., self.partner, :, :],
            np.asarray(self.partner_centre, float))

    def normal_at(self, poses: "Poses") -> np.ndarray:
        """(..., 3): the unit normal the contact's force acts along (the ground's, or
        from the partner's centre to this sphere's)."""
        if self.partner is None:
            return np.broadcast_to(np.asarray(self.normal, float),
                                   poses.origin.shape[:-2] + (3,))
        gap = self.world_centre(poses) - self.partner_world_centre(poses)
        length = np.linalg.norm(gap, axis=-1, keepdims=True)
        return gap / np.where(length > 0, length, 1.0)

    def force_point(self, poses: "Poses") -> np.ndarray:
        """(..., 3): where the force acts: the sphere's lowest point c - radius n on a
        ground, the middle of the overlap c - (radius - d/2) n against a partner."""
        c, n = self.world_centre(poses), self.normal_at(poses)
        if self.partner is None:
            return c - self.radius * n
        gap = np.linalg.norm(c - self.partner_world_centre(poses), axis=-1, keepdims=True)
        depth = self.radius + self.partner_radius - gap
        return c - (self.radius - depth / 2) * n


@dataclass(frozen=True)
class Poses:
    """Frames of every body at one or more configurations (leading axes: the states)."""
    origin: np.ndarray
    R: np.ndarray
    com: np.ndarray
    joint: np.ndarray
    axis: np.ndarray
    tip: np.ndarray

    def at(self, k: int) -> "Poses":
        """The k-th configuration of a sequence."""
        return Poses(*(getattr(self, f)[k] for f in self.__dataclass_fields__))


class Frames:
    """The generated forward kinematics of one robot."""

    def __init__(self, skeleton: Skeleton, source: str):
        namespace: dict[str, object] = {}
        exec(compile(source, "<anadyn frames>", "exec"), namespace)   # noqa: S102
        self.skeleton, self.source = skeleton, source
        self._frames = namespace["frames"]

    def __call__(self, q) -> Poses:
        """Poses at coordinates ``q``: shape (n,) for one configuration, or
        (..., n) for many (e.g. the rows of a simulation)."""
        q = np.asarray(q, dtype=float)
        n = len(self.skeleton.coordinates)
        if q.shape[-1:] != (n,):
            raise ValueError(f"expected {n} coordinates, got shape {q.shape}")
        origin, R, com, joint, axis, tip = self._frames(*np.moveaxis(q, -1, 0))
        b = len(self.skeleton.bodies)
        return Poses(origin, R.reshape(R.shape[:-2] + (b, 3, 3)), com, joint, axis, tip)


def source(robot) -> tuple[Skeleton, str]:
    """The skeleton and generated source of ``robot``'s forward kinematics."""
    import sympy as sp

    from .. import __version__
    from ..symbolic import kinematics
    from .codegen import Function, module_source

    kin = kinematics.build(robot)
    origins, rotations, coms, joints, axes, tips = [], [], [], [], [], []
    for k, b in enumerate(kin.bodies):
        origin = sp.Matrix(b.position - b.R * b.com)
        if b.parent is None:
            parent_origin, parent_R = sp.zeros(3, 1), sp.eye(3)
        else:
            parent_origin, parent_R = origins[b.parent], rotations[b.parent]
        joint_origin = sp.Matrix([a.xreplace(robot.parameter_substitution())
                                  for a in b.body.joint.origin])
        joint = sp.Matrix(parent_origin + parent_R * joint_origin)
        axis = sp.Matrix(b.R * b.axis) if b.body.joint.joint_type.moving else sp.zeros(3, 1)
        origins.append(origin)
        rotations.append(sp.Matrix(b.R))
        coms.append(sp.Matrix(b.position))
        joints.append(joint)
        axes.append(axis)
        tips.append(sp.Matrix(origin + 2 * b.R * b.com))

    def stack(vectors):
        return sp.Matrix([[v[i] for i in range(3)] for v in vectors])

    R_rows = sp.Matrix.vstack(*[R for R in rotations])
    function = Function(
        "frames", tuple(kin.q),
        (("origin", stack(origins)), ("R", R_rows), ("com", stack(coms)),
         ("joint", stack(joints)), ("axis", stack(axes)), ("tip", stack(tips))),
        True, "Body origins, rotations (stacked 3 x 3 blocks), mass centres, joint "
              "locations, joint axes and link tips, world axes.")
    code = module_source([function], f"generated by anadyn {__version__} from {robot.source} "
                                     f"(forward kinematics)")
    values = robot.parameter_substitution()
    skeleton = Skeleton(
        name=robot.name, coordinates=tuple(c.name for c in robot.coordinates),
        units=tuple(c.unit for c in robot.coordinates),
        initial=tuple(float(c.initial) for c in robot.coordinates),
        bodies=tuple(b.name for b in robot.bodies),
        parents=tuple(-1 if b.parent is None else b.parent for b in kin.bodies),
        joint_types=tuple(b.joint.type for b in robot.bodies),
        displacements=tuple(sp.sstr(b.joint.displacement, order="none")
                            if b.joint.joint_type.moving else ""
                            for b in robot.bodies),
        gravity=tuple(float(g.xreplace(values)) for g in robot.gravity),
        contacts=_contacts(robot, values))
    return skeleton, code


def _contacts(robot, values) -> tuple:
    """The contacts' numbers (``numeric.contact.contact_plans``) a drawing needs."""
    from .contact import contact_plans

    index = {b.name: i for i, b in enumerate(robot.bodies)}
    wanted = [f.name for f in fields(Contact)]
    return tuple({k: v for k, v in asdict(plan).items() if k in wanted}
                 for plan in contact_plans(robot, lambda e: float(e.xreplace(values) if hasattr(e, "xreplace") else e),
                               index))


def frames(robot, use_cache: bool = False) -> Frames:
    """The forward kinematics of ``robot`` (a validated ``Robot``, or a path to a
    robot file), from the cache when asked and there."""
    from pathlib import Path

    if isinstance(robot, (str, Path)):
        return _from_path(robot, use_cache)
    if use_cache:
        found = cached(robot.digest, robot.source)
        if found is not None:
            return found
    skeleton, code = source(robot)
    if use_cache:
        cache.store(robot.digest, CACHE_KEY, {"code": code, "skeleton": asdict(skeleton),
                                              "name_given": robot.name_given})
    return Frames(skeleton, code)


def _from_path(path, use_cache: bool) -> Frames:
    import hashlib

    from ..model.yamlsource import read_text

    text, source_name = read_text(path)
    if use_cache:
        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()
        found = cached(digest, source_name)
        if found is not None:
            return found
    from ..model import robot_from_text

    return frames(robot_from_text(text, source_name), use_cache)


def cached(digest: str, source_name: str) -> Frames | None:
    """The stored forward kinematics of the robot file with this digest, or None."""
    from dataclasses import replace

    from ..model.names import default_name

    entry = cache.load(digest, CACHE_KEY)
    if entry is None:
        return None
    try:
        skeleton = Skeleton.from_dict(entry["skeleton"])
        if not entry["name_given"]:
            skeleton = replace(skeleton, name=default_name(source_name))
        return Frames(skeleton, entry["code"])
    except Exception:           # noqa: BLE001  anything wrong with a stored entry is a miss
        return None
