"""Many runs and products: export, optimize, sweep, batch, identify, excite."""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

from .common import path_of
from .models import load, parametric_model


def export(robot, lang: str, out: str | Path | None = None, formulation: str = "kane",
           symbolic: bool = False, fragment: bool = False):
    """The equations as standalone code or a LaTeX document (``anadyn export``).

    :param robot: see ``load``.
    :param lang: "python", "c", "matlab", "latex", "casadi" or "jax".
    :param out: folder to write the files (and export.json) to; None: write nothing.
    :param formulation: "kane" or "lagrange".
    :param symbolic: pass the parameters and gains in instead of folding them in.
    :param fragment: LaTeX only: the body without preamble.
    :returns: an ``ExportResult``; ``files`` maps each file name to its text.
    """
    from ..services import export as service

    service.check_options(lang, fragment, symbolic)
    result = service.export(load(robot), lang, formulation, symbolic, fragment)
    if out is not None:
        service.write(result, Path(out))
    return result


def optimize(robot, goal: Mapping[str, float] | None = None,
             start: Mapping[str, float] | None = None, duration: float | None = None,
             objective: str = "effort", intervals: int = 20, out: str | Path | None = None):
    """A rest-to-rest motion of least effort or least time under the file's joint limits,
    by Hermite-Simpson collocation with IPOPT (``anadyn optimize``; needs CasADi).

    :param robot: see ``load`` (an open chain).
    :param goal: coordinate -> value [the file's trajectory ``to``].
    :param start: coordinate -> value [the trajectory's ``from``, else the initial values].
    :param duration: s; with objective "time" the first guess [the trajectory's duration].
    :param objective: "effort" (integral of the squared efforts) or "time".
    :param intervals: collocation intervals.
    :param out: folder for optimize.csv, trajectory.yaml, NAME_optimized.yaml (YAML
        robots) and optimize.json; None: write nothing.
    :returns: an ``OptimizeResult`` (``t``, ``q``, ``dq``, ``ddq``, ``u`` rows at the knots
        and midpoints; ``success``, ``status``, ``defect``, ``margins``); a failed solve is
        returned with ``success`` False and the best iterate, not raised.
    """
    from ..model.constraints import refuse_closed_chain
    from ..services import optimize as service

    model = load(robot)
    refuse_closed_chain(model, "optimize")
    result = service.optimize(model, None if goal is None else dict(goal),
                              None if start is None else dict(start), duration, objective,
                              intervals)
    if out is not None:
        service.write(result, Path(out), model.source)
    return result


def sweep(robot, vary: Iterable[str], command: str = "simulate",
          samples: int | None = None, seed: int = 0, metrics: str | None = None,
          maxima: Iterable[str] = (), minima: Iterable[str] = (), jobs: int | None = None,
          scheduler: str | None = None, formulation: str = "kane", cache: bool = False,
          **settings):
    """One robot, many values of its parameters or gains (``anadyn sweep``).

    :param robot: a YAML or URDF file's path, or a library name.
    :param vary: "NAME=SPEC" items: FROM:TO:COUNT (grid), V1,V2,... (list),
        normal(MEAN,SD) or uniform(LOW,HIGH) (Monte-Carlo).
    :param command: what each sample runs: "simulate", "inverse" or "check".
    :param samples: Monte-Carlo draws per distribution [100].
    :param seed: seed of the draws.
    :param metrics: comma-separated metrics [the command's].
    :param maxima: "METRIC=BOUND" limits, METRIC <= BOUND.
    :param minima: "METRIC=BOUND" limits, METRIC >= BOUND.
    :param jobs: local worker processes [all cores].
    :param scheduler: a Dask scheduler's address [local processes].
    :param formulation: "kane" or "lagrange" (a sweep evaluates the closed forms).
    :param cache: see ``numeric_model``.
    :param settings: the runs' settings by their library names: method, rtol, atol,
        t_end, output_step, settle_band, roundtrip, roundtrip_tolerance,
        roundtrip_segment, energy_tol, max_condition.
    :returns: a ``SweepResult`` (one row per sample: the varied values, status, metrics).
    """
    from ..studies import executors
    from ..studies import sweep as service

    plan = service.plan(path_of(robot), list(vary), command, formulation,
                        samples=samples, seed=seed, metrics=metrics, maxima=list(maxima),
                        minima=list(minima), use_cache=cache, **settings)
    client = executors.connect(scheduler) if scheduler is not None else None
    try:
        return service.run(plan, jobs=jobs, scheduler=client)
    finally:
        if client is not None:
            client.close()


