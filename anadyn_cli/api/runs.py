"""Runs of one robot: simulate, inverse, check, compare, accuracy, linearize."""
from __future__ import annotations

from typing import Iterable

from .common import given
from .models import load, numeric_model


def simulate(robot, formulation: str | None = None, evaluator: str | None = None,
             cache: bool = False, method: str | None = None, rtol: float | None = None,
             atol: float | None = None, t_end: float | None = None,
             output_step: float | None = None, estimate_error: bool = False):
    """Direct dynamics under the file's control laws (``anadyn simulate``).

    :param robot: see ``numeric_model``.
    :param formulation: see ``numeric_model``.
    :param evaluator: see ``numeric_model``.
    :param cache: see ``numeric_model``.
    :param method: integrator: auto, odeint, RK45, RK23, DOP853, Radau, BDF, LSODA.
    :param rtol: relative tolerance.
    :param atol: absolute tolerance.
    :param t_end: horizon, s.
    :param output_step: step of the output rows, s.
    :param estimate_error: also estimate the run's global error (a re-solve).
    :returns: a ``SimulationResult``: ``t`` (N,), ``x`` (N, 2n) = [q, dq], ``efforts``
        (N, m); a failed run is returned, not raised (``result.solution.success``).
    """
    from ..services.simulate import simulate as run

    return run(numeric_model(robot, formulation, evaluator, cache), method=method, rtol=rtol,
               atol=atol, t_end=t_end, output_step=output_step, estimate_error=estimate_error)


def inverse(robot, formulation: str | None = None, evaluator: str | None = None,
            cache: bool = False, output_step: float | None = None, roundtrip: bool = True,
            roundtrip_tolerance: float | None = None,
            roundtrip_segment: float | None = None, motion=None,
            smoothing_window: int | None = None, smoothing_order: int | None = None,
            contact_gap: float | None = None, contact_resolution: str = "least-norm"):
    """Efforts that produce the file's prescribed motion, or a measured one
    (``anadyn inverse [--motion data.csv]``); on a robot in contact, the contact forces
    it needs too (``numeric.contact_inverse``).

    :param robot: see ``numeric_model``.
    :param formulation: see ``numeric_model``.
    :param evaluator: see ``numeric_model``.
    :param cache: see ``numeric_model``.
    :param output_step: step of the output rows, s.
    :param roundtrip: integrate the direct dynamics driven by the efforts and measure
        how closely it follows the motion.
    :param roundtrip_tolerance: largest allowed tracking error, rad or m [1e-6].
    :param roundtrip_segment: length of the round trip's pieces, s [automatic].
    :param motion: a CSV of measured motion (the columns of inverse.csv: ``t``, each
        coordinate, optionally every ``d<q>`` and ``dd<q>``) to use instead of the
        file's trajectory; rates and accelerations it lacks come from a
        Savitzky-Golay filter.
    :param smoothing_window: the filter's window, samples (odd) [21].
    :param smoothing_order: the filter's polynomial degree [3].
    :param contact_gap: the largest gap of an active contact, m [1e-6].
    :param contact_resolution: how redundant contact forces are chosen: "least-norm", or
        "cone" (the least-norm ones inside the friction cones where those leave them).
    :returns: an ``InverseResult``: ``t``, ``q``, ``dq``, ``ddq``, ``efforts`` with rows
        as times; ``roundtrip.passed`` says whether the round trip met its tolerance;
        ``contact.forces`` (rows, contacts, 3) the contact forces needed.
    """
    from ..numeric import contact_inverse, measured
    from ..services.inverse import DEFAULT_TOLERANCE, inverse as run

    tolerance = DEFAULT_TOLERANCE if roundtrip_tolerance is None else roundtrip_tolerance
    model = numeric_model(robot, formulation, evaluator, cache)
    samples = None
    if motion is not None:
        how = measured.Differentiator.given(smoothing_window, smoothing_order)
        samples = measured.read_motion(motion, model.coordinates, how,
                                       speeds=model.speeds, quaternions=model.quaternions)
    return run(model, step=output_step, roundtrip=roundtrip, tolerance=tolerance,
               segment=roundtrip_segment, measured=samples,
               contact_gap=(contact_inverse.DEFAULT_GAP if contact_gap is None
                            else contact_gap),
               contact_resolution=contact_resolution)


def check(robot, formulation: str | None = None, evaluator: str | None = None,
          cache: bool = False, rtol: float | None = None, atol: float | None = None,
          t_end: float | None = None, output_step: float | None = None,
          samples: int | None = None, max_condition: float | None = None,
          energy_tol: float | None = None):
    """Stability report along the simulated path (``anadyn check``).

    :param robot: see ``numeric_model``.
    :param formulation: see ``numeric_model``.
    :param evaluator: see ``numeric_model``.
    :param cache: see ``numeric_model``.
    :param rtol: relative tolerance of the run.
    :param atol: absolute tolerance of the run.
    :param t_end: horizon, s.
    :param output_step: step of the path's rows, s.
    :param samples: points where the Jacobian's eigenvalues are taken [200].
    :param max_condition: threshold on the scaled condition number of M [1e8].
    :param energy_tol: threshold on the energy balance's error over its scale [1e-6].
    :returns: a ``StabilityReport`` (``t``, ``x`` rows as times; ``passed``, ``checks``).
    """
    from ..services.check import check as run

    return run(numeric_model(robot, formulation, evaluator, cache), rtol=rtol, atol=atol,
               t_end=t_end, output_step=output_step,
               **given(samples=samples, max_condition=max_condition, energy_tol=energy_tol))


