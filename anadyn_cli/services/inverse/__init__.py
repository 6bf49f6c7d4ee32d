"""Inverse dynamics: the actuator efforts that produce a prescribed motion.

Given q(t) from the robot file's ``trajectory`` (exact rates and
accelerations, see ``trajectory``) or measured samples of it (``measured``:
rates and accelerations as given or differentiated, efforts at the samples),
the equations M(q) ddq = F(t, q, dq) + B(q) tau
give, with B square and non-singular,

    tau(t) = B^-1 (M ddq - F)        at (t, q(t), dq(t), ddq(t))

F holds the joint forces and loads, so the efforts overcome friction,
damping, springs and loads.

evaluated over the whole time grid at once (the model's ``demand`` on arrays:
the recursive Newton-Euler algorithm, O(n) a point, on the recursive path;
one batched solve for B; no Python loop per point).

Round trip: the direct dynamics x' = [dq, M^-1 (F + B tau(t))], driven by the
efforts as exact functions of time (recomputed from the trajectory at the
integrator's t, never interpolated), integrated from the trajectory's start
state, must follow the prescribed q(t); the largest deviation on the output
grid is reported and checked against a tolerance.  An arm held against
gravity is usually unstable in open loop (the chapter's arms: deviations grow
like exp(3..5 t/s), some 1e24-fold over their 15 s), so such a motion is
integrated in segments short enough for double precision, each restarted
from the prescribed state (see ``round_trip``).  A measured motion is followed
between its samples by its piecewise quintic (``MeasuredMotion``), which passes
through every sample with the sample's rate and acceleration, so its round trip
checks the efforts against the measured positions the same way.

Spherical and floating joints (speeds that are not rates, ``SpeedMap``): the
motion gives each quaternion's path (coordinates), its speeds are the body's
angular velocity w = 2 vec(conj(q) (x) dq) / |q|^2 and their derivatives
(exact from the trajectory's q(t), dq(t), ddq(t)).  No actuator acts on such a
joint, so the rows of its speeds are solved apart: the actuated rows give tau,
and on the joint's rows the generalized force the motion needs is reported as
a wrench (``free_rows``): a floating joint's force along its slides (the
joint frame's axes: the world's for a base without ``rpy``) and moment about
the body's origin in body axes, a spherical joint's moment.  The round trip
applies it with the efforts and measures a quaternion's error as the angle of
the turn between the attitudes, 2 asin |vec(conj(q_prescribed) (x) q)|.

Robots in contact (``numeric.contact_inverse``): every row no actuator reaches (the
free rows above and a passive body's slides) is given by the active contacts' forces of
least norm, M ddq - F (contacts' forces left out) = B tau + J_c^T lambda + the residual
on those rows (the wrench columns); the contact forces are reported per sample and
contact, and the samples they cannot support are counted.  The round trip applies them,
as functions of time, in place of the compliant law.
"""
from __future__ import annotations

import time

import numpy as np

from ...errors import ModelError, SettingError, positive
from ...numeric import constrained, contact_inverse
from ...numeric.measured import MeasuredMotion, SpeedMap
from ...numeric.model import NumericModel
from ...numeric.settings import trajectory_grid
from ...numeric import limits
from .checks import check_actuation, check_counts, describe, finite, null_space
from .dynamics import (InSpeeds, InverseDynamics, check_quaternions, contact_rows, free_rows,
                       row_names, slides_hint)
from .report import (InverseResult, Sizing, columns, plot_title, roundtrip_line, sizing,
                     sizing_table, summary, table, unit_label, unsupported_line, write)
from .roundtrip import (DEFAULT_TOLERANCE, RoundTrip, deviation_names, error_unit,
                        raise_if_failed, round_trip)

DEFAULT_STEP = 0.01          # s, output grid (else the file's simulation.output_step)
MAX_POINTS = 10**7           # rows of the output grid

__all__ = ["inverse", "InverseDynamics", "InverseResult", "RoundTrip", "Sizing", "InSpeeds",
           "DEFAULT_TOLERANCE", "free_rows", "row_names", "round_trip", "raise_if_failed",
           "deviation_names", "error_unit", "columns", "table", "sizing", "sizing_table",
           "roundtrip_line", "summary", "plot_title", "unit_label", "write"]


