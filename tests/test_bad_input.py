"""Bad robot files: one line naming the file, the line, the key path, what is
wrong and what is allowed; exit 2; nothing on stdout; never a traceback.

Every case starts from the text of a shipped robot (robots/rr.yaml unless
said otherwise), changes one thing, and runs the command line on it.  Line
numbers refer to robots/rr.yaml (rrt.yaml for the RRT cases):

     4 name              14 bodies[0].joint   25 actuators.T01z
     6 parameters        18 bodies[1]         28 controller.gains
     7 gravity           19 bodies[1].parent  29 controller.laws
     8 coordinates       20 bodies[1].joint   33 controller.laws.T12z
     9 coordinates.q1    21 bodies[1].mass    34 trajectory
    11 bodies            22 bodies[1].com     35 simulation
    12 bodies[0]         23 bodies[1].inertia

Each expected message was read for clarity before it went in here; they are
the contract, so a changed wording must change this file too.
"""
from __future__ import annotations

import contextlib
import re
import signal
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

import anadyn_cli.model.loader  # noqa: F401  (imports SymPy now, not inside a timed call)
from anadyn_cli.cli import main
from anadyn_cli.model import expressions, names, yamlschema

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
RR = (ROBOTS / "rr.yaml").read_text()
RRT = (ROBOTS / "rrt.yaml").read_text()
FUNCTIONS = ("abs, acos, asin, atan, atan2, cos, cosh, exp, log, max, min, sign, sin, sinh, "
             "sqrt, tan, tanh")
ONLY = f"use numbers, names, + - * / ** and the functions {FUNCTIONS}"
TOP = ("name, description, parameters, gravity, coordinates, speeds, bodies, actuators, "
       "controller, loads, trajectory, simulation, loops, constraints, contacts")
RR_PARAMETERS = "L1, L2, g, m1, m2, pi"          # what a constant of rr.yaml may use


def edit(text: str, old: str, new: str) -> str:
    """``text`` with the one occurrence of ``old`` replaced (the case fails if
    the shipped robot no longer contains it exactly once)."""
    assert text.count(old) == 1, f"{old!r} occurs {text.count(old)} times"
    return text.replace(old, new)


def rr(old: str, new: str) -> str:
    return edit(RR, old, new)


def rrt(old: str, new: str) -> str:
    return edit(RRT, old, new)


def without(text: str, *lines: str) -> str:
    for line in lines:
        text = edit(text, line + "\n", "")
    return text


@dataclass
class Case:
    id: str
    text: str | bytes
    error: str            # "{file}" stands for the path of the file


def case(id: str, text: str | bytes, error: str):
    return pytest.param(Case(id, text, error), id=id)


