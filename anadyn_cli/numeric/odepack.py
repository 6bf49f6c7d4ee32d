"""ODEPACK's LSODA (scipy's ``odeint``) without importing ``scipy.integrate``.

``import scipy.integrate`` takes about 0.28 s on these machines (it loads
scipy.special, scipy.optimize and more for its other solvers): as long as a
whole warm ``simulate`` of a 12-link chain.  ``odeint`` needs only the
compiled ``_odepack`` extension, which loads alone in ~8 ms.  ``odeint``
below loads that extension by itself and calls it as ``scipy.integrate.odeint``
does (same arguments, same Fortran: the same bits).

That call is SciPy's private interface, with no promise behind it, so it is
used only after a self-check: the first time a SciPy version is met, two small
problems (with and without a Jacobian) are solved by the extension and by the
public ``scipy.integrate.odeint``, and the extension is used only if every
number and counter is the same bit for bit.  The verdict is recorded, sealed,
in the owner-only native cache folder (``cache.native_directory``), one record
per SciPy and Python version, so later runs skip both the check and the import.
Where the extension is not found, does not load, fails the check or refuses
the call, ``scipy.integrate.odeint`` runs: slower to import, never wrong.
"""
from __future__ import annotations

import functools
import importlib.machinery
import importlib.util
import sys
from pathlib import Path

import numpy as np

from . import cache

#: ODEPACK's return code for a successful run, and scipy's message for it
SUCCESS, SUCCESS_MESSAGE = 2, "Integration successful."
NAME = "scipy.integrate._odepack"


@functools.lru_cache(maxsize=1)
def extension():
    """The ``_odepack`` extension, loaded alone, if it passed the self-check
    (``same_as_scipy``, recorded per SciPy version); None: use the public call."""
    module = _load()
    if module is None:
        return None
    import scipy

    name = f"scipy-odepack-{scipy.__version__}-{sys.implementation.cache_tag}.json"
    place = _record_folder()
    record = cache.read_record(place, name, "SciPy self-check record") if place else None
    if isinstance(record, dict) and isinstance(record.get("same"), bool):
        same = record["same"]
    else:
        same = same_as_scipy(module)
        if place is not None:
            try:
                cache.write_record(place, name, {"same": same, "scipy": scipy.__version__})
            except OSError:
                pass
    return module if same else None


def _record_folder():
    """The native cache folder for the self-check's record; None when it cannot be
    used (an untrusted folder is refused by the derivation cache, not here)."""
    try:
        return cache.trusted_folder(cache.native_directory(), create=True)
    except cache.UntrustedCache:
        return None


def _load():
    """The ``_odepack`` extension module, loaded alone; None if it cannot be."""
    if NAME in sys.modules:
        return sys.modules[NAME]
    try:
        import scipy
        folder = Path(scipy.__file__).parent / "integrate"
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            path = folder / f"_odepack{suffix}"
            if path.exists():
                loader = importlib.machinery.ExtensionFileLoader(NAME, str(path))
                spec = importlib.util.spec_from_file_location(NAME, path, loader=loader)
                module = importlib.util.module_from_spec(spec)
                loader.exec_module(module)
                return module if callable(getattr(module, "odeint", None)) else None
    except (ImportError, OSError):
        return None
    return None


def _van_der_pol(t, x):
    return [x[1], 5.0 * (1 - x[0] ** 2) * x[1] - x[0]]


def _van_der_pol_jacobian(t, x):
    return [[0.0, 1.0], [-10.0 * x[0] * x[1] - 1, 5.0 * (1 - x[0] ** 2)]]


def same_as_scipy(module) -> bool:
    """Whether ``module``'s odeint gives the bits of ``scipy.integrate.odeint``:
    the solution and every counter of a van der Pol oscillator (mu = 5) over
    [0, 3], with the Jacobian and a tcrit, and without."""
    from scipy.integrate import odeint as scipy_odeint

    grid = np.linspace(0.0, 3.0, 7)
    try:
        for jacobian, tcrit in ((_van_der_pol_jacobian, [3.0]), (None, None)):
            x, info, code = _call(module, _van_der_pol, [2.0, 0.0], grid, jacobian, 1e-9,
                                  1e-11, 5000, tcrit, True)
            x_ref, info_ref = scipy_odeint(_van_der_pol, [2.0, 0.0], grid, Dfun=jacobian,
                                           rtol=1e-9, atol=1e-11, mxstep=5000, tcrit=tcrit,
                                           tfirst=True, full_output=True)
            if code != SUCCESS or not np.array_equal(x, x_ref) or any(
                    not np.array_equal(info[k], info_ref[k])
                    for k in ("nst", "nfe", "nje", "tcur", "hu", "nqu", "mused")):
                return False
    except Exception:           # noqa: BLE001  any failure of the private call: not the same
        return False
    return True


def _call(module, func, y0, t, jacobian, rtol, atol, mxstep, tcrit, tfirst):
    """(x, info, code) of the extension's odeint, called as scipy.integrate.odeint does."""
    return module.odeint(func, np.array(y0, dtype=float), np.array(t, dtype=float), (),
                         jacobian, 0, -1, -1, 1, rtol, atol, tcrit, 0.0, 0.0, 0.0, 0, mxstep,
                         0, 12, 5, int(bool(tfirst)))


def odeint(func, y0, t, jacobian=None, rtol: float = 1e-10, atol: float = 1e-12,
           mxstep: int = 0, tcrit=None, tfirst: bool = False):
    """(x, info) as ``scipy.integrate.odeint(..., full_output=True)`` returns them."""
    module = extension()
    if module is not None:
        try:
            x, info, code = _call(module, func, y0, t, jacobian, rtol, atol, mxstep, tcrit,
                                  tfirst)
        except TypeError:               # another signature: SciPy's own wrapper below
            pass
        else:
            info["message"] = SUCCESS_MESSAGE if code == SUCCESS else _message(code)
            return x, info
    from scipy.integrate import odeint as scipy_odeint
    return scipy_odeint(func, y0, t, Dfun=jacobian, rtol=rtol, atol=atol, full_output=True,
                        mxstep=mxstep, tcrit=tcrit, tfirst=tfirst)


def _message(code: int) -> str:
    """SciPy's words for a failed run (imported only then)."""
    try:
        from scipy.integrate._odepack_py import _msgs
    except ImportError:
        _msgs = {}
    return _msgs.get(code, f"ODEPACK stopped with code {code}.")
