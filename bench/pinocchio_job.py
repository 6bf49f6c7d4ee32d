"""anadyn simulate's and inverse's jobs done with Pinocchio, the baseline of
``bench/scale.py`` and ``bench/cold.py``.

    python bench/pinocchio_job.py ROBOT.urdf JOB.json OUT.csv
    python bench/pinocchio_job.py --inverse ROBOT.urdf JOB.json MOTION.csv OUT.csv
    python bench/pinocchio_job.py --check ROBOT.urdf JOB.json OUT.csv
    python bench/pinocchio_job.py --linearize ROBOT.urdf JOB.json OUT.csv

simulate: loads the URDF, sets gravity, integrates x = [q, v] under the PD
laws and joint friction tau = -b v - k (q - target) - f tanh(v / v0) with
scipy's odeint (LSODA) calling ABA, with the analytic Jacobian from
Pinocchio's ABA derivatives (d(ddq)/dx = [ddq_dq - Minv K, ddq_dv - Minv
(B + f / v0 (1 - tanh^2(v / v0)))]), at the same tolerances as anadyn, and writes
t, q, v, tau at full precision.  JOB.json holds the joint names (anadyn's
coordinate order), initial q, targets, gains, friction (optional), gravity,
t_end, dt, rtol, atol.  Prints the RHS and Jacobian calls.

--check: ``anadyn check``'s job: the same integration with the energy that the
joint damping and friction dissipate carried as one more state (its Jacobian
row analytic), then along the path the mass matrix's condition number (raw, and
after diagonal scaling) at every row, the energy balance T + V + E_d - E0 over
the energy scale, the eigenvalues of the state Jacobian at 200 rows, and RK45
at rtol 1e-3 and 1e-7 (5,000 and 20,000 RHS calls at most); writes t, the two
condition numbers and the balance.

--linearize: ``anadyn linearize``'s job at the initial state, at rest, under the
static holding efforts (RNEA(q, 0, 0) + k (q - target)): A = [[0, I], [d(ddq)/dq,
d(ddq)/dv]] and B = [[0], [M^-1]] from Pinocchio's ABA derivatives, the
eigenvalues of A, the controllability rank of (A, B) (orthonormal Krylov
blocks, ``staircase_rank``); writes A and B.

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


class Dynamics:
    """The job's closed loop: x = [q, v] (and, with ``dissipation``, the energy that
    damping and friction dissipate, one more state)."""

    def __init__(self, urdf: str, job_path: str, dissipation: bool = False):
        (self.job, self.model, self.data, self.place, self.b, self.k, self.target, self.fr,
         self.v0) = setup(urdf, job_path)
        self.n, self.extra, self.calls = self.model.nv, int(dissipation), [0, 0]

    def tau(self, q, v):
        return -self.b * v - self.k * (q - self.target) - self.fr * np.tanh(v / self.v0)

    def f(self, x, t):
        self.calls[0] += 1
        n = self.n
        q, v = x[:n], x[n:2 * n]
        out = [v, pin.aba(self.model, self.data, q, v, self.tau(q, v))]
        if self.extra:
            out.append([np.dot(v, self.b * v + self.fr * np.tanh(v / self.v0))])
        return np.concatenate(out)

    def jac(self, x, t):
        self.calls[1] += 1
        n = self.n
        q, v = x[:n], x[n:2 * n]
        dq, dv, Minv = pin.computeABADerivatives(self.model, self.data, q, v, self.tau(q, v))
        J = np.zeros((2 * n + self.extra, 2 * n + self.extra))
        J[:n, n:2 * n] = np.eye(n)
        J[n:2 * n, :n] = dq - Minv * self.k
        th = np.tanh(v / self.v0)
        J[n:2 * n, n:2 * n] = dv - Minv * (self.b + self.fr / self.v0 * (1 - th ** 2))
        if self.extra:
            J[2 * n, n:2 * n] = 2 * self.b * v + self.fr * (th + v / self.v0 * (1 - th ** 2))
        return J

    def path(self):
        """(grid, x) of the job's run, by odeint (LSODA) with the Jacobian."""
        job = self.job
        steps = int(round(job["t_end"] / job["dt"]))
        grid = np.arange(steps + 1) * job["dt"]
        x0 = np.concatenate((np.array(job["initial"])[self.place], np.zeros(self.n),
                             np.zeros(self.extra)))
        return grid, odeint(self.f, x0, grid, Dfun=self.jac, rtol=job["rtol"],
                            atol=job["atol"], mxstep=10**6)


