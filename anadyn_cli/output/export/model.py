"""What every exported language needs: the matrices, the names, the documentation.

For n coordinates q (state x = [q, dq]) and m actuator efforts tau:

    M(q) ddq = F(t, q, dq) + B(q) tau            the equations of motion
    tau_c(t, q, dq)                               the file's control laws (zero without)
    K(t, q, dq, ddq) = [dG/dq - (dM/dq) ddq | dG/d(dq)],  G = F + B tau_c

so that the Jacobian of the closed-loop state derivative is
[[0, I], [M^-1 K]] (differentiating M ddq = G gives M d(ddq) = dG - (dM) ddq),
without inverting M symbolically.  ``ExportModel.build`` derives these once;
the language modules (``c``, ``python``, ``matlab``, ``latex``) only print.

A robot with a spherical joint (a floating joint is three slides and one) has
nq coordinates, its unit quaternion (qw, qx, qy, qz) among them, and n < nq
speeds u, the joint's body-axes angular velocity among them: the state is
x = [q, u] (nq + n), the equations read M(q) du = F(t, q, u) + B(q) tau, and the
kinematic differential equations dq = W(q) u (``kinematic``, nq) with their
Jacobian R = d(W(q) u)/dx (nq x (nq + n)) give the state derivative [W(q) u, du]
and its Jacobian [[R], [M^-1 K]], K being n x (nq + n).  The generated functions
then name their speeds ``u`` and the speeds' rates ``du`` (``arrays``).

Names: every robot name (coordinate, parameter, gain) becomes a local
variable of the generated functions.  ``local_names`` keeps each as it is
unless it collides with a word the target language reserves or with an
argument of the generated functions, and then appends underscores.
"""
from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass, field

import sympy as sp

from ... import __version__
from ...errors import ModelError, printable
from ...model.robot import Robot
from ...numeric.closed_form import control_laws, state_partials
from ...model.expressions import as_expr

TIME = sp.Symbol("t", real=True)
#: longest MATLAB identifier (namelengthmax) and our longest function suffix
MATLAB_NAME_MAX = 63
LONGEST_SUFFIX = "_input_matrix"


@dataclass(frozen=True)
class Quantity:
    """A named input: a coordinate, a rate, an acceleration, an effort, a parameter or gain."""
    symbol: sp.Symbol
    name: str
    unit: str            # "rad", "m", "rad/s", "N*m", ... ; "" when unknown
    index: int           # position in its array (parameters: in the params struct)
    value: float | None = None      # parameters and gains: the file's value
    kind: str = ""       # "parameter" or "gain" for parameters


