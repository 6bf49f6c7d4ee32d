"""The Pinocchio side of ``bench/floating.py``: a free-flyer robot's state
derivative from ABA, and, run as a script, a 1 s free fall written as CSV.

    python bench/pinocchio_fall.py ROBOT.urdf OUT.csv

x = [q, v] with Pinocchio's free-flyer q = (p, quaternion (x, y, z, w), joints) and
v = (linear velocity in body axes, angular velocity in body axes, joint rates):
dp = R v_lin, dquat = 1/2 quat (x) (0, w), the joints' rates, and a = ABA(q, v, 0).
Integrated by odeint (LSODA) at anadyn's default tolerances (1e-10, 1e-12).
"""
import sys

import numpy as np
import pinocchio as pin


def derivative(model, data):
    """f(x, t) -> dx/dt of the free-flyer robot ``model`` (module docstring)."""
    nq, nv = model.nq, model.nv
    zero = np.zeros(nv)

    def rhs(x, t=0.0):
        q, v = x[:nq], x[nq:]
        a = pin.aba(model, data, q, v, zero)
        x_, y_, z_, w_ = q[3:7]
        R = pin.Quaternion(w_, x_, y_, z_).matrix()
        wx, wy, wz = v[3:6]
        dquat = 0.5 * np.array([w_ * wx + y_ * wz - z_ * wy, w_ * wy + z_ * wx - x_ * wz,
                                w_ * wz + x_ * wy - y_ * wx, -(x_ * wx + y_ * wy + z_ * wz)])
        return np.concatenate([R @ v[:3], dquat, v[6:], a])
    return rhs


def main() -> None:
    from scipy.integrate import odeint

    urdf, out = sys.argv[1], sys.argv[2]
    model = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
    rhs = derivative(model, model.createData())
    x0 = np.concatenate([pin.neutral(model), np.zeros(model.nv)])
    t = np.linspace(0.0, 1.0, 101)
    x = odeint(rhs, x0, t, rtol=1e-10, atol=1e-12)
    np.savetxt(out, np.column_stack([t, x]), delimiter=",")


if __name__ == "__main__":
    main()
