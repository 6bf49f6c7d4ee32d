"""Arguments and options shared by the commands."""
from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

RobotArg = typer.Argument(..., help="Robot: a YAML or URDF file, or a library name (`anadyn "
                                         "robots` lists them).", show_default=False)


class Formulation(str, Enum):
    """How the symbolic equations are derived (never the integrator: that is --method)."""
    kane = "kane"
    lagrange = "lagrange"


class Evaluator(str, Enum):
    """What runs the numbers (``numeric.build``): the Newton-Euler recursions or the
    closed forms of a formulation."""
    recursive = "recursive"
    closed_form = "closed-form"


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
         "fragment": "--fragment", "formulation": "--formulation", "evaluator": "--evaluator",
         "seed": "--seed", "reference_calls": "--reference-calls", "frames": "--frames",
         "jobs": "--jobs", "settle_band": "--settle-band",
         "smoothing_window": "--smoothing-window", "smoothing_order": "--smoothing-order",
         "symbolic": "--symbolic", "goal": "--to", "start": "--from", "objective": "--minimize",
         "duration": "--duration", "intervals": "--intervals",
         "method": "--method", "vary": "--vary", "derivatives": "--derivatives",
         "parameters": "--parameter", "regressor": "--regressor", "contact_gap": "--contact-gap",
         "contact_resolution": "--contact-resolution"}
FLAGS.update(holdout="--holdout", period="--period", harmonics="--harmonics", margin="--margin",
             iterations="--iterations")  # identify, excite


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

FormulationOpt = typer.Option(None, "--formulation", case_sensitive=False, show_default=False,
                              help="Evaluate the closed forms of these equations: kane or "
                                   "lagrange [default: none with the recursive evaluator, "
                                   "else kane].")
EvaluatorOpt = typer.Option(None, "--evaluator", case_sensitive=False, show_default=False,
                            help="What runs the numbers: recursive (Newton-Euler recursions, "
                                 "open trees only) or closed-form (the formulation's M, F, B) "
                                 "[default: recursive on an open tree unless --formulation "
                                 "is given; closed-form (kane) on a closed chain].")
#: the formulation of commands that work on the closed forms only (no --evaluator)
SymbolicFormulationOpt = typer.Option(Formulation.kane, "--formulation", case_sensitive=False,
                                      help="Formulation of the symbolic equations: kane or "
                                           "lagrange.")


def prepared_model(robot: Path, formulation: Formulation | None, evaluator: Evaluator | None,
                   cache: bool, timings: dict | None = None):
    """The ``NumericModel`` a command runs (``numeric.build.numeric_model``), under a
    progress line."""
    from .. import progress
    from ..numeric.build import numeric_model

    what = (f"the {formulation.value} equations" if formulation is not None
            else "the recursive equations" if evaluator is Evaluator.recursive
            else "the equations")
    with progress.task(f"preparing {what}"):
        return numeric_model(robot, None if formulation is None else formulation.value,
                             use_cache=cache, timings=timings,
                             evaluator=None if evaluator is None else evaluator.value)


def _usable_out(out: Path | None) -> Path | None:
    """--out (or, not given, results/ that holds the default folders) is checked when the
    command line is read, before any computation."""
    from ..files import check_dir

    check_dir(out if out is not None else Path("results"),
              "--out" if out is not None else "output folder")
    return out


#: the Savitzky-Golay differentiator of measured positions (``numeric.measured``)
SmoothingWindowOpt = typer.Option(
    None, "--smoothing-window",
    help="Samples of the Savitzky-Golay differentiator that gives the measured motion's "
         "missing rates and accelerations (odd) [default: 21].")
SmoothingOrderOpt = typer.Option(
    None, "--smoothing-order", help="Its polynomial degree (2 to 10) [default: 3].")
OutOpt = typer.Option(None, "--out", help="Output folder [default: results/NAME/].",
                      callback=_usable_out)


