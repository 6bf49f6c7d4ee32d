"""The documentation: the site builds with warnings as errors, and every code block in it
(docs/**/*.md and README.md) runs.

A fenced block's language says what happens to it; an HTML comment on the line
right before the fence, ``<!-- docs-test: WORD WORD=VALUE ... -->``, adds to it:

* ``sh``: each line is a command, run in the page's folder (a fresh temporary
  folder per page holding links to the repository's ``robots/`` and ``configs/``,
  shared by the page's blocks in order).  ``anadyn ...`` runs through
  ``anadyn_cli.cli.main`` (``> FILE`` sends its output to FILE); other programs
  (a compiler, ``./arm``) run as processes; a line whose program is one of
  ``OPTIONAL_PROGRAMS`` and not installed is skipped with the rest of its ``&&``
  chain, any other missing program fails.  ``exit=N``: every
  command of the block must end with N (default 0).
* ``python``: executed in a fresh namespace, in the page's folder.
* ``yaml``: ``robot`` (a complete robot file: loaded and validated),
  ``robot=PATH`` (also equal to that shipped file), ``overlay=PATH`` (top-level
  keys replacing those of the shipped robot PATH, then validated), or ``batch``
  (a batch file, read by ``anadyn batch``'s loader).
* ``file=NAME`` (any language): the block is also written to NAME in the page's folder.
* ``text``: output, a synopsis or other text; not run.  ``output``: equal to what
  the block before it printed (when it ran in full).
* ``norun``: not run (kept for the few blocks that cannot run here: installing,
  starting a cluster).  ``slow``: run only with ``-m slow``.

Any other language, or a fence without one, fails the test: a block nobody runs
must say so; an indented code block (which no fence marks) fails
``test_every_code_block_is_fenced``.  docs/explanation/about-the-docs.md says the same
for writers.
"""
from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parent.parent
DOCS = REPO / "docs"
PAGES = sorted(DOCS.rglob("*.md")) + [REPO / "README.md"]
MARK = re.compile(r"^\s*<!--\s*docs-test:(.*?)-->\s*$")
FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
LANGUAGES = {"sh", "python", "yaml", "c", "text"}
OPTIONAL_PROGRAMS = {"gcc", "cc", "pdflatex", "octave", "ffmpeg"}   # skipped where missing


@dataclass
class Block:
    page: Path
    line: int            # 1-based line of the opening fence
    language: str
    text: str
    marks: dict = field(default_factory=dict)

    def where(self) -> str:
        return f"{self.page.relative_to(REPO)}:{self.line}"


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of ``page``, in order, with the marks written before each."""
    found, lines, k = [], page.read_text(encoding="utf-8").split("\n"), 0
    while k < len(lines):
        opening = FENCE.match(lines[k])
        if not opening:
            k += 1
            continue
        indent = opening[1]
        end = next(j for j in range(k + 1, len(lines)) if lines[j].rstrip() == indent + "```")
        marks = {}
        mark = MARK.match(lines[k - 1]) if k else None
        for word in (mark[1].split() if mark else []):
            key, _, value = word.partition("=")
            marks[key] = value or True
        text = "\n".join(line[len(indent):] for line in lines[k + 1:end]) + "\n"
        found.append(Block(page, k + 1, opening[2], text, marks))
        k = end + 1
    return found


def runs_in_default(block: Block) -> bool:
    return "slow" not in block.marks


# -- running one block ---------------------------------------------------------------------
def commands(text: str) -> list[list[str]]:
    """The command lines of a shell block, continuation lines joined, comments dropped."""
    joined = re.sub(r"\\\n", " ", text)
    return [words for line in joined.split("\n") if (words := shlex.split(line, comments=True))]


def chains(words: list[str]) -> list[list[str]]:
    """``a && b`` as [a, b]."""
    parts, current = [], []
    for word in words:
        if word == "&&":
            parts.append(current)
            current = []
        else:
            current.append(word)
    return [*parts, current]


def run_anadyn(argv: list[str]) -> tuple[int, str, str]:
    from anadyn_cli.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def run_shell(block: Block, folder: Path) -> str | None:
    """What the block's commands printed, None if a program was missing."""
    expected, printed = int(block.marks.get("exit", 0)), ""
    for words in commands(block.text):
        for command in chains(words):
            target = None
            if ">" in command:
                at = command.index(">")
                command, target = command[:at], folder / command[at + 1]
            if command[0] == "anadyn":
                code, out, err = run_anadyn(command[1:])
            elif command[0].startswith("./") or shutil.which(command[0]):
                done = subprocess.run(command, cwd=folder, capture_output=True, text=True,
                                      timeout=300, check=False)
                code, out, err = done.returncode, done.stdout, done.stderr
            else:
                assert command[0] in OPTIONAL_PROGRAMS, f"{block.where()}: no program {command[0]}"
                printed = None                       # not installed here: skip the chain
                break
            assert code == expected, f"{block.where()}: {shlex.join(command)} -> {code}\n{err}"
            if target is not None:
                target.write_text(out, encoding="utf-8")
            elif printed is not None:
                printed += out
    return printed


