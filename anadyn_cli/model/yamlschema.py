"""The YAML that robot files are read with (and that ``anadyn import`` writes with):
plain data, remembering the line of every key path.

Only ``yaml.SafeLoader`` is used.  Beyond ``safe_load`` this rejects what a
robot file never needs and what hides mistakes: duplicate keys, aliases
(and with them alias bombs), merge keys, explicit tags other than the plain
types (``!!binary``, ``!!python/...``, ``!custom``), non-string keys, bytes
that are not UTF-8, and files over MAX_BYTES (parsing is pure Python, about
30 s per MiB at worst, so the cap also bounds the time spent).

Numbers are read as their text reads: plain integers and floats follow the
YAML 1.2 core schema (``010`` is 10, never YAML 1.1's octal 8; ``1:30`` and
``1_000`` are text, never 90 and 1000; ``1e-5`` is a number), everything
else is ``safe_load``'s (docs/reference/numbers-and-names.md).
"""
from __future__ import annotations

import math
import re

import yaml

from ..errors import ModelError, shorten

MAX_BYTES = 256 * 1024
#: tags a plain YAML value resolves to; any other (explicit) tag is refused
PLAIN_TAGS = frozenset(f"tag:yaml.org,2002:{name}" for name in
                       ("str", "int", "float", "bool", "null", "map", "seq", "timestamp"))
ALIAS_TAG = "!anadyn/alias"     # an alias (*name), kept where it is written
INT_TAG, FLOAT_TAG = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
#: the YAML 1.2 core schema's integers and floats (decimal, 0o octal, 0x hex; no
#: underscores, no sexagesimal, no YAML 1.1 leading-zero octal)
INTEGER = re.compile(r"[-+]?[0-9]+\Z|0o[0-7]+\Z|0x[0-9a-fA-F]+\Z")
FLOAT = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?\Z"
                   r"|[-+]?\.(?:inf|Inf|INF)\Z|\.(?:nan|NaN|NAN)\Z")


def _yaml12_resolvers(resolvers: dict) -> dict:
    """``resolvers`` (a Resolver's first character -> [(tag, pattern)]) with the
    int and float rules of the YAML 1.2 core schema in place of YAML 1.1's."""
    table = {first: [(tag, rx) for tag, rx in rules if tag not in (INT_TAG, FLOAT_TAG)]
             for first, rules in resolvers.items()}
    for tag, pattern, firsts in ((INT_TAG, INTEGER, "-+0123456789"),
                                 (FLOAT_TAG, FLOAT, "-+.0123456789")):
        anchored = re.compile(f"^(?:{pattern.pattern})")
        for first in firsts:
            table.setdefault(first, []).append((tag, anchored))
    return table


