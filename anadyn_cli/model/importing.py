"""What the URDF and MJCF imports (``model.urdf``, ``model.mjcf``) share in reading:
a file up to a size (``read_capped``) and XML from strangers (``parse_xml``); what
they share in writing is ``robottext``."""
from __future__ import annotations

import stat
from pathlib import Path

from ..errors import ModelError

def read_capped(path: Path, name: str, limit: int, kind: str, what: str) -> bytes:
    """The bytes of the file at ``path`` (``name`` in messages); ModelError if it is
    missing, not a regular file or over ``limit`` bytes, the limit for ``kind``
    (URDF, MJCF); ``what`` is the file expected (``a URDF file``)."""
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise ModelError(f"is not a regular file, expected {what}", source=name)
        if info.st_size > limit:
            raise ModelError(f"file is {info.st_size} bytes, the limit for {kind} is {limit}",
                             source=name)
        with path.open("rb") as stream:       # the size may change under us: read at most
            raw = stream.read(limit + 1)       # one byte past the limit
    except FileNotFoundError:
        raise ModelError("no such file", source=name) from None
    except OSError as err:
        raise ModelError(f"cannot read: {err.strerror}", source=name) from None
    if len(raw) > limit:
        raise ModelError(f"file is over {limit} bytes, the limit for {kind}", source=name)
    return raw


def parse_xml(raw: bytes, source: str, kind: str):
    """The root element of ``raw``, parsed by defusedxml (expat underneath; entity
    declarations and external references refused: no "billion laughs", no file or
    network access); ``kind`` (URDF, MJCF) names the format in messages."""
    import defusedxml
    from defusedxml import ElementTree

    try:
        return ElementTree.fromstring(raw, forbid_dtd=False, forbid_entities=True,
                                      forbid_external=True)
    except ElementTree.ParseError as err:
        line, column = getattr(err, "position", (None, None))
        reason = str(err).split(":")[0]
        raise ModelError(f"not well-formed XML: {reason} (column {column})", source=source,
                         line=line) from None
    except defusedxml.EntitiesForbidden:
        raise ModelError("XML entity declarations are refused (entity expansion is a "
                         f"classic attack and no {kind} needs it)", source=source) from None
    except defusedxml.DefusedXmlException as err:
        raise ModelError(f"refused XML: {type(err).__name__} (external references and "
                         "entities are not read)", source=source) from None
