"""anadyn's equations of motion against an independent oracle.

For random robots (``random_robots.py``) and the two book robots, Kane's
method and Lagrange's equations as derived by anadyn must agree with the
equations that ``sympy.physics.mechanics.KanesMethod`` derives from the same
YAML (``mechanics_oracle.py``) and with each other, and M(q) must be
symmetric positive definite, all at random states (q, dq).

Agreement is measured as max|A - B| / max(1, max|B|) over a matrix, and must
be within 1e-10.
"""
from __future__ import annotations

import functools
import math
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from anadyn_cli import derive, robot_from_text

from mechanics_oracle import oracle_equations
from random_robots import random_robot_yaml

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
SEEDS = range(30)
STATES = 3
TOLERANCE = 1e-10
CASES = [f"seed{seed}" for seed in SEEDS] + ["rr", "rrt"]


def robot_text(case: str) -> str:
    if case.startswith("seed"):
        return random_robot_yaml(int(case[4:]))
    return (ROBOTS / f"{case}.yaml").read_text()


# -- numeric evaluation -------------------------------------------------------
_FUNCTIONS = {sp.sin: math.sin, sp.cos: math.cos, sp.tan: math.tan, sp.exp: math.exp,
              sp.log: math.log, sp.asin: math.asin, sp.acos: math.acos, sp.atan: math.atan}


def _value(expr: sp.Expr, values: dict, memo: dict) -> float:
    """``expr`` at ``values`` in floating point, each shared subexpression once."""
    found = memo.get(expr)
    if found is not None:
        return found
    if expr.is_Symbol:
        result = values[expr]
    elif expr.is_Number or expr.is_NumberSymbol:
        result = float(expr)
    elif expr.is_Add:
        result = math.fsum(_value(a, values, memo) for a in expr.args)
    elif expr.is_Mul:
        result = 1.0
        for a in expr.args:
            result *= _value(a, values, memo)
    elif expr.is_Pow:
        result = _value(expr.base, values, memo) ** _value(expr.exp, values, memo)
    elif expr.func in _FUNCTIONS:
        result = _FUNCTIONS[expr.func](*(_value(a, values, memo) for a in expr.args))
    elif not expr.free_symbols:
        result = float(expr)
    else:
        raise TypeError(f"cannot evaluate {type(expr).__name__}: {expr}")
    memo[expr] = result
    return result


def evaluate(matrix: sp.MatrixBase, values: dict) -> np.ndarray:
    memo: dict = {}
    return np.array([[_value(sp.sympify(matrix[i, j]), values, memo)
                      for j in range(matrix.cols)] for i in range(matrix.rows)],
                    dtype=float).reshape(matrix.shape)


def relative_difference(a: np.ndarray, reference: np.ndarray) -> float:
    assert a.shape == reference.shape, (a.shape, reference.shape)
    if a.size == 0:
        return 0.0
    return float(np.abs(a - reference).max() / max(1.0, np.abs(reference).max()))


# -- the cases, derived once each -------------------------------------------------
@dataclass(frozen=True)
class Numeric:
    M: np.ndarray
    F: np.ndarray
    B: np.ndarray


@dataclass(frozen=True)
class Case:
    text: str
    states: tuple[tuple[np.ndarray, np.ndarray], ...]
    oracle: tuple[Numeric, ...]          # one per state
    kane: tuple[Numeric, ...]
    lagrange: tuple[Numeric, ...]


def _numeric(q, dq, M, F, B, states) -> tuple[Numeric, ...]:
    result = []
    for q_value, dq_value in states:
        values = {**dict(zip(q, map(float, q_value))), **dict(zip(dq, map(float, dq_value)))}
        result.append(Numeric(evaluate(M, values), evaluate(F, values), evaluate(B, values)))
    return tuple(result)


@functools.lru_cache(maxsize=None)
def case(name: str) -> Case:
    text = robot_text(name)
    robot = robot_from_text(text, f"{name}.yaml")
    q, dq, tau, M, F, B = oracle_equations(text)
    n = len(q)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    states = tuple((rng.uniform(-math.pi, math.pi, n), rng.uniform(-2.0, 2.0, n))
                   for _ in range(STATES))
    eoms = {method: derive(robot, method) for method in ("kane", "lagrange")}
    for eom in eoms.values():      # same unknowns, same order, as the oracle
        assert [s.name for s in eom.q] == [s.name for s in q]
        assert [s.name for s in eom.dq] == [s.name for s in dq]
        assert [s.name for s in eom.efforts] == [s.name for s in tau]
        assert eom.M.shape == (n, n) and eom.F.shape == (n, 1) and eom.B.shape == (n, len(tau))
        assert eom.M.free_symbols | eom.F.free_symbols | eom.B.free_symbols <= set(q) | set(dq)
    return Case(text, states, _numeric(q, dq, M, F, B, states),
                *(_numeric(eom.q, eom.dq, eom.M, eom.F, eom.B, states)
                  for eom in eoms.values()))


