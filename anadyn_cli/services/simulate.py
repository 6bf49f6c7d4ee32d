"""Direct dynamics under the robot's feedback laws (passive without a controller).

    x = [q, u],  dx/dt = [W(q) u, M(q)^-1 (F(q, u) + B(q) tau(t, q, u))]

integrated from the coordinates' and speeds' initial values, with rows at
t = k * output_step exactly.  The speeds u are the coordinates' rates (W = 1)
unless the robot has a spherical joint (``numeric.model``): then each row's
quaternion is made unit after the run (the motion does not depend on its norm)
and the largest distance of the integrated norm from 1 is reported
(``quaternion_drift`` in simulate.json).  With rigid contacts the run goes from
contact event to contact event, impacts applied between (``numeric.impacts``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import NumericalError
from ..model.info import RobotInfo, Simulation
from ..numeric import constrained, contact_run, impacts, integrators
from ..numeric.build import titled
from ..numeric.model import NumericModel
from ..numeric.settings import output_grid, resolve
from .. import files as output
from ..output.csv_table import write_csv
from ..output.notebook import Displayed
from ..output import plots, tables
from ..numeric import limits


@dataclass
class SimulationResult(Displayed):
    """A run; rows are times: ``t`` (N,), ``x`` (N, nq + n) = [q, u], ``efforts`` (N, m)."""
    robot: RobotInfo
    settings: Simulation
    solution: integrators.Solution
    efforts: np.ndarray                   # N x m
    timings: dict = field(default_factory=dict)
    estimated_error: float | None = None  # integrators.estimate_error, when asked for
    formulation: str | None = None        # of the closed forms; None: recursive evaluator
    evaluator: str = ""                   # recursive or closed-form (numeric.build)
    constraints: "constrained.ConstraintRun | None" = None   # drift, multipliers (closed chains)
    limits: list = field(default_factory=list)   # limits.Exceeded: bounds of the file passed
    code: str = ""                        # what computed the RHS (native C, generated Python)
    quaternion_drift: float | None = None     # max | |q| - 1 | before the rows were made unit
    contacts: "contact_run.ContactRun | None" = None   # contact forces and events, per row

    @property
    def t(self) -> np.ndarray:
        return self.solution.t

    @property
    def x(self) -> np.ndarray:
        return self.solution.x

    def table(self) -> tuple[list[str], list[np.ndarray]]:
        """simulate.csv's header and columns (``to_csv`` writes them; notebooks show them)."""
        return columns(self)

    def figure(self, rates: bool = False):
        """The run as a Matplotlib Figure (the global backend is not touched)."""
        return plots.time_figure(self.t, _panels(self, rates), plot_title(self), pairs=rates)


def simulate(model: NumericModel, method: str | None = None, rtol: float | None = None,
             atol: float | None = None, t_end: float | None = None,
             output_step: float | None = None, estimate_error: bool = False,
             timings: dict | None = None) -> SimulationResult:
    """Integrate ``model``'s direct dynamics from the file's initial state.

    Settings not given come from the robot file, then anadyn's defaults
    (``numeric.settings``).  A failure is returned in ``result.solution``,
    not raised; ``estimate_error`` adds the run's estimated global error.
    """
    timings = {} if timings is None else timings
    settings = resolve(model.info, method=method, rtol=rtol, atol=atol, t_end=t_end,
                       output_step=output_step)
    grid = output_grid(settings.t_end, settings.output_step)
    rigid = model.rigid_contacts is not None        # impacts, constraints: numeric.impacts
    if rigid:
        run = impacts.run(model, grid, settings.method, settings.rtol, settings.atol)
        solution = run.solution
    else:
        problem = model.problem()
        solution = integrators.integrate(problem, model.initial_state(), grid,
                                         settings.method, settings.rtol, settings.atol)
    timings["solve"] = solution.wall
    if model.quaternions:                    # the rows on the unit sphere, the drift kept
        solution.x, drift = model.on_manifold(solution.x)
    n, m = model.nq, len(model.info.actuators)
    q, dq = solution.x[:, :n].T, solution.x[:, n:].T
    efforts = model.efforts(solution.t, q, dq) if m else np.zeros((0, len(solution.t)))
    efforts = np.broadcast_to(efforts, (m, len(solution.t))).T
    result = SimulationResult(model.info, settings, solution, np.array(efforts), timings,
                              formulation=model.formulation, evaluator=model.evaluator,
                              code=getattr(model, "native_note", "generated Python"),
                              quaternion_drift=drift if model.quaternions else None)
    rates = model.coordinate_rates(solution.x.T).T                          # dq = W(q) u
    result.limits = limits.check(model.info, solution.t, solution.x[:, :n], rates,
                                 result.efforts)
    if constrained.is_constrained(model):       # drift and constraint forces on every row
        result.constraints = model.run_report(solution.t, solution.x)
    result.contacts = run.contacts if rigid else contact_run.run_report(model, solution.t,
                                                                        solution.x)
    if estimate_error and solution.success:
        start = time.perf_counter()
        result.estimated_error = (impacts.estimate_error(model, solution, settings.rtol,
                                                         settings.atol) if rigid else
                                  integrators.estimate_error(problem, solution, settings.rtol,
                                                             settings.atol))
        timings["estimate"] = time.perf_counter() - start
    return result


