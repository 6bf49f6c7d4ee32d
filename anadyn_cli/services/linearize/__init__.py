"""Linearization about an operating point: state-space matrices, modes, controllability.

With x = [q, dq], u = tau and M(q) ddq = F(t, q, dq) + B(q) tau:

    dx/dt = f(t, x, u) = [dq, M^-1 (F + B u)]
    A = df/dx = [[0, I], [M^-1 K]],   B = df/du = [[0], [M^-1 B]]
    K = d(F + B u - M a)/dx  at the point's accelerations a = ddq0

(differentiating M ddq = F + B u gives M d(ddq) = d(F + B u) - (dM) ddq, so M
is never inverted symbolically).  A holds the efforts u0 fixed (open loop);
A_closed_loop is the Jacobian of the file's closed loop u = tau_c(t, x),
d(ddq)/dx (u = tau_c(x0)) + M^-1 B d(tau_c)/dx, with zero efforts when the file
has no controller (the motion ``simulate`` integrates).

Two evaluators give these numbers (``equations.Road``; ``numeric.build``'s words,
recorded as ``evaluator`` and ``formulation``, and which code ran as ``code``):
"recursive", the default on open trees of revolute and prismatic joints, runs the
recursive Newton-Euler algorithm and its derivatives (d(ddq)/dx and M^-1 B
directly, no symbolic equations) on the generic kernel, compiled once per
installation, or where it cannot serve on the derivatives generated for the robot
(``recursive.road``); "closed-form" differentiates the closed forms of Kane's or
Lagrange's equations (``formulation``) symbolically as above, the road of a robot
with a spherical joint.  The control laws' Jacobian is symbolic in both.

The operating point is the file's initial state at t = 0 unless ``at``
says otherwise; its efforts u0 are the given ones, else the controller's at
that state, else the static holding efforts u0 = pinv(B) (-F(t, q, 0))
(exact when B is square and invertible; their residual is reported); ``efforts``
chooses otherwise (holding efforts about a set point, for a controller design).
``equilibrium`` first solves ddq(t, q, 0, tau(q)) = 0 (F + B tau = 0) for q
near the given one (scipy.optimize.root, analytic Jacobian), with tau the
controller's law at rest, the given efforts, or zero without either.

Eigenvalues of A and A_closed_loop with natural frequency |lambda| and
damping ratio -Re(lambda)/|lambda|.  The controllability rank of (A, B) is the
dimension of the controllable subspace, grown one orthonormal Krylov block at
a time (the staircase form; better conditioned than the rank of
[B, AB, ..., A^(2n-1) B]), and each mode gets the Popov-Belevitch-Hautus test.

On the generic kernel, the runs after the first read no robot: the first keeps the
kernel's tables beside the robot's cache entry (a cold ``simulate``, ``inverse`` or
``check`` does too), and a robot that the record holds whole (``recorded.serves``:
no control laws, no parameters) is linearized from it (``RecordedRobot``), with
the same numbers to the bit.

One module per job: ``point`` (the operating point, the equilibrium search),
``equations`` (the evaluators' interface, the closed forms differentiated once),
``recursive`` (the recursive evaluator: the kernel's or the generated code),
``recorded`` (a robot as the kernel's record holds it),
``state_space`` (``linearize``), ``modes`` (eigenvalues, controllability),
``parametric`` (the symbolic form), ``writing`` (files, summary, report).
"""
from .point import EFFORTS, EQUILIBRIUM_TOL, OperatingPoint, check_efforts, parse_at
from .modes import RANK_TOL, controllability_rank, modes
from .parametric import symbolic_form
from .recorded import RecordedRobot, serves
from .state_space import Linearization, linearize
from .writing import report, summary, write

__all__ = ["EFFORTS", "EQUILIBRIUM_TOL", "OperatingPoint", "check_efforts", "parse_at",
           "RANK_TOL", "controllability_rank", "modes", "symbolic_form", "Linearization",
           "linearize", "RecordedRobot", "serves", "report", "summary", "write"]
