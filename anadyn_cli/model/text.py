"""The one-line lists people type in options: ``m2=1,2,5``, ``q=[0, pi/2], t=1``.

Light on purpose (no SymPy): the sweep grammar reads its options with it
before anything is derived.
"""
from __future__ import annotations

from ..errors import SettingError

OPENING, CLOSING = "([", ")]"


def split_items(text: str, setting: str) -> list[str]:
    """The items of ``text`` between commas outside parentheses and brackets, as
    written (not stripped; ``"a,,b"`` gives an empty middle item).  An unbalanced
    parenthesis or bracket is a SettingError of ``setting``."""
    items, depth, current = [], 0, []
    for char in text:
        if char in OPENING:
            depth += 1
        elif char in CLOSING:
            depth -= 1
            if depth < 0:
                raise SettingError(setting, f"{text!r}: unbalanced {char!r}")
        if char == "," and depth == 0:
            items.append("".join(current))
            current = []
        else:
            current.append(char)
    if depth:
        raise SettingError(setting, f"{text!r}: unbalanced brackets")
    return items + ["".join(current)]
