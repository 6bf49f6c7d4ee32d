"""Trajectory optimization (``anadyn optimize``): rest to rest between two poses,
minimizing effort or time under the robot file's joint limits.

Direct collocation, Hermite-Simpson (separated form), on N intervals of length
h = T/N with the state x = [q, dq] and the efforts u at the knots and the
interval midpoints, the dynamics f(t, x, u) = [dq, ddq] being the CasADi
function of anadyn's traced forward dynamics (``output.export.casadi``):

    x_mid   = (x_k + x_k+1)/2 + h/8 (f_k - f_k+1)
    x_k+1   = x_k + h/6 (f_k + 4 f_mid + f_k+1)

so that q(t) on each interval is the cubic Hermite interpolant of q and dq at
its ends, and the efforts are quadratic through u_k, u_mid, u_k+1.  Objective
``effort``: the Simpson sum of |u|^2 dt over [0, T], T given; ``time``: T.
Constraints at every knot and midpoint: the joints' position bounds on
theta(q), their rate bounds on dtheta/dt, the actuators' effort bounds (the
file's ``limits``, imposed ``BACKOFF`` inside them but for the start and goal poses); start
and goal at rest.  IPOPT (shipped with CasADi) solves it, from straight lines
at rest; ``defect`` is the largest collocation residual, ``margins`` the
smallest distance of every bounded quantity to its bound over the points.
The file's control laws play no part: the efforts are the unknowns.  Needs
the optional extra ``casadi``.

For ``simulate`` to track the motion, ``tracking`` writes feedback laws of t, q
and dq for the optimized robot file: per actuator a on a joint of displacement
theta_a(q) (linear in q),

    tau_a = u_a(t) - kp_a (theta_a(q) - theta_a(r(t))) - kd_a (dtheta_a - dtheta_a(r, dr))

with u_a the optimized efforts (quadratic on each interval, as the collocation
assumes) and r(t) the optimized motion (the cubic Hermite interpolant of q and
dq at the knots); after T, r is the goal and u_a the efforts that hold it at
rest (least squares with fewer actuators than coordinates), and kp_a = w^2 L_a,
kd_a = 2 w L_a, L_a = 1 / (A^T M A)_aa (A = M^-1 B: the inertia the actuator
feels at the start pose), w = ``TRACKING_FREQUENCY``.  The robot file's
expressions have no table lookup, so u_a + kp_a theta_a(r) + kd_a dtheta_a(r, dr),
one piecewise cubic in t, is written as a cubic plus truncated powers
max(t - t_k, 0)^j at the knots and a step (sign(t - T) + 1)/2 at T
(coefficients to ten digits); a law longer than
an expression may be (``model.expressions.MAX_LENGTH``: about 25 intervals) is
not written, and the optimized file says so.
"""
from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field
from functools import reduce
from pathlib import Path

import numpy as np

from .. import files as output
from ..output.csv_table import write_csv
from ..errors import ModelError, NumericalError, SettingError
from ..model.info import RobotInfo

OBJECTIVES = ("effort", "time")
#: the operations of ``model.info.expression_tree`` nodes, in CasADi
OPERATIONS = {"+": operator.add, "*": operator.mul, "**": operator.pow, "sin": "sin",
              "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos", "atan": "atan",
              "atan2": "atan2", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "exp": "exp",
              "log": "log", "Abs": "fabs", "sign": "sign", "Min": "fmin", "Max": "fmax"}
MAX_INTERVALS = 200
#: the tracking laws' natural frequency (rad/s), critically damped (``tracking``)
TRACKING_FREQUENCY = 10.0
#: the bounds are imposed this much (relative) inside the file's, so that IPOPT's
#: constraint tolerance never puts a point beyond them
BACKOFF = 1e-6


