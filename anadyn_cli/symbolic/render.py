"""Readable equations of motion: the chapter's "... = 0" form, or M, F, B.

    residual_r = sum_s M_rs ddq_s - F_r - sum_k B_rk tau_k = 0

The generalized forces of the joint forces and loads, Q (part of F), are
shown apart: each equation ends in ``- Q_<coordinate>`` and the entries of Q
follow under their own heading (with ``--matrices``: F[r] = ... + Q[r]).

Small systems are shown with their trigonometric terms recombined
(``sympy.trigsimp``) and collected by accelerations and efforts; larger
ones are printed as derived.  Numeric systems print decimals, symbolic
ones exact numbers.

With a spherical joint the equations are one per speed (labelled by the
speed, M du = F + B tau), followed by the kinematic differential equations
dq = W(q) u under their own heading.
"""
from __future__ import annotations

import sympy as sp

from .canonical import fits
from .eom import EquationsOfMotion
from ..errors import ModelError

FORMATS = ("text", "latex")
FORMS = ("residual", "matrices")
LATEX_LINE = 80      # printed characters per displayed line of LaTeX, about a text width


def render(eom: EquationsOfMotion, fmt: str = "text", form: str = "residual") -> str:
    if fmt not in FORMATS:
        raise ModelError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    if form not in FORMS:
        raise ModelError(f"unknown form {form!r}; choose one of {', '.join(FORMS)}")
    readable = fits([*eom.M, *eom.F, *eom.B])
    show = _printer(fmt, eom.symbolic, eom.q)

    def tidy(expr: sp.Expr, collect: bool = False) -> sp.Expr:
        if readable:
            expr = sp.trigsimp(expr)
            if collect:
                expr = sp.collect(expr, [*eom.ddq, *eom.efforts])
        return expr

    lines: list = [f"# {eom.formulation} equations, "
                   f"{'symbolic parameters' if eom.symbolic else 'numeric parameters'}"]
    # a line is text, or (before, expression, after): printed at the end, so that a
    # large system can name its shared terms once (``_shared``)
    Q = eom.joint_forces_and_loads
    forces = sp.Matrix(eom.F - Q)       # gravity and velocity products
    heading = "# joint forces and loads: generalized forces Q, part of F"
    if form == "residual":
        labels = eom.q if eom.kinematic is None else eom.dq      # one equation per speed
        names = [sp.Symbol(f"Q_{q}") for q in labels]
        tau = sp.Matrix(len(eom.efforts), 1, list(eom.efforts))
        residuals = eom.M * sp.Matrix(eom.ddq) - forces - eom.B * tau
        for q, residual, name, entry in zip(labels, residuals, names, Q):
            after = f" - {show(name)} = 0" if entry != 0 else " = 0"
            lines.append((f"{q}: ", tidy(residual, collect=True), after))
        if any(entry != 0 for entry in Q):
            lines.append(heading)
            lines += [(f"{show(name)} = ", tidy(entry), "") for name, entry in zip(names, Q)
                      if entry != 0]
        return _finish(lines + _kinematic(eom, show), show, readable)
    for name, matrix in (("M", eom.M), ("F", forces), ("B", eom.B)):
        for i in range(matrix.rows):
            for j in range(matrix.cols):
                if name == "M" and j < i:
                    continue          # symmetric
                index = f"{i + 1},{j + 1}" if matrix.cols > 1 or name == "B" else f"{i + 1}"
                added = f" + Q[{index}]" if name == "F" and Q[i] != 0 else ""
                lines.append((f"{name}[{index}] = ", tidy(matrix[i, j]), added))
    if any(entry != 0 for entry in Q):
        lines.append(heading)
        lines += [(f"Q[{i + 1}] = ", tidy(entry), "") for i, entry in enumerate(Q) if entry != 0]
    return _finish(lines + _kinematic(eom, show), show, readable)


def _kinematic(eom: EquationsOfMotion, show) -> list:
    """The kinematic differential equations dq = W(q) u, when the speeds are not the
    coordinates' rates (a spherical joint); none otherwise."""
    if eom.kinematic is None:
        return []
    speeds = set(eom.dq)
    return ["# kinematic differential equations: dq = W(q) u (a quaternion's: "
            "1/2 q (x) (0, w))"] + [(f"{show(rate)} = ", expr, "") for rate, expr
                                    in zip(eom.rates, eom.kinematic) if expr not in speeds]