@dataclass
class ExportModel:
    name: str                        # identifier used as file name and prefix
    robot_name: str
    source: str
    formulation: str
    symbolic: bool
    coordinates: list[Quantity]
    rates: list[Quantity]            # the speeds u: the coordinates' rates but a quaternion's
    accelerations: list[Quantity]
    efforts: list[Quantity]
    parameters: list[Quantity]       # empty unless symbolic
    has_controller: bool
    M: sp.Matrix
    F: sp.Matrix
    B: sp.Matrix
    laws: sp.Matrix                  # m x 1
    K: sp.Matrix                     # n x (nq + n)
    Q: sp.Matrix | None = None       # joint forces and loads (part of F), when the robot has them
    time_dependent: bool = False
    initial_state: list[float] = field(default_factory=list)   # x(0) = [q0, dq0] of the file
    generator: str = field(default_factory=lambda: f"anadyn {__version__}")
    #: dq = W(q) u (nq x 1), and R = its Jacobian d(W(q) u)/dx (nq x (nq + n)), when the
    #: speeds are not the coordinates' rates (a spherical joint); None otherwise
    kinematic: sp.Matrix | None = None
    R: sp.Matrix | None = None

    @property
    def n(self) -> int:
        """The number of speeds (of rows of M, F and B)."""
        return len(self.rates)

    @property
    def nq(self) -> int:
        """The number of coordinates: n, or more with a spherical joint's quaternion."""
        return len(self.coordinates)

    @property
    def arrays(self) -> tuple[str, str, str]:
        """The generated functions' names of the coordinates, the speeds and their rates:
        ("q", "dq", "ddq"), or ("q", "u", "du") when the speeds are not rates."""
        return ("q", "dq", "ddq") if self.kinematic is None else ("q", "u", "du")

    @property
    def m(self) -> int:
        return len(self.efforts)

    # -- construction -------------------------------------------------------
    @classmethod
    def build(cls, robot: Robot, eom) -> "ExportModel":
        """The export model of ``robot`` from its equations ``eom`` (symbolic
        parameters when ``eom.symbolic``; the control laws keep their gains
        as symbols then too)."""
        symbolic = bool(eom.symbolic)
        coordinates = [Quantity(s, s.name, c.unit, i)
                       for i, (s, c) in enumerate(zip(eom.q, robot.coordinates))]
        rates = [Quantity(s, s.name, u.unit, i)
                 for i, (s, u) in enumerate(zip(eom.dq, robot.speeds))]
        accelerations = [Quantity(s, s.name, u.unit + "^2", i)
                         for i, (s, u) in enumerate(zip(eom.ddq, robot.speeds))]
        efforts = [Quantity(s, s.name, a.unit, i)
                   for i, (s, a) in enumerate(zip(eom.efforts, robot.actuators))]
        laws = control_laws(robot, symbolic)
        M, F, B = sp.Matrix(eom.M), sp.Matrix(eom.F), sp.Matrix(eom.B)
        K = partials(M, F, B, laws, list(eom.q), list(eom.dq), list(eom.ddq))
        parameters: list[Quantity] = []
        if symbolic:
            used: set[sp.Symbol] = set()
            for matrix in (M, F, B, laws):
                used |= matrix.free_symbols
            values = robot.parameter_substitution()
            for name in robot.parameters:
                symbol = sp.Symbol(name, real=True)
                if symbol in used:
                    parameters.append(Quantity(symbol, name, "", len(parameters),
                                               float(values[symbol]), "parameter"))
            if robot.controller is not None:
                for name, value in robot.controller.gains.items():
                    symbol = sp.Symbol(name, real=True)
                    if symbol in used:
                        parameters.append(Quantity(symbol, name, "", len(parameters),
                                                   float(value.xreplace(values)), "gain"))
        known = ({TIME} | set(eom.q) | set(eom.dq) | set(eom.ddq)
                 | {p.symbol for p in parameters})
        for label, matrix in (("M", M), ("F", F), ("B", B), ("control laws", laws)):
            stray = matrix.free_symbols - known
            if stray:       # a bug: nothing in a valid robot leaves other names
                raise ModelError(f"cannot export: {label} depends on "
                                 f"{', '.join(sorted(map(str, stray)))}")
        Q = getattr(eom, "Q", None)
        kinematic = None if eom.kinematic is None else sp.Matrix(eom.kinematic)
        return cls(name=identifier(robot.name), robot_name=robot.name, source=robot.source,
                   formulation=eom.formulation, symbolic=symbolic, coordinates=coordinates,
                   rates=rates, accelerations=accelerations, efforts=efforts,
                   parameters=parameters, has_controller=robot.controller is not None,
                   M=M, F=F, B=B, laws=laws, K=K,
                   Q=sp.Matrix(Q) if Q is not None and any(e != 0 for e in Q) else None,
                   time_dependent=any(TIME in e.free_symbols for e in (*F, *laws)),
                   initial_state=_initial_state(robot), kinematic=kinematic,
                   R=None if kinematic is None else kinematic.jacobian(
                       list(eom.q) + list(eom.dq)))

    # -- documentation shared by the languages --------------------------------
    def title(self) -> str:
        method = {"kane": "Kane's method", "lagrange": "Lagrange's equations"}.get(
            self.formulation, self.formulation)
        where = "parameters passed in" if self.symbolic else "parameters folded in"
        return (f"Equations of motion of robot '{printable(self.robot_name)}' "
                f"({printable(self.source)}), by {method}, {where}; generated by "
                f"{self.generator}.")

    def units_lines(self, base: int = 0, left: str = "[", right: str = "]") -> list[str]:
        """One line per coordinate (and speed) and per actuator: index (from ``base``),
        name, unit; with a spherical joint, the conventions of x = [q, u] too."""
        if self.kinematic is None:
            lines = [f"coordinates q (rates dq, accelerations ddq), index from {base}:"]
            for c in self.coordinates:
                i = f"{left}{c.index + base}{right}"
                lines.append(f"  q{i} = {c.name} ({c.unit}); dq{i} = d{c.name} ({c.unit}/s); "
                             f"ddq{i} = dd{c.name} ({c.unit}/s^2)")
        else:
            lines = self.speed_lines(base, left, right)
        if self.efforts:
            lines.append(f"actuator efforts tau, index from {base}:")
            for e in self.efforts:
                what = "torque" if e.unit == "N*m" else "force"
                lines.append(f"  tau{left}{e.index + base}{right} = {e.name} ({e.unit}, {what})")
        else:
            lines.append("actuator efforts tau: none (m = 0; B has no columns)")
        if self.kinematic is None:
            lines.append("row r of M ddq, F and B tau is a generalized force along q_r: N*m "
                         "for an angle, N for a length; time t in s.")
        else:
            lines.append("row r of M du, F and B tau is a generalized force along u_r: N*m "
                         "for an angular speed, N for a linear one; time t in s.")
        if self.time_dependent:
            lines.append("F or the control laws depend on time t explicitly.")
        return lines

    def speed_lines(self, base: int, left: str, right: str) -> list[str]:
        """The coordinates, the speeds and the conventions of x = [q, u] (a spherical
        joint: its quaternion, its body-axes angular velocity, dq = W(q) u)."""
        lines = [f"x = [q, u]: nq = {self.nq} coordinates q, then n = {self.n} speeds u "
                 "(not all of them coordinate rates).",
                 "Each spherical joint's coordinates are a unit quaternion (qw, qx, qy, qz), "
                 "scalar first, the body's attitude in its joint frame; its speeds "
                 "(wx, wy, wz) are the body's angular velocity relative to its parent in the "
                 "body's own axes (rad/s).  A floating joint is three slides (x, y, z: the "
                 "body's origin in the joint frame, the world for a base; their speeds its "
                 "velocity in that frame, m/s) and a spherical joint.",
                 "The kinematic differential equations dq = W(q) u give the coordinates' "
                 "rates: a slide's or a turn's is its speed, a quaternion's is "
                 "1/2 q (x) (0, w) (Hamilton product).  The dynamics do not depend on a "
                 "quaternion's norm; make it unit again now and then when integrating.",
                 f"coordinates q, index from {base}:"]
        lines += [f"  q{left}{c.index + base}{right} = {c.name} ({c.unit})"
                  for c in self.coordinates]
        lines.append(f"speeds u (their rates du), index from {base}:")
        lines += [f"  u{left}{u.index + base}{right} = {u.name} ({u.unit}); "
                  f"du{left}{u.index + base}{right} = {a.name} ({a.unit})"
                  for u, a in zip(self.rates, self.accelerations)]
        return wrap(lines, 88)

    def law_lines(self) -> list[str]:
        if not self.efforts:
            return ["control laws: none (no actuators)."]
        if not self.has_controller:
            return ["control laws: none in the robot file; the state derivative uses zero "
                    "efforts (passive motion)."]
        return ["control laws (the file's controller), used by efforts(), rhs() and "
                "jacobian():"] + [f"  {e.name} = {sp.sstr(law)}"
                                  for e, law in zip(self.efforts, self.laws)]

    def parameter_lines(self) -> list[str]:
        if not self.symbolic:
            return ["parameters: folded in (the robot file's values)."]
        if not self.parameters:
            return ["parameters: none appear in the equations."]
        lines = ["parameters p (the robot file's values as defaults; parameters defined "
                 "by others are expanded):"]
        for p in self.parameters:
            lines.append(f"  {p.name} = {p.value!r} ({p.kind})")
        return lines


