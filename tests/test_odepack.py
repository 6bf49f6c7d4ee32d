"""``numeric.odepack``: ODEPACK's LSODA loaded without ``scipy.integrate``, against
``scipy.integrate.odeint`` itself (the same Fortran: the same bits), and its
fallback when the extension cannot be used."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import odeint as scipy_odeint

from anadyn_cli.numeric import odepack


def van_der_pol(t, x, mu=50.0):
    return np.array([x[1], mu * (1 - x[0] ** 2) * x[1] - x[0]])


def van_der_pol_jacobian(t, x, mu=50.0):
    return np.array([[0.0, 1.0], [-2 * mu * x[0] * x[1] - 1, mu * (1 - x[0] ** 2)]])


GRID = np.linspace(0.0, 20.0, 201)


def ours_and_scipys(**options):
    ours = odepack.odeint(van_der_pol, [2.0, 0.0], GRID, van_der_pol_jacobian, rtol=1e-10,
                          atol=1e-12, tfirst=True, **options)
    theirs = scipy_odeint(van_der_pol, [2.0, 0.0], GRID, Dfun=van_der_pol_jacobian,
                          rtol=1e-10, atol=1e-12, full_output=True, tfirst=True, **options)
    return ours, theirs


@pytest.mark.parametrize("options", [{"mxstep": 10**6}, {"mxstep": 10**6, "tcrit": [20.0]}])
def test_the_same_bits_as_scipy(options):
    assert odepack.extension() is not None          # loaded alone on this SciPy
    (x, info), (x_ref, info_ref) = ours_and_scipys(**options)
    assert np.array_equal(x, x_ref)
    assert info["message"] == info_ref["message"] == "Integration successful."
    for key in ("nst", "nfe", "nje", "tcur", "mused"):
        assert np.array_equal(info[key], info_ref[key]), key


def test_a_failed_run_says_what_scipy_says():
    """Too few steps allowed: the run stops early with SciPy's own message."""
    with pytest.warns(Warning):                     # scipy's wrapper warns, ours does not
        (x, info), (x_ref, info_ref) = ours_and_scipys(mxstep=5)
    assert info["message"] == info_ref["message"] != "Integration successful."
    assert info["message"].startswith("Excess work done")
    assert info["tcur"][0] == info_ref["tcur"][0] < GRID[-1]     # where it stopped (the
    # arrays past the rows reached are uninitialized memory, on both sides)


def test_without_the_extension_scipy_odeint_runs(monkeypatch):
    monkeypatch.setattr(odepack, "extension", lambda: None)
    (x, info), (x_ref, _) = ours_and_scipys(mxstep=10**6)
    assert np.array_equal(x, x_ref) and info["message"] == "Integration successful."


def test_a_run_does_not_import_scipy_integrate(repo, tmp_path):
    """What the module is for: ``simulate`` by odeint never loads scipy.integrate."""
    code = ("import sys\nfrom anadyn_cli.api import simulate\n"
            f"simulate({str(repo / 'robots/rr.yaml')!r})\n"
            "from anadyn_cli.numeric import odepack\n"
            "print('scipy.integrate' in sys.modules, odepack.extension() is not None)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, check=True).stdout.split()
    assert out == ["False", "True"]
