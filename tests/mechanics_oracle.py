"""An independent oracle: the robot's equations of motion by SymPy's
``sympy.physics.mechanics`` (KanesMethod), built from the YAML text alone.

Nothing from ``anadyn_cli`` is used here.  The YAML is read with
``yaml.safe_load``; numbers and the simple expressions that appear in the
files this oracle is used on (the random robots of ``random_robots.py`` and
``robots/rr.yaml``, ``robots/rrt.yaml``: parameters, ``pi``, ``+ - * / **``,
and joint displacements that are linear in the coordinates) are evaluated by
a small ``ast`` walker below.

Modelling (the conventions anadyn documents, restated independently):

* joint frame J = parent frame P translated by ``origin`` (P axes) and turned
  by rpy, R = Rz(yaw) Ry(pitch) Rx(roll), i.e. a body-fixed z-y'-x''
  rotation by (yaw, pitch, roll);
* revolute: body frame B = J turned about the (normalized) ``axis`` by the
  displacement; prismatic: B = J with its origin slid along ``axis`` by the
  displacement; fixed: B = J;
* mass centre at ``com`` (B axes), central inertia tensor in B axes;
* gravity (N axes) on every mass centre; an actuator on a revolute joint is a
  torque tau*axis on B and -tau*axis on P, on a prismatic joint a force
  tau*axis on B's origin and the opposite force on the coincident point of P;
* joint forces act as an actuator would, with
  tau = -damping*w - friction*tanh(w/friction_velocity) - stiffness*(theta - rest),
  theta the displacement and w its rate (friction_velocity 0.01 when not
  given);
* a load (``loads``) is a force on the point fixed in the body at ``point``
  (B axes) and a torque on B, both given in N axes (``frame: world``, the
  default) or B axes (``frame: body``), expressions of t, the coordinates
  and their rates (``d`` + name).

KanesMethod with u = q' gives M u' = forcing; M is its mass matrix, F the
forcing with tau = 0 and B = d(forcing)/d(tau).  F may contain the time, as
the plain real Symbol ``t``.
"""
from __future__ import annotations

import ast
import math
import operator

import sympy as sp
import yaml
from sympy.physics import mechanics as me

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.Pow: operator.pow}
_CALLS = {"sin": sp.sin, "cos": sp.cos, "tanh": sp.tanh, "exp": sp.exp, "sqrt": sp.sqrt}
TIME = sp.Symbol("t", real=True)


def evaluate(value, names: dict):
    """A YAML scalar: a number, or an arithmetic expression of ``names``."""
    if isinstance(value, bool):
        raise ValueError(f"not a number: {value!r}")
    if isinstance(value, (int, float)):
        return float(value)
    if not isinstance(value, str):
        raise ValueError(f"not a number or expression: {value!r}")

    def walk(node):
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id == "pi":
                return math.pi
            return names[node.id]
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = walk(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](walk(node.left), walk(node.right))
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id in _CALLS and len(node.args) == 1 and not node.keywords):
            return _CALLS[node.func.id](walk(node.args[0]))
        raise ValueError(f"unsupported expression {value!r}")

    return walk(ast.parse(value, mode="eval"))


def _vector3(data, names) -> list[float]:
    if data is None:
        return [0.0, 0.0, 0.0]
    assert len(data) == 3
    return [evaluate(v, names) for v in data]


def _number(x: float) -> sp.Expr:
    """Integral values exact (so that 1*x and 0*x stay out of the expressions)."""
    return sp.Integer(int(x)) if float(x).is_integer() else sp.Float(x)


def _in(frame, components) -> me.Vector:
    x, y, z = (_number(c) for c in components)
    return x * frame.x + y * frame.y + z * frame.z


def _expressions_in(frame, components) -> me.Vector:
    x, y, z = (sp.sympify(c) for c in components)
    return x * frame.x + y * frame.y + z * frame.z


def _along_joint(body, parent, value, label, N) -> list:
    """The loads of an effort ``value`` along a body's joint, reaction on the parent."""
    if body["kind"] == "revolute":
        torque = value * body["axis"]
        return [(body["frame"], torque)] + ([(parent["frame"], -torque)] if parent else [])
    if body["kind"] != "prismatic":
        raise ValueError("an effort along a fixed joint")
    force = value * body["axis"]
    loads = [(body["origin"], force)]
    if parent is not None:
        # the point of the parent that coincides with the body's origin
        coincident = body["joint_point"].locatenew(f"C_{label}",
                                                   body["displacement"] * body["axis"])
        coincident.v2pt_theory(body["joint_point"], N, parent["frame"])
        loads.append((coincident, -force))
    return loads


