"""`anadyn export` of robots with a spherical or a floating joint: the state is
x = [q, u] with nq coordinates (each spherical joint's unit quaternion (qw, qx, qy, qz)
among them) and n < nq speeds (its body-axes angular velocity), so the exported
functions take q (nq) and u (n), return M (n x n), F (n), B (n x m), du (n) and the
efforts as they do for any robot, and add rates(q, u) = W(q) u (nq); the state
derivative is [W(q) u, du] (nq + n) and its Jacobian [[R], [M^-1 K]].

Checked against independent sources:

- anadyn's numeric model (``anadyn.numeric_model``: the recursive Newton-Euler path,
  generated and run by other code than the closed forms the export prints) at 20
  random states (unit quaternions, random speeds, times and efforts), every exported
  function of the C (gcc -std=c99 -Wall -Wextra -Werror -pedantic, loaded with ctypes)
  and of the Python, to 1e-12 relative: the spherical pendulum, the satellite (a
  floating bus with a reaction wheel under a time-dependent law), a chain with two
  spherical joints and a law of the speeds and a quaternion, and (slow) Solo12 on its
  free base;
- Pinocchio's free-flyer model of Solo12 (``pinocchio_mapped``: its linear speed in
  body axes and its (x, y, z, w) quaternion mapped explicitly): M, the inverse and the
  forward dynamics of the exported Python to 1e-9 relative;
- ``anadyn simulate``: the exported Python rhs integrated by SciPy for 1 s ends where
  simulate ends (quaternions made unit, as simulate writes them);
- Octave runs the MATLAB files where it is installed (skipped otherwise).

The derivatives' export (``--derivatives``, with its ``_batch`` functions) and the
traced CasADi/JAX exports still refuse such a robot, with one line.
"""
from __future__ import annotations

import csv
import ctypes
import functools
import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import anadyn
from anadyn_cli.cli import main
from anadyn_cli.model import load_robot, robot_from_text
from anadyn_cli.services import export as service
from anadyn_cli.symbolic.formulations import derive

from test_export import (C_FLAGS, GCC, OCTAVE, assert_balanced, load_module,
                         octave_numbers)

REPO = Path(__file__).resolve().parent.parent
TOL = 1e-12
STATES = 20

# two spherical joints in a chain, an actuated turn between them, and a control law
# of a speed, a quaternion's coordinate and time
TWO_BALLS = """\
name: two_balls
parameters: {m1: 1.2, m2: 0.8, g: 9.81}
gravity: [0.2, -0.1, -g]
coordinates:
  th: {initial: 0.2, rate: 0.1}
speeds:
  upper_wz: {initial: 1.0}
  lower_wx: {initial: -0.5}
bodies:
  - name: upper
    joint: {type: spherical, origin: [0, 0, 1], rpy: [0.1, 0.2, -0.3]}
    mass: m1
    com: [0.05, 0.02, -0.3]
    inertia: {ixx: 0.03, iyy: 0.04, izz: 0.02, ixy: 0.002, ixz: -0.001, iyz: 0.003}
  - name: elbow
    parent: upper
    joint: {type: revolute, axis: [0, 1, 0], origin: [0, 0, -0.6], displacement: th}
    mass: 0.5
    com: [0.1, 0, 0]
    inertia: {ixx: 0.002, iyy: 0.004, izz: 0.004}
  - name: lower
    parent: elbow
    joint: {type: spherical, origin: [0.2, 0, 0]}
    mass: m2
    com: [0, 0.01, -0.25]
    inertia: {ixx: 0.02, iyy: 0.025, izz: 0.01, ixy: -0.001, ixz: 0.0005, iyz: 0.001}
actuators:
  T: {joint: elbow}
controller:
  gains: {k: 3.0, c: 0.4}
  laws:
    T: -k*th - c*dth + 0.3*upper_wx + 0.2*lower_qz*sin(t)
"""
QUICK = ["spherical_pendulum", "satellite", "two_balls"]
CASES = [*QUICK, pytest.param("solo12_free", marks=pytest.mark.slow)]
needs_gcc = pytest.mark.skipif(GCC is None, reason="no C compiler (gcc or cc) on this machine")


@functools.lru_cache(maxsize=None)
def robot_of(case: str):
    if case == "two_balls":
        return robot_from_text(TWO_BALLS, "two_balls.yaml")
    return load_robot(REPO / "robots" / f"{case}.yaml")


@functools.lru_cache(maxsize=None)
def export_of(case: str, lang: str):
    """The export of ``case`` in ``lang`` (the equations derived once per robot)."""
    return service.export(robot_of(case), lang, eom=_equations(case))


