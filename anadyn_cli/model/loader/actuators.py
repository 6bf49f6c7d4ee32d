"""The ``actuators`` and ``controller`` sections: which joint each actuator
drives, its drive (gear, rotor, motor-side friction, torque constant, effort
saturation), the controller's gains and one law per actuator."""
from __future__ import annotations

import difflib

import sympy as sp

from ...errors import shorten
from ..joints import Revolute
from ..robot import Actuator, Body, Controller, Coordinate, Joint, frozen_map
from ..yamlschema import describe_value as _kind
from .bodies import MOVING_WORDS
from .cursor import Cursor

#: the keys of an actuator's ``drive``
DRIVE_KEYS = ("gear", "rotor_inertia", "motor_damping", "motor_friction", "friction_velocity",
              "torque_constant", "effort_limit")


class _Actuators:
    """The builder's actuators and controller (part of
    ``builder._RobotBuilder``)."""

    def actuators(self, cursor: Cursor, bodies: tuple[Body, ...]
                  ) -> tuple[tuple[Actuator, ...], tuple[Body, ...]]:
        """The actuators, and the bodies followed by the rotors of their drives."""
        by_name = {b.name: b for b in bodies}
        result, rotors = [], []
        self.effort_limits: dict[str, sp.Expr] = {}
        for key, item in cursor.mapping().items():
            self.key_name(item, key, "actuator name")
            self.claim(item, key, "an actuator")
            fields = item.mapping(("joint", "drive"), required=("joint",))
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
            if "drive" not in fields:
                result.append(Actuator(key, body_name, joint.joint_type.effort_unit,
                                       effort_limit=joint.limits.effort))
                continue
            actuator, rotor = self.drive(fields["drive"], key, by_name[body_name])
            result.append(actuator)
            rotors += [rotor] if rotor is not None else []
        return tuple(result), bodies + tuple(rotors)

    def drive(self, cursor: Cursor, name: str, body: Body) -> tuple[Actuator, Body | None]:
        """An actuator's drive: a motor behind a gear of ratio N (gear: motor rate = N times
        the joint rate, default 1) with torque constant k_t (N*m/A: the effort is then a
        current in A); the generalized force is N*k_t times the effort.  With a
        rotor_inertia J_r, motor_damping or motor_friction the motor is rotary: a rotor
        body on the joint's parent at the joint's frame, turning about the joint's axis by
        N times its displacement, massless but for J_r about the axis, the motor-side
        damping and friction acting along its joint; the effort (without k_t) is then a
        torque in N*m, else the joint's own unit (N*m, or N on a prismatic joint).
        effort_limit bounds the effort (its unit): the controller's law is clipped to it
        (``controller``)."""
        fields = cursor.mapping(DRIVE_KEYS)
        values = {key: self.constant(item) for key, item in fields.items()}
        numbers = {key: self.check_numeric(fields[key], e) for key, e in values.items()}
        gear = values.get("gear", sp.Integer(1))
        if numbers.get("gear", 1) == 0:
            raise fields["gear"].error("must not be 0 (motor rate = gear * joint rate)")
        for key, unit in (("rotor_inertia", "kg*m^2"), ("motor_damping", "N*m*s/rad"),
                          ("motor_friction", "N*m")):
            if numbers.get(key, 0) < 0:
                raise fields[key].error(f"must be 0 or positive ({unit}), got {numbers[key]:g}")
        for key, unit in (("torque_constant", "N*m/A"), ("effort_limit", "in the effort's unit"),
                          ("friction_velocity", "rad/s of the motor")):
            if key in numbers and numbers[key] <= 0:
                raise fields[key].error(f"must be positive ({unit}), got {numbers[key]:g}")
        if "effort_limit" in values:
            self.effort_limits[name] = values["effort_limit"]
        rotary = bool({"rotor_inertia", "motor_damping", "motor_friction"} & set(values))
        unit = ("A" if "torque_constant" in values else
                Revolute.effort_unit if rotary else body.joint.joint_type.effort_unit)
        scale = gear * values.get("torque_constant", sp.Integer(1))   # of the parameters
        joint_limit = body.joint.limits.effort
        limit = values.get("effort_limit", None if joint_limit is None else
                           joint_limit / abs(scale))
        actuator = Actuator(name, body.name, unit, scale,
                            None if limit is None else limit.xreplace(self.values))
        if not rotary:
            return actuator, None
        rotor = f"{name}_rotor"
        self.claim(cursor, rotor, f"the rotor of actuator {name!r}")
        joint = body.joint
        forces = {"damping": values.get("motor_damping", sp.Integer(0)),
                  "friction": values.get("motor_friction", sp.Integer(0))}
        if "friction_velocity" in values:
            forces["friction_velocity"] = values["friction_velocity"]
        axis = sp.Matrix(joint.axis)
        inertia = values.get("rotor_inertia", sp.Integer(0)) * axis * axis.T
        return actuator, Body(rotor, body.parent,
                              Joint(Revolute.word, joint.axis, joint.origin, joint.rpy,
                                    gear * joint.displacement, **forces),
                              sp.Integer(0), (sp.Integer(0),) * 3, sp.ImmutableMatrix(inertia))

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
            if key in self.effort_limits:        # the drive's saturation
                limit = self.effort_limits[key]
                laws[key] = sp.Min(sp.Max(laws[key], -limit), limit)
        missing = [a for a in actuator_names if a not in laws]
        if missing:
            raise laws_cursor.error(f"no law for actuator(s) {', '.join(missing)}; "
                                    "every actuator needs one")
        return Controller(frozen_map(gains), frozen_map(laws))
