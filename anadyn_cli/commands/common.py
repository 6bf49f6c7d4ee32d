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


def out_dir(out: Path | None, robot_name: str) -> Path:
    return out if out is not None else Path("results") / robot_name


FormulationOpt = typer.Option(Method.kane, "--formulation", help="Formulation to integrate.")
OutOpt = typer.Option(None, "--out", help="Output folder [default: results/NAME/].")
