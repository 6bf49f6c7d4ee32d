"""anadyn's generated dynamics against a Pinocchio model whose state is anadyn's mapped:
v_pin = J u and a_pin = J du + Jdot_u (a joint whose speeds Pinocchio takes in other
axes: a planar joint's, a free-flyer's), so that anadyn's M = J^T M_pin J, its
inverse dynamics J^T tau_pin and its accelerations J^+ (a_pin - Jdot_u)
(tests/test_compound_joints.py, tests/test_floating.py)."""
from __future__ import annotations

import numpy as np


def rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b))))


def check_mapped(pin, namespace: dict, model, draw, to_pin, states: int = 20, seed: int = 0,
                 also=None, tolerance: float = 1e-9) -> int:
    """At ``states`` states ``draw(rng)`` -> (q, u, du) mapped by ``to_pin`` -> (q_pin,
    v_pin, a_pin, J, Jdot_u): M (crba), inverse dynamics (rnea) and forward dynamics
    (aba) to ``tolerance`` relative; ``also(q, u, q_pin, v_pin, data)`` checks more."""
    data = model.createData()
    rng = np.random.default_rng(seed)
    for _ in range(states):
        q, u, du = draw(rng)
        qp, vp, ap, J, bias = to_pin(q, u, du)
        Mp = pin.crba(model, data, qp)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        M, F, _ = namespace["mfb"](0.0, *q, *u)
        assert rel(M, J.T @ Mp @ J) < tolerance
        tau = J.T @ pin.rnea(model, data, qp, vp, ap)
        assert rel(namespace["inverse_dynamics"](0.0, *q, *u, *du), tau) < tolerance
        free = pin.aba(model, data, qp, vp, np.zeros(model.nv))
        expected = np.linalg.lstsq(J, free - bias, rcond=None)[0]
        assert rel(namespace["accelerations"](0.0, *q, *u), expected) < tolerance
        if also is not None:
            also(q, u, qp, vp, data)
    return states