@dataclass
class OptimizeResult:
    robot: str
    coordinates: list[str]
    efforts: list[str]
    objective: str
    status: str                      # IPOPT's return status
    success: bool
    iterations: int
    cost: float
    intervals: int
    t: np.ndarray                    # (2N+1,) knots and midpoints
    q: np.ndarray                    # (2N+1, n)
    dq: np.ndarray
    ddq: np.ndarray
    u: np.ndarray                    # (2N+1, m)
    defect: float
    goal_error: float                # max |q(T) - goal|, |dq(T)|
    margins: list[dict] = field(default_factory=list)
    #: the robot file's ``controller`` section that tracks the motion (``tracking``), or
    #: None and why not
    controller: dict | None = None
    no_controller: str = ""

    @property
    def duration(self) -> float:
        return float(self.t[-1])


def _tree(ca, node, values: dict):
    if isinstance(node, (int, float)):
        return float(node)
    if isinstance(node, str):
        return values[node]
    operation, *arguments = node
    function = OPERATIONS[operation]
    function = getattr(ca, function) if isinstance(function, str) else function
    arguments = [_tree(ca, a, values) for a in arguments]
    if operation in ("+", "*") or len(arguments) > 2:          # n-ary: folded
        return reduce(function, arguments)
    return function(*arguments)


def _bounded(ca, info: RobotInfo, q, dq, u) -> list[tuple[str, str, object, float, float]]:
    """(name, quantity, value, lower, upper) for every bound of the file."""
    values = {c.name: q[i] for i, c in enumerate(info.coordinates)}
    values.update({"d" + c.name: dq[i] for i, c in enumerate(info.coordinates)})
    found = []
    for joint in info.joint_limits:
        if joint.lower is not None or joint.upper is not None:
            found.append((joint.label, "position", _tree(ca, joint.displacement, values),
                          -np.inf if joint.lower is None else joint.lower,
                          np.inf if joint.upper is None else joint.upper))
        if joint.velocity is not None:
            found.append((joint.label, "rate", _tree(ca, joint.rate, values),
                          -joint.velocity, joint.velocity))
    for k, actuator in enumerate(info.actuators):
        if actuator.effort_limit is not None:
            found.append((actuator.name, "effort", u[k], -actuator.effort_limit,
                          actuator.effort_limit))
    return found


def endpoints(robot, goal: dict | None, start: dict | None) -> tuple[np.ndarray, np.ndarray]:
    """Start and goal poses: given, else the file's trajectory ``from`` / ``to``, else
    (start) the initial values; ModelError for an unknown coordinate or no goal."""
    names = [c.name for c in robot.coordinates]
    section = robot.trajectory if robot.trajectory is not None and robot.trajectory.kind in (
        "cycloidal", "quintic") else None
    for setting, given in (("goal", goal or {}), ("start", start or {})):
        for name in given:
            if name not in names:
                raise SettingError(setting, f"names unknown coordinate {name!r}; coordinates: "
                                   f"{', '.join(names)}")
    q0 = np.array([float((start or {}).get(c.name, section.start.get(c.name, c.initial)
                                               if section else c.initial))
                   for c in robot.coordinates])
    if goal is None and section is None:
        raise SettingError("goal", "is missing: give the goal pose (the file has no "
                           "cycloidal or quintic trajectory to take it from)")
    end = goal if goal is not None else section.end
    qf = np.array([float(end.get(c.name, q0[i])) for i, c in enumerate(robot.coordinates)])
    return q0, qf