def _compare(found: tuple[Numeric, ...], reference: tuple[Numeric, ...], what: str) -> None:
    worst = {}
    for k, (a, b) in enumerate(zip(found, reference)):
        for part in "MFB":
            difference = relative_difference(getattr(a, part), getattr(b, part))
            worst[part] = max(worst.get(part, 0.0), difference)
            assert difference <= TOLERANCE, (
                f"{what}: {part} differs by {difference:.3g} (relative) at state {k}\n"
                f"found:\n{getattr(a, part)}\nexpected:\n{getattr(b, part)}")


@pytest.mark.parametrize("name", CASES)
def test_kane_matches_oracle(name):
    c = case(name)
    _compare(c.kane, c.oracle, "kane vs sympy.physics.mechanics")


@pytest.mark.parametrize("name", CASES)
def test_lagrange_matches_oracle(name):
    c = case(name)
    _compare(c.lagrange, c.oracle, "lagrange vs sympy.physics.mechanics")


@pytest.mark.parametrize("name", CASES)
def test_kane_matches_lagrange(name):
    c = case(name)
    _compare(c.kane, c.lagrange, "kane vs lagrange")


@pytest.mark.parametrize("name", CASES)
def test_mass_matrix_symmetric_positive_definite(name):
    c = case(name)
    for method, results in (("kane", c.kane), ("lagrange", c.lagrange), ("oracle", c.oracle)):
        for k, result in enumerate(results):
            M = result.M
            scale = max(1.0, np.abs(M).max())
            asymmetry = np.abs(M - M.T).max() / scale
            assert asymmetry <= 1e-12, f"{method}: M not symmetric ({asymmetry:.3g}) at state {k}"
            try:
                np.linalg.cholesky(M)
            except np.linalg.LinAlgError:
                pytest.fail(f"{method}: M not positive definite at state {k}; "
                            f"eigenvalues {np.linalg.eigvalsh(M)}")


# -- the oracle and the generator themselves ------------------------------------------
def test_oracle_matches_textbook_rr():
    """The oracle on robots/rr.yaml (absolute angles, joint 2 turns by q2 - q1)
    gives the textbook equations of a planar two-bar arm."""
    q, dq, tau, M, F, B = oracle_equations(robot_text("rr"))
    L1 = L2 = m1 = m2 = 1.0
    g = 9.81
    rng = np.random.default_rng(7)
    for _ in range(3):
        (q1, q2), (u1, u2) = rng.uniform(-3, 3, 2), rng.uniform(-2, 2, 2)
        values = dict(zip([*q, *dq], [q1, q2, u1, u2]))
        c = math.cos(q2 - q1)
        s = math.sin(q2 - q1)
        M_book = np.array([[m1 * L1**2 / 3 + m2 * L1**2, m2 * L1 * L2 / 2 * c],
                           [m2 * L1 * L2 / 2 * c, m2 * L2**2 / 3]])
        F_book = np.array([[m2 * L1 * L2 / 2 * s * u2**2
                            - (m1 / 2 + m2) * g * L1 * math.cos(q1)],
                           [-m2 * L1 * L2 / 2 * s * u1**2 - m2 * g * L2 / 2 * math.cos(q2)]])
        B_book = np.array([[1.0, -1.0], [0.0, 1.0]])
        assert relative_difference(evaluate(M, values), M_book) <= TOLERANCE
        assert relative_difference(evaluate(F, values), F_book) <= TOLERANCE
        assert relative_difference(evaluate(B, values), B_book) <= TOLERANCE


def test_random_robots_are_deterministic_valid_and_varied():
    import yaml

    texts = [random_robot_yaml(seed) for seed in SEEDS]
    assert texts == [random_robot_yaml(seed) for seed in SEEDS]
    features = set()
    for seed, text in zip(SEEDS, texts):
        robot = robot_from_text(text, f"seed{seed}.yaml")
        data = yaml.safe_load(text)
        bodies = data["bodies"]
        kinds = {b["joint"]["type"] for b in bodies}
        parents = [b.get("parent", "ground") for b in bodies]
        features |= kinds
        features.add(f"{len(bodies)} bodies")
        if len(set(parents)) < len(parents):
            features.add("branch")
        if any(" " in str(b["joint"].get("displacement", "")) for b in bodies):
            features.add("combination")
        if any("displacement" not in b["joint"] and b["joint"]["type"] != "fixed"
               for b in bodies):
            features.add("default displacement")
        if not any(float(g) for g in data.get("gravity", [0, 0, 0])):
            features.add("no gravity")
        assert len(robot.actuators) == len(robot.coordinates)
    for wanted in ("revolute", "prismatic", "fixed", "5 bodies", "6 bodies", "branch",
                   "combination", "default displacement", "no gravity"):
        assert wanted in features, wanted
