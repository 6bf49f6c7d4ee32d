"""Equations compiled once with chosen parameters and gains left free, bound per run.

A sweep derives and compiles a robot once and then runs it for many values
of a few names.  ``fold`` makes a copy of the robot in which those names
stay symbols and everything else is folded to numbers, as a plain run folds
it; ``source`` generates the numeric module from that copy with any code
generator that takes a Robot (``closed_form`` by default), so the free names
appear in the generated code as module-level variables:

    _free_m2 = nan                      # one per varied name
    PARAMETERS = ('m2',)
    def bind(values): ...               # sets them, in PARAMETERS order
    def start(): ...                    # x0 = [q(0), dq(0)] at the bound values
    def inertial(): ...                 # masses and inertia tensors that depend on them
    def motion(t): ...                  # the prescribed motion (robots with a trajectory:
                                        # numeric.trajectory.derivatives, parameters free)
    def duration(): ...                 # its duration; TRAJECTORY = (kind, nan)

``BoundModel`` is a ``NumericModel`` over such a module with ``bind``.  The
generated functions keep their signatures, so every integrator and service
runs a bound model as it runs any other.  Binding sets module globals: one
``BoundModel`` must not be bound from two threads at once (executors give
each thread its own).

What follows a varied name (everything the file computes from it) is
computed from it in the generated code, never folded:

* parameters defined by expressions of others (``parameter_substitution``
  of the folded copy keeps them as expressions of the free symbols), and
  with them masses, inertias, lengths, gravity, joint forces and the laws;
* controller gains defined from parameters or from other gains;
* the coordinates' initial values and rates, and the trajectory.

The loader folds the last two kinds (and gains) to numbers, so ``fold``
parses their text again from the file with the same safe expression parser.
The run's settings (``simulation``) may not depend on a varied name.
"""
from __future__ import annotations

import difflib
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType
from typing import Callable, Mapping

import sympy as sp

from ..errors import ModelError
from ..model import expressions, yamlschema
from ..model.robot import Controller, Coordinate, Robot, Trajectory
from . import trajectory
from .codegen import Function, module_source
from .bound import BoundModel  # noqa: F401  (re-exported: the model of a bindable module)
from ..model.expressions import as_expr

PREFIX = "_free_"                 # generated-code name of a free parameter or gain


def free_symbol(name: str) -> sp.Symbol:
    return sp.Symbol(PREFIX + name, real=True)


@dataclass(frozen=True)
class PartlyFolded(Robot):
    """A Robot whose ``parameter_substitution`` leaves the ``free`` names as
    symbols (``free_symbol``) and folds every other parameter to its number;
    parameters defined from free ones become expressions of them."""
    free: Mapping[str, sp.Symbol] = field(default_factory=dict)

    def parameter_substitution(self, symbolic: bool = False) -> dict[sp.Symbol, sp.Expr]:
        resolved: dict[sp.Symbol, sp.Expr] = {}
        for name, definition in self.parameters.items():
            resolved[sp.Symbol(name, real=True)] = (self.free[name] if name in self.free
                                                    else definition.xreplace(resolved))
        return resolved


@dataclass(frozen=True)
class Folding:
    """The varied names, what they are, and the copy of the robot that keeps them."""
    robot: PartlyFolded
    names: tuple[str, ...]
    kinds: Mapping[str, str]            # name -> "parameter" or "gain"
    nominal: Mapping[str, float]        # the file's value of each name
    follows: Mapping[str, tuple[str, ...]]   # what is computed from them, by section
    unchecked: tuple[str, ...] = ()     # bodies whose inertia skips the triangle inequality

    def describe(self) -> str:
        """``m2 (parameter), b01 (gain); following: gains kp; initial q3``."""
        kept = ", ".join(f"{n} ({self.kinds[n]})" for n in self.names)
        following = "; ".join(f"{section} {', '.join(items)}"
                              for section, items in self.follows.items() if items)
        return kept + (f"; computed from them: {following}" if following else "")


def names_in(robot: Robot) -> dict[str, str]:
    """Every name a sweep may vary: parameter or gain."""
    found = {name: "parameter" for name in robot.parameters}
    if robot.controller is not None:
        found.update({name: "gain" for name in robot.controller.gains})
    return found


def unknown_name(robot: Robot, name: str) -> ModelError:
    known = names_in(robot)
    close = [k for k in known if k.lower() == name.lower()] or \
        difflib.get_close_matches(name, list(known), n=1, cutoff=0.5)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    if not known:
        how = ("; write it out with `anadyn import` and give the values to vary names in "
               "its parameters" if robot.source.lower().endswith(".urdf") else
               "; name the values to vary in its parameters")
        return ModelError(f"--vary {name}: {robot.source} has no parameters or gains to "
                          f"vary{how}")
    parameters = ", ".join(robot.parameters) or "none"
    gains = ", ".join(robot.controller.gains) if robot.controller is not None else ""
    return ModelError(f"--vary {name}: no parameter or gain of that name in {robot.source}"
                      f"{hint}; parameters: {parameters}"
                      + (f"; gains: {gains}" if gains else ""))


