"""Deterministic random robot files for cross-checking the formulations.

``random_robot_yaml(seed)`` writes a valid robot YAML text: 1 to 6 bodies on a
random tree (each body's parent is ground or any earlier body), revolute and
prismatic joints with the odd fixed one, arbitrary (unnormalized) axes,
origins and rpy, random masses, mass centres and physically valid inertia
tensors, zero or arbitrary gravity, and one actuator per moving joint.

Every number is written as a plain decimal with at most 6 significant digits
(no exponent notation, so YAML reads it as a float and anadyn takes it
exactly as written).  Joint displacements are the joint's own coordinate or,
for some robots, a linear combination such as ``q2 - q1`` (a triangular,
hence invertible, map from coordinates to displacements).  The only
expression forms written are ``c*name`` terms joined by `` + `` / `` - ``,
which ``tests/mechanics_oracle.py`` reads independently.

``random_robot_yaml(seed, forces=True)`` adds joint damping, friction (with
and without its own friction_velocity), springs and a ``loads`` section
(forces and torques of t, the coordinates and rates, in world or body
axes, at random points), drawn from a second random stream, so the robot
itself is the same as without them.  Load expressions are sums of
``c*name``, ``c*sin(c*t)`` and ``c*cos(name)`` terms.

    python tests/random_robots.py [seed] [forces]     # print a sample
"""
from __future__ import annotations

import math
import random

import numpy as np

MAX_BODIES = 6


def fmt(x: float, digits: int = 6) -> str:
    """A YAML float with at most ``digits`` significant digits, no exponent."""
    x = float(x)
    if x == 0 or abs(x) < 1e-9:
        return "0.0"
    decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))
    text = f"{round(x, decimals):.{decimals}f}"
    if "." in text:
        text = text.rstrip("0")
        if text.endswith("."):
            text += "0"
    else:
        text += ".0"
    return "0.0" if float(text) == 0 else text


def vec(values, digits: int = 6) -> str:
    return "[" + ", ".join(fmt(v, digits) for v in values) + "]"


def _rotation(rng: random.Random) -> np.ndarray:
    """A uniformly random rotation matrix (from a random unit quaternion)."""
    w, x, y, z = (rng.gauss(0, 1) for _ in range(4))
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _inertia(rng: random.Random, mass: float, degenerate: bool) -> str | None:
    """An inertia mapping (central, body axes) or None for a point mass.

    Point masses and slender rods (singular tensors) only if ``degenerate``:
    they are kept off revolute joints, so that M(q) is positive definite
    (the moving body nearest the root always has kinetic energy).
    """
    style = rng.random() if degenerate else 1.0
    if style < 0.08:
        return None                                   # point mass
    if style < 0.2:                                   # slender rod along x: exact, degenerate
        length = rng.uniform(0.2, 1.0)
        i = fmt(mass * length ** 2 / 12)
        return f"{{iyy: {i}, izz: {i}}}"
    # a solid box or ellipsoid with random semi-axes, randomly rotated
    a, b, c = (rng.uniform(0.05, 0.6) for _ in range(3))
    k = 1 / 12 if rng.random() < 0.5 else 1 / 5      # box (full sides) or ellipsoid
    principal = np.diag([mass * k * (b * b + c * c), mass * k * (a * a + c * c),
                         mass * k * (a * a + b * b)])
    if rng.random() < 0.25:
        R = np.eye(3)                                 # principal axes = body axes
    else:
        R = _rotation(rng)
    I = R @ principal @ R.T
    entries = {"ixx": I[0, 0], "iyy": I[1, 1], "izz": I[2, 2],
               "ixy": I[0, 1], "ixz": I[0, 2], "iyz": I[1, 2]}
    items = [f"{key}: {fmt(value)}" for key, value in entries.items()
             if fmt(value) != "0.0"]
    return "{" + ", ".join(items) + "}"


def _axis(rng: random.Random) -> list[float]:
    if rng.random() < 0.4:                            # a coordinate axis, maybe negative/scaled
        axis = [0.0, 0.0, 0.0]
        axis[rng.randrange(3)] = rng.choice([1.0, 1.0, 1.0, -1.0, 2.0, 0.5])
        return axis
    while True:
        axis = [round(rng.uniform(-1, 1), 3) for _ in range(3)]
        if math.sqrt(sum(a * a for a in axis)) > 0.2:
            return axis


