"""The forward dynamics' linear algebra: M ddq = G solved by an unrolled sparse
Cholesky factorization P M P^T = L L^T in an elimination order that takes
leaves first (greedy minimum fill), so that a tree's factor has no fill-in.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..ir import ZERO, Ex, Program


def elimination_order(pattern: list[set[int]]) -> list[int]:
    """Greedy minimum-fill order (ties: fewest neighbours, then last index first):
    on a tree's mass matrix it takes leaves first and adds no fill-in."""
    n = len(pattern)
    graph = {i: set(pattern[i]) - {i} for i in range(n)}
    order = []
    while graph:
        def fill(v):
            nb = list(graph[v])
            return sum(1 for x in range(len(nb)) for y in range(x) if nb[y] not in graph[nb[x]])
        v = min(graph, key=lambda v: (fill(v), len(graph[v]), -v))
        nb = graph.pop(v)
        for x in nb:
            graph[x] |= nb - {x}
            graph[x].discard(v)
        order.append(v)
    return order


@dataclass
class Factor:
    order: list[int]                      # elimination order (coordinate indices)
    inv: list[Ex]                         # 1 / L_jj
    L: dict[tuple[int, int], Ex]          # L_ij, i > j, positions in the order


def cholesky(P: Program, M: list[list[Ex]]) -> Factor:
    """P M P^T = L L^T unrolled, L_jj = sqrt(d_j), d_j = A_jj - sum_k L_jk^2 checked > 0,
    L_ij = (A_ij - sum_k L_ik L_jk) / L_jj; entries that are structurally zero skipped."""
    n = len(M)
    pattern = [{s for s in range(n) if not M[r][s].is_zero()} for r in range(n)]
    order = elimination_order(pattern)
    A = [[M[order[i]][order[j]] for j in range(n)] for i in range(n)]
    L: dict[tuple[int, int], Ex] = {}
    inv: list[Ex] = []
    for j in range(n):
        d = A[j][j] - sum((L[j, k] * L[j, k] for k in range(j) if (j, k) in L), ZERO)
        d = P.check_positive(P.emit(d), f"mass matrix not positive definite (pivot {j})")
        inv_j = P.call("recip", P.call("sqrt", d))
        inv.append(inv_j)
        for i in range(j + 1, n):
            value = A[i][j] - sum((L[i, k] * L[j, k] for k in range(j)
                                   if (i, k) in L and (j, k) in L), ZERO)
            if not value.is_zero():
                L[i, j] = P.emit(value * inv_j)
    return Factor(order, inv, L)


def solve(P: Program, fac: Factor, G: list[Ex]) -> list[Ex]:
    """x with M x = G: L y = P G, L^T z = y, x = P^T z."""
    n = len(G)
    y = []
    for i in range(n):
        value = G[fac.order[i]] - sum((fac.L[i, k] * y[k] for k in range(i) if (i, k) in fac.L),
                                      ZERO)
        y.append(P.emit(value * fac.inv[i]))
    z = [None] * n
    for i in reversed(range(n)):
        value = y[i] - sum((fac.L[k, i] * z[k] for k in range(i + 1, n) if (k, i) in fac.L), ZERO)
        z[i] = P.emit(value * fac.inv[i])
    x = [None] * n
    for i in range(n):
        x[fac.order[i]] = z[i]
    return x


def factor_tables(fac: Factor, n: int):
    """(order, rows, cols): the elimination order; for each position i the
    entries (k, index into factor()'s L list) of row i (k < i) and of column i
    (k > i) of L."""
    keys = sorted(fac.L)
    index = {key: k for k, key in enumerate(keys)}
    rows = [[(k, index[i, k]) for k in range(i) if (i, k) in fac.L] for i in range(n)]
    cols = [[(k, index[k, i]) for k in range(i + 1, n) if (k, i) in fac.L] for i in range(n)]
    return (list(fac.order), rows, cols)