def fold(robot: Robot, text: str, names: tuple[str, ...]) -> Folding:
    """The copy of ``robot`` (read from ``text``) with ``names`` kept free."""
    known = names_in(robot)
    for name in names:
        if name not in known:
            raise unknown_name(robot, name)
    if len(set(names)) != len(names):
        twice = next(n for n in names if names.count(n) > 1)
        raise ModelError(f"--vary {twice}: given twice; vary each name once")
    folder = _Folder(robot, text, names, known)
    changes: dict[str, object] = {}
    if robot.controller is not None:
        changes["controller"] = folder.controller()
    changes["coordinates"] = folder.coordinates()
    if robot.trajectory is not None:
        changes["trajectory"] = folder.trajectory()
    folder.check_fixed()
    nominal = {}
    for name in names:
        value = (robot.parameter_substitution()[folder.symbols[name]]
                 if known[name] == "parameter" else robot.controller.gains[name])
        nominal[name] = float(value)
    return Folding(replace(folder.copy, **changes), tuple(names),
                   MappingProxyType({n: known[n] for n in names}), MappingProxyType(nominal),
                   MappingProxyType({k: tuple(v) for k, v in folder.follows.items()}),
                   tuple(folder.unchecked))


class _Folder:
    """The sections of a robot file read again with some names kept free: what follows
    from them (``follows``: section -> entries) and the fields that change."""

    def __init__(self, robot: Robot, text: str, names: tuple[str, ...], known: dict):
        self.robot, self.names = robot, names
        self.free = {n: free_symbol(n) for n in names}
        self.free_set = set(self.free.values())
        params = {n: self.free[n] for n in names if known[n] == "parameter"}
        self.data, _ = yamlschema.load(text, robot.source)
        self.symbols = {name: sp.Symbol(name, real=True) for name in robot.parameters}
        self.copy = PartlyFolded(**{f.name: getattr(robot, f.name) for f in fields(Robot)},
                                 free=MappingProxyType(params))
        self.values = self.copy.parameter_substitution()
        self.follows: dict[str, list[str]] = {
            "parameters": [name for name in robot.parameters if name not in self.free
                           and self.values[self.symbols[name]].free_symbols & self.free_set],
            "gains": [], "initial": [], "trajectory": []}
        self.unchecked: list = []

    def depends(self, raw, names_table, extra: Mapping = MappingProxyType({})) -> sp.Expr | None:
        """The raw field as an expression of the free symbols, None if it has none."""
        if raw is None:
            return None
        expr = expressions.parse(raw, names_table).xreplace(self.values).xreplace(dict(extra))
        return expr if expr.free_symbols & self.free_set else None

    def controller(self) -> Controller:
        """Controller gains: varied, computed from varied names, or the loader's numbers."""
        raw_gains = (self.data.get("controller") or {}).get("gains") or {}
        gains: dict[str, sp.Expr] = {}
        table = dict(self.symbols)
        for name, value in self.robot.controller.gains.items():
            expr = None if name in self.free else self.depends(raw_gains.get(name), table, {
                sp.Symbol(k, real=True): v for k, v in gains.items()})
            if name in self.free:
                gains[name] = self.free[name]
            elif expr is not None:
                gains[name] = expr
                self.follows["gains"].append(name)
            else:
                gains[name] = value
            table[name] = sp.Symbol(name, real=True)
        return Controller(MappingProxyType(gains), self.robot.controller.laws)

    def coordinates(self) -> tuple[Coordinate, ...]:
        """Initial values and rates."""
        raw_coordinates = self.data.get("coordinates") or {}
        coordinates = []
        for c in self.robot.coordinates:
            raw = raw_coordinates.get(c.name) or {}
            initial = self.depends(raw.get("initial"), self.symbols)
            rate = self.depends(raw.get("rate"), self.symbols)
            if initial is not None or rate is not None:
                self.follows["initial"].append(c.name)
            coordinates.append(Coordinate(c.name, c.initial if initial is None else initial,
                                          c.rate if rate is None else rate, c.unit))
        return tuple(coordinates)

    def trajectory(self) -> Trajectory:
        raw = self.data.get("trajectory") or {}
        tr = self.robot.trajectory
        duration = self.depends(raw.get("duration"), self.symbols)
        ends = {}
        for key, folded in (("from", tr.start), ("to", tr.end)):
            ends[key] = {}
            for name, value in folded.items():
                expr = self.depends((raw.get(key) or {}).get(name), self.symbols)
                ends[key][name] = value if expr is None else expr
                if expr is not None:
                    self.follows["trajectory"].append(f"{key}.{name}")
        paths = {}
        for name, value in tr.expressions.items():
            expr = self.depends((raw.get("expressions") or {}).get(name),
                                {**self.symbols, "t": trajectory.T})
            paths[name] = value if expr is None else expr
            if expr is not None:
                self.follows["trajectory"].append(f"expressions.{name}")
        if duration is not None:
            self.follows["trajectory"].insert(0, "duration")
        return Trajectory(tr.kind, tr.duration if duration is None else duration,
                          MappingProxyType(ends["from"]), MappingProxyType(ends["to"]),
                          MappingProxyType(paths))

    def check_fixed(self) -> None:
        """The file's joint limits are checked at their values in the file, and the run's
        settings stay fixed: neither may depend on a varied name."""
        symbols, names = self.symbols, self.names
        for item in self.data.get("bodies") or []:
            if not isinstance(item, dict):
                continue
            if (item.get("inertia") or {}).get("triangle_inequality") == "ignore":
                self.unchecked.append(item.get("name"))
            for key, value in (((item.get("joint") or {}).get("limits") or {}).items()):
                expr = expressions.parse(value, symbols).xreplace(self.values)
                used = sorted(n for n in names if self.free[n] in expr.free_symbols)
                if used:
                    raise ModelError(
                        f"--vary {used[0]}: the limits of body {item.get('name')}'s joint "
                        f"({key}) in {self.robot.source} depend on it; a sweep checks the "
                        "file's limits at their values (give them as numbers, or as "
                        "--max/--min bounds)")
        for key, value in ((self.data.get("simulation") or {}).items()):
            if key != "method" and self.depends(value, symbols) is not None:
                used = sorted(n for n in names if self.free[n] in expressions.parse(
                    value, symbols).xreplace(self.values).free_symbols)
                raise ModelError(
                    f"--vary {used[0]}: simulation.{key} in {self.robot.source} depends on "
                    "it; a sweep keeps the run's settings fixed (give them as numbers, or on "
                    "the command line)")


