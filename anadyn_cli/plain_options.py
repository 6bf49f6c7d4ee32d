"""Plain option values read without Pydantic: ``plain_coercion``.

Typer (0.29, the version installed here) turns each command-line value into its type
with a Pydantic ``TypeAdapter`` built for that parameter on every run, even for
an option left out: importing Pydantic and building the adapters costs ~60 ms
of CPU on each command, about what a warm run computes.  ``plain_coercion``
gives each parameter of a click command built by typer a ``PlainValue``,
which reads the values whose meaning is plain without Pydantic, as typer
would read them:

- a value already of the parameter's type (a default: ``1.0`` for a float,
  an Enum member, a Path) as it is; None as nothing (typer's own rule);
- text for ``str``; decimal text (``12``, ``-0.5``, ``1e-3``) for ``int``
  (digits only) and ``float`` without bounds: ``int()`` and ``float()``, the
  numbers Pydantic gives;
- text for a ``Path``: a ``Path`` checked by typer's own ``coerce_cli_path``
  (exists, file or folder, as asked), the Path that Pydantic makes of it;
- text for an Enum: typer's own ``coerce_cli_choice``;
- a parameter with a ``parser``: its value (as typer: the parser decides);
- lists of these.

Anything else, and any value these do not accept, goes to typer's own
coercion (``build_runtime_param``), so its messages stay typer's.  With a
typer that lacks these internals nothing changes.
"""
from __future__ import annotations

import re
from enum import Enum
from pathlib import Path
from typing import get_args, get_origin

_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_INTEGER = re.compile(r"[+-]?\d{1,18}")
#: no plain reading: typer's own coercion reads the value
_TYPER = object()


def plain_coercion(command) -> None:
    """Give every typer parameter of ``command`` (a click Group or Command made by
    ``typer.main.get_command``) that has no coercion yet a ``PlainValue``."""
    try:                                # the typer internals used here and below
        from typer._coercion import build_runtime_param  # noqa: F401
        from typer._param_types import coerce_cli_choice, coerce_cli_path  # noqa: F401
        from typer.core import _TyperParameter
    except ImportError:
        return
    def plain(param):
        if (isinstance(param, _TyperParameter) and hasattr(param, "type_descriptor")
                and getattr(param, "_runtime_param", _TYPER) is None):
            param._runtime_param = PlainValue(param.type_descriptor)
        return param

    def help_option(made):              # made anew for each context
        return lambda ctx: plain(made(ctx))

    commands = getattr(command, "commands", {}) or {}
    for one in (command, *commands.values()):
        for param in getattr(one, "params", ()):
            plain(param)
        if hasattr(one, "get_help_option"):
            one.get_help_option = help_option(one.get_help_option)


class PlainValue:
    """The coercion of one parameter (module docstring); typer's own for the rest."""

    def __init__(self, descriptor):
        self.descriptor, self._typer = descriptor, None

    def coerce(self, value, param, ctx):
        multiple = param.multiple or param.nargs == -1
        if value is None:
            return () if multiple else None
        plain = _TYPER
        if self.descriptor.file_annotation is None:
            info = self.descriptor.parameter_info
            if multiple and isinstance(value, (list, tuple)) and get_origin(
                    self.descriptor.annotation) is list:
                (item,) = get_args(self.descriptor.annotation) or (str,)
                values = [_plain(item, info, v, param, ctx) for v in value]
                plain = _TYPER if any(v is _TYPER for v in values) else values
            elif not multiple:
                plain = _plain(self.descriptor.annotation, info, value, param, ctx)
        if plain is not _TYPER:
            return plain
        if self._typer is None:
            from typer._coercion import build_runtime_param
            self._typer = build_runtime_param(self.descriptor)
        return self._typer.coerce(value, param=param, ctx=ctx)


def _plain(annotation, info, value, param, ctx):
    """``value`` read as ``annotation`` when its meaning is plain, else _TYPER."""
    parser = getattr(info, "parser", None)
    if parser is not None:              # typer: the parser's value, its ValueError a message
        try:
            return parser(value)
        except (ValueError, AssertionError):
            return _TYPER
    if getattr(info, "click_type", None) is not None:
        return _TYPER
    if annotation is str:
        return value if isinstance(value, str) else _TYPER
    if annotation in (int, float):
        if getattr(info, "min", None) is not None or getattr(info, "max", None) is not None:
            return _TYPER
        if type(value) is annotation:
            return value
        pattern = _INTEGER if annotation is int else _DECIMAL
        if isinstance(value, str) and pattern.fullmatch(value):
            return annotation(value)
        return _TYPER
    if isinstance(annotation, type) and issubclass(annotation, Enum):
        if isinstance(value, annotation):
            return value
        from typer._param_types import coerce_cli_choice
        try:
            return coerce_cli_choice(value, choices=list(annotation),
                                     case_sensitive=info.case_sensitive, ctx=ctx)
        except ValueError:
            return _TYPER
    if annotation is Path and getattr(info, "path_type", None) in (None, Path):
        if isinstance(value, str) and value and "\0" not in value:
            value = Path(value)
        if not isinstance(value, Path):
            return _TYPER
        from typer._param_types import coerce_cli_path
        return coerce_cli_path(value, info, path_type=Path, param=param, ctx=ctx)
    return _TYPER
