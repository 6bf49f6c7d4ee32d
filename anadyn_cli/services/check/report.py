"""What ``check`` found: ``StabilityReport`` and its judged ``Check``s, the text, the
per-contact figures, check.json's summary and the files."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import CheckFailed
from ...model.info import RobotInfo
from ...numeric import constrained, contact_run, integrators
from ... import files as output
from ...output.csv_table import write_csv
from .path import PROBE_RTOLS, Momentum, Probe

UNDAMPED = 1e-6               # fastest decay x horizon below this: nothing decays


@dataclass
class Check:
    name: str
    value: float
    threshold: float
    passed: bool
    text: str


@dataclass
class StabilityReport:
    robot: RobotInfo
    t_end: float
    rtol: float
    atol: float
    t: np.ndarray                 # path rows
    x: np.ndarray
    work: np.ndarray              # actuators' work W(t)
    rhs_calls: int
    solve_wall: float
    sample_t: np.ndarray
    decay: np.ndarray             # max(-Re lambda) per sample, 1/s
    growth: np.ndarray            # max(Re lambda) per sample
    speed: np.ndarray             # max |lambda| per sample
    classic: np.ndarray           # max|Re| / max(min|Re|, 1/horizon) over decaying modes
    condition: np.ndarray         # raw condition number per row checked
    scaled_condition: np.ndarray
    condition_t: np.ndarray
    energy_residual: np.ndarray   # T + V - W - E0 per row, J
    energy_scale: float
    probe: Probe
    checks: list[Check] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    load_work: np.ndarray | None = None   # loads' work W_loads(t); None: no loads or
    dissipated: np.ndarray | None = None  # joint forces; energy dissipated E_d(t) >= 0
    constraints: "constrained.ConstraintCheck | None" = None   # closed chains
    contacts: "contact_run.ContactRun | None" = None     # contact forces on the rows
    contact_laws: tuple = ()                     # per contact: k, p, its body's mass
    momentum: "Momentum | None" = None           # a free robot's momentum (``momentum``)
    computation: dict = field(default_factory=dict)   # what ran (numeric.build.computation)

    @property
    def passive(self) -> bool:
        return not self.robot.actuators and self.load_work is None

    @property
    def balance(self) -> str:
        """The balance checked, e.g. T + V - W - W_loads + E_d - E0."""
        rigid = self.contacts is not None and self.contacts.model == "rigid"
        return ("T + V" + ("" if self.contacts is None else " + E_c" if rigid else " + V_c")
                + ("" if not self.robot.actuators else " - W")
                + ("" if self.load_work is None else " - W_loads + E_d") + " - E0")

    @property
    def stiff(self) -> bool:
        """The probe's verdict, given a mode that decays: with none (e.g. two
        coaxial vertical joints under gravity along them, where nothing moves
        and every eigenvalue is 0) both probe runs take the fewest steps, and
        equal call counts measure nothing; stability limits no step."""
        return self.probe.limited and self.auto_ratio > UNDAMPED

    @property
    def fastest_decay(self) -> float:
        return float(self.decay.max(initial=0.0))

    @property
    def auto_ratio(self) -> float:
        return self.fastest_decay * self.t_end

    @property
    def energy_error(self) -> float:
        return float(np.abs(self.energy_residual).max() / self.energy_scale)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)


def seconds(value: float) -> str:
    if not math.isfinite(value):
        return "none"
    if value >= 1:
        return f"{value:.3g} s"
    if value >= 1e-3:
        return f"{value * 1e3:.3g} ms"
    return f"{value * 1e6:.3g} us"


def text(report: StabilityReport) -> str:
    """The report as printed by ``anadyn check``."""
    r = report
    k_decay = int(np.nanargmax(r.decay)) if len(r.decay) else 0
    k_speed = int(np.nanargmax(r.speed)) if len(r.speed) else 0
    k_classic = int(np.nanargmax(r.classic)) if len(r.classic) else 0
    k_cond = int(np.nanargmax(r.condition))
    k_scaled = int(np.nanargmax(r.scaled_condition))
    p = r.probe
    lines = [
        f"{r.robot.name}: {r.t_end:g} s, {len(r.t)} rows, odeint (LSODA) rtol {r.rtol:g} "
        f"atol {r.atol:g}, {r.rhs_calls} RHS calls"
        + ("" if r.passive else ", actuators' work integrated with the state"
           if r.load_work is None else
           ", actuators' and loads' work and dissipated energy integrated with the state"),
        f"eigenvalues of the Jacobian at {len(r.sample_t)} points along the path:",
        "  fastest decay        " + (
            f"{r.fastest_decay:.4g} 1/s at t = {r.sample_t[k_decay]:.4g} s (time constant "
            f"{seconds(1 / r.fastest_decay)})" if r.fastest_decay * r.t_end > UNDAMPED else
            "none: no motion dies out over the run (an undamped robot: its modes oscillate "
            "or drift; the figures are in check.json)"),
        f"  fastest rate |lambda| {r.speed[k_speed]:.4g} 1/s at t = {r.sample_t[k_speed]:.4g} s",
        "  fastest growth       " + (f"{float(np.nanmax(r.growth)):.4g} 1/s"
                                     if float(np.nanmax(r.growth)) * r.t_end > UNDAMPED
                                     else "none: no motion grows over the run"),
        f"  stiffness ratio      {r.classic[k_classic]:.3g} (max/min |Re lambda| of the decaying"
        f" modes, min at least 1/horizon, at t = {r.sample_t[k_classic]:.4g} s); fastest decay"
        f" x horizon {r.auto_ratio:.3g} (auto's threshold {integrators.STIFF_RATIO:g})",
        f"explicit probe (RK45): {p.loose_calls}{'+' if p.loose_capped else ''} RHS calls at "
        f"rtol {PROBE_RTOLS[0]:.0e}, {p.tight_calls}{'+' if p.tight_capped else ''} at rtol "
        f"{PROBE_RTOLS[1]:.0e} over the first {p.window:.4g} s: calls fall "
        f"{'at least ' if p.tight_capped else ''}{1 / p.ratio:.2g}x for a 1e4 looser tolerance"
        f" (~6x when accuracy sets the step, ~1x when stability does)",
        f"stiffness: {'stiff' if r.stiff else 'not stiff'} (explicit methods are "
        f"{'' if r.stiff else 'not '}stability-limited"
        + ("; no mode decays along the path, so the equal call counts measure nothing)"
           if p.limited and not r.stiff else ")"),
        f"mass matrix: condition number up to {r.condition[k_cond]:.3g} (t = "
        f"{r.condition_t[k_cond]:.4g} s), {r.scaled_condition[k_scaled]:.3g} after diagonal "
        "scaling",
        (f"energy: passive, T + V{' + E_c' if ' E_c' in r.balance else ''} drifts by at most "
         f"{np.abs(r.energy_residual).max():.3g} J "
         f"(energy scale {r.energy_scale:.4g} J)" if r.passive else
         f"energy: actuators' work W from {r.work.min():.4g} to {r.work.max():.4g} J; "
         f"{r.balance} at most {np.abs(r.energy_residual).max():.3g} J (energy scale "
         f"{r.energy_scale:.4g} J)"),
    ]
    if r.load_work is not None:
        lines.insert(-1, f"energy: loads' work W_loads from {r.load_work.min():.4g} to "
                         f"{r.load_work.max():.4g} J; dissipated by joint damping and "
                         f"friction{'' if r.contacts is None else ' and the contacts'} "
                         f"E_d = {r.dissipated[-1]:.4g} J at the end")
    if r.constraints is not None:
        lines.append(r.constraints.line())
    if r.momentum is not None:
        lines.insert(-1, _momentum_line(r.momentum))
    rigid = r.contacts is not None and r.contacts.model == "rigid"
    for name, depth, at, tau in contact_figures(r):
        if rigid:
            strikes = sum(e["contact"] == name and e["event"] == "touch-down"
                          for e in r.contacts.located)
            lines.insert(-1, f"contact {name} (rigid): {strikes} impact"
                             f"{'s' * (strikes != 1)}; largest penetration {depth:.3g} m "
                             "(the constraint's drift)")
            continue
        lines.insert(-1, f"contact {name} (compliant): largest penetration {depth:.3g} m" + (
            f" at t = {at:.4g} s; time constant sqrt(m/k_eff) there {seconds(tau)}"
            if depth > 0 else " (never touched)"))
    if rigid:
        lines.insert(-1, "contacts (rigid): E_c, the energy sliding friction and the "
                         f"impacts took, {sum(e['energy_lost'] for e in r.contacts.located):.4g}"
                         " J from the impacts by the end")
    for c in r.checks:
        lines.append(f"{'ok  ' if c.passed else 'FAIL'} {c.text}")
    for w in r.warnings:
        lines.append(f"warning: {w}")
    failed = [c.name for c in r.checks if not c.passed]
    lines.append(f"check: {'passed' if not failed else 'FAILED (' + ', '.join(failed) + ')'}")
    return "\n".join(lines)


def _momentum_line(h: Momentum) -> str:
    """What is conserved of a free robot's momentum, and its end values."""
    P, L = h.h[-1, :3], h.h[-1, 3:]
    what = ("nothing conserved: loads or contacts act" if not len(h.conserved) else
            "all conserved (no external force)" if len(h.conserved) == 6 else
            "conserved: P normal to gravity, L along it")
    return (f"momentum: free robot, {what}; at the end P = "
            f"({', '.join(f'{v:.4g}' for v in P)}) kg m/s, L = "
            f"({', '.join(f'{v:.4g}' for v in L)}) kg m^2/s (world axes, about the origin)")