def _term(coefficient: float, name: str, first: bool) -> str:
    sign = "-" if coefficient < 0 else "+"
    magnitude = abs(coefficient)
    body = name if magnitude == 1 else f"{fmt(magnitude, 3)}*{name}"
    if first:
        return ("-" if sign == "-" else "") + body
    return f" {sign} {body}"


def _joint_forces(rng: random.Random) -> list[str]:
    """Some of damping, friction (maybe with friction_velocity), stiffness and rest."""
    keys = []
    if rng.random() < 0.6:
        keys.append(f"damping: {fmt(rng.uniform(0.05, 2.0), 3)}")
    if rng.random() < 0.6:
        keys.append(f"friction: {fmt(rng.uniform(0.1, 3.0), 3)}")
        if rng.random() < 0.7:
            keys.append(f"friction_velocity: {fmt(rng.choice([0.05, 0.2, 0.5, 1.5]), 3)}")
    if rng.random() < 0.6:
        keys.append(f"stiffness: {fmt(rng.uniform(0.5, 30.0), 3)}")
        if rng.random() < 0.7:
            keys.append(f"rest: {fmt(rng.uniform(-1.0, 1.0), 3)}")
    return keys


def _load_expression(rng: random.Random, coordinates: list[str]) -> str:
    """c0 + c1*sin(c2*t) + c3*q + c4*dq + c5*cos(q), some terms left out."""
    text = fmt(rng.uniform(-5, 5), 3)
    if rng.random() < 0.5:
        text += _term(rng.uniform(-3, 3), f"sin({fmt(rng.uniform(0.5, 4), 3)}*t)", False)
    if coordinates and rng.random() < 0.5:
        text += _term(rng.uniform(-3, 3), rng.choice(coordinates), False)
    if coordinates and rng.random() < 0.5:
        text += _term(rng.uniform(-2, 2), "d" + rng.choice(coordinates), False)
    if coordinates and rng.random() < 0.3:
        text += _term(rng.uniform(-2, 2), f"cos({rng.choice(coordinates)})", False)
    return text


def _loads(rng: random.Random, bodies: list[str], coordinates: list[str]) -> list[str]:
    lines = ["loads:"]
    for _ in range(rng.randint(1, 3)):
        entry = [f"body: {rng.choice(bodies)}"]
        kinds = rng.choice([("force",), ("torque",), ("force", "torque")])
        if "force" in kinds and rng.random() < 0.7:
            entry.append("point: " + vec([rng.uniform(-0.5, 0.5) for _ in range(3)], 4))
        for kind in kinds:
            components = [_load_expression(rng, coordinates) if rng.random() < 0.7 else "0"
                          for _ in range(3)]
            entry.append(f"{kind}: [" + ", ".join(components) + "]")
        if rng.random() < 0.7:
            entry.append(f"frame: {rng.choice(['world', 'body'])}")
        lines.append("  - {" + ", ".join(entry) + "}")
    return lines


