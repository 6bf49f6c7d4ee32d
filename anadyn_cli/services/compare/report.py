"""How ``compare`` shows what it found: the terminal table and settings line,
compare.json's key figures, and the files of each robot."""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from ... import files as output
from .results import QUANTITIES, CompareResult, csv_text, number_text


def rows(result: CompareResult) -> list[list[str]]:
    """robot, check, max abs, max rel, tolerance, result."""
    table = []
    for r in result.robots:
        table.append([r.name, "symbolic", "-", "-", "exact",
                      ("MISMATCH " if not r.symbolic.passed else "") + r.symbolic.describe()])
        for d in [*r.numeric.values(), r.trajectory]:
            if d.quantity == "trajectory" and r.failure:
                verdict = f"FAILED: {r.failure}"
            elif d.passed:
                verdict = "ok" + (f" ({d.note})" if d.quantity == "trajectory" else "")
            else:
                verdict = f"MISMATCH ({d.note or d.where})"
            tolerance = (f"{d.tolerance:g} rel" if d.quantity != "trajectory"
                         else f"{d.tolerance:g} scaled")
            table.append([r.name, d.quantity, number_text(d.max_abs), number_text(d.max_rel), tolerance,
                          verdict])
    return table


def table(result: CompareResult) -> str:
    header = ["robot", "check", "max abs", "max rel", "tolerance", "result"]
    body = rows(result)
    widths = [max(len(line[i]) for line in [header, *body]) for i in range(len(header) - 1)]
    lines = []
    for line in [header, *body]:
        lines.append("  ".join(f"{cell:<{w}}" for cell, w in zip(line, widths))
                     + "  " + line[-1])
    return "\n".join(lines)


def settings_line(result: CompareResult) -> str:
    return (f"kane vs lagrange: symbolic budget {result.symbolic_terms} terms per robot; "
            f"{result.samples} random states (seed {result.seed}), "
            f"|lagrange - kane| <= {result.rtol:g} x size per state; trajectories: "
            f"states scaled by max(1, |x|max) within {result.trajectory_tol:g}")


def summary(result: CompareResult) -> dict:
    """Key figures (``compare.json``); ``robots`` is keyed by robot name."""
    robots: dict[str, dict] = {}
    worst = {q: {"max_abs": 0.0, "max_rel": 0.0} for q in (*QUANTITIES, "lambda",
                                                           "trajectory")}
    for key, r in zip(keys(result), result.robots):
        s = r.symbolic
        robots[key] = {
            "source": r.source, "passed": r.passed, "mismatches": r.mismatches,
            "simulation_failure": r.failure or None,
            "symbolic": {"status": s.status, "entries": s.entries, "proven": s.proven,
                         "too_large": s.too_large, "not_reduced": s.not_reduced,
                         "terms": s.terms, "entry": s.entry or None,
                         "residual": s.residual or None, "seconds": s.seconds,
                         "text": s.describe()},
            "numeric": {q: d.to_dict() for q, d in r.numeric.items()},
            "trajectory": r.trajectory.to_dict(),
            "timings": dict(r.timings)}
        for d in [*r.numeric.values(), r.trajectory]:
            for part in ("max_abs", "max_rel"):
                value = getattr(d, part)
                current = worst[d.quantity][part]
                worst[d.quantity][part] = (None if current is None or not math.isfinite(value)
                                           else max(current, value))
    return {"passed": result.passed, "formulation": ["kane", "lagrange"],
            "evaluator": "closed-form", "mismatches": sum(len(r.mismatches) for r in result.robots),
            "simulation_failures": sum(bool(r.failure) for r in result.robots),
            "robots_compared": len(result.robots),
            "symbolic_proven": sum(r.symbolic.status == "zero" for r in result.robots),
            "samples": result.samples, "seed": result.seed, "rtol": result.rtol,
            "trajectory_tol": result.trajectory_tol, "symbolic_terms": result.symbolic_terms,
            "worst": worst, "robots": robots, "timings": dict(result.timings)}




def keys(result: CompareResult) -> list[str]:
    """Each robot's name, made unique (a name met again gets -2, -3, ...): its key in
    compare.json and, comparing several, its folder."""
    found: list[str] = []
    for r in result.robots:
        key, k = r.name, 2
        while key in found:
            key, k = f"{r.name}-{k}", k + 1
        found.append(key)
    return found


@output.one_set
def write(result: CompareResult, out: Path) -> list[Path]:
    """compare.csv and compare.json of each robot: in ``out`` when there is one
    robot, else in ``out/<robot name>/`` for each (the command's ``out`` is then
    results/, so every robot's files are in results/<robot>/ as with any command);
    the files of all the robots go in place together (``files.one_set``)."""
    parts = ([(out, result)] if len(result.robots) == 1 else
             [(out / key, replace(result, robots=[r]))
              for key, r in zip(keys(result), result.robots)])
    written = []
    for folder, part in parts:
        folder = output.prepare_dir(folder)
        written += [folder / "compare.csv", folder / "compare.json"]
        output.write_text(written[-2], csv_text(part))
        output.write_json(written[-1], summary(part))
    return written
