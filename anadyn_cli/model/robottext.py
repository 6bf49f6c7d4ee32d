"""The anadyn YAML text of an imported robot (URDF, MJCF), shared by ``model.urdf``
and ``model.mjcf``: numbers (``Numbers``, ``_format``), names made identifiers
(``_Names``), angles (``_angle``), comments, and ``render``, through which no name
in the imported file can change the YAML structure."""
from __future__ import annotations

import functools
import math
import re

import numpy as np

import yaml

from ..errors import printable
from .names import IDENTIFIER, RESERVED_NAMES
from .yamlschema import Dumper

SMALLEST = 1e-30                  # anadyn's number range (model.loader); smaller -> 0


class Numbers:
    """Numbers as an import writes them: integral values as int, tiny ones
    (< SMALLEST) as 0, counted in ``flushed``."""
    flushed = 0

    def value(self, x: float) -> float | int:
        """A number for the YAML: integral values as int, tiny ones (< SMALLEST) as 0."""
        x = float(x)
        if x != 0 and abs(x) < SMALLEST:
            self.flushed += 1
            return 0
        return int(x) if x.is_integer() and abs(x) < 1e15 else x

    def vector(self, v) -> list:
        return [self.value(x) for x in v]

    def inertia_entries(self, inertia: np.ndarray) -> dict:
        """The non-zero entries of a symmetric inertia tensor ({ixx: 0} if none)."""
        keys = {"ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2),
                "ixy": (0, 1), "ixz": (0, 2), "iyz": (1, 2)}
        entries = {k: self.value(inertia[i, j]) for k, (i, j) in keys.items()}
        return {k: v for k, v in entries.items() if v != 0} or {"ixx": 0}


class _Names:
    """URDF names -> anadyn identifiers (letters, digits, _; a letter first; at
    most 64; not reserved), unique within their kind; coordinates, their
    rates d<q> and accelerations dd<q>, and actuators share one namespace."""

    def __init__(self):
        self.taken: set[str] = set()
        self.bodies: set[str] = set()

    @staticmethod
    def clean(name: str, prefix: str) -> str:
        text = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not text or not text[0].isalpha():
            text = prefix + text
        text = text[:60]
        return text + "_" if text in RESERVED_NAMES else text

    @staticmethod
    def unique(base: str, free) -> str:
        name, k = base, 2
        while not free(name):
            name, k = f"{base[:56]}_{k}", k + 1
        return name

    def robot(self, name: str) -> str:
        return self.clean(name, "robot_")

    def coordinate(self, name: str) -> str:
        triple = lambda n: {n, "d" + n, "dd" + n}                      # noqa: E731
        result = self.unique(self.clean(name, "q_"),
                             lambda n: not triple(n) & self.taken and IDENTIFIER.match("dd" + n))
        self.taken |= triple(result)
        return result

    def actuator(self, coordinate: str) -> str:
        result = self.unique(f"tau_{coordinate}"[:64], lambda n: n not in self.taken)
        self.taken.add(result)
        return result

    def body(self, name: str) -> str:
        result = self.unique(self.clean(name, "link_"), lambda n: n not in self.bodies)
        self.bodies.add(result)
        return result


def _angle(x: float):
    """An angle as ``k*pi/4`` text when x is that multiple of pi to the last bit, else x."""
    for k in range(-8, 9):
        if k and abs(x - k * math.pi / 4) <= 4 * np.spacing(abs(x)):
            g = math.gcd(abs(k), 4)
            num, den = k // g, 4 // g
            head = "-" if num < 0 else ""
            text = f"{head}{'' if abs(num) == 1 else f'{abs(num)}*'}pi"
            return text if den == 1 else f"{text}/{den}"
    return x


