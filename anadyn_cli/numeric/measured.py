"""A measured motion: q(t) sampled in a CSV file, with rates and accelerations.

The file has a header row and the columns of ``inverse.csv``: ``t`` (s), each
coordinate by its name, optionally every rate ``d<name>`` and every
acceleration ``dd<name>``; other columns are ignored (efforts, say, which
identification reads with ``read_table``).  Times must increase; every value
must be a finite number.

Rates and accelerations the file does not give come from a Savitzky-Golay
differentiator (``Differentiator``): at each sample, the least-squares
polynomial of degree ``order`` through the ``window`` samples centred on it
(the first and last window at the ends), differentiated at that sample.  On
uniformly sampled times (steps equal to 1e-6 relative) this is
``scipy.signal.savgol_filter(deriv=1, 2, mode="interp")``; otherwise the same
local fit in the samples' own times.  Positions are used as measured.  The
filter is centred, so it has no lag; at interior samples it scales the
derivatives of a sinusoid of frequency f by 1 + ``bias(f, step, window, order,
deriv)``, a real factor computed exactly from the filter's coefficients, and
independent noise of standard deviation sigma on q reaches the derivatives
multiplied by ``noise_gain``.

``MeasuredMotion(t)`` gives q, dq, ddq at any time between the first and last
sample: the piecewise quintic through the samples with those values as its
value, first and second derivative (``scipy.interpolate.BPoly``), so it is
exact at the samples and its own derivatives are its rates and accelerations.

A robot with spherical (or floating) joints has speeds that are not rates
(``SpeedMap``): each joint's unit quaternion (qw, qx, qy, qz) is four columns
of coordinates, its speeds are the body's angular velocity w (body axes) and
the rate and acceleration columns are the speeds' (``wx``) and their
derivatives' (``dwx``).  Quaternion rows are made unit (a warning when one is
off by more than ``ROUNDING``, an error beyond ``NORM_TOLERANCE``) and their
signs made continuous (q and -q are one attitude); missing speeds come from
the differentiated quaternion, w = 2 vec(conj(q) (x) dq).
"""
from __future__ import annotations

import csv
import io
import math
import warnings
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..errors import ModelError, SettingError

DEFAULT_WINDOW = 21          # samples of the differentiator's local fit
DEFAULT_ORDER = 3            # its polynomial degree
UNIFORM = 1e-6               # largest relative spread of the time steps treated as uniform
CHUNK = 4096                 # samples per batch of the non-uniform local fits
ROUNDING = 1e-6              # | |q| - 1 | of a measured quaternion made unit silently
NORM_TOLERANCE = 1e-2        # ... made unit with a warning up to this, refused beyond


