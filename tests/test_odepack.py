"""``numeric.odepack``: ODEPACK's LSODA loaded without ``scipy.integrate``, against
``scipy.integrate.odeint`` itself (the same Fortran: the same bits), its
self-check (recorded per SciPy version in the native cache folder) and its
fallback when the extension cannot be used or fails the check."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import odeint as scipy_odeint

from anadyn_cli.numeric import cache, odepack


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


class OneUlpOff:
    """SciPy's _odepack as another layout might answer: one bit off in the solution."""

    def __init__(self, module):
        self.module = module

    def odeint(self, *args):
        x, info, code = self.module.odeint(*args)
        return np.nextafter(x, np.inf), info, code


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """An empty cache folder, no verdict remembered in this process."""
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    odepack.extension.cache_clear()
    yield tmp_path / "cache-native"
    odepack.extension.cache_clear()


def records(folder):
    return {p.name: json.loads(cache.unseal(p.read_bytes())) for p in folder.glob("scipy-*")}


def test_the_self_check_is_done_once_per_scipy_version(fresh, monkeypatch):
    import scipy
    assert odepack.extension() is not None
    name = f"scipy-odepack-{scipy.__version__}-{sys.implementation.cache_tag}.json"
    assert records(fresh) == {name: {"same": True, "scipy": scipy.__version__}}
    assert (fresh / name).stat().st_mode & 0o777 == 0o600
    odepack.extension.cache_clear()

    def no_check(module):
        raise AssertionError("checked again")
    with monkeypatch.context() as patch:          # recorded: not checked again
        patch.setattr(odepack, "same_as_scipy", no_check)
        assert odepack.extension() is not None
    odepack.extension.cache_clear()
    monkeypatch.setattr(scipy, "__version__", "99.0.0")     # another SciPy: checked again
    assert odepack.extension() is not None
    assert len(records(fresh)) == 2


def test_an_extension_that_is_one_bit_off_is_not_used(fresh, monkeypatch):
    real = odepack._load()
    assert odepack.same_as_scipy(real)
    monkeypatch.setattr(odepack, "_load", lambda: OneUlpOff(real))
    assert not odepack.same_as_scipy(OneUlpOff(real))
    assert odepack.extension() is None                  # scipy.integrate.odeint instead
    assert [r["same"] for r in records(fresh).values()] == [False]
    (x, info), (x_ref, _) = ours_and_scipys(mxstep=10**6)
    assert np.array_equal(x, x_ref) and info["message"] == "Integration successful."


def test_a_damaged_record_is_checked_again(fresh, monkeypatch):
    assert odepack.extension() is not None
    (record,) = fresh.glob("scipy-*")
    record.write_bytes(record.read_bytes().replace(b"true", b"fals"))
    odepack.extension.cache_clear()
    with pytest.warns(UserWarning, match="SciPy self-check record .* is damaged"):
        assert odepack.extension() is not None
    assert [r["same"] for r in records(fresh).values()] == [True]


def test_a_run_does_not_import_scipy_integrate(repo, tmp_path):
    """What the module is for: ``simulate`` by odeint loads scipy.integrate only
    for the self-check of the first run with this SciPy, never after."""
    code = ("import sys\nfrom anadyn_cli.api import simulate\n"
            f"simulate({str(repo / 'robots/rr.yaml')!r})\n"
            "from anadyn_cli.numeric import cache, odepack\n"
            "print('scipy.integrate' in sys.modules, odepack.extension() is not None)")
    env = {**os.environ, "ANADYN_CACHE_DIR": str(tmp_path / "cache")}

    def run():
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              cwd=tmp_path, check=True, env=env).stdout.split()
    assert run() == ["True", "True"]               # the self-check imported it
    assert run() == ["False", "True"]