@functools.lru_cache(maxsize=None)
def _equations(case: str):
    return derive(robot_of(case), "kane")


class Reference:
    """anadyn's numbers at random states x = [q, u] (unit quaternions), times and efforts."""

    def __init__(self, robot, seed: int = 3):
        model = anadyn.numeric_model(robot)
        self.nq, self.n, self.m = model.nq, model.n, len(robot.actuators)
        assert self.nq > self.n                     # the case this file is about
        rng = np.random.default_rng(seed)
        self.rows = []
        for _ in range(STATES):
            x = np.concatenate([rng.uniform(-1.2, 1.2, self.nq), rng.uniform(-2, 2, self.n)])
            for index in model.quaternions:
                drawn = rng.normal(size=4)
                x[list(index)] = drawn / np.linalg.norm(drawn)
            t, tau = float(rng.uniform(0, 3)), rng.uniform(-3, 3, self.m)
            q, u = x[:self.nq], x[self.nq:]
            M, F, B = (np.asarray(a, dtype=float) for a in model.mfb(t, q, u))
            B = B.reshape(self.n, self.m)
            du = np.linalg.solve(M, F + B @ tau)
            self.rows.append({
                "t": t, "x": x, "tau": tau, "M": M, "F": F, "B": B,
                "efforts": np.asarray(model.efforts(t, q, u), dtype=float).reshape(self.m),
                "rates": model.coordinate_rates(x), "rhs": model.rhs(t, x),
                "jacobian": model.jacobian(t, x), "du": du,
                "inverse": np.linalg.pinv(B) @ (M @ du - F)})


@functools.lru_cache(maxsize=None)
def reference_of(case: str) -> Reference:
    return Reference(robot_of(case))


def assert_close(name: str, got, want) -> None:
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert got.shape == want.shape, f"{name}: shape {got.shape} != {want.shape}"
    if want.size:
        scale = max(1.0, float(np.abs(want).max()))
        difference = float(np.abs(got - want).max())
        assert difference <= TOL * scale, f"{name}: max |diff| {difference:.3g} (scale {scale:.3g})"


KEYS = ("M", "F", "B", "efforts", "rates", "rhs", "jacobian", "du", "inverse")


# -- C ----------------------------------------------------------------------------------------
class CRobot:
    """The exported C behind ctypes."""

    def __init__(self, folder: Path, name: str, nq: int, n: int, m: int):
        library = folder / f"lib{name}.so"        # no -O: Solo12's C builds in 1 s, not minutes
        done = subprocess.run([GCC, *C_FLAGS, "-fPIC", "-shared", str(folder / f"{name}.c"),
                               "-o", str(library), "-lm"], capture_output=True, text=True)
        assert done.returncode == 0, f"gcc failed:\n{done.stderr}"
        self.lib, self.name, self.nq, self.n, self.m = ctypes.CDLL(str(library)), name, nq, n, m

    def call(self, function: str, *args, out: int):
        result = (ctypes.c_double * max(out, 1))()
        arrays = [ctypes.c_double(a) if isinstance(a, float) else
                  (ctypes.c_double * max(len(a), 1))(*a) for a in args]
        f = getattr(self.lib, f"{self.name}_{function}")
        f.restype = ctypes.c_int if function == "accelerations" else None
        status = f(*arrays, result)
        assert status in (None, 0), f"{function} returned {status}"
        return np.array(result[:out])

    def values(self, row) -> dict:
        nq, n, m, t = self.nq, self.n, self.m, row["t"]
        x = list(row["x"])
        q, u = x[:nq], x[nq:]
        return {"M": self.call("mass_matrix", q, out=n * n).reshape(n, n),
                "F": self.call("forcing", t, q, u, out=n),
                "B": self.call("input_matrix", q, out=n * m).reshape(n, m),
                "efforts": self.call("efforts", t, q, u, out=m),
                "rates": self.call("rates", q, u, out=nq),
                "rhs": self.call("rhs", t, x, out=nq + n),
                "jacobian": self.call("jacobian", t, x, out=(nq + n) ** 2).reshape(nq + n, -1),
                "du": self.call("accelerations", t, q, u, list(row["tau"]), out=n),
                "inverse": self.call("inverse", t, q, u, list(row["du"]), out=m)}