@dataclass(frozen=True)
class Differentiator:
    """Savitzky-Golay: ``window`` (odd, > ``order``) samples, polynomial degree ``order``."""
    window: int = DEFAULT_WINDOW
    order: int = DEFAULT_ORDER

    def __post_init__(self):
        if isinstance(self.order, bool) or not isinstance(self.order, int) or not (
                2 <= self.order <= 10):
            raise SettingError("smoothing_order", "must be a whole number from 2 to 10 "
                                                  "(accelerations need degree 2 or more), "
                                                  f"got {self.order!r}")
        if isinstance(self.window, bool) or not isinstance(self.window, int) or (
                self.window % 2 == 0 or self.window <= self.order):
            raise SettingError("smoothing_window", "must be an odd whole number of samples "
                                                   f"greater than the order {self.order}, "
                                                   f"got {self.window!r}")

    @classmethod
    def given(cls, window: int | None, order: int | None) -> "Differentiator":
        """The filter with ``window`` and ``order`` where given, the defaults elsewhere."""
        return cls(DEFAULT_WINDOW if window is None else window,
                   DEFAULT_ORDER if order is None else order)

    def describe(self) -> str:
        return f"Savitzky-Golay, {self.window} samples, degree {self.order}"

    def derivatives(self, t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(dy/dt, d2y/dt2) of the samples y (N, ...) at times t (N,), increasing."""
        steps = np.diff(t)
        h = float(steps.mean())
        if np.ptp(steps) <= UNIFORM * h:
            from scipy.signal import savgol_filter

            return tuple(savgol_filter(y, self.window, self.order, deriv=d, delta=h, axis=0,
                                       mode="interp") for d in (1, 2))
        return local_fit(t, y, self.window, self.order)


def local_fit(t: np.ndarray, y: np.ndarray, window: int, order: int):
    """(dy/dt, d2y/dt2) at every sample by the least-squares polynomial of degree
    ``order`` in (t - t_k) through the ``window`` samples centred on sample k (the
    first or last ``window`` samples near the ends): Savitzky-Golay in the samples'
    own times."""
    N, half = len(t), window // 2
    first = np.clip(np.arange(N) - half, 0, N - window)
    shape = y.shape[1:]
    flat = y.reshape(N, -1)
    out = np.empty((2, N, flat.shape[1]))
    powers = np.arange(order + 1)
    for begin in range(0, N, CHUNK):
        rows = np.arange(begin, min(N, begin + CHUNK))
        index = first[rows, None] + np.arange(window)            # (rows, window)
        scale = t[index[:, -1]] - t[index[:, 0]]                 # for conditioning
        s = (t[index] - t[rows, None]) / scale[:, None]
        A = s[..., None] ** powers                               # (rows, window, order+1)
        coefficients = np.linalg.pinv(A) @ flat[index]           # (rows, order+1, columns)
        out[0, rows] = coefficients[:, 1] / scale[:, None]
        out[1, rows] = 2 * coefficients[:, 2] / scale[:, None] ** 2
    return out[0].reshape((N, *shape)), out[1].reshape((N, *shape))


def bias(frequency, step: float, window: int = DEFAULT_WINDOW, order: int = DEFAULT_ORDER,
         deriv: int = 1):
    """The relative error of the interior Savitzky-Golay derivative of order ``deriv``
    of a sinusoid of ``frequency`` (Hz, scalar or array) sampled every ``step`` s:
    the estimate is (1 + bias) times the exact derivative, bias real (the filter is
    symmetric, so there is no lag).  From the filter's coefficients c_j
    (``scipy.signal.savgol_coeffs``), which reproduce polynomials of degree
    <= ``order`` exactly: bias = sum_j c_j r(z_j) / (i w)^deriv with z_j = i w x_j,
    x_j = (j - window // 2) step, and r(z) = e^z minus its Taylor polynomial of degree
    ``order`` (summed as a series where |z| <= 2, so that small biases are not lost to
    rounding)."""
    from scipy.signal import savgol_coeffs

    omega = 2 * np.pi * np.asarray(frequency, dtype=float)
    c = savgol_coeffs(window, order, deriv=deriv, delta=step, use="dot")
    z = 1j * np.multiply.outer(omega, (np.arange(window) - window // 2) * step)
    term = z ** (order + 1) / math.factorial(order + 1)
    series = term.copy()
    for m in range(order + 2, order + 40):
        term = term * z / m
        series = series + term
    direct = np.exp(z) - sum(z ** m / math.factorial(m) for m in range(order + 1))
    remainder = np.where(np.abs(z) <= 2, series, direct)
    return ((remainder @ c) / (1j * omega) ** deriv).real


def noise_gain(step: float, window: int = DEFAULT_WINDOW, order: int = DEFAULT_ORDER,
               deriv: int = 1) -> float:
    """Standard deviation of the interior derivative estimate per unit standard
    deviation of independent noise on the samples: |coefficients|_2."""
    from scipy.signal import savgol_coeffs

    return float(np.linalg.norm(savgol_coeffs(window, order, deriv=deriv, delta=step)))


def product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product a (x) b of quaternions (w, x, y, z) along the last axis."""
    aw, av, bw, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, -1, keepdims=True),
                           aw * bv + bw * av + np.cross(av, bv)], -1)


