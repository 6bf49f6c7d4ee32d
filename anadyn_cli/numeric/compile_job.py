"""One native build: compile a C file in a private folder, store the library in
the native cache folder, or remember why it failed.

``native.build`` runs it in the run's own process; ``native.build_in_background``
in a detached one (``python -I``, importing only this module, ``cache`` and the
standard library: a few milliseconds).  In the cache folder a build leaves

    MODULE-<sha256[:16]><EXT_SUFFIX>   the library, 0600, named by its content
    MODULE.lib                         sealed {"sha256": ...}: which library is MODULE's
    MODULE.failed                      sealed {"why": ...}: a failed build, not tried
                                       again (``native.failed_before`` says why, once)

The library is renamed into place before its record is written, and a
content-addressed name never changes its bytes, so a reader that finds the
record finds the whole library (or a damaged one, which its hash shows).
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

from . import cache

#: the longest a compile may run; a build marker older than this is stale
TIMEOUT = 1800.0
#: the compiler's output inside the private build folder
OUTPUT = "library.so"


def library_name(module: str, digest: str, suffix: str) -> str:
    return f"{module}-{digest[:16]}{suffix}"


def run(command: list[str], work: Path, module: str, suffix: str,
        folder: Path | None) -> tuple[Path | None, str]:
    """Compile with ``command`` (run in ``work``, writing OUTPUT there) and store the
    library in ``folder`` when it is given: (its path, "compiled"), or (None, why)
    after remembering the failure in ``folder``."""
    try:
        done = subprocess.run(command, cwd=work, stdin=subprocess.DEVNULL,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              timeout=TIMEOUT)
    except (OSError, subprocess.TimeoutExpired) as err:
        why = f"the C compiler failed ({err})"
    else:
        first = (done.stderr.decode(errors="replace").strip().splitlines() or ["?"])[0]
        why = None if done.returncode == 0 else f"the C compiler failed ({first.strip()})"
    built = work / OUTPUT
    if why is None and not built.is_file():
        why = "the C compiler wrote no library"
    if why is not None:
        if folder is not None:
            try:
                cache.write_record(folder, f"{module}.failed", {"why": why})
            except OSError:
                pass
        return None, why
    os.chmod(built, 0o600)
    if folder is None:
        return built, "compiled"
    digest = hashlib.sha256(built.read_bytes()).hexdigest()
    final = folder / library_name(module, digest, suffix)
    try:
        os.replace(built, final)
        cache.write_record(folder, f"{module}.lib", {"sha256": digest})
    except OSError:
        return (final if final.exists() else built), "compiled"
    return final, "compiled"


def release(marker: Path) -> None:
    """Remove the build marker if it is still this process's."""
    try:
        if (cache.read_private(marker) or b"").strip() == str(os.getpid()).encode():
            os.remove(marker)
    except (OSError, cache.Untrusted):
        pass


def main(argv: list[str]) -> None:
    """The detached build: FOLDER MODULE SUFFIX WORK COMMAND...  The build marker
    MODULE.building, made by the run that started this, gets this process's id."""
    folder, module, suffix, work, command = Path(argv[0]), argv[1], argv[2], Path(argv[3]), argv[4:]
    marker = folder / f"{module}.building"
    try:
        cache.write_private(folder, marker.name, str(os.getpid()).encode())
        run(command, work, module, suffix, folder)
    finally:
        shutil.rmtree(work, ignore_errors=True)
        release(marker)


if __name__ == "__main__":          # pragma: no cover  (native.build_in_background's -c)
    main(sys.argv[1:])
