"""LaTeX export: the equations in the chapter's "... = 0" form, then M, F, B.

    sum_s M_rs ddq_s - F_r - sum_k B_rk tau_k = 0,   r = 1..n

A whole document (article, amsmath) or, with ``fragment``, only its body
(which needs ``\\usepackage{amsmath}``).  Small systems are shown with their
trigonometric terms recombined and collected by accelerations and efforts
(as ``anadyn equations`` does); long sums are broken across lines between
terms, and a term too long for a line inside its \\left( ... \\right) (the line
closing with \\right., the next opening with \\left.), so every line stays balanced.
"""
from __future__ import annotations


import sympy as sp

from ...symbolic.canonical import fits
from ...symbolic.render import latex_lines, latex_width as _width
from .model import TIME, ExportModel

LINE = 80           # printed characters per displayed line (``latex_width``), about a text width
SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
           "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
           "^": r"\textasciicircum{}"}


def escape(text: str) -> str:
    """Plain text for LaTeX's text mode."""
    return "".join(SPECIAL.get(ch, ch) for ch in text)


def files(model: ExportModel, fragment: bool = False) -> dict[str, str]:
    return {f"{model.name}.tex": document(model, fragment)}


class _Writer:
    def __init__(self, model: ExportModel):
        self.model = model
        self.readable = fits([*model.M, *model.F, *model.B])
        names: dict[sp.Symbol, str] = {TIME: "t"}
        for c in model.coordinates:
            names[c.symbol] = sp.latex(sp.Symbol(c.name))
        # a coordinate's rate is the coordinate dotted; a speed that is no coordinate's
        # rate (a spherical joint's) keeps its name, and its rate is that name dotted
        rates = {f"d{c.name}": names[c.symbol] for c in model.coordinates}
        for r, a in zip(model.rates, model.accelerations):
            if r.name in rates:
                names[r.symbol], names[a.symbol] = dotted(rates[r.name], 1), dotted(
                    rates[r.name], 2)
            else:
                names[r.symbol] = sp.latex(sp.Symbol(r.name))
                names[a.symbol] = dotted(names[r.symbol], 1)
        self.names = names

    def tidy(self, expr: sp.Expr, collect: bool = False) -> sp.Expr:
        """Small systems: trigonometric terms recombined, products of sums expanded (so
        that long entries break between terms), collected by accelerations and efforts."""
        if self.readable:
            expr = sp.expand(sp.trigsimp(expr))
            if collect:
                expr = sp.collect(expr, [a.symbol for a in self.model.accelerations]
                                  + [e.symbol for e in self.model.efforts])
        return expr

    def latex(self, expr: sp.Expr) -> str:
        if not self.model.symbolic:
            expr = expr.xreplace({r: sp.Float(r, 10) for r in expr.atoms(sp.Rational)
                                  if not r.is_Integer})
        return sp.latex(expr, symbol_names=self.names, full_prec=False)

    def lines(self, expr: sp.Expr) -> list[str]:
        """``expr`` as LaTeX, a sum broken between its terms into lines of about LINE."""
        terms = expr.as_ordered_terms() if expr.is_Add else [expr]
        accelerations = {a.symbol for a in self.model.accelerations}
        efforts = {e.symbol for e in self.model.efforts}
        terms.sort(key=lambda term: 0 if term.free_symbols & accelerations else
                   2 if term.free_symbols & efforts else 1)      # stable: keeps the order within
        out = [""]
        for k, term in enumerate(terms):
            text = self.latex(term)
            if k:
                text = f"- {text[1:].lstrip()}" if text.startswith("-") else f"+ {text}"
            for part in latex_lines(text, LINE):      # a term too long: cut inside its ( )
                if out[-1] and _width(out[-1]) + _width(part) > LINE:
                    out.append("")
                out[-1] += (" " if out[-1] else "") + part
        return out

    def equation(self, left: str, expr: sp.Expr, tag: str | None = None,
                 right: str | None = None) -> str:
        """One align row (possibly several lines): ``left = expr`` or ``expr = right``."""
        lines = self.lines(expr)
        suffix = rf" \tag{{{tag}}}" if tag else ""
        if right is not None:          # "... = 0"
            rows = [rf"& {lines[0]}"] + [rf"& \quad {line}" for line in lines[1:]]
            rows[-1] += rf" = {right}"
        else:
            rows = [rf"{left} &= {lines[0]}"] + [rf"& \quad {line}" for line in lines[1:]]
        rows = [row + r" \nonumber" for row in rows[:-1]] + [rows[-1] + suffix]
        return " \\\\\n".join(rows)


def dotted(base: str, order: int) -> str:
    """``base`` with ``order`` dots on its head: q_{1} -> \\dot{q}_{1}."""
    head, sep, tail = base.partition("_{")
    return rf"\{'d' * order}ot{{{head}}}{sep}{tail}"


def _align(rows: list[str]) -> list[str]:
    return [r"\begin{align*}" if not any(r"\tag" in row for row in rows) else r"\begin{align}",
            " \\\\\n".join(rows),
            r"\end{align*}" if not any(r"\tag" in row for row in rows) else r"\end{align}"]


