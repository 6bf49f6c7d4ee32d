"""Benchmark: anadyn's compliant contact against MuJoCo at matched accuracy (issue 27,
item 6): CPU time of each simulator on the same two scenes, and the ratio, in one run.

    python bench/contact_mujoco.py [--repeats 3]

Scenes (the MJCF of each is written here, with the masses, inertias, geometry,
friction and PD laws of the anadyn file):

* quadruped: robots/contact/quadruped_standing.yaml for 5 s (dropped 5 cm, stands
  under its PD laws; MuJoCo: free joint, ``position`` actuators kp 300, kv 10 at
  the file's joint targets, foot spheres only colliding, friction 0.8);
  scored on the rest height (trunk z at 5 s) and on the trunk height every 10 ms
  (the landing included);
* ball: a 1 kg ball (r 0.1 m) dropped from 1 m on a slide, ten bounces; scored on
  its first ten touch-down times (where the gap crosses 0 between rows 0.1 ms
  apart, in both).

The contact laws differ (anadyn: Hunt-Crossley; MuJoCo: its soft constraint,
solref 0.02 s critically damped for the quadruped, 0.004 s at damping ratio
0.015 for the ball, chosen to bounce about as anadyn's ball does), so each
simulator is scored against its own converged run:

* anadyn: ``integrators.integrate`` with ``auto`` at rtol 1e-6, 1e-8 and 1e-10
  (``simulate``'s default), atol rtol/100; its error is what ``simulate
  --estimate-error`` reports, the distance to a re-solve (``auto``) at rtol 1e-13;
* MuJoCo, with its default integrator (semi-implicit Euler) and with RK4:
  timesteps halved from the largest stable one (its solver's options left at
  their defaults), each scored against a reference run by RK4 at a quarter of
  the smallest timestep scored (the soft contact's timestep error falls at first
  to second order, so the reference's own error is a quarter to a sixteenth of
  RK4's at the smallest timestep scored; the rows beyond that are extrapolations).

For each anadyn row the table gives MuJoCo's cheapest run whose error is at most
anadyn's, its CPU time and the ratio MuJoCo / anadyn; where no run reaches it,
the timestep and CPU time are extrapolated from each integrator's finest run
(error ~ dt^p, p fitted over its three finest runs when their errors fall
steadily; time ~ 1/dt), the cheaper taken and marked "~"; where MuJoCo's error
does not fall steadily with its timestep (or p < 0.5) "not reached".  CPU time
is ``time.process_time`` of the stepping only (model building and compiling
excluded for both), the minimum of ``--repeats`` runs.
No test depends on these timings (2 noisy cores).  The whole run takes about
90 s of CPU (measured: 87 s; 161 s of wall time on 2 loaded cores); the table
is in docs/how-to/contact.md.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROBOTS = Path(__file__).resolve().parents[1] / "robots" / "contact"
RTOLS = (1e-6, 1e-8, 1e-10)
REFERENCE_RTOL = 1e-13
ROW = 1e-4                        # s between the ball's rows, both simulators
MIN_ORDER = 0.5                   # MuJoCo's error falling slower than dt^0.5: not extrapolated
INTEGRATORS = ("Euler", "RK4")    # MuJoCo's default (semi-implicit Euler) and its RK4
#: the anadyn ball: bouncing_ball.yaml's law on a vertical drop (k 1e6 N/m^1.5,
#: alpha 0.02 s/m), ten bounces in 6.6 s
BALL = """
name: bench_ball
gravity: [0, 0, -9.81]
coordinates:
  z: {initial: 1.0}
bodies:
  - {name: ball, joint: {type: prismatic, axis: [0, 0, 1], displacement: z}, mass: 1.0}
contacts:
  stiffness: 1e6
  damping: 2e4
  geometry:
    - {name: floor, body: ball, radius: 0.1}
