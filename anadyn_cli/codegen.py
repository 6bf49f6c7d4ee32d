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


def _function_source(f: Function) -> list[str]:
    printer = (NumPyPrinter({"fully_qualified_modules": True}) if f.vectorized
               else PythonCodePrinter({"fully_qualified_modules": True}))
    flat = [e for _, m in f.outputs for e in m]
    temps, reduced = sp.cse(flat, symbols=sp.numbered_symbols("_x"), order="none")
    names = ", ".join(str(a) for a in f.args)
    body = [f"def {f.name}({names}):", f'    """{f.doc}"""']
    if f.vectorized:
        shapes = ", ".join(f"numpy.shape({a})" for a in f.args)
        body.append(f"    _shape = numpy.broadcast_shapes({shapes})")
    for symbol, expr in temps:
        body.append(f"    {symbol} = {printer.doprint(expr)}")
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
