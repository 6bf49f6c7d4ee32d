"""Arguments and options shared by the commands."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

RobotArg = typer.Argument(..., help="Robot: a YAML or URDF file, or a library name (`anadyn "
                                         "robots` lists them).", show_default=False)


class Formulation(str, Enum):
    """How the equations are derived (never the integrator: that is --method)."""
    kane = "kane"
    lagrange = "lagrange"


class Format(str, Enum):
    text = "text"
    latex = "latex"


class PlotFormat(str, Enum):
    png = "png"
    svg = "svg"
    pdf = "pdf"


PlotFormatOpt = typer.Option(PlotFormat.png, "--plot-format", case_sensitive=False,
                             help="Plot file format: png (200 dpi), svg or pdf.")


def integrator_name(value: str | None) -> str | None:
    """The integrator's own spelling of ``value`` (``rk45`` -> ``RK45``); a name
    that matches none is passed on as given, for the error that lists them."""
    if value is None:
        return None
    from ..numeric.integrators import METHODS

    return next((m for m in METHODS if m.lower() == value.strip().lower()), value)


#: run settings as the library names them -> the flags that set them
FLAGS = {"output_step": "--dt", "t_end": "--t-end", "rtol": "--rtol", "atol": "--atol",
         "roundtrip_tolerance": "--roundtrip-tol", "roundtrip_segment": "--roundtrip-segment",
         "max_condition": "--max-condition", "energy_tol": "--energy-tol",
         "samples": "--samples", "probe_calls": "--probe-calls", "repeats": "--repeats",
         "max_calls": "--max-calls", "numeric_tolerance": "--tol",
         "trajectory_tolerance": "--trajectory-tol", "symbolic_terms": "--symbolic-terms",
         "at": "--at", "efforts": "--efforts", "equilibrium": "--equilibrium",
         "fragment": "--fragment"}


def flag_message(setting: str, reason: str) -> str:
    """A setting's error in the command line's words: ``--dt must be ...``."""
    return f"{FLAGS.get(setting, setting)} {reason}"


def time_line(timings: dict, start: float) -> str:
    """``time: load 0.081 s, cache miss, ...; total 2.076 s`` (start from perf_counter)."""
    import time

    split = ", ".join(f"{k} {v:.3f} s" if isinstance(v, float) else f"{k} {v}"
                      for k, v in timings.items())
    return f"time: {split}; total {time.perf_counter() - start:.3f} s"


def out_dir(out: Path | None, robot_name: str) -> Path:
    return out if out is not None else Path("results") / robot_name


RtolOpt = typer.Option(None, help="Relative tolerance [default: from the file, else 1e-10].")
AtolOpt = typer.Option(None, help="Absolute tolerance [default: from the file, else 1e-12].")
TEndOpt = typer.Option(None, "--t-end", help="Horizon in s [default: from the file, else 10].")
DtOpt = typer.Option(None, "--dt", help="Output step in s [default: from the file, else 0.01].")
MethodOpt = typer.Option(None, help="Integrator (any case): auto, odeint, RK45, RK23, DOP853, "
                                    "Radau, BDF, LSODA [default: from the file, else auto].")

FormulationOpt = typer.Option(Formulation.kane, "--formulation", case_sensitive=False,
                              help="Formulation to integrate.")


def _usable_out(out: Path | None) -> Path | None:
    """--out is checked when the command line is read, before any computation."""
    if out is not None:
        from ..files import check_dir
        check_dir(out)
    return out


OutOpt = typer.Option(None, "--out", help="Output folder [default: results/NAME/].",
                      callback=_usable_out)