def _initial_state(robot: Robot) -> list[float]:
    """x(0) = [q(0), u(0)] of the robot file."""
    values = robot.parameter_substitution()
    return ([float(c.initial.xreplace(values)) for c in robot.coordinates]
            + [float(u.initial.xreplace(values)) for u in robot.speeds])


def identifier(name: str, limit: int = MATLAB_NAME_MAX - len(LONGEST_SUFFIX)) -> str:
    """``name`` as a C, Python and MATLAB identifier: letters, digits and
    underscores, starting with a letter, short enough for MATLAB function names."""
    cleaned = re.sub(r"[^A-Za-z0-9_]", "_", name)
    if not cleaned or not cleaned[0].isalpha():
        cleaned = "robot_" + cleaned
    return cleaned[:limit].rstrip("_") or "robot"


def partials(M: sp.Matrix, F: sp.Matrix, B: sp.Matrix, laws: sp.Matrix,
             q: list, dq: list, ddq: list) -> sp.Matrix:
    """K = [dG/dq - (dM/dq) ddq | dG/d(dq)] with G = F + B tau_c (n x 2n)."""
    return state_partials(M, F + B * laws if B.cols else F, q, dq, ddq)


def smooth_steps(expr: sp.Expr) -> sp.Expr:
    """Heaviside(x) (from differentiating min and max) as (sign(x) + 1)/2, which
    every target language prints (C's math.h and Octave have no Heaviside)."""
    if not _contains(expr, sp.Heaviside):
        return expr
    return expr.replace(lambda e: isinstance(e, sp.Heaviside),
                        lambda e: (sp.sign(e.args[0]) + 1) / 2)


