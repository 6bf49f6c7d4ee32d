"""Reading MJCF XML: the file and its <include>s (each inside the model's folder,
MAX_BYTES in all, MAX_INCLUDES files), defusedxml's parse (``importing.parse_xml``:
no entities, no external references), the <compiler> settings, the <default>
classes, and ``_Reader``, which reads attributes as MuJoCo resolves them (the
element's own value, else its class's default) with their numbers as written."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import ModelError, display_name
from ..importing import parse_xml, read_capped
from ..urdf.parse import DECIMAL, LARGEST

MAX_BYTES = 4 * 1024 * 1024       # the model and its includes together (MJCFs: ~2-200 kB);
#                                   an include is read up to what the files before it left
EXPECTED = "an MJCF (MuJoCo XML) file"
MAX_DEPTH = 200                   # elements in elements (bodies in bodies: the import recurses)
MAX_INCLUDES = 64                 # <include> files in one model (cycles end here too)
#: defaults that apply to every actuator shortcut (MuJoCo keeps one actuator per class)
ACTUATOR_TAGS = ("general", "motor", "position", "velocity")


def is_mjcf(path: Path) -> bool:
    """Whether ``path`` is an .xml file whose root element is <mujoco> (read from its
    first 4 kB: comments and the XML declaration may come first)."""
    if path.suffix.lower() != ".xml" or not path.is_file():
        return False
    try:
        with path.open("rb") as stream:
            head = stream.read(4096)
    except OSError:
        return False
    return re.search(rb"<mujoco[\s>/]", head) is not None


def load(path: Path):
    """The model's <mujoco> element with every <include> replaced by the included
    file's elements, and the display name of the model file."""
    shown = display_name(path)
    folder = path.resolve().parent
    budget = [MAX_BYTES, MAX_INCLUDES]
    raw = read_capped(path, shown, budget[0], "MJCF", EXPECTED)
    budget[0] -= len(raw)
    root = parse_xml(raw, shown, "MJCF")
    if root.tag != "mujoco":
        raise ModelError(f"the root element is <{root.tag}>, expected <mujoco>: not an MJCF "
                         "file", source=shown)
    _expand(root, folder, shown, budget)
    return root, shown


def _expand(root, folder: Path, shown: str, budget: list[int]) -> None:
    """Replace each <include file="..."> below ``root`` by the children of the
    included file's root, in place (includes in included files too); the files must
    lie inside ``folder``, and the result be at most MAX_DEPTH elements deep."""
    stack = [root]
    while stack:
        element = stack.pop()
        children = []
        for child in list(element):
            if child.tag != "include":
                children.append(child)
                continue
            name = child.get("file")
            if not name:
                raise ModelError('<include> needs file="..."', source=shown)
            target = (folder / name).resolve()
            if not target.is_relative_to(folder):
                raise ModelError(f'<include file="{name}">: outside the model\'s folder; '
                                 "included files must be inside it", source=shown)
            budget[1] -= 1
            if budget[1] < 0:
                raise ModelError(f'<include file="{name}">: more than {MAX_INCLUDES} included '
                                 "files (or an include cycle)", source=shown)
            included_name = display_name(target)
            raw = read_capped(target, included_name, budget[0], "MJCF", EXPECTED)
            budget[0] -= len(raw)
            children.extend(parse_xml(raw, included_name, "MJCF"))
        element[:] = children
        stack.extend(children)
    _check_depth(root, shown)


def _check_depth(root, shown: str) -> None:
    """ModelError if elements nest more than MAX_DEPTH deep (the import recurses)."""
    stack = [(root, 1)]
    while stack:
        element, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise ModelError(f"<{element.tag}>: elements nested more than {MAX_DEPTH} deep; "
                             "no robot needs that many", source=shown)
        stack.extend((child, depth + 1) for child in element)


@dataclass(frozen=True)
class Compiler:
    """<compiler> settings that change the numbers (MuJoCo's defaults)."""
    degrees: bool = True              # angle="degree"
    eulerseq: str = "xyz"
    inertiafromgeom: str = "auto"     # true, false, auto (only bodies without <inertial>)
    autolimits: bool = True
    boundmass: float = 0.0
    boundinertia: float = 0.0
    settotalmass: float = -1.0
    inertiagroups: tuple = (0, 5)     # inertiagrouprange: geom groups that have mass


