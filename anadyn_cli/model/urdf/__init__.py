"""URDF -> an anadyn robot description (a plain dict in the YAML schema, and its text).

URDF is XML from strangers, so it is read with ``defusedxml`` (expat underneath,
with entity declarations and external references refused: no "billion laughs",
no file or network access) and capped at MAX_BYTES.  Numbers must be decimals
as written (DECIMAL: no ``1_0``, which float() reads as 10); names, however
odd, end up as identifiers, in double-quoted strings or in escaped comments,
never as YAML structure (``render``).  Every mistake is one
``ModelError`` line naming the file and the element, e.g.
``arm.urdf: joint 'elbow': <limit lower="1" upper="-1">: lower is above upper``.

The mapping, frames as in URDF (a link's frame is its joint frame after the
joint moves; the joint frame is the parent's frame moved by <origin xyz> and
turned by <origin rpy>, R = Rz(yaw) Ry(pitch) Rx(roll)), which is anadyn's own
convention, so joints carry over number for number:

- the root link, and every link fixed to it, is the base: the ``ground``;
- a revolute, continuous (a revolute without position limits) or prismatic
  joint is a body with that joint; its coordinate is named after the joint,
  and it gets one actuator ``tau_<joint>``;
- a <mimic joint="m" multiplier="k" offset="c"> joint is a body whose
  displacement is ``k*m + c`` (chains of mimics composed), with no coordinate
  and no actuator of its own;
- a link on a fixed joint is folded into the body it is fixed to: its mass,
  centre of mass and inertia are added exactly (``combine``), its name and
  pose are kept as a comment above that body in the YAML text;
- a locked joint (``lock``: joint -> value, Pinocchio's ``buildReducedModel``)
  folds its child in the same way, at the pose its joint type's ``transform``
  gives at that value; the mimics of a locked joint are locked with it;
- a link without mass between joints (URDF's ball joints: three revolute
  joints with virtual links) is a body of mass 0; a joint that moves no mass
  at all (none on its link or beyond) is refused, naming every such joint;
- <limit> -> joint ``limits: {lower, upper, velocity, effort}``;
  <dynamics damping friction> -> joint ``damping``, ``friction``;
- a <transmission> of one joint and one actuator with a <mechanicalReduction>
  N other than 1 -> that joint's actuator ``drive: {gear: N}`` (``transmission``);
- the child link's <inertial>: com = origin xyz, inertia = R I R^T with R
  the rotation of origin rpy (central inertia in body axes);
- gravity: 9.81 m/s^2 along -z of the root link, the URDF convention.

Floating and planar joints cannot be represented (``fix_base`` welds the one
that carries the root link to the world).  ``ReadingOptions`` gathers
``fix_base``, ``inertia`` and ``lock``; ``READING`` holds those a command reads
URDF files with, and ``link_bodies`` says where each link ends up.  Inertias that no rigid body has
(principal moments breaking I1 + I2 >= I3) are refused unless ``inertia`` is
"repair" (the nearest valid tensor, ``nearest_valid_moments``) or "accept";
both are stated in ``Imported.warnings``, never silent.

The package, one step per module: ``options`` (ReadingOptions, READING, --lock
texts), ``parse`` (the file and its XML, <link> and <joint> elements),
``frames`` (poses, roll-pitch-yaw), ``inertia`` (mass properties, the inertia
policy), ``tree`` (root, floating joints, tree order, mimics), ``reduce``
(locks, folding, joints that move no mass), ``emit`` (the YAML text) and
``importer`` (the steps in order, ``import_file``, ``link_bodies``, ``place``).
"""
from importlib import import_module

from .options import INERTIA_POLICIES, READING, ReadingOptions, parse_lock, reading
from .parse import (DECIMAL, LARGEST, MAX_BYTES, URDF_TYPES, WELDED, XACRO,
                    _parse_xml, read_urdf)

#: names loaded on first use: a run that reads a URDF's import back from the cache
#: (``numeric.build``) reads the file (``read_urdf``) and imports nothing
_LAZY = {**dict.fromkeys(("PLAIN_TEXT", "SMALLEST", "render"), "..robottext"),
         **dict.fromkeys(("IDENTITY", "Pose", "compose", "matrix_rpy", "rpy_matrix"), ".frames"),
         **dict.fromkeys(("GRAVITY", "Imported", "LinkBodies", "_Importer", "description",
                          "import_file", "import_urdf", "link_bodies", "place"), ".importer"),
         **dict.fromkeys(("PSD_TOLERANCE", "TRIANGLE_TOLERANCE", "MassProperties", "combine",
                          "inertia_problem", "nearest_valid_moments"), ".inertia")}

__all__ = sorted(["DECIMAL", "INERTIA_POLICIES", "LARGEST", "MAX_BYTES", "READING",
                  "ReadingOptions", "URDF_TYPES", "WELDED", "XACRO", "_parse_xml", "parse_lock",
                  "read_urdf", "reading", *_LAZY])


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'anadyn_cli.model.urdf' has no attribute {name!r}")
