"""Read YAML safely into plain data, remembering the line of every key path.

Only ``yaml.SafeLoader`` is used.  Beyond ``safe_load`` this rejects what a
robot file never needs and what hides mistakes: duplicate keys, aliases
(and with them alias bombs), merge keys, explicit tags other than the plain
types (``!!binary``, ``!!python/...``, ``!custom``), non-string keys, bytes
that are not UTF-8, and files over MAX_BYTES (parsing is pure Python, about
30 s per MiB at worst, so the cap also bounds the time spent).
"""
from __future__ import annotations

import stat
from pathlib import Path

import yaml

from ..errors import ModelError

MAX_BYTES = 256 * 1024
#: tags a plain YAML value resolves to; any other (explicit) tag is refused
PLAIN_TAGS = frozenset(f"tag:yaml.org,2002:{name}" for name in
                       ("str", "int", "float", "bool", "null", "map", "seq", "timestamp"))
ALIAS_TAG = "!anadyn/alias"     # an alias (*name), kept where it is written


class _Loader(yaml.SafeLoader):
    """SafeLoader that composes each alias as a node of its own at the place it
    is used (never the anchored node again), so that refusing it names the
    right line, and an alias bomb is refused at its first alias."""

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.get_event()
            return yaml.ScalarNode(ALIAS_TAG, event.anchor, event.start_mark, event.end_mark)
        return super().compose_node(parent, index)


def read_text(path: str | Path, quiet: bool = False) -> tuple[str, str]:
    """(text, display name) of a robot or config file; ModelError if unreadable.

    A path that does not exist may name a library robot (``library.resolve``);
    a ``.urdf`` file is imported (``urdf.import_file``) and its text is the
    anadyn YAML that ``anadyn import`` writes, so caching and validation work
    as for any robot file.  The import's warnings go to stderr unless ``quiet``.
    """
    from . import library

    path = library.resolve(path)
    name = str(path)
    if path.suffix.lower() == ".urdf" and path.exists():
        from .urdf import import_file

        imported = import_file(path)
        if not quiet:
            for warning in imported.warnings:
                library.announce(f"warning: {warning}", warning=True)
        return imported.text, name
    try:
        if path.is_dir():
            raise ModelError("is a directory, expected a YAML file", source=name)
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):     # a device or a pipe may never end
            raise ModelError("is not a regular file, expected a YAML file", source=name)
        if info.st_size > MAX_BYTES:
            raise ModelError(f"file is {info.st_size} bytes, the limit is {MAX_BYTES}",
                             source=name)
        with path.open("rb") as stream:       # the size may change under us: read at most
            raw = stream.read(MAX_BYTES + 1)   # one byte past the limit
        if len(raw) > MAX_BYTES:
            raise ModelError(f"file is over {MAX_BYTES} bytes, the limit", source=name)
    except FileNotFoundError:
        from .library import missing_hint
        raise ModelError("no such file" + missing_hint(path), source=name) from None
    except OSError as err:
        raise ModelError(f"cannot read: {err.strerror}", source=name) from None
    try:
        return raw.decode("utf-8"), name
    except UnicodeDecodeError as err:
        line = raw.count(b"\n", 0, err.start) + 1
        column = err.start - (raw.rfind(b"\n", 0, err.start) + 1) + 1
        raise ModelError(f"not UTF-8 text: byte 0x{raw[err.start]:02x} at column {column}; "
                         "save the file as UTF-8", source=name, line=line) from None


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
            shown = node.value if len(node.value) <= 40 else node.value[:37] + "..."
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
