"""The generic kernel: the recursions compiled once per installation, reading a
robot as numbers (``tables``), so that a cold run starts at once.

``kernel.c`` (read with importlib.resources) runs the articulated-body
algorithm (forward dynamics, O(n)), the recursive Newton-Euler algorithm
(inverse dynamics M ddq - F, with the joint springs, dampers and friction) and
the composite-rigid-body algorithm (M) over the tables of ``tables.pack``, for
revolute, prismatic, fixed and spherical joints (so floating bases: the state
x = [q, u], a quaternion's rates dq = 1/2 q (x) (0, w) in the kernel).  It
is compiled like the robot-specific code (``native.load``, the cache's
``-native`` folder, hashed, owner-only), once: its C text does not depend on
the robot.

``first_run`` serves a cold run (cache miss) with a ``GenericModel`` while the
robot-specific code is generated, stored in the derivation cache and compiled
in a forked process at the lowest priority, for the next run (one such build
per robot at a time, its cost reported by the next run, a failure said once
and not retried: ``background``).  It stores what the model is made of beside
the cache entry (``RECORD``): ``recorded`` serves the runs that come before the
build ends from it, without reading the robot again.  Only when
native code is on in its default mode (``ANADYN_NATIVE`` unset), and
``ANADYN_GENERIC`` is not 0, on POSIX (fork), for robots the tables can hold.
A ``GenericModel`` computes rhs, accelerations, driven accelerations, the
inverse dynamics (``demand``) and M F B with the kernel, the control laws with
a small generated Python function, and the Jacobian of the state derivative
(``GenericModel.jacobian``: the kernel's exact, forward-mode derivative of the
Newton-Euler recursion at fixed efforts, the control laws' derivatives by central
differences), and ``check``'s integrands with the kernel's ``energies``
(``Energies``: T, V and the power joint damping and friction dissipate, from the
kinematics); anything else (a free robot's momentum) comes from the generated
Python of the full recursive path, built in this process when first asked for.
The kernel's numbers agree with the generated code to rounding (~1e-13 relative,
a different order of operations), not to the bit.
"""
from __future__ import annotations

import os
import sys
from importlib import resources
from typing import NamedTuple

import numpy as np

from .differences import central_differences
from .energies import Energies
from .tables import Tables, pack
from ..model import NumericModel, PrescribedMotion, run_generated
from ...model.info import RobotInfo

__all__ = ["Energies", "GenericModel", "Layout", "RECORD", "Record", "Tables", "enabled",
           "first_run", "keep", "kernel", "pack", "read", "recorded"]


def c_text() -> str:
    """The kernel's C file (module name and init function left as placeholders)."""
    return resources.files(__package__).joinpath("kernel.c").read_text(encoding="utf-8")


def enabled() -> bool:
    """ANADYN_GENERIC not 0 and native code in its default mode (``native.mode``)."""
    from .. import native

    value = os.environ.get("ANADYN_GENERIC", "1").strip().lower()
    return value not in ("0", "off", "no") and native.mode() == "auto"


_KERNEL: list = []


def kernel(timings: dict | None = None):
    """The compiled kernel module (built now the first time ever: once per
    installation and cache folder, the compile's time in ``timings``), or None
    when native code cannot be built."""
    if not _KERNEL:
        from .. import native

        module, _ = native.load(c_text(), timings, how="wait")
        _KERNEL.append(module)
    return _KERNEL[0]


class Layout(NamedTuple):
    """What a GenericModel reads of the plan: the names of the coordinates, speeds
    and efforts, and the coordinate indices of each spherical joint's quaternion."""
    coordinates: tuple[str, ...]
    speeds: tuple[str, ...]
    efforts: tuple[str, ...]
    quaternions: tuple[tuple[int, ...], ...]

    @classmethod
    def of(cls, pl) -> "Layout":
        from ..recursive.emit import quaternions

        return cls(tuple(pl.coordinates), tuple(pl.speeds), tuple(pl.efforts), quaternions(pl))


def _call(code: int) -> None:
    if code == 1:
        raise np.linalg.LinAlgError("mass matrix not positive definite")


