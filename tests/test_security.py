"""Nothing in a robot file is ever run as Python.

Code-running payloads go into every expression-valued field of the shipped
robots (present ones, plus the optional ``rate`` and ``displacement`` where
the file leaves them out); the command line must refuse each with exit 2 and
one line naming the field, and nothing may happen: no MARKER file, and an
audit hook (``sys.addaudithook``) sees no process started, no MARKER opened
and no code compiled from a string executed.

Cost: a CLI run takes ~50 ms, so the full product (118 fields x 25 payloads)
is split: every field once with a payload taken in turn, every
payload in six fields of different kinds on the command line, and every
payload against the expression parser directly with every name allowed.
A static check of anadyn's source completes the picture.
"""
from __future__ import annotations

import ast
import copy
import sys
from pathlib import Path

import pytest
import sympy as sp
import yaml

from anadyn_cli.cli import main
from anadyn_cli.model import expressions

REPO = Path(__file__).resolve().parent.parent
ROBOTS = {name: (REPO / "robots" / f"{name}.yaml").read_text()
          for name in ("rr", "rrt", "rrt_friction")}

PAYLOADS = [
    "__import__('os').system('touch MARKER')",
    "open('MARKER', 'w')",
    "open('{tmp}/MARKER_ABSOLUTE', 'w').write('x')",
    "().__class__.__bases__[0].__subclasses__()",
    "[c for c in ().__class__.__base__.__subclasses__() if c.__name__ == 'Popen']",
    "(lambda: open('MARKER', 'w'))()",
    "getattr(q1, '__class__')",
    "q1.__class__",
    "sin.__globals__['__builtins__']['open']('MARKER', 'w')",
    "'MARKER' * 10",
    "[open('MARKER', 'w')][0]",
    "__builtins__",
    "__import__",
    "eval(\"open('MARKER', 'w')\")",
    "exec(\"open('MARKER', 'w')\")",
    "compile('open(1)', 'MARKER', 'exec')",
    "breakpoint()",
    "globals()",
    "sin(open('MARKER', 'w'))",
    "max(1, *open('MARKER', 'w'))",
    "sqrt(**{'MARKER': 1})",
    "1 if open('MARKER', 'w') else 0",
    "(marker := open('MARKER', 'w'))",
    "f\"{open('MARKER', 'w')}\"",
    "b'MARKER'",
]
#: fields that get every payload on the command line (robot, key path)
CROSS = [("rr", "parameters.L1"), ("rr", "bodies[1].joint.displacement"),
         ("rr", "controller.laws.T12z"), ("rrt", "bodies[2].inertia.ixx"),
         ("rrt", "trajectory.to.q3"), ("rrt", "simulation.t_end")]


# -- the fields ---------------------------------------------------------------------------
def expression_fields(data: dict) -> list[tuple[tuple, str]]:
    """(keys into the parsed file, key path as anadyn names it) of every field
    whose value is an expression, following the README's table."""
    fields: list[tuple[tuple, str]] = []

    def add(keys: tuple, name: str) -> None:
        fields.append((keys, name))

    for key in data.get("parameters", {}):
        add(("parameters", key), f"parameters.{key}")
    for i, _ in enumerate(data.get("gravity", [])):
        add(("gravity", i), f"gravity[{i}]")
    for name in data["coordinates"]:
        for key in ("initial", "rate"):               # rate: optional, absent in both files
            add(("coordinates", name, key), f"coordinates.{name}.{key}")
    for b, body in enumerate(data["bodies"]):
        joint = body["joint"]
        for key in ("axis", "origin", "rpy"):
            for i, _ in enumerate(joint.get(key, [])):
                add(("bodies", b, "joint", key, i), f"bodies[{b}].joint.{key}[{i}]")
        if joint["type"] != "fixed":                  # displacement: optional, absent in rrt
            add(("bodies", b, "joint", "displacement"), f"bodies[{b}].joint.displacement")
        for key in ("damping", "friction", "friction_velocity", "stiffness", "rest"):
            if key in joint:                          # joint forces: rrt_friction
                add(("bodies", b, "joint", key), f"bodies[{b}].joint.{key}")
        add(("bodies", b, "mass"), f"bodies[{b}].mass")
        for i, _ in enumerate(body.get("com", [])):
            add(("bodies", b, "com", i), f"bodies[{b}].com[{i}]")
        for key in body.get("inertia", {}):
            add(("bodies", b, "inertia", key), f"bodies[{b}].inertia.{key}")
    controller = data.get("controller", {})
    for section in ("gains", "laws"):
        for key in controller.get(section, {}):
            add(("controller", section, key), f"controller.{section}.{key}")
    trajectory = data.get("trajectory", {})
    if "duration" in trajectory:
        add(("trajectory", "duration"), "trajectory.duration")
    for section in ("from", "to", "expressions"):
        for key in trajectory.get(section, {}):
            add(("trajectory", section, key), f"trajectory.{section}.{key}")
    for key in ("t_end", "output_step", "rtol", "atol"):
        if key in data.get("simulation", {}):
            add(("simulation", key), f"simulation.{key}")
    for k, load in enumerate(data.get("loads", [])):
        for key in ("point", "force", "torque"):
            for i, _ in enumerate(load.get(key, [])):
                add(("loads", k, key, i), f"loads[{k}].{key}[{i}]")
    return fields


