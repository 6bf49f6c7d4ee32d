"""Read YAML safely into plain data, remembering the line of every key path.

Only ``yaml.SafeLoader`` is used.  Beyond ``safe_load`` this rejects what a
robot file never needs and what hides mistakes: duplicate keys, aliases
(and with them alias bombs), non-string keys, and files over MAX_BYTES.
"""
from __future__ import annotations

from pathlib import Path

import yaml

from ..errors import ModelError

MAX_BYTES = 1 << 20


def read_text(path: str | Path) -> tuple[str, str]:
    """(text, display name) of a robot or config file; ModelError if unreadable."""
    path = Path(path)
    name = str(path)
    try:
        if path.is_dir():
            raise ModelError("is a directory, expected a YAML file", source=name)
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise ModelError(f"file is {size} bytes, the limit is {MAX_BYTES}", source=name)
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ModelError("no such file", source=name) from None
    except OSError as err:
        raise ModelError(f"cannot read: {err.strerror}", source=name) from None
    try:
        return raw.decode("utf-8"), name
    except UnicodeDecodeError:
        raise ModelError("not UTF-8 text", source=name) from None


def load(text: str, source: str) -> tuple[object, dict[str, int]]:
    """Parse YAML text into (data, lines), lines mapping key paths to 1-based lines."""
    if len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise ModelError(f"text longer than {MAX_BYTES} bytes", source=source)
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise ModelError("empty file, expected a YAML mapping", source=source)
        lines: dict[str, int] = {}
        data = _Walker(loader, lines, source).walk(node, "")
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ModelError(f"not valid YAML: {problem}", source=source, line=line) from None
    except RecursionError:
        raise ModelError("YAML nested too deeply", source=source) from None
    finally:
        loader.dispose()
    return data, lines


class _Walker:
    def __init__(self, loader: yaml.SafeLoader, lines: dict[str, int], source: str):
        self.loader, self.lines, self.source, self.seen = loader, lines, source, set()

    def walk(self, node: yaml.Node, path: str) -> object:
        if id(node) in self.seen:
            raise ModelError("YAML aliases (*name) are not supported; write the value out",
                             source=self.source, path=path or None,
                             line=node.start_mark.line + 1)
        self.seen.add(id(node))
        self.lines.setdefault(path, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            result: dict[str, object] = {}
            for key_node, value_node in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    raise ModelError("YAML merge keys (<<) are not supported",
                                     source=self.source, path=path or None, line=key_node.start_mark.line + 1)
                key = self.loader.construct_object(key_node)
                if not isinstance(key, str):
                    raise ModelError(f"keys must be names, got {key!r}", source=self.source,
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
        return self.loader.construct_object(node)