class GenericModel(NumericModel):
    """A ``NumericModel`` computed by the generic kernel (module docstring);
    ``full()`` builds the generated Python for what the kernel does not do."""

    def __init__(self, info, layout: Layout, tables: Tables, module, small_source: str, full):
        namespace = run_generated(small_source)
        self.info, self.source = info, small_source
        self.evaluator, self.formulation = "recursive", None
        self.coordinates, self.effort_names = layout.coordinates, layout.efforts
        self.speeds, self.quaternions = layout.speeds, layout.quaternions
        self.n, self.nq = len(self.speeds), len(self.coordinates)   # x = [q (nq), u (n)]
        self._rates = namespace.get("rates")          # dq = W(q) u, with a spherical joint
        # ``pack`` refuses contacts
        self.contact_names, self.contact_laws, self.rigid_contacts = (), (), None
        self._kernel, self._make_full, self._full = module, full, None
        self._ints, self._doubles = tables.ints, tables.doubles
        self._laws = namespace["laws"] if self.effort_names and not namespace["NO_LAWS"] else None
        self._efforts = namespace["efforts"]
        self._motion = (PrescribedMotion(*namespace["TRAJECTORY"], namespace["motion"])
                        if "TRAJECTORY" in namespace else None)
        self._motion_error = namespace.get("MOTION_ERROR")
        self._jacobian = self.jacobian
        self._select = tables.effort_map()                        # efforts -> joint forces
        self._B = tables.A.T @ self._select                       # constant: theta affine
        self._B.setflags(write=False)
        self.integrands = Energies(tables, module)        # check's T, V and P_d
        self._zero = np.zeros(tables.A.shape[0])
        self.native_note = "generic kernel"      # first_run adds what becomes of the robot's code

    def full(self) -> NumericModel:
        """The generated Python of the recursive path (built on first use)."""
        if self._full is None:
            self._full = self._make_full()
        return self._full

    def __getattr__(self, name):          # only for what this class does not set
        if name.startswith("__") or name in ("_full", "_make_full"):
            raise AttributeError(name)
        return getattr(self.full(), name)

    def _joint_efforts(self, t: float, x) -> np.ndarray:
        if self._laws is None:
            return self._zero
        return self._select @ np.asarray(self._laws(t, *x.tolist()), dtype=float)

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=float)
        out = np.empty(self.nq + self.n)
        _call(self._kernel.rhs(self._ints, self._doubles, x, self._joint_efforts(t, x), out))
        return out

    def accelerations(self, t: float, x) -> list[float]:
        return self.rhs(t, np.asarray(x, dtype=float))[self.nq:].tolist()

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        """[[R], [M^-1 K]]: the kernel's (R = d(W(q) u)/dx, [0, I] without a
        spherical joint; K = -dID/dx at fixed efforts, exact: the Newton-Euler
        recursion differentiated in forward mode), plus M^-1 B d(tau)/dx with the
        laws' derivatives by ``central_differences``."""
        n, nq, n2 = self.n, self.nq, self.nq + self.n
        x = np.ascontiguousarray(x, dtype=float)
        J = np.empty((n2, n2))
        _call(self._kernel.jac(self._ints, self._doubles, x, self._joint_efforts(t, x), J))
        if self._laws is not None:
            dtau = central_differences(lambda y: self._laws(t, *y.tolist()), x)
            M = np.empty((n, n))
            _call(self._kernel.mass(self._ints, self._doubles, np.ascontiguousarray(x[:nq]), M))
            J[nq:] += np.linalg.solve(M, self._B @ dtau)
        return J

    def driven_accelerations(self, t: float, x: np.ndarray, efforts) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=float)
        out = np.empty(self.nq + self.n)
        _call(self._kernel.rhs(self._ints, self._doubles, x,
                               self._select @ np.asarray(efforts, dtype=float), out))
        return out[self.nq:]

    def actuation(self, t, q, dq) -> np.ndarray:
        return self._B

    @property
    def has_forces(self) -> bool:
        """Joint damping or friction, or (without a spherical joint) springs: the robots
        whose generated code has ``powers`` (the tables hold no loads)."""
        passive = self.integrands.passive
        return bool(passive[:, :2].any() or (not self.quaternions and passive[:, 3].any()))

    def momentum(self, t, q, u):
        return self.full().momentum(t, q, u) if self.quaternions else None

    def conserved(self):
        """None for a robot that is not free (a free one has a spherical joint: its
        generated code answers)."""
        return self.full().conserved() if self.quaternions else None

    def _inverse_points(self, q, dq, ddq) -> tuple[np.ndarray, tuple]:
        """M ddq - F (no actuators) over broadcast arrays q (nq, ...), dq and ddq
        (n, ...) -> (..., n)."""
        n, ns = self.n, self.nq + self.n
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (*q, *dq, *ddq)))
        shape = arrays[0].shape
        columns = np.stack([a.reshape(-1) for a in arrays], axis=1)
        count = len(columns)
        out = np.empty((count, n))
        _call(self._kernel.inverse(self._ints, self._doubles, count,
                                   np.ascontiguousarray(columns[:, :ns]),
                                   np.ascontiguousarray(columns[:, ns:]), out))
        return out, shape

    def demand(self, t, q, dq, ddq) -> tuple[np.ndarray, np.ndarray]:
        out, shape = self._inverse_points(q, dq, ddq)
        return out.reshape(shape + (self.n,)), self._B

    def mfb(self, t, q, dq):
        n = self.n
        zeros = np.zeros((n,) + np.broadcast_shapes(np.shape(q[0]), np.shape(dq[0])))
        out, shape = self._inverse_points(q, dq, zeros)
        qs = np.stack([np.broadcast_to(np.asarray(v, dtype=float), shape).reshape(-1) for v in q],
                      axis=1)
        M = np.empty((len(qs), n, n))
        for k, row in enumerate(qs):
            _call(self._kernel.mass(self._ints, self._doubles, np.ascontiguousarray(row), M[k]))
        B = np.broadcast_to(self._B, shape + self._B.shape)
        return M.reshape(shape + (n, n)), -out.reshape(shape + (n,)), B