def source(folding: Folding, formulation: str = "kane",
           generator: Callable[[Robot], str] | None = None, eom=None) -> str:
    """The numeric module of ``folding.robot`` with its free names bindable.

    ``generator(robot) -> source`` is any code generator that prints the
    free symbols as names (default: derive by ``formulation`` and
    ``closed_form.source``); the functions below are appended to its module.
    """
    robot = folding.robot
    if generator is None:
        from . import closed_form
        from ..symbolic.formulations import derive

        # the closed forms by Kane's method stand in for the recursive path (whose
        # generator folds every mass property to a number)
        method = "kane" if formulation == "recursive" else formulation
        eom = derive(robot, method) if eom is None else eom
        code = closed_form.source(robot, eom)
    else:
        code = generator(robot)
    values = robot.parameter_substitution()
    functions = [Function("start", (), (("x", [*(c.initial for c in robot.coordinates),
                                                 *(u.initial for u in robot.speeds)]),),
                          False, "Initial state [q(0), u(0)] at the bound values.")]
    free_set = {free_symbol(n) for n in folding.names}
    masses, inertias, dependent = [], [], []
    for body in robot.bodies:
        mass = body.mass.xreplace(values)
        inertia = body.inertia.xreplace(values)
        if (mass.free_symbols | inertia.free_symbols) & free_set:
            dependent.append(body.name)
            masses.append(mass)
            inertias.extend(inertia)
    functions.append(Function("inertial", (), (("mass", masses or [sp.Integer(0)]),
                                                ("inertia", inertias or [sp.Integer(0)] * 9)),
                              False, "Masses and inertia tensors (row-major) of the bodies "
                                     "in INERTIAL_BODIES at the bound values."))
    motion_error = ""
    if robot.trajectory is not None:
        try:
            functions.append(trajectory.function(
                *trajectory.derivatives(robot, values, free_set)))
        except ModelError as err:       # raised when inverse asks for the motion
            motion_error = str(err)
        else:
            functions.append(Function("duration", (), (("T", [robot.trajectory.duration
                                                              .xreplace(values)]),),
                                      False, "Duration of the prescribed motion, s."))
    stray = set()
    for f in functions:
        for _, out in f.outputs:
            for e in (out if isinstance(out, list) else list(out)):
                stray |= as_expr(e).free_symbols - free_set - set(f.args)
    if stray:      # the loader makes this impossible; a generator bug otherwise
        raise ModelError(f"cannot bind {', '.join(sorted(map(str, stray)))}")
    extra = module_source(functions, "bindable parameters and what follows from them")
    globals_ = [PREFIX + n for n in folding.names]
    lines = [f"{g} = float('nan')" for g in globals_]
    lines += [f"PARAMETERS = {tuple(folding.names)!r}",
              f"INERTIAL_BODIES = {tuple(dependent)!r}",
              f"TRIANGLE_UNCHECKED = {tuple(b for b in folding.unchecked if b in dependent)!r}",
              *([f"TRAJECTORY = ({robot.trajectory.kind!r}, float('nan'))"]
                if robot.trajectory is not None and not motion_error else []),
              *([f"MOTION_ERROR = {motion_error!r}"] if motion_error else []),
              "", "", "def bind(values):",
              '    """Bind the free names to ``values`` (floats, in PARAMETERS order)."""']
    if globals_:
        lines += [f"    global {', '.join(globals_)}",
                  f"    {', '.join(globals_)}, = (float(v) for v in values)"]
    else:
        lines.append("    pass")
    return code + "\n\n" + "\n".join(lines) + "\n\n" + extra
