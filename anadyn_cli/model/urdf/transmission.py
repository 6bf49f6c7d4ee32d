"""URDF <transmission> elements -> the drives of the imported actuators.

A transmission names one <joint> and one <actuator>; its <mechanicalReduction>
(inside the <actuator>, ROS's current format, or directly inside the
<transmission>, the older one) is the gear ratio N of that joint's actuator:
motor rate = N times joint rate, joint torque = N times the motor's.  It
imports as ``drive: {gear: N}`` on the actuator of that joint (a ratio of 1, the
default, changes nothing and imports as no drive).  Transmissions of several
joints or actuators (differentials) are not imported: one warning each.
"""
from __future__ import annotations

import math

from .parse import DECIMAL, LARGEST


def gears(root, reader) -> dict[str, dict]:
    """URDF joint name -> ``{"drive": {"gear": N}}`` for each simple transmission whose
    mechanicalReduction is not 1.  A reduction of 0, or one that is not a decimal number,
    is one ``ModelError`` naming the transmission."""
    found: dict[str, dict] = {}
    for element in root.findall("transmission"):
        where = f"<transmission name={element.get('name')!r}>"
        joints, actuators = element.findall("joint"), element.findall("actuator")
        if len(joints) != 1 or len(actuators) != 1:
            reader.warnings.append(f"{reader.source}: {where}: {len(joints)} joints and "
                                   f"{len(actuators)} actuators; only transmissions of one "
                                   "joint and one actuator import (as a gear), ignored")
            continue
        ratio = actuators[0].find("mechanicalReduction")
        if ratio is None:
            ratio = element.find("mechanicalReduction")
        if ratio is None:
            continue
        text = (ratio.text or "").strip()
        value = float(text) if DECIMAL.match(text) else math.nan
        if not (math.isfinite(value) and 0 < abs(value) <= LARGEST):
            raise reader.error(where, f"<mechanicalReduction>{text}</mechanicalReduction>: "
                                      "expected a non-zero decimal number (the gear ratio: "
                                      "motor rate / joint rate)")
        if value != 1:
            found[joints[0].get("name")] = {"drive": {"gear": value}}
    return found