def contact_figures(report: StabilityReport) -> list[tuple[str, float, float, float]]:
    """Per contact: its largest penetration d (m, 0 if it never touched), when, and the
    time constant sqrt(m / k_eff) of its body's mass on the spring linearized there,
    k_eff = p k d^(p-1) (inf when it never touched or its body has no mass)."""
    if report.contacts is None:
        return []
    out = []
    for c, name in enumerate(report.contacts.names):
        depth = report.contacts.values[c, 3]
        row = int(np.argmax(depth))
        d = max(float(depth[row]), 0.0)
        k, p, mass = report.contact_laws[c]
        stiffness = p * k * d ** (p - 1) if d > 0 else 0.0
        tau = math.sqrt(mass / stiffness) if stiffness > 0 and mass > 0 else math.inf
        out.append((name, d, float(report.t[row]), tau))
    return out


def summary(report: StabilityReport) -> dict:
    """Key figures (``check.json``)."""
    r = report
    return {
        "robot": r.robot.name, **r.computation, "t_end": r.t_end, "rows": len(r.t),
        "rtol": r.rtol,
        "atol": r.atol, "rhs_calls": r.rhs_calls, "passed": r.passed, "stiff": r.stiff,
        "fastest_decay": r.fastest_decay,
        "fastest_time_constant": 1 / r.fastest_decay if r.fastest_decay else None,
        "fastest_rate": float(np.nanmax(r.speed)),
        "fastest_growth": float(np.nanmax(r.growth)),
        "stiffness_ratio": float(np.nanmax(r.classic)),
        "decay_times_horizon": r.auto_ratio,
        "probe": {"method": "RK45", "rtols": list(PROBE_RTOLS), "window": r.probe.window,
                  "loose_calls": r.probe.loose_calls, "tight_calls": r.probe.tight_calls,
                  "loose_capped": r.probe.loose_capped, "tight_capped": r.probe.tight_capped,
                  "ratio": r.probe.ratio, "stability_limited": r.probe.limited},
        "mass_condition": float(np.nanmax(r.condition)),
        "mass_condition_scaled": float(np.nanmax(r.scaled_condition)),
        "passive": r.passive, "energy_error": r.energy_error,
        "momentum": None if r.momentum is None else {
            "conserved_rows": r.momentum.conserved.tolist(), "linear_drift": r.momentum.linear,
            "angular_drift": r.momentum.angular, "start": r.momentum.h[0].tolist(),
            "end": r.momentum.h[-1].tolist()},
        "energy_residual_max": float(np.abs(r.energy_residual).max()),
        "energy_scale": r.energy_scale,
        "actuator_work_final": float(r.work[-1]),
        "load_work_final": float(r.load_work[-1]) if r.load_work is not None else 0.0,
        "dissipated_final": float(r.dissipated[-1]) if r.dissipated is not None else 0.0,
        "checks": [{"name": c.name, "value": c.value, "threshold": c.threshold,
                    "passed": c.passed} for c in r.checks],
        "warnings": list(r.warnings),
        "timings": dict(r.timings),
        **({} if r.constraints is None else {"constraints": r.constraints.summary()}),
        **({} if r.contacts is None else {"contacts": {
            name: {"model": r.contacts.model, "max_penetration": depth, "at": at,
                   "time_constant": tau if math.isfinite(tau) else None}
            for name, depth, at, tau in contact_figures(r)}}),
        **({} if r.contacts is None or r.contacts.located is None else {
            "impact_losses": sum(e["energy_lost"] for e in r.contacts.located),
            "events": r.contacts.located}),
    }