def oracle_equations(robot_yaml_text: str):
    """(q, dq, tau, M, F, B) of the robot: plain real Symbols named like the
    coordinates, ``d`` + coordinate, and the actuators; M, F, B sympy Matrices."""
    data = yaml.safe_load(robot_yaml_text)
    params: dict[str, float] = {}
    for key, value in (data.get("parameters") or {}).items():
        params[key] = evaluate(value, params)

    coordinate_names = list(data["coordinates"])
    t = me.dynamicsymbols._t
    qs = [me.dynamicsymbols(name, real=True) for name in coordinate_names]
    us = [me.dynamicsymbols("u_" + name, real=True) for name in coordinate_names]
    by_name = dict(zip(coordinate_names, qs))
    actuator_items = list((data.get("actuators") or {}).items())
    taus = {name: sp.Symbol(name, real=True) for name, _ in actuator_items}

    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    g = _vector3(data.get("gravity"), params)
    gravity = _in(N, g)

    # joints without a displacement take the coordinates in order, in file order
    default_coordinates = iter(qs)
    displacements = {}
    for item in data["bodies"]:
        joint = item["joint"]
        if joint["type"] == "fixed":
            continue
        if "displacement" in joint:
            value = evaluate(joint["displacement"], {**params, **by_name})
        else:
            value = next(default_coordinates)
        displacements[item["name"]] = sp.sympify(value)

    built = {}       # body name -> dict(frame, origin, joint_frame, joint_point, kind, axis, parent)
    pending = list(data["bodies"])
    rigid_bodies, loads = [], []
    while pending:          # parents before children (the file may list them in any order)
        progressed = False
        for item in list(pending):
            parent_name = item.get("parent", "ground")
            if parent_name != "ground" and parent_name not in built:
                continue
            pending.remove(item)
            progressed = True
            built[item["name"]] = _build_body(item, built, N, O, params,
                                              displacements.get(item["name"]),
                                              rigid_bodies, loads, gravity)
        assert progressed, "cycle in the body tree"

    for name, item in actuator_items:
        body = built[item["joint"]]
        loads += _along_joint(body, built.get(body["parent"]), taus[name], item["joint"], N)

    # joint forces: damping, smoothed Coulomb friction, springs
    rates = dict(zip(qs, us))
    for item in data["bodies"]:
        joint = item["joint"]
        if joint["type"] == "fixed":
            continue
        value = {key: evaluate(joint.get(key, default), params) for key, default in
                 (("damping", 0), ("friction", 0), ("friction_velocity", 0.01),
                  ("stiffness", 0), ("rest", 0))}
        theta = displacements[item["name"]]
        w = sum(theta.diff(q) * u for q, u in rates.items())
        effort = (-value["damping"] * w
                  - value["friction"] * sp.tanh(w / value["friction_velocity"])
                  - value["stiffness"] * (theta - value["rest"]))
        if effort != 0:
            body = built[item["name"]]
            loads += _along_joint(body, built.get(body["parent"]), effort,
                                  f"{item['name']}_passive", N)

    # external loads
    names = {**params, **by_name, "t": t}
    names.update({"d" + name: u for name, u in zip(coordinate_names, us)})
    for k, entry in enumerate(data.get("loads") or []):
        body = built[entry["body"]]
        frame = N if entry.get("frame", "world") == "world" else body["frame"]
        if "force" in entry:
            point = body["origin"].locatenew(f"P_load{k}",
                                             _in(body["frame"], _vector3(entry.get("point"),
                                                                         params)))
            point.v2pt_theory(body["origin"], N, body["frame"])
            loads.append((point, _expressions_in(frame, [evaluate(c, names)
                                                         for c in entry["force"]])))
        if "torque" in entry:
            loads.append((body["frame"], _expressions_in(frame, [evaluate(c, names)
                                                                 for c in entry["torque"]])))

    kd = [q.diff(t) - u for q, u in zip(qs, us)]
    kane = me.KanesMethod(N, q_ind=qs, u_ind=us, kd_eqs=kd)
    kane.kanes_equations(rigid_bodies, loads)
    M = kane.mass_matrix
    forcing = kane.forcing

    q_symbols = [sp.Symbol(name, real=True) for name in coordinate_names]
    dq_symbols = [sp.Symbol("d" + name, real=True) for name in coordinate_names]
    replace = {**dict(zip(us, dq_symbols)), **dict(zip(qs, q_symbols))}
    M = sp.Matrix(M).xreplace(replace)
    forcing = sp.Matrix(forcing).xreplace(replace).xreplace({t: TIME})
    tau_symbols = [taus[name] for name, _ in actuator_items]
    B = forcing.jacobian(tau_symbols) if tau_symbols else sp.zeros(len(qs), 0)
    F = forcing.xreplace({tau: 0 for tau in tau_symbols})
    for matrix in (M, F, B):
        leftover = {s for s in matrix.free_symbols
                    if s not in set(q_symbols) | set(dq_symbols) | {TIME}}
        leftover |= matrix.atoms(sp.Derivative, sp.core.function.AppliedUndef)
        assert not leftover, f"oracle left {leftover} in its equations"
    return q_symbols, dq_symbols, tau_symbols, M, F, B


