"""The generated Python module: one function per traced program (scalar, or
vectorized over NumPy arrays for the functions in VECTORIZED), the tables of
the Cholesky factor and the names of the coordinates and efforts.
"""
from __future__ import annotations

from ...model.robot import Robot
from ..native import VECTOR_MARK
from ..printers import python_expr, python_lines
from .factor import factor_tables
from .trace import Generated, Traced, generate


def _matrix_output(value) -> bool:
    return bool(value) and isinstance(value[0], list)


def _python_function(tr: Traced, vectorized: bool, doc: str) -> list[str]:
    lines = [f"def {tr.name}({', '.join(tr.args)}):", f'    """{doc}"""']
    if vectorized:
        shapes = ", ".join(f"numpy.shape({a})" for a in tr.args)
        lines.append(f"    _shape = numpy.broadcast_shapes({shapes})")
    lines += python_lines(tr.statements, vectorized)
    returned = []
    for name, value in tr.outputs.items():
        out = f"_out_{name}"
        if not vectorized:
            if _matrix_output(value):
                rows = ", ".join("[" + ", ".join(python_expr(x) for x in row) + "]"
                                 for row in value)
                lines.append(f"    {out} = numpy.array([{rows}])")
            else:
                lines.append(f"    {out} = [{', '.join(python_expr(x) for x in value)}]")
        else:
            matrix = _matrix_output(value)
            dims = f"{len(value)}, {len(value[0]) if value else 0}" if matrix else f"{len(value)},"
            if matrix and not value:
                dims = "0, 0"
            lines.append(f"    {out} = numpy.zeros(_shape + ({dims}))")
            cells = ([((i, j), x) for i, row in enumerate(value) for j, x in enumerate(row)]
                     if matrix else [((i,), x) for i, x in enumerate(value)])
            for index, x in cells:
                if not x.is_zero():
                    where = ", ".join(map(str, index))
                    lines.append(f"    {out}[..., {where}] = {python_expr(x)}")
        returned.append(out)
    lines.append(f"    return {', '.join(returned)}")
    return lines


PY_HEADER = """\
import functools
import math
import numpy
from math import sin as _sin, cos as _cos, sqrt as _sqrt, tanh as _tanh
_singular = numpy.linalg.LinAlgError
"""

VEC_HEADER = """\
_vsin, _vcos, _vsqrt, _vtanh = numpy.sin, numpy.cos, numpy.sqrt, numpy.tanh
"""


DOCS = {
    "factor": "ddq, 1/L_jj and L_ij (i > j) of P M P^T = L L^T (CRBA, sparse Cholesky; "
              "positions in FACTOR) for the Jacobian.",
    "accelerations": "ddq solving M(q) ddq = F + B tau(t, q, dq) (recursive: CRBA with an "
                     "unrolled sparse Cholesky, or the articulated-body algorithm, whichever "
                     "costs fewer operations; scalar floats).",
    "dynamics_jacobian": "M and K = -dID/d[q, dq] at fixed ddq = [dG/dq - (dM/dq) ddq | dG/ddq]; "
                         "d(ddq)/dx = M^-1 K (scalar).",
    "driven_accelerations": "ddq solving M(q) ddq = F + B e for given actuator efforts e "
                            "(CRBA, sparse Cholesky; scalar floats).",
    "efforts": "Actuator efforts under the control laws (vectorized).",
    "mfb": "M, F and B of M ddq = F + B tau (vectorized).",
    "inverse_dynamics": "ID = M ddq - F by the recursive Newton-Euler algorithm, O(n) "
                        "(vectorized).",
    "actuation": "B of M ddq = F + B tau (vectorized).",
    "potential": "Potential energy V of gravity and joint springs (vectorized).",
    "rates": "The coordinates' rates dq = W(q) u (a spherical joint's quaternion: "
             "1/2 q (x) (0, w); vectorized).",
    "powers": "[power of the loads, power dissipated by joint damping and friction], W "
              "(recursive velocities; vectorized).",
    "momentum": "[Px, Py, Pz] (kg m/s) and [Lx, Ly, Lz] (kg m^2/s, about the world "
                "origin) of a free robot, world axes (recursive velocities; vectorized).",
    "contacts": "Per contact: normal force, friction along t1 and t2 (N), penetration (m), "
                "spring energy (J), dissipated power (W), the contact point's velocity "
                "along n, t1, t2 (m/s) (numeric.contact; vectorized).",
}

