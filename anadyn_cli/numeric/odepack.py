"""ODEPACK's LSODA (scipy's ``odeint``) without importing ``scipy.integrate``.

``import scipy.integrate`` takes about 0.28 s on these machines (it loads
scipy.special, scipy.optimize and more for its other solvers): as long as a
whole warm ``simulate`` of a 12-link chain.  ``odeint`` needs only the
compiled ``_odepack`` extension, which loads alone in ~8 ms.  ``odeint``
below loads that extension by itself and calls it exactly as
``scipy.integrate.odeint`` does (same arguments, same Fortran: the same
bits; ``tests/test_integrators.py`` compares them).  Where the extension is
not found, does not load, or refuses the call (another SciPy layout), it
falls back to ``scipy.integrate.odeint``: slower to import, never wrong.
"""
from __future__ import annotations

import functools
import importlib.machinery
import importlib.util
import sys
from pathlib import Path

import numpy as np

#: ODEPACK's return code for a successful run, and scipy's message for it
SUCCESS, SUCCESS_MESSAGE = 2, "Integration successful."
NAME = "scipy.integrate._odepack"


@functools.lru_cache(maxsize=1)
def extension():
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


def odeint(func, y0, t, jacobian=None, rtol: float = 1e-10, atol: float = 1e-12,
           mxstep: int = 0, tcrit=None, tfirst: bool = False):
    """(x, info) as ``scipy.integrate.odeint(..., full_output=True)`` returns them."""
    module = extension()
    if module is not None:
        try:
            x, info, code = module.odeint(
                func, np.array(y0, dtype=float), np.array(t, dtype=float), (), jacobian,
                0, -1, -1, 1, rtol, atol, tcrit, 0.0, 0.0, 0.0, 0, mxstep, 0, 12, 5,
                int(bool(tfirst)))
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
