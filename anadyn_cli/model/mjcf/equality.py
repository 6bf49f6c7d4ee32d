"""MJCF <equality> ``connect`` and ``weld`` as anadyn loops (``model.constraints``).

MuJoCo's equality constraints are soft (``solref``, ``solimp``); anadyn's loops
hold exactly, so the import says so in one warning.  The mapping, as MuJoCo's
compiler places the constraints (its ``eq_data``):

- ``connect body1 [body2] anchor``: the anchor (body1's axes) and the point of
  body2 (default the world) that coincides with it at the model's reference
  configuration (qpos0, the joints' ``ref``) coincide along world x, y and z;
  ``connect site1 site2``: the two sites' origins coincide;
- ``weld body1 [body2] anchor relpose``: body2's frame keeps its pose in body1's
  (the one at qpos0, or ``relpose`` when its quaternion is not zero, which then
  places body2's anchor point); ``weld site1 site2``: the site frames coincide.
  Three points of body2 carry it: the anchor and the points WELD_ARM away from
  it along world x and y (at qpos0), each tied to its place in body1;

then only the equations that are independent at qpos0 are kept (rows taken
in order while they raise the rank of the constraint Jacobian, so a weld keeps
3 + 2 + 1 of its 9 when nothing else limits it, and a planar connect the two
in its plane).  If the rows together have a higher rank at a configuration
NEARBY where the equalities hold than at qpos0, the start is singular and the
import stops.
The dependent coordinates come from a column-pivoted QR of the kept rows'
Jacobian at qpos0 (Businger-Golub: the column with the largest part not yet
spanned first), over the unactuated hinge and slide coordinates first while
their columns keep PREFER of the largest column's size, then over all.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..joints import Revolute
from ..names import GROUND
from ..urdf.frames import compose, rpy_matrix
from . import frames

#: the equality elements mapped onto loops; the others are refused
MAPPED = ("connect", "weld")
WELD_ARM = 1.0       # m: a weld's second and third points, from its anchor (world x, y);
#                      1 m, so their multipliers (N) read as the moments (N m) they carry
RANK_TOL = 1e-8      # a row or column below this times the Jacobian's size adds no rank
NEARBY = 1e-3       # rad or m: how far from qpos0 the rank is checked again
PREFER = 1e-3        # unactuated columns are taken first while this size (relative) is left
DIRECTIONS = ("x", "y", "z")
WORLD = "world"      # MuJoCo's name of the world body


@dataclass(frozen=True)
class Equality:
    """One connect or weld: its objects' frames in their anadyn bodies, and where
    they meet (None: where they are at qpos0)."""
    name: str            # MJCF name (or "<tag>N")
    kind: str            # connect | weld
    where: str           # for messages
    one: tuple           # (anadyn body, (R, t)): object 1's frame in that body's axes
    two: tuple
    a: np.ndarray | None          # the meeting point in object 1's axes
    b: np.ndarray | None          # ... in object 2's axes
    rotation: np.ndarray | None   # weld: object 2's axes in object 1's


def read(reader, section, placed: dict, sites: dict) -> list[Equality]:
    """The <equality> section's connect and weld elements; one line for any other."""
    found = []
    for k, element in enumerate(section):
        name = element.get("name") or f"{element.tag}{k + 1}"
        where = f"equality {element.tag} {name!r}"
        if element.tag not in MAPPED:
            raise reader.error(where, f"a <{element.tag}> equality: anadyn maps connect and "
                                      "weld equalities onto loops only; remove it from a copy")
        cls = element.get("class", "main")
        if cls not in reader.defaults:
            raise reader.error(where, f'class="{cls}": no <default> of this class')
        active = element.get("active", reader.defaults[cls].get("equality", {}).get("active",
                                                                                     "true"))
        if active != "true":
            raise reader.error(where, f'active="{active}": anadyn\'s loops always hold; an '
                                      "equality switched off at the start is not imported")
        by_site = element.get("site1") is not None or element.get("site2") is not None
        if by_site:
            for key in ("body1", "body2", "anchor", "relpose"):
                if element.get(key) is not None:
                    raise reader.error(where, f"{key} with site1 and site2: give the two sites "
                                              "only (their frames meet)")
            one, two = (_object(reader, element, key, sites, "site", where)
                        for key in ("site1", "site2"))
            zero = np.zeros(3)
            found.append(Equality(name, element.tag, where, one, two, zero, zero,
                                  np.eye(3) if element.tag == "weld" else None))
            continue
        one = _object(reader, element, "body1", placed, "body", where)
        if element.get("body2") is None:
            two = placed[WORLD]
        else:
            two = _object(reader, element, "body2", placed, "body", where)
        anchor = reader.numbers(element, "anchor", 3, where, "0 0 0")
        if element.tag == "connect":
            found.append(Equality(name, "connect", where, one, two, anchor, None, None))
            continue
        relpose = reader.numbers(element, "relpose", 7, where, "0 1 0 0 0 0 0")
        given = bool(np.any(relpose[3:]))
        found.append(Equality(name, "weld", where, one, two, relpose[:3] if given else None,
                              anchor, frames.quat_matrix(relpose[3:]) if given else None))
    return found


