"""MJCF (MuJoCo XML) -> an anadyn robot description, as ``urdf`` does for URDF.

MJCF is XML from strangers: it is read with ``defusedxml`` (entity declarations
and external references refused), the model and its <include>s capped at
MAX_BYTES together, each <include> inside the model's folder (no meshes are
read).  Numbers must be decimals as written; names end up as identifiers or in
escaped text, never as YAML structure (``robottext.render``).  Every mistake is
one ``ModelError`` line naming the file and the element.

The mapping (``importer``), computed as MuJoCo's compiler computes it:

- bodies with <joint type="hinge"> -> revolute, type="slide" -> prismatic; a body
  with several joints becomes a chain of bodies, one per joint, the earlier ones
  massless; a body without joints is folded into the body it hangs from (its
  mass, centre of mass and inertia added); bodies on the world body are the
  ground;
- frames: pos, and quat, axisangle, euler (with <compiler eulerseq>), xyaxes or
  zaxis, angles in <compiler angle> units (degrees by default); <frame>
  elements, nested, their poses composed into what they hold; a hinge turns
  about its pos (the anadyn body frame sits there); a joint's ``ref`` is turned
  (or slid) into the joint frame, so the coordinate is MuJoCo's qpos and starts
  at ref;
- <default> classes, nested, and childclass; range (limited or autolimits),
  damping, stiffness and springref (anadyn's ``rest``); frictionloss becomes
  anadyn's smoothed friction, with a warning (MuJoCo's is a constraint);
- armature a, added by MuJoCo to the mass matrix's diagonal: a rotor body on the
  ground turning with the coordinate, inertia a about its fixed axis (a thin
  disk, a/2 across): exactly a*rate^2/2 of kinetic energy, no other effect;
- mass properties: the <inertial> (diaginertia or fullinertia, in its frame),
  or with ``inertiafromgeom`` (true, or auto without <inertial>) the sum of the
  body's geoms in groups 0-5, of their ``mass`` or ``density`` (default 1000):
  sphere, capsule, cylinder, box, ellipsoid (``inertia``), fromto included;
  ``settotalmass``, ``boundmass``, ``boundinertia`` and ``inertiagrouprange``
  as MuJoCo applies them;
- <option gravity> and <flag gravity|spring|damper="disable">;
- <actuator>: motor, position and velocity on joints, with their gear (the
  actuator's ``drive: {gear}``), ctrlrange and forcerange; the control u is a
  controller gain (0) and each actuator's effort (MuJoCo's actuator_force) a law
  (``_Importer.actuators``).

Free joints import as anadyn's floating joints (welded by ``fix_base`` on a body
of the world body), ball joints as spherical ones, with MuJoCo's qpos and qvel as
their coordinates and speeds (``_Importer.several_joint``).

<equality> connect and weld become loops, exact (MuJoCo's are soft), with the
dependent coordinates chosen by a pivoted QR at qpos0 (``equality``; the importer's
part: ``loops``).

Refused, one line each: forces and actuators on ball and free joints, tendons,
other equalities (joint, tendon, flex, inactive ones, any with ball or free
joints), composites, plugins, mocap bodies, gravcomp, springdamper, mesh geoms
(and shellinertia) without an <inertial>, other actuators.  With ``contacts``
(--contacts) the sphere, capsule and box geoms that can touch a plane of the
world become compliant contacts against it (``contact``: the law; ``geoms``: which
geoms).  Actuators: ``actuators``.
Ignored: sites (but as an equality's ends), cameras, lights, assets, sensors,
<contact> pairs and excludes, keyframes, visuals.
"""
from .source import MAX_BYTES, MAX_INCLUDES, is_mjcf

__all__ = ["MAX_BYTES", "MAX_INCLUDES", "import_file", "is_mjcf"]


def import_file(*args, **kwargs):
    """``importer.import_file``: the importer is read only when an MJCF file is (a run
    of a URDF or YAML robot that merely asks whether a file is MJCF does not need it)."""
    from .importer import import_file as run

    return run(*args, **kwargs)