def _finish(lines: list, show, readable: bool) -> str:
    """The printout.  A large system (not ``readable``) first names the terms its
    expressions share, x1 = ..., as the chapter names its intermediate quantities:
    SymPy's printer would otherwise write every shared term out again wherever it
    occurs (a 12-link chain: 34 MB in 114 s, against 74 kB in under a second)."""
    exprs = [line[1] for line in lines if isinstance(line, tuple)]
    shared: list = []
    if not readable and exprs:
        taken = set().union(*(e.free_symbols for e in exprs))
        shared, exprs = sp.cse(exprs, symbols=sp.numbered_symbols("x", start=1, exclude=taken),
                               order="none")
    out = [lines[0]]                                      # the title
    if shared:
        out.append(f"# shared terms, each named once: x1 .. x{len(shared)}")
        out += [f"{show(symbol)} = {show(value)}" for symbol, value in shared]
        out.append("# the equations")
    reduced = iter(exprs)
    for line in lines[1:]:
        if isinstance(line, tuple):
            before, _, after = line
            text = show(next(reduced))
            if after.startswith(" - ") and after.endswith(" = 0") and text == "0":
                out.append(f"{before}-{after[3:]}")       # 0 - Q_q = 0 -> -Q_q = 0
            else:
                out.append(f"{before}{text}{after}")
        else:
            out.append(line)
    return "\n".join(out)


def _printer(fmt: str, exact: bool, coordinates=()):
    names = latex_names(coordinates) if fmt == "latex" else {}

    def show(expr: sp.Expr) -> str:
        if not exact:
            expr = expr.xreplace({r: sp.Float(r, 8) for r in expr.atoms(sp.Rational)
                                  if not r.is_Integer})
        if fmt == "latex":
            return sp.latex(expr, symbol_names=names)
        return sp.sstr(expr, full_prec=False)
    return show


printer = _printer     # (fmt, exact, coordinates) -> show(expr), for other printouts


def latex_names(coordinates) -> dict[sp.Symbol, str]:
    """LaTeX for the rates and accelerations of ``coordinates``: dq1 -> \\dot{q}_{1},
    ddq1 -> \\ddot{q}_{1} (SymPy alone would print dq_{1}, ddq_{1})."""
    names = {}
    for q in coordinates:
        base = sp.latex(q)
        head, sub = base, ""
        if "_{" in base and base.endswith("}"):
            cut = base.index("_{")
            head, sub = base[:cut], base[cut:]
        names[sp.Symbol("d" + q.name, real=True)] = rf"\dot{{{head}}}{sub}"
        names[sp.Symbol("dd" + q.name, real=True)] = rf"\ddot{{{head}}}{sub}"
    return names


def latex_width(latex: str) -> int:
    """Roughly how many characters ``latex`` takes printed: commands that draw
    nothing or a single glyph, braces and sub/superscript markers dropped."""
    import re

    text = re.sub(r"\\(left|right|nonumber|quad)\b", "", latex)
    text = re.sub(r"\\(dot|ddot|mathrm|operatorname)\b", "", text)
    text = re.sub(r"\\[A-Za-z]+", "xx", text)        # \sin, \alpha: about two glyphs
    return len(re.sub(r"[{}_^ ]", "", text))


def _top_level(latex: str) -> tuple[list[int], list[tuple[int, int]]]:
    """Where ``latex`` has a binary `` + `` or `` - `` outside every brace and
    \\left ... \\right pair, and the (start, end) of its outermost \\left ... \\right
    pairs (end: just after the closing delimiter)."""
    cuts, groups, depth, opened, k = [], [], 0, 0, 0
    while k < len(latex):
        if latex.startswith(r"\left", k):
            if depth == 0:
                opened = k
            depth, k = depth + 1, k + 5
            continue
        if latex.startswith(r"\right", k):
            depth, k = depth - 1, k + 6
            if depth == 0:
                k += 2 if latex.startswith("\\", k) else 1     # the delimiter
                groups.append((opened, k))
            continue
        if latex[k] == "{":
            depth += 1
        elif latex[k] == "}":
            depth -= 1
        elif depth == 0 and k > 0 and latex.startswith((" + ", " - "), k):
            cuts.append(k)
        k += 1
    return cuts, groups