def _contains(expr: sp.Basic, kind: type) -> bool:
    """Whether ``expr`` has a subexpression of type ``kind``; each shared subtree is
    visited once (``Basic.has`` walks the whole tree, which for the large shared
    expressions of a 7-axis arm took 18 of its 70 s of generation)."""
    seen: set[int] = set()
    stack = [expr]
    while stack:
        node = stack.pop()
        if isinstance(node, kind):
            return True
        for arg in node.args:
            if id(arg) not in seen:
                seen.add(id(arg))
                stack.append(arg)
    return False


def local_names(model: ExportModel, reserved: set[str]) -> dict[sp.Symbol, str]:
    """Symbol -> local variable name: the robot's own name unless ``reserved``
    (or already taken), then with underscores appended."""
    taken = set(reserved)
    result: dict[sp.Symbol, str] = {}
    for quantity in (*model.coordinates, *model.rates, *model.accelerations,
                     *model.parameters):
        name = quantity.name
        while name in taken:
            name += "_"
        taken.add(name)
        result[quantity.symbol] = name
    return result


def temporary_prefix(names: set[str], base: str = "w") -> str:
    """A prefix for the cse temporaries (prefix + digits) that no name uses."""
    prefix = base
    while any(re.fullmatch(re.escape(prefix) + r"\d+", n) for n in names):
        prefix += "_"
    return prefix


@dataclass
class Block:
    """Outputs of one generated function after common subexpression elimination.

    ``temporaries`` are (name, expression) in evaluation order; ``outputs``
    maps each output to its row-major list of reduced expressions.  The
    expressions keep the robot's symbols (renaming would rebuild every tree):
    a ``Named`` printer given ``names`` shows them, and the temporaries, by
    their local names.
    """
    temporaries: list[tuple[str, sp.Expr]]
    outputs: dict[str, list[sp.Expr]]
    used: set[str]                   # local names of the inputs the block reads
    names: dict                      # symbol -> local name, for the printer


