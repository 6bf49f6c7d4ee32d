"""Arguments and options shared by the commands."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

RobotArg = typer.Argument(..., help="Robot description (YAML).", show_default=False)


class Method(str, Enum):
    kane = "kane"
    lagrange = "lagrange"


class Format(str, Enum):
    text = "text"
    latex = "latex"


def time_line(timings: dict, start: float) -> str:
    """``time: load 0.081 s, cache miss, ...; total 2.076 s`` (start from perf_counter)."""
    import time

    split = ", ".join(f"{k} {v:.3f} s" if isinstance(v, float) else f"{k} {v}"
                      for k, v in timings.items())
    return f"time: {split}; total {time.perf_counter() - start:.3f} s"


def out_dir(out: Path | None, robot_name: str) -> Path:
    return out if out is not None else Path("results") / robot_name


FormulationOpt = typer.Option(Method.kane, "--formulation", help="Formulation to integrate.")


def _usable_out(out: Path | None) -> Path | None:
    """--out is checked when the command line is read, before any computation."""
    if out is not None:
        from ..output.files import check_dir
        check_dir(out)
    return out


OutOpt = typer.Option(None, "--out", help="Output folder [default: results/NAME/].",
                      callback=_usable_out)
