"""One road to each result: the prescribed motion and the control laws.

``numeric.trajectory.derivatives`` generates the motion for a plain run and
for a sweep's bindable module (parameters left free); ``closed_form.control_laws``
gives the laws for the numeric modules, the export and linearize.  The
references are written out again here: the cycloid and its derivatives by
hand, the laws evaluated from the file's own text of the parameters.
"""
import math
from pathlib import Path

import numpy as np
import sympy as sp

from anadyn_cli.errors import ModelError
from anadyn_cli.model import robot_from_text
from anadyn_cli.model.info import RobotInfo
from anadyn_cli.numeric import bindable, closed_form, trajectory

ROOT = Path(__file__).resolve().parents[1]
RR_TEXT = (ROOT / "robots" / "rr.yaml").read_text()
CYCLOID = "trajectory: {kind: cycloidal, duration: 15, to: {q1: pi/6, q2: pi/3}}"


def cycloid(q0: float, qf: float, T: float, t: np.ndarray):
    """q, dq, ddq of the rest-to-rest cycloid from q0 to qf in T, by hand."""
    w = 2 * math.pi / T
    q = q0 + (qf - q0) / T * (t - np.sin(w * t) / w)
    dq = (qf - q0) / T * (1 - np.cos(w * t))
    ddq = (qf - q0) / T * w * np.sin(w * t)
    return q, dq, ddq


def test_the_swept_motion_and_the_plain_motion_are_the_hand_cycloid(tmp_path):
    # the end of q2 is a parameter: free in the sweep's module, a number in the plain run
    text = (RR_TEXT.replace("parameters: {", "parameters: {q2_end: pi/3, ")
            .replace(CYCLOID, "trajectory: {kind: cycloidal, duration: 15, "
                              "to: {q1: pi/6, q2: q2_end}}"))
    assert text != RR_TEXT
    path = tmp_path / "rr_end.yaml"
    path.write_text(text)
    robot = robot_from_text(text, str(path))
    t = np.linspace(0.0, 15.0, 61)
    q10, q20 = -math.pi / 18, robot.coordinates[1].initial

    plain = trajectory.motion(robot)(t)
    folding = bindable.fold(robot, text, ("q2_end",))
    model = bindable.BoundModel(RobotInfo.from_robot(folding.robot),
                                bindable.source(folding, "kane"), "kane")
    for value in (math.pi / 3, 1.25):
        swept = model.bind([value]).motion(t)
        for k, (q0, qf) in enumerate(((q10, math.pi / 6), (float(q20), value))):
            for got, want in zip(swept, cycloid(q0, qf, 15.0, t)):
                np.testing.assert_allclose(got[:, k], want, rtol=0, atol=1e-12)
            if value == math.pi / 3:          # the file's value: the plain run's motion
                for got, want in zip(plain, cycloid(q0, qf, 15.0, t)):
                    np.testing.assert_allclose(got[:, k], want, rtol=0, atol=1e-12)


def test_a_motion_without_acceleration_is_refused_alike_by_both_roads(tmp_path):
    text = RR_TEXT.replace(CYCLOID, "trajectory: {kind: expression, duration: 2, "
                                    "expressions: {q1: abs(t - 1)}}")
    assert text != RR_TEXT
    path = tmp_path / "kink.yaml"
    path.write_text(text)
    robot = robot_from_text(text, str(path))
    message = (f"{path}: trajectory.expressions.q1: q1(t) is not twice differentiable "
               "(its rate jumps); inverse dynamics needs a finite acceleration")
    try:
        trajectory.motion(robot)
    except ModelError as err:
        assert str(err) == message
    else:
        raise AssertionError("the kinked motion was compiled")
    folding = bindable.fold(robot, text, ("m2",))
    model = bindable.BoundModel(RobotInfo.from_robot(folding.robot),
                                bindable.source(folding, "kane"), "kane").bind([2.0])
    try:
        model.motion
    except ModelError as err:
        assert str(err) == message
    else:
        raise AssertionError("the sweep's module compiled the kinked motion")


def test_the_symbolic_control_laws_are_the_numeric_ones_at_the_files_values():
    robot = robot_from_text(RR_TEXT, "rr.yaml")
    numeric = closed_form.control_laws(robot)
    symbolic = closed_form.control_laws(robot, symbolic=True)
    # the file's values, read again from its text: parameters and gains
    values = {sp.Symbol(k, real=True): v for k, v in
              {"L1": 1.0, "L2": 1.0, "m1": 1.0, "m2": 1.0, "g": 9.81, "b01": 450, "g01": 300,
               "b12": 200, "g12": 300, "q1f": math.pi / 6, "q2f": math.pi / 3}.items()}
    assert {s.name for s in symbolic.free_symbols} >= {"b01", "g01", "q1f"}
    rng = np.random.default_rng(4)
    state = [sp.Symbol("t", real=True), *(c.symbol for c in robot.coordinates),
             *sorted(numeric.free_symbols - {sp.Symbol("t", real=True)}
                     - {c.symbol for c in robot.coordinates}, key=str)]
    for _ in range(5):
        point = dict(zip(state, rng.uniform(-1, 1, len(state))))
        want = [float(e.xreplace(values).xreplace(point)) for e in symbolic]
        got = [float(e.xreplace(point)) for e in numeric]
        np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-12)