def optimize(robot, goal: dict | None = None, start: dict | None = None,
             duration: float | None = None, objective: str = "effort", intervals: int = 20,
             max_iterations: int = 1000, tolerance: float = 1e-10) -> OptimizeResult:
    """The optimal rest-to-rest motion of ``robot`` (a validated open-chain Robot) from
    ``start`` to ``goal`` (coordinate -> value; defaults: ``endpoints``) in ``duration``
    s (objective effort; default the file's trajectory duration) or in least time
    (``duration`` the first guess).  ModelError (exit 2) for a start or goal outside the
    position limits; a failed solve comes back with ``success`` False and the best
    iterate (``raise_if_failed``)."""
    from ..output.export import casadi as export_casadi
    from ..output.export.traced import trace

    ca = export_casadi.require()
    duration, q0, qf, info = _problem(ca, robot, goal, start, duration, objective, intervals)
    n, m = len(q0), len(robot.actuators)
    zero = np.zeros(n)
    export_casadi_functions = export_casadi.functions(trace(robot))
    fd = export_casadi_functions["forward_dynamics"]
    opti = ca.Opti()
    points = 2 * intervals + 1
    X = opti.variable(2 * n, points)
    U = opti.variable(m, points) if m else ca.MX(0, points)
    T = opti.variable() if objective == "time" else duration
    h = T / intervals
    t = [h * j / 2 for j in range(points)]
    F = [ca.vertcat(X[n:, j], fd(t[j], X[:n, j], X[n:, j], U[:, j])) for j in range(points)]
    defects = []
    for k in range(intervals):
        a, mid, b = 2 * k, 2 * k + 1, 2 * k + 2
        defects.append(X[:, mid] - (X[:, a] + X[:, b]) / 2 - h / 8 * (F[a] - F[b]))
        defects.append(X[:, b] - X[:, a] - h / 6 * (F[a] + 4 * F[mid] + F[b]))
    for d in defects:
        opti.subject_to(d == 0)
    opti.subject_to(X[:, 0] == np.concatenate([q0, zero]))
    opti.subject_to(X[:, -1] == np.concatenate([qf, zero]))
    for j in range(points):
        for _, quantity, value, lower, upper in _bounded(ca, info, X[:n, j], X[n:, j], U[:, j]):
            end = quantity == "position" and j in (0, points - 1)   # the poses may lie on a bound
            inside = 0.0 if end else BACKOFF
            if np.isfinite(lower):
                opti.subject_to(value >= lower + inside * max(1.0, abs(lower)))
            if np.isfinite(upper):
                opti.subject_to(value <= upper - inside * max(1.0, abs(upper)))
    if objective == "time":
        opti.subject_to(T >= 1e-3)
        opti.set_initial(T, duration if duration is not None else 1.0)
        opti.minimize(T)
    else:
        weights = [1.0 if j in (0, points - 1) else (4.0 if j % 2 else 2.0) for j in range(points)]
        opti.minimize(h / 6 * sum(w * ca.sumsqr(U[:, j]) for j, w in enumerate(weights)))
    s = np.linspace(0.0, 1.0, points)
    opti.set_initial(X, np.vstack([np.outer(q0, 1 - s) + np.outer(qf, s), np.zeros((n, points))]))
    opti.solver("ipopt", {"print_time": False},
                {"print_level": 0, "sb": "yes", "max_iter": max_iterations, "tol": tolerance})
    try:
        value, success = opti.solve().value, True
    except RuntimeError:                       # the best iterate, reported as failed
        value, success = opti.debug.value, False
    stats = opti.stats()
    x = np.array(value(X)).reshape(2 * n, points)
    u = np.array(value(U)).reshape(m, points)
    T = float(value(T)) if objective == "time" else float(T)
    result = OptimizeResult(
        robot.name, [c.name for c in robot.coordinates], [a.name for a in robot.actuators],
        objective, str(stats.get("return_status", "unknown")), success,
        int(stats.get("iter_count", 0)), float(value(opti.f)), intervals,
        np.linspace(0.0, T, points), x[:n].T, x[n:].T,
        np.array([np.array(value(f)).ravel()[n:] for f in F]), u.T,
        max(float(np.max(np.abs(np.array(value(d))))) for d in defects),
        float(max(np.max(np.abs(x[:n, -1] - qf)), np.max(np.abs(x[n:, -1])))))
    result.margins = _margins(ca, info, result)
    if m:
        result.controller, result.no_controller = tracking(
            robot, result, *_inertia_and_hold(export_casadi_functions, q0, qf, m))
    return result