"""
BALL_MJCF = """<mujoco model="ball">
  <option timestep="{dt}" integrator="{integrator}" gravity="0 0 -9.81"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1" solref="0.004 0.015"/>
    <body><joint type="slide" axis="0 0 1"/>
      <geom type="sphere" size="0.1" mass="1" solref="0.004 0.015"/></body>
  </worldbody>
</mujoco>"""
BOUNCES = 10
BALL_END = {"anadyn": 6.7, "MuJoCo": 7.0}          # s: past each one's tenth touch-down

L, HIP, KNEE = 0.2, 0.5, -1.0                        # quadruped_standing.yaml's values
LEGS = {"fl": (0.2, 0.15), "fr": (0.2, -0.15), "hl": (-0.2, 0.15), "hr": (-0.2, -0.15)}
QUADRUPED_END, QUADRUPED_ROW = 5.0, 0.01


def _leg(name: str, x: float, y: float) -> str:
    thigh, shank = L * L / 12, 0.5 * L * L / 12
    return f"""
      <body name="{name}_thigh" pos="{x} {y} 0">
        <joint name="{name}_hip" axis="0 1 0"/>
        <inertial pos="0 0 {-L / 2}" mass="1" diaginertia="{thigh} {thigh} 0.0001"/>
        <body name="{name}_shank" pos="0 0 {-L}">
          <joint name="{name}_knee" axis="0 1 0"/>
          <inertial pos="0 0 {-L / 2}" mass="0.5" diaginertia="{shank} {shank} 0.0001"/>
          <geom name="{name}_foot" size="0.02" pos="0 0 {-L}" friction="0.8 0.005 0.0001"/>
        </body>
      </body>"""


QUADRUPED_MJCF = f"""<mujoco model="quadruped_standing">
  <option timestep="{{dt}}" integrator="{{integrator}}" gravity="0 0 -9.81"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1" friction="0.8 0.005 0.0001"/>
    <body name="trunk" pos="0 0 0.42">
      <freejoint/>
      <inertial pos="0 0 0" mass="10"
                diaginertia="{10 * 0.1 / 12} {10 * 0.26 / 12} {10 * 0.34 / 12}"/>
      {"".join(_leg(name, x, y) for name, (x, y) in LEGS.items())}
    </body>
  </worldbody>
  <actuator>
    {"".join(f'<position joint="{leg}_{j}" kp="300" kv="10"/>'
             for leg in LEGS for j in ("hip", "knee"))}
  </actuator>
</mujoco>"""


# -- the runs: (what is scored, CPU seconds) ------------------------------------------
def _cpu(function):
    start = time.process_time()
    value = function()
    return value, time.process_time() - start


def _crossings(gap: np.ndarray, step: float) -> np.ndarray:
    """Touch-downs: where ``gap`` (rows ``step`` apart) crosses 0 downwards, linear
    between two rows."""
    down = np.flatnonzero((gap[:-1] > 0) & (gap[1:] <= 0))
    return (down + gap[down] / (gap[down] - gap[down + 1])) * step


class Anadyn:
    """One scene's numeric model, run by ``integrate`` on a grid of rows."""

    def __init__(self, robot, end: float, row: float, score):
        from anadyn_cli.numeric.build import numeric_model

        self.model, built = _cpu(lambda: numeric_model(robot))
        self.build = built
        self.grid = np.arange(0.0, end + row / 2, row)
        self.score = score

    def __call__(self, rtol: float, method: str = "auto"):
        from anadyn_cli.numeric import integrators

        solution, cpu = _cpu(lambda: integrators.integrate(
            self.model.problem(), self.model.initial_state(), self.grid, method, rtol,
            rtol * 1e-2))
        if not solution.success:
            raise RuntimeError(f"anadyn failed at rtol {rtol:g}: {solution.message}")
        return self.score(np.asarray(solution.x)), cpu


