"""anadyn inverse: the efforts that produce the file's prescribed motion."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import FormulationOpt, Method, OutOpt, RobotArg, out_dir, time_line


def inverse(
    robot: Path = RobotArg,
    formulation: Method = FormulationOpt,
    dt: float = typer.Option(None, "--dt", help="Output step in s (default: the file's "
                                                "simulation.output_step, else 0.01)."),
    out: Path = OutOpt,
    roundtrip: bool = typer.Option(True, "--roundtrip/--no-roundtrip",
                                   help="Integrate the direct dynamics driven by the "
                                        "efforts and check that it follows the motion."),
    roundtrip_tol: float = typer.Option(1e-6, "--roundtrip-tol",
                                        help="Largest allowed tracking error of the round "
                                             "trip, rad or m."),
    roundtrip_segment: float = typer.Option(
        None, "--roundtrip-segment",
        help="Length in s of the round trip's pieces, each started from the prescribed "
             "state (default: short enough that the open-loop growth stays below 1e3; "
             "the whole motion when it is stable)."),
    plot: bool = typer.Option(True, help="Write inverse.png."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Efforts tau = B^-1 (M ddq - F) along the file's trajectory: inverse.csv, inverse.png.

    Exit 1 when the round trip misses --roundtrip-tol; exit 2 when the file has
    no trajectory or its actuators cannot produce an arbitrary motion.
    """
    import time

    from ..services import inverse as service
    from ..model import load_robot
    from ..numeric.trajectory import missing

    start = time.perf_counter()
    timings: dict = {}
    loaded = time.perf_counter()
    model = load_robot(robot)
    timings["load"] = time.perf_counter() - loaded
    if model.trajectory is None:
        raise missing(model)
    result = service.inverse(model, formulation.value, step=dt, roundtrip=roundtrip,
                             tolerance=roundtrip_tol, segment=roundtrip_segment,
                             timings=timings, use_cache=cache)
    written = service.write(result, out_dir(out, model.name), plot=plot)
    typer.echo(f"{result.robot.name}: {result.kind} motion over {result.duration:g} s "
               f"({result.formulation}); efforts at {len(result.t)} points in "
               f"{timings['efforts'] * 1e3:.2f} ms")
    typer.echo(service.table(result))
    typer.echo(service.roundtrip_line(result))
    typer.echo(time_line(result.timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    service.check(result)