VECTORIZED = {"efforts", "mfb", "inverse_dynamics", "actuation", "potential", "rates",
              "powers", "momentum", "contacts"}


def module_source(gen: Generated, header: str = "") -> str:
    """Python source with COORDINATES, EFFORTS and the six functions."""
    pl = gen.plan
    names = {f"_q{k}": c for k, c in enumerate(pl.coordinates)}
    names.update({f"_u{k}": u for k, u in enumerate(pl.speeds)})
    names.update({f"_w{k}": "d" + u for k, u in enumerate(pl.speeds)})
    names.update({f"_e{k}": e for k, e in enumerate(pl.efforts)})
    names["_t"] = "t"
    lines = [f"# {line}" for line in header.splitlines()] + [PY_HEADER, VEC_HEADER]
    for name, tr in gen.functions.items():
        vectorized = name in VECTORIZED
        if name == "mfb":
            lines.append(VECTOR_MARK)
        c = tr.counts
        doc = (f"{DOCS[name]}\n\n    Arguments: {', '.join(names[a] for a in tr.args)}.\n"
               f"    Operations: {c.mul} multiplications, {c.add} additions, {c.div} divisions, "
               f"{c.calls} calls, {c.other} in expressions.\n    ")
        body = _python_function(tr, vectorized, doc)
        if vectorized:
            body = [line.replace("_sin(", "_vsin(").replace("_cos(", "_vcos(")
                    .replace("_sqrt(", "_vsqrt(").replace("_tanh(", "_vtanh(")
                    for line in body]
        lines += body + [""]
    lines.append(f"FACTOR = {factor_tables(gen.factor, pl.n)!r}")
    B = gen.functions["actuation"].outputs["B"]
    lines.append(f"CONSTANT_ACTUATION = {all(x.constant() is not None for row in B for x in row)}")
    lines.append(f"COORDINATES = {tuple(pl.coordinates)!r}")
    lines.append(f"EFFORTS = {tuple(pl.efforts)!r}")
    if pl.contacts:
        lines.append(f"CONTACTS = {tuple(c.name for c in pl.contacts)!r}")
        laws = tuple((c.stiffness, c.exponent, pl.bodies[c.body].mass) for c in pl.contacts)
        lines.append(f"CONTACT_LAWS = {laws!r}   # stiffness, exponent, the body's mass")
        friction = tuple(c.friction for c in pl.contacts)
        lines.append(f"CONTACT_FRICTION = {friction!r}   # mu (the rigid model's kinetic one)")
        if pl.contacts[0].rigid:       # numeric.impacts: e, mu, the bodies, a pair's size
            rules = tuple((c.restitution, c.friction, tuple(
                pl.bodies[b].name for b in (c.body, c.partner) if b is not None),
                c.radius + c.partner_radius if c.partner is not None else 0.0,
                c.static_friction) for c in pl.contacts)
            lines.append(f"RIGID_CONTACTS = {rules!r}   # e, mu (kinetic), bodies, radii of "
                         "a pair, mu_s (static)")
    if pl.spherical:          # speeds that are not rates: x = [q, u], dq = W(q) u
        lines.append(f"SPEEDS = {tuple(pl.speeds)!r}")
        lines.append(f"QUATERNIONS = {quaternions(pl)!r}")
    if "momentum" in gen.functions:     # a free robot: what acts on it from outside
        lines.append(f"GRAVITY = {tuple(pl.gravity)!r}")
        lines.append(f"EXTERNAL = {bool(pl.loads or pl.contacts)!r}   # loads or contacts")
    return "\n".join(lines) + "\n"


def quaternions(pl) -> tuple:
    """The coordinate indices of each spherical joint's quaternion (qw, qx, qy, qz)."""
    return tuple(tuple(b.quaternion) for b in pl.bodies if b.quaternion)


def source(robot: Robot) -> str:
    """The generated module's source for ``robot``."""
    from ... import __version__
    header = (f"generated by anadyn {__version__} from {robot.source} (recursive)\n"
              f"robot {robot.name}: coordinates {', '.join(c.name for c in robot.coordinates)}; "
              f"efforts {', '.join(a.name for a in robot.actuators) or 'none'}")
    return module_source(generate(robot), header)