def _object(reader, element, key: str, known: dict, what: str, where: str):
    value = element.get(key)
    if value is None:
        raise reader.error(where, f"needs {key}")
    if value not in known:
        raise reader.error(where, f'{key}="{value}": no {what} of this name')
    return known[value]


def close(equalities: list[Equality], data: dict, candidates: list[str], actuated: set[str],
          error) -> tuple[list[tuple], dict[str, float]]:
    """The loops, (equality, (body, point) a, (body, point) b, directions) each, points
    in the bodies' axes, and the dependent coordinates with their guesses (where the
    equalities hold next to qpos0: qpos0's values when it satisfies them), for
    ``equalities`` on the imported tree ``data`` (robot-file data without them);
    ``candidates`` are the coordinates that may be dependent, ``error(where,
    message)`` makes the ModelError of a refusal."""
    geometry = _Tree(data["bodies"], list(data["coordinates"]))
    names = list(data["coordinates"])
    q0 = np.array([float(c["initial"]) for c in data["coordinates"].values()])
    start = geometry.poses(q0)
    pairs = []                                         # (equality, ends a and b) per point
    for equality in equalities:
        pairs += [(equality, ends) for ends in _points(equality, start)]
    if any(ends[0][0] == ends[1][0] for _, ends in pairs):
        equality = next(e for e, ends in pairs if ends[0][0] == ends[1][0])
        raise error(equality.where, "both objects are on one rigid body here (no joint "
                                    "between them): the equality constrains nothing")

    def gaps(q):
        return _gaps(pairs, geometry.poses(q))

    def jacobian(q):                               # central differences
        rows = np.zeros((3 * len(pairs), len(q)))
        for k in range(len(q)):
            step = 1e-6 * max(1.0, abs(q[k]))
            up, down = q.copy(), q.copy()
            up[k] += step
            down[k] -= step
            rows[:, k] = (gaps(up) - gaps(down)) / (2 * step)
        return rows

    closed = _project(q0, gaps, jacobian)          # q0 itself unless relpose or sites
    if closed is None:
        raise error(equalities[0].where, "the equality constraints cannot be met near the "
                                         "reference configuration; check the sites or relpose")
    J = jacobian(closed)
    size = max(1.0, float(np.abs(J).max(initial=0.0)))
    kept = _independent(J, size)
    near = _nearby(closed, J, size, gaps, jacobian)
    rank = len(kept) if near is None else np.linalg.matrix_rank(jacobian(near),
                                                                tol=RANK_TOL * size)
    if rank > len(kept):
        raise error(equalities[0].where, f"the equality constraints are singular at the "
                                         f"reference configuration (rank {len(kept)} there, "
                                         f"{rank} next to it); move the joints' ref")
    loops, used = [], set()
    for k, (equality, (a, b)) in enumerate(pairs):
        directions = [DIRECTIONS[d] for d in range(3) if 3 * k + d in kept]
        if directions:
            used.add(id(equality))
            loops.append((equality, a, b, directions))
    for equality in equalities:
        if id(equality) not in used:
            raise error(equality.where, "no joint moves its objects apart: the equality "
                                        "constrains nothing")
    rows = J[kept]
    pools = ([names.index(q) for q in candidates if q not in actuated],
             [names.index(q) for q in candidates])
    dependent = _pivoted(rows, pools)
    if len(dependent) < len(kept):
        raise error(equalities[0].where, f"the equality constraints fix {len(kept)} "
                                         "combinations of the coordinates, but only "
                                         f"{len(dependent)} hinge or slide coordinates can be "
                                         "solved from them")
    return loops, {names[i]: float(closed[i]) for i in sorted(dependent)}


class _Tree:
    """World poses of the imported bodies at numeric coordinates, from the joints as
    written (revolute and prismatic; rpy as numbers or ``robottext._angle``'s k*pi/d),
    as the loader composes them: C = Rz(yaw) Ry(pitch) Rx(roll), then the turn about
    (or the slide along) the unit axis by the coordinate."""

    def __init__(self, bodies: list[dict], coordinates: list[str]):
        self.items = []
        for body in bodies:
            joint = body["joint"]
            axis = np.asarray(joint["axis"], dtype=float)
            self.items.append((body["name"], body.get("parent", GROUND), joint["type"],
                               rpy_matrix([_angle_value(a) for a in joint.get("rpy", (0, 0, 0))]),
                               np.asarray(joint.get("origin", (0, 0, 0)), dtype=float),
                               axis / np.linalg.norm(axis),
                               coordinates.index(joint["displacement"])))

    def poses(self, q) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        poses = {GROUND: (np.eye(3), np.zeros(3))}
        for name, parent, kind, C, origin, axis, index in self.items:
            if kind == Revolute.word:
                local = (C @ frames.axis_angle(axis, q[index]), origin)
            else:
                local = (C, origin + C @ axis * q[index])
            poses[name] = compose(poses[parent], local)
        return poses


