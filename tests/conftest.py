"""Shared fixtures and test settings.

* The repository's paths and robot texts (``repo``, ``rr_text``, ``rrt_text``).
* A private derivation cache for the whole session: no test writes to the
  user's ~/.cache/anadyn (tests that study the cache set their own folder).
* Progress lines (``anadyn_cli.progress``) are switched off: in plain mode
  (stderr not a terminal, as under pytest) a step that outlasts two seconds
  says so on stderr, and on a busy machine any step may, so tests that
  assert a command's exact stderr would depend on the machine's load.
  ``tests/test_cli_manners.py`` tests the progress modes explicitly.
"""
from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True, scope="session")
def _session_cache(tmp_path_factory):
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ANADYN_CACHE_DIR", str(tmp_path_factory.mktemp("anadyn-session-cache")))
        yield


@pytest.fixture(autouse=True)
def _quiet_progress(monkeypatch):
    monkeypatch.setenv("ANADYN_PROGRESS", "off")


@pytest.fixture(autouse=True)
def _no_terminal_size(monkeypatch):
    """Tables are printed whole (standard output is not a terminal) unless a test sets
    COLUMNS itself: pytest-xdist's workers inherit a COLUMNS from the main process."""
    monkeypatch.delenv("COLUMNS", raising=False)
    monkeypatch.delenv("LINES", raising=False)


@pytest.fixture
def repo() -> Path:
    """The repository root (robots/, configs/, README.md)."""
    return REPO


@pytest.fixture
def rr_text() -> str:
    return (REPO / "robots" / "rr.yaml").read_text(encoding="utf-8")


@pytest.fixture
def rrt_text() -> str:
    return (REPO / "robots" / "rrt.yaml").read_text(encoding="utf-8")


@pytest.fixture(autouse=True)
def _no_background_compiler(monkeypatch):
    """No native compile in the background of a test (tests/test_recursive.py sets
    ANADYN_NATIVE itself where it studies the native path)."""
    monkeypatch.setenv("ANADYN_NATIVE", "0")
