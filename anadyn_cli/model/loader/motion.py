"""The ``trajectory`` and ``simulation`` sections (spline and waypoint
trajectories are read by ``model.spline`` and ``model.waypoints``)."""
from __future__ import annotations

import difflib
import math

import sympy as sp

from ...errors import shorten
from .. import expressions
from ..info import METHODS
from ..robot import Simulation, Trajectory, frozen_map
from .cursor import Cursor

TRAJECTORY_KINDS = ("cycloidal", "quintic", "expression", "waypoints", "spline")
MAX_ROWS = 1_000_000      # simulation.t_end / simulation.output_step


class _Motion:
    """The builder's trajectory and simulation (part of ``builder._RobotBuilder``)."""

    def trajectory(self, cursor: Cursor) -> Trajectory:
        fields = cursor.mapping(("kind", "duration", "from", "to", "expressions", "points",
                                 "durations", "shape", "times", "q", "dq", "ddq"),
                                required=("kind",))
        kind = fields["kind"].choice(TRAJECTORY_KINDS)
        if kind == "spline":                     # samples of q, dq, ddq (model.spline)
            from .. import spline
            return spline.read(self, cursor, fields)
        for key in ("times", "q", "dq", "ddq"):
            if key in fields:
                raise fields[key].error(f"'{key}' belongs to kind 'spline'")
        if kind == "waypoints":                  # poses and durations (model.waypoints)
            from .. import waypoints
            return waypoints.read(self, cursor, fields)
        for key in ("points", "durations", "shape"):
            if key in fields:
                raise fields[key].error(f"'{key}' belongs to kind 'waypoints'")
        if "duration" not in fields:
            raise cursor.error("missing required key 'duration'")
        duration = self.constant(fields["duration"])
        T = self.positive(fields["duration"], duration, "a duration in s")
        duration = duration.xreplace(self.values)
        ends = {}
        for key in ("from", "to"):
            ends[key] = {}
            if key in fields:
                if kind == "expression":
                    raise fields[key].error("'from' and 'to' belong to cycloidal and quintic "
                                            "trajectories; 'expression' takes 'expressions'")
                for name, item in fields[key].mapping().items():
                    self.known_coordinate(item, name)
                    value = self.constant(item)
                    self.check_numeric(item, value)
                    ends[key][name] = value.xreplace(self.values)
        expressions_ = {}
        if kind == "expression":
            if "expressions" not in fields:
                raise cursor.error("missing required key 'expressions' for kind 'expression'")
            t = sp.Symbol("t", real=True)
            names = {**self.symbols, "t": t}
            for name, item in fields["expressions"].mapping().items():
                self.known_coordinate(item, name)
                expression = item.expr(names, self.unavailable(names))
                for moment in (sp.Integer(0), sp.Float(T)):
                    try:   # in double precision first: exact evaluation of a huge number hangs
                        expressions.approximate(expression, {**self.values, t: moment})
                        value = complex(expression.xreplace(self.values).xreplace({t: moment})
                                        .evalf())
                    except (TypeError, ValueError, ArithmeticError, RecursionError):
                        value = complex("nan")
                    if value.imag != 0 or not math.isfinite(value.real):
                        raise item.error(f"not a finite real number at t = {float(moment):g} "
                                         f"s; q(t) must be defined for 0 <= t <= {T:g}")
                expressions_[name] = expression.xreplace(self.values)
        elif "expressions" in fields:
            raise fields["expressions"].error("'expressions' belongs to kind 'expression'")
        elif "to" not in fields:
            raise cursor.error(f"missing required key 'to' for a {kind} trajectory")
        return Trajectory(kind, duration, frozen_map(ends["from"]), frozen_map(ends["to"]),
                          frozen_map(expressions_))

    def known_coordinate(self, cursor: Cursor, name: str) -> None:
        if name not in self.q:
            close = difflib.get_close_matches(name, list(self.q), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise cursor.error(f"unknown coordinate {shorten(name)!r}{hint}; coordinates: "
                               f"{', '.join(self.q)}")

    def simulation(self, cursor: Cursor) -> Simulation:
        fields = cursor.mapping(("t_end", "output_step", "method", "rtol", "atol"))
        values: dict[str, object] = {}
        for key in ("t_end", "output_step", "rtol", "atol"):
            if key in fields:
                expr = self.constant(fields[key])
                value = self.check_numeric(fields[key], expr)
                if value <= 0:
                    raise fields[key].error(f"must be positive, got {value:g}")
                values[key] = value
        if "t_end" in values and "output_step" in values:
            if values["output_step"] > values["t_end"]:
                raise fields["output_step"].error(
                    f"output step {values['output_step']:g} s is longer than t_end "
                    f"{values['t_end']:g} s; it must be at most t_end")
            rows = values["t_end"] / values["output_step"]
            if rows > MAX_ROWS:
                raise fields["output_step"].error(
                    f"t_end / output_step = {rows:.3g} rows; at most {MAX_ROWS:,} "
                    "(raise output_step or shorten t_end)")
        if "method" in fields:
            values["method"] = fields["method"].choice(METHODS)
        return Simulation(**values)