def inputs_used(model: "ExportModel", names: dict, blk: Block):
    """What ``blk`` reads, in order: (local name, array, 0-based index) of the
    coordinates (array "q"), speeds ("dq" or "u": ``ExportModel.arrays``) and their
    rates ("ddq" or "du"), and (local name, Quantity) of the parameters; each
    exporter writes their unpacking."""
    states = [(names[quantity.symbol], array, quantity.index)
              for group, array in zip((model.coordinates, model.rates, model.accelerations),
                                      model.arrays)
              for quantity in group if names[quantity.symbol] in blk.used]
    parameters = [(names[par.symbol], par) for par in model.parameters
                  if names[par.symbol] in blk.used]
    return states, parameters


class Named:
    """Printer mix-in: symbols in ``names`` print as their local names."""

    def __init__(self, names: dict, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._local = names

    def _print_Symbol(self, expr, *args, **kwargs):
        local = self._local.get(expr)
        return local if local is not None else super()._print_Symbol(expr, *args, **kwargs)

    _print_Dummy = _print_Symbol


def block(outputs: dict[str, list[sp.Expr]], renames: dict[sp.Symbol, str],
          prefix: str) -> Block:
    """cse over all ``outputs`` together; temporaries named ``prefix`` + digits."""
    flat: list[sp.Expr] = []
    for exprs in outputs.values():
        flat += [smooth_steps(as_expr(e)) for e in exprs]
    temps, reduced = sp.cse(flat, symbols=sp.numbered_symbols(prefix, cls=sp.Dummy),
                            order="none")
    temps = _needed(temps, reduced)
    result: dict[str, list[sp.Expr]] = {}
    position = 0
    for key, exprs in outputs.items():
        result[key] = reduced[position:position + len(exprs)]
        position += len(exprs)
    names = {**renames, TIME: "t"}
    symbols: set[sp.Symbol] = set()
    for expr in [*reduced, *(e for _, e in temps)]:
        symbols |= expr.free_symbols
    used = {names[s] for s in symbols if s in names}
    names.update({symbol: f"{prefix}{k}" for k, (symbol, _) in enumerate(temps)})
    return Block([(names[s], e) for s, e in temps], result, used, names)


def _needed(temps: list[tuple[sp.Symbol, sp.Expr]], outputs: list[sp.Expr]):
    """The temporaries the outputs read, directly or through other temporaries, in
    order: ``cse`` can leave one that nothing reads (the UR5's partials had one,
    which C compilers reject under -Wall -Werror as an unused variable)."""
    read: set = set()
    for expr in outputs:
        read |= expr.free_symbols
    kept = []
    for symbol, expr in reversed(temps):
        if symbol in read:
            kept.append((symbol, expr))
            read |= expr.free_symbols
    return kept[::-1]


def quiet(text: str) -> None:
    """A ``note`` that tells no one (the exporters' default)."""


def leaf_note(outputs: dict[str, sp.Matrix]) -> str:
    """What a progress line says while a generated function's code is made:
    ``K (6 x 12): common subexpressions and code``."""
    return ", ".join(f"{key} ({matrix.rows} x {matrix.cols})" for key, matrix in outputs.items()
                     ) + ": common subexpressions and code"


def wrap(lines: list[str], width: int = 92) -> list[str]:
    """Lines longer than ``width`` broken at spaces, continuation lines indented
    like the line plus two spaces."""
    out = []
    for line in lines:
        if len(line) <= width:
            out.append(line)
            continue
        indent = " " * (len(line) - len(line.lstrip()))
        out += textwrap.wrap(line, width, subsequent_indent=indent + "  ",
                             break_long_words=False, break_on_hyphens=False) or [""]
    return out


def row_major(matrix: sp.Matrix) -> list[sp.Expr]:
    return [matrix[i, j] for i in range(matrix.rows) for j in range(matrix.cols)]
