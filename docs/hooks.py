"""MkDocs hook: the command-line reference, generated from the commands themselves.

A page holding the line ``<!-- cli-reference -->`` gets, in its place, what
``anadyn --help`` and ``anadyn CMD --help`` print for every command registered
on the typer app (``anadyn_cli.commands.COMMANDS``), run through
``anadyn_cli.cli.main`` at 80 columns (what the page's code boxes show without
scrolling), so the reference cannot drift from the code.  tests/test_docs.py
checks that every command is there.
"""
from __future__ import annotations

import contextlib
import io
import os

MARKER = "<!-- cli-reference -->"
COLUMNS = "80"


def command_names() -> list[str]:
    """The commands as the CLI registers them, in its order."""
    import typer

    from anadyn_cli import cli

    cli._register_commands()
    return list(typer.main.get_command(cli.app).commands)


def help_text(argv: list[str]) -> str:
    """What ``anadyn ARGV --help`` prints at 80 columns."""
    from anadyn_cli.cli import main

    printed, saved = io.StringIO(), os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = COLUMNS
    try:
        with contextlib.redirect_stdout(printed):
            main([*argv, "--help"])
    finally:
        if saved is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = saved
    return printed.getvalue()


def help_sections() -> str:
    """Markdown: ``anadyn --help``, then one section per command."""
    parts = []
    for argv in ([], *([name] for name in command_names())):
        title = " ".join(["anadyn", *argv])
        parts += [f"## {title}", "", "```text", help_text(argv).rstrip("\n"), "```", ""]
    return "\n".join(parts)


def on_page_markdown(markdown: str, page, config, files) -> str:   # noqa: ARG001  (MkDocs' signature)
    """Replace the marker by the generated reference (other pages pass unchanged)."""
    return markdown.replace(MARKER, help_sections()) if MARKER in markdown else markdown
