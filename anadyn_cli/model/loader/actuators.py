"""The ``actuators`` and ``controller`` sections: which joint each actuator
drives, the controller's gains and one law per actuator."""
from __future__ import annotations

import difflib

import sympy as sp

from ...errors import shorten
from ..robot import Actuator, Body, Controller, Coordinate, frozen_map
from ..yamlschema import describe_value as _kind
from .bodies import MOVING_WORDS
from .cursor import Cursor


class _Actuators:
    """The builder's actuators and controller (part of
    ``builder._RobotBuilder``)."""

    def actuators(self, cursor: Cursor, bodies: tuple[Body, ...]) -> tuple[Actuator, ...]:
        by_name = {b.name: b for b in bodies}
        result = []
        for key, item in cursor.mapping().items():
            self.key_name(item, key, "actuator name")
            self.claim(item, key, "an actuator")
            fields = item.mapping(("joint",), required=("joint",))
            body_name = fields["joint"].value
            if not isinstance(body_name, str):
                raise fields["joint"].error(f"expected a body name, got {_kind(body_name)}")
            if body_name not in by_name:
                shown = repr(shorten(body_name))
                close = (difflib.get_close_matches(body_name, list(by_name), n=1)
                         if isinstance(body_name, str) else [])
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise fields["joint"].error(f"unknown body {shown}{hint}; actuators act on "
                                            f"the joint of one of: {', '.join(by_name)}")
            joint = by_name[body_name].joint
            if not joint.joint_type.axial:
                raise fields["joint"].error(f"body {body_name!r} has a {joint.type} joint; "
                                            f"anadyn drives only a {MOVING_WORDS} joint")
            result.append(Actuator(key, body_name, joint.joint_type.effort_unit))
        return tuple(result)

    def controller(self, cursor: Cursor, actuators: tuple[Actuator, ...],
                   coordinates: tuple[Coordinate, ...]) -> Controller:
        fields = cursor.mapping(("gains", "laws"), required=("laws",))
        gains: dict[str, sp.Expr] = {}
        names = dict(self.symbols)
        if "gains" in fields:
            for key, item in fields["gains"].mapping().items():
                self.key_name(item, key, "gain name")
                self.claim(item, key, "a controller gain")
                value = item.expr(names, self.unavailable(names))
                self.check_numeric(item, value)
                value = value.xreplace(self.values).xreplace(self.gain_values)
                gains[key] = value
                symbol = sp.Symbol(key, real=True)
                names[key] = symbol
                self.gain_values[symbol] = value
        t = sp.Symbol("t", real=True)
        names.update(self.q)
        names.update(self.speed_names())
        names["t"] = t
        laws_cursor = fields["laws"]
        laws = {}
        actuator_names = [a.name for a in actuators]
        state = self.initial_state(coordinates)
        for key, item in laws_cursor.mapping().items():
            if key not in actuator_names:
                close = difflib.get_close_matches(key, actuator_names, n=1)
                hint = f"did you mean {close[0]!r}? " if close else ""
                raise item.error(f"law for unknown actuator; {hint}actuators: "
                                 f"{', '.join(actuator_names) or 'none'}")
            laws[key] = item.expr(names, self.unavailable(names))
            self.defined_at(item, laws[key], state, "the law")
        missing = [a for a in actuator_names if a not in laws]
        if missing:
            raise laws_cursor.error(f"no law for actuator(s) {', '.join(missing)}; "
                                    "every actuator needs one")
        return Controller(frozen_map(gains), frozen_map(laws))
