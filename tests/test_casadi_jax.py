"""export --lang casadi / jax: the functions equal anadyn's numeric model to 1e-12."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli.cli import main

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
FILES = ["rr.yaml", "rrt.yaml", "ur5.urdf", "panda.urdf"]


def _states(model, rng, m):
    n = model.n
    return (float(rng.normal()), rng.normal(size=n), rng.normal(size=n), rng.normal(size=m),
            rng.normal(size=n))


def _reference(model, t, q, dq, tau, ddq):
    BT, B = model.demand(t, q, dq, ddq)
    return (model.driven_accelerations(t, np.concatenate([q, dq]), tau),
            np.linalg.lstsq(B, BT, rcond=None)[0], model.mfb(t, q, dq)[0])


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("name", FILES)
def test_casadi_equals_numeric_model(tmp_path, name):
    ca = pytest.importorskip("casadi")
    import anadyn

    out = tmp_path / "ca"
    assert main(["export", str(ROBOTS / name), "--lang", "casadi", "--out", str(out)]) == 0
    model = anadyn.numeric_model(str(ROBOTS / name))
    stem = model.name
    fd, inv, mass = (ca.Function.deserialize((out / f"{stem}_{f}.casadi").read_text())
                     for f in ("forward_dynamics", "inverse_dynamics", "mass_matrix"))
    rng = np.random.default_rng(7)
    m = len(model.effort_names)
    for _ in range(5):
        t, q, dq, tau, ddq = _states(model, rng, m)
        ref = _reference(model, t, q, dq, tau, ddq)
        got = (np.array(fd(t, q, dq, tau)).ravel(), np.array(inv(t, q, dq, ddq)).ravel(),
               np.array(mass(q)))
        for a, b in zip(got, ref):
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12)
    # CasADi's derivative of the forward dynamics = central differences of anadyn's
    x = ca.SX.sym("x", 2 * model.n)
    J = ca.Function("J", [x], [ca.jacobian(fd(t, x[:model.n], x[model.n:], tau), x)])
    x0 = np.concatenate([q, dq])
    eps = 1e-6
    numeric = np.column_stack([
        (model.driven_accelerations(t, x0 + eps * e, tau)
         - model.driven_accelerations(t, x0 - eps * e, tau)) / (2 * eps)
        for e in np.eye(2 * model.n)])
    assert np.allclose(np.array(J(x0)), numeric, rtol=1e-6, atol=1e-6)


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("name", FILES)
def test_jax_equals_numeric_model(tmp_path, name):
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    import anadyn

    out = tmp_path / "jx"
    assert main(["export", str(ROBOTS / name), "--lang", "jax", "--out", str(out)]) == 0
    model = anadyn.numeric_model(str(ROBOTS / name))
    spec = importlib.util.spec_from_file_location("exported", out / f"{model.name}_jax.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    fd = jax.jit(module.forward_dynamics)
    rng = np.random.default_rng(3)
    m = len(model.effort_names)
    for _ in range(3):
        t, q, dq, tau, ddq = _states(model, rng, m)
        got = (np.array(fd(t, q, dq, tau)), np.array(module.inverse_dynamics(t, q, dq, ddq)),
               np.array(module.mass_matrix(q)))
        for a, b in zip(got, _reference(model, t, q, dq, tau, ddq)):
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12)
    batch = jax.vmap(module.forward_dynamics, in_axes=(None, 0, 0, 0))(
        t, np.tile(q, (4, 1)), np.tile(dq, (4, 1)), np.tile(tau, (4, 1)))
    assert batch.shape == (4, model.n) and np.allclose(batch[2], got[0], atol=1e-12)
    # grad of a scalar of ddq against central differences of anadyn's model
    grad = np.array(jax.grad(lambda q_: module.forward_dynamics(t, q_, dq, tau)[0])(q))
    eps = 1e-6
    numeric = [(model.driven_accelerations(t, np.concatenate([q + eps * e, dq]), tau)[0]
                - model.driven_accelerations(t, np.concatenate([q - eps * e, dq]), tau)[0])
               / (2 * eps) for e in np.eye(model.n)]
    assert np.allclose(grad, numeric, rtol=1e-6, atol=1e-6)


def test_symbolic_refused_for_traced_languages(capsys):
    assert main(["export", str(ROBOTS / "rr.yaml"), "--lang", "jax", "--symbolic"]) == 2
    assert capsys.readouterr().err == ("anadyn: error: --symbolic applies to python, c, "
                                       "matlab and latex, not jax\n")


LOADED = """
loads:
  - body: bar2
    point: [0.5, 0, 0]
    force: ["0.3*max(q1, 0) + abs(dq2)*sign(q2)", "5*sin(2*t)*exp(-t)", 0]
    torque: [0, 0, "atan2(q1, 2) + tanh(dq1)"]
"""


def test_sympy_statements_of_loads(tmp_path):
    """Loads of t, q, dq reach the traced code as SymPy statements: CasADi translates them
    node by node, JAX prints them; both still equal the numeric model."""
    ca = pytest.importorskip("casadi")
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    import anadyn
    from anadyn_cli.model import load_robot
    from anadyn_cli.output.export import traced

    path = tmp_path / "rr_loaded.yaml"
    path.write_text((ROBOTS / "rr.yaml").read_text() + LOADED)
    kinds = {s.kind for f in traced.trace(load_robot(path)).functions.values()
             for s in f.statements}
    assert "sympy" in kinds
    for lang in ("casadi", "jax"):
        assert main(["export", str(path), "--lang", lang, "--out", str(tmp_path / lang)]) == 0
    fd = ca.Function.deserialize((tmp_path / "casadi" / "rr_forward_dynamics.casadi").read_text())
    inv = ca.Function.deserialize((tmp_path / "casadi" / "rr_inverse_dynamics.casadi").read_text())
    spec = importlib.util.spec_from_file_location("loaded", tmp_path / "jax" / "rr_jax.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    model = anadyn.numeric_model(str(path))
    rng = np.random.default_rng(11)
    for _ in range(5):
        t, q, dq, tau, ddq = _states(model, rng, 2)
        ref = _reference(model, t, q, dq, tau, ddq)[:2]
        for got in ((np.array(fd(t, q, dq, tau)).ravel(), np.array(inv(t, q, dq, ddq)).ravel()),
                    (np.array(module.forward_dynamics(t, q, dq, tau)),
                     np.array(module.inverse_dynamics(t, q, dq, ddq)))):
            for a, b in zip(got, ref):
                assert np.allclose(a, b, rtol=1e-12, atol=1e-12)


def test_without_casadi_one_line(monkeypatch, tmp_path, capsys):
    import sys

    monkeypatch.setitem(sys.modules, "casadi", None)          # import casadi fails
    message = "anadyn: error: CasADi is not installed; pip install 'anadyn[casadi]' (or casadi)\n"
    for argv in (["export", str(ROBOTS / "rr.yaml"), "--lang", "casadi"],
                 ["optimize", str(ROBOTS / "optimize" / "rr_swing.yaml")]):
        assert main([*argv, "--out", str(tmp_path / "out")]) == 2
        assert capsys.readouterr().err == message
    assert not (tmp_path / "out").exists()
