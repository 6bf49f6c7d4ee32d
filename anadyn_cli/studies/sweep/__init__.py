"""Parameter sweeps: a robot derived and compiled once, run for many values of a few names.

    anadyn sweep ROBOT --vary NAME=SPEC ... [--command simulate|inverse|check]

NAME is a parameter or a controller gain of the robot file; SPEC is one of

    FROM:TO:COUNT        a grid, COUNT values evenly from FROM to TO (10:60:11)
    V1,V2,...            a list (100,450; one value fixes the name)
    normal(MEAN,SD)      a Monte-Carlo draw from a normal distribution
    uniform(LOW,HIGH)    a Monte-Carlo draw from a uniform distribution

Numbers may be constant expressions (``pi/6``), read by the robot file's
own safe parser; nothing is evaluated as Python.  Grids and lists combine as
a full grid (the first --vary varies slowest); distributions draw
``--samples`` values each from one generator seeded by ``--seed``, and at
every grid point the same draws are used (common random numbers).

The varied names stay symbols and everything else is folded to numbers:
the robot is derived and compiled once (``numeric.bindable``), and each
sample only binds its numbers and runs the command's service (the same
code ``anadyn simulate``, ``inverse`` and ``check`` run).  What the file
computes from a varied name follows it: derived parameters, gains defined
from parameters, initial values, the trajectory.

Per sample, on the output grid (t = k dt), over the whole run:

    peak_<a>         max |tau_a(t)|                       (N*m or N)
    rms_<a>          sqrt(integral of tau_a^2 dt / duration), trapezoidal
    tracking_error   max over t and coordinates of |q(t) - r(t)|, rad or m, with
                     r(t) the file's trajectory held at its end after its duration
                     (simulate, check); for inverse the round trip's largest error
                     (the direct dynamics driven by the efforts against the motion)
    final_error      max over coordinates of |q - r| at the end of the run: the
                     steady-state error against the trajectory's end, the target
    settling_time    the time after which every coordinate stays within
                     --settle-band (2 %) of its largest deviation from its final
                     value, around that final value; near t_end: not settled
    final_<q>        q and d<q> at the end of the run
    energy_error     check's energy balance max |T + V - W - E0| / energy scale
                     (simulate: one more solve with the actuators' work W)
    stiff, fastest_decay, mass_condition_scaled, check_passed     (check)
    limits_passed    how many of the file's joint limits (position, rate, effort;
                     ``numeric.limits``) the run passes
    rhs_calls, steps the integrator's work

``--max METRIC=BOUND`` and ``--min METRIC=BOUND`` judge each sample, with the
file's joint limits: ``within_limits`` (1 or 0) and ``limit_miss`` (which
not); for one varied name, ``capacity`` gives the range of values from the
first one within the limits up to the first miss.

``status`` is ok, failed (the run failed numerically: ``reason`` says where),
invalid (the values make no robot: a mass not positive, an inertia that no
body has, actuators that cannot produce the motion) or error (anything else,
a bug).  A failed sample is data, not the end of the sweep.

The package, one job a module: ``grammar`` (the text of --vary, --max, --min),
``design`` (the samples), ``plan`` (what runs per sample, decided before any
runs), ``sample`` (one sample on a worker), ``runner`` (the samples through
``studies.executors``) and ``report`` (``SweepResult``, sweep.csv, sweep.json,
sweep.png, the terminal's table); the figure is ``studies.sweep_plot``.
"""
from __future__ import annotations

from .design import DEFAULT_SAMPLES, Design, design
from .grammar import DISTRIBUTIONS, EXAMPLES, Spec, parse_bound, parse_spec, parse_vary
from .plan import (CHECK_SAMPLES, COMMANDS, DEFAULT_GROUPS, GROUPS, SETTLE_BAND, Payload,
                   Plan, metric_columns, metric_groups, plan)
from .report import (JSON_ROWS, STATUSES, SweepResult, capacity, csv_text, headline, lines,
                     metric_summary, summary, table, write)
from .runner import run
from .sample import STILL, Runner, dask_setup, settling_time, setup, work

__all__ = ["CHECK_SAMPLES", "COMMANDS", "DEFAULT_GROUPS", "DEFAULT_SAMPLES", "DISTRIBUTIONS",
           "EXAMPLES", "GROUPS", "JSON_ROWS", "SETTLE_BAND", "STATUSES", "STILL", "Design",
           "Payload", "Plan", "Runner", "Spec", "SweepResult", "capacity", "csv_text",
           "dask_setup", "design", "headline", "lines", "metric_columns", "metric_groups",
           "metric_summary", "parse_bound", "parse_spec", "parse_vary", "plan", "run",
           "settling_time", "setup", "summary", "table", "work", "write"]
