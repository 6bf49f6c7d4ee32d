"""The robots of ``bench/scale.py``, each written twice from one spec: as an
anadyn YAML file and as a URDF file for Pinocchio (the same numbers).

- ``chain(n)``: n revolute joints with alternating axes z, y, z, y, ... (as
  configs/chain6.yaml), each at the previous link's tip, slender 0.5 m, 1 kg
  links with diagonal inertia, gravity along -z, PD laws holding a bent posture;
- ``tree(branches, depth)``: a trunk of 2 joints carrying ``branches`` arms of
  ``depth`` joints each (2 + branches*depth joints; 4 x 7 gives 30), axes
  cycling z, y, x, full (rotated) inertia tensors;
- ``arm7()``: a 7-joint arm with rpy between links and full inertia
  tensors (Panda-like proportions);
- ``panda()``: the Franka Panda's seven arm joints and links as its URDF in
  tests/data/urdf gives them (frames, masses, centres of mass, full inertia
  tensors); the hand and fingers after the last joint are left off.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET  # noqa: S405  (the project's own test file)
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class Link:
    name: str
    parent: str                      # "ground" or a link name
    axis: tuple
    origin: tuple
    rpy: tuple = (0.0, 0.0, 0.0)
    mass: float = 1.0
    com: tuple = (0.0, 0.0, 0.0)
    inertia: np.ndarray = field(default_factory=lambda: np.diag([0.02, 0.02, 0.001]))
    initial: float = 0.0
    target: float = 0.0
    gains: tuple = (2.0, 50.0)       # damping b, stiffness k of the PD law


@dataclass
class Spec:
    name: str
    links: list[Link]
    gravity: tuple = (0.0, 0.0, -9.81)
    t_end: float = 5.0
    dt: float = 0.01


def _f(x: float) -> str:
    return repr(float(x))


def _v(values) -> str:
    return "[" + ", ".join(_f(v) for v in values) + "]"


def to_yaml(spec: Spec) -> str:
    lines = [f"name: {spec.name}", f"gravity: {_v(spec.gravity)}", "coordinates:"]
    lines += [f"  q_{l.name}: {{initial: {_f(l.initial)}}}" for l in spec.links]
    lines.append("bodies:")
    for l in spec.links:
        I = l.inertia
        lines += [f"  - name: {l.name}", f"    parent: {l.parent}",
                  f"    joint: {{type: revolute, axis: {_v(l.axis)}, origin: {_v(l.origin)}, "
                  f"rpy: {_v(l.rpy)}, displacement: q_{l.name}}}",
                  f"    mass: {_f(l.mass)}", f"    com: {_v(l.com)}",
                  f"    inertia: {{ixx: {_f(I[0, 0])}, iyy: {_f(I[1, 1])}, izz: {_f(I[2, 2])}, "
                  f"ixy: {_f(I[0, 1])}, ixz: {_f(I[0, 2])}, iyz: {_f(I[1, 2])}}}"]
    lines.append("actuators:")
    lines += [f"  tau_{l.name}: {{joint: {l.name}}}" for l in spec.links]
    lines += ["controller:", "  laws:"]
    lines += [f"    tau_{l.name}: -{_f(l.gains[0])}*dq_{l.name} - {_f(l.gains[1])}*(q_{l.name} - "
              f"{_f(l.target)})" for l in spec.links]
    lines.append(f"simulation: {{t_end: {_f(spec.t_end)}, output_step: {_f(spec.dt)}}}")
    return "\n".join(lines) + "\n"


def to_urdf(spec: Spec) -> str:
    out = [f'<robot name="{spec.name}">', '  <link name="ground"/>']
    for l in spec.links:
        I = l.inertia
        out += [f'  <link name="{l.name}"><inertial>',
                f'    <origin xyz="{" ".join(map(_f, l.com))}" rpy="0 0 0"/>',
                f'    <mass value="{_f(l.mass)}"/>',
                f'    <inertia ixx="{_f(I[0, 0])}" ixy="{_f(I[0, 1])}" ixz="{_f(I[0, 2])}" '
                f'iyy="{_f(I[1, 1])}" iyz="{_f(I[1, 2])}" izz="{_f(I[2, 2])}"/>',
                '  </inertial></link>',
                f'  <joint name="j_{l.name}" type="revolute">',
                f'    <parent link="{l.parent}"/><child link="{l.name}"/>',
                f'    <origin xyz="{" ".join(map(_f, l.origin))}" rpy="{" ".join(map(_f, l.rpy))}"/>',
                f'    <axis xyz="{" ".join(map(_f, l.axis))}"/>',
                '    <limit lower="-10" upper="10" effort="1000" velocity="100"/>',
                '  </joint>']
    out.append("</robot>")
    return "\n".join(out) + "\n"


def chain(n: int) -> Spec:
    L, m = 0.5, 1.0
    Ixx = m * L * L / 12
    links = []
    for i in range(n):
        z = i % 2 == 0
        links.append(Link(
            name=f"l{i + 1}", parent="ground" if i == 0 else f"l{i}",
            axis=(0.0, 0.0, 1.0) if z else (0.0, 1.0, 0.0),
            origin=(0.0, 0.0, 0.0 if i == 0 else L), mass=m, com=(0.0, 0.0, L / 2),
            inertia=np.diag([Ixx, Ixx, 0.001]),
            initial=0.3 * math.sin(1.7 * i + 0.5), target=0.5 * math.cos(1.3 * i),
            gains=(0.2, 5.0) if z else (2.0, 50.0)))
    return Spec(f"chain{n}", links)


def _rotation(a: float, b: float, c: float) -> np.ndarray:
    ca, sa, cb, sb, cc, sc = (math.cos(a), math.sin(a), math.cos(b), math.sin(b),
                              math.cos(c), math.sin(c))
    Rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
    Ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    Rx = np.array([[1, 0, 0], [0, cc, -sc], [0, sc, cc]])
    return Rz @ Ry @ Rx


def _full_inertia(mass: float, sides, angles) -> np.ndarray:
    a, b, c = sides
    principal = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * mass / 12
    R = _rotation(*angles)
    I = R @ principal @ R.T
    return np.round(I, 12)


def tree(branches: int = 4, depth: int = 7) -> Spec:
    axes = [(0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)]
    links = []
    k = 0

    def add(name, parent, origin, rpy=(0.0, 0.0, 0.0)):
        nonlocal k
        mass = 1.0 + 0.25 * (k % 4)
        links.append(Link(
            name=name, parent=parent, axis=axes[k % 3], origin=origin, rpy=rpy, mass=mass,
            com=(0.02 * (k % 3), 0.01, 0.15),
            inertia=_full_inertia(mass, (0.08, 0.1, 0.3), (0.3 * k, 0.2, 0.1 * k)),
            initial=0.2 * math.sin(k + 1.0), target=0.3 * math.cos(0.7 * k),
            gains=(3.0, 60.0)))
        k += 1

    add("trunk1", "ground", (0.0, 0.0, 0.0))
    add("trunk2", "trunk1", (0.0, 0.0, 0.4))
    for b in range(branches):
        angle = 2 * math.pi * b / branches
        parent = "trunk2"
        for d in range(depth):
            name = f"b{b + 1}_{d + 1}"
            if d == 0:
                add(name, parent, (0.1 * math.cos(angle), 0.1 * math.sin(angle), 0.3),
                    rpy=(0.0, 0.4, angle))
            else:
                add(name, parent, (0.0, 0.0, 0.3))
            parent = name
    return Spec(f"tree{len(links)}", links)


def arm7() -> Spec:
    """7 revolute joints, rpy of +-pi/2 between links (as the Panda), full inertias."""
    h = math.pi / 2
    frames = [((0, 0, 0.333), (0, 0, 0)), ((0, 0, 0), (-h, 0, 0)), ((0, -0.316, 0), (h, 0, 0)),
              ((0.0825, 0, 0), (h, 0, 0)), ((-0.0825, 0.384, 0), (-h, 0, 0)),
              ((0, 0, 0), (h, 0, 0)), ((0.088, 0, 0), (h, 0, 0))]
    masses = [4.97, 0.646, 3.23, 3.59, 1.23, 1.67, 0.735]
    links = []
    for i, ((xyz, rpy), m) in enumerate(zip(frames, masses)):
        links.append(Link(
            name=f"a{i + 1}", parent="ground" if i == 0 else f"a{i}", axis=(0.0, 0.0, 1.0),
            origin=tuple(map(float, xyz)), rpy=tuple(map(float, rpy)), mass=m,
            com=(0.01 * (i % 3), -0.02 * (i % 2), 0.03 * (i % 4) - 0.02),
            inertia=_full_inertia(m, (0.1, 0.12, 0.2), (0.4 * i, 0.3, 0.2 * i)),
            initial=0.3 * math.sin(i + 0.3), target=0.4 * math.cos(i), gains=(5.0, 80.0)))
    return Spec("arm7", links)


PANDA = Path(__file__).resolve().parents[1] / "tests" / "data" / "urdf" / "panda.urdf"


def _floats(text: str | None, default=(0.0, 0.0, 0.0)) -> tuple:
    return tuple(float(v) for v in text.split()) if text else default


def panda(path: Path = PANDA) -> Spec:
    """The Panda's arm from its URDF: joints panda_joint1..7 and their child links."""
    root = ET.parse(path).getroot()
    inertials = {link.get("name"): link.find("inertial") for link in root.findall("link")}
    links = []
    for i in range(7):
        joint = root.find(f"joint[@name='panda_joint{i + 1}']")
        origin, inertial = joint.find("origin"), inertials[joint.find("child").get("link")]
        com = inertial.find("origin")
        assert _floats(com.get("rpy")) == (0.0, 0.0, 0.0)      # inertia in the link frame
        t = inertial.find("inertia").attrib
        inertia = np.array([[float(t["ixx"]), float(t["ixy"]), float(t["ixz"])],
                            [float(t["ixy"]), float(t["iyy"]), float(t["iyz"])],
                            [float(t["ixz"]), float(t["iyz"]), float(t["izz"])]])
        links.append(Link(
            name=f"p{i + 1}", parent="ground" if i == 0 else f"p{i}",
            axis=_floats(joint.find("axis").get("xyz")), origin=_floats(origin.get("xyz")),
            rpy=_floats(origin.get("rpy")), mass=float(inertial.find("mass").get("value")),
            com=_floats(com.get("xyz")), inertia=inertia,
            initial=0.3 * math.sin(i + 0.3), target=0.4 * math.cos(i), gains=(5.0, 80.0)))
    return Spec("panda", links)


#: the named robots of the benches' --robots options
SPECS = {"chain6": lambda: chain(6), "chain12": lambda: chain(12), "chain24": lambda: chain(24),
         "tree30": tree, "arm7": arm7, "panda": panda}
