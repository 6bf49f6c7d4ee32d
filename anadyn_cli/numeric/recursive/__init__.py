"""Recursive (Newton-Euler) dynamics of a robot, traced into straight-line code.

Nothing here builds closed forms: each step of the recursions is traced
(``ir.Ex``) with the robot's numbers folded in and emitted as one statement
per scalar quantity, so the code grows like the recursions.  One algorithm per
module, as in Pinocchio:

- ``plan``: the robot's numbers, in internal symbols;
- ``spatial``: vector algebra on traced expressions, motion-subspace projections;
- ``tracer``: what the algorithms share (joint maps, frames, loads, efforts);
- ``rnea``: inverse dynamics ID = M ddq - F - B tau (recursive Newton-Euler);
- ``crba``: the mass matrix M = J^T H J (composite rigid bodies);
- ``aba``: forward dynamics in O(n) (articulated bodies);
- ``potential``: the potential energy;
- ``factor``: the sparse Cholesky factorization and solve of M ddq = G;
- ``regressor``: the joint-torque regressor Y with M ddq - F = Y pi (RNEA columns);
- ``trace``: the generated functions, traced and pruned;
- ``emit``: the generated Python module.

What a joint does (its transform and motion subspace) comes from its type
(``model.joints``); no algorithm here names a joint type.

Conventions (those of ``anadyn_cli.symbolic.kinematics``): joint rates from
coordinate rates, with J = d(theta)/dq and H_i the Hessian of theta_i,

    dtheta = J dq,    ddtheta = J ddq + h,    h_i = dq^T H_i dq

Forward dynamics, whichever costs fewer operations for the robot at hand:
M ddq = G = -ID(t, q, dq, 0) with the actuators, solved by the unrolled
Cholesky factorization of ``factor``; or the articulated-body algorithm
(``aba``, O(n)) in joint space, then ddq = J^-1 (ddtheta - h), when J is
constant and invertible.  Short chains and bushy trees favour the first, long
chains the second.
"""
from .emit import PY_HEADER, _python_function, module_source, source
from .plan import Plan, plan
from .trace import Generated, Traced, complete, forward, generate, trace_aba

__all__ = ["PY_HEADER", "Generated", "Plan", "Traced", "_python_function", "complete",
           "forward", "generate", "module_source", "plan", "source", "trace_aba"]
