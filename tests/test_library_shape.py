"""The library's shape (issue 16): the import graph runs one way, services speak
the domain, the Python API example of the docs works as printed, and the bugs found
by the structural read stay fixed."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

from anadyn_cli import robot_from_text
from anadyn_cli.cli import main
from anadyn_cli.errors import SettingError

PACKAGE = Path(__file__).resolve().parent.parent / "anadyn_cli"
#: pipeline stages, in order; a module may import from its own stage or an earlier one
STAGES = {"errors": 0, "files": 0, "progress": 0, "model": 1, "symbolic": 2, "numeric": 3,
          "output": 4, "services": 5, "studies": 6, "api": 7, "commands": 7, "cli": 8,
          "plain_options": 8,
          "__main__": 9, "__init__": 9}


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> set[str]:
    """Every anadyn_cli module ``path`` imports, at the top or inside a function."""
    here = module_name(path)
    package = here if path.name == "__init__.py" else here.rsplit(".", 1)[0]
    found = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for guard in [n for n in ast.walk(tree) if isinstance(n, ast.If)
                  and getattr(n.test, "id", "") == "TYPE_CHECKING"]:
        guard.body = []                      # names for annotations only, never imported
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package.split(".")[: len(package.split(".")) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                candidate = f"{target}.{alias.name}"
                found.add(candidate if is_module(candidate) else target)
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("anadyn_cli"):
            found.add(node.module)
    return found


def is_module(name: str) -> bool:
    path = PACKAGE.parent.joinpath(*name.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def stage(module: str) -> int:
    parts = module.split(".")
    return STAGES[parts[1]] if len(parts) > 1 else STAGES["__init__"]


def test_imports_run_down_the_pipeline():
    """YAML -> model -> symbolic -> numeric -> output -> services -> studies -> commands
    -> CLI:
    no module imports from a later stage (so no cycle crosses a folder)."""
    backwards = []
    for path in sorted(PACKAGE.rglob("*.py")):
        here = module_name(path)
        for target in imports(path):
            if target.startswith("anadyn_cli.") and stage(target) > stage(here):
                backwards.append(f"{here} -> {target}")
    assert backwards == []


def test_services_side_by_side():
    """No service imports another (studies such as sweep run several)."""
    for path in sorted((PACKAGE / "services").glob("*.py")):
        others = {t for t in imports(path) if t.startswith("anadyn_cli.services.")}
        assert others == set(), path.name


def test_no_import_cycles_between_modules():
    graph = {module_name(p): {t for t in imports(p) if t.startswith("anadyn_cli")}
             for p in PACKAGE.rglob("*.py")}
    state: dict[str, int] = {}
    cycles = []

    def visit(node, trail):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if nxt == node or nxt not in graph or graph[nxt] is None:
                continue
            if state.get(nxt) == 1 and not node.startswith(nxt + "."):
                cycles.append(" -> ".join(trail[trail.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt, trail + [nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    # a package's __init__ naming its own modules is not a cycle
    assert [c for c in cycles if not re.fullmatch(r"([\w.]+) -> \1\.\w+ -> \1", c)] == []


def test_services_never_name_flags_or_switch_backends():
    for path in sorted((PACKAGE / "services").glob("*.py")):
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"""["'(]--[a-z]""", text), path.name
    for path in PACKAGE.rglob("*.py"):
        assert "matplotlib.use(" not in path.read_text(encoding="utf-8"), path.name
        assert not re.search(r"import.*pyplot|pyplot\.", path.read_text(encoding="utf-8")), \
            path.name


def test_a_wrong_setting_is_named_as_the_library_knows_it(tmp_path):
    import anadyn

    model = anadyn.numeric_model("robots/rr.yaml")
    with pytest.raises(SettingError) as caught:
        anadyn.simulate(model, output_step=0)
    assert str(caught.value) == "output_step must be a positive number, got 0"
    with pytest.raises(SettingError, match="^roundtrip_segment must be a positive number"):
        anadyn.inverse(model, roundtrip_segment=-1)