def small_source(pl, robot) -> str:
    """The laws (scalar) and efforts (vectorized) of ``pl``, with a spherical joint
    the coordinates' rates dq = W(q) u (vectorized), and the prescribed motion: the
    generated Python a GenericModel needs."""
    from .. import trajectory
    from ..recursive import PY_HEADER, _python_function
    from ..recursive.emit import VEC_HEADER
    from ..recursive.trace import Traced, trace_efforts, trace_rates

    efforts = trace_efforts(pl)
    laws = Traced("laws", efforts.args, efforts.statements, efforts.outputs, efforts.counts)
    vector = "\n".join(_python_function(efforts, True, "Efforts under the control laws."))
    for name in ("sin", "cos", "sqrt", "tanh"):
        vector = vector.replace(f"_{name}(", f"_v{name}(")
    no_laws = all(x.is_zero() for x in efforts.outputs["tau"])
    rates = (_python_function(trace_rates(pl), True, "dq = W(q) u.") if pl.spherical else [])
    return "\n".join([PY_HEADER, VEC_HEADER,
                      *_python_function(laws, False, "Efforts under the control laws."),
                      vector, *rates, f"NO_LAWS = {no_laws}", ""]) + trajectory.motion_source(robot)


def first_run(robot, pl, info, full, own_code, entry: str,
              timings: dict | None = None) -> GenericModel | None:
    """A GenericModel for a cold run of ``robot`` (its plan ``pl``), starting
    ``own_code()`` (the robot's own code, generated, compiled and stored under the
    cache entry ``entry``) in a forked process unless it is being built or failed
    (``background.start``); None when the kernel cannot serve (``enabled``, no
    fork, no kernel, or tables that cannot hold the robot): the caller goes on as
    before.  What the model is made of is stored beside the entry (``Record``),
    for the runs that come before the robot's own code (``recorded``).
    ``timings``: the kernel's compile, the first time ever."""
    if not _can_serve():
        return None
    tables, _ = pack(pl)
    if tables is None:
        return None
    module = kernel(timings)
    if module is None:
        return None
    record = Record.of(robot, pl, info, tables)
    keep(entry, record)
    return _served(GenericModel(info, record.layout, tables, module, record.small, full),
                   entry, own_code)


def stored_energies(stored) -> Energies | None:
    """``check``'s integrands (``Energies``, the kernel loaded when first asked for)
    for a warm run, from the tables stored with the robot's cache entry
    (``Tables.to_dict``); None when there are none, they are damaged, or the kernel
    is off (``enabled``)."""
    if stored is None or not enabled():
        return None
    try:
        return Energies(Tables.from_dict(stored))
    except (KeyError, TypeError, ValueError):
        return None


#: beside the derivation cache entry KEY.json: KEY.kernel, sealed, a ``Record``
RECORD = ".kernel"