def inverse(model: NumericModel, step: float | None = None, roundtrip: bool = True,
            tolerance: float = DEFAULT_TOLERANCE, segment: float | None = None,
            timings: dict | None = None, measured: MeasuredMotion | None = None,
            contact_gap: float = contact_inverse.DEFAULT_GAP, friction=None,
            contact_resolution: str = "least-norm") -> InverseResult:
    """Efforts along the file's trajectory (``model.motion``), or along a ``measured``
    motion (``numeric.measured``: at its samples), and the round trip.

    ``step``: output step, s (default: the file's output step, else 0.01; a measured
    motion has its samples instead); ``tolerance``: largest round-trip tracking error,
    rad or m; ``segment``: length of the round trip's pieces, s (default: automatic,
    see round_trip).  On a robot with contacts (``numeric.contact_inverse``): a contact
    within ``contact_gap`` (m) of its ground is active, and the rows no actuator reaches
    are given by the contacts' minimum-norm forces (``contact_resolution`` "least-norm"),
    or the least-norm ones inside the friction cones where those leave them ("cone");
    ``friction``: mu per contact (None: the model's, the robot file's ``friction``).
    """
    timings = {} if timings is None else timings
    info = model.info
    step, tolerance, contact_gap = _settings(model, step, tolerance, segment, measured,
                                             contact_gap, contact_resolution)
    start = time.perf_counter()
    motion = model.motion if measured is None else _measured(model, measured)
    if model.quaternions and measured is None:
        motion = InSpeeds(motion, SpeedMap(model.nq, model.quaternions))
    if not (constrained.is_constrained(model) or model.quaternions or model.contact_names):
        check_counts(info)
    timings["trajectory"] = time.perf_counter() - start
    t, step = _grid(motion, measured, step)
    if constrained.is_constrained(model):         # closed chains (numeric.constrained)
        return _closed_chain(model, motion, t, step, roundtrip, tolerance, segment, timings)
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        q, dq, ddq = motion(t) if measured is None else (motion.q, motion.dq, motion.ddq)
        demand, B = InverseDynamics(model, motion).demand(t, q, dq, ddq)
    elapsed = time.perf_counter() - start
    speed_map = SpeedMap(model.nq, model.quaternions)
    check_quaternions(model, speed_map, t, q)
    _check_finite(model, t, q, dq, ddq)
    B = np.broadcast_to(B, (len(t), model.n, len(model.effort_names)))
    free, wrench_columns = free_rows(model, B)
    support = share = None
    if model.contact_names:
        free, wrench_columns = contact_rows(model, speed_map, B, free, wrench_columns)
        support = contact_inverse.ContactSupport(model, free, contact_gap, friction,
                                                 contact_resolution)
        with np.errstate(all="ignore"):
            share = support.distribute(t, q, dq, demand)
        demand = share.remainder
    dynamics = InverseDynamics(model, motion, free, support)
    rows = row_names(model, speed_map)
    check_actuation(info, t, B[:, dynamics.actuated], [rows[k] for k in dynamics.actuated],
                    slides_hint(model, speed_map, B, free))
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        tau, wrench = dynamics.apportion(demand, B)
    timings["efforts"] = elapsed + time.perf_counter() - start
    finite(info, t, np.concatenate([tau, wrench], -1), "the efforts")
    if model.quaternions:
        q = speed_map.unit(q)
    result = InverseResult(info, model.formulation, motion.kind, motion.duration, step, t,
                           q, dq, ddq, tau, dynamics, timings=timings,
                           rates=np.einsum("kim,ki->km", B, dq),
                           wrench=wrench if free else None, wrench_columns=wrench_columns,
                           contact=share)
    if share is not None:
        _assess_contacts(result, support, share, wrench)
    result.limits = limits.check(info, t, q, speed_map.rates(q, dq, ddq)[0], tau)
    if roundtrip:
        result.roundtrip = round_trip(result, tolerance, segment)
        timings["roundtrip"] = result.roundtrip.wall
    return result


def _settings(model: NumericModel, step, tolerance, segment, measured, contact_gap,
              contact_resolution) -> tuple:
    """(step, tolerance, contact_gap) checked (SettingError when one is out of range):
    the step the file's output step (else ``DEFAULT_STEP``) when not given."""
    if model.contact_names:
        contact_gap = positive("contact_gap", contact_gap)
        if contact_resolution not in contact_inverse.RESOLUTIONS:
            raise SettingError("contact_resolution", "is one of "
                               + ", ".join(contact_inverse.RESOLUTIONS)
                               + f", got {contact_resolution!r}")
    if measured is not None and step is not None:
        raise SettingError("output_step", "does not apply to a measured motion: its efforts "
                                          "are computed at its samples")
    step = positive("output_step", step if step is not None
                    else model.info.simulation.output_step or DEFAULT_STEP)
    tolerance = positive("roundtrip_tolerance", tolerance)
    if segment is not None:
        positive("roundtrip_segment", segment)
    return step, tolerance, contact_gap


def _grid(motion, measured: MeasuredMotion | None, step: float) -> tuple[np.ndarray, float]:
    """(t, step): a measured motion's samples and their mean spacing, else the grid of
    ``step`` over the trajectory (SettingError when it is longer or too fine)."""
    if measured is not None:
        return measured.t, measured.duration / (len(measured.t) - 1)
    if step > motion.duration:
        raise SettingError("output_step", f"{step:g} s is longer than the trajectory's "
                                          f"duration {motion.duration:g} s")
    if motion.duration / step > MAX_POINTS:
        raise SettingError("output_step", f"{step:g} s gives more than {MAX_POINTS:.0e} "
                                          f"points over {motion.duration:g} s")
    return trajectory_grid(motion.duration, step), step