FIELDS = [(robot, keys, name) for robot, text in ROBOTS.items()
          for keys, name in expression_fields(yaml.safe_load(text))]


def with_value(robot: str, keys: tuple, value: object) -> str:
    """The robot's text with the field at ``keys`` set to ``value``."""
    data = copy.deepcopy(yaml.safe_load(ROBOTS[robot]))
    target = data
    for key in keys[:-1]:
        target = target[key]
    target[keys[-1]] = value
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=1000)


def line_of(text: str, keys: tuple) -> int:
    """1-based line of the field at ``keys``, from PyYAML's own nodes: the key's
    line for a mapping entry, the item's line for a list entry."""
    node, line = yaml.compose(text), None
    for key in keys:
        if isinstance(node, yaml.MappingNode):
            key_node, node = next((k, v) for k, v in node.value if k.value == key)
            line = key_node.start_mark.line + 1
        else:
            node = node.value[key]
            line = node.start_mark.line + 1
    return line


# -- watching for side effects ---------------------------------------------------------------
WATCH = {"armed": False, "seen": []}
STARTS_PROCESS = {"os.system", "os.exec", "os.spawn", "os.posix_spawn", "os.fork",
                  "os.forkpty", "subprocess.Popen", "pty.spawn", "socket.connect",
                  "ctypes.dlopen", "webbrowser.open", "pdb.Pdb"}
TELLTALE = {"MARKER", "MARKER_ABSOLUTE", "open", "system", "__import__", "eval", "exec",
            "getattr", "__subclasses__", "__builtins__", "__globals__", "breakpoint", "globals",
            "compile"}


def _names(code) -> set[str]:
    found = set(code.co_names) | {c for c in code.co_consts if isinstance(c, str)}
    for const in code.co_consts:
        if hasattr(const, "co_names"):
            found |= _names(const)
    return found


def _audit(event: str, args: tuple) -> None:
    if not WATCH["armed"]:
        return
    if event in STARTS_PROCESS:
        WATCH["seen"].append(event)
    elif event == "open" and Path(str(args[0])).name.startswith("MARKER"):
        WATCH["seen"].append(f"open {args[0]}")
    elif event == "exec" and hasattr(args[0], "co_filename"):
        code = args[0]                # code compiled from a string, not a module being imported
        if code.co_filename.startswith("<") and _names(code) & TELLTALE:
            WATCH["seen"].append(f"exec of {code.co_filename}: {sorted(_names(code) & TELLTALE)}")


sys.addaudithook(_audit)              # stays for the session; does nothing unless armed


