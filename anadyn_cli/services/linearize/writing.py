"""A linearization's files (``write``), key figures (``summary``) and terminal
report (``report``)."""
from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ... import files as output
from ...numeric.build import describe
from .state_space import Linearization


def summary(result: Linearization) -> dict:
    p = result.point
    names = (result.point_state or result.state)[:len(p.q)]
    rates = result.point_state[len(p.q):] if result.point_state else names
    return {
        "robot": result.robot, "formulation": result.formulation, "evaluator": result.evaluator,
        "code": result.code,
        "state": result.state, "inputs": result.inputs, "units": result.units,
        "x0": [*map(float, p.q), *map(float, p.dq)], "u0": list(map(float, p.tau)),
        "operating_point": {
            "t": p.t, "q": dict(zip(names, map(float, p.q))),
            "dq": dict(zip(rates, map(float, p.dq))),
            "tau": dict(zip(result.inputs, map(float, p.tau))),
            "ddq": dict(zip(rates, map(float, p.ddq))),
            "efforts_from": p.efforts_from, "equilibrium": p.equilibrium,
            "searched_equilibrium": p.searched, "holding_residual": p.holding_residual},
        "A": result.A.tolist(), "B": result.B.tolist(),
        "A_closed_loop": result.A_closed_loop.tolist(), "controller": result.has_controller,
        "eigenvalues": result.eigenvalues,
        "eigenvalues_closed_loop": result.eigenvalues_closed_loop,
        "controllability_rank": result.controllability_rank,
        "controllable": result.controllability_rank == len(result.state),
        "stable_open_loop": all(e["real"] < 0 for e in result.eigenvalues),
        "stable_closed_loop": all(e["real"] < 0 for e in result.eigenvalues_closed_loop),
        **({"symbolic": result.symbolic} if result.symbolic is not None else {}),
        "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
    }


def _csv(rows: list[list]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    for row in rows:
        writer.writerow([f"{v:.17g}" if isinstance(v, float) else
                         "" if v is None else v for v in row])
    return buffer.getvalue()


@output.one_set
def write(result: Linearization, out: Path) -> list[Path]:
    """linearize.json and the CSVs: A, B, A_closed_loop (a row per state derivative,
    header d/dt then the states or inputs) and the eigenvalues."""
    out = output.prepare_dir(out)
    written = []
    for name, matrix, columns in (("A", result.A, result.state), ("B", result.B, result.inputs),
                                  ("A_closed_loop", result.A_closed_loop, result.state)):
        rows = [["d/dt", *columns]] + [[s, *map(float, row)]
                                       for s, row in zip(result.state, matrix)]
        written.append(out / f"linearize_{name}.csv")
        output.write_text(written[-1], _csv(rows))
    keys = ["real", "imag", "natural_frequency", "frequency_hz", "damping_ratio",
            "time_constant"]
    rows = [["system", *keys, "controllable"]]
    for system, entries in (("open_loop", result.eigenvalues),
                            ("closed_loop", result.eigenvalues_closed_loop)):
        for e in entries:
            rows.append([system, *(e[k] for k in keys),
                         "" if "controllable" not in e else str(e["controllable"]).lower()])
    written.append(out / "linearize_eigenvalues.csv")
    output.write_text(written[-1], _csv(rows))
    written.append(out / "linearize.json")
    output.write_json(written[-1], summary(result))
    return written


def _matrix_text(matrix: np.ndarray, rows: list[str], columns: list[str]) -> list[str]:
    width = max([10, *map(len, columns)]) + 2
    label = max([4, *map(len, rows)])
    lines = [" " * label + "".join(f"{c:>{width}}" for c in columns)]
    for name, row in zip(rows, matrix):
        lines.append(f"{name:>{label}}" + "".join(f"{v:>{width}.6g}" for v in row))
    return lines


def report(result: Linearization) -> str:
    p = result.point
    units = result.units
    state = ", ".join(f"{s} = {v:.6g} {u}" for s, v, u in
                      zip(result.point_state or result.state, [*p.q, *p.dq],
                          result.point_units or units))
    code = f", {result.code.split(' (')[0]}" if result.evaluator == "recursive" else ""
    lines = [f"{result.robot} ({describe(result.formulation, result.evaluator)}{code}) at "
             f"t = {p.t:g} s: {state}"]
    source = {"given": "given", "controller": "the controller's", "none": "zero",
              "holding": "static holding"}[p.efforts_from]
    if result.inputs:
        lines.append(f"efforts ({source}): " + ", ".join(
            f"{a} = {v:.6g}" for a, v in zip(result.inputs, p.tau))
            + ("" if p.holding_residual is None or p.holding_residual < 1e-9 else
               f" (they cannot hold the state: residual generalized force "
               f"{p.holding_residual:.3g})"))
    lines.append(("static equilibrium" + (" (found by the equilibrium search)" if p.searched else ""))
                 if p.equilibrium else
                 f"not an equilibrium: ddq = ({', '.join(f'{v:.4g}' for v in p.ddq)})")
    derivative = [f"d{s}" if i < len(result.state) // 2 or result.point_state else
                  f"dd{s[1:]}" for i, s in enumerate(result.state)]    # (speeds: d<u>)
    lines += ["", "A = d(dx/dt)/dx, efforts held:"]
    lines += _matrix_text(result.A, derivative, result.state)
    if result.inputs:
        lines += ["", "B = d(dx/dt)/d(tau):"]
        lines += _matrix_text(result.B, derivative, result.inputs)
    lines += ["", "A_closed_loop, " + ("under the file's control laws:" if result.has_controller
                                       else "zero efforts (no controller):")]
    lines += _matrix_text(result.A_closed_loop, derivative, result.state)
    lines += ["", f"{'eigenvalues':>28}  {'wn (rad/s)':>11}  {'zeta':>8}   "
                  f"{'closed loop':>28}  {'wn (rad/s)':>11}  {'zeta':>8}"]
    for a, b in zip(result.eigenvalues, result.eigenvalues_closed_loop):
        lines.append(f"{_complex(a):>28}  {a['natural_frequency']:>11.5g}  {_zeta(a):>8}   "
                     f"{_complex(b):>28}  {b['natural_frequency']:>11.5g}  {_zeta(b):>8}")
    size = len(result.state)
    rank = result.controllability_rank
    uncontrollable = [e for e in result.eigenvalues if not e.get("controllable", True)]
    lines += ["", f"controllability rank {rank} of {size}"
              + (" (controllable)" if rank == size else
                 f" (not controllable; modes failing the PBH test: "
                 f"{', '.join(_complex(e).strip() for e in uncontrollable) or 'none'})")]
    if result.symbolic is not None:
        s = result.symbolic
        lines += ["", f"symbolic ({s['formulation']}: {s['form']}; parameters "
                      f"{', '.join(s['parameters']) or 'none'}; {s['note']}):"]
        for key in ("A", "B", "A_closed_loop") if "A" in s else ("E", "A_bar", "B_bar"):
            if key in s:
                lines.append(f"  {key} = {s[key]}")
    return "\n".join(lines)


def _complex(e: dict) -> str:
    if e["imag"] == 0:
        return f"{e['real']:.6g}"
    return f"{e['real']:.6g} {'+' if e['imag'] > 0 else '-'} {abs(e['imag']):.6g}i"


def _zeta(e: dict) -> str:
    return "-" if e["damping_ratio"] is None else f"{e['damping_ratio']:.4g}"
