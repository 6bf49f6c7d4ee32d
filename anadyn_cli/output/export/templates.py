"""The export's code templates: text files beside this module (``*.in``), read with
``importlib.resources`` and filled in by ``string.Template``."""
from __future__ import annotations

from importlib import resources
from string import Template

#: what an empty list field becomes before its line is dropped
_DROPPED = "\x00"


def template(name: str, **fields) -> list[str]:
    """The lines of the template ``name`` beside this module, its ``${field}``s filled
    in: a list of lines fills its own line of the template with them (an empty list
    drops that line), anything else is written as ``str`` writes it."""
    text = resources.files(__package__).joinpath(name).read_text(encoding="utf-8")
    filled = {key: ("\n".join(value) if value else _DROPPED) if isinstance(value, list)
              else value for key, value in fields.items()}
    return [line for line in Template(text).substitute(filled).split("\n")
            if line != _DROPPED]
