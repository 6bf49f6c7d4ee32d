"""anadyn animate: the robot moving under its feedback laws, as a GIF (and MP4)."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import (DtOpt, Formulation, FormulationOpt, MethodOpt, OutOpt, RobotArg, TEndOpt,
                     integrator_name, out_dir, time_line)


def animate(
    robot: Path = RobotArg,
    formulation: Formulation = FormulationOpt,
    method: str = MethodOpt,
    t_end: float = TEndOpt,
    dt: float = DtOpt,
    frames: int = typer.Option(150, "--frames", help="Most frames in the animation."),
    mp4: bool = typer.Option(True, help="Also write animate.mp4 when ffmpeg is on the PATH."),
    out: Path = OutOpt,
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Simulate the robot (as simulate does) and animate the motion: animate.gif (and .mp4).

    A 3-D view and the front view, the time in every frame's title; real time
    when it fits in 20 s of playback at up to 25 frames per second.
    """
    import time

    from ..errors import ModelError
    from ..numeric.build import numeric_model
    from .. import progress
    from ..services import simulate as simulation

    if frames < 2:
        raise ModelError(f"--frames must be 2 or more, got {frames}")
    start = time.perf_counter()
    timings: dict = {}
    with progress.task(f"preparing the {formulation.value} equations"):
        model = numeric_model(robot, formulation.value, use_cache=cache, timings=timings)
    with progress.task(f"integrating {model.info.name}"):
        result = simulation.simulate(model, method=integrator_name(method), t_end=t_end,
                                     output_step=dt, timings=timings)
    if not result.solution.success:
        simulation.write(result, out_dir(out, model.info.name), plot=False)   # raises
    written, note = animate_run(result, robot, out_dir(out, model.info.name), frames, mp4,
                                cache, timings)
    typer.echo(f"{model.info.name}: {len(result.t)} rows over {result.t[-1]:g} s "
               f"({simulation.plot_title(result).split(': ', 1)[1]}); {note}")
    typer.echo(time_line(timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))


def animate_run(result, robot: Path, out: Path, frames: int = 150, mp4: bool = True,
                cache: bool = True, timings: dict | None = None) -> tuple[list[Path], str]:
    """animate.gif (+ .mp4) of a finished simulation ``result`` of ``robot``."""
    import time

    from ..numeric.frames import frames as kinematics
    from .. import progress
    from ..services import show as service

    timings = {} if timings is None else timings
    start = time.perf_counter()
    with progress.task("forward kinematics"):
        fk = kinematics(robot, use_cache=cache)
    n = len(result.robot.coordinates)
    animation = service.animate(fk, result.t, result.x[:, :n],
                                f"{result.robot.name} ({result.solution.method})",
                                max_frames=frames)
    written, note = service.write_animation(animation, out, mp4=mp4)
    timings["animate"] = time.perf_counter() - start
    return written, note
