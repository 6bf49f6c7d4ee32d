"""``_RobotBuilder``: validates a robot file section by section (one mixin per
section group), growing the table of known names, and makes the ``Robot``."""
from __future__ import annotations

from collections.abc import Mapping

import sympy as sp

from ..robot import Robot, Simulation, frozen_map
from .actuators import _Actuators
from .bodies import _Bodies
from .checks import _Checks
from .compound import _Compound
from .contacts import _Contacts
from .cursor import Cursor
from .forces import _Forces
from .motion import _Motion
from .numbers import _Numbers
from .spherical import _Spherical

TOP_KEYS = ("name", "description", "parameters", "gravity", "coordinates", "speeds",
            "bodies", "actuators", "controller", "loads", "trajectory", "simulation", "loops",
            "constraints", "contacts")


class _RobotBuilder(_Numbers, _Bodies, _Compound, _Spherical, _Forces, _Checks, _Actuators,
                    _Motion, _Contacts):
    """Validates one file section by section, growing the table of known names."""

    def __init__(self, root: Cursor, digest: str, default_name: str,
                 overrides: Mapping[str, object] | None = None):
        self.root, self.digest, self.default_name = root, digest, default_name
        self.overrides = dict(overrides or {})     # parameter values given by the caller
        self.symbols: dict[str, sp.Expr] = {}      # parameters
        self.owner: dict[str, str] = {}            # every name in the file -> what it is
        self.definitions: dict[str, sp.Expr] = {}
        self.values: dict[sp.Symbol, sp.Expr] = {}
        self.gain_values: dict[sp.Symbol, sp.Expr] = {}
        self.q: dict[str, sp.Symbol] = {}
        self.added_coordinates: list = []          # a floating joint's x, y, z not declared
        # what each name in the file is, to say why it cannot be used somewhere
        self.kinds: dict[str, str] = {"t": "time"}

    @staticmethod
    def key_name(item: Cursor, key: str, what: str) -> str:
        """A mapping key that names something must be an identifier."""
        return Cursor(key, item.path, item.source, item.lines).identifier(what)

    def claim(self, cursor: Cursor, name: str, what: str) -> None:
        if name in self.owner:
            raise cursor.error(f"name {name!r} is already used by {self.owner[name]}; "
                               "every name in a robot file must be different")
        self.owner[name] = what
        self.kinds[name] = what

    def unavailable(self, allowed: Mapping[str, object]) -> Mapping[str, str]:
        """What each name of the file that ``allowed`` does not hold is ("time", "a
        body", ...), for the expression reader's messages: a view, looked up only
        when a name is not found (a robot has hundreds of names and expressions)."""
        return _Unavailable(self.kinds, allowed)

    def build(self) -> Robot:
        top = self.root.mapping(TOP_KEYS, required=("coordinates", "bodies"))
        name = top["name"].identifier("robot name") if "name" in top else self.default_name
        description = top["description"].text() if "description" in top else ""
        self.prescan(top)
        if "parameters" in top:
            self.parameters(top["parameters"])
        unknown = sorted(set(self.overrides) - set(self.definitions))
        if unknown:
            raise self.root.error(f"parameters: the file defines no {', '.join(unknown)} (it "
                                  f"defines: {', '.join(self.definitions) or 'none'})")
        gravity = self.constant_vector(top.get("gravity"))
        coordinate_cursors = self.coordinate_names(top["coordinates"])
        self.speed_section(top.get("speeds"))
        bodies, units, body_cursors = self.bodies(top["bodies"])
        coordinates = self.coordinates(coordinate_cursors, units) + tuple(self.added_coordinates)
        coordinates = self.spherical_state(top, bodies, coordinates, coordinate_cursors,
                                           body_cursors)
        self.check_displacements(bodies, body_cursors, coordinates)
        actuators, bodies = (self.actuators(top["actuators"], bodies) if "actuators" in top
                             else ((), bodies))           # bodies + the drives' rotors
        if "controller" in top:
            controller = self.controller(top["controller"], actuators, coordinates)
        else:
            controller = None
        loads = self.loads(top["loads"], bodies, coordinates) if "loads" in top else ()
        contacts = self.contacts(top["contacts"], bodies) if "contacts" in top else None
        trajectory = self.trajectory(top["trajectory"]) if "trajectory" in top else None
        simulation = self.simulation(top["simulation"]) if "simulation" in top else Simulation()
        constraints = None
        from .. import constraints as closing       # closed chains (issue 10)
        if closing.wanted(top, coordinate_cursors):
            constraints, coordinates = closing.build(self, top, coordinate_cursors, bodies,
                                                     coordinates)
        robot = Robot(name=name, source=self.root.source, digest=self.digest,
                      parameters=frozen_map(self.definitions), gravity=gravity,
                      coordinates=coordinates, bodies=bodies, actuators=actuators,
                      controller=controller, loads=loads, trajectory=trajectory,
                      simulation=simulation, description=description,
                      name_given="name" in top, constraints=constraints,
                      contacts=contacts)
        self.check_mass_matrix(robot, top["coordinates"], coordinate_cursors)
        return robot

    def prescan(self, top: dict[str, Cursor]) -> None:
        """Names defined further down, so that using one too early gets a clear message."""
        def keys(cursor: Cursor | None) -> list[str]:
            value = cursor.value if cursor is not None else None
            return [k for k in value if isinstance(k, str)] if isinstance(value, dict) else []

        for key in keys(top.get("parameters")):
            self.kinds[key] = "a parameter defined further down"
        for key in keys(top.get("actuators")):
            self.kinds.setdefault(key, "an actuator")
        controller = top.get("controller")
        if controller is not None and isinstance(controller.value, dict):
            for key in keys(Cursor(controller.value.get("gains"), "", "", {})):
                self.kinds.setdefault(key, "a controller gain")
        bodies = top["bodies"].value
        if isinstance(bodies, list):
            for item in bodies:
                if isinstance(item, dict) and isinstance(item.get("name"), str):
                    self.kinds.setdefault(item["name"], "a body")


class _Unavailable(Mapping):
    """The items of ``kinds`` whose names ``allowed`` does not hold (a view)."""

    def __init__(self, kinds: Mapping[str, str], allowed: Mapping[str, object]):
        self._kinds, self._allowed = kinds, allowed

    def __getitem__(self, name: str) -> str:
        if name in self._allowed:
            raise KeyError(name)
        return self._kinds[name]

    def __iter__(self):
        return (name for name in self._kinds if name not in self._allowed)

    def __len__(self) -> int:
        return sum(1 for _ in self)