def columns(result: SimulationResult) -> tuple[list[str], list[np.ndarray]]:
    """CSV contract: t, coordinates, speeds (the rates d<name>, or with a spherical
    joint the speeds ``Robot.speeds`` names), actuator efforts; then the closed
    chains' multipliers and drift, the contacts' forces and penetrations."""
    names = [c.name for c in result.robot.coordinates]
    speeds = [u.name for u in result.robot.speeds] or ["d" + n for n in names]
    header = ["t", *names, *speeds, *(a.name for a in result.robot.actuators)]
    data = [result.t, *result.x.T, *result.efforts.T]
    if result.constraints is not None:        # after the contract: multipliers, drift
        extra_header, extra = result.constraints.columns()
        header, data = header + extra_header, data + extra
    if result.contacts is not None:
        extra_header, extra = result.contacts.columns()
        header, data = header + extra_header, data + extra
    return header, data


@output.one_set
def write(result: SimulationResult, out: Path, plot: bool = True, plot_format: str = "png",
          rates: bool = False) -> list[Path]:
    """simulate.csv (+ the plot, png/svg/pdf, with the rates if asked); on failure only
    simulate.partial.csv, then NumericalError."""
    out = output.prepare_dir(out)
    start = time.perf_counter()
    header, data = columns(result)
    if not result.solution.success:
        partial = out / "simulate.partial.csv"
        write_csv(partial, header, data)
        raise NumericalError(f"{result.robot.source}: {result.solution.message}; "
                             f"{len(result.t)} rows before it in {partial}")
    written = [out / "simulate.csv"]
    write_csv(written[0], header, data)
    if plot:
        written.append(plots.plot_path(out, "simulate", plot_format))
        plots.write_plot(written[-1], result.t, _panels(result, rates), plot_title(result),
                         pairs=rates)
    (out / "simulate.partial.csv").unlink(missing_ok=True)
    result.timings["write"] = time.perf_counter() - start
    written.append(out / "simulate.json")
    output.write_json(written[-1], summary(result))
    return written


def summary(result: SimulationResult) -> dict:
    """Key figures of a run (``simulate.json``)."""
    solution = result.solution
    final = dict(zip(columns(result)[0][1:], (float(v) for v in
                                              np.concatenate([solution.x[-1],
                                                              result.efforts[-1]]))))
    return {"robot": result.robot.name, "method": solution.method, "reason": solution.reason,
            "success": solution.success, "rhs_calls": solution.rhs_calls,
            "jacobian_calls": solution.jacobian_calls, "steps": solution.steps,
            "rtol": result.settings.rtol, "atol": result.settings.atol,
            "t_end": float(result.t[-1]), "rows": len(result.t), "final": final,
            "formulation": result.formulation, "evaluator": result.evaluator,
            "code": result.code,
            "timings": {k: v for k, v in result.timings.items() if isinstance(v, float)},
            **({} if result.estimated_error is None
               else {"estimated_error": result.estimated_error}),
            "limits": limits.summary(result.robot, result.limits),
            **({} if result.constraints is None else result.constraints.summary()),
            **({} if result.quaternion_drift is None
               else {"quaternion_drift": result.quaternion_drift}),
            **({} if result.contacts is None else {"contact": result.contacts.summary()})}


def plot_title(result: SimulationResult) -> str:
    """The robot, the command and what computed the numbers (``build.describe``); the
    method and tolerances are in simulate.json."""
    return titled(f"{result.robot.name}: simulate", result.formulation, result.evaluator)


def _panels(result: SimulationResult, rates: bool = False) -> list:
    """A panel per coordinate (and rate, or with a spherical joint a panel per speed
    after them), efforts grouped by unit."""
    n = len(result.robot.coordinates)
    coordinates = [(c.name, c.unit) for c in result.robot.coordinates]
    speeds = result.robot.speeds
    panels = plots.state_panels(coordinates, result.x[:, :n],
                                result.x[:, n:] if rates and not speeds else None)
    if rates and speeds:
        panels += plots.state_panels([(u.name, u.unit) for u in speeds], result.x[:, n:])
    if result.robot.actuators:
        panels += plots.effort_panels([(a.name, a.unit) for a in result.robot.actuators],
                                      result.efforts)
    if result.constraints is not None:
        panels += plots.effort_panels([(r.column, r.unit or "1") for r in
                                       result.constraints.rows], result.constraints.multipliers)
    if result.contacts is not None:
        panels += plots.effort_panels([(f"{name}_fn", "N") for name in result.contacts.names],
                                      result.contacts.values[:, 0].T)
    return panels


def table(result: SimulationResult, max_coordinates: int = 4) -> str:
    """The state at round times over the whole run (about 15 rows whatever the
    horizon, and the last row), units in the headers; rates (or the speeds of a
    robot with a spherical joint, after the coordinates) only up to
    ``max_coordinates`` coordinates (all of them are in simulate.csv)."""
    coordinates = result.robot.coordinates
    n = len(coordinates)
    rates = n <= max_coordinates
    speeds = [(u.name, u.unit) for u in result.robot.speeds] if rates else []
    # (header, column of x): each coordinate followed by its rate, or the speeds last
    shown = []
    for i, c in enumerate(coordinates):
        shown.append((f"{c.name} ({c.unit})", i))
        if rates and not speeds:
            shown.append((f"d{c.name} ({c.unit}/s)", n + i))
    shown += [(f"{name} ({unit})", n + k) for k, (name, unit) in enumerate(speeds)]
    rows = []
    for k in tables.grid_rows(len(result.t), result.settings.output_step):
        x = result.x[k]
        rows.append([tables.time_text(result.t[k])]
                    + [tables.number(x[column]) for _, column in shown])
    return tables.render(["t (s)"] + [header for header, _ in shown], rows)