CASES = [
    # -- not YAML, not a mapping, empty --------------------------------------------
    case("not-yaml-unclosed-list", rr("gravity: [0, -g, 0]", "gravity: [0, -g, 0"),
         "{file}:8: not valid YAML: expected ',' or ']', but got ':'"),
    case("not-yaml-two-colons", rr("name: rr", "name: rr: arm"),
         "{file}:4: not valid YAML: mapping values are not allowed here"),
    case("not-yaml-tab", rr("  q2: {initial: pi/6}", "\tq2: {initial: pi/6}"),
         "{file}:10: not valid YAML: found character '\\t' that cannot start any token"),
    case("not-yaml-two-documents", RR + "---\nname: other\n",
         "{file}:36: not valid YAML: expected a single document in the stream, but found "
         "another document"),
    case("not-utf8", RR.encode() + b"# caf\xe9\n",
         "{file}:36: not UTF-8 text: byte 0xe9 at column 6; save the file as UTF-8"),
    case("not-a-mapping-list", "- bar1\n- bar2\n",
         "{file}:1: the file must be a YAML mapping of keys to values, got a list"),
    case("not-a-mapping-number", "42\n",
         "{file}:1: the file must be a YAML mapping of keys to values, got the number 42"),
    case("not-a-mapping-text", "just some text\n",
         "{file}:1: the file must be a YAML mapping of keys to values, got the text "
         "'just some text'"),
    case("not-a-mapping-null", "~\n",
         "{file}:1: the file must be a YAML mapping of keys to values, got nothing (null)"),
    case("empty-file", "", "{file}: empty file, expected a YAML mapping"),
    case("only-comments", "# nothing here\n\n", "{file}: empty file, expected a YAML mapping"),
    case("python-tag", rr("name: rr", "name: !!python/object/apply:os.system ['touch MARKER']"),
         "{file}:4: name: YAML tag !!python/object/apply:os.system is not supported; write "
         "plain numbers, text, lists and mappings"),
    case("custom-tag", rr("    mass: m2", "    mass: !expr m2"),
         "{file}:21: bodies[1].mass: YAML tag !expr is not supported; write plain numbers, "
         "text, lists and mappings"),
    case("duplicate-key", rr("    mass: m2", "    mass: m2\n    mass: m1"),
         "{file}:22: bodies[1].mass: duplicate key"),
    case("alias", rr("com: [L2/2, 0, 0]", "com: *bar1_com").replace(
        "com: [L1/2, 0, 0]", "com: &bar1_com [L1/2, 0, 0]"),
        "{file}:22: bodies[1].com: YAML aliases (*name) are not supported; write the value out"),
    case("merge-key", rr("    mass: m2", "    <<: {mass: m2}"),
         "{file}:21: bodies[1]: YAML merge keys (<<) are not supported"),
    case("number-as-key", rr("parameters: {L1: 1.0", "parameters: {1: 1.0"),
         "{file}:6: parameters: keys must be names, got 1"),
    # -- unknown keys (with a did-you-mean where one is close) ---------------------
    case("unknown-top-key", rr("gravity:", "gravty:"),
         "{file}:7: gravty: unknown key; did you mean 'gravity'? allowed: " + TOP),
    case("unknown-top-key-no-hint", rr("gravity:", "colour: red\ngravity:"),
         "{file}:7: colour: unknown key; allowed: " + TOP),
    case("unknown-body-key", rr("    mass: m2", "    mas: m2"),
         "{file}:21: bodies[1].mas: unknown key; did you mean 'mass'? allowed: name, parent, "
         "joint, mass, com, inertia"),
    case("unknown-joint-key", rr("origin: [L1, 0, 0]", "orign: [L1, 0, 0]"),
         "{file}:20: bodies[1].joint.orign: unknown key; did you mean 'origin'? allowed: type, "
         "axis, origin, rpy, displacement, limits, damping, friction, friction_velocity, "
         "stiffness, rest"),
    case("unknown-inertia-key", rr("{iyy: m2*L2**2/12,", "{iyyy: m2*L2**2/12,"),
         "{file}:23: bodies[1].inertia.iyyy: unknown key; did you mean 'iyy'? allowed: ixx, "
         "iyy, izz, ixy, ixz, iyz, triangle_inequality"),
    case("unknown-coordinate-key", rr("q2: {initial: pi/6}", "q2: {inital: pi/6}"),
         "{file}:10: coordinates.q2.inital: unknown key; did you mean 'initial'? allowed: "
         "initial, rate, dependent"),
    case("unknown-simulation-key", rr("t_end: 15", "t_ned: 15"),
         "{file}:35: simulation.t_ned: unknown key; did you mean 't_end'? allowed: t_end, "
         "output_step, method, rtol, atol"),
    case("unquoted-comma-splits-expression", rr("duration: 15,", "duration: max(10, 15),"),
         "{file}:34: trajectory.15): unknown key (a comma or colon inside {...} splits an "
         "expression: quote it); allowed: kind, duration, from, to, expressions, points, "
         "durations, shape, times, q, dq, ddq"),
    # -- missing required keys ------------------------------------------------------
    case("missing-coordinates", without(RR, "coordinates:", "  q1: {initial: -pi/18}       "
                                        "# the text's q1(0); the inverse listing's pi/18 is a "
                                        "slip", "  q2: {initial: pi/6}"),
         "{file}:4: missing required key 'coordinates'"),
    case("missing-mass", without(RR, "    mass: m2"),
         "{file}:18: bodies[1]: missing required key 'mass'"),
    case("missing-body-name", rr("  - name: bar2\n    parent: bar1", "  - parent: bar1"),
         "{file}:18: bodies[1]: missing required key 'name'"),
    case("missing-joint-type", rr("{type: revolute, axis: [0, 0, 1], displacement: q1}",
                                  "{axis: [0, 0, 1], displacement: q1}"),
         "{file}:14: bodies[0].joint: missing required key 'type'"),
    case("missing-axis", rr("{type: revolute, axis: [0, 0, 1], displacement: q1}",
                            "{type: revolute, displacement: q1}"),
         "{file}:14: bodies[0].joint: missing required key 'axis' for a revolute joint"),
    case("missing-laws", RR[:RR.index("  laws:")] + RR[RR.index("trajectory:"):],
         "{file}:27: controller: missing required key 'laws'"),
    case("missing-trajectory-end", rr("duration: 15, to: {q1: pi/6, q2: pi/3}}",
                                      "duration: 15}"),
         "{file}:34: trajectory: missing required key 'to' for a cycloidal trajectory"),
    # -- wrong types ------------------------------------------------------------------
    case("type-bodies-number", RR[:RR.index("bodies:")] + "bodies: 3\n",
         "{file}:11: bodies: expected a list, got the number 3"),
    case("type-body-text", rr("  - name: bar2\n", "  - bar2\n  - name: bar2\n"),
         "{file}:18: bodies[1]: expected a mapping, got the text 'bar2'"),
    case("type-mass-list", rr("    mass: m2", "    mass: [m2]"),
         "{file}:21: bodies[1].mass: expected a number or an expression, got a list"),
    case("type-mass-boolean", rr("    mass: m2", "    mass: yes"),
         "{file}:21: bodies[1].mass: expected a number or an expression, got the boolean true"),
    case("type-mass-null", rr("    mass: m2", "    mass:"),
         "{file}:21: bodies[1].mass: expected a number or an expression, got nothing (null)"),
    case("type-mass-date", rr("    mass: m2", "    mass: 2024-06-07"),
         "{file}:21: bodies[1].mass: expected a number or an expression, got a date"),
    case("type-com-two-components", rr("com: [L2/2, 0, 0]", "com: [L2/2, 0]"),
         "{file}:22: bodies[1].com: expected a list of 3 components [x, y, z], got 2"),
    case("type-gravity-mapping", rr("gravity: [0, -g, 0]", "gravity: {y: -g}"),
         "{file}:7: gravity: expected a list, got a mapping"),
    case("type-inertia-list", rr("inertia: {iyy: m2*L2**2/12, izz: m2*L2**2/12}",
                                 "inertia: [0, 1, 1]"),
         "{file}:23: bodies[1].inertia: expected a mapping, got a list"),
    case("type-joint-text", rr("{type: revolute, axis: [0, 0, 1], displacement: q1}",
                               "revolute"),
         "{file}:14: bodies[0].joint: expected a mapping, got the text 'revolute'"),
    case("type-joint-kind", rr("{type: revolute, axis: [0, 0, 1], displacement: q1}",
                               "{type: hinge, axis: [0, 0, 1], displacement: q1}"),
         "{file}:14: bodies[0].joint.type: must be one of revolute, prismatic, fixed, "
         "spherical, planar, universal, cylindrical, helical, floating, got 'hinge'"),
    case("type-name-number", rr("name: rr", "name: 5"),
         "{file}:4: name: robot name must be a letter followed by up to 63 letters, digits or "
         "underscores, got 5"),
    case("type-description-number", rr("description: Planar two-bar arm, absolute angles "
                                       "(chapter 6.3)", "description: 6.3"),
         "{file}:5: description: expected text, got the number 6.3"),
    case("type-parent-number", rr("parent: bar1", "parent: 1"),
         "{file}:19: bodies[1].parent: expected 'ground' or a body name, got the number 1"),
    case("type-actuator-text", rr("T12z: {joint: bar2}", "T12z: bar2"),
         "{file}:26: actuators.T12z: expected a mapping, got the text 'bar2'"),
    case("type-trajectory-kind", rr("kind: cycloidal", "kind: linear"),
         "{file}:34: trajectory.kind: must be one of cycloidal, quintic, expression, waypoints, "
         "spline, got 'linear'"),
    case("type-method", rr("output_step: 0.01}", "output_step: 0.01, method: rk4}"),
         "{file}:35: simulation.method: must be one of auto, odeint, RK45, RK23, DOP853, "
         "Radau, BDF, LSODA, got 'rk4'"),
    # -- numbers: non-finite, non-numeric, out of range -----------------------------------
    case("nan", rr("m1: 1.0", "m1: .nan"),
         "{file}:6: parameters.m1: expected a finite number, got nan"),
    case("infinity", rr("gravity: [0, -g, 0]", "gravity: [0, -.inf, 0]"),
         "{file}:7: gravity[1]: expected a finite number, got -inf"),
    case("nan-as-text", rr("m1: 1.0", "m1: nan"),
         "{file}:6: parameters.m1: unknown name 'nan'; allowed here: L1, L2, pi"),
    case("non-numeric-text", rr("    mass: m2", "    mass: heavy"),
         "{file}:21: bodies[1].mass: unknown name 'heavy'; allowed here: " + RR_PARAMETERS),
    case("float-overflow", rr("m1: 1.0", "m1: 1e999"),
         "{file}:6: parameters.m1: number too large (the largest allowed is about 1.8e308)"),
    case("power-overflow", rr("m1: 1.0", "m1: 10**10**10"),
         "{file}:6: parameters.m1: numeric power overflows (the largest number allowed is "
         "about 1.8e308)"),
    case("exp-tower", rr("m1: 1.0", "m1: exp(exp(exp(100)))"),
         "{file}:6: parameters.m1: exp(exp(100)) overflows in floating point (the largest "
         "number allowed is about 1.8e308)"),
    case("exp-tower-of-a-parameter", rr("m1: 1.0", "m1: exp(exp(exp(100*L1)))"),
         "{file}:6: parameters.m1: exp(exp(exp(100*L1))) overflows in floating point (the "
         "largest number allowed is about 1.8e308)"),
    case("exp-tower-in-a-function", rr("    mass: m2", "    mass: abs(sin(exp(exp(exp(99)))))"),
         "{file}:21: bodies[1].mass: exp(exp(99)) overflows in floating point (the largest "
         "number allowed is about 1.8e308)"),
    case("exp-tower-in-a-law", rr("    T12z: -b12*dq2",
                                  "    T12z: exp(exp(exp(100*q2))) - b12*dq2"),
         "{file}:33: controller.laws.T12z: the law is not a finite real number at the initial "
         "state (dq2 = 0, q2 = 0.523599); it must be defined where the motion starts"),
    case("huge-integer", rr("m1: 1.0", "m1: 1" + "0" * 400),
         "{file}:6: parameters.m1: number too large (the largest allowed is about 1.8e308)"),
    case("huge-integer-over-4096-bits", rr("m1: 1.0", "m1: 1" + "0" * 1300),
         "{file}:6: parameters.m1: number too large (more than 4096 bits), the largest allowed "
         "is about 1.8e308"),
    case("too-many-digits", rr("m1: 1.0", "m1: " + "9" * 5000),
         "{file}:6: parameters.m1: cannot read the value '" + "9" * 37 + "...' (too many "
         "digits)"),
    case("out-of-range", rr("m1: 1.0", "m1: 1e-40"),
         "{file}:6: parameters.m1: 1e-40 is out of range: numbers in a robot file are 0 or "
         "between 1e-30 and 1e+30 in size (SI units)"),
    case("complex", rr("    mass: m2", "    mass: sqrt(-m2)"),
         "{file}:21: bodies[1].mass: must be a finite real number, got I"),
    case("division-by-zero", rr("    mass: m2", "    mass: m2/0"),
         "{file}:21: bodies[1].mass: division by zero"),
    case("division-by-zero-parameter", rr("    mass: m2", "    mass: m2/(L1 - L2)"),
         "{file}:21: bodies[1].mass: must be a finite real number, got zoo"),
    # -- mass ------------------------------------------------------------------------------
    case("mass-zero", rr("    mass: m2", "    mass: 0"),
         "{file}:21: bodies[1].mass: must be positive (a mass in kg), got 0"),
    case("mass-negative", rr("    mass: m2", "    mass: -m2"),
         "{file}:21: bodies[1].mass: must be positive (a mass in kg), got -1"),
    case("mass-negative-parameter", rr("m2: 1.0", "m2: -2.5"),
         "{file}:21: bodies[1].mass: must be positive (a mass in kg), got -2.5"),
    # -- inertia ------------------------------------------------------------------------------
    case("inertia-negative-moment", rr("{iyy: m2*L2**2/12, izz: m2*L2**2/12}",
                                       "{ixx: -1, iyy: 1, izz: 1}"),
         "{file}:23: bodies[1].inertia: inertia tensor must be positive semidefinite; its "
         "principal moments are -1, 1, 1"),
    case("inertia-products-too-large", rr("{iyy: m2*L2**2/12, izz: m2*L2**2/12}",
                                          "{ixx: 1, iyy: 1, izz: 1, ixy: 2}"),
         "{file}:23: bodies[1].inertia: inertia tensor must be positive semidefinite; its "
         "principal moments are -1, 1, 3"),
    case("inertia-triangle", rr("{iyy: m2*L2**2/12, izz: m2*L2**2/12}",
                                "{ixx: 1, iyy: 1, izz: 3}"),
         "{file}:23: bodies[1].inertia: principal moments 1, 1, 3 break the triangle "
         "inequality (no rigid body has them: I1 + I2 >= I3)"),
    case("inertia-triangle-readme", rr("{iyy: m2*L2**2/12, izz: m2*L2**2/12}",
                                       "{izz: m2*L2**2/12}"),
         "{file}:23: bodies[1].inertia: principal moments 0, 0, 0.0833333 break the triangle "
         "inequality (no rigid body has them: I1 + I2 >= I3)"),
    # -- axis -----------------------------------------------------------------------------
    case("axis-zero", rr("axis: [0, 0, 1], origin", "axis: [0, 0, 0], origin"),
         "{file}:20: bodies[1].joint.axis: axis must not be the zero vector; give a direction "
         "such as [0, 0, 1]"),
    case("axis-zero-by-parameters", rr("axis: [0, 0, 1], origin", "axis: [0, 0, L1 - L2], origin"),
         "{file}:20: bodies[1].joint.axis: axis must not be the zero vector; give a direction "
         "such as [0, 0, 1]"),
    case("fixed-joint-with-axis", rr("{type: revolute, axis: [0, 0, 1], origin: [L1, 0, 0], "
                                     "displacement: q2 - q1}", "{type: fixed, axis: [0, 0, 1]}"),
         "{file}:20: bodies[1].joint.axis: a fixed joint has no axis or displacement; remove it "
         "or make the joint revolute or prismatic"),
    # -- the tree of bodies --------------------------------------------------------------------
    case("unknown-parent", rr("parent: bar1", "parent: bar3"),
         "{file}:19: bodies[1].parent: unknown parent 'bar3' (did you mean 'bar2'?); use "
         "'ground' or a body name"),
    case("unknown-parent-no-hint", rr("parent: bar1", "parent: base"),
         "{file}:19: bodies[1].parent: unknown parent 'base'; use 'ground' or a body name"),
    case("cycle", rr("    parent: ground", "    parent: bar2"),
         "{file}:13: bodies[0].parent: bodies bar1, bar2 form a cycle; every chain must start "
         "at ground"),
    case("own-parent", rr("parent: bar1", "parent: bar2"),
         "{file}:19: bodies[1].parent: bodies bar2 form a cycle; every chain must start at "
         "ground"),
    case("duplicate-body-name", rr("  - name: bar2", "  - name: bar1"),
         "{file}:18: bodies[1].name: duplicate body name 'bar1'; every body needs its own name"),
    case("duplicate-name-parameter-coordinate", rr("g: 9.81}", "g: 9.81, q1: 2}"),
         "{file}:9: coordinates.q1: name 'q1' is already used by a parameter; every name in a "
         "robot file must be different"),
    case("duplicate-name-actuator-coordinate", rr("  T12z: {joint: bar2}", "  q2: {joint: bar2}"),
         "{file}:26: actuators.q2: name 'q2' is already used by a coordinate; every name in a "
         "robot file must be different"),
    case("duplicate-name-gain-rate", rr("b01: 450,", "dq1: 450,"),
         "{file}:28: controller.gains.dq1: name 'dq1' is already used by the rate of "
         "coordinate 'q1'; every name in a robot file must be different"),
    # -- names that are not identifiers --------------------------------------------------------
    case("robot-name-path", rr("name: rr", "name: ../../etc/evil"),
         "{file}:4: name: robot name must be a letter followed by up to 63 letters, digits or "
         "underscores, got '../../etc/evil'"),
    case("robot-name-absolute", rr("name: rr", "name: /tmp/evil"),
         "{file}:4: name: robot name must be a letter followed by up to 63 letters, digits or "
         "underscores, got '/tmp/evil'"),
    case("robot-name-space", rr("name: rr", "name: r r"),
         "{file}:4: name: robot name must be a letter followed by up to 63 letters, digits or "
         "underscores, got 'r r'"),
    case("robot-name-too-long", rr("name: rr", "name: " + "r" * 65),
         "{file}:4: name: robot name must be a letter followed by up to 63 letters, digits or "
         "underscores, got " + repr("r" * 37) + "... (65 characters)"),
    case("robot-name-reserved", rr("name: rr", "name: ground"),
         "{file}:4: name: 'ground' is reserved; choose another robot name"),
    case("body-name-slash", rr("name: bar2", "name: a/b"),
         "{file}:18: bodies[1].name: body name must be a letter followed by up to 63 letters, "
         "digits or underscores, got 'a/b'"),
    case("body-name-dots", rr("name: bar2", "name: '..'"),
         "{file}:18: bodies[1].name: body name must be a letter followed by up to 63 letters, "
         "digits or underscores, got '..'"),
    case("coordinate-name-digit-first", RR.replace("q2", "2q"),
         "{file}:10: coordinates.2q: coordinate name must be a letter followed by up to 63 "
         "letters, digits or underscores, got '2q'"),
    case("coordinate-name-dunder", RR.replace("q2", "__q2"),
         "{file}:10: coordinates.__q2: coordinate name must be a letter followed by up to 63 "
         "letters, digits or underscores, got '__q2'"),
    case("coordinate-name-comma", rr("  q2: {initial: pi/6}", "  'q,2': {initial: pi/6}"),
         "{file}:10: coordinates.q,2: coordinate name must be a letter followed by up to 63 "
         "letters, digits or underscores, got 'q,2'"),
    case("parameter-name-space", rr("L1: 1.0", "'L 1': 1.0"),
         "{file}:6: parameters.L 1: parameter name must be a letter followed by up to 63 "
         "letters, digits or underscores, got 'L 1'"),
    case("parameter-name-reserved", rr("g: 9.81}", "g: 9.81, sin: 1}"),
         "{file}:6: parameters.sin: 'sin' is reserved; choose another parameter name"),
    case("parameter-name-keyword", rr("g: 9.81}", "g: 9.81, lambda: 1}"),
         "{file}:6: parameters.lambda: 'lambda' is reserved; choose another parameter name"),
    case("actuator-name-path", rr("  T12z: {joint: bar2}", "  ../T12z: {joint: bar2}"),
         "{file}:26: actuators.../T12z: actuator name must be a letter followed by up to 63 "
         "letters, digits or underscores, got '../T12z'"),
    case("gain-name-newline", rr("b01: 450,", "\"b\\n01\": 450,"),
         "{file}:28: controller.gains.b\n01: gain name must be a letter followed by up to 63 "
         "letters, digits or underscores, got 'b\\n01'"),
    # -- coordinates and displacements ---------------------------------------------------------
    case("coordinate-unused", rr("  q2: {initial: pi/6}", "  q2: {initial: pi/6}\n  q3: {}"),
         "{file}:11: coordinates.q3: no joint displacement uses this coordinate; every "
         "coordinate must move some joint"),
    case("displacement-undeclared-coordinate", rr("displacement: q2 - q1",
                                                  "displacement: q3 - q1"),
         "{file}:20: bodies[1].joint.displacement: unknown name 'q3'; allowed here: L1, L2, g, "
         "m1, m2, q1, q2, pi"),
    case("displacement-rate", rr("displacement: q2 - q1", "displacement: q2 - dq1"),
         "{file}:20: bodies[1].joint.displacement: 'dq1' is the rate of coordinate 'q1' and "
         "cannot be used here; allowed here: L1, L2, g, m1, m2, q1, q2, pi"),
    case("displacement-constant", rr("displacement: q2 - q1", "displacement: L1"),
         "{file}:20: bodies[1].joint.displacement: the displacement must depend on at least "
         "one coordinate, e.g. q1 or q2 - q1"),
    case("displacement-kink", rr("displacement: q2 - q1", "displacement: abs(q2) - q1"),
         "{file}:20: bodies[1].joint.displacement: abs() has a kink or a jump and is not "
         "allowed here (this expression is differentiated twice); use the smooth functions "
         "acos, asin, atan, atan2, cos, cosh, exp, log, sin, sinh, sqrt, tan, tanh"),
    case("displacement-undefined-at-start", rr("displacement: q2 - q1",
                                               "displacement: sqrt(q2 - 1)"),
         "{file}:20: bodies[1].joint.displacement: the displacement is not a finite real "
         "number at the initial state (q2 = 0.523599); it must be defined where the motion "
         "starts"),
    case("coordinate-moves-no-mass", rrt("  q3: {initial: 0.25}", "  q3: {initial: 0.25}\n"
                                         "  q4: {initial: 0}").replace(
        "joint: {type: prismatic, axis: [0, 0, 1], origin: [0, 0, L2]}",
        "joint: {type: prismatic, axis: [0, 0, 1], origin: [0, 0, L2], "
        "displacement: q3 + 0*q4 + q4 - q4 + q4**3 - q4**3}").replace(
        "  - name: link3", "  - name: pin\n    parent: link3\n    joint: {type: revolute, "
        "axis: [0, 0, 1], displacement: q4}\n    mass: 1\n  - name: link3"),
        "{file}:13: coordinates.q4: moving q4 moves no mass (the mass matrix is singular at "
        "the initial state and at 2 random states); every coordinate must move a body with "
        "mass off the joint axis or with inertia about it"),
    # -- actuators and laws --------------------------------------------------------------------
    case("law-for-unknown-actuator", rr("    T12z: -b12", "    T99z: -b12"),
         "{file}:33: controller.laws.T99z: law for unknown actuator; actuators: T01z, T12z"),
    case("law-for-misspelt-actuator", rr("    T12z: -b12", "    T12x: -b12"),
         "{file}:33: controller.laws.T12x: law for unknown actuator; did you mean 'T12z'? "
         "actuators: T01z, T12z"),
    case("actuator-without-law", without(RR, "    T12z: -b12*dq2 - g12*(q2 - q2f) + "
                                         "0.5*g*L2*m2*cos(q2)"),
         "{file}:29: controller.laws: no law for actuator(s) T12z; every actuator needs one"),
    case("actuator-on-unknown-body", rr("T12z: {joint: bar2}", "T12z: {joint: bar3}"),
         "{file}:26: actuators.T12z.joint: unknown body 'bar3' (did you mean 'bar2'?); "
         "actuators act on the joint of one of: bar1, bar2"),
    case("law-uses-acceleration", rr("    T12z: -b12*dq2", "    T12z: -b12*ddq2"),
         "{file}:33: controller.laws.T12z: 'ddq2' is the acceleration of coordinate 'q2' and "
         "cannot be used here; allowed here: L1, L2, b01, b12, dq1, dq2, g, g01, g12, m1, m2, "
         "q1, q1f, q2, q2f, t, pi"),
    # -- expressions ---------------------------------------------------------------------------
    case("syntax-error", rr("    mass: m2", "    mass: m2 *"),
         "{file}:21: bodies[1].mass: syntax error in 'm2 *' at the end; write an arithmetic "
         "expression such as 2*L1*cos(q1)"),
    case("syntax-error-parenthesis", rr("    T12z: -b12*dq2", "    T12z: (-b12*dq2"),
         "{file}:33: controller.laws.T12z: syntax error in '(-b12*dq2 - g12*(q2 - q2f) + "
         "0.5*g*L2*m2*cos(q2)' at column 1: '(' was never closed; write an arithmetic "
         "expression such as 2*L1*cos(q1)"),
    case("caret-power", rr("    mass: m2", "    mass: m2^2"),
         "{file}:21: bodies[1].mass: the operator ^ (use ** for powers) is not allowed; " + ONLY),
    case("unknown-name", rr("    mass: m2", "    mass: m3"),
         "{file}:21: bodies[1].mass: unknown name 'm3'; allowed here: " + RR_PARAMETERS),
    case("unknown-name-typo", rr("    mass: m2", "    mass: mm2"),
         "{file}:21: bodies[1].mass: unknown name 'mm2' (did you mean m2?); allowed here: "
         + RR_PARAMETERS),
    case("name-defined-further-down", rr("L1: 1.0, L2: 1.0", "L1: L2, L2: 1.0"),
         "{file}:6: parameters.L1: 'L2' is a parameter defined further down and cannot be "
         "used here; allowed here: pi"),
    case("coordinate-in-a-constant", rr("    mass: m2", "    mass: m2*q1"),
         "{file}:21: bodies[1].mass: 'q1' is a coordinate and cannot be used here; allowed "
         "here: " + RR_PARAMETERS),
    case("attribute-access", rr("    mass: m2", "    mass: m2.real"),
         "{file}:21: bodies[1].mass: attribute access (.real) is not allowed; " + ONLY),
    case("call-not-whitelisted", rr("    mass: m2", "    mass: gamma(m2)"),
         "{file}:21: bodies[1].mass: call of gamma is not allowed; allowed functions: "
         + FUNCTIONS),
    case("call-of-builtin", rr("    mass: m2", "    mass: \"float('1')\""),
         "{file}:21: bodies[1].mass: call of float is not allowed; allowed functions: "
         + FUNCTIONS),
    case("call-of-a-parameter", rr("    mass: m2", "    mass: (m2)(1)"),
         "{file}:21: bodies[1].mass: call of m2 is not allowed; allowed functions: "
         + FUNCTIONS),
    case("call-of-an-attribute", rr("    mass: m2", "    mass: \"''.join('m2')\""),
         "{file}:21: bodies[1].mass: attribute access (.join) is not allowed; " + ONLY),
    case("function-without-call", rr("    mass: m2", "    mass: m2*sin"),
         "{file}:21: bodies[1].mass: sin is a function; call it as sin(...)"),
    case("function-arity", rr("    mass: m2", "    mass: atan2(m2)"),
         "{file}:21: bodies[1].mass: atan2() takes 2 argument(s), got 1"),
    case("function-keyword", rr("    mass: m2", "    mass: sqrt(x=m2)"),
         "{file}:21: bodies[1].mass: sqrt() takes positional arguments only"),
    case("lambda", rr("    mass: m2", "    mass: '(lambda: m2)()'"),
         "{file}:21: bodies[1].mass: lambda is not allowed; " + ONLY),
    case("subscript", rr("    mass: m2", "    mass: '[m2][0]'"),
         "{file}:21: bodies[1].mass: subscripting is not allowed; " + ONLY),
    case("string", rr("    mass: m2", "    mass: \"'m2'\""),
         "{file}:21: bodies[1].mass: the string 'm2' is not allowed in an expression; " + ONLY),
    case("dunder-name", rr("    mass: m2", "    mass: __builtins__"),
         "{file}:21: bodies[1].mass: name '__builtins__' is not allowed (no name starts with "
         "_); allowed here: " + RR_PARAMETERS),
    case("comparison", rr("    mass: m2", "    mass: m2 > 0"),
         "{file}:21: bodies[1].mass: comparison is not allowed; " + ONLY),
    case("if-expression", rr("    mass: m2", "    mass: m2 if m2 else 1"),
         "{file}:21: bodies[1].mass: if-expression is not allowed; " + ONLY),
    case("comma", rr("    mass: m2", "    mass: 1,5"),
         "{file}:21: bodies[1].mass: a comma (a tuple; write decimals with a point, e.g. 1.5) "
         "is not allowed; " + ONLY),
    case("comprehension", rr("    mass: m2", "    mass: '[m for m in (m1, m2)]'"),
         "{file}:21: bodies[1].mass: a comprehension is not allowed; " + ONLY),
    case("generator", rr("    mass: m2", "    mass: 'sqrt(m for m in (m1, m2))'"),
         "{file}:21: bodies[1].mass: a comprehension is not allowed; " + ONLY),
    case("star-arguments", rr("    mass: m2", "    mass: 'max(*(m1, m2))'"),
         "{file}:21: bodies[1].mass: max() takes positional arguments only"),
    case("walrus", rr("    mass: m2", "    mass: (x := m2)"),
         "{file}:21: bodies[1].mass: := is not allowed; " + ONLY),
    case("empty-expression", rr("    mass: m2", "    mass: '  '"),
         "{file}:21: bodies[1].mass: empty expression"),
    case("expression-too-long", rr("    mass: m2", "    mass: " + "+".join(["m2"] * 700)),
         "{file}:21: bodies[1].mass: expression longer than 2000 characters"),
    case("expression-nested-too-deeply", rr("    mass: m2", "    mass: " + "-" * 1500 + "m2"),
         "{file}:21: bodies[1].mass: expression too deeply nested (limit 100)"),
    case("parentheses-nested-too-deeply", rr("    mass: m2",
                                             "    mass: " + "(" * 300 + "m2" + ")" * 300),
         "{file}:21: bodies[1].mass: syntax error in '" + "(" * 57 + "...' at column 201: "
         "too many nested parentheses; write an arithmetic expression such as 2*L1*cos(q1)"),
    # -- trajectory ----------------------------------------------------------------------------
    case("trajectory-unknown-coordinate", rr("to: {q1: pi/6,", "to: {q9: 1, q1: pi/6,"),
         "{file}:34: trajectory.to.q9: unknown coordinate 'q9'; coordinates: q1, q2"),
    case("trajectory-misspelt-coordinate", rr("to: {q1: pi/6,", "from: {q11: 0}, to: {q1: pi/6,"),
         "{file}:34: trajectory.from.q11: unknown coordinate 'q11' (did you mean 'q1'?); "
         "coordinates: q1, q2"),
    case("trajectory-expression-unknown-coordinate",
         rr("{kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}",
            "{kind: expression, duration: 15, expressions: {q3: sin(t)}}"),
         "{file}:34: trajectory.expressions.q3: unknown coordinate 'q3'; coordinates: q1, q2"),
    case("trajectory-expression-undefined",
         rr("{kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}",
            "{kind: expression, duration: 15, expressions: {q1: log(t)}}"),
         "{file}:34: trajectory.expressions.q1: not a finite real number at t = 0 s; q(t) must "
         "be defined for 0 <= t <= 15"),
    case("trajectory-duration-zero", rr("duration: 15", "duration: 0"),
         "{file}:34: trajectory.duration: must be positive (a duration in s), got 0"),
    case("trajectory-duration-negative", rr("duration: 15", "duration: -L1"),
         "{file}:34: trajectory.duration: must be positive (a duration in s), got -1"),
    # -- simulation settings -------------------------------------------------------------------
    case("t-end-zero", rr("t_end: 15", "t_end: 0"),
         "{file}:35: simulation.t_end: must be positive, got 0"),
    case("t-end-negative", rr("t_end: 15", "t_end: -15"),
         "{file}:35: simulation.t_end: must be positive, got -15"),
    case("t-end-infinite", rr("t_end: 15", "t_end: .inf"),
         "{file}:35: simulation.t_end: expected a finite number, got inf"),
    case("t-end-text", rr("t_end: 15", "t_end: forever"),
         "{file}:35: simulation.t_end: unknown name 'forever'; allowed here: " + RR_PARAMETERS),
    case("dt-zero", rr("output_step: 0.01", "output_step: 0"),
         "{file}:35: simulation.output_step: must be positive, got 0"),
    case("dt-negative", rr("output_step: 0.01", "output_step: -0.01"),
         "{file}:35: simulation.output_step: must be positive, got -0.01"),
    case("dt-longer-than-t-end", rr("output_step: 0.01", "output_step: 20"),
         "{file}:35: simulation.output_step: output step 20 s is longer than t_end 15 s; it "
         "must be at most t_end"),
    case("too-many-rows", rr("output_step: 0.01", "output_step: 1e-6"),
         "{file}:35: simulation.output_step: t_end / output_step = 1.5e+07 rows; at most "
         "1,000,000 (raise output_step or shorten t_end)"),
    case("rtol-negative", rr("output_step: 0.01}", "output_step: 0.01, rtol: -1e-6}"),
         "{file}:35: simulation.rtol: must be positive, got -1e-06"),
    # -- the spatial arm -----------------------------------------------------------------------
    case("rrt-prismatic-mass-zero", rrt("    mass: m3", "    mass: m3 - 40"),
         "{file}:28: bodies[2].mass: must be positive (a mass in kg), got 0"),
    case("rrt-inertia-not-symmetric-psd", rrt("{ixx: I3x, iyy: I3y, izz: I3z}",
                                              "{ixx: I3x, iyy: I3y, izz: I3z, ixy: 5}"),
         "{file}:29: bodies[2].inertia: inertia tensor must be positive semidefinite; its "
         "principal moments are -0.524938, 1, 9.52494"),
    case("rrt-law-for-unknown-actuator", rrt("    F23z:", "    F23x:"),
         "{file}:40: controller.laws.F23x: law for unknown actuator; did you mean 'F23z'? "
         "actuators: T01x, T12y, F23z"),
    case("rrt-displacement-undeclared", rrt("joint: {type: prismatic, axis: [0, 0, 1], "
                                            "origin: [0, 0, L2]}",
                                            "joint: {type: prismatic, axis: [0, 0, 1], "
                                            "origin: [0, 0, L2], displacement: q4}"),
         "{file}:27: bodies[2].joint.displacement: unknown name 'q4'; allowed here: I3x, I3y, "
         "I3z, L1, L2, g, m1, m2, m3, q1, q2, q3, pi"),
    case("rrt-gravity-component", rrt("gravity: [-g, 0, 0]", "gravity: [-g, 0, 0, 0]"),
         "{file}:8: gravity: expected a list of 3 components [x, y, z], got 4"),
]