def check_options(command):
    """Check ``command``'s options when the command line is read, before any work:
    each option whose flag sets a setting with a range (``errors.ALLOWED``, by
    ``FLAGS``) parses its text and refuses a value outside that range in one line
    (``--rtol must be a number greater than 0 and less than 1, got 1e+300``), and
    every ``--out`` is checked as a folder (``files.check_dir``).  Returns ``command``."""
    import inspect

    from typer.models import OptionInfo

    from ..errors import ALLOWED

    settings = {flag: setting for setting, flag in FLAGS.items() if setting in ALLOWED}
    for parameter in inspect.signature(command).parameters.values():
        option = parameter.default
        if not isinstance(option, OptionInfo):
            continue
        flags = [d for d in option.param_decls if d.startswith("--")] or [
            "--" + parameter.name.replace("_", "-")]
        if flags[0] == "--out" and option.callback is None:
            option.callback = _usable_out
        elif flags[0] in settings and option.parser is None:
            option.parser = _setting_parser(settings[flags[0]])
            option.metavar = option.metavar or ("INTEGER" if ALLOWED[settings[flags[0]]].whole
                                                else "FLOAT")
    return with_urdf_options(command)


# -- how a URDF is read: --fix-base, --inertia, --lock on every command that takes a robot ------
class InertiaPolicy(str, Enum):
    refuse = "refuse"
    repair = "repair"
    accept = "accept"


FixBaseOpt = typer.Option(False, "--fix-base",
                          help="URDF: weld the floating or planar joint that carries the root "
                               "link to the world, where its origin puts it (a URDF's root "
                               "link is fixed to the world in any case); MJCF: weld the free "
                               "joint of a body on the world body where the body is placed.")
FloatingBaseOpt = typer.Option(False, "--floating-base",
                               help="URDF: free the root link: a floating joint between the "
                                    "world and it (x, y, z, a unit quaternion; speeds dx, dy, "
                                    "dz in the world frame and the angular velocity in body "
                                    "axes), as Pinocchio's free-flyer root; without it the "
                                    "root link is fixed to the world, as URDF says.")
InertiaOpt = typer.Option(InertiaPolicy.refuse, "--inertia",
                          help="URDF: inertias that no rigid body has (not positive "
                               "semidefinite, or principal moments breaking I1 + I2 >= I3): "
                               "refuse them, repair them (nearest valid tensor), or accept them "
                               "as given (triangle inequality only); repair and accept are "
                               "stated in a warning.")
LockOpt = typer.Option(None, "--lock", metavar="JOINT=VALUE",
                       help="URDF: hold this joint at VALUE (rad or m; a number or an "
                            "expression such as pi/4): a reduced robot, the joint's child "
                            "folded into the body before it (repeatable).")
ContactsOpt = typer.Option(False, "--contacts",
                           help="MJCF: import the sphere, capsule and box geoms that can "
                                "touch a plane of the world as compliant contacts against it "
                                "(docs: how-to/mjcf); without it the robot has no contacts.")
#: parameter -> (type, option) of the URDF reading options (``model.urdf.ReadingOptions``)
URDF_OPTIONS = {"fix_base": (bool, FixBaseOpt), "floating_base": (bool, FloatingBaseOpt),
                "inertia": (InertiaPolicy, InertiaOpt), "lock": (Optional[List[str]], LockOpt),
                "contacts": (bool, ContactsOpt)}


def reading_options(fix_base: bool, inertia: InertiaPolicy, lock: list[str] | None,
                    floating_base: bool = False, contacts: bool = False):
    """The ``urdf.ReadingOptions`` of --fix-base, --inertia, the --lock texts,
    --floating-base and --contacts."""
    from ..model import urdf

    return urdf.ReadingOptions(fix_base, inertia.value,
                               tuple(urdf.parse_lock(text) for text in lock or ()),
                               floating_base, contacts)


