"""Joint limits against a run: where a position, rate or effort goes beyond the
robot file's ``limits`` (``model.info.JointLimitInfo``, ``ActuatorInfo.effort_limit``).

    position:  lower <= theta(q) <= upper          theta: the joint's displacement
    rate:      |dtheta/dt| = |sum_i (dtheta/dq_i) dq_i| <= velocity
    effort:    |tau_a| <= effort                   for each actuator a on the joint

Checked on the output rows (a bound crossed and recrossed between two rows
goes unseen); a value counts as beyond its bound when it passes it by more
than 1e-9 of the bound's size (at least 1e-9), so that a motion that ends
exactly on a limit is not reported for its rounding.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..model.info import RobotInfo

SLACK = 1e-9
UNITS = {"rad": ("rad", "rad/s"), "m": ("m", "m/s")}


@dataclass(frozen=True)
class Exceeded:
    """One bound passed during a run."""
    name: str            # the coordinate (or joint) or the actuator
    quantity: str        # "position", "rate" or "effort"
    bound: str           # "lower", "upper" or "magnitude"
    limit: float
    unit: str
    first_time: float    # the first output row beyond the bound, s
    worst: float         # the value furthest beyond it
    worst_time: float
    rows: int            # output rows beyond it

    def line(self) -> str:
        """``NAME: QUANTITY above its upper limit L UNIT from t = T s (up to V UNIT at t = T2 s, R rows)``."""
        where = {"lower": "below its lower limit", "upper": "above its upper limit",
                 "magnitude": "beyond its limit +-"}[self.bound]
        toward = "down to" if self.bound == "lower" else "up to"
        return (f"{self.name}: {self.quantity} {where}{'' if self.bound == 'magnitude' else ' '}"
                f"{self.limit:g} {self.unit} from t = {self.first_time:g} s ({toward} "
                f"{self.worst:.6g} {self.unit} at t = {self.worst_time:g} s, {self.rows} "
                f"row{'s' if self.rows > 1 else ''})")


def check(robot: RobotInfo, t: np.ndarray, q: np.ndarray, dq: np.ndarray,
          efforts: np.ndarray) -> list[Exceeded]:
    """Every bound of ``robot`` that the rows (t (N,), q and dq (N, n), efforts (N, m)) pass."""
    t = np.asarray(t, dtype=float)
    values = {c.name: q[:, i] for i, c in enumerate(robot.coordinates)}
    values.update({"d" + c.name: dq[:, i] for i, c in enumerate(robot.coordinates)})
    found: list[Exceeded] = []
    for joint in robot.joint_limits:
        position_unit, rate_unit = UNITS.get(joint.unit, (joint.unit, joint.unit + "/s"))
        if joint.lower is not None or joint.upper is not None:
            theta = _evaluate(joint.displacement, values, len(t))
            if joint.lower is not None:
                found += _beyond(joint.label, "position", "lower", joint.lower, position_unit,
                                 t, joint.lower - theta)
            if joint.upper is not None:
                found += _beyond(joint.label, "position", "upper", joint.upper, position_unit,
                                 t, theta - joint.upper)
        if joint.velocity is not None:
            rate = _evaluate(joint.rate, values, len(t))
            found += _beyond(joint.label, "rate", "magnitude", joint.velocity, rate_unit, t,
                             np.abs(rate) - joint.velocity, rate)
    for k, actuator in enumerate(robot.actuators):
        if actuator.effort_limit is not None:
            tau = efforts[:, k]
            found += _beyond(actuator.name, "effort", "magnitude", actuator.effort_limit,
                             actuator.unit.replace("*", "·"), t,
                             np.abs(tau) - actuator.effort_limit, tau)
    return found


#: the operations of an expression tree (``model.info.expression_tree``)
OPERATIONS = {
    "+": lambda *a: sum(a), "*": lambda *a: np.prod(np.broadcast_arrays(*a), axis=0),
    "**": np.power, "sin": np.sin, "cos": np.cos, "tan": np.tan, "asin": np.arcsin,
    "acos": np.arccos, "atan": np.arctan, "atan2": np.arctan2, "sinh": np.sinh,
    "cosh": np.cosh, "tanh": np.tanh, "exp": np.exp, "log": np.log, "Abs": np.abs,
    "sign": np.sign, "Min": lambda *a: np.minimum.reduce(np.broadcast_arrays(*a)),
    "Max": lambda *a: np.maximum.reduce(np.broadcast_arrays(*a)),
}


def _evaluate(tree, values: dict[str, np.ndarray], rows: int) -> np.ndarray:
    """A joint's displacement or rate over the rows, from its expression tree."""
    def value(node):
        if isinstance(node, (int, float)):
            return float(node)
        if isinstance(node, str):
            return values[node]
        operation, *arguments = node
        return OPERATIONS[operation](*(value(a) for a in arguments))

    with np.errstate(all="ignore"):
        return np.broadcast_to(np.asarray(value(tree), dtype=float), (rows,))


def _beyond(name: str, quantity: str, bound: str, limit: float, unit: str, t: np.ndarray,
            excess: np.ndarray, value: np.ndarray | None = None) -> list[Exceeded]:
    """The bound as passed where ``excess`` (how far beyond it) is over the slack; [] if never."""
    over = excess > SLACK * max(1.0, abs(limit))
    if not over.any():
        return []
    worst = int(np.argmax(np.where(over, excess, -np.inf)))
    shown = value if value is not None else (limit + excess if bound == "upper" else limit - excess)
    return [Exceeded(name, quantity, bound, float(limit), unit, float(t[int(np.argmax(over))]),
                     float(shown[worst]), float(t[worst]), int(over.sum()))]


def bounds(robot: RobotInfo) -> int:
    """How many bounds the robot file gives (lower and upper count one each)."""
    joints = sum((j.lower is not None) + (j.upper is not None) + (j.velocity is not None)
                 for j in robot.joint_limits)
    return joints + sum(a.effort_limit is not None for a in robot.actuators)


def summary(robot: RobotInfo, exceeded: list[Exceeded]) -> dict:
    """The ``limits`` field of simulate.json and inverse.json."""
    return {"bounds": bounds(robot), "count": len(exceeded),
            "exceeded": [asdict(e) for e in exceeded]}


def lines(exceeded: list[Exceeded]) -> list[str]:
    """One warning line per bound passed."""
    return [f"limit exceeded: {e.line()}" for e in exceeded]