def batch(config, out: str | Path, jobs: int | None = None, scheduler: str | None = None):
    """Run the jobs of a batch file and judge each against its expectations
    (``anadyn batch``).

    :param config: the batch file (YAML).
    :param out: folder of the jobs' results and of summary.csv, summary.json, junit.xml.
    :param jobs: jobs run at the same time [all cores].
    :param scheduler: a Dask scheduler's address [local processes].
    :returns: a ``BatchResult``: ``results``, one ``JobResult`` per job (``ok``,
        ``failures``, ``figures``); ``failed``, those that missed their expectations.
    """
    from ..studies import batch as service
    from ..studies import executors

    plan = service.load_batch(config)
    client = executors.connect(scheduler) if scheduler is not None else None
    try:
        result = service.run(plan, Path(out), jobs, scheduler=client)
    finally:
        if client is not None:
            client.close()
    service.write(result, Path(out))
    return result


def identify(robot, data, out: str | Path | None = None, holdout: float = 0.2,
             physical: bool = False, smoothing_window: int | None = None,
             smoothing_order: int | None = None):
    """Base parameters from measured motion and efforts (``anadyn identify``).

    :param robot: see ``load``.
    :param data: a CSV with the columns of inverse.csv: t, each coordinate, optionally
        d<q> and dd<q>, each actuator.
    :param out: folder for identify.csv, identify.png, identify_residuals.png,
        NAME_identified.yaml and identify.json; None: write nothing.
    :param holdout: the last fraction of the samples, kept out of the estimate to judge
        its predictions.
    :param physical: fit the physically consistent parameters for the robot file.
    :param smoothing_window: the Savitzky-Golay window for missing rates (odd) [21].
    :param smoothing_order: its degree [3].
    :returns: an ``Identification`` (``estimate``, ``std``, ``condition``, ``predicted``,
        ``pi``, ``rms()``, ``robot_text``).
    """
    from ..numeric import measured
    from ..studies.identification import estimate as service

    model = parametric_model(robot)
    how = measured.Differentiator.given(smoothing_window, smoothing_order)
    result = service.identify(model, service.read_measurements(data, model, how),
                              holdout=holdout, physical=physical)
    if out is not None:
        service.write(result, Path(out))
    return result


def excite(robot, out: str | Path | None = None, period: float = 10.0, harmonics: int = 5,
           samples: int = 100, margin: float = 0.9, seed: int = 0, iterations: int = 100,
           output_step: float = 0.01):
    """An exciting trajectory for identification (``anadyn excite``): Fourier series
    within the joint limits, least condition number of the base regressor.

    :param robot: see ``load``.
    :param out: folder for excite.csv, NAME_excite.yaml and excite.json; None: write
        nothing.
    :param period: s.
    :param harmonics: terms of each series.
    :param samples: times of one period the condition number and limits are taken at.
    :param margin: fraction of each limit used.
    :param seed: of the random start.
    :param iterations: of the optimizer (SLSQP).
    :param output_step: step of excite.csv, s.
    :returns: an ``Excitation`` (``t``, ``q``, ``dq``, ``ddq``, ``efforts``,
        ``condition``, ``expressions()``).
    """
    from ..studies.identification import excite as service

    result = service.excite(parametric_model(robot), period=period, harmonics=harmonics,
                            samples=samples, margin=margin, seed=seed,
                            iterations=iterations, output_step=output_step)
    if out is not None:
        service.write(result, Path(out))
    return result