# -- YAML text ---------------------------------------------------------------------
def _format(x) -> str:
    """A number as text that Python and YAML read back as the same value (floats
    keep a '.' before an exponent, as yaml's own dumper writes them); text as is."""
    if isinstance(x, (np.floating, np.integer)):
        x = x.item()
    if isinstance(x, bool):                  # a flag, e.g. ``dependent: true``
        return "true" if x else "false"
    if x is None:
        raise TypeError(x)
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        if x.is_integer() and abs(x) < 1e15:
            return str(int(x))
        text = repr(x)
        if "e" in text and "." not in text.split("e")[0]:
            mantissa, exponent = text.split("e")
            text = f"{mantissa}.0e{exponent}"
        return text
    return str(x)


#: text written plain when the dumper finds it unambiguous (names, expressions)
PLAIN_TEXT = re.compile(r"[A-Za-z0-9_.*/+-](?:[A-Za-z0-9_.*/+ -]*[A-Za-z0-9_.*/+-])?\Z")


class _Quoted(Dumper):
    """The loader's dumper with every string but names and expressions
    (PLAIN_TEXT) double-quoted: escapes, one line."""


_Quoted.add_representer(str, lambda dumper, text: dumper.represent_scalar(
    "tag:yaml.org,2002:str", text, style=None if PLAIN_TEXT.match(text) else '"'))


def _scalar(value, dumper: type = _Quoted) -> str:
    """One scalar as YAML: a number by ``_format`` (its repr), text by ``_text``."""
    if isinstance(value, str):
        return _text(value, dumper)
    return _format(value)


@functools.lru_cache(maxsize=4096)
def _text(value: str, dumper: type) -> str:
    """Text as YAML written by ``dumper``: by default double-quoted but for names
    and expressions, which are plain where the loader reads them back as the
    same text (``yes`` or ``010`` are quoted)."""
    text = yaml.dump([value], Dumper=dumper, default_flow_style=True, width=math.inf,
                     allow_unicode=True)
    return text.strip()[1:-1]


def _key(name: str) -> str:
    """A mapping key: plain when the loader reads it back as this text, else quoted."""
    return _scalar(name, Dumper)


def _flow(value) -> str:
    """A value in flow style: keys by ``_key``, scalars by ``_scalar``."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)}: {_flow(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_flow(v) for v in value) + "]"
    return _scalar(value)


def _comment(line: str, indent: str = "") -> str:
    """A comment line; line breaks and controls in ``line`` escaped (``printable``)."""
    return f"{indent}# {printable(line)}".rstrip()


def render(data: dict, header: list[str], body_comments: list[list[str]]) -> str:
    """The YAML text of ``data`` (block style, leaves in flow style), with
    ``header`` comment lines on top and each body's comment lines above it.

    Every string is written by yaml's own dumper (``_text``: free text
    double-quoted, with escapes), every key by the loader's (quoted when it
    would not read back as text), every number by its repr and every comment
    line made ``printable``, so no name or file name from the URDF can change
    the structure: the text loads back to ``data`` (tests/test_import_trust.py)."""
    out = [_comment(line) for line in header]
    for key, value in data.items():
        if key == "bodies":
            out.append("bodies:")
            for body, comment in zip(value, body_comments):
                out.extend(_comment(line, "  ") for line in comment)
                lead = "  - "
                for k, v in body.items():
                    if k == "joint":
                        out.append(f"{lead}joint:")
                        out.extend(f"      {_key(jk)}: {_flow(jv)}" for jk, jv in v.items())
                    else:
                        out.append(f"{lead}{_key(k)}: {_flow(v)}")
                    lead = "    "
        elif isinstance(value, dict):
            out.append(f"{_key(key)}:")
            for k, v in value.items():
                if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
                    out.append(f"  {_key(k)}:")                  # e.g. contacts' geometry
                    out.extend(f"    - {_flow(x)}" for x in v)
                else:
                    out.append(f"  {_key(k)}: {_flow(v)}")
        else:
            out.append(f"{_key(key)}: {_flow(value)}")
    return "\n".join(out) + "\n"
