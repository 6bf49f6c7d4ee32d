"""The numeric model of a constrained robot (closed chains, velocity constraints).

State x = [q, dq] over all n coordinates.  The generated module (the tree's
functions from ``closed_form`` plus ``source`` below) gives, at (t, q, dq):
the tree's M, F, B; the control laws tau; the holonomic residuals f (h);
the Pfaffian matrix A (c x n), the velocity residual g = A dq + a0 and the
acceleration right side b (A ddq = b).  With G = F + B tau, the
accelerations and multipliers solve

    M ddq = G + A^T lambda,   A ddq = b

by the formulation the model was derived with:

* ``lagrange``: the multipliers first, lambda = S^-1 (b - A M^-1 G) with
  S = A M^-1 A^T, then ddq = M^-1 (G + A^T lambda);
* ``kane``: dependent speeds: ddq = T du + e with T = [I; -A_d^-1 A_i],
  e = [0; A_d^-1 b], and T^T M T du = T^T (G - M e) (Kane's equations with
  the nonholonomic partial velocities T); lambda from the dependent rows,
  A_d^T lambda = (M ddq - G)_d.  The dependent speeds are the file's while
  they stay well determined (|A_d^-1 A_i| <= 1e6: they move at most 1e6
  times as fast as the independent ones), else the best-conditioned c
  columns of A (greedy column pivoting), so a choice that becomes singular
  along the motion (the knife edge heading along y) does not stop the run.

**Drift control** (Ascher, Chin and Reich's stabilization of the invariant
manifold): the integrated field is

    dq/dt  = dq  - gamma W Ah^T (Ah W Ah^T)^-1 f
    ddq/dt = ddq - gamma W A^T  (A W A^T)^-1 g,      W = M^-1

which is the exact dynamics on the constraints (f = 0, g = 0) and pulls any
deviation back at the rate gamma (df/dt = -gamma f, dg/dt = -gamma g to first
order), so the integrator's local errors cannot accumulate into drift: the
drift stays near (local error rate) / gamma.  gamma = STABILIZATION (1/s);
W = M^-1 moves the state along the constraint normals in the kinetic-energy
metric (free of units).  The drift is measured on the integrated state
(never projected away) and reported with every run.

The Jacobian of the field is taken by forward differences (2n more field
evaluations, not counted as RHS calls).

Only NumPy is imported at module level; ``source`` (code generation) needs
SymPy and imports it inside.

The package, one module per job: ``generation`` (the generated constraint
functions), ``dynamics`` (``ConstrainedModel``, ``ConstraintRun``), ``inverse``
(``ClosedChainInverse``), ``states`` (states on the constraints, for compare),
``check`` (conditioning and drift along a path).
"""
from .generation import MARKER, source
from .dynamics import (NEWTON_ITERATIONS, SINGULAR_CONSTRAINTS, SPLIT_LIMIT, STABILIZATION,
                       ConstrainedModel, ConstraintRun, Row, is_constrained, model_type)
from .inverse import ClosedChainInverse
from .states import accelerations, consistent_states
from .check import DEAD_POINT, ConstraintCheck, conditioning, drift

__all__ = ["MARKER", "source", "NEWTON_ITERATIONS", "SINGULAR_CONSTRAINTS", "SPLIT_LIMIT",
           "STABILIZATION", "ConstrainedModel", "ConstraintRun", "Row", "is_constrained",
           "model_type", "ClosedChainInverse", "accelerations", "consistent_states",
           "DEAD_POINT", "ConstraintCheck", "conditioning", "drift"]