@needs_gcc
@pytest.mark.parametrize("case", CASES)
def test_exported_c_matches_anadyn(case, tmp_path):
    result = export_of(case, "c")
    service.write(result, tmp_path)
    reference = reference_of(case)
    c_robot = CRobot(tmp_path, result.model.name, reference.nq, reference.n, reference.m)
    for row in reference.rows:
        got = c_robot.values(row)
        for key in KEYS:
            assert_close(f"{case} C {key}", got[key], row[key])


def test_the_c_header_states_the_sizes_and_the_conventions():
    header = export_of("satellite", "c").files["satellite.h"]
    for line in ("#define SATELLITE_N_COORDINATES 8", "#define SATELLITE_N_SPEEDS 7",
                 "#define SATELLITE_N_EFFORTS 1", "#define SATELLITE_N_STATES 15"):
        assert line in header
    text = " ".join(header.replace(" * ", " ").split())
    for phrase in ("unit quaternion (qw, qx, qy, qz), scalar first",
                   "angular velocity relative to its parent in the body's own axes",
                   "the world for a base", "dq = W(q) u",
                   "void satellite_rates(const double *q, const double *u, double *dq);",
                   "void satellite_forcing(double t, const double *q, const double *u, "
                   "double *F);",
                   "q[4] = bus_qw (1)", "u[4] = bus_wx (rad/s); du[4] = dbus_wx (rad/s^2)"):
        assert phrase in text, phrase
    # a robot without a spherical joint keeps its header (no speeds macro, x = [q, dq])
    rr = service.export(load_robot(REPO / "robots" / "rr.yaml"), "c").files["rr.h"]
    assert "N_SPEEDS" not in rr and "state x = [q, dq] = [q1, q2, dq1, dq2]" in rr