def _build_body(item, built, N, O, params, displacement, rigid_bodies, loads, gravity):
    name = item["name"]
    parent_name = item.get("parent", "ground")
    if parent_name == "ground":
        P, P_origin = N, O
    else:
        P, P_origin = built[parent_name]["frame"], built[parent_name]["origin"]
    joint = item["joint"]
    kind = joint["type"]
    origin = _vector3(joint.get("origin"), params)
    roll, pitch, yaw = _vector3(joint.get("rpy"), params)

    if roll == pitch == yaw == 0:
        J = P                   # no turn: the joint axes are the parent's axes
    else:
        J = me.ReferenceFrame(f"J_{name}")
        J.orient_body_fixed(P, tuple(map(_number, (yaw, pitch, roll))), "zyx")
    joint_point = P_origin.locatenew(f"Oj_{name}", _in(P, origin))
    joint_point.v2pt_theory(P_origin, N, P)

    axis = None
    if kind != "fixed":
        a = _vector3(joint["axis"], params)
        norm = math.sqrt(sum(c * c for c in a))
        a = [c / norm for c in a]
        axis = _in(J, a)

    if kind == "revolute":
        B = me.ReferenceFrame(f"B_{name}")
        B.orient_axis(J, axis, displacement)
        body_origin = joint_point
        axis = _in(B, a)     # the same vector, in B axes
        # the same angular velocity, but in B axes (as the inertia dyadic): far
        # smaller expressions than orient_axis's J-axes form
        B.set_ang_vel(J, displacement.diff(me.dynamicsymbols._t) * axis)
    elif kind == "prismatic":
        B = J                   # may be the parent's frame itself (same axes)
        body_origin = joint_point.locatenew(f"Ob_{name}", displacement * axis)
        body_origin.set_vel(P, displacement.diff(me.dynamicsymbols._t) * axis)
        body_origin.v1pt_theory(joint_point, N, P)
    elif kind == "fixed":
        B = J                   # may be the parent's frame itself (same axes)
        body_origin = joint_point
    else:
        raise ValueError(f"unknown joint type {kind!r}")

    mass = _number(evaluate(item["mass"], params))
    com = _vector3(item.get("com"), params)
    G = body_origin.locatenew(f"G_{name}", _in(B, com))
    G.v2pt_theory(body_origin, N, B)
    entries = {k: 0.0 for k in ("ixx", "iyy", "izz", "ixy", "iyz", "ixz")}
    for key, value in (item.get("inertia") or {}).items():
        entries[key] = evaluate(value, params)
    e = {key: _number(value) for key, value in entries.items()}
    dyadic = me.inertia(B, e["ixx"], e["iyy"], e["izz"], e["ixy"], e["iyz"], e["ixz"])
    rigid_bodies.append(me.RigidBody(f"body_{name}", G, B, mass, (dyadic, G)))
    loads.append((G, mass * gravity))
    return {"frame": B, "origin": body_origin, "joint_point": joint_point, "kind": kind,
            "axis": axis, "displacement": displacement, "parent": parent_name}
