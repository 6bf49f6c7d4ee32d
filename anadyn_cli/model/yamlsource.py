"""A robot or config file's text: a library name resolved, a URDF imported, the
file's size and encoding checked (the YAML itself is read by ``yamlschema``)."""
from __future__ import annotations

import stat
from pathlib import Path

from ..errors import ModelError, display_name
from .yamlschema import MAX_BYTES


def read_text(path: str | Path, quiet: bool = False) -> tuple[str, str]:
    """(text, display name) of a robot or config file; ModelError if unreadable.

    A path that does not exist may name a library robot (``library.resolve``);
    a ``.urdf`` file or an MJCF model is imported (``library.import_robot``, with the
    current ``urdf.READING`` options: --fix-base, --inertia, --lock) and its text is the
    anadyn YAML that ``anadyn import`` writes with them, so caching and validation
    work as for any robot file.  The import's warnings go to stderr unless ``quiet``.
    """
    from . import library

    path = library.resolve(path)
    name = display_name(path)
    if path.exists() and library.imports(path):
        imported = library.import_robot(path)
        if not quiet:
            for warning in imported.warnings:
                library.announce(f"warning: {warning}", warning=True)
        return imported.text, name
    try:
        if path.is_dir():
            raise ModelError("is a directory, expected a YAML file", source=name)
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):     # a device or a pipe may never end
            raise ModelError("is not a regular file, expected a YAML file", source=name)
        if info.st_size > MAX_BYTES:
            raise ModelError(f"file is {info.st_size} bytes, the limit is {MAX_BYTES}",
                             source=name)
        with path.open("rb") as stream:       # the size may change under us: read at most
            raw = stream.read(MAX_BYTES + 1)   # one byte past the limit
        if len(raw) > MAX_BYTES:
            raise ModelError(f"file is over {MAX_BYTES} bytes, the limit", source=name)
    except FileNotFoundError:
        from .library import missing_hint
        raise ModelError("no such file" + missing_hint(path), source=name) from None
    except OSError as err:
        raise ModelError(f"cannot read: {err.strerror}", source=name) from None
    try:
        return raw.decode("utf-8"), name
    except UnicodeDecodeError as err:
        line = raw.count(b"\n", 0, err.start) + 1
        column = err.start - (raw.rfind(b"\n", 0, err.start) + 1) + 1
        raise ModelError(f"not UTF-8 text: byte 0x{raw[err.start]:02x} at column {column}; "
                         "save the file as UTF-8", source=name, line=line) from None