class _Reader:
    """Reads attributes and numbers of one model (``source`` in messages), with its
    <default> classes; ``compiler`` is read first."""

    def __init__(self, source: str, root):
        self.source = source
        self.defaults: dict[str, dict[str, dict[str, str]]] = {"main": {}}
        for top in root.findall("default"):         # several (from includes) add up
            self._defaults(top, self.defaults["main"], "main")
        self.compiler = self._compiler(root)

    def error(self, where: str | None, message: str) -> ModelError:
        return ModelError(message, source=self.source, path=where)

    # -- defaults and compiler -------------------------------------------------------
    def _defaults(self, element, inherited: dict, name: str) -> None:
        if name in self.defaults and name != "main":
            raise self.error(f"<default class={name!r}>", "a class of this name exists already")
        own = {tag: dict(values) for tag, values in inherited.items()}
        for child in element:
            if child.tag == "default":
                continue
            tag = "actuator" if child.tag in ACTUATOR_TAGS else child.tag
            own.setdefault(tag, {}).update(child.attrib)
            if tag == "actuator":
                own.setdefault(child.tag, {}).update(child.attrib)
        self.defaults[name] = own
        for child in element.findall("default"):
            if not child.get("class"):
                raise self.error("<default>", 'a nested <default> needs class="..."')
            self._defaults(child, own, child.get("class"))

    def _compiler(self, root) -> Compiler:
        values = {}
        for element in root.findall("compiler"):
            values.update(element.attrib)
        where = "<compiler>"
        angle = values.get("angle", "degree")
        if angle not in ("degree", "radian"):
            raise self.error(where, f'angle="{angle}": expected degree or radian')
        seq = values.get("eulerseq", "xyz")
        if len(seq) != 3 or any(c not in "xyzXYZ" for c in seq):
            raise self.error(where, f'eulerseq="{seq}": expected three of x y z X Y Z')
        if values.get("coordinate", "local") != "local":
            raise self.error(where, f'coordinate="{values["coordinate"]}": only local '
                                    "coordinates exist in MuJoCo 2.3.3 and later")
        fromgeom = values.get("inertiafromgeom", "auto")
        if fromgeom not in ("true", "false", "auto"):
            raise self.error(where, f'inertiafromgeom="{fromgeom}": expected true, false or auto')
        if values.get("balanceinertia") == "true":
            raise self.error(where, 'balanceinertia="true": anadyn keeps inertias as given; '
                                    "correct them in the file")
        number = lambda key, default: float(self.numbers(  # noqa: E731
            _Attributes(values, "compiler"), key, 1, where, default)[0])
        return Compiler(angle == "degree", seq, fromgeom,
                        values.get("autolimits", "true") == "true",
                        number("boundmass", "0"), number("boundinertia", "0"),
                        number("settotalmass", "-1"),
                        tuple(self.numbers(_Attributes(values, "compiler"), "inertiagrouprange",
                                           2, where, "0 5")))

    # -- attributes --------------------------------------------------------------------
    def get(self, element, key: str, cls: str = "main") -> str | None:
        """The attribute as MuJoCo resolves it: the element's own, else the default of
        its class (its ``class``, else ``cls``) for its tag."""
        value = element.get(key)
        if value is not None:
            return value
        cls = element.get("class", cls)
        if cls not in self.defaults:
            raise self.error(self.where(element), f'class="{cls}": no <default> of this class')
        for name in (element.tag, "actuator" if element.tag in ACTUATOR_TAGS else None):
            found = self.defaults[cls].get(name, {}).get(key) if name else None
            if found is not None:
                return found
        return None

    @staticmethod
    def where(element) -> str:
        name = element.get("name")
        return f"{element.tag} {name!r}" if name else f"<{element.tag}>"

    def numbers(self, element, key: str, count, where: str, default: str | None = None,
                cls: str = "main") -> np.ndarray:
        """``count`` numbers (an int, or a (least, most) range) of the attribute."""
        text = self.get(element, key, cls)
        text = default if text is None else text
        least, most = (count, count) if isinstance(count, int) else count
        shown = f'{key}="{text}"'
        if text is None:
            raise self.error(where, f"needs the attribute {key}")
        words = text.split()
        if any(word.lower().lstrip("+-") in ("inf", "infinity", "nan") for word in words):
            raise self.error(where, f"{shown}: numbers must be finite")
        wanted = f"{least}" if least == most else f"{least} to {most}"
        odd = next((word for word in words if not DECIMAL.match(word)), None)
        if odd is not None:
            raise self.error(where, f"{shown}: {odd!r} is not a decimal number such as -1.5e-3; "
                                    f"expected {wanted} number{'s' if most > 1 else ''}")
        values = [float(word) for word in words]
        if not least <= len(values) <= most:
            raise self.error(where, f"{shown}: expected {wanted} number{'s' if most > 1 else ''}"
                                    f", got {len(values)}")
        if not all(math.isfinite(v) and abs(v) <= LARGEST for v in values):
            raise self.error(where, f"{shown}: out of range (at most {LARGEST:g} in size)")
        return np.array(values)

    def number(self, element, key: str, where: str, default: str | None = None,
               cls: str = "main") -> float:
        return float(self.numbers(element, key, 1, where, default, cls)[0])

    def word(self, element, key: str, allowed: tuple[str, ...], where: str, default: str,
             cls: str = "main") -> str:
        value = self.get(element, key, cls)
        value = default if value is None else value
        if value not in allowed:
            *words, last = allowed
            raise self.error(where, f'{key}="{value}": expected {", ".join(words)} or {last}')
        return value


class _Attributes:
    """A plain mapping read like an element of no class (the merged <compiler>
    attributes)."""

    def __init__(self, values: dict, tag: str):
        self.values, self.tag = values, tag

    def get(self, key, default=None):
        return self.values.get(key, default) if key != "class" else default