def _angle_value(value) -> float:
    """A written angle: a number, or k*pi/d text (``robottext._angle``)."""
    if not isinstance(value, str):
        return float(value)
    sign, times, over = re.fullmatch(r"(-?)(?:(\d+)\*)?pi(?:/(\d+))?", value).groups()
    return (-1 if sign else 1) * int(times or 1) * math.pi / int(over or 1)


def _points(equality: Equality, poses: dict) -> list[tuple]:
    """The point pairs ((body, point), (body, point)), each point in its anadyn body's
    axes, that coincide when the equality holds."""
    (body1, pose1), (body2, pose2) = equality.one, equality.two
    world1, world2 = compose(poses[body1], pose1), compose(poses[body2], pose2)
    a, b, rotation = equality.a, equality.b, equality.rotation
    if a is None:
        a = world1[0].T @ (world2[1] + world2[0] @ b - world1[1])
    if b is None:
        b = world2[0].T @ (world1[1] + world1[0] @ a - world2[1])
    offsets = [np.zeros(3)]
    if equality.kind == "weld":
        if rotation is None:
            rotation = world1[0].T @ world2[0]
        offsets += [world2[0].T @ (WELD_ARM * np.eye(3)[k]) for k in (0, 1)]
    else:
        rotation = np.eye(3)
    return [((body1, pose1[1] + pose1[0] @ (a + rotation @ u)),
             (body2, pose2[1] + pose2[0] @ (b + u))) for u in offsets]


def _gaps(pairs, poses) -> np.ndarray:
    """World x, y, z of r_a - r_b for each pair."""
    out = []
    for _, ((body_a, a), (body_b, b)) in pairs:
        (Ra, pa), (Rb, pb) = poses[body_a], poses[body_b]
        out.append(pa + Ra @ a - pb - Rb @ b)
    return np.concatenate(out)


def _nearby(q0, J, size: float, gaps, jacobian) -> np.ndarray | None:
    """A configuration where the equalities hold, NEARBY (rad or m) from q0 along
    the motions they allow there; None if none is found."""
    _, values, axes = np.linalg.svd(J)
    free = axes[int((values > RANK_TOL * size).sum()):]
    if not len(free):
        return None
    direction = np.random.default_rng(0).normal(size=len(free)) @ free
    return _project(q0 + NEARBY * direction / np.linalg.norm(direction), gaps, jacobian)


def _project(q, gaps, jacobian) -> np.ndarray | None:
    """q moved onto the configurations where the gaps are 0 (Gauss-Newton, least-norm
    steps); q itself if they are 0 there, None if it does not converge."""
    for _ in range(30):
        residual = gaps(q)
        if np.abs(residual).max() <= 1e-12 * max(1.0, np.abs(q).max()):
            return q
        q = q - np.linalg.lstsq(jacobian(q), residual, rcond=None)[0]
    return None


def _independent(J: np.ndarray, size: float) -> list[int]:
    """Rows of J taken in order while each raises the rank."""
    kept: list[int] = []
    for row in range(len(J)):
        if np.linalg.matrix_rank(J[kept + [row]], tol=RANK_TOL * size) > len(kept):
            kept.append(row)
    return kept


def _pivoted(J: np.ndarray, pools: tuple[list[int], list[int]]) -> list[int]:
    """Columns of J by column-pivoted QR, from the first pool while a column keeps
    PREFER of the largest column's size beyond those taken, then from the second
    (down to RANK_TOL), until they span J's rows."""
    target = np.linalg.matrix_rank(J, tol=RANK_TOL * max(1.0, np.abs(J).max(initial=0.0)))
    largest = max(1e-300, float(np.linalg.norm(J, axis=0).max(initial=0.0)))
    basis = np.zeros((J.shape[0], 0))
    chosen: list[int] = []
    for pool, floor in zip(pools, (PREFER, RANK_TOL)):
        while len(chosen) < target:
            left = J - basis @ (basis.T @ J)
            sizes = {k: float(np.linalg.norm(left[:, k])) for k in pool if k not in chosen}
            if not sizes:
                break
            best = max(sizes, key=sizes.get)
            if sizes[best] <= floor * largest:
                break
            chosen.append(best)
            basis = np.column_stack([basis, left[:, best] / sizes[best]])
    return chosen