@needs_gcc
def test_a_program_integrates_the_c_with_the_header_macros(tmp_path):
    """A user's program: explicit Euler steps on [W(q) u, du] with the quaternion made
    unit each step, sized by the header's macros; the spin about the rod's axis (no
    torque about it: izz du_z = 0) stays 2 rad/s."""
    service.write(export_of("spherical_pendulum", "c"), tmp_path)
    program = tmp_path / "use.c"
    program.write_text("""\
#include <math.h>
#include <stdio.h>
#include "spherical_pendulum.h"
int main(void)
{
    double x[SPHERICAL_PENDULUM_N_STATES] = SPHERICAL_PENDULUM_INITIAL_STATE;
    double dx[SPHERICAL_PENDULUM_N_STATES], norm;
    int i, k;
    for (k = 0; k < 1000; ++k) {
        spherical_pendulum_rhs(0.0, x, dx);
        for (i = 0; i < SPHERICAL_PENDULUM_N_STATES; ++i)
            x[i] += 1e-3 * dx[i];
        norm = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]);
        for (i = 0; i < SPHERICAL_PENDULUM_N_COORDINATES; ++i)
            x[i] /= norm;
    }
    printf("%.12f %d\\n", x[SPHERICAL_PENDULUM_N_COORDINATES + 2], SPHERICAL_PENDULUM_N_SPEEDS);
    return 0;
}
""")
    done = subprocess.run([GCC, *C_FLAGS, str(program), str(tmp_path / "spherical_pendulum.c"),
                           "-o", str(tmp_path / "use"), "-lm"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    out = subprocess.run([str(tmp_path / "use")], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["2.000000000000", "3"]


# -- Python -----------------------------------------------------------------------------------
def python_module(case: str, folder: Path):
    result = export_of(case, "python")
    service.write(result, folder)
    path = folder / f"{result.model.name}.py"
    imports = re.findall(r"^\s*(?:import|from)\s+(\w+)", path.read_text(), flags=re.M)
    assert set(imports) == {"math"}, imports            # the standard library only
    return load_module(path)


def python_values(module, row, nq: int) -> dict:
    t, x = row["t"], list(row["x"])
    q, u = x[:nq], x[nq:]
    return {"M": module.mass_matrix(q), "F": module.forcing(t, q, u),
            "B": np.reshape(module.input_matrix(q), row["B"].shape),
            "efforts": module.efforts(t, q, u), "rates": module.rates(q, u),
            "rhs": module.rhs(t, x), "jacobian": module.jacobian(t, x),
            "du": module.accelerations(t, q, u, list(row["tau"])),
            "inverse": module.inverse(t, q, u, list(row["du"]))}


@pytest.mark.parametrize("case", CASES)
def test_exported_python_matches_anadyn(case, tmp_path):
    module = python_module(case, tmp_path)
    reference = reference_of(case)
    assert (module.N_COORDINATES, module.N_SPEEDS) == (reference.nq, reference.n)
    assert len(module.INITIAL_STATE) == reference.nq + reference.n
    for row in reference.rows:
        got = python_values(module, row, reference.nq)
        for key in KEYS:
            assert_close(f"{case} Python {key}", got[key], row[key])


def test_symbolic_python_takes_the_parameters(tmp_path):
    """--symbolic: the satellite's parameters and gains passed in, changed, match anadyn
    on the file with those values."""
    changed = {"m_bus": 400.0, "Ibz": 90.0, "T0": 0.5}
    result = service.export(robot_of("satellite"), "python", symbolic=True)
    service.write(result, tmp_path)
    module = load_module(tmp_path / "satellite.py")
    p = {**module.PARAMETERS, **changed}
    reference = Reference(anadyn.load(REPO / "robots" / "satellite.yaml", changed))
    for row in reference.rows[:5]:
        x = list(row["x"])
        assert_close("symbolic rhs", module.rhs(row["t"], x, p), row["rhs"])
        assert_close("symbolic jacobian", module.jacobian(row["t"], x, p), row["jacobian"])
    assert np.abs(np.array(module.rhs(1.0, x)) - np.array(module.rhs(1.0, x, p))).max() > 1e-3


def _simulated(case: str, folder: Path) -> np.ndarray:
    """simulate.csv's row at t = 1 s (quaternions unit)."""
    code = main(["simulate", str(REPO / "robots" / f"{case}.yaml"), "--t-end", "1",
                 "--no-plot", "--out", str(folder)])
    assert code == 0
    with open(folder / "simulate.csv", newline="") as handle:
        rows = list(csv.reader(handle))
    last = [float(v) for v in rows[-1]]
    assert last[0] == 1.0
    return np.array(last[1:])


@pytest.mark.parametrize("case", ["spherical_pendulum", "satellite"])
def test_the_exported_rhs_integrates_like_simulate(case, tmp_path):
    from scipy.integrate import solve_ivp

    module = python_module(case, tmp_path / "export")
    nq, n = module.N_COORDINATES, module.N_SPEEDS
    ode = solve_ivp(module.rhs, (0.0, 1.0), module.INITIAL_STATE, method="DOP853",
                    rtol=1e-11, atol=1e-12, t_eval=[1.0])
    assert ode.success
    x = ode.y[:, -1]
    for index in anadyn.numeric_model(robot_of(case)).quaternions:
        x[list(index)] /= np.linalg.norm(x[list(index)])
    simulated = _simulated(case, tmp_path / "simulate")
    assert np.abs(x - simulated[:nq + n]).max() < 1e-7


# -- against Pinocchio's free-flyer --------------------------------------------------------------
@pytest.mark.slow
def test_solo12_exports_match_pinocchios_free_flyer(tmp_path):
    """robots/solo12_free.yaml is solo12.urdf of example-robot-data imported with a free
    base: Pinocchio reads the URDF with a free-flyer root."""
    pin = pytest.importorskip("pinocchio")
    from pinocchio_mapped import check_mapped
    from test_floating import ROBOTS, Mapping

    urdf = ROBOTS / "solo_description" / "robots" / "solo12.urdf"
    if not urdf.exists():
        pytest.skip("example-robot-data has no solo12.urdf")
    robot = robot_of("solo12_free")
    model = pin.buildModelFromXML(re.sub(r"<dynamics[^>]*/>", "", urdf.read_text()),
                                  pin.JointModelFreeFlyer())
    joints = {c.name: c.name for c in robot.coordinates if not c.name.startswith("base_link_")}
    mapping = Mapping(robot, model, "base_link", joints)
    module = python_module("solo12_free", tmp_path)
    nq = module.N_COORDINATES

    def mfb(t, *x):
        q, u = x[:nq], x[nq:]
        return (np.array(module.mass_matrix(q)), np.array(module.forcing(t, q, u)),
                np.array(module.input_matrix(q)))

    def inverse_dynamics(t, *x):                       # M du - F: every generalized force
        q, u, du = x[:nq], x[nq:nq + module.N_SPEEDS], x[nq + module.N_SPEEDS:]
        return np.array(module.mass_matrix(q)) @ du - np.array(module.forcing(t, q, u))

    def accelerations(t, *x):
        return module.accelerations(t, x[:nq], x[nq:], [0.0] * module.N_EFFORTS)

    namespace = {"mfb": mfb, "inverse_dynamics": inverse_dynamics,
                 "accelerations": accelerations}
    assert check_mapped(pin, namespace, model, mapping.random, mapping.to_pin) == 20


# -- MATLAB / Octave, LaTeX ---------------------------------------------------------------------
def test_matlab_files_take_q_and_u_and_add_the_rates(tmp_path):
    result = export_of("satellite", "matlab")
    files = result.files
    assert "satellite_rates.m" in files
    for name, text in files.items():
        first = text.splitlines()[0]
        assert re.fullmatch(rf"function \w+ = {name[:-2]}\(.*\)", first), first
    assert files["satellite_forcing.m"].startswith("function F = satellite_forcing(t, q, u)")
    assert "  dx = [satellite_rates(q, u); satellite_accelerations(" in files["satellite_rhs.m"]
    assert "function J = satellite_rates_jacobian(q, u)" in files["satellite_jacobian.m"]


@pytest.mark.skipif(OCTAVE is None, reason="Octave is not installed (apt-get install octave)")
@pytest.mark.parametrize("case", QUICK)
def test_matlab_files_run_in_octave(case, tmp_path):
    result = export_of(case, "matlab")
    service.write(result, tmp_path)
    name, reference = result.model.name, reference_of(case)
    nq, n, m = reference.nq, reference.n, reference.m
    vec = lambda v: "[" + "; ".join(repr(float(a)) for a in v) + "]"   # noqa: E731
    calls = [f"{name}_mass_matrix(q)", f"{name}_forcing(t, q, u)", f"{name}_input_matrix(q)",
             f"{name}_efforts(t, q, u)", f"{name}_rates(q, u)", f"{name}_rhs(t, x)",
             f"{name}_jacobian(t, x)", f"{name}_accelerations(t, q, u, tau)",
             f"{name}_inverse(t, q, u, du)"]
    lines = [f"addpath('{tmp_path}');"]
    for row in reference.rows[:5]:
        x = row["x"]
        lines += [f"t = {row['t']!r}; q = {vec(x[:nq])}; u = {vec(x[nq:])}; x = [q; u];",
                  f"tau = {vec(row['tau'])}; du = {vec(row['du'])};",
                  "out = {" + ", ".join(calls) + "};",
                  "for k = 1:numel(out)", "  v = out{k}';",
                  "  printf('%d', numel(v)); printf(' %.17g', v(:)); printf('\\n');", "end"]
    numbers = octave_numbers(tmp_path, lines)
    keys = ("M", "F", "B", "efforts", "rates", "rhs", "jacobian", "du", "inverse")
    for k, row in enumerate(reference.rows[:5]):
        for key, values in zip(keys, numbers[k * len(keys):(k + 1) * len(keys)]):
            if m == 0 and key in ("B", "efforts", "inverse"):
                continue
            assert_close(f"{case} Octave {key}", np.reshape(values, row[key].shape), row[key])


@pytest.mark.parametrize("case", QUICK)
def test_latex_has_one_equation_per_speed_and_the_kinematic_equations(case):
    result = export_of(case, "latex")
    text = result.files[f"{result.model.name}.tex"]
    assert_balanced(text)
    robot = robot_of(case)
    assert text.count("= 0 \\tag{") == len(robot.speeds)
    section = text.split(r"\subsection*{Kinematic differential equations}")[1]
    section = section.split(r"\subsection*")[0]
    assert section.count("&=") == len(robot.coordinates)
    assert r"M(q)\,\dot{u} = F(t, q, u) + B(q)\,\tau" in text


# -- what still refuses ---------------------------------------------------------------------------
@pytest.mark.parametrize("argv, words", [
    (["--lang", "c", "--derivatives"], "derivatives"),
    (["--lang", "python", "--derivatives"], "derivatives"),
    (["--lang", "casadi"], "exports"),
    (["--lang", "jax"], "exports")])
def test_derivatives_and_traced_exports_refuse_with_one_line(argv, words, tmp_path, capsys):
    if "casadi" in argv:
        pytest.importorskip("casadi")
    out = tmp_path / "x"
    code = main(["export", str(REPO / "robots" / "satellite.yaml"), *argv, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert "spherical joint" in err and words in err and "satellite.yaml" in err, err
    assert not out.exists() or not any(out.iterdir())


def test_export_runs_on_the_command_line(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["export", str(REPO / "robots" / "spherical_pendulum.yaml"), "--lang", "c",
                 "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["export.json", "spherical_pendulum.c",
                                                      "spherical_pendulum.h"]
    summary = json.loads((out / "export.json").read_text())
    assert summary["coordinates"] == ["qw", "qx", "qy", "qz"]
    assert summary["speeds"] == ["wx", "wy", "wz"]