def test_the_command_line_names_its_flag(tmp_path, capsys):
    assert main(["simulate", "robots/rr.yaml", "--dt", "0", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err == "anadyn: error: --dt must be a positive number, got 0\n"


def test_library_calls_leave_the_cache_alone(tmp_path, monkeypatch):
    import anadyn

    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    anadyn.simulate("robots/rr.yaml", t_end=0.05)
    assert not (tmp_path / "cache").exists()
    anadyn.simulate("robots/rr.yaml", t_end=0.05, cache=True)
    assert len(list((tmp_path / "cache").glob("*.json"))) == 1     # one derivation entry


def test_the_python_api_example_runs_as_printed(repo, tmp_path, monkeypatch):
    """The first block of docs/reference/python-api.md, executed in a scratch folder
    (tests/test_docs.py runs every block; this one also checks what it writes)."""
    text = (repo / "docs" / "reference" / "python-api.md").read_text(encoding="utf-8")
    block = text.split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "robots").symlink_to(repo / "robots")
    import matplotlib

    backend = matplotlib.get_backend()
    exec(compile(block, "python-api.md", "exec"), {})    # noqa: S102  our own docs
    assert (tmp_path / "rr.csv").read_text().startswith("t,q1,q2,dq1,dq2,T01z,T12z\n")
    assert (tmp_path / "rr.png").stat().st_size > 10_000
    assert matplotlib.get_backend() == backend


def test_results_keep_rows_as_times():
    import anadyn

    run = anadyn.simulate("robots/rrt.yaml", t_end=0.5)
    assert run.x.shape == (len(run.t), 6) and run.efforts.shape == (len(run.t), 3)
    inverse = anadyn.inverse("robots/rrt.yaml", roundtrip=False, output_step=0.5)
    assert inverse.q.shape == (len(inverse.t), 3) and inverse.efforts.shape == (len(inverse.t), 3)


# -- the bugs found by the structural read -------------------------------------------------
def test_roundtrip_segment_is_accepted(tmp_path):
    """A local array once shadowed the validator: --roundtrip-segment 1 exited 4."""
    assert main(["inverse", "robots/rr.yaml", "--roundtrip-segment", "1", "--no-plot",
                 "--out", str(tmp_path)]) == 0


TWO_JOINTS = """
coordinates: {q1: {initial: 0.1}, q2: {initial: 0.2}}
bodies:
  - {name: a, parent: ground, joint: {type: revolute, axis: [0, 0, 1]%s},
     mass: 1, com: [0.5, 0, 0], inertia: {ixx: 0.1, iyy: 0.1, izz: 0.1}}
  - {name: b, parent: a, joint: {type: revolute, axis: [0, 0, 1], origin: [1, 0, 0]%s},
     mass: 1, com: [0.5, 0, 0], inertia: {ixx: 0.1, iyy: 0.1, izz: 0.1}}
"""


@pytest.mark.parametrize("first, second, expected", [
    ("", ", displacement: q1", ["q2", "q1"]),        # q1 is taken: a gets the next unused
    ("", "", ["q1", "q2"]),
    ("", ", displacement: q2 - q1", ["q1", "-q1 + q2"]),   # coupled: claims no coordinate
    (", displacement: q2", "", ["q2", "q1"]),
])
def test_a_default_displacement_takes_the_next_unused_coordinate(first, second, expected):
    robot = robot_from_text(TWO_JOINTS % (first, second), "two.yaml")
    assert [str(b.joint.displacement) for b in robot.bodies] == expected


PENDULUM = """
gravity: [0, -9.81, 0]
coordinates: {q1: {initial: 0.1}}
bodies:
  - {name: bar, parent: ground, joint: {type: revolute, axis: [0, 0, 1]},
     mass: 1, com: [0.5, 0, 0], inertia: {ixx: 0, iyy: 0.08, izz: 0.08}}
"""


def test_equations_of_a_passive_pendulum(tmp_path, capsys):
    """No actuators once made M ddq - F - B tau a 0x0 product and exit 4."""
    path = tmp_path / "pendulum.yaml"
    path.write_text(PENDULUM)
    assert main(["equations", str(path)]) == 0
    out = capsys.readouterr().out
    assert "ddq1" in out and "= 0" in out


def test_one_word_per_concept(capsys):
    """--formulation is how the equations are derived, --method the integrator."""
    assert main(["equations", "robots/rr.yaml", "--formulation", "lagrange"]) == 0
    capsys.readouterr()
    assert main(["equations", "robots/rr.yaml", "--method", "lagrange"]) == 2


def test_dead_code_is_gone():
    from anadyn_cli.model import expressions
    from anadyn_cli.model.robot import Coordinate
    from anadyn_cli.numeric.integrators import Stiffness

    assert not hasattr(Coordinate, "acceleration_symbol")
    assert not hasattr(expressions, "RESERVED")
    assert "slowest" not in Stiffness.__dataclass_fields__
    source = "".join(p.read_text(encoding="utf-8") for p in PACKAGE.rglob("*.py"))
    assert "bdf_fraction" not in source


def test_the_numeric_model_is_stateless():
    import anadyn

    model = anadyn.numeric_model("robots/rr.yaml")
    before = dict(vars(model))
    first = anadyn.simulate(model, t_end=0.2)
    second = anadyn.simulate(model, t_end=0.2)
    assert vars(model).keys() == before.keys()
    assert first.solution.rhs_calls == second.solution.rhs_calls > 0
    assert np.array_equal(first.x, second.x)