@pytest.fixture
def watched(tmp_path, monkeypatch):
    """cwd = tmp_path, a private cache; afterwards: no MARKER, no audited side effect."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    WATCH["seen"].clear()
    WATCH["armed"] = True
    try:
        yield tmp_path
    finally:
        WATCH["armed"] = False
    assert WATCH["seen"] == []
    assert not list(tmp_path.rglob("MARKER*"))
    assert not list(REPO.glob("MARKER*")) and not list(Path.cwd().glob("MARKER*"))


def refused(capsys, tmp: Path, robot: str, keys: tuple, name: str, payload: str) -> str:
    """Run ``anadyn equations`` with ``payload`` in the field; return the message."""
    text = with_value(robot, keys, payload.replace("{tmp}", str(tmp)))
    path = tmp / f"{robot}.yaml"
    path.write_text(text)
    code = main(["equations", str(path)])
    out, err = capsys.readouterr()
    head = f"anadyn: error: {path}:{line_of(text, keys)}: {name}: "
    assert err.startswith(head) and err.endswith("\n") and err.count("\n") == 1, err
    assert (code, out) == (2, ""), err
    return err[len(head):]


# -- the shipped robots, every field ---------------------------------------------------------
def test_every_field_is_found():
    """The field list is not silently short (the README's keys, in both files)."""
    names = {(robot, name) for robot, _, name in FIELDS}
    assert len(FIELDS) == len(names) == 48 + 70 + 89
    for expected in [("rr", "gravity[1]"), ("rr", "coordinates.q2.rate"),
                     ("rr", "bodies[1].joint.origin[0]"), ("rr", "bodies[0].inertia.izz"),
                     ("rr", "controller.gains.q2f"), ("rr", "trajectory.duration"),
                     ("rrt", "bodies[0].joint.displacement"), ("rrt", "bodies[2].mass"),
                     ("rrt", "controller.laws.F23z"), ("rrt", "simulation.output_step"),
                     ("rrt_friction", "bodies[2].joint.friction_velocity"),
                     ("rrt_friction", "bodies[1].joint.rest"),
                     ("rrt_friction", "loads[0].force[1]"), ("rrt_friction", "loads[0].point[2]"),
                     *CROSS]:
        assert expected in names


@pytest.mark.parametrize("index", range(len(FIELDS)),
                         ids=[f"{robot}:{name}" for robot, _, name in FIELDS])
def test_payload_in_every_field(capsys, watched, index):
    robot, keys, name = FIELDS[index]
    refused(capsys, watched, robot, keys, name, PAYLOADS[index % len(PAYLOADS)])


@pytest.mark.parametrize("payload", PAYLOADS)
@pytest.mark.parametrize("robot, name", CROSS)
def test_every_payload_in_fields_of_each_kind(capsys, watched, robot, name, payload):
    keys = next(k for r, k, n in FIELDS if (r, n) == (robot, name))
    refused(capsys, watched, robot, keys, name, payload)


@pytest.mark.parametrize("payload", PAYLOADS)
def test_every_payload_is_refused_wherever_every_name_is_allowed(payload, tmp_path):
    """Where a field's names come from does not matter: even with every name
    of both robots (and t, the rates) allowed, no payload parses."""
    names = {}
    for text in ROBOTS.values():
        data = yaml.safe_load(text)
        for key in [*data["parameters"], *data["controller"]["gains"], "t",
                    *data["coordinates"], *(f"d{c}" for c in data["coordinates"])]:
            names[key] = sp.Symbol(key, real=True)
    with pytest.raises(expressions.ExpressionError):
        expressions.parse(payload.replace("{tmp}", str(tmp_path)), names)


def test_payloads_are_dangerous_python():
    """The payloads would do harm if evaluated: each is valid Python, most
    name something that runs code (a test of the test)."""
    for payload in PAYLOADS:
        ast.parse(payload, mode="eval")
    assert sum(any(word in payload for word in ("open", "system", "eval", "exec",
                                                "__subclasses__", "breakpoint"))
               for payload in PAYLOADS) >= 15


def test_the_watch_sees_code_run(tmp_path, monkeypatch):
    """A test of the test: running a payload for real is caught by the audit hook."""
    monkeypatch.chdir(tmp_path)
    WATCH["seen"].clear()
    WATCH["armed"] = True
    try:
        eval(compile("open('MARKER', 'w').close()", "<payload>", "eval"))  # noqa: S307
    finally:
        WATCH["armed"] = False
    assert (tmp_path / "MARKER").exists()
    assert WATCH["seen"] and WATCH["seen"][0].startswith("exec of <payload>")
    assert any(seen.startswith("open") for seen in WATCH["seen"])


# -- text that is not an expression, and the generated code ----------------------------------
def test_text_fields_and_file_names_never_reach_generated_code(capsys, watched):
    """The description is text, the file name goes into the header of the generated
    module: both stay inert through simulate and inverse (which compile code)."""
    tmp = watched
    text = ROBOTS["rr"].replace(
        "description: Planar two-bar arm, absolute angles (chapter 6.3)",
        "description: \"\\\"\\\"\\\"\\nimport os; os.system('touch MARKER')\\n#\"")
    folder = tmp / "a\nimport os; os.system('touch MARKER')\n\"\"\"\n"
    folder.mkdir()
    path = folder / "rr\nopen('MARKER', 'w')\n.yaml"
    path.write_text(text)
    assert yaml.safe_load(text)["description"].startswith('"""\nimport os')
    code = main(["simulate", str(path), "--t-end", "0.1", "--dt", "0.05", "--out",
                 str(tmp / "out"), "--no-plot", "--no-cache"])
    assert code == 0, capsys.readouterr().err
    code = main(["inverse", str(path), "--dt", "0.5", "--out", str(tmp / "out"), "--no-plot",
                 "--no-roundtrip", "--no-cache"])
    assert code == 0, capsys.readouterr().err
    assert (tmp / "out" / "simulate.csv").exists() and (tmp / "out" / "inverse.csv").exists()


# -- anadyn's own source -------------------------------------------------------------------
def calls_and_names(path: Path):
    """(name, line) of every call and every name or attribute in ``path``."""
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else (
                func.attr if isinstance(func, ast.Attribute) else None)
            if name:
                yield "call", name, node, node.lineno
        elif isinstance(node, ast.Name):
            yield "name", node.id, node, node.lineno
        elif isinstance(node, ast.Attribute):
            yield "name", node.attr, node, node.lineno


SOURCES = sorted((REPO / "anadyn_cli").rglob("*.py"))


def test_source_never_evaluates_text():
    """No eval, sympify, parse_expr or unsafe YAML loading anywhere in anadyn;
    exec only on anadyn's own generated modules, marshal only on their sealed bytecode."""
    assert len(SOURCES) > 30
    forbidden_calls = {"eval", "sympify", "S", "parse_expr", "__import__", "unsafe_load",
                       "full_load", "load_all", "unsafe_load_all", "full_load_all"}
    forbidden_names = {"Loader", "FullLoader", "UnsafeLoader", "CLoader", "CFullLoader",
                       "CUnsafeLoader", "UnsafeConstructor", "FullConstructor", "pickle",
                       "marshal", "parse_expr"}
    found, execs, marshalled = [], [], []
    for path in SOURCES:
        where = path.relative_to(REPO).as_posix()
        for kind, name, node, line in calls_and_names(path):
            if kind == "call" and name in forbidden_calls:
                found.append(f"{where}:{line}: {name}(")
            elif kind == "call" and name == "load" and isinstance(node.func, ast.Attribute) \
                    and getattr(node.func.value, "id", None) == "yaml":
                found.append(f"{where}:{line}: yaml.load(")
            elif kind == "name" and name in forbidden_names:
                if (where, name) == ("anadyn_cli/numeric/cache.py", "marshal"):
                    marshalled.append(line)   # the bytecode of generated code, sealed
                else:
                    found.append(f"{where}:{line}: {name}")
            elif kind == "call" and name == "exec":
                source = ast.unparse(node)
                execs.append((where, source))
    assert found == []
    # marshal only in cache.compiled: the code objects of anadyn's own generated source,
    # read back through the sealed, owner-only cache reader (_read_sealed) like every entry
    compiled = next(n for n in ast.walk(ast.parse((REPO / "anadyn_cli/numeric/cache.py")
                                                  .read_text()))
                    if isinstance(n, ast.FunctionDef) and n.name == "compiled")
    assert marshalled and all(compiled.lineno <= line <= compiled.end_lineno
                              for line in marshalled)
    assert "_read_sealed(" in ast.unparse(compiled)
    assert sorted(where for where, _ in execs) == ["anadyn_cli/numeric/frames.py",
                                                   "anadyn_cli/numeric/model.py",
                                                   "anadyn_cli/numeric/trajectory.py"]
    for where, source in execs:                # exec(compile(<generated source>, "<anadyn ...>"))
        assert source.startswith(("exec(compile(source, '<anadyn ",      # or via the cache:
                                  "exec(compiled(source, '<anadyn ")), (where, source)


def test_the_static_check_finds_what_it_looks_for(tmp_path):
    """A test of the test: the walker sees a call hidden in ordinary code, not in text."""
    sample = tmp_path / "sample.py"
    sample.write_text("import yaml, sympy\n# eval( in a comment\nx = 'sympify( in text'\n"
                      "y = sympy.sympify(x)\nz = yaml.load(x, Loader=yaml.FullLoader)\n")
    seen = {(kind, name, line) for kind, name, _, line in calls_and_names(sample)}
    assert ("call", "sympify", 4) in seen and ("call", "load", 5) in seen
    assert ("name", "FullLoader", 5) in seen
    assert not any(name == "eval" for _, name, _ in seen)
