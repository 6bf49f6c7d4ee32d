"""Derivation cache: generated code and robot info on disk, keyed by content.

    key = sha256(robot file bytes, formulation, anadyn version, anadyn code)

The last part is a fingerprint of anadyn's own source files, so a new
version or a changed code generator never reuses stale code.  Entries live
in $ANADYN_CACHE_DIR, else $XDG_CACHE_HOME/anadyn, else ~/.cache/anadyn,
one JSON file each, written atomically.  A damaged or unreadable entry is a
miss; a cache folder that cannot be written is skipped silently (the cache
only saves time).
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
from pathlib import Path

from .. import __version__

FORMAT = 1


def directory() -> Path:
    if os.environ.get("ANADYN_CACHE_DIR"):
        return Path(os.environ["ANADYN_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "anadyn"


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash of anadyn's own .py files (names and contents)."""
    package = Path(__file__).parent
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def key(robot_digest: str, formulation: str) -> str:
    text = f"{FORMAT}|{robot_digest}|{formulation}|{__version__}|{code_fingerprint()}"
    return hashlib.sha256(text.encode()).hexdigest()


def load(robot_digest: str, formulation: str) -> dict | None:
    """The stored entry, or None on a miss."""
    path = directory() / f"{key(robot_digest, formulation)}.json"
    try:
        entry = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(entry, dict) or entry.get("digest") != robot_digest:
        return None
    return entry


def store(robot_digest: str, formulation: str, entry: dict) -> None:
    from ..files import write_text

    folder = directory()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_text(folder / f"{key(robot_digest, formulation)}.json",
                   json.dumps({**entry, "digest": robot_digest}))
    except OSError:
        pass