def _problem(ca, robot, goal, start, duration, objective: str, intervals: int):
    """(duration, q0, qf, info): the settings checked (SettingError), the duration the
    file's trajectory's when not given, the start and goal poses (``endpoints``) inside
    the position limits (ModelError)."""
    if objective not in OBJECTIVES:
        raise SettingError("objective", f"must be one of {', '.join(OBJECTIVES)}, "
                                        f"not {objective!r}")
    if not 1 <= intervals <= MAX_INTERVALS:
        raise SettingError("intervals", f"must be 1 to {MAX_INTERVALS}, got {intervals}")
    if duration is None and robot.trajectory is not None:
        duration = float(robot.trajectory.duration)
    if duration is None and objective == "effort":
        raise SettingError("duration", "is missing: minimizing effort needs the duration")
    if duration is not None and not duration > 0:
        raise SettingError("duration", f"must be positive, got {duration:g}")
    q0, qf = endpoints(robot, goal, start)
    info = RobotInfo.from_robot(robot)
    if objective == "time" and any(a.effort_limit is None for a in info.actuators):
        raise SettingError("objective", "time needs an effort limit on every actuator "
                           "(joint limits: effort); without them the least time is zero")
    zero, efforts = np.zeros(len(q0)), np.zeros(len(robot.actuators))
    for label, pose in (("start", q0), ("goal", qf)):
        for name, quantity, theta, lower, upper in _bounded(ca, info, pose, zero, efforts):
            if quantity == "position" and not lower <= float(theta) <= upper:
                raise ModelError(f"unreachable {label}: {name} = {float(theta):g} is outside "
                                 f"its limits [{lower:g}, {upper:g}]", source=robot.source)
    return duration, q0, qf, info


def _inertia_and_hold(functions: dict, q0: np.ndarray, qf: np.ndarray, m: int):
    """1 / (A^T M A)_aa at the start pose, A = M^-1 B = d(ddq)/dtau, and the efforts
    that hold the goal pose at rest (least squares where fewer than n)."""
    fd, zero = functions["forward_dynamics"], np.zeros(len(q0))

    def slopes(q):
        base = np.array(fd(0.0, q, zero, np.zeros(m))).ravel()
        return base, np.column_stack([np.array(fd(0.0, q, zero, e)).ravel() - base
                                      for e in np.eye(m)])

    mass = np.array(functions["mass_matrix"](q0)).reshape(len(q0), len(q0))
    _, A = slopes(q0)
    base, Af = slopes(qf)
    return 1.0 / np.diag(A.T @ mass @ A), np.linalg.lstsq(Af, -base, rcond=None)[0]


def _power_series(t: np.ndarray, pieces: list[list[float]], final: float) -> list[tuple]:
    """f(t) for polynomial ``pieces`` (coefficients in t - t_k on [t_k, t_k+1]), f
    continuous, and the constant ``final`` after t[-1], as (coefficient, knot or None,
    power) terms: sum c t^j over the first piece, then at each later knot the jumps
    of the Taylor coefficients, c max(t - t_k, 0)^j, and at t[-1] a step of power 0."""
    degree = max(len(p) for p in pieces)
    pieces = [list(p) + [0.0] * (degree - len(p)) for p in pieces]
    h = np.diff(t)
    after = pieces[1:] + [[final] + [0.0] * (degree - 1)]
    terms = [(c, None, j) for j, c in enumerate(pieces[0]) if c]
    for k, (before, now) in enumerate(zip(pieces, after)):
        for j in range(0 if k == len(pieces) - 1 else 1, degree):
            shifted = sum(before[i] * math.comb(i, j) * h[k] ** (i - j) for i in range(j, degree))
            if now[j] - shifted:
                terms.append((now[j] - shifted, float(t[k + 1]), j))
    return terms


def _number(value: float) -> str:
    """A coefficient in a law's text: ten significant digits, no spaces."""
    return repr(float(f"{value:.10g}"))


