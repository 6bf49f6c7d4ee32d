"""anadyn simulate's and inverse's jobs done with Pinocchio, the baseline of
``bench/scale.py`` and ``bench/cold.py``.

    python bench/pinocchio_job.py ROBOT.urdf JOB.json OUT.csv
    python bench/pinocchio_job.py --inverse ROBOT.urdf JOB.json MOTION.csv OUT.csv

simulate: loads the URDF, sets gravity, integrates x = [q, v] under the PD
laws and joint friction tau = -b v - k (q - target) - f tanh(v / v0) with
scipy's odeint (LSODA) calling ABA, with the analytic Jacobian from
Pinocchio's ABA derivatives (d(ddq)/dx = [ddq_dq - Minv K, ddq_dv - Minv
(B + f / v0 (1 - tanh^2(v / v0)))]), at the same tolerances as anadyn, and writes
t, q, v, tau at full precision.  JOB.json holds the joint names (anadyn's
coordinate order), initial q, targets, gains, friction (optional), gravity,
t_end, dt, rtol, atol.  Prints the RHS and Jacobian calls.

--inverse: reads MOTION.csv (``t``, then q, ``d``q and ``dd``q by joint name,
as ``anadyn inverse --motion`` reads it; a joint without columns stays at 0),
computes tau = RNEA(q, v, a) + b v + k (q - target) + f tanh(v / v0) at every
sample (the efforts that make the damped joints follow the motion) and writes
t and tau at full precision.
"""
import json
import sys

import numpy as np
import pinocchio as pin
from scipy.integrate import odeint


def setup(urdf: str, job_path: str):
    """(job, model, data, place, b, k, target, f, v0): the job's arrays in Pinocchio's
    order (``place``: Pinocchio's index -> the job's)."""
    with open(job_path) as f:
        job = json.load(f)
    model = pin.buildModelFromUrdf(urdf)
    model.gravity.linear = np.array(job["gravity"], dtype=float)
    data = model.createData()
    n = model.nv
    order = np.array([model.joints[model.getJointId(j)].idx_v for j in job["joints"]])
    place = np.empty(n, dtype=int)
    place[order] = np.arange(n)              # pinocchio index -> job index
    f = np.array(job.get("friction", [0.0] * n))[place]
    v0 = np.array(job.get("friction_velocity", [1.0] * n))[place]
    return (job, model, data, place, np.array(job["damping"])[place],
            np.array(job["stiffness"])[place], np.array(job["target"])[place], f, v0)


def inverse(urdf: str, job_path: str, motion: str, out: str) -> None:
    job, model, data, place, b, k, target, f, v0 = setup(urdf, job_path)
    n = model.nv
    with open(motion) as handle:
        header = handle.readline().strip().split(",")
    table = np.loadtxt(motion, delimiter=",", skiprows=1, ndmin=2)
    column = {name: i for i, name in enumerate(header)}
    names = np.array(job["joints"])[place]               # Pinocchio's order
    q, v, a = (np.column_stack([table[:, column[prefix + j]] if prefix + j in column
                                else np.zeros(len(table)) for j in names])
               for prefix in ("", "d", "dd"))
    tau = np.empty_like(q)
    for i in range(len(table)):
        tau[i] = pin.rnea(model, data, q[i], v[i], a[i])
    tau += b * v + k * (q - target) + f * np.tanh(v / v0)
    np.savetxt(out, np.column_stack((table[:, column["t"]], tau)), delimiter=",", fmt="%.17g",
               header=",".join(["t", *(f"tau_{j}" for j in names)]), comments="")
    print(f"rnea calls {len(table)} ({n} joints)")


def main(urdf: str, job_path: str, out: str) -> None:
    job, model, data, place, b, k, target, fr, v0 = setup(urdf, job_path)
    n = model.nv
    calls = [0, 0]

    def tau_of(q, v):
        return -b * v - k * (q - target) - fr * np.tanh(v / v0)

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
        J[n:, n:] = dv - Minv * (b + fr / v0 * (1 - np.tanh(v / v0) ** 2))
        return J

    steps = int(round(job["t_end"] / job["dt"]))
    grid = np.arange(steps + 1) * job["dt"]
    x0 = np.concatenate((np.array(job["initial"])[place], np.zeros(n)))
    x = odeint(f, x0, grid, Dfun=jac, rtol=job["rtol"], atol=job["atol"], mxstep=10**6)
    q, v = x[:, :n], x[:, n:]
    tau = tau_of(q, v)
    names = [f"q_{j}" for j in np.array(job["joints"])[place]]
    header = ["t", *names, *("d" + s for s in names), *(f"tau_{s[2:]}" for s in names)]
    np.savetxt(out, np.column_stack((grid, q, v, tau)), delimiter=",", fmt="%.17g",
               header=",".join(header), comments="")
    print(f"rhs calls {calls[0]}, jacobian calls {calls[1]}")


if __name__ == "__main__":
    if sys.argv[1] == "--inverse":
        inverse(*sys.argv[2:6])
    else:
        main(*sys.argv[1:4])
