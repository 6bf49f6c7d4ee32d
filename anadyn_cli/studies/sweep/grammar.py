"""The text of ``--vary NAME=SPEC``, ``--max METRIC=BOUND`` and ``--min METRIC=BOUND``
(the grammar is in ``anadyn_cli.studies.sweep``'s docstring)."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ...errors import MAX_SAMPLES, ModelError
from ...model.text import split_items

DISTRIBUTIONS = ("normal", "uniform")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_CALL = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*\((.*)\)\s*\Z", re.S)
EXAMPLES = ("e.g. m2=0.5:2:7 (grid), m2=1,2,5 (list), m2=normal(1,0.05) or "
            "m2=uniform(0.8,1.2)")


@dataclass(frozen=True)
class Spec:
    """One --vary: ``values`` for a grid or list, ``arguments`` for a distribution."""
    name: str
    text: str
    kind: str                               # grid, list, normal, uniform
    values: tuple[float, ...] = ()
    arguments: tuple[float, float] = (math.nan, math.nan)

    @property
    def random(self) -> bool:
        return self.kind in DISTRIBUTIONS

    def describe(self) -> str:
        if self.kind == "grid":
            return f"{len(self.values)} values from {self.values[0]:g} to {self.values[-1]:g}"
        if self.kind == "list":
            return ", ".join(f"{v:g}" for v in self.values)
        a, b = self.arguments
        return f"normal(mean {a:g}, sd {b:g})" if self.kind == "normal" else \
            f"uniform({a:g}, {b:g})"

    def to_dict(self) -> dict:
        data = {"name": self.name, "spec": self.text, "kind": self.kind}
        if self.random:
            data.update(zip(("mean", "sd") if self.kind == "normal" else ("low", "high"),
                            self.arguments))
        else:
            data["values"] = list(self.values)
        return data


def parse_vary(option: str) -> Spec:
    """``NAME=SPEC`` (see the module docstring); ModelError naming the option."""
    name, equals, spec = option.partition("=")
    name, spec = name.strip(), spec.strip()
    if not equals or not name or not spec:
        raise ModelError(f"--vary {option!r}: expected NAME=SPEC, {EXAMPLES}")
    if not _NAME.match(name):
        raise ModelError(f"--vary {option}: {name!r} is not a parameter or gain name")
    return parse_spec(name, spec)


def parse_spec(name: str, spec: str) -> Spec:
    where = f"--vary {name}={spec}"
    call = _CALL.match(spec)
    if call and call.group(1).lower() in DISTRIBUTIONS:
        kind = call.group(1).lower()
        items = _items(where, call.group(2))
        shape = "normal(MEAN,SD)" if kind == "normal" else "uniform(LOW,HIGH)"
        if len(items) != 2:
            raise ModelError(f"{where}: {kind} takes two numbers, {shape}")
        a, b = (_number(where, item) for item in items)
        if kind == "normal" and not b > 0:
            raise ModelError(f"{where}: the standard deviation must be positive, got {b:g}")
        if kind == "uniform" and not b > a:
            raise ModelError(f"{where}: uniform(LOW,HIGH) needs LOW < HIGH, got {a:g} and "
                             f"{b:g}")
        return Spec(name, spec, kind, arguments=(a, b))
    if call and not _known_function(call.group(1)) and "," not in spec.replace(
            call.group(2), ""):
        raise ModelError(f"{where}: unknown distribution {call.group(1)!r}; use "
                         "normal(MEAN,SD) or uniform(LOW,HIGH)")
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3:
            raise ModelError(f"{where}: a grid is FROM:TO:COUNT, e.g. 10:60:11 "
                             "(11 values from 10 to 60)")
        low, high = _number(where, parts[0]), _number(where, parts[1])
        count = parts[2].strip()
        if not re.fullmatch(r"\d{1,9}", count) or not 1 <= int(count) <= MAX_SAMPLES:
            raise ModelError(f"{where}: the grid's COUNT must be a whole number from 1 to "
                             f"{MAX_SAMPLES:,}, got {count!r}")
        count = int(count)
        if count == 1 and low != high:
            raise ModelError(f"{where}: a grid of 1 value from {low:g} to {high:g}; give "
                             "2 or more values, or one value as a list")
        return Spec(name, spec, "grid", tuple(float(v) for v in np.linspace(low, high, count)))
    values = tuple(_number(where, item) for item in _items(where, spec))
    if len(values) > MAX_SAMPLES:
        raise ModelError(f"{where}: {len(values)} values; at most {MAX_SAMPLES:,} samples")
    return Spec(name, spec, "list", values)


def _known_function(name: str) -> bool:
    from ...model.names import FUNCTION_NAMES
    return name in FUNCTION_NAMES


def _items(where: str, text: str) -> list[str]:
    """The comma-separated numbers of a list or a distribution's arguments, stripped;
    an empty one is an error."""
    items = split_items(text, "vary")
    if any(not item.strip() for item in items):
        raise ModelError(f"{where}: empty value in the list; write numbers separated by "
                         "commas, " + EXAMPLES)
    return [item.strip() for item in items]


def _number(where: str, text: str) -> float:
    """A finite real constant: a number or an expression of numbers and pi."""
    from ...model import expressions

    try:
        value = complex(expressions.parse(text.strip(), {}).evalf())
    except expressions.ExpressionError as err:
        raise ModelError(f"{where}: {err}") from None
    except (TypeError, ValueError, ArithmeticError):
        raise ModelError(f"{where}: {text.strip()!r} is not a number") from None
    if value.imag != 0 or not math.isfinite(value.real):
        raise ModelError(f"{where}: {text.strip()!r} is not a finite real number")
    return float(value.real)


def parse_bound(option: str, text: str) -> tuple[str, float]:
    """``--max METRIC=BOUND`` (value <= BOUND) or ``--min METRIC=BOUND``."""
    metric, equals, bound = text.partition("=")
    metric, bound = metric.strip(), bound.strip()
    if not equals or not metric or not bound:
        raise ModelError(f"{option} {text!r}: expected METRIC=BOUND, e.g. {option} "
                         "peak_T01z=50")
    return metric, _number(f"{option} {text}", bound)

