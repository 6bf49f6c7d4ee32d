"""SymPy expressions -> source of a small Python module with numeric functions.

Every function is generated from plain matrices (as pydy does), with common
subexpressions eliminated (``sympy.cse``) across all of its outputs.  Scalar
functions use ``math`` on Python floats (the integrators call them once per
step); vectorized ones use NumPy over arrays of any shape and broadcast
constant entries.  Each function writes into fresh arrays and documents its
argument order.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.pycode import PythonCodePrinter


@dataclass(frozen=True)
class Function:
    """One generated function: ``name(*args)`` returns ``outputs`` in order.

    An output given as a list of expressions is a vector (shape (k,)); one
    given as a Matrix keeps both dimensions, even with a single column.
    """
    name: str
    args: tuple[sp.Symbol, ...]
    outputs: tuple[tuple[str, sp.Matrix | list], ...]
    vectorized: bool
    doc: str


def module_source(functions: list[Function], header: str) -> str:
    lines = [f"# {line}" for line in header.splitlines()]
    lines += ["import functools", "import math", "import numpy", ""]
    for function in functions:
        lines += _function_source(function) + [""]
    return "\n".join(lines)


def _head(f: Function, flat: list, printer) -> tuple[list[str], list]:
    """The def line, docstring and cse temporaries of ``f``; the reduced ``flat``."""
    temps, reduced = sp.cse(flat, symbols=sp.numbered_symbols("_x"), order="none")
    names = ", ".join(str(a) for a in f.args)
    body = [f"def {f.name}({names}):", f'    """{f.doc}"""']
    if f.vectorized:
        shapes = ", ".join(f"numpy.shape({a})" for a in f.args)
        body.append(f"    _shape = numpy.broadcast_shapes({shapes})")
    body += [f"    {symbol} = {printer.doprint(expr)}" for symbol, expr in temps]
    return body, reduced


def _function_source(f: Function) -> list[str]:
    printer = (NumPyPrinter({"fully_qualified_modules": True}) if f.vectorized
               else PythonCodePrinter({"fully_qualified_modules": True}))
    body, reduced = _head(f, [e for _, m in f.outputs for e in m], printer)
    position = 0
    returned = []
    for name, value in f.outputs:
        out_name = f"_{name}"     # robot names start with a letter: no clash with an argument
        vector = not isinstance(value, sp.MatrixBase)
        matrix = sp.Matrix(value)
        rows, cols = matrix.shape
        dims = f"{rows}," if vector else f"{rows}, {cols}"
        shape = f"_shape + ({dims})" if f.vectorized else f"({dims})"
        body.append(f"    {out_name} = numpy.zeros({shape})")
        for i in range(rows):
            for j in range(cols):
                expr = reduced[position]
                position += 1
                if expr != 0:
                    index = f"..., {i}" if f.vectorized else f"{i}"
                    index += "" if vector else f", {j}"
                    body.append(f"    {out_name}[{index}] = {printer.doprint(expr)}")
        returned.append(out_name)
    body.append(f"    return {', '.join(returned)}")
    return body



#: largest n solved by the unrolled factorization; beyond it numpy.linalg.solve
#: (the unrolled code grows like n^3 / 6 lines)
UNROLLED_MAX = 10


def solver_source(name: str, args: tuple[sp.Symbol, ...], M: sp.Matrix, G: list,
                  doc: str) -> list[str]:
    """``name(*args)`` -> the list a solving M a = G, M symmetric positive definite.

    For n <= UNROLLED_MAX the Cholesky factorization M = L L^T and the two
    triangular solves L y = G, L^T a = y are unrolled over Python floats
    (L_jj = sqrt(M_jj - sum_k L_jk^2), L_ij = (M_ij - sum_k L_ik L_jk) / L_jj),
    skipping entries of L that are structurally zero: a diagonal M costs n
    divisions.  A pivot that is not positive raises numpy.linalg.LinAlgError
    (M singular or not positive definite); a NaN passes through to the caller.
    """
    n = M.rows
    if n > UNROLLED_MAX:
        return _function_source(Function(name, args, (("M", M), ("G", list(G))), False, doc)
                                )[:-1] + ["    return numpy.linalg.solve(_M, _G).tolist()"]
    pairs = [(i, j) for i in range(n) for j in range(i + 1)]
    printer = PythonCodePrinter({"fully_qualified_modules": True})
    body, reduced = _head(Function(name, args, (), False, doc),
                          [M[i, j] for i, j in pairs] + list(G), printer)
    entry = dict(zip(pairs, reduced))
    nonzero = {pair: entry[pair] != 0 for pair in pairs}
    body.append("    _singular = numpy.linalg.LinAlgError")
    for j in range(n):
        body.append(f"    _d = {printer.doprint(entry[j, j])}"
                    + "".join(f" - _L{j}_{k}**2" for k in range(j) if nonzero[j, k]))
        body.append("    if _d <= 0.0:")
        body.append(f"        raise _singular('mass matrix not positive definite (pivot {j})')")
        body.append(f"    _L{j}_{j} = math.sqrt(_d)")
        for i in range(j + 1, n):
            products = [k for k in range(j) if nonzero[i, k] and nonzero[j, k]]
            nonzero[i, j] = nonzero[i, j] or bool(products)
            if nonzero[i, j]:
                body.append(f"    _L{i}_{j} = ({printer.doprint(entry[i, j])}"
                            + "".join(f" - _L{i}_{k}*_L{j}_{k}" for k in products)
                            + f") / _L{j}_{j}")
    for i in range(n):
        body.append(f"    _y{i} = ({printer.doprint(reduced[len(pairs) + i])}"
                    + "".join(f" - _L{i}_{k}*_y{k}" for k in range(i) if nonzero[i, k])
                    + f") / _L{i}_{i}")
    for i in reversed(range(n)):
        body.append(f"    _a{i} = (_y{i}" + "".join(f" - _L{k}_{i}*_a{k}" for k in range(i + 1, n)
                                                    if nonzero[k, i]) + f") / _L{i}_{i}")
    body.append("    return [" + ", ".join(f"_a{i}" for i in range(n)) + "]")
    return body