class Record(NamedTuple):
    """What a cold run's GenericModel is made of, kept beside the robot's cache entry
    (``RECORD``) so that later runs are served without reading the robot: its info,
    layout, tables and small source (``small_source``), and the names of its
    parameters (None in a record written before they were kept)."""
    info: RobotInfo
    layout: Layout
    tables: Tables
    small: str
    parameters: tuple[str, ...] | None

    @classmethod
    def of(cls, robot, pl, info, tables: Tables) -> "Record":
        """The record of ``robot`` (validated), its plan ``pl``, info and tables."""
        return cls(info, Layout.of(pl), tables, small_source(pl, robot), tuple(robot.parameters))

    def to_dict(self) -> dict:
        return {"robot": self.info.to_dict(), "layout": self.layout._asdict(),
                "small": self.small, "tables": self.tables.to_dict(),
                "parameters": None if self.parameters is None else list(self.parameters)}

    @classmethod
    def from_dict(cls, data: dict, source: str) -> "Record":
        """The stored record of the robot read from ``source`` (its display name);
        KeyError, TypeError or ValueError when it is damaged."""
        layout = data["layout"]
        layout = Layout(*(tuple(str(k) for k in layout[key])
                          for key in ("coordinates", "speeds", "efforts")),
                        tuple(tuple(int(i) for i in q) for q in layout["quaternions"]))
        parameters = data.get("parameters")
        if not isinstance(data["small"], str):
            raise TypeError("small source")
        return cls(RobotInfo.from_dict(data["robot"], source), layout,
                   Tables.from_dict(data["tables"]), data["small"],
                   None if parameters is None else tuple(str(p) for p in parameters))


def read(entry: str, source: str) -> Record | None:
    """The ``Record`` beside the cache entry ``entry`` of the robot read from
    ``source``; None when there is none, or it is damaged (``cache.read_record``
    warns of a damaged or foreign file)."""
    from .. import cache

    folder = cache.trusted_folder(cache.directory(), create=False)
    data = None if folder is None else cache.read_record(folder, entry + RECORD,
                                                         "first-run record")
    if not isinstance(data, dict):
        return None
    try:
        return Record.from_dict(data, source)
    except Exception:           # noqa: BLE001  anything wrong with a stored record is a miss
        return None


def keep(entry: str, record: Record) -> None:
    """Store ``record`` beside the cache entry ``entry`` (nothing when the cache
    folder cannot be written)."""
    from .. import cache

    folder = cache.trusted_folder(cache.directory(), create=True)
    if folder is not None:
        try:
            cache.write_record(folder, entry + RECORD, record.to_dict())
        except OSError:
            pass


def _can_serve() -> bool:
    return enabled() and hasattr(os, "fork")


def _served(model: GenericModel, entry: str, own_code) -> GenericModel:
    """``model``, the robot's own code started (``background.start``) and said in its note."""
    from .. import background

    model.native_note = (f"generic kernel (the robot's own code "
                         f"{background.start(entry, own_code, _fork)})")
    return model


def recorded(entry: str, source: str, full, own_code) -> GenericModel | None:
    """The GenericModel of an earlier cold run of the robot whose derivation cache
    entry is ``entry`` (its ``Record``; ``source``: the robot's display name), with
    no robot read: a run that comes while the robot's own code is being built (or
    after it failed) is served as the first was, from the same numbers.  As in
    ``first_run``, ``own_code()`` is started unless it is being built or failed,
    ``full()`` builds the generated Python for what the kernel does not do.  None
    when there is no such record (or it is damaged, or the kernel cannot serve)."""
    if not _can_serve():
        return None
    record = read(entry, source)
    module = None if record is None else kernel()
    if module is None:
        return None
    try:
        model = GenericModel(record.info, record.layout, record.tables, module, record.small,
                             full)
    except Exception:           # noqa: BLE001  anything wrong with a stored record is a miss
        return None
    return _served(model, entry, own_code)


def _fork(work) -> None:
    """Run ``work()`` in a detached grandchild at the lowest priority, its output
    discarded; this process waits only for the short-lived child."""
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid:
        os.waitpid(pid, 0)
        return
    try:                                          # the child: detach, fork, leave
        os.setsid()
        if os.fork():
            os._exit(0)
        os.nice(19)
        null = os.open(os.devnull, os.O_RDWR)
        for fd in (0, 1, 2):
            os.dup2(null, fd)
        work()
    finally:
        os._exit(0)