def latex_lines(latex: str, width: int = LATEX_LINE) -> list[str]:
    """A sum printed by SymPy cut into lines of about ``width`` printed characters,
    before its top-level `` + `` and `` - `` (never inside braces, so every line
    stays balanced); a term still too long that holds a \\left( ... \\right) sum
    is cut inside it, each line closing with \\right. and the next opening with
    \\left. ."""
    cuts, _ = _top_level(latex)
    pieces = [latex[a:b].strip() for a, b in zip([0, *cuts], [*cuts, len(latex)])]
    lines = [""]
    for piece in pieces:
        if latex_width(piece) > width:
            inner = _group_lines(piece, width)
            if len(inner) > 1:
                if lines[-1]:
                    lines.append("")
                lines[-1] += inner[0]
                lines += inner[1:]
                continue
        if lines[-1] and latex_width(lines[-1]) + latex_width(piece) > width:
            lines.append("")
        lines[-1] += (" " if lines[-1] else "") + piece
    return lines


def _group_lines(term: str, width: int) -> list[str]:
    """``term`` = head \\left( sum \\right) tail cut inside the sum (one line if it
    has no such group)."""
    _, groups = _top_level(term)
    if not groups:
        return [term]
    start, end = max(groups, key=lambda g: g[1] - g[0])
    opening = term[start:start + 6]                   # \left( or \left[
    closing = term[end - 7:end] if term[end - 8:end - 6] != "\\" else term[end - 8:end]
    inner = latex_lines(term[start + 6:end - len(closing)], width)
    if len(inner) == 1:
        return [term]
    lines = [f"{term[:start]}{opening}{inner[0]} \\right."]
    lines += [rf"\left. {line} \right." for line in inner[1:-1]]
    lines.append(rf"\left. {inner[-1]} {closing}{term[end:]}")
    return lines


def latex_document(text: str, title: str) -> str:
    """A printout made with fmt "latex" as a LaTeX document that compiles as it is
    (pdflatex, amsmath only).  Its lines become: ``# heading`` a paragraph;
    ``q1: e = 0`` the row ``e &= 0`` tagged (q_1); ``lhs = e`` the row
    ``lhs &= e`` (``M[1,2]`` written M_{1,2}); a long sum continues on further
    rows, ``& \\quad ...``, of about LATEX_LINE printed characters
    (``latex_lines``)."""
    import re

    out = [f"% {title} (anadyn)", r"\documentclass[10pt]{article}", r"\usepackage{amsmath}",
           r"\allowdisplaybreaks", r"\begin{document}",
           r"\noindent\textbf{" + _latex_text(title) + "}"]
    rows: list[str] = []

    def close() -> None:
        if rows:
            out.extend([r"\begin{align*}", " \\\\\n".join(rows), r"\end{align*}"])
            rows.clear()

    for line in text.splitlines():
        if not line.strip():
            continue
        if line.startswith("#"):
            close()
            out.append(r"\par\noindent " + _latex_text(line.lstrip("# ")))
            continue
        labelled = re.fullmatch(r"([A-Za-z]\w*): (.*) = 0", line)
        if labelled:
            label = sp.latex(sp.Symbol(labelled[1]))
            parts = latex_lines(labelled[2])
            if len(parts) == 1:
                rows.append(f"  {parts[0]} &= 0 \\tag*{{$({label})$}}")
            else:                    # long: the lines aligned on the left, "= 0" at the end
                rows.append(" \\\\\n".join([f"  & {parts[0]}"]
                                          + [rf"  & \quad {p}" for p in parts[1:]])
                            + f" = 0 \\tag*{{$({label})$}}")
            continue
        lhs, _, rhs = line.partition(" = ")
        lhs = re.sub(r"^(\w+)\[([^\]]+)\]", r"\1_{\2}", lhs)
        parts = latex_lines(rhs)
        rows.append(" \\\\\n".join([f"  {lhs} &= {parts[0]}"]
                                  + [rf"  & \quad {p}" for p in parts[1:]]))
    close()
    out.append(r"\end{document}")
    return "\n".join(out)


def _latex_text(text: str) -> str:
    """Plain text for LaTeX's text mode (its special characters escaped)."""
    import re

    specials = {"\\": r"\textbackslash{}", "_": r"\_", "%": r"\%", "&": r"\&", "#": r"\#",
                "$": r"\$", "{": r"\{", "}": r"\}", "^": r"\^{}", "~": r"\~{}"}
    return re.sub(r"[\\_%&#${}^~]", lambda m: specials[m[0]], text)
