"""What the numeric services need to know about a robot, in plain Python types.

A ``RobotInfo`` is taken from a validated ``Robot`` and stored beside the
generated code in the derivation cache, so a cached robot is simulated
without SymPy.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

from .names import default_name

#: the integrators by name (numeric.integrators runs them; the loader checks a file's choice)
METHODS = ("auto", "odeint", "RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")


@dataclass(frozen=True)
class Simulation:
    t_end: float | None = None
    output_step: float | None = None
    method: str | None = None
    rtol: float | None = None
    atol: float | None = None


@dataclass(frozen=True)
class CoordinateInfo:
    name: str
    unit: str            # "rad" or "m"
    initial: float
    rate: float


@dataclass(frozen=True)
class SpeedInfo:
    name: str
    unit: str            # "rad/s" or "m/s"
    initial: float


@dataclass(frozen=True)
class ActuatorInfo:
    name: str
    unit: str            # "N*m" or "N"
    effort_limit: float | None = None     # |effort| bound of its joint's limits


@dataclass(frozen=True)
class JointLimitInfo:
    """A joint's position and rate bounds (``numeric.limits`` checks runs against them).

    ``displacement`` and ``rate`` are theta(q) and dtheta/dt = sum_i dtheta/dq_i dq_i as
    expression trees in plain JSON types (``expression_tree``), so that a cached robot
    is checked without SymPy and without evaluating any text."""
    label: str           # the coordinate, or "BODY (theta)" for a coupled joint
    unit: str            # "rad" or "m"
    displacement: object
    rate: object
    lower: float | None = None
    upper: float | None = None
    velocity: float | None = None


@dataclass(frozen=True)
class RobotInfo:
    name: str
    source: str
    digest: str
    coordinates: tuple[CoordinateInfo, ...]
    actuators: tuple[ActuatorInfo, ...]
    simulation: Simulation
    has_controller: bool
    name_given: bool = True       # False: the name comes from the file name
    joint_limits: tuple[JointLimitInfo, ...] = ()
    #: the generalized speeds when some are not coordinate rates (a spherical joint's),
    #: else () (the speeds are the coordinates' rates)
    speeds: tuple[SpeedInfo, ...] = ()

    @classmethod
    def from_robot(cls, robot) -> "RobotInfo":
        return cls(
            name=robot.name, source=robot.source, digest=robot.digest,
            coordinates=tuple(CoordinateInfo(c.name, c.unit, float(c.initial), float(c.rate))
                              for c in robot.coordinates),
            actuators=tuple(ActuatorInfo(a.name, a.unit, _float(a.effort_limit))
                            for a in robot.actuators),
            simulation=robot.simulation, has_controller=robot.controller is not None,
            name_given=robot.name_given, joint_limits=joint_limit_infos(robot),
            speeds=tuple(SpeedInfo(u.name, u.unit, float(u.initial)) for u in robot.speeds)
            if robot.spherical else ())

    def to_dict(self) -> dict:
        data = asdict(self)
        if not self.speeds:              # the rates: stored as before speeds existed
            del data["speeds"]
        return data

    @classmethod
    def from_dict(cls, data: dict, source: str) -> "RobotInfo":
        """The stored info for the same text read from ``source`` (which names
        the robot when the file does not)."""
        name = data["name"] if data["name_given"] else default_name(source)
        return cls(name=name, source=source, digest=data["digest"],
                   coordinates=tuple(CoordinateInfo(**c) for c in data["coordinates"]),
                   actuators=tuple(ActuatorInfo(**a) for a in data["actuators"]),
                   simulation=Simulation(**data["simulation"]),
                   has_controller=data["has_controller"], name_given=data["name_given"],
                   joint_limits=tuple(JointLimitInfo(**j) for j in data.get("joint_limits", ())),
                   speeds=tuple(SpeedInfo(**u) for u in data.get("speeds", ())))


def _float(value) -> float | None:
    return None if value is None else float(value)


#: SymPy function -> its name in an expression tree (the robot file's functions)
TREE_FUNCTIONS = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
                  "exp", "log", "Abs", "sign", "Min", "Max")


def expression_tree(expr):
    """A SymPy expression as nested lists: a number, a symbol's name, or
    [op, *arguments] with op "+", "*", "**" or a function of TREE_FUNCTIONS."""
    if expr.is_Symbol:
        return expr.name
    if expr.is_Number or expr.is_NumberSymbol:
        return float(expr)
    if expr.is_Add or expr.is_Mul:
        return ["+" if expr.is_Add else "*", *(expression_tree(a) for a in expr.args)]
    if expr.is_Pow:
        return ["**", expression_tree(expr.base), expression_tree(expr.exp)]
    name = type(expr).__name__
    if name not in TREE_FUNCTIONS:
        raise ValueError(f"no expression tree for {name}")
    return [name, *(expression_tree(a) for a in expr.args)]


def joint_limit_infos(robot) -> tuple[JointLimitInfo, ...]:
    """The position and rate bounds of ``robot``'s joints, with parameters substituted."""
    import sympy as sp

    values = robot.parameter_substitution()
    result = []
    for body in robot.bodies:
        limits = body.joint.limits
        if not body.joint.joint_type.moving or all(getattr(limits, k) is None
                                                   for k in ("lower", "upper", "velocity")):
            continue
        theta = body.joint.displacement.xreplace(values)
        rate = sp.Add(*[sp.diff(theta, c.symbol) * c.rate_symbol for c in robot.coordinates
                        if c.symbol in theta.free_symbols])
        coordinate = next((c for c in robot.coordinates if theta == c.symbol), None)
        label = coordinate.name if coordinate else f"{body.name} ({theta.evalf(6)})"
        unit = body.joint.joint_type.unit
        result.append(JointLimitInfo(label, unit, expression_tree(theta), expression_tree(rate),
                                     *(_float(getattr(limits, k)) for k in
                                       ("lower", "upper", "velocity"))))
    return tuple(result)