def compare(*robots, samples: int | None = None, seed: int | None = None,
            numeric_tolerance: float | None = None, trajectory_tolerance: float | None = None,
            symbolic_terms: int | None = None, t_end: float | None = None,
            cache: bool = False):
    """Lagrange against Kane: symbolically, numerically and along the motion
    (``anadyn compare``).

    :param robots: one or more robots (see ``load``).
    :param samples: random states of the numeric check [200].
    :param seed: seed of the random states [0].
    :param numeric_tolerance: largest allowed relative difference of M, F, B, ddq [1e-9].
    :param trajectory_tolerance: largest allowed difference of the simulated states [1e-7].
    :param symbolic_terms: budget of the symbolic check in expanded terms; 0: off [10000].
    :param t_end: horizon of the trajectory check, s.
    :param cache: see ``numeric_model``.
    :returns: a ``CompareResult`` (``passed``; one ``RobotComparison`` per robot).
    """
    from ..services.compare import compare as run

    return run([load(r) for r in robots], t_end=t_end, use_cache=cache,
               **given(samples=samples, seed=seed, rtol=numeric_tolerance,
                        trajectory_tol=trajectory_tolerance, symbolic_terms=symbolic_terms))


def accuracy(robot, methods: Iterable[str] | None = None,
             tolerances: Iterable[float] | None = None, repeats: int | None = None,
             max_calls: int | None = None, reference_calls: int | None = None,
             t_end: float | None = None, output_step: float | None = None,
             formulation: str | None = None, evaluator: str | None = None,
             cache: bool = False):
    """Work-precision study: error against run time for every method and tolerance
    (``anadyn accuracy``).

    :param robot: see ``numeric_model``.
    :param methods: integrators [all of them].
    :param tolerances: relative tolerances; atol = rtol * 1e-2 [1e-3 .. 1e-10].
    :param repeats: timed runs per setting, the minimum reported [3].
    :param max_calls: RHS-call budget per run [20000].
    :param reference_calls: RHS-call budget per reference attempt [500000].
    :param t_end: horizon, s.
    :param output_step: step of the grid the error is taken on, s.
    :param formulation: see ``numeric_model``.
    :param evaluator: see ``numeric_model``.
    :param cache: see ``numeric_model``.
    :returns: an ``AccuracyStudy`` (one ``Row`` per run; ``levels()``: the fastest
        setting per error level).
    """
    from ..numeric.integrators import METHODS
    from ..services.accuracy import study

    if methods is not None:
        by_name = {m.lower(): m for m in METHODS}
        methods = tuple(by_name.get(m.lower(), m) for m in methods)
    return study(numeric_model(robot, formulation, evaluator, cache), t_end=t_end,
                 output_step=output_step,
                 **given(methods=methods, repeats=repeats, max_calls=max_calls,
                          reference_calls=reference_calls,
                          tolerances=None if tolerances is None else tuple(tolerances)))


def linearize(robot, at: str | None = None, equilibrium: bool = False,
              symbolic: bool = False, efforts: str = "auto", formulation: str | None = None,
              evaluator: str | None = None):
    """State-space matrices, modes and controllability at an operating point
    (``anadyn linearize``).

    :param robot: see ``load``.
    :param at: the operating point, "name=value" items separated by commas: ``t``,
        coordinates (``q1=pi/6``), rates (``dq1=0``), efforts, or vectors ``q=[...]``,
        ``dq=[...]``, ``tau=[...]`` [the file's initial state at t = 0].
    :param equilibrium: first find the static equilibrium nearest the given state.
    :param symbolic: also give the matrices with the parameters as symbols.
    :param efforts: "auto", "controller", "holding" or "zero" (unless ``at`` gives them).
    :param formulation: "kane" or "lagrange": the closed forms of these equations.
    :param evaluator: "recursive" (the recursive Newton-Euler algorithm and its exact
        derivatives, on the generic kernel where it serves the robot, else generated
        for it; ``code`` in the result says which) or "closed-form" [recursive unless
        a formulation is given or the robot has a spherical joint].
    :returns: a ``Linearization`` (``A``, ``B``, ``A_closed_loop`` as numpy arrays,
        ``eigenvalues``, ``controllability_rank``).
    """
    from ..services import linearize as service

    model = load(robot)
    service.check_efforts(model, efforts, service.parse_at(at, model))
    return service.linearize(model, formulation, at, equilibrium, symbolic, efforts=efforts,
                             evaluator=evaluator)