def _text(terms) -> str:
    """The robot-file expression of ``_power_series``' terms, compact."""
    parts = []
    for c, knot, j in terms:
        base = "t" if knot is None else f"max(t-{_number(knot)},0)"
        if knot is not None and j == 0:                # a step at the knot
            parts.append(f"{_number(c / 2)}*(sign(t-{_number(knot)})+1)")
            continue
        parts.append(_number(c) + ("" if j == 0 else f"*{base}" if j == 1 else f"*{base}**{j}"))
    return "+".join(parts).replace("+-", "-") or "0"


def tracking(robot, result: OptimizeResult, inertia: np.ndarray,
             hold: np.ndarray) -> tuple[dict | None, str]:
    """The ``controller`` section whose laws track ``result`` (module docstring), and
    why not (None): an actuator's joint displacement not linear in q, or a law longer
    than the robot file's expressions may be.  The laws are w_a(t) - kp_a theta_a(q) -
    kd_a dtheta_a(q, dq), w_a = u_a + kp_a theta_a(r) + kd_a dtheta_a(r, dr) one
    piecewise cubic in t."""
    import sympy as sp

    from ..model.expressions import MAX_LENGTH

    t, N = result.t[::2], result.intervals
    h = np.diff(t)
    coordinates = robot.coordinates
    q, dq = result.q[::2], result.dq[::2]
    c2 = (3 * (q[1:] - q[:-1]) / h[:, None] - 2 * dq[:-1] - dq[1:]) / h[:, None]
    c3 = (2 * (q[:-1] - q[1:]) / h[:, None] + dq[:-1] + dq[1:]) / h[:, None] ** 2
    bodies = {b.name: b for b in robot.bodies}
    w = TRACKING_FREQUENCY
    laws = {}
    for a, actuator in enumerate(robot.actuators):
        theta = bodies[actuator.body].joint.displacement
        slopes = [sp.diff(theta, c.symbol) for c in coordinates]
        if any(s.free_symbols for s in slopes):
            return None, (f"{actuator.name}'s joint displacement {theta} is not linear in "
                          "the coordinates")
        A = np.array([float(s) for s in slopes])
        offset = float(theta.xreplace({c.symbol: 0 for c in coordinates}))
        kp, kd = w * w * inertia[a], 2 * w * inertia[a]
        u, mid = result.u[::2, a], result.u[1::2, a]
        pieces = []
        for k in range(N):
            e1 = (4 * mid[k] - 3 * u[k] - u[k + 1]) / h[k]
            e2 = 2 * (u[k] - 2 * mid[k] + u[k + 1]) / h[k] ** 2
            r = [A @ q[k] + offset, A @ dq[k], A @ c2[k], A @ c3[k]]      # theta_a(r) on it
            pieces.append([u[k] + kp * r[0] + kd * r[1], e1 + kp * r[1] + 2 * kd * r[2],
                           e2 + kp * r[2] + 3 * kd * r[3], kp * r[3]])
        rate = sum((s * c.rate_symbol for s, c in zip(slopes, coordinates)), sp.Integer(0))
        final = hold[a] + kp * (A @ q[-1] + offset)
        laws[actuator.name] = (f"{_text(_power_series(t, pieces, final))}"
                               f"-{_number(kp)}*({theta})-{_number(kd)}*({rate})")
        if len(laws[actuator.name]) > MAX_LENGTH:
            return None, (f"the law of {actuator.name} would be longer than {MAX_LENGTH} "
                          f"characters (fewer --intervals)")
    return {"laws": laws}, ""


def _margins(ca, info: RobotInfo, result: OptimizeResult) -> list[dict]:
    """The smallest distance to each bound over the points (negative: beyond it)."""
    worst: dict = {}
    for j, at in enumerate(result.t):
        for name, quantity, v, lower, upper in _bounded(ca, info, result.q[j], result.dq[j],
                                                        result.u[j]):
            margin = min(float(v) - lower, upper - float(v))
            if (name, quantity) not in worst or margin < worst[name, quantity]["margin"]:
                worst[name, quantity] = {
                    "name": name, "quantity": quantity, "margin": margin, "t": float(at),
                    "lower": float(lower) if np.isfinite(lower) else None,
                    "upper": float(upper) if np.isfinite(upper) else None}
    return list(worst.values())