def _integer(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    text = loader.construct_scalar(node)
    if not INTEGER.match(text):
        raise ValueError("not an integer of the YAML 1.2 core schema")
    base = {"0o": 8, "0x": 16}.get(text[:2], 10)
    return int(text[2:] if base != 10 else text, base)


def _float(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> float | str:
    """The float; one too large for a double (1e999) stays text, which the
    expression reader refuses as too large, as it does '1e999' quoted."""
    text = loader.construct_scalar(node)
    if not (FLOAT.match(text) or INTEGER.match(text) and text[:2] not in ("0o", "0x")):
        raise ValueError("not a float of the YAML 1.2 core schema")
    special = {".inf": math.inf, "+.inf": math.inf, "-.inf": -math.inf, ".nan": math.nan}
    if text.lower() in special:
        return special[text.lower()]
    value = float(text)
    return text if math.isinf(value) else value


class _Loader(yaml.SafeLoader):
    """SafeLoader with the YAML 1.2 core schema's numbers, which composes each
    alias as a node of its own at the place it is used (never the anchored
    node again), so that refusing it names the right line, and an alias bomb
    is refused at its first alias."""

    yaml_implicit_resolvers = _yaml12_resolvers(yaml.SafeLoader.yaml_implicit_resolvers)

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.get_event()
            return yaml.ScalarNode(ALIAS_TAG, event.anchor, event.start_mark, event.end_mark)
        return super().compose_node(parent, index)


_Loader.add_constructor(INT_TAG, _integer)
_Loader.add_constructor(FLOAT_TAG, _float)


class Dumper(yaml.SafeDumper):
    """SafeDumper whose idea of a plain scalar is the loader's: a string that
    the loader would read as a number, boolean or null is quoted."""

    yaml_implicit_resolvers = _Loader.yaml_implicit_resolvers


def load(text: str, source: str) -> tuple[object, dict[str, int]]:
    """Parse YAML text into (data, lines), lines mapping key paths to 1-based lines."""
    if len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise ModelError(f"text longer than {MAX_BYTES} bytes", source=source)
    loader = None
    try:
        loader = _Loader(text)                    # checks the characters first
        node = loader.get_single_node()
        if node is None or (node.tag == "tag:yaml.org,2002:null" and not node.value.strip()
                            and node.value != "~" and not node.style):
            raise ModelError("empty file, expected a YAML mapping", source=source)
        lines: dict[str, int] = {}
        data = _Walker(loader, lines, source).walk(node, "")
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        position = getattr(err, "position", None)          # reader errors: bad characters
        if line is None and isinstance(position, int):
            line = text.count("\n", 0, position) + 1
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        context = getattr(err, "context", None)
        if context and problem.startswith("but "):      # "expected a single document ..."
            problem = f"{context}, {problem}"
        raise ModelError(f"not valid YAML: {problem}", source=source, line=line) from None
    except RecursionError:
        raise ModelError("YAML nested too deeply", source=source) from None
    finally:
        if loader is not None:
            loader.dispose()
    return data, lines


class _Walker:
    def __init__(self, loader: yaml.SafeLoader, lines: dict[str, int], source: str):
        self.loader, self.lines, self.source, self.seen = loader, lines, source, set()

    def walk(self, node: yaml.Node, path: str) -> object:
        if node.tag == ALIAS_TAG or id(node) in self.seen:
            raise ModelError("YAML aliases (*name) are not supported; write the value out",
                             source=self.source, path=path or None,
                             line=node.start_mark.line + 1)
        self.seen.add(id(node))
        self.lines.setdefault(path, node.start_mark.line + 1)
        if node.tag not in PLAIN_TAGS:
            tag = node.tag.replace("tag:yaml.org,2002:", "!!")
            raise ModelError(f"YAML tag {tag} is not supported; write plain numbers, text, "
                             "lists and mappings", source=self.source, path=path or None,
                             line=node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            result: dict[str, object] = {}
            for key_node, value_node in node.value:
                if key_node.tag == ALIAS_TAG:
                    self.walk(key_node, path)         # refused, naming its line
                if key_node.tag == "tag:yaml.org,2002:merge":
                    raise ModelError("YAML merge keys (<<) are not supported",
                                     source=self.source, path=path or None, line=key_node.start_mark.line + 1)
                key = self.loader.construct_object(key_node)
                if not isinstance(key, str):
                    shown = {None: "null", True: "true", False: "false"}.get(key, repr(key)) \
                        if key is None or isinstance(key, bool) else repr(key)
                    raise ModelError(f"keys must be names, got {shown}", source=self.source,
                                     path=path or None,
                                     line=key_node.start_mark.line + 1)
                child = f"{path}.{key}" if path else key
                if key in result:
                    raise ModelError("duplicate key", source=self.source, path=child,
                                     line=key_node.start_mark.line + 1)
                self.lines[child] = key_node.start_mark.line + 1
                result[key] = self.walk(value_node, child)
            return result
        if isinstance(node, yaml.SequenceNode):
            return [self.walk(item, f"{path}[{i}]") for i, item in enumerate(node.value)]
        try:
            return self.loader.construct_object(node)
        except (ValueError, OverflowError) as err:     # e.g. an int of 5000 digits, 2001-13-45
            shown = shorten(node.value, 40)
            reason = "too many digits" if "digits" in str(err) else str(err)
            raise ModelError(f"cannot read the value {shown!r} ({reason})", source=self.source,
                             path=path or None, line=node.start_mark.line + 1) from None


def describe_value(value: object) -> str:
    """What a YAML value is, for a message: ``the number 3``, ``a list``, ..."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the text {value!r}" if len(value) < 40 else "text"
    if isinstance(value, (int, float)):
        return f"the number {value!r}" if len(repr(value)) < 40 else "a number"
    return {dict: "a mapping", list: "a list"}.get(
        type(value), f"a {type(value).__name__.replace('datetime', 'date and time')}")