def write(tmp_path: Path, text: str | bytes, name: str = "bad.yaml") -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


@contextlib.contextmanager
def deadline(seconds: float):
    """Fail instead of hanging (the loader's evaluation of huge numbers once hung)."""
    def expired(signum, frame):
        raise AssertionError(f"no answer within {seconds} s")
    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run(capsys, argv: list) -> tuple[int, str, str]:
    with deadline(30):
        code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))


@pytest.mark.parametrize("bad", CASES)
def test_equations_names_the_mistake(tmp_path, capsys, bad: Case):
    path = write(tmp_path, bad.text)
    code, out, err = run(capsys, ["equations", path])
    assert err == "anadyn: error: " + bad.error.replace("{file}", str(path)) + "\n"
    assert (code, out) == (2, "")


SIMULATE_CASES = ["not-yaml-unclosed-list", "empty-file", "unknown-body-key", "missing-mass",
                  "type-mass-list", "nan", "mass-zero", "inertia-triangle", "axis-zero",
                  "unknown-parent", "cycle", "duplicate-body-name", "robot-name-path",
                  "coordinate-unused", "law-for-unknown-actuator", "actuator-without-law",
                  "attribute-access", "dunder-name", "trajectory-unknown-coordinate",
                  "t-end-zero", "dt-negative", "exp-tower"]


