"""MJCF ``<actuator>`` elements (a mixin of the importer): motor, position and velocity
actuators on hinge and slide joints, as anadyn's actuators with a drive's gear and their
laws as MuJoCo computes the force (controls as gains, ctrlrange and forcerange as
clamps)."""
from __future__ import annotations

from ..robottext import _format


class Actuators:
    """The actuators, their laws and the controls they read."""

    def actuators(self, root):
        """{actuator: {joint: body, drive: {gear}}}, {actuator: law} and {gain: value}, as
        MuJoCo computes an actuator's force: the control u (a gain, 0) clamped to
        ctrlrange, the force (motor: u; position servo: kp (u - gear q) - kv gear dq;
        velocity servo: kv (u - gear dq)) clamped to forcerange is the law (MuJoCo's
        actuator_force); its gear is the drive's (the force on the joint: gear times it)."""
        owners = {b.mjcf_joint: b.name for b in self.bodies}
        actuators, laws, gains = {}, {}, {}
        for section in root.findall("actuator"):
            for k, element in enumerate(section):
                name = element.get("name") or f"{element.tag}{k + 1}"
                where = f"actuator {name!r}"
                if element.tag not in ("motor", "position", "velocity"):
                    raise self.error(where, f"<{element.tag}>: anadyn imports motor, position "
                                            "and velocity actuators")
                joint = self.get(element, "joint")
                if joint is None:
                    raise self.error(where, "anadyn imports actuators on a joint (joint=\"...\"),"
                                            " not on tendons, sites or bodies")
                if joint not in owners or joint in self.several:
                    raise self.error(where, f'joint="{joint}": no hinge or slide joint of '
                                            "this name (anadyn's actuators act along one "
                                            "coordinate)")
                gear = self.numbers(element, "gear", (1, 6), where, "1")[0]
                actuator, control = self.identifier(name, "u_"), self.identifier(f"u_{name}", "u_")
                actuators[actuator] = {"joint": owners[joint], **(     # the gear: a drive's
                    {"drive": {"gear": self.value(gear)}} if gear != 1 else {})}
                gains[control] = 0
                force = self.force(element, self.clamped(element, "ctrl", control, where),
                                   self.coordinates[joint][0], gear, where)
                force = self.clamped(element, "force", force, where)
                laws[actuator] = force
        return actuators, laws, gains

    def force(self, element, u: str, q: str, gear: float, where: str) -> str:
        """The actuator's force (before forcerange) for the control text ``u``."""
        if element.tag == "motor":
            return u
        for key in ("dampratio", "timeconst"):
            if self.number(element, key, where, "0") != 0:
                raise self.error(where, f"{key}: give kv (and kp) instead; anadyn imports "
                                        "the gains as they are")
        g = "" if gear == 1 else f"{_format(self.value(gear))}*"
        kv = self.number(element, "kv", where, "0" if element.tag == "position" else "1")
        if element.tag == "velocity":
            return f"{_format(kv)}*({u} - {g}d{q})"
        term = f"{_format(self.number(element, 'kp', where, '1'))}*({u} - {g}{q})"
        return term + (f" - {_format(kv)}*{g}d{q}" if kv else "")

    def clamped(self, element, kind: str, text: str, where: str) -> str:
        """``text`` clamped to the actuator's ``kind``range (ctrl or force) when it is
        limited (``kind``limited true, or auto with autolimits and a range given)."""
        key = f"{kind}range"
        limited = self.word(element, f"{kind}limited", ("true", "false", "auto"), where, "auto")
        if not (limited == "true" or limited == "auto" and self.compiler.autolimits
                and self.get(element, key) is not None):
            return text
        lower, upper = self.numbers(element, key, 2, where, "0 0")
        if lower > upper:
            raise self.error(where, f'{key}="{self.get(element, key)}": the lower end is above '
                                    "the upper one")
        return f"min(max({text}, {_format(self.value(lower))}), {_format(self.value(upper))})"

    def identifier(self, name: str, prefix: str) -> str:
        """``name`` made an identifier not yet taken by a coordinate, rate, actuator or gain."""
        result = self.names.unique(self.names.clean(name, prefix),
                                   lambda n: n not in self.names.taken)
        self.names.taken.add(result)
        return result

