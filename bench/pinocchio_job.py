"""anadyn simulate's job done with Pinocchio, the baseline of ``bench/scale.py``.

    python bench/pinocchio_job.py ROBOT.urdf JOB.json OUT.csv

Loads the URDF, sets gravity, integrates x = [q, v] under the PD laws
tau = -b v - k (q - target) with scipy's odeint (LSODA) calling ABA, with
the analytic Jacobian from Pinocchio's ABA derivatives
(d(ddq)/dx = [ddq_dq - Minv K, ddq_dv - Minv B]), at the same tolerances as
anadyn, and writes t, q, v, tau at full precision.  JOB.json holds the
joint names (anadyn's coordinate order), initial q, targets, gains,
gravity, t_end, dt, rtol, atol.  Prints the RHS and Jacobian calls.
"""
import json
import sys

import numpy as np
import pinocchio as pin
from scipy.integrate import odeint


def main(urdf: str, job_path: str, out: str) -> None:
    with open(job_path) as f:
        job = json.load(f)
    model = pin.buildModelFromUrdf(urdf)
    model.gravity.linear = np.array(job["gravity"], dtype=float)
    data = model.createData()
    n = model.nv
    order = np.array([model.joints[model.getJointId(j)].idx_v for j in job["joints"]])
    place = np.empty(n, dtype=int)
    place[order] = np.arange(n)              # pinocchio index -> job index
    b = np.array(job["damping"])[place]
    k = np.array(job["stiffness"])[place]
    target = np.array(job["target"])[place]
    calls = [0, 0]

    def tau_of(q, v):
        return -b * v - k * (q - target)

    def f(x, t):
        calls[0] += 1
        q, v = x[:n], x[n:]
        return np.concatenate((v, pin.aba(model, data, q, v, tau_of(q, v))))

    def jac(x, t):
        calls[1] += 1
        q, v = x[:n], x[n:]
        dq, dv, Minv = pin.computeABADerivatives(model, data, q, v, tau_of(q, v))
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        J[n:, :n] = dq - Minv * k
        J[n:, n:] = dv - Minv * b
        return J

    steps = int(round(job["t_end"] / job["dt"]))
    grid = np.arange(steps + 1) * job["dt"]
    x0 = np.concatenate((np.array(job["initial"])[place], np.zeros(n)))
    x = odeint(f, x0, grid, Dfun=jac, rtol=job["rtol"], atol=job["atol"], mxstep=10**6)
    q, v = x[:, :n], x[:, n:]
    tau = tau_of(q, v)
    names = [f"q_{j}" for j in np.array(job["joints"])[order]]
    header = ["t", *names, *("d" + s for s in names), *(f"tau_{s[2:]}" for s in names)]
    np.savetxt(out, np.column_stack((grid, q, v, tau)), delimiter=",", fmt="%.17g",
               header=",".join(header), comments="")
    print(f"rhs calls {calls[0]}, jacobian calls {calls[1]}")


if __name__ == "__main__":
    main(*sys.argv[1:4])