@pytest.mark.parametrize("bad", [p for p in CASES if p.id in SIMULATE_CASES],
                         ids=lambda bad: bad.id)
def test_simulate_names_the_same_mistake_and_writes_nothing(tmp_path, capsys, bad: Case):
    path, out_dir = write(tmp_path, bad.text), tmp_path / "out"
    code, out, err = run(capsys, ["simulate", path, "--out", out_dir, "--no-plot",
                                  "--no-cache"])
    assert err == "anadyn: error: " + bad.error.replace("{file}", str(path)) + "\n"
    assert (code, out) == (2, "")
    assert not out_dir.exists()


def test_every_class_of_mistake_is_covered():
    """The issue's list, each class at least once (guards against a case being lost)."""
    ids = {p.id for p in CASES}
    required = {"not-yaml-unclosed-list", "not-a-mapping-list", "empty-file",
                "unknown-top-key", "missing-mass", "type-mass-list", "nan", "non-numeric-text",
                "mass-zero", "mass-negative", "inertia-negative-moment", "inertia-triangle",
                "axis-zero", "unknown-parent", "cycle", "duplicate-body-name", "robot-name-path",
                "coordinate-unused", "displacement-undeclared-coordinate",
                "law-for-unknown-actuator", "actuator-without-law", "syntax-error",
                "unknown-name", "attribute-access", "call-not-whitelisted", "lambda",
                "subscript", "string", "dunder-name", "trajectory-unknown-coordinate",
                "t-end-zero", "dt-zero"}
    assert required <= ids, required - ids
    assert len(ids) == len(CASES)


