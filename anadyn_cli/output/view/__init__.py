"""The 3-D view as one self-contained HTML page (``anadyn view``).

The page is ``view.html`` with its placeholders filled: three.js (vendored
from the npm registry, ``vendor/``, MIT) and the page's code ``viewer.js``
inlined as text and loaded through blob URLs, and the scene as JSON (numbers
and names only; ``<`` escaped so that no name can close the script element).
It needs no server and no network.  Meshes are read in Python (``meshes``)
and sent as triangles only, so the page needs no mesh loaders and never
reads a file itself.
"""
from __future__ import annotations

import base64
import html
import json
import re
from importlib import resources

import numpy as np

from .meshes import Part

VENDOR = {"three_core": "three.core.min.js", "three_module": "three.module.min.js",
          "orbit_controls": "OrbitControls.js"}
_SCRIPT_END = re.compile(r"</script|<!--", re.IGNORECASE)


def _text(*path: str) -> str:
    return resources.files(__name__).joinpath(*path).read_text(encoding="utf-8")


def b64(array: np.ndarray, dtype) -> str:
    """The array's bytes (little-endian ``dtype``) in base64."""
    return base64.b64encode(np.ascontiguousarray(array, dtype=dtype).tobytes()).decode("ascii")


def pack(part: Part) -> dict:
    """One mesh part for the page: the vertices its triangles use, quantized to 16 bits
    over their box (``low + u * step``, error at most step/2 per axis), and triangle
    indices in 16 bits when they fit, else 32.  (The visual's scale is applied by the page.)"""
    used, triangles = np.unique(part.triangles, return_inverse=True)
    positions = part.positions[used]
    low, high = positions.min(axis=0), positions.max(axis=0)
    step = np.where(high > low, (high - low) / 65535.0, 1.0)
    quantized = np.rint((positions - low) / step).astype("<u2")
    wide = len(used) > 65535
    return {"positions": b64(quantized, "<u2"), "low": low.tolist(), "step": step.tolist(),
            "indices": b64(triangles.reshape(-1), "<u4" if wide else "<u2"), "wide": wide,
            "color": list(part.color) if part.color else None,
            "triangles": int(len(part.triangles))}


def page(scene: dict, title: str, playback: bool) -> str:
    """The HTML page showing ``scene`` (see ``services.view.scene_data``)."""
    from ... import __version__

    pieces = {key: _text("vendor", name) for key, name in VENDOR.items()}
    pieces["viewer"] = _text("viewer.js")
    for key, text in pieces.items():
        if _SCRIPT_END.search(text):
            raise RuntimeError(f"{key} contains </script or <!--; it cannot be inlined")
    pieces["scene"] = json.dumps(scene, separators=(",", ":"), allow_nan=False).replace(
        "<", "\\u003c")
    pieces["title"] = html.escape(title)
    pieces["version"] = html.escape(__version__)
    pieces["playback"] = ('<button id="play" type="button">play</button>'
                          '<input id="time" type="range" min="0" max="0" value="0" step="1">'
                          if playback else "")
    return re.sub(r"\{\{(\w+)\}\}", lambda match: pieces[match.group(1)], _text("view.html"))
