"""How a URDF is read: ``ReadingOptions`` (--fix-base, --floating-base, --inertia,
--lock), the
``READING`` a command sets for its run, and the texts of ``--lock``."""
from __future__ import annotations

import math
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

from ...errors import ModelError

INERTIA_POLICIES = ("refuse", "repair", "accept")


@dataclass(frozen=True)
class ReadingOptions:
    """How a URDF is read (the flags of the same names): ``fix_base`` welds the
    floating or planar joint that carries the root link; ``inertia`` is the policy
    for impossible inertias (INERTIA_POLICIES); ``lock`` is ((joint, value), ...),
    the joints held at a value (a number, or its text: ``0.5``, ``pi/4``);
    ``floating_base`` frees the root link: a floating joint between the world and
    it (Pinocchio's ``JointModelFreeFlyer`` root), where a URDF fixes it;
    ``contacts`` (MJCF only) imports the contact geoms as contacts (``mjcf.contact``)."""
    fix_base: bool = False
    inertia: str = "refuse"
    lock: tuple[tuple[str, float | str], ...] = ()
    floating_base: bool = False
    contacts: bool = False

    def flags(self) -> str:
        """The options as command-line flags ('' for the defaults)."""
        words = (["--fix-base"] if self.fix_base else []) + (
            ["--floating-base"] if self.floating_base else []) + (
            [f"--inertia {self.inertia}"] if self.inertia != "refuse" else []) + (
            ["--contacts"] if self.contacts else [])
        return " ".join(words + [f"--lock {name}={value}" for name, value in self.lock])


#: the options that ``yamlsource.read_text`` and ``link_bodies`` read a URDF with; a
#: command sets them for its run (``reading``, from ``commands.common``)
READING: ContextVar[ReadingOptions] = ContextVar("urdf_reading", default=ReadingOptions())


@contextmanager
def reading(options: ReadingOptions):
    """Read URDF files with ``options`` inside the block (``READING``)."""
    token = READING.set(options)
    try:
        yield options
    finally:
        READING.reset(token)


def parse_lock(option: str) -> tuple[str, str]:
    """``JOINT=VALUE`` of a ``--lock`` -> (joint, value text); ModelError if malformed."""
    name, equals, value = option.partition("=")
    if not equals or not name.strip() or not value.strip():
        raise ModelError(f"--lock {option!r}: expected JOINT=VALUE, e.g. --lock elbow=pi/4 "
                         "(rad for a revolute joint, m for a prismatic one)")
    return name.strip(), value.strip()


def _lock_value(value: float | str, shown: str) -> float:
    """A --lock value: a number, or an expression of numbers and pi (``pi/4``) read by
    ``expressions.parse`` and evaluated in double precision by ``approximate`` (no
    names, never run as code); finite and real."""
    from .. import expressions

    try:
        number = expressions.approximate(expressions.parse(value, {}))
    except expressions.ExpressionError as err:
        raise ModelError(f"{shown}: {err}") from None
    if number.imag != 0 or not math.isfinite(number.real):
        raise ModelError(f"{shown}: {value!r} is not a finite real number")
    return number.real
