"""Shared test settings.

Progress lines (``anadyn_cli.output.progress``) are switched off for the
suite: in plain mode (stderr not a terminal, as under pytest) a step that
outlasts two seconds says so on stderr, and on a busy machine any step may,
so tests that assert a command's exact stderr would depend on the machine's
load.  ``tests/test_cli_manners.py`` tests the progress modes explicitly.
"""
import pytest


@pytest.fixture(autouse=True)
def _quiet_progress(monkeypatch):
    monkeypatch.setenv("ANADYN_PROGRESS", "off")