def to_csv(result: OptimizeResult, path: Path) -> None:
    """t, q, dq, ddq and the efforts at the knots and midpoints."""
    names = result.coordinates
    header = (["t"] + names + ["d" + c for c in names] + ["dd" + c for c in names]
              + result.efforts)
    columns = [result.t, *result.q.T, *result.dq.T, *result.ddq.T, *result.u.T]
    write_csv(path, header, columns)


def summary(result: OptimizeResult) -> dict:
    return {"robot": result.robot, "objective": result.objective, "status": result.status,
            "success": result.success, "iterations": result.iterations, "cost": result.cost,
            "duration": result.duration, "intervals": result.intervals,
            "method": "Hermite-Simpson collocation, IPOPT", "defect": result.defect,
            "goal_error": result.goal_error, "margins": result.margins}


def section(result: OptimizeResult) -> dict:
    """The motion as a robot file's ``trajectory`` section of kind ``spline``
    (``model.spline``): q, dq, ddq at the knots and midpoints, quintics between."""
    names = result.coordinates
    return {"kind": "spline", "times": [float(t) for t in result.t],
            **{key: {c: [float(v) for v in values[:, i]] for i, c in enumerate(names)}
               for key, values in (("q", result.q), ("dq", result.dq), ("ddq", result.ddq))}}


def robot_file(result: OptimizeResult, robot_text: str) -> str:
    """A YAML robot file's text with its trajectory replaced by the motion (its other
    sections as they were, comments dropped)."""
    import yaml

    data = yaml.safe_load(robot_text)
    data["trajectory"] = section(result)
    if result.controller is not None:
        data["controller"] = result.controller
        laws = ("and, for simulate, control laws that track it (the optimized efforts plus a PD "
                "on each actuator's joint\n# about the motion, then the efforts that hold the "
                "goal; see anadyn_cli/services/optimize.py)")
    else:
        laws = f"(no tracking laws: {result.no_controller})"
    return (f"# {result.robot} with the motion of anadyn optimize ({result.objective}, "
            f"{result.status}) {laws};\n# every other section as in the original\n"
            + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100))


@output.one_set
def write(result: OptimizeResult, out: Path, source: str | None = None) -> list[Path]:
    """optimize.csv (the motion ``inverse --motion`` replays), trajectory.yaml (the
    section for a robot file), when ``source`` (the robot's file) is YAML
    NAME_optimized.yaml (that file with this trajectory: ``inverse`` replays it), and
    optimize.json."""
    import yaml

    yaml_file = source is not None and Path(source).suffix.lower() in (".yaml", ".yml")
    robot_text = Path(source).read_text(encoding="utf-8") if yaml_file else None
    out = output.prepare_dir(out)
    written = [out / "optimize.csv", out / "trajectory.yaml"]
    to_csv(result, written[0])
    output.write_text(written[1], yaml.safe_dump({"trajectory": section(result)},
                                                 sort_keys=False, default_flow_style=None,
                                                 width=100))
    if robot_text is not None:
        written.append(out / f"{result.robot}_optimized.yaml")
        output.write_text(written[-1], robot_file(result, robot_text))
    written.append(out / "optimize.json")
    output.write_json(written[-1], summary(result))
    return written


def raise_if_failed(result: OptimizeResult) -> None:
    """NumericalError (exit 3) with the solver's status when it did not converge."""
    if not result.success:
        raise NumericalError(f"optimization failed: IPOPT {result.status} after "
                             f"{result.iterations} iterations (defect {result.defect:.3g}); "
                             "the best iterate is written")
