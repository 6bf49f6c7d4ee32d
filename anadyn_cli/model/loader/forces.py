"""What acts along a joint and on a body: a joint's forces (damping, friction,
stiffness) and limits, and the ``loads`` section."""
from __future__ import annotations

import difflib
import math

import sympy as sp

from ...errors import shorten
from ..joints import JointType
from ..robot import Body, Coordinate, JointLimits, Load
from ..yamlschema import describe_value as _kind
from .cursor import Cursor

#: joint keys for the forces along the joint (robot.Joint), reaction on the parent
JOINT_FORCE_KEYS = ("damping", "friction", "friction_velocity", "stiffness", "rest")
LOAD_FRAMES = ("world", "body")


class _Forces:
    """The builder's joint forces, joint limits and loads (part of
    ``builder._RobotBuilder``)."""

    def joint_forces(self, fields: dict[str, Cursor], kind: JointType) -> dict[str, sp.Expr]:
        """damping, friction, friction_velocity, stiffness, rest: constants (expressions of
        the parameters); damping, friction and stiffness >= 0, friction_velocity > 0.  Their
        units follow from the joint type's: damping N*m*s/rad or N*s/m, friction N*m or N,
        friction_velocity rad/s or m/s, stiffness N*m/rad or N/m."""
        units = {"damping": f"{kind.effort_unit}*s/{kind.unit}",
                 "friction": kind.effort_unit,
                 "friction_velocity": f"{kind.unit}/s",
                 "stiffness": f"{kind.effort_unit}/{kind.unit}"}
        result: dict[str, sp.Expr] = {}
        for key in JOINT_FORCE_KEYS:
            if key not in fields:
                continue
            expr = self.constant(fields[key])
            value = self.check_numeric(fields[key], expr)
            if key == "friction_velocity" and value <= 0:
                raise fields[key].error(f"must be positive (the joint rate, in "
                                        f"{units[key]}, over which friction is smoothed), got "
                                        f"{value:g}")
            if key in ("damping", "friction", "stiffness") and value < 0:
                raise fields[key].error(f"must be 0 or positive ({units[key]}), got {value:g}")
            result[key] = expr
        return result

    def limits(self, cursor: Cursor) -> JointLimits:
        """Bounds a run is checked against: lower <= displacement <= upper (rad or m),
        |rate| <= velocity, |effort| <= effort; lower <= upper, velocity and effort > 0."""
        fields = cursor.mapping(("lower", "upper", "velocity", "effort"))
        exprs: dict[str, sp.Expr] = {}
        values: dict[str, float] = {}
        for key, item in fields.items():
            exprs[key] = self.constant(item)
            values[key] = self.check_numeric(item, exprs[key])
            if key in ("velocity", "effort") and values[key] <= 0:
                raise item.error(f"must be positive, got {values[key]:g}")
        if values.get("lower", -math.inf) > values.get("upper", math.inf):
            raise fields["upper"].error(f"upper limit {values['upper']:g} is below the lower "
                                        f"limit {values['lower']:g}")
        return JointLimits(**{k: e.xreplace(self.values) for k, e in exprs.items()})

    def loads(self, cursor: Cursor, bodies: tuple[Body, ...],
              coordinates: tuple[Coordinate, ...]) -> tuple[Load, ...]:
        """External forces and torques: ``body``, ``point`` (body axes, constants),
        ``force`` and/or ``torque`` (expressions of t, the coordinates and their rates),
        ``frame`` (world or body: the axes of the two vectors)."""
        by_name = {b.name: b for b in bodies}
        names = {**self.symbols, **self.q, "t": sp.Symbol("t", real=True)}
        names.update(self.speed_names())
        state = self.initial_state(coordinates)
        result = []
        for item in cursor.sequence():
            fields = item.mapping(("body", "point", "force", "torque", "frame"),
                                  required=("body",))
            body = fields["body"].value
            if not isinstance(body, str):
                raise fields["body"].error(f"expected a body name, got {_kind(body)}")
            if body not in by_name:
                close = difflib.get_close_matches(body, list(by_name), n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise fields["body"].error(f"unknown body {shorten(body)!r}{hint}; loads act on "
                                           f"one of: {', '.join(by_name)}")
            if "force" not in fields and "torque" not in fields:
                raise item.error("a load needs a force, a torque or both, e.g. "
                                 "force: [0, 0, -50] (N) or torque: [0, 0, 2] (N*m)")
            if "point" in fields and "force" not in fields:
                raise fields["point"].error("only a force has a point of application (a "
                                            "torque acts on the whole body); remove the point "
                                            "or add a force")
            point = self.constant_vector(fields.get("point"))
            frame = fields["frame"].choice(LOAD_FRAMES) if "frame" in fields else "world"
            vectors = {}
            for key in ("force", "torque"):
                vectors[key] = (sp.Integer(0),) * 3
                if key in fields:
                    vectors[key] = fields[key].vector(names, self.unavailable(names))
                    for i, component in enumerate(vectors[key]):
                        self.defined_at(fields[key], component, state,
                                        f"the {'xyz'[i]} component")
            result.append(Load(body, point, vectors["force"], vectors["torque"], frame))
        return tuple(result)
