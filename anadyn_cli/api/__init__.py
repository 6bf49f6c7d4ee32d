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

from .models import (base_parameters, derivatives, derive, equations, import_urdf, load,
                     numeric_model, parametric_model, robots)
from .runs import accuracy, check, compare, inverse, linearize, simulate
from .studies import batch, excite, export, identify, optimize, sweep
from .drawings import animate, show, view

__all__ = ["load", "derive", "equations", "numeric_model", "derivatives", "import_urdf", "robots",
           "parametric_model", "base_parameters", "simulate", "inverse", "check", "compare",
           "accuracy", "linearize", "export", "optimize", "sweep", "batch", "identify", "excite",
           "view", "show", "animate"]