def body(model: ExportModel) -> list[str]:
    w = _Writer(model)
    method = {"kane": "Kane's method", "lagrange": "Lagrange's equations"}.get(
        model.formulation, model.formulation)
    out = [rf"\section*{{Equations of motion of robot \texttt{{{escape(model.robot_name)}}}}}",
           "",
           rf"Derived from \texttt{{{escape(model.source)}}} by {method} with "
           rf"{escape(model.generator)}; "
           + ("the parameters are kept as symbols." if model.symbolic
              else "the parameters of the file are substituted (decimals rounded to ten "
                   "significant digits).")
           + " Units are SI: m, kg, s, rad, N, N\\,m.", ""]
    coords = ", ".join(rf"${w.names[c.symbol]}$ ({escape(c.unit)})" for c in model.coordinates)
    if model.kinematic is None:
        out += [rf"Generalized coordinates: {coords}; their rates and accelerations are "
                r"written $\dot{q}$, $\ddot{q}$."]
    else:
        speeds = ", ".join(rf"${w.names[u.symbol]}$ ({escape(u.unit)})" for u in model.rates)
        out += [rf"Generalized coordinates $q$: {coords}.  Generalized speeds $u$: {speeds}; "
                r"their rates are written $\dot{u}$.  A spherical joint's coordinates are a "
                r"unit quaternion $(q_w, q_x, q_y, q_z)$, scalar first, and its speeds the "
                r"body's angular velocity relative to its parent in the body's axes; the "
                r"coordinates' rates follow from the kinematic differential equations "
                r"$\dot{q} = W(q)\,u$ below."]
    if model.efforts:
        efforts = ", ".join(rf"${sp.latex(e.symbol)}$ ({e.unit.replace('*', '~')})"
                            for e in model.efforts)
        out += [rf"Actuator efforts $\tau$: {efforts}."]
    else:
        out += [r"The robot has no actuators."]
    out += ["", r"\subsection*{Equations of motion}", ""]
    if model.kinematic is None:
        out += [r"One equation per coordinate, in the form "
                r"$\sum_s M_{rs}\ddot{q}_s - F_r - \sum_k B_{rk}\tau_k = 0$:", ""]
    else:
        out += [r"One equation per speed, in the form "
                r"$\sum_s M_{rs}\dot{u}_s - F_r - \sum_k B_{rk}\tau_k = 0$:", ""]
    residuals = sp.Matrix(model.M) * sp.Matrix([a.symbol for a in model.accelerations]) \
        - model.F - (model.B * sp.Matrix([e.symbol for e in model.efforts]) if model.m
                     else sp.zeros(model.n, 1))
    tags = model.coordinates if model.kinematic is None else model.rates
    rows = [w.equation("", w.tidy(residuals[r], collect=True), tag=f"${w.names[c.symbol]}$",
                       right="0")
            for r, c in enumerate(tags)]
    out += _align(rows)
    if model.kinematic is not None:
        out += ["", r"\subsection*{Kinematic differential equations}", ""]
        out += _align([w.equation(dotted(w.names[c.symbol], 1), w.tidy(rate))
                       for c, rate in zip(model.coordinates, model.kinematic)])
    out += ["", r"\subsection*{Matrix form}", "",
            (r"$M(q)\,\ddot{q} = F(t, q, \dot{q}) + B(q)\,\tau$" if model.kinematic is None
             else r"$M(q)\,\dot{u} = F(t, q, u) + B(q)\,\tau$")
            + r", with $M$ symmetric; $F$ holds gravity, the velocity products and any joint "
            r"forces and loads of the robot file.", ""]
    rows = []
    for i in range(model.n):
        for j in range(i, model.n):
            rows.append(w.equation(f"M_{{{i + 1}{j + 1}}}" if model.n < 10 else
                                   f"M_{{{i + 1},{j + 1}}}", w.tidy(model.M[i, j])))
    for i in range(model.n):
        rows.append(w.equation(f"F_{{{i + 1}}}", w.tidy(model.F[i])))
    for i in range(model.n):
        for k in range(model.m):
            rows.append(w.equation(f"B_{{{i + 1}{k + 1}}}" if max(model.n, model.m) < 10 else
                                   f"B_{{{i + 1},{k + 1}}}", w.tidy(model.B[i, k])))
    out += _align(rows)
    if model.has_controller and model.m:
        out += ["", r"\subsection*{Control laws}", ""]
        out += _align([w.equation(sp.latex(e.symbol), law)
                       for e, law in zip(model.efforts, model.laws)])
    if model.symbolic and model.parameters:
        out += ["", r"\subsection*{Parameters}", "", r"\begin{tabular}{lll}",
                r"name & value in the file & kind \\ \hline"]
        for p in model.parameters:
            out.append(rf"${sp.latex(p.symbol)}$ & {p.value!r} & {p.kind} \\")
        out += [r"\end{tabular}"]
    return out + [""]


def document(model: ExportModel, fragment: bool = False) -> str:
    head = [f"% {model.name}.tex -- {model.title()}".replace("\n", " ")]
    if fragment:
        return "\n".join(head + [r"% A fragment: \input it in a document that loads amsmath.",
                                 ""] + body(model))
    return "\n".join(head + [
        r"\documentclass[10pt]{article}",
        r"\usepackage[a4paper,margin=2cm]{geometry}",
        r"\usepackage{amsmath}",
        r"\allowdisplaybreaks",
        r"\begin{document}", ""] + body(model) + [r"\end{document}", ""])