def conjugate(a: np.ndarray) -> np.ndarray:
    return a * np.array([1.0, -1.0, -1.0, -1.0])


@dataclass(frozen=True)
class SpeedMap:
    """Coordinates' rates <-> speeds of a robot with spherical joints.

    ``quaternions``: each spherical joint's coordinate indices (qw, qx, qy, qz), as the
    numeric model's ``quaternions``.  The other coordinates keep their order and have
    their rates as speeds; the quaternions' speeds follow, three each (the body's angular
    velocity w in body axes), in the same order.  With dq = 1/2 q (x) (0, w):

        w  = 2 vec(conj(q) (x) dq) / |q|^2
        dw = 2 vec(conj(q) (x) ddq) / |q|^2 - 2 w (q . dq) / |q|^2

    exact for a quaternion of any norm (its direction is the attitude), and back

        dq = 1/2 q (x) (0, w),   ddq = 1/2 (dq (x) (0, w) + q (x) (0, dw)).
    """
    nq: int
    quaternions: tuple

    @property
    def plain(self) -> list[int]:
        """The coordinates that are not a quaternion's: their speeds are their rates."""
        taken = {i for group in self.quaternions for i in group}
        return [i for i in range(self.nq) if i not in taken]

    @property
    def n(self) -> int:
        return self.nq - len(self.quaternions)

    def angular(self, j: int) -> slice:
        """The speeds of quaternion ``j``: its angular velocity's three."""
        first = len(self.plain) + 3 * j
        return slice(first, first + 3)

    def speeds(self, q, dq, ddq) -> tuple[np.ndarray, np.ndarray]:
        """(u, du) (..., n) from the coordinates, their rates and accelerations (..., nq)."""
        q, dq, ddq = (np.asarray(v, dtype=float) for v in (q, dq, ddq))
        shape = q.shape[:-1] + (self.n,)
        u, du = np.empty(shape), np.empty(shape)
        plain = self.plain
        u[..., :len(plain)], du[..., :len(plain)] = dq[..., plain], ddq[..., plain]
        for j, group in enumerate(self.quaternions):
            a, da, dda = (v[..., list(group)] for v in (q, dq, ddq))
            square = np.sum(a * a, -1, keepdims=True)
            w = 2 * product(conjugate(a), da)[..., 1:] / square
            u[..., self.angular(j)] = w
            du[..., self.angular(j)] = (2 * product(conjugate(a), dda)[..., 1:]
                                        - 2 * w * np.sum(a * da, -1, keepdims=True)) / square
        return u, du

    def rates(self, q, u, du) -> tuple[np.ndarray, np.ndarray]:
        """(dq, ddq) (..., nq) from the coordinates (..., nq) and the speeds (..., n)."""
        q, u, du = (np.asarray(v, dtype=float) for v in (q, u, du))
        dq, ddq = np.empty_like(q), np.empty_like(q)
        plain = self.plain
        dq[..., plain], ddq[..., plain] = u[..., :len(plain)], du[..., :len(plain)]
        for j, group in enumerate(self.quaternions):
            a = q[..., list(group)]
            w, dw = (np.concatenate([np.zeros(v.shape[:-1] + (1,)), v[..., self.angular(j)]],
                                    -1) for v in (u, du))
            da = product(a, w) / 2
            dq[..., list(group)] = da
            ddq[..., list(group)] = (product(da, w) + product(a, dw)) / 2
        return dq, ddq

    def unit(self, q: np.ndarray) -> np.ndarray:
        """``q`` with every quaternion divided by its norm."""
        q = np.array(q, dtype=float)
        for group in self.quaternions:
            q[..., list(group)] /= np.linalg.norm(q[..., list(group)], axis=-1, keepdims=True)
        return q

    def deviations(self, q: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """(..., nq - 3 k): |q_i - reference_i| for the other coordinates, then for every
        quaternion the angle of the turn between the two attitudes, 2 asin |vec(conj(r)
        (x) q)| (both made unit; rad)."""
        plain = self.plain
        out = [np.abs(q[..., plain] - reference[..., plain])]
        a, b = self.unit(q), self.unit(reference)
        for group in self.quaternions:
            turn = product(conjugate(b[..., list(group)]), a[..., list(group)])[..., 1:]
            out.append(2 * np.arcsin(np.minimum(np.linalg.norm(turn, axis=-1), 1.0))[..., None])
        return np.concatenate(out, -1)


@dataclass(frozen=True, eq=False)
class Table:
    """Columns of a measured CSV, by name (the ones asked for), and the file's name."""
    source: str
    columns: dict

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns


def read_table(path, required, optional=(), note: str = "") -> Table:
    """The columns ``required`` (``t`` first: s, increasing) and those of ``optional``
    the file has, from a CSV file with a header row; every one of their values a
    finite number.  Other columns are not read.  ModelError naming the file, line
    and column, and what is allowed (``note`` added to the expected columns),
    otherwise."""
    source = str(path)
    if not Path(path).is_file():
        raise ModelError(f"no such file (expected a CSV with columns {', '.join(required)})",
                         source=source)
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            text = handle.read()
        fast = _numbers(text)
        rows = _numbered(text) if fast is None else [fast[0]]
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise ModelError(f"cannot read it as CSV text ({getattr(err, 'strerror', None) or err})",
                         source=source) from None
    if not rows:
        raise ModelError(f"is empty: expected a header row ({', '.join(required)}) and one "
                         "row of numbers per sample", source=source)
    line, header = rows[0][0], [name.strip() for name in rows[0][1]]
    missing = [name for name in required if name not in header]
    if missing:
        raise ModelError(f"no column {', '.join(missing)}: expected {', '.join(required)}"
                         f"{note}, found {', '.join(header) or 'an empty header'}",
                         source=source, line=line)
    wanted = [name for name in (*required, *optional) if name in header]
    for name in wanted:
        if header.count(name) > 1:
            raise ModelError(f"column {name} appears {header.count(name)} times; give it "
                             "once", source=source, line=line)
    index = [header.index(name) for name in wanted]
    if fast is not None and fast[1].shape[1] == len(header):    # every value a finite number
        values = fast[1][:, index]
    else:                       # value by value, to say where and what
        values = _values(_numbered(text)[1:], header, index, source)
    table = Table(source, dict(zip(wanted, values.T)))
    t = table["t"]
    back = np.flatnonzero(np.diff(t) <= 0)
    if len(back):
        k = int(back[0]) + 1
        raise ModelError(f"times must increase, got {t[k]:g} after {t[k - 1]:g}",
                         source=source, line=_numbered(text)[k + 1][0], path="column t")
    return table


def _numbered(text: str) -> list[tuple[int, list[str]]]:
    """The CSV rows of ``text`` that are not blank, with their line numbers."""
    return [(number, row) for number, row in enumerate(csv.reader(io.StringIO(text)), 1)
            if any(f.strip() for f in row)]


def _numbers(text: str) -> tuple[tuple[int, list[str]], np.ndarray] | None:
    """((line, the header row), the table below it) when every line below the first
    that is not blank is numbers separated by commas, as many on each and every one
    finite (read at once by NumPy, each text as float() reads it); None otherwise,
    and for a table without rows (``read_table`` then reads the rows one by one, to
    say where and what is wrong)."""
    reader = csv.reader(io.StringIO(text))
    header = next((row for row in reader if any(f.strip() for f in row)), None)
    if header is None:
        return None
    line = reader.line_num
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")           # no rows: said below
            table = np.loadtxt(io.StringIO(text), delimiter=",", comments=None, ndmin=2,
                               skiprows=line, dtype=float, quotechar='"')
    except ValueError:
        return None
    if table.size == 0 or not np.isfinite(table).all():
        return None
    return (line, header), table


def _values(body, header, index, source: str) -> np.ndarray:
    """The columns ``index`` of the numbered rows ``body``, each a finite number;
    ModelError naming the first row or value that is not."""
    values = np.empty((len(body), len(index)))
    for k, (number, row) in enumerate(body):
        if len(row) != len(header):
            raise ModelError(f"{len(row)} values, the header has {len(header)} columns",
                             source=source, line=number)
        for j, column in enumerate(index):
            text = row[column].strip()
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise ModelError(f"must be a finite number, got {text!r}", source=source,
                                 line=number, path=f"column {header[column]}")
            values[k, j] = value
    return values


@dataclass(frozen=True, eq=False)
class MeasuredMotion:
    """q (N, nq), and the speeds dq and their derivatives ddq (N, n), at the measured
    samples, and between them.

    ``given``: which of "dq", "ddq" the file gave; the others come from
    ``differentiator``.  ``speed_map``: with spherical joints, how the speeds are
    made from the coordinates' rates (None: the speeds are the rates)."""
    source: str
    names: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    given: tuple[str, ...]
    differentiator: Differentiator
    kind: str = "measured"
    speed_map: SpeedMap | None = None

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def differentiated(self) -> tuple[str, ...]:
        return tuple(k for k in ("dq", "ddq") if k not in self.given)

    def describe(self) -> str:
        """How the rates and accelerations were obtained, in words."""
        if not self.differentiated:
            return "rates and accelerations as given"
        what = " and ".join({"dq": "rates", "ddq": "accelerations"}[k]
                            for k in self.differentiated)
        return f"{what} by {self.differentiator.describe()}"

    def __call__(self, t):
        """q, dq, ddq at ``t`` (scalar or array, within the samples' times): arrays of
        shape t.shape + (nq or n,), the samples themselves at the sample times (when
        every t is one, they are returned with no spline built: ``samples_near``)."""
        at = np.asarray(t, dtype=float)
        k = np.clip(np.searchsorted(self.t, at), 0, len(self.t) - 1)
        if np.array_equal(self.t[k], at):
            return self.q[k], self.dq[k], self.ddq[k]
        q, dq, ddq = (p(t) for p in self._spline)
        if self.speed_map is None:
            return q, dq, ddq
        return (q, *self.speed_map.speeds(q, dq, ddq))

    def samples_near(self, times) -> np.ndarray:
        """The sample time nearest each of ``times``."""
        k = np.clip(np.searchsorted(self.t, times), 1, len(self.t) - 1)
        before = np.abs(np.asarray(times) - self.t[k - 1]) <= np.abs(self.t[k] - times)
        return self.t[np.where(before, k - 1, k)]

    @cached_property
    def _spline(self):
        """The piecewise quintic with value q, slope dq, curvature ddq at every sample
        (the coordinates' rates and accelerations), and its two derivatives."""
        from scipy.interpolate import BPoly

        dq, ddq = ((self.dq, self.ddq) if self.speed_map is None
                   else self.speed_map.rates(self.q, self.dq, self.ddq))
        spline = BPoly.from_derivatives(self.t, np.stack([self.q, dq, ddq], 1))
        return spline, spline.derivative(), spline.derivative(2)


def read_motion(path, names, differentiator: Differentiator | None = None,
                speeds=None, quaternions: tuple = ()) -> MeasuredMotion:
    """The motion of coordinates ``names`` from a CSV (``read_table``): their columns,
    every speed's column (``speeds``, default ``d<name>``) and its derivative's
    (``d<speed>``) when the file gives all of them, else differentiated by
    ``differentiator`` (default: ``Differentiator()``).  ``quaternions``: each
    spherical joint's coordinate indices (``SpeedMap``); their rows are made unit
    and of continuous sign."""
    differentiator = differentiator or Differentiator()
    names = tuple(names)
    speeds = tuple("d" + n for n in names) if speeds is None else tuple(speeds)
    kinds = {"d": speeds, "dd": tuple("d" + u for u in speeds)}
    note = (" (the robot's coordinates; optionally d<coordinate> and dd<coordinate> for each)"
            if not quaternions else
            f" (the robot's coordinates; optionally the speeds {', '.join(speeds)} and "
            "their derivatives d<speed>)")
    table = read_table(path, ("t", *names), [*kinds["d"], *kinds["dd"]], note)
    t = table["t"]
    columns = {}
    for prefix, wanted in kinds.items():
        present = [name for name in wanted if name in table]
        if present and len(present) != len(wanted):
            absent = [name for name in wanted if name not in present]
            what = (f"{prefix}<coordinate>" if not quaternions
                    else "speed" if prefix == "d" else "d<speed>")
            raise ModelError(f"has {', '.join(present)} but not {', '.join(absent)}: give "
                             f"every {what} column or none", source=table.source)
        if present:
            columns[prefix] = np.stack([table[n] for n in wanted], -1)
    need = 2 if len(columns) == 2 else differentiator.window
    if len(t) < need:
        raise ModelError(f"{len(t)} sample{'s' * (len(t) != 1)}: "
                         + (f"the differentiator ({differentiator.describe()}) "
                            if need > 2 else "a motion ") + f"needs at least {need}",
                         source=table.source)
    q = np.stack([table[n] for n in names], -1)
    speed_map = SpeedMap(len(names), tuple(quaternions)) if quaternions else None
    if speed_map is not None:
        q = _unit_quaternions(table, names, q, speed_map)
    if len(columns) < 2:
        rates, accelerations = differentiator.derivatives(t, q)
        if speed_map is not None:
            rates, accelerations = speed_map.speeds(q, rates, accelerations)
        columns.setdefault("d", rates)
        columns.setdefault("dd", accelerations)
    given = tuple(k for k, prefix in (("dq", "d"), ("ddq", "dd")) if kinds[prefix][0] in table)
    return MeasuredMotion(table.source, names, t, q, columns["d"], columns["dd"], given,
                          differentiator, speed_map=speed_map)


def _unit_quaternions(table: Table, names: tuple, q: np.ndarray, speed_map: SpeedMap
                      ) -> np.ndarray:
    """``q`` with every quaternion row made unit (a warning when one is off by more than
    ROUNDING; ModelError beyond NORM_TOLERANCE) and each row's sign chosen nearest the
    previous row's (q and -q are one attitude; a sign flip would wreck the derivatives)."""
    from ..model.library import announce

    q = q.copy()
    for group in speed_map.quaternions:
        index = list(group)
        norm = np.linalg.norm(q[:, index], axis=1)
        off = np.abs(norm - 1)
        label = f"the quaternion ({', '.join(names[i] for i in index)})"
        for limit in (NORM_TOLERANCE, ROUNDING):         # the first row beyond each
            k = int(np.argmax(off > limit))
            if off[k] <= limit:
                continue
            if limit == NORM_TOLERANCE:
                raise ModelError(f"{label} has norm {norm[k]:.6g} at t = {table['t'][k]:g} s;"
                                 f" it must be a unit quaternion (within {NORM_TOLERANCE:g})",
                                 source=table.source)
            announce(f"{table.source}: {label} has norm {norm[k]:.9g} at t = "
                     f"{table['t'][k]:g} s (off 1 by up to {off.max():.3g}); made unit",
                     warning=True)
        rows = q[:, index] / norm[:, None]
        flips = np.cumsum(np.concatenate([[0], np.sum(rows[1:] * rows[:-1], 1) < 0])) % 2
        q[:, index] = rows * np.where(flips, -1.0, 1.0)[:, None]
    return q