class MuJoCo:
    """One scene in MuJoCo at an (integrator, timestep), stepped in C between rows."""

    def __init__(self, xml: str, end: float, row: float, start, score):
        self.xml, self.end, self.row, self.start, self.score = xml, end, row, start, score

    def __call__(self, setting: tuple[str, float]):
        import mujoco

        integrator, dt = setting
        model = mujoco.MjModel.from_xml_string(
            self.xml.replace("{dt}", repr(dt)).replace("{integrator}", integrator))
        data = mujoco.MjData(model)
        self.start(data)
        per_row = max(1, round(self.row / dt))
        rows = round(self.end / (per_row * dt))
        out = np.empty((rows + 1, model.nq))
        out[0] = data.qpos

        def run():
            for k in range(rows):
                mujoco.mj_step(model, data, nstep=per_row)
                out[k + 1] = data.qpos

        _, cpu = _cpu(run)
        if not np.isfinite(out).all() or data.warning.number.any():   # unstable: reset
            return None, cpu
        return self.score(out, per_row * dt), cpu


def _quadruped_start(data):
    data.qpos[7:] = [HIP, KNEE] * 4
    data.ctrl[:] = [HIP, KNEE] * 4


# -- scoring ---------------------------------------------------------------------------------
def _error(value, reference) -> float:
    if value is None or len(value) != len(reference):
        return np.inf
    return float(np.abs(np.asarray(value) - reference).max())


def _table(name: str, metrics: dict, ours: dict, theirs: dict) -> list[str]:
    """Lines for one scene: per metric and integrator MuJoCo's errors, then per
    anadyn rtol the table row: MuJoCo's cheapest run that reaches anadyn's error,
    else the cheapest extrapolated one (error ~ dt^p, p fitted over an integrator's
    three finest runs when their errors fall steadily and p >= MIN_ORDER), else
    "not reached"."""
    lines = []
    for metric, pick in metrics.items():
        reference, theirs_reference = pick(ours["reference"]), pick(theirs["reference"])
        scored, finest = [], {}
        for integrator in INTEGRATORS:
            runs = sorted(((dt, _error(pick(v), theirs_reference), cpu)
                           for (method, dt), (v, cpu) in theirs["runs"].items()
                           if method == integrator and dt >= 4 * theirs["dt_reference"]),
                          reverse=True)
            scored += [(integrator, *run) for run in runs]
            last = [run for run in runs if np.isfinite(run[1])][-3:]
            errors = np.array([e for _, e, _ in last])
            falling = len(last) == 3 and errors.min() > 0 and (np.diff(errors) < 0).all()
            order = float(np.polyfit(np.log([h for h, _, _ in last]), np.log(errors), 1)[0]) \
                if falling else 0.0
            finest[integrator] = (*last[-1], order)
            lines.append(f"{name}, {metric}, MuJoCo {integrator}: errors " + ", ".join(
                f"{dt:.3g} s {error:.1e}" for dt, error, _ in runs) + (
                f"; order {order:.2f} over the finest three" if falling else
                "; not falling steadily over the finest three"))
        for rtol in RTOLS:
            value, cpu = ours["runs"][rtol]
            error = _error(pick(value), reference)
            found = [run for run in scored if run[2] <= error]
            if found:
                integrator, dt, their_error, their_cpu = min(found, key=lambda run: run[3])
                cells = (f"{integrator} {dt:.3g} s", f"{their_error:.1e}",
                         f"{their_cpu * 1e3:.3g} ms", f"{their_cpu / cpu:.3g}")
            else:
                guesses = [(integrator, h * (error / e) ** (1 / order), c * h)
                           for integrator, (h, e, c, order) in finest.items()
                           if order >= MIN_ORDER]
                if guesses:
                    integrator, dt, work = min(guesses, key=lambda g: g[2] / g[1])
                    their_cpu = work / dt
                    cells = (f"~{integrator} {dt:.2g} s", f"~{error:.1e}",
                             f"~{their_cpu:.3g} s", f"~{their_cpu / cpu:.2g}")
                else:
                    cells = ("not reached (its error stops at "
                             f"{min(e for _, e, _, _ in finest.values()):.1e})", "-", "-", "-")
            lines.append(f"| {name} | {metric} | {rtol:.0e} | {error:.1e} | "
                         f"{cpu * 1e3:.3g} ms | " + " | ".join(cells) + " |")
    return lines


