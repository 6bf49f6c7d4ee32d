"""The functions the CasADi and JAX exports build, traced once from the recursive dynamics.

For n coordinates and m actuators (state names as in the robot file):

    forward_dynamics(t, q, dq, tau) -> ddq (n)     M ddq = F + B tau  (CRBA + Cholesky)
    inverse_dynamics(t, q, dq, ddq) -> tau (m)     tau = pinv(B) (M ddq - F)  (RNEA)
    mass_matrix(q)                  -> M (n x n)   (CRBA)

Each is a straight-line program of ``numeric.ir`` statements (``recursive.trace``:
``trace_driven``, ``trace_inverse`` with ``trace_actuation``, ``trace_mfb``): the
same statements the native and Python evaluators run, so an export computes
what ``anadyn.numeric_model`` computes.  The efforts are the given ``tau``, not
the file's control laws.  The inverse dynamics needs B constant (actuators on
joints whose displacement is linear in q, the usual case): pinv(B) is then
folded in as numbers (exact for B = I).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ModelError
from ...numeric.ir import Ex, prune
from ...numeric.recursive import plan
from ...numeric.recursive.trace import trace_actuation, trace_driven, trace_inverse, trace_mfb

#: argument name -> prefix of its atoms in the traced statements
ATOMS = {"t": "_t", "q": "_q", "dq": "_u", "ddq": "_w", "tau": "_e"}


@dataclass
class Function:
    """One function: arguments (name, size), statements, its output's name and
    values (flat, row-major) and shape."""
    name: str
    args: list[tuple[str, int]]
    output: str
    statements: list
    outputs: list[Ex]
    shape: tuple[int, ...]
    doc: str

    def atoms(self, arg: str, size: int) -> list[str]:
        return ["_t"] if arg == "t" else [f"{ATOMS[arg]}{k}" for k in range(size)]


@dataclass
class Traced:
    robot_name: str
    coordinates: list[str]
    efforts: list[str]
    functions: dict[str, Function]
    n: int                           # coordinates
    m: int                           # actuators


def trace(robot) -> Traced:
    """The three functions of ``robot`` (a validated open-chain ``Robot``); ModelError
    when B depends on the state (no constant pinv(B) for the inverse dynamics)."""
    robot.refuse_spherical("exports and optimal motions (export, optimize)")
    robot.refuse_contacts("exports and optimal motions (export, optimize)")
    pl = plan(robot)
    n, m = pl.n, len(pl.actuator_joint)
    B = trace_actuation(pl).outputs["B"]
    if any(x.constant() is None for row in B for x in row):
        raise ModelError("the actuation matrix B depends on the state; the CasADi and JAX "
                         "exports need actuators on joints whose displacement is linear in q",
                         source=robot.source)
    P = np.linalg.pinv(np.array([[x.constant() for x in row] for row in B]).reshape(n, m))
    driven = trace_driven(pl)
    inverse = trace_inverse(pl)
    ID = inverse.outputs["ID"]
    tau = [sum((ID[j].scale(P[k, j]) for j in range(n)), Ex()) for k in range(m)]
    mfb = trace_mfb(pl)
    M = [x for row in mfb.outputs["M"] for x in row]
    M_statements = prune(mfb.statements, M)
    if any(a == "_t" for s in M_statements for a in s.atoms()):
        raise ModelError("the mass matrix depends on t; the CasADi and JAX exports need "
                         "M(q)", source=robot.source)
    functions = {
        "forward_dynamics": Function(
            "forward_dynamics", [("t", 1), ("q", n), ("dq", n), ("tau", m)], "ddq",
            driven.statements, driven.outputs["ddq"], (n,),
            "ddq solving M(q) ddq = F(t, q, dq) + B tau"),
        "inverse_dynamics": Function(
            "inverse_dynamics", [("t", 1), ("q", n), ("dq", n), ("ddq", n)], "tau",
            inverse.statements, tau, (m,), "tau = pinv(B) (M(q) ddq - F(t, q, dq))"),
        "mass_matrix": Function("mass_matrix", [("q", n)], "M", M_statements, M, (n, n),
                                "M(q), symmetric positive definite"),
    }
    return Traced(robot.name, [c.name for c in robot.coordinates],
                  [a.name for a in robot.actuators], functions, n, m)