def check_yaml(block: Block, folder: Path) -> None:
    import anadyn
    from anadyn_cli.studies.batch import load_batch

    data = yaml.safe_load(block.text)
    name = block.marks.get("file") or "docs_example.yaml"
    path = folder / name
    if "robot" in block.marks:
        if block.marks["robot"] is not True:
            assert block.text == (REPO / block.marks["robot"]).read_text(encoding="utf-8"), \
                f"{block.where()}: differs from {block.marks['robot']}"
        path.write_text(block.text, encoding="utf-8")
        anadyn.load(path)
    elif "overlay" in block.marks:
        base = yaml.safe_load((REPO / block.marks["overlay"]).read_text(encoding="utf-8"))
        path.write_text(yaml.safe_dump({**base, **data}), encoding="utf-8")
        anadyn.load(path)
    elif "batch" in block.marks:
        path.write_text(block.text, encoding="utf-8")
        assert load_batch(path).jobs
    else:
        raise AssertionError(f"{block.where()}: a yaml block needs robot, overlay, batch or norun")


def run_block(block: Block, folder: Path) -> str | None:
    """Run or check one block; what it printed (None: nothing to compare)."""
    if "file" in block.marks:
        (folder / block.marks["file"]).parent.mkdir(parents=True, exist_ok=True)
        (folder / block.marks["file"]).write_text(block.text, encoding="utf-8")
    if block.language == "sh":
        return run_shell(block, folder)
    if block.language == "python":
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            exec(compile(block.text, block.where(), "exec"), {"__name__": "__docs__"})  # noqa: S102  our own docs
        return printed.getvalue()
    if block.language == "yaml":
        check_yaml(block, folder)
    return None


def run_page(page: Path, folder: Path, monkeypatch, slow: bool) -> int:
    """Run the blocks of ``page`` in order in ``folder``; how many ran."""
    for name in ("robots", "configs"):
        (folder / name).symlink_to(REPO / name)
    monkeypatch.chdir(folder)
    monkeypatch.syspath_prepend(str(folder))
    import matplotlib

    backend, ran, printed = matplotlib.get_backend(), 0, None
    for block in blocks(page):
        if block.language == "text" and "output" in block.marks and printed is not None:
            assert printed == block.text, f"{block.where()}: the block before printed\n{printed}"
        if block.language == "text" or "norun" in block.marks \
                or not (slow or runs_in_default(block)):
            if block.language == "text" and "file" in block.marks:
                run_block(block, folder)                 # writes the file, runs nothing
            printed = None
            continue
        printed = run_block(block, folder)
        ran += 1
    assert matplotlib.get_backend() == backend
    for name, module in list(sys.modules.items()):      # modules the page's code wrote
        if folder.resolve() in Path(getattr(module, "__file__", None) or "/").resolve().parents:
            del sys.modules[name]
    return ran


# -- the tests --------------------------------------------------------------------------------
def page_id(page: Path) -> str:
    return str(page.relative_to(REPO))


@pytest.mark.parametrize("page", PAGES, ids=page_id)
def test_every_block_says_what_it_is(page):
    for block in blocks(page):
        assert block.language in LANGUAGES, \
            f"{block.where()}: fence language {block.language!r}; use one of {sorted(LANGUAGES)}"
        if block.language == "c":
            assert "file" in block.marks or "norun" in block.marks, f"{block.where()}: c needs file="


@pytest.mark.parametrize("page", PAGES, ids=page_id)
def test_the_blocks_of_a_page_run(page, tmp_path, monkeypatch):
    run_page(page, tmp_path, monkeypatch, slow=False)


SLOW_PAGES = [page for page in PAGES if not all(map(runs_in_default, blocks(page)))]


@pytest.mark.slow
@pytest.mark.parametrize("page", SLOW_PAGES, ids=page_id)
def test_the_slow_blocks_of_a_page_run(page, tmp_path, monkeypatch):
    run_page(page, tmp_path, monkeypatch, slow=True)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once by ``mkdocs build --strict``: a broken link or anchor, a page
    missing from the navigation or an API name that does not resolve is an error."""
    pytest.importorskip("mkdocs")
    folder = tmp_path_factory.mktemp("docs") / "site"
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet",
                           "--site-dir", str(folder)], cwd=REPO, capture_output=True, text=True,
                          timeout=600, check=False,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert done.returncode == 0, done.stderr
    return folder


def test_the_site_builds_strict(site):
    assert (site / "index.html").is_file() and (site / "reference" / "cli" / "index.html").is_file()


@pytest.mark.parametrize("page", sorted(DOCS.rglob("*.md")), ids=page_id)
def test_every_code_block_is_fenced(site, page):
    """Every <pre> of a hand-written page is a fenced block that the tests above run or
    declare: an indented code block would escape them."""
    text = page.read_text(encoding="utf-8")
    if "<!-- cli-reference -->" in text or "\n::: " in text:
        pytest.skip("generated content")
    html = site / page.relative_to(DOCS).with_suffix("") / "index.html"
    if page.name == "index.md":
        html = site / page.relative_to(DOCS).parent / "index.html"
    assert html.read_text(encoding="utf-8").count("<pre") == len(blocks(page))


def test_the_cli_reference_has_every_command():
    """docs/hooks.py inserts a section per command of ``COMMANDS`` with its --help."""
    sys.path.insert(0, str(DOCS))
    try:
        from hooks import help_sections
    finally:
        sys.path.remove(str(DOCS))
    from anadyn_cli.commands import COMMANDS

    text = help_sections()
    for command in COMMANDS:
        name = getattr(command, "cli_name", None) or command.__name__
        section = text.split(f"## anadyn {name}\n", 1)[1].split("## anadyn ", 1)[0]
        assert f"Usage: anadyn {name} " in section and "--help" in section, name
    assert "Usage: anadyn [OPTIONS] COMMAND" in text


def test_readme_stays_short_and_its_links_resolve():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.encode()) <= 10_500
    links = re.findall(r"\]\(([^)#]+)\)", text)
    assert links and all((REPO / link).is_file() for link in links), links
