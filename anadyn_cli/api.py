"""The Python API: every command of ``anadyn`` as a function of ``import anadyn``.

    import anadyn
    robot = anadyn.load("rr", parameters={"m1": 2.0})   # a path, or a library name
    eom = anadyn.derive(robot, "lagrange")     # M(q) ddq = F(t, q, dq) + B(q) tau
    run = anadyn.simulate(robot, t_end=5)      # rows are times: run.t, run.x, run.efforts
    run.to_csv("rr.csv"); run.figure()         # a Matplotlib Figure; no backend switched
    inv = anadyn.inverse(robot)                # efforts along the file's trajectory
    anadyn.compare(robot).passed               # Lagrange against Kane

A robot is a path (YAML or URDF), a library name, a validated ``Robot``
(``load``) or, where numbers are computed, an already built
``NumericModel`` (``numeric_model``).  Settings are named as the library
names them (``output_step``, ``t_end``, ``roundtrip_tolerance``; a wrong
one raises ``SettingError`` with that name); a setting left at None takes
the robot file's value, then anadyn's default, as on the command line.
Nothing is printed; a file is written only by a function given an ``out``
folder (or by a result's ``to_csv``).  The derivation cache is off unless
``cache=True``.  ``formulation`` and ``evaluator`` choose what computes
the numbers (``numeric.build``; the command line's ``--formulation`` and
``--evaluator``).  Checks are returned, not raised: ``passed`` on the
result says whether the command would exit 1.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping


def load(robot, parameters: Mapping[str, object] | None = None):
    """The validated robot.

    :param robot: a YAML or URDF file's path, a library name, or a ``Robot`` (returned
        as it is).
    :param parameters: values replacing the file's ``parameters`` (numbers, or
        expressions as the file writes them); the file is not written.  A name the
        file does not define is a ``ModelError``.
    :returns: the frozen, validated ``Robot``.
    """
    from .errors import ModelError
    from .model import load_robot

    if not _is_robot(robot):
        return load_robot(robot, parameters)
    if parameters:
        raise ModelError("parameters apply to a robot file or library name, not to a loaded "
                         "Robot: load(path, parameters=...)")
    return robot


def derive(robot, formulation: str = "kane", symbolic: bool = False):
    """The equations of motion, M(q) ddq = F(t, q, dq) + B(q) tau.

    :param robot: see ``load``.
    :param formulation: "kane" or "lagrange".
    :param symbolic: keep the parameters as symbols (else their values are put in).
    :returns: an ``EquationsOfMotion`` (``M``, ``F``, ``B``, ``q``, ``dq``, ``ddq``,
        ``efforts``: SymPy matrices and symbols).
    """
    from .symbolic.formulations import derive as derive_equations

    model = load(robot)
    model.refuse_contacts("symbolic equations (derive, equations)")
    return derive_equations(model, formulation, symbolic=symbolic)


def equations(robot, formulation: str = "kane", fmt: str = "text", symbolic: bool = False,
              matrices: bool = False, energies: bool = False,
              kane_terms: bool = False) -> str:
    """What ``anadyn equations`` prints: the equations as readable text or LaTeX.

    :param robot: see ``load``.
    :param formulation: "kane" or "lagrange".
    :param fmt: "text", or "latex" (a document that compiles as it is).
    :param symbolic: keep the parameters as symbols.
    :param matrices: M, F, B instead of one equation per coordinate.
    :param energies: the kinetic and potential energy of each body and in total.
    :param kane_terms: Kane's generalized active and inertia forces per coordinate.
        With none of the three, the equations; with several, each part in that order.
    :returns: the text.
    """
    from . import progress
    from .symbolic import render as printout
    from .symbolic import terms

    model = load(robot)
    equations_asked = matrices or not (energies or kane_terms)
    parts = []
    if equations_asked or kane_terms:
        eom = derive(model, formulation, symbolic)
    if equations_asked:
        parts.append(printout.render(eom, fmt, "matrices" if matrices else "residual"))
        if model.constraints is not None:
            from .symbolic.formulations.constrained import render_constraints
            parts.append(render_constraints(model, fmt, symbolic))
    if energies:
        with progress.task(f"energies of {model.name}"):
            parts.append(terms.render_energies(terms.energies(model, symbolic), fmt,
                                               model.q, printout.printer))
    if kane_terms:
        with progress.task(f"Kane's terms of {model.name}"):
            parts.append(terms.render_kane_terms(terms.kane_terms(model, eom), fmt,
                                                 printout.printer))
    text = "\n".join(parts)
    if fmt == "latex":
        text = printout.latex_document(text, f"{model.name}: {formulation}, "
                                             f"{'symbolic' if symbolic else 'numeric'} "
                                             "parameters")
    return text


def numeric_model(robot, formulation: str | None = None, evaluator: str | None = None,
                  cache: bool = False):
    """The compiled model the numeric functions run (build it once, run it often).

    :param robot: see ``load``; a ``NumericModel`` is returned as it is.
    :param formulation: "kane" or "lagrange": evaluate the closed forms of these
        equations; None: none named.
    :param evaluator: "recursive" (Newton-Euler recursions, open trees only),
        "closed-form", or None: recursive on an open tree unless a formulation is
        named, Kane's closed forms on a closed chain.
    :param cache: reuse (and fill) the derivation cache.
    :returns: a ``NumericModel``; its ``formulation`` and ``evaluator`` say what runs.
    """
    from .numeric.build import numeric_model as build
    from .numeric.model import NumericModel

    if isinstance(robot, NumericModel):
        return robot
    return build(robot if _is_robot(robot) else _path(robot), formulation, use_cache=cache,
                 evaluator=evaluator)


def derivatives(robot, native: bool = True, parameters=()):
    """The open-loop derivatives of the forward and inverse dynamics (recursive
    path, open trees): ``forward_derivatives(t, q, dq, tau)``,
    ``inverse_derivatives(t, q, dq, ddq)``, ``mass_matrix_inverse(q)``, and with
    ``parameters`` ``forward_parameter_derivatives(t, q, dq, tau)`` (d(ddq)/dp, (n, k)),
    ``inverse_parameter_derivatives(t, q, dq, ddq)`` (d(ID)/dp, (n, k)) and
    ``closed_loop_parameter_derivatives(t, q, dq)`` (d(ddq)/dp under the control laws),
    at one state or at N states (rows); shapes in ``anadyn_cli.numeric.derivatives``.

    :param robot: see ``load``.
    :param native: run C (compiled now on first use, then cached; the generated
        Python, vectorized by NumPy, without a compiler); False: the Python.
    :param parameters: names of the robot file's parameters (a mass, a length, an
        inertia, g, ...) or gains to differentiate with respect to, in the columns'
        order.
    :returns: a ``Derivatives`` (``native`` is the C extension or None, ``note``
        says why).
    """
    from .numeric.derivatives import derivatives as build

    return build(load(robot), native, parameters)


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
    from .services.simulate import simulate as run

    return run(numeric_model(robot, formulation, evaluator, cache), method=method, rtol=rtol,
               atol=atol, t_end=t_end, output_step=output_step, estimate_error=estimate_error)


def inverse(robot, formulation: str | None = None, evaluator: str | None = None,
            cache: bool = False, output_step: float | None = None, roundtrip: bool = True,
            roundtrip_tolerance: float | None = None,
            roundtrip_segment: float | None = None, motion=None,
            smoothing_window: int | None = None, smoothing_order: int | None = None):
    """Efforts that produce the file's prescribed motion, or a measured one
    (``anadyn inverse [--motion data.csv]``).

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
    :returns: an ``InverseResult``: ``t``, ``q``, ``dq``, ``ddq``, ``efforts`` with rows
        as times; ``roundtrip.passed`` says whether the round trip met its tolerance.
    """
    from .numeric import measured
    from .services.inverse import DEFAULT_TOLERANCE, inverse as run

    tolerance = DEFAULT_TOLERANCE if roundtrip_tolerance is None else roundtrip_tolerance
    model = numeric_model(robot, formulation, evaluator, cache)
    samples = None
    if motion is not None:
        how = measured.Differentiator.given(smoothing_window, smoothing_order)
        samples = measured.read_motion(motion, model.coordinates, how)
    return run(model, step=output_step, roundtrip=roundtrip, tolerance=tolerance,
               segment=roundtrip_segment, measured=samples)


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
    from .services.check import check as run

    return run(numeric_model(robot, formulation, evaluator, cache), rtol=rtol, atol=atol,
               t_end=t_end, output_step=output_step,
               **_given(samples=samples, max_condition=max_condition, energy_tol=energy_tol))


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
    from .services.compare import compare as run

    return run([load(r) for r in robots], t_end=t_end, use_cache=cache,
               **_given(samples=samples, seed=seed, rtol=numeric_tolerance,
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
    from .numeric.integrators import METHODS
    from .services.accuracy import study

    if methods is not None:
        by_name = {m.lower(): m for m in METHODS}
        methods = tuple(by_name.get(m.lower(), m) for m in methods)
    return study(numeric_model(robot, formulation, evaluator, cache), t_end=t_end,
                 output_step=output_step,
                 **_given(methods=methods, repeats=repeats, max_calls=max_calls,
                          reference_calls=reference_calls,
                          tolerances=None if tolerances is None else tuple(tolerances)))


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
    from .services import export as service

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
    from .model.constraints import refuse_closed_chain
    from .services import optimize as service

    model = load(robot)
    refuse_closed_chain(model, "optimize")
    result = service.optimize(model, None if goal is None else dict(goal),
                              None if start is None else dict(start), duration, objective,
                              intervals)
    if out is not None:
        service.write(result, Path(out), model.source)
    return result


def linearize(robot, at: str | None = None, equilibrium: bool = False,
              symbolic: bool = False, efforts: str = "auto", formulation: str = "kane"):
    """State-space matrices, modes and controllability at an operating point
    (``anadyn linearize``).

    :param robot: see ``load``.
    :param at: the operating point, "name=value" items separated by commas: ``t``,
        coordinates (``q1=pi/6``), rates (``dq1=0``), efforts, or vectors ``q=[...]``,
        ``dq=[...]``, ``tau=[...]`` [the file's initial state at t = 0].
    :param equilibrium: first find the static equilibrium nearest the given state.
    :param symbolic: also give the matrices with the parameters as symbols.
    :param efforts: "auto", "controller", "holding" or "zero" (unless ``at`` gives them).
    :param formulation: "kane" or "lagrange".
    :returns: a ``Linearization`` (``A``, ``B``, ``A_closed_loop`` as numpy arrays,
        ``eigenvalues``, ``controllability_rank``).
    """
    from .services import linearize as service

    model = load(robot)
    service.check_efforts(model, efforts, service.parse_at(at, model))
    return service.linearize(model, formulation, at, equilibrium, symbolic, efforts=efforts)


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
    from .studies import executors
    from .studies import sweep as service

    plan = service.plan(_path(robot), list(vary), command, formulation,
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
    from .studies import batch as service
    from .studies import executors

    plan = service.load_batch(config)
    client = executors.connect(scheduler) if scheduler is not None else None
    try:
        result = service.run(plan, Path(out), jobs, scheduler=client)
    finally:
        if client is not None:
            client.close()
    service.write(result, Path(out))
    return result


def view(robot, run=None, package_paths: Iterable = (), cache: bool = False,
         out: Path | str | None = None):
    """The robot in 3-D (``anadyn view``): its URDF meshes or generated shapes, playing a
    run with a time slider, or with a slider per coordinate.

    :param robot: a YAML or URDF file, a library name, or a loaded ``Robot``.
    :param run: a simulate.csv or inverse.csv of this robot to play (columns ``t`` and
        every coordinate).
    :param package_paths: folders holding the ROS packages that ``package://`` mesh
        paths name (ROS_PACKAGE_PATH and pip's example-robot-data are searched too).
    :param cache: reuse the generated kinematics from the derivation cache.
    :param out: a folder to write view.html and view.json into.
    :returns: a ``View``: ``html()`` is the self-contained page; in Jupyter it shows
        itself inline.
    """
    from .model.library import resolve
    from .services import view as service

    model = load(robot)
    played = service.read_run(run, [c.name for c in model.coordinates]) if run else None
    urdf = resolve(robot) if isinstance(robot, (str, Path)) else None
    result = service.view(model, played,
                          urdf if urdf is not None and urdf.suffix.lower() == ".urdf" else None,
                          tuple(package_paths), use_cache=cache)
    if out is not None:
        service.write(result, Path(out))
    return result


def show(robot, at: Mapping[str, float] | Iterable[str] = (), cache: bool = False):
    """The robot drawn at its initial pose, or another (``anadyn show``).

    :param robot: see ``load``.
    :param at: the pose: coordinate values ({"q1": 0.3}) or "q1=30deg" items.
    :param cache: reuse the generated kinematics from the cache.
    :returns: a ``Drawing`` (``figure()``: a Matplotlib Figure; ``pose``: every frame).
    """
    from .numeric.frames import frames
    from .services import show as service

    return service.draw(frames(_source(robot), use_cache=cache), _items(at))


def animate(robot, out: str | Path | None = None, motion: str = "simulate",
            frames: int = 150, mp4: bool = True, formulation: str | None = None,
            evaluator: str | None = None, cache: bool = False, method: str | None = None,
            t_end: float | None = None, output_step: float | None = None):
    """The robot moving (``anadyn animate``).

    :param robot: see ``load``.
    :param out: folder for animate.gif (animate.mp4 with ffmpeg) and animate.json;
        None: write nothing.
    :param motion: "simulate" (the direct dynamics under the feedback laws) or
        "inverse" (the file's prescribed trajectory).
    :param frames: most frames in the animation.
    :param mp4: also write animate.mp4 when ffmpeg is on the PATH.
    :param formulation: see ``numeric_model``.
    :param evaluator: see ``numeric_model``.
    :param cache: see ``numeric_model``.
    :param method: integrator, as ``simulate``.
    :param t_end: horizon of the simulation, s.
    :param output_step: step of the motion's rows, s.
    :returns: an ``Animation`` (``times``; ``images``: the frames as arrays;
        ``computation``: what computed the motion).
    """
    from . import errors
    from .errors import ModelError, NumericalError
    from .numeric.frames import frames as kinematics
    from .services import show as service

    errors.check("frames", frames)
    if motion not in ("simulate", "inverse"):
        raise ModelError(f"motion must be simulate or inverse, got {motion!r}")
    source = _source(robot)
    if motion == "inverse":
        run = inverse(source, formulation, evaluator, cache, output_step=output_step,
                      roundtrip=False)
        q = run.q
    else:
        run = simulate(source, formulation, evaluator, cache, method=method, t_end=t_end,
                       output_step=output_step)
        if not run.solution.success:
            raise NumericalError(f"{run.robot.source}: {run.solution.message}")
        q = run.x[:, :len(run.robot.coordinates)]
    animation = service.animate(kinematics(source, use_cache=cache), run.t, q,
                                f"{run.robot.name}: animate {motion}", max_frames=frames)
    animation.computation = {"formulation": run.formulation, "evaluator": run.evaluator}
    if out is not None:
        service.write_animation(animation, Path(out), mp4=mp4)
    return animation


def import_urdf(urdf, out: str | Path | None = None, fix_base: bool = False,
                inertia: str = "refuse", lock: Mapping[str, float | str] | None = None):
    """A URDF robot as an anadyn robot file (``anadyn import``).

    :param urdf: a URDF file's path, or the name of a library robot.
    :param out: the robot file to write (YAML with comments); None: write nothing.
    :param fix_base: weld a floating or planar root joint to the world.
    :param inertia: physically impossible inertias: "refuse", "repair" or "accept".
    :param lock: joints held at a value, {joint: number or text such as "pi/4"}: a
        reduced robot, as Pinocchio's ``buildReducedModel`` makes it.
    :returns: an ``Imported``: ``text`` (the robot file), ``data``, ``warnings``; the
        text is validated as a robot before it is returned.
    """
    from .errors import ModelError
    from .files import write_text
    from .model import library, robot_from_text
    from .model.urdf import import_file

    path = library.resolve(urdf)
    if path.suffix.lower() != ".urdf":
        raise ModelError("not a URDF file (expected a .urdf file name)", source=str(path))
    imported = import_file(path, fix_base=fix_base, inertia=inertia, lock=lock or ())
    robot_from_text(imported.text, f"{path} (imported)")         # what is written loads
    if out is not None:
        write_text(Path(out), imported.text)
    return imported


def robots():
    """The robot library (``anadyn robots``).

    :returns: one ``library.Entry`` per robot: ``name``, ``path``, ``dof``, ``joints``,
        ``description``.
    """
    from .model import library

    return library.listing()


def parametric_model(robot):
    """The robot's dynamics linear in its parameters, Q = Y(q, dq, ddq) pi (open trees;
    each joint displacement linear in the coordinates).

    :param robot: see ``load``.
    :returns: a ``ParametricModel``: ``regressor(q, dq, ddq)`` (N, n, p),
        ``actuator_regressor`` (N, m, p), ``names`` (10 per body: m, m*cx, m*cy, m*cz,
        Ixx, Ixy, Iyy, Ixz, Iyz, Izz about the body origin in body axes; per moving
        joint Ia, Fv, Fc), ``nominal`` (the file's pi).
    """
    from .studies.identification.regressor import parametric_model as build

    return build(load(robot))


def base_parameters(robot, exact: bool | None = None, states: int = 60, seed: int = 0):
    """The identifiable combinations of the parameters (``equations --base-parameters``).

    :param robot: see ``load``.
    :param exact: also solve the coefficients exactly from Kane's equations [robots of up
        to three coordinates].
    :param states: random states of the rank-revealing QR.
    :param seed: their seed.
    :returns: a ``BaseParameters``: ``rank``, ``K`` (base = K pi), ``expressions()``,
        ``exact`` (rational coefficients or None).
    """
    from .studies.identification.base import base_parameters as compute

    return compute(parametric_model(robot), states, seed, exact)


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
    from .numeric import measured
    from .studies.identification import estimate as service

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
    from .studies.identification import excite as service

    result = service.excite(parametric_model(robot), period=period, harmonics=harmonics,
                            samples=samples, margin=margin, seed=seed,
                            iterations=iterations, output_step=output_step)
    if out is not None:
        service.write(result, Path(out))
    return result


def _given(**settings) -> dict:
    """The settings that are not None (the others keep the service's defaults)."""
    return {k: v for k, v in settings.items() if v is not None}


def _items(at) -> list[str]:
    """A pose as "name=value" items (``show``'s ``at``)."""
    if isinstance(at, Mapping):
        return [f"{name}={float(value)!r}" for name, value in at.items()]
    return [at] if isinstance(at, str) else list(at)


def _source(robot):
    """A ``Robot`` as it is, else the path (a library name resolved)."""
    return robot if _is_robot(robot) else _path(robot)


def _is_robot(value) -> bool:
    from .model.robot import Robot

    return isinstance(value, Robot)


def _path(value) -> Path:
    return value if isinstance(value, Path) else Path(str(value))