def random_robot_yaml(seed: int, forces: bool = False) -> str:
    """A valid robot YAML text, the same for the same seed (and ``forces``)."""
    rng = random.Random(seed)
    frng = random.Random(f"forces {seed}")      # the forces' own stream
    n_bodies = rng.randint(1, MAX_BODIES)
    prefix = rng.choice(["q", "q", "q", "x", "th"])
    linear_combinations = rng.random() < 0.35
    body_prefix = rng.choice(["link", "b", "arm"])

    kinds = []
    for _ in range(n_bodies):
        r = rng.random()
        kinds.append("revolute" if r < 0.47 else "prismatic" if r < 0.88 else "fixed")
    if all(k == "fixed" for k in kinds):
        kinds[rng.randrange(n_bodies)] = rng.choice(["revolute", "prismatic"])
    moving = [i for i, k in enumerate(kinds) if k != "fixed"]
    n = len(moving)
    # coordinate names in file order (shuffled relative to the bodies sometimes)
    coordinate_names = [f"{prefix}{k + 1}" for k in range(n)]
    file_order = list(coordinate_names)
    if rng.random() < 0.3:
        rng.shuffle(file_order)
    body_coordinate = {body: coordinate_names[k] for k, body in enumerate(moving)}

    lines = [f"# random robot, seed {seed}", f"name: random{seed}"]
    g = rng.random()
    if g < 0.2:
        pass                                          # no gravity key: zero gravity
    elif g < 0.3:
        lines.append("gravity: [0, 0, 0]")
    elif g < 0.6:
        lines.append("gravity: [0, 0, -9.81]")
    else:
        lines.append("gravity: " + vec([rng.uniform(-10, 10) for _ in range(3)], 4))
    lines.append("coordinates:")
    for name in file_order:
        lines.append(f"  {name}: {{}}" if rng.random() < 0.5 else f"  {name}:")
    lines.append("bodies:")

    names = [f"{body_prefix}{i + 1}" for i in range(n_bodies)]
    next_default = 0                                  # loader's default-coordinate iterator
    earlier_moving: list[str] = []                    # coordinates of earlier moving joints
    parents: list[str] = []
    last_default: int | None = None                   # joints taking defaults form a chain

    def descends(i: int, ancestor: int | None) -> bool:
        name = parents[i]
        while ancestor is not None and name != "ground":
            if name == names[ancestor]:
                return True
            name = parents[names.index(name)]
        return ancestor is None

    for i in range(n_bodies):
        parent = "ground" if i == 0 or rng.random() < 0.3 else names[rng.randrange(i)]
        parents.append(parent)
        kind = kinds[i]
        joint = [f"type: {kind}"]
        if kind != "fixed":
            joint.append("axis: " + vec(_axis(rng), 3))
        if rng.random() < 0.75:
            joint.append("origin: " + vec([rng.uniform(-0.5, 0.5) for _ in range(3)], 4))
        r = rng.random()
        if r < 0.3:
            joint.append("rpy: " + vec([rng.uniform(-math.pi, math.pi) for _ in range(3)], 5))
        elif r < 0.5:                                 # a single turn
            rpy = [0.0, 0.0, 0.0]
            rpy[rng.randrange(3)] = rng.uniform(-math.pi, math.pi)
            joint.append("rpy: " + vec(rpy, 5))
        elif r < 0.6:
            joint.append("rpy: [0, 0, 0]")
        if kind != "fixed":
            own = body_coordinate[i]
            displacement = own
            if linear_combinations and earlier_moving and rng.random() < 0.7:
                others = rng.sample(earlier_moving, k=min(len(earlier_moving), rng.randint(1, 2)))
                coefficient = rng.choice([1.0, 1.0, -1.0, 2.0, 0.5])
                displacement = _term(coefficient, own, True)
                for other in others:
                    displacement += _term(rng.choice([-1.0, -1.0, 1.0, 0.5, -0.25]), other, False)
            if (displacement == own and next_default < n
                    and file_order[next_default] == own and rng.random() < 0.5
                    and descends(i, last_default)):  # (after the draw: same robots)
                next_default += 1                     # omit it: the loader's default
                last_default = i
            else:
                joint.append(f"displacement: {displacement}")
            earlier_moving.append(own)
            if forces:
                joint += _joint_forces(frng)
        mass = rng.uniform(0.5, 5)
        lines.append(f"  - name: {names[i]}")
        if parent != "ground" or rng.random() < 0.5:
            lines.append(f"    parent: {parent}")
        lines.append("    joint: {" + ", ".join(joint) + "}")
        lines.append(f"    mass: {fmt(mass, 4)}")
        if rng.random() < 0.8:
            lines.append("    com: " + vec([rng.uniform(-0.3, 0.3) for _ in range(3)], 4))
        inertia = _inertia(rng, round(mass, 3), degenerate=kind != "revolute")
        if inertia is not None:
            lines.append(f"    inertia: {inertia}")
    lines.append("actuators:")
    order = list(moving)
    if rng.random() < 0.3:
        rng.shuffle(order)
    for body in order:
        lines.append(f"  tau_{names[body]}: {{joint: {names[body]}}}")
    if forces:
        lines += _loads(frng, names, coordinate_names)
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    import sys

    print(random_robot_yaml(int(sys.argv[1]) if len(sys.argv) > 1 else 0,
                            forces=len(sys.argv) > 2), end="")