def _check_finite(model: NumericModel, t, q, dq, ddq) -> None:
    """ModelError at the first prescribed q, dq or ddq that is not finite."""
    speeds = [*model.speeds]
    for name, values, names in (("q", q, model.coordinates), ("dq", dq, speeds),
                                ("ddq", ddq, ["d" + u for u in speeds])):
        bad = ~np.isfinite(values)
        if bad.any():
            k, i = np.argwhere(bad)[0]
            raise ModelError(f"the prescribed {name} of {names[i]} "
                             f"is not finite at t = {t[k]:g} s", source=model.info.source,
                             path="trajectory")


def _assess_contacts(result: InverseResult, support, share, wrench) -> None:
    """``result.contact_report``: the samples the contact forces cannot support, scaled
    by the motion's largest force (a warning when there are any)."""
    scale = float(np.abs(share.remainder).max(initial=0.0)     # the motion's largest
                  + np.abs(share.forces).max(initial=0.0))     # force, about
    result.contact_report = support.assess(result.t, share.forces, share.active, wrench, scale)
    if result.contact_report["samples"]:
        from ...numeric.cache import warn
        warn(unsupported_line(result))


def _measured(model: NumericModel, measured: MeasuredMotion) -> MeasuredMotion:
    """``measured`` if it moves this robot's coordinates, in their order (open chains)."""
    if constrained.is_constrained(model):
        raise ModelError("a measured motion drives open chains only: this robot has "
                         "loop constraints (give it a trajectory section)",
                         source=model.info.source)
    if tuple(measured.names) != tuple(model.coordinates):
        raise ModelError(f"the measured motion moves {', '.join(measured.names)}; the robot's "
                         f"coordinates are {', '.join(model.coordinates)}",
                         source=measured.source)
    if measured.dq.shape[-1] != model.n:
        raise ModelError(f"the measured motion has {measured.dq.shape[-1]} rates; the robot has "
                         f"{model.n} speeds (read it with the model's speeds and quaternions: "
                         "measured.read_motion(path, model.coordinates, speeds=model.speeds, "
                         "quaternions=model.quaternions))", source=measured.source)
    return measured


def _closed_chain(model, motion, t, step, roundtrip, tolerance, segment, timings):
    """Efforts for a closed chain: the independent coordinates follow the trajectory,
    the dependent ones the constraints (``constrained.ClosedChainInverse``)."""
    info = model.info
    chain = constrained.ClosedChainInverse(model, motion, None)
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        q, dq, ddq = chain.kinematics(t)
    chain.grid, chain.q = t, q
    chain.check_velocity(t, q, dq, info.source)
    rank, k, P = chain.actuation(float(t[0]), q[0], dq[0])
    m = chain.m
    counts = (f"{k} degree{'s' * (k != 1)} of freedom ({model.n} coordinates, {model.c} "
              f"constraint equation{'s' * (model.c != 1)}), {m} actuator{'s' * (m != 1)}")
    if rank < k:
        names = [c.name for c in info.coordinates]
        N = np.linalg.svd(np.asarray(model._pfaffian(float(t[0]), *q[0].tolist())[0]))[2]
        lost = null_space(P.T) if P.size else np.eye(k)
        motions = N[model.c:].T @ lost
        raise ModelError(f"{counts}: inverse dynamics needs actuators that drive every motion "
                         f"the constraints allow; not actuated: "
                         f"{describe(motions, ['d' + n for n in names])}",
                         source=info.source, path="actuators")
    note = ("" if m == k else f"redundant actuation ({counts}): of the efforts that produce "
            "the motion, the one of least Euclidean norm")
    with np.errstate(all="ignore"):
        tau, lam, lost = chain.along(t, q, dq, ddq)
    if lost is not None:
        raise ModelError(f"{counts}: the actuators cannot drive every motion the constraints "
                         f"allow at t = {t[lost]:g} s (a singular configuration for them)",
                         source=info.source, path="actuators")
    timings["efforts"] = time.perf_counter() - start
    finite(info, t, tau, "the efforts")
    result = InverseResult(info, model.formulation, motion.kind, motion.duration, step, t,
                           q, dq, ddq, tau, chain, timings=timings, note=note)
    drift = np.array([np.abs(model.residuals(float(moment), np.concatenate([a, b]))[0]).max(
        initial=0.0) for moment, a, b in zip(t, q, dq)])
    result.constraints = constrained.ConstraintRun(model.rows, model.h, t, drift,
                                                   np.zeros(len(t)), lam, 0.0)
    if roundtrip:
        result.roundtrip = RoundTrip(**chain.round_trip(t, q, dq, segment, tolerance))
        timings["roundtrip"] = result.roundtrip.wall
    return result