def main(urdf: str, job_path: str, out: str) -> None:
    d = Dynamics(urdf, job_path)
    job, place, n, calls = d.job, d.place, d.n, d.calls
    grid, x = d.path()
    q, v = x[:, :n], x[:, n:]
    tau = d.tau(q, v)
    names = [f"q_{j}" for j in np.array(job["joints"])[place]]
    header = ["t", *names, *("d" + s for s in names), *(f"tau_{s[2:]}" for s in names)]
    np.savetxt(out, np.column_stack((grid, q, v, tau)), delimiter=",", fmt="%.17g",
               header=",".join(header), comments="")
    print(f"rhs calls {calls[0]}, jacobian calls {calls[1]}")


def check(urdf: str, job_path: str, out: str) -> None:
    from scipy.integrate import solve_ivp

    d = Dynamics(urdf, job_path, dissipation=True)
    model, data, n = d.model, d.data, d.n
    grid, x = d.path()
    raw, scaled, T, V = (np.empty(len(grid)) for _ in range(4))
    for i, row in enumerate(x):
        q, v = row[:n], row[n:2 * n]
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        s = 1 / np.sqrt(np.diag(M))
        raw[i], scaled[i] = np.linalg.cond(M), np.linalg.cond(s[:, None] * M * s)
        T[i] = pin.computeKineticEnergy(model, data, q, v)
        V[i] = pin.computePotentialEnergy(model, data, q)
    dissipated = x[:, 2 * n]
    scale = max(T.max(), V.max() - V.min(), dissipated.max())
    balance = (T + V + dissipated - T[0] - V[0]) / scale
    rows = np.unique(np.linspace(0, len(grid) - 1, 200).round().astype(int))
    fastest = max(np.abs(np.linalg.eigvals(d.jac(x[i], grid[i])[:2 * n, :2 * n])).max()
                  for i in rows)

    class Budget(Exception):
        pass

    def probe(rtol, budget):
        count = [0]

        def f(t, y):
            count[0] += 1
            if count[0] > budget:
                raise Budget
            return d.f(y, t)
        try:
            solve_ivp(f, (grid[0], grid[-1]), x[0], method="RK45", rtol=rtol, atol=rtol * 1e-2)
        except Budget:
            pass
        return count[0]
    loose, tight = probe(1e-3, 5_000), probe(1e-7, 20_000)
    np.savetxt(out, np.column_stack((grid, raw, scaled, balance)), delimiter=",", fmt="%.17g",
               header="t,condition,scaled_condition,energy_balance", comments="")
    print(f"largest |balance| {np.abs(balance).max():.1e}, fastest rate {fastest:.3g}, "
          f"RK45 calls {loose} / {tight}")


def staircase_rank(A, B, tol: float = 1e-10) -> int:
    """The dimension of the controllable subspace of (A, B), grown one orthonormal
    Krylov block at a time (as ``anadyn linearize`` does)."""
    def orthonormal(W):
        U, s, _ = np.linalg.svd(W, full_matrices=False)
        return U[:, :int(np.sum(s > tol * max(s.max(initial=0.0), 1e-300)))]
    basis = block = orthonormal(B)
    while block.shape[1] and basis.shape[1] < len(A):
        W = A @ block
        W -= basis @ (basis.T @ W)
        block = orthonormal(W) if np.abs(W).max() > tol * np.abs(A).max() else W[:, :0]
        basis = np.hstack((basis, block))
    return basis.shape[1]


def linearize(urdf: str, job_path: str, out: str) -> None:
    d = Dynamics(urdf, job_path)
    model, data, n = d.model, d.data, d.n
    q, v = np.array(d.job["initial"])[d.place], np.zeros(n)
    tau = pin.rnea(model, data, q, v, np.zeros(n)) + d.k * (q - d.target)   # holding
    dq, dv, Minv = pin.computeABADerivatives(model, data, q, v, tau)
    Minv = np.triu(Minv) + np.triu(Minv, 1).T
    A = np.block([[np.zeros((n, n)), np.eye(n)], [dq, dv]])
    B = np.vstack((np.zeros((n, n)), Minv))
    eigenvalues = np.linalg.eigvals(A)
    rank = staircase_rank(A, B)
    np.savetxt(out, np.hstack((A, B)), delimiter=",", fmt="%.17g")
    print(f"{len(eigenvalues)} eigenvalues, controllability rank {rank} of {2 * n}")


if __name__ == "__main__":
    jobs = {"--inverse": (inverse, 4), "--check": (check, 3), "--linearize": (linearize, 3)}
    job, count = jobs.get(sys.argv[1], (None, 0))
    if job is not None:
        job(*sys.argv[2:2 + count])
    else:
        main(*sys.argv[1:4])