@pytest.mark.parametrize("option, value, message", [
    ("--t-end", "0", "--t-end must be a positive number, got 0"),
    ("--t-end", "-3", "--t-end must be a positive number, got -3"),
    ("--dt", "0", "--dt must be a positive number, got 0"),
    ("--dt", "-0.5", "--dt must be a positive number, got -0.5"),
])
def test_simulate_options_not_positive(tmp_path, capsys, option, value, message):
    path, out_dir = write(tmp_path, RR, "rr.yaml"), tmp_path / "out"
    code, out, err = run(capsys, ["simulate", path, option, value, "--out", out_dir,
                                  "--no-plot", "--no-cache"])
    assert (code, out, err) == (2, "", f"anadyn: error: {message}\n")
    assert not out_dir.exists()


def test_missing_file_and_folder(tmp_path, capsys):
    code, out, err = run(capsys, ["equations", tmp_path / "none.yaml"])
    assert (code, out, err) == (2, "", f"anadyn: error: {tmp_path / 'none.yaml'}: no such file\n")
    code, out, err = run(capsys, ["equations", tmp_path])
    assert (code, out, err) == (2, "", f"anadyn: error: {tmp_path}: is a directory, expected "
                                       "a YAML file\n")


# -- limits: size and alias bombs are refused at once ---------------------------------------
def timed(capsys, argv) -> tuple[float, int, str, str]:
    start = time.perf_counter()
    code, out, err = run(capsys, argv)
    return time.perf_counter() - start, code, out, err