@output.one_set
def write(report: StabilityReport, out: Path) -> list[Path]:
    """check.csv (the path's figures per eigenvalue sample) and check.json."""
    out = output.prepare_dir(out)
    written = [out / "check.csv"]
    rows = np.searchsorted(report.t, report.sample_t)
    cond_rows = np.searchsorted(report.condition_t, report.sample_t).clip(
        0, len(report.condition_t) - 1)
    forces = ([] if report.load_work is None else
              [("load_work", report.load_work[rows]), ("dissipated", report.dissipated[rows])])
    write_csv(written[0], ["t", "fastest_decay", "fastest_growth", "fastest_rate",
                                  "stiffness_ratio", "mass_condition", "mass_condition_scaled",
                                  "energy_residual", "actuator_work", *(f[0] for f in forces)],
                     [report.sample_t, report.decay, report.growth, report.speed,
                      report.classic, report.condition[cond_rows],
                      report.scaled_condition[cond_rows], report.energy_residual[rows],
                      report.work[rows], *(f[1] for f in forces)])
    written.append(out / "check.json")
    output.write_json(written[-1], summary(report))
    return written


def raise_if_failed(report: StabilityReport) -> None:
    failed = [c for c in report.checks if not c.passed]
    if failed:
        raise CheckFailed(f"{report.robot.source}: " + "; ".join(
            f"{c.name} {c.value:.3g} exceeds {c.threshold:.0e}" for c in failed))