def with_urdf_options(command):
    """``command`` with --fix-base, --inertia and --lock (URDF_OPTIONS) when it takes a
    robot (a ``robot`` or ``robots`` argument) and has no such options of its own: the
    URDF files it reads are read with them (``urdf.reading``), which changes the
    imported text and so the derivation cache's key.  Given for robots none of which
    is a URDF file, they are refused in one line."""
    import functools
    import inspect

    signature = inspect.signature(command)
    if not {"robot", "robots"} & set(signature.parameters) or "fix_base" in signature.parameters:
        return command

    @functools.wraps(command)
    def run(*args, fix_base=False, floating_base=False, inertia=InertiaPolicy.refuse,
            lock=None, contacts=False, **kwargs):
        from ..model import library, urdf

        options = reading_options(fix_base, inertia, lock, floating_base, contacts)
        robots = kwargs.get("robots") or [kwargs.get("robot")]
        if options.flags() and not any(
                r is not None and library.imports(library.resolve(r)) for r in robots):
            from ..errors import ModelError
            raise ModelError(f"{options.flags()}: these options say how a URDF file is read; "
                             f"{', '.join(map(str, robots))} is not a URDF file")
        with urdf.reading(options):
            return command(*args, **kwargs)

    added = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=option,
                               annotation=kind) for name, (kind, option) in URDF_OPTIONS.items()]
    run.__signature__ = signature.replace(parameters=[*signature.parameters.values(), *added])
    run.__annotations__ = {**command.__annotations__,
                           **{name: kind for name, (kind, _) in URDF_OPTIONS.items()}}
    return run


def _setting_parser(setting: str):
    from ..errors import check

    return lambda value: check(setting, value)


# -- figures for reports: --size, --title, --font-size on every command that plots --------
def _figure_size(value: str | None) -> tuple[float, float] | None:
    """--size WxH in inches (``6.4x4.8``), each side 1 to 50."""
    if value is None:
        return None
    from ..errors import ModelError

    width, sep, height = value.lower().replace(" ", "").partition("x")
    try:
        size = (float(width), float(height)) if sep else None
    except ValueError:
        size = None
    if size is None or not all(1 <= v <= 50 for v in size):
        raise ModelError(f"--size: expected WIDTHxHEIGHT in inches, each 1 to 50, e.g. "
                         f"6.4x4.8; got {value!r}")
    return size


def _font_size(value: float | None) -> float | None:
    if value is not None and not 4 <= value <= 40:
        from ..errors import ModelError
        raise ModelError(f"--font-size: expected 4 to 40 points, got {value:g}")
    return value


SizeOpt = typer.Option(None, "--size", metavar="WxH", callback=_figure_size,
                       help="Figure size in inches, e.g. 6.4x4.8 (PNG: 200 pixels an inch) "
                            "[default: fitted to the panels].")
TitleOpt = typer.Option(None, "--title", help="Figure title [default: ROBOT: COMMAND].")
FontSizeOpt = typer.Option(None, "--font-size", callback=_font_size,
                           help="Axis-label font size in points; the other texts scale with "
                                "it [default: 8-9].")


def figure_style(size, title: str | None, font_size: float | None):
    """The ``plots.FigureStyle`` of --size (already parsed), --title and --font-size."""
    from ..output.plots import FigureStyle

    return FigureStyle(size, title, font_size)


def echo_table(text: str, full: str) -> None:
    """Print ``text`` with its wide tables cut to the terminal's width
    (``tables.fit``); ``full`` names the file that has every column."""
    from ..output import tables

    typer.echo(tables.fit(text, tables.terminal_width(), full))


def echo_limits(exceeded: list, json_name: str) -> None:
    """The joint limits a run passed, as warnings on stderr: one line each for up to
    three, else one summary line (every one is in ``json_name``)."""
    from ..numeric.limits import lines

    found = lines(exceeded)
    if len(found) > 3:
        counts = {}
        for e in exceeded:
            counts[e.quantity] = counts.get(e.quantity, 0) + 1
        first = min(exceeded, key=lambda e: e.first_time)
        found = [f"{len(found)} joint limits exceeded ("
                 + ", ".join(f"{q} {k}" for q, k in counts.items())
                 + f"), first {first.name}'s {first.quantity} at t = "
                 f"{first.first_time:g} s; details in {json_name}"]
    for line in found:
        typer.echo(f"anadyn: warning: {line}", err=True)