def test_file_over_the_size_cap_is_refused_within_a_second(tmp_path, capsys):
    filler = "# " + "x" * 78 + "\n"
    text = RR + filler * (yamlschema.MAX_BYTES // len(filler) + 1)
    path = write(tmp_path, text, "big.yaml")
    size = path.stat().st_size
    assert size > yamlschema.MAX_BYTES == 256 * 1024
    elapsed, code, out, err = timed(capsys, ["equations", path])
    assert err == f"anadyn: error: {path}: file is {size} bytes, the limit is 262144\n"
    assert (code, out) == (2, "")
    assert elapsed < 1.0


def test_file_just_under_the_size_cap_is_read(tmp_path, capsys):
    """The cap is the limit, not a rough guess: padding up to it is still a robot."""
    text = RR + "#" * (yamlschema.MAX_BYTES - len(RR.encode()) - 1) + "\n"
    assert len(text.encode()) == yamlschema.MAX_BYTES
    code, out, err = run(capsys, ["equations", write(tmp_path, text, "rr.yaml")])
    assert (code, err) == (0, "") and out.startswith("# kane equations")


def test_text_over_the_size_cap_is_refused():
    from anadyn_cli import ModelError, robot_from_text
    with pytest.raises(ModelError, match=r"^big\.yaml: text longer than 262144 bytes$"):
        robot_from_text(RR + "#" * yamlschema.MAX_BYTES, "big.yaml")


def billion_laughs(levels: int = 10, width: int = 10) -> str:
    """width**levels copies of "lol" if expanded (10**10: some 30 GB)."""
    lines = ['lol0: &lol0 ["lol"' + ', "lol"' * (width - 1) + "]"]
    for level in range(1, levels + 1):
        lines.append(f"lol{level}: &lol{level} [" + ", ".join([f"*lol{level - 1}"] * width)
                     + "]")
    return "\n".join(lines) + "\n"


def test_alias_bomb_is_refused_within_a_second(tmp_path, capsys):
    path = write(tmp_path, billion_laughs(), "bomb.yaml")
    elapsed, code, out, err = timed(capsys, ["equations", path])
    assert err == (f"anadyn: error: {path}:2: lol1[0]: YAML aliases (*name) are not supported; "
                   "write the value out\n")
    assert (code, out) == (2, "")
    assert elapsed < 1.0


def test_alias_bomb_inside_a_robot_is_refused_within_a_second(tmp_path, capsys):
    bomb = billion_laughs().replace("\n", "\n  ")
    text = rr("description: Planar two-bar arm, absolute angles (chapter 6.3)",
              "description: Planar two-bar arm\nlaughs:\n  " + bomb.rstrip())
    path = write(tmp_path, text, "bomb.yaml")
    elapsed, code, out, err = timed(capsys, ["simulate", path, "--out", tmp_path / "out",
                                             "--no-plot", "--no-cache"])
    assert err == (f"anadyn: error: {path}:8: laughs.lol1[0]: YAML aliases (*name) are not "
                   "supported; write the value out\n")
    assert (code, out) == (2, "")
    assert elapsed < 1.0


def test_deeply_nested_yaml_is_refused(tmp_path, capsys):
    path = write(tmp_path, rr("m1: 1.0", "m1: " + "[" * 5000 + "]" * 5000), "deep.yaml")
    code, out, err = run(capsys, ["equations", path])
    assert (code, out, err) == (2, "", f"anadyn: error: {path}: YAML nested too deeply\n")


# -- the names in the docs (reference/robot-file.md), the expression module and names.py agree
def test_function_and_constant_names_agree():
    assert names.FUNCTION_NAMES == set(expressions.FUNCTIONS)
    assert names.CONSTANT_NAMES == set(expressions.CONSTANTS)
    assert names.FUNCTION_NAMES | names.CONSTANT_NAMES <= names.RESERVED_NAMES
    reference = (ROBOTS.parent / "docs" / "reference" / "robot-file.md").read_text()
    listed = re.search(r"and the functions `([^`]*)`", reference)
    assert listed and set(listed[1].split()) == names.FUNCTION_NAMES
