"""anadyn compare: Lagrange against Kane, symbolically, numerically and along the motion."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from ..errors import ModelError
from .common import out_dir


def compare(
    robots: Optional[List[Path]] = typer.Argument(
        None, help="Robot descriptions (YAML or URDF files, or library names) [default: "
                   "every robots/*.yaml, else the library's].",
        show_default=False, metavar="ROBOT"),
    samples: int = typer.Option(200, "--samples", help="Random states for the numeric check."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random states."),
    tol: float = typer.Option(1e-9, "--tol", help="Numeric check: largest allowed "
                              "|lagrange - kane| relative to the size of M, F, B or ddq "
                              "at each state."),
    trajectory_tol: float = typer.Option(1e-7, "--trajectory-tol",
                                         help="Largest allowed difference of the simulated "
                                              "states (each scaled by max(1, |x|max))."),
    symbolic_terms: int = typer.Option(10000, "--symbolic-terms",
                                       help="Budget of the symbolic check in expanded terms "
                                            "per robot (bounds its time); 0 turns it off."),
    t_end: float = typer.Option(None, "--t-end", help="Horizon of the trajectory check in s "
                                                      "[default: from the file, else 10]."),
    out: Path = typer.Option(None, "--out", help="Output folder [default: results/NAME/; "
                                                 "comparing several robots, OUT/NAME/ for "
                                                 "each, OUT default results/]."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Derive both formulations and check that M, F, B, ddq and the simulated motion agree.

    Prints a table of every robot (the summary), writes compare.csv and
    compare.json to results/NAME/ of each robot; exit 1 on any difference beyond
    the printed tolerances, naming the robot and quantity.
    """
    import time

    from ..services import compare as service
    from ..model import load_robot

    start = time.perf_counter()
    models = [load_robot(p) for p in robot_files(robots)]
    if not robots:          # every shipped robot but those with a spherical joint
        from ..model.library import announce

        left = [m.name for m in models if m.spherical]
        models = [m for m in models if not m.spherical]
        if left:
            announce(f"left out (a spherical joint: name them to compare them; a floating "
                     f"base's closed forms are large): {', '.join(left)}")
    result = service.compare(models, samples=samples, seed=seed, rtol=tol,
                             trajectory_tol=trajectory_tol, symbolic_terms=symbolic_terms,
                             t_end=t_end, use_cache=cache)
    folder = (out_dir(out, models[0].name) if len(models) == 1      # several: a folder each
              else out if out is not None else Path("results"))     # in it (service.write)
    written = service.write(result, folder)
    typer.echo(service.settings_line(result))
    typer.echo(service.table(result))
    typer.echo(f"time: total {time.perf_counter() - start:.2f} s")
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    service.raise_if_failed(result)


def robot_files(paths) -> list[Path]:
    """The given files, or every robots/*.yaml, or (no robots/ here) the library's copy."""
    if paths:
        return [Path(p) for p in paths]
    found = sorted(Path("robots").glob("*.yaml"))
    if not found:
        from ..model import library

        found = library.shipped_yaml()
        if found:
            library.announce(f"no robots/*.yaml here: comparing the library's, in "
                             f"{found[0].parent}")
    if not found:
        raise ModelError("no robot files given and none in robots/*.yaml")
    return found
