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
class ActuatorInfo:
    name: str
    unit: str            # "N*m" or "N"


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

    @classmethod
    def from_robot(cls, robot) -> "RobotInfo":
        return cls(
            name=robot.name, source=robot.source, digest=robot.digest,
            coordinates=tuple(CoordinateInfo(c.name, c.unit, float(c.initial), float(c.rate))
                              for c in robot.coordinates),
            actuators=tuple(ActuatorInfo(a.name, a.unit) for a in robot.actuators),
            simulation=robot.simulation, has_controller=robot.controller is not None,
            name_given=robot.name_given)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict, source: str) -> "RobotInfo":
        """The stored info for the same text read from ``source`` (which names
        the robot when the file does not)."""
        name = data["name"] if data["name_given"] else default_name(source)
        return cls(name=name, source=source, digest=data["digest"],
                   coordinates=tuple(CoordinateInfo(**c) for c in data["coordinates"]),
                   actuators=tuple(ActuatorInfo(**a) for a in data["actuators"]),
                   simulation=Simulation(**data["simulation"]),
                   has_controller=data["has_controller"], name_given=data["name_given"])
