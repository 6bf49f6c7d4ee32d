"""anadyn animate: the robot moving, as a GIF (and MP4): under its feedback laws, along
its prescribed trajectory (as inverse computes it), or a run written before."""
from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from .common import (DtOpt, Evaluator, EvaluatorOpt, FontSizeOpt, Formulation, FormulationOpt,
                     MethodOpt, OutOpt, RobotArg, SizeOpt, TEndOpt, TitleOpt, integrator_name,
                     out_dir, prepared_model, time_line)


class Motion(str, Enum):
    simulate = "simulate"
    inverse = "inverse"


def animate(
    robot: Path = RobotArg,
    motion: Motion = typer.Option(Motion.simulate, "--motion", case_sensitive=False,
                                  help="simulate: the direct dynamics under the feedback "
                                       "laws; inverse: the file's prescribed trajectory."),
    source: Path = typer.Option(None, "--from", metavar="CSV",
                                help="Play a run written before instead: a simulate.csv or "
                                     "inverse.csv of this robot (its t and coordinate "
                                     "columns)."),
    formulation: Formulation = FormulationOpt,
    evaluator: Evaluator = EvaluatorOpt,
    method: str = MethodOpt,
    t_end: float = TEndOpt,
    dt: float = DtOpt,
    frames: int = typer.Option(150, "--frames", help="Most frames in the animation."),
    mp4: bool = typer.Option(True, help="Also write animate.mp4 when ffmpeg is on the PATH."),
    out: Path = OutOpt,
    size: str = typer.Option(None, "--size", metavar="WxH", callback=SizeOpt.callback,
                             help="Frame size in inches at 100 dpi [default: 12.8x7.2, "
                                  "1280x720 pixels]."),
    title: str = TitleOpt,
    font_size: float = typer.Option(None, "--font-size", callback=FontSizeOpt.callback,
                                    help="Axis-label font size in points; the other texts "
                                         "scale with it [default: 10, 14 pixels]."),
    cache: bool = typer.Option(True, help="Reuse derived equations from the cache."),
) -> None:
    """Animate the robot's motion: animate.gif (and .mp4), with the path of its tips.

    A 3-D view and the front view (a planar robot: its plane), the time in
    every frame's title; real time when it fits in 20 s of playback at up to
    25 frames per second.
    """
    import time

    from ..errors import ModelError
    from .. import progress
    from ..services import show as service

    if frames < 2:
        raise ModelError(f"--frames must be 2 or more, got {frames}")
    start = time.perf_counter()
    timings: dict = {}
    computation: dict = {}
    columns: dict = {}          # the run's contact forces, by column name
    if source is not None:
        from ..numeric.frames import frames as kinematics

        with progress.task("forward kinematics"):
            fk = kinematics(robot, use_cache=cache)
        t, q, columns = service.read_run(source, fk.skeleton)
        name, what = fk.skeleton.name, f"{source.name}"
    else:
        model = prepared_model(robot, formulation, evaluator, cache, timings)
        name = model.info.name
        if motion is Motion.inverse:
            from ..services import inverse

            with progress.task(f"the prescribed motion of {name}"):
                result = inverse.inverse(model, step=dt, roundtrip=False, timings=timings)
            t, q, what = result.t, result.q, f"{result.kind} trajectory"
        else:
            from ..services import simulate as simulation

            with progress.task(f"integrating {name}"):
                result = simulation.simulate(model, method=integrator_name(method),
                                             t_end=t_end, output_step=dt, timings=timings)
            if not result.solution.success:
                simulation.write(result, out_dir(out, name), plot=False)   # raises
            n = len(result.robot.coordinates)
            t, q, what = result.t, result.x[:, :n], f"simulated, {result.solution.method}"
            columns = force_columns(result)
        computation = {"formulation": result.formulation, "evaluator": result.evaluator}
    played = "animate" if source is not None else f"animate {motion.value}"
    written, note = animate_run(robot, t, q, title or f"{name}: {played}", out_dir(out, name), frames=frames, mp4=mp4, cache=cache,
                                timings=timings, size=size, font_size=font_size,
                                computation=computation, columns=columns)
    typer.echo(f"{name}: {len(t)} rows over {t[-1]:g} s ({what}); {note}")
    typer.echo(time_line(timings, start))
    typer.echo("wrote " + ", ".join(str(p) for p in written))


def force_columns(result) -> dict:
    """A simulation's contact force columns (``<contact>_fn``, ``_ft1``, ``_ft2``)."""
    if result.contacts is None:
        return {}
    header, data = result.table()
    wanted = {f"{name}{part}" for name in result.contacts.names
              for part in ("_fn", "_ft1", "_ft2")}
    return {name: values for name, values in zip(header, data) if name in wanted}


def animate_run(robot: Path, t, q, title: str, out: Path, frames: int = 150, mp4: bool = True,
                cache: bool = True, timings: dict | None = None, size=None,
                font_size: float | None = None, computation: dict | None = None,
                columns: dict | None = None) -> tuple[list[Path], str]:
    """animate.gif (+ .mp4) of ``robot`` moving through ``q`` (rows x n) at times ``t``;
    ``size`` in inches at 100 dpi, ``font_size`` in points (None: the defaults); the
    contact forces drawn from ``columns`` (the run's ``<contact>_fn`` ... columns)."""
    import time

    from ..numeric.frames import frames as kinematics
    from .. import progress
    from ..services import show as service

    timings = {} if timings is None else timings
    start = time.perf_counter()
    with progress.task("forward kinematics"):
        fk = kinematics(robot, use_cache=cache)
    animation = service.animate(fk, t, q, title, max_frames=frames,
                                size=size or service.FRAME_SIZE,
                                font=font_size or service.FRAME_FONT, columns=columns)
    animation.computation = dict(computation or {})
    written, note = service.write_animation(animation, out, mp4=mp4)
    timings["animate"] = time.perf_counter() - start
    return written, note