def _measure(anadyn: Anadyn, mujoco: MuJoCo, timesteps: dict, dt_reference, repeats: int):
    """anadyn at RTOLS and its reference; MuJoCo at each integrator's timesteps and
    its reference (RK4 at ``dt_reference``)."""
    ours = {"reference": anadyn(REFERENCE_RTOL)[0], "runs": {}}
    for rtol in RTOLS:
        runs = [anadyn(rtol) for _ in range(repeats)]
        ours["runs"][rtol] = (runs[0][0], min(cpu for _, cpu in runs))
    theirs = {"reference": mujoco(("RK4", dt_reference))[0], "dt_reference": dt_reference,
              "runs": {}}
    for integrator, steps in timesteps.items():
        for dt in steps:
            runs = [mujoco((integrator, dt)) for _ in range(repeats if dt >= 1e-4 else 1)]
            theirs["runs"][integrator, dt] = (runs[0][0], min(cpu for _, cpu in runs))
    return ours, theirs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    from anadyn_cli.model import load_robot, robot_from_text

    wall, cpu = time.perf_counter(), time.process_time()
    quad = Anadyn(load_robot(ROBOTS / "quadruped_standing.yaml"), QUADRUPED_END,
                  QUADRUPED_ROW, lambda x: x[:, height])
    height = quad.model.state_names().index("trunk_z")
    quad_mj = MuJoCo(QUADRUPED_MJCF, QUADRUPED_END, QUADRUPED_ROW, _quadruped_start,
                     lambda q, step: q[:, 2])
    halvings = [5e-4 / 2 ** k for k in range(6)]               # 1e-3 s and above: unstable
    quad_runs = _measure(quad, quad_mj, {"Euler": halvings[:5], "RK4": halvings[1:5]},
                         halvings[5] / 2, args.repeats)

    ball = Anadyn(robot_from_text(BALL, "bench_ball.yaml"), BALL_END["anadyn"], ROW,
                  lambda x: _crossings(x[:, 0] - 0.1, ROW)[:BOUNCES])

    def ball_start(data):
        data.qpos[0] = 1.0

    ball_mj = MuJoCo(BALL_MJCF, BALL_END["MuJoCo"], ROW, ball_start,
                     lambda q, step: _crossings(q[:, 0] - 0.1, step)[:BOUNCES])
    halvings = [1e-3 / 2 ** k for k in range(9)]
    ball_runs = _measure(ball, ball_mj, {"Euler": halvings[:8], "RK4": halvings[3:7]},
                         halvings[8] / 2, args.repeats)

    print(f"anadyn's model building (excluded): quadruped {quad.build:.2f} s, "
          f"ball {ball.build:.2f} s CPU")
    rows = _table("quadruped, 5 s", {
        "rest height (m)": lambda v: None if v is None else v[-1:],
        "trunk height every 10 ms (m)": lambda v: v}, *quad_runs)
    rows += _table("ball, 10 bounces", {"touch-down times (s)": lambda v: v}, *ball_runs)
    print("\n".join(row for row in rows if not row.startswith("|")))
    print("| scene | scored on | anadyn rtol | anadyn error | anadyn CPU | MuJoCo integrator, "
          "timestep | MuJoCo error | MuJoCo CPU | MuJoCo / anadyn |")
    print("|---|---|---|---|---|---|---|---|---|")
    print("\n".join(row for row in rows if row.startswith("|")))
    print(f"whole run: {time.process_time() - cpu:.0f} s CPU, "
          f"{time.perf_counter() - wall:.0f} s wall")


if __name__ == "__main__":
    main()
