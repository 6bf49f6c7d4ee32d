"""The printers of straight-line programs (``ir``): statements and sums as Python
(``math`` on floats, or NumPy over arrays: ``python_lines``, ``python_expr``) and as
C99 (``c_lines``, ``c_expr``); C and Python share the syntax of a sum of products
(``ir.python_sum``, an ``Ex``'s own text)."""
from __future__ import annotations

import sympy as sp

from .ir import Ex, Statement, _number, python_sum


PY_CALLS = {"sin": "_sin", "cos": "_cos", "sqrt": "_sqrt", "tanh": "_tanh"}


class _PyPrinter:
    def __init__(self, vectorized: bool):
        from sympy.printing.numpy import NumPyPrinter
        from sympy.printing.pycode import PythonCodePrinter
        self.vectorized = vectorized
        self.sympy = (NumPyPrinter({"fully_qualified_modules": True}) if vectorized
                      else PythonCodePrinter({"fully_qualified_modules": True}))

    def statements(self, statements: list[Statement], indent: str = "    ") -> list[str]:
        lines = []
        for s in statements:
            if s.kind == "check":
                atom, message = s.payload
                lines.append(f"{indent}if {atom} <= 0.0:")
                lines.append(f"{indent}    raise _singular({message!r})")
            else:
                lines.append(f"{indent}{s.name} = {_value(s, PY_CALLS, self.sympy.doprint)}")
        return lines


def _value(s: Statement, calls: dict, sympy_text) -> str:
    """The right-hand side of a sum, call or SymPy statement (``calls``: the
    target language's name of each function; ``sympy_text``: its printer)."""
    if s.kind == "sum":
        return python_sum(s.payload)
    if s.kind == "call":
        function, atom = s.payload
        return f"1.0/{atom}" if function == "recip" else f"{calls[function]}({atom})"
    return sympy_text(s.payload)


def python_lines(statements: list[Statement], vectorized: bool) -> list[str]:
    return _PyPrinter(vectorized).statements(statements)


def python_expr(value: Ex) -> str:
    c = value.constant()
    return _number(c) if c is not None else python_sum(value.terms)


_C_PRINTER = []


def _c_printer():
    if not _C_PRINTER:
        from sympy.printing.c import C99CodePrinter
        _C_PRINTER.append(C99CodePrinter())
    return _C_PRINTER[0]


def c_lines(statements: list[Statement], indent: str = "    ",
            fail: str = "return 1;") -> list[str]:
    """C99 statements (``double`` locals); a failed check runs ``fail``."""
    lines = []
    for s in statements:
        if s.kind == "check":
            atom, _ = s.payload
            lines.append(f"{indent}if ({atom} <= 0.0) {fail}")
        else:
            lines.append(f"{indent}const double {s.name} = {_value(s, C_CALLS, _c_text)};")
    return lines


#: C's names of the functions of call statements (C99 <math.h>)
C_CALLS = {"sin": "sin", "cos": "cos", "sqrt": "sqrt", "tanh": "tanh"}


def _c_text(expr: sp.Expr) -> str:
    """A SymPy expression in C99, on one line; ValueError if it has no C form."""
    text = _c_printer().doprint(expr)
    if "Not supported" in text:
        raise ValueError(f"no C form for {expr}")
    return " ".join(text.split())          # a ternary printed over several lines


def c_expr(value: Ex) -> str:
    return python_expr(value)
