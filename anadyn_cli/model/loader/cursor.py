"""``Cursor``: a value of the robot file with its key path, for errors that name
the file, line and key; it reads the value as a mapping, list, name, choice or
expression."""
from __future__ import annotations

import difflib
import math
import re
from typing import Mapping

import sympy as sp

from ...errors import ModelError, shorten
from .. import expressions
from ..names import IDENTIFIER, RESERVED_NAMES, nearest_key
from ..yamlschema import describe_value as _kind


class Cursor:
    """A value in the file together with its key path, for precise errors."""

    def __init__(self, value: object, path: str, source: str, lines: dict[str, int]):
        self.value, self.path, self.source, self.lines = value, path, source, lines

    def error(self, message: str) -> ModelError:
        return ModelError(message, source=self.source, path=self.path or None,
                          line=self.lines.get(nearest_key(self.path, self.lines)))

    def child(self, key: str | int, value: object) -> "Cursor":
        path = f"{self.path}[{key}]" if isinstance(key, int) else (
            f"{self.path}.{key}" if self.path else key)
        return Cursor(value, path, self.source, self.lines)

    def mapping(self, allowed: tuple[str, ...] | None = None,
                required: tuple[str, ...] = ()) -> dict[str, "Cursor"]:
        """The children of a mapping; unknown keys (if ``allowed``) and missing required ones fail."""
        if not isinstance(self.value, dict):
            if not self.path:
                raise self.error(f"the file must be a YAML mapping of keys to values, got "
                                 f"{_kind(self.value)}")
            raise self.error(f"expected a mapping, got {_kind(self.value)}")
        if allowed is not None:
            for key in self.value:
                if key not in allowed:
                    close = difflib.get_close_matches(key, allowed, n=1)
                    hint = f"did you mean {close[0]!r}? " if close else ""
                    split = (" (a comma or colon inside {...} splits an expression: quote "
                             "it)" if re.search(r"[()*/+^]", key) else "")
                    raise self.child(key, None).error(
                        f"unknown key{split}; {hint}allowed: {', '.join(allowed)}")
        for key in required:
            if key not in self.value:
                raise self.error(f"missing required key {key!r}")
        return {key: self.child(key, value) for key, value in self.value.items()}

    def sequence(self) -> list["Cursor"]:
        if not isinstance(self.value, list):
            raise self.error(f"expected a list, got {_kind(self.value)}")
        return [self.child(i, v) for i, v in enumerate(self.value)]

    def text(self) -> str:
        if not isinstance(self.value, str):
            raise self.error(f"expected text, got {_kind(self.value)}")
        return self.value

    def identifier(self, what: str = "name") -> str:
        value = self.value
        if not isinstance(value, str) or not IDENTIFIER.match(value):
            shown = repr(value) if not isinstance(value, str) or len(value) <= 40 else (
                f"{value[:37]!r}... ({len(value)} characters)")
            raise self.error(f"{what} must be a letter followed by up to 63 letters, digits "
                             f"or underscores, got {shown}")
        if value in RESERVED_NAMES:
            raise self.error(f"{value!r} is reserved; choose another {what}")
        return value

    def choice(self, options: tuple[str, ...]) -> str:
        if not isinstance(self.value, str) or self.value not in options:
            shown = repr(shorten(self.value)) if isinstance(self.value, str) else _kind(self.value)
            raise self.error(f"must be one of {', '.join(options)}, got {shown}")
        return self.value

    def expr(self, names: Mapping[str, sp.Expr], unavailable: Mapping[str, str] | None = None,
             smooth: bool = False) -> sp.Expr:
        try:
            return expressions.parse(self.value, names, unavailable, smooth)
        except expressions.ExpressionError as err:
            raise self.error(str(err)) from None

    def number(self, names: Mapping[str, sp.Expr], substitution: Mapping) -> float:
        """An expression that must evaluate to a finite real number."""
        expr = self.expr(names).xreplace(substitution)
        if expr.free_symbols:
            raise self.error(f"must be a number, depends on {sorted(map(str, expr.free_symbols))}")
        try:
            value = float(expr)
        except (TypeError, ValueError):
            raise self.error(f"must be a real number, got {expr}") from None
        if not math.isfinite(value):
            raise self.error(f"must be finite, got {value}")
        return value

    def vector(self, names: Mapping[str, sp.Expr], unavailable: Mapping[str, str] | None = None
               ) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        items = self.sequence()
        if len(items) != 3:
            raise self.error(f"expected a list of 3 components [x, y, z], got {len(items)}")
        return tuple(item.expr(names, unavailable) for item in items)
