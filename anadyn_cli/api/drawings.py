"""The robot drawn: view (3-D in the browser), show, animate."""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

from .common import items, robot_source
from .models import load
from .runs import inverse, simulate


def view(robot, run=None, package_paths: Iterable = (), cache: bool = False,
         out: Path | str | None = None):
    """The robot in 3-D (``anadyn view``): its URDF meshes or generated shapes, playing a
    run with a time slider, or with a slider per coordinate.

    :param robot: a YAML or URDF file, a library name, or a loaded ``Robot``.
    :param run: a simulate.csv or inverse.csv of this robot to play (columns ``t`` and
        every coordinate).
    :param package_paths: folders holding the ROS packages that ``package://`` mesh
        paths name (ROS_PACKAGE_PATH and pip's example-robot-data are searched too).
    :param cache: reuse the generated kinematics from the derivation cache.
    :param out: a folder to write view.html and view.json into.
    :returns: a ``View``: ``html()`` is the self-contained page; in Jupyter it shows
        itself inline.
    """
    from ..model.library import resolve
    from ..services import view as service

    model = load(robot)
    played = service.read_run(run, [c.name for c in model.coordinates]) if run else None
    urdf = resolve(robot) if isinstance(robot, (str, Path)) else None
    result = service.view(model, played,
                          urdf if urdf is not None and urdf.suffix.lower() == ".urdf" else None,
                          tuple(package_paths), use_cache=cache)
    if out is not None:
        service.write(result, Path(out))
    return result


def show(robot, at: Mapping[str, float] | Iterable[str] = (), cache: bool = False):
    """The robot drawn at its initial pose, or another (``anadyn show``).

    :param robot: see ``load``.
    :param at: the pose: coordinate values ({"q1": 0.3}) or "q1=30deg" items.
    :param cache: reuse the generated kinematics from the cache.
    :returns: a ``Drawing`` (``figure()``: a Matplotlib Figure; ``pose``: every frame).
    """
    from ..numeric.frames import frames
    from ..services import show as service

    return service.draw(frames(robot_source(robot), use_cache=cache), items(at))


def animate(robot, out: str | Path | None = None, motion: str = "simulate",
            frames: int = 150, mp4: bool = True, formulation: str | None = None,
            evaluator: str | None = None, cache: bool = False, method: str | None = None,
            t_end: float | None = None, output_step: float | None = None):
    """The robot moving (``anadyn animate``).

    :param robot: see ``load``.
    :param out: folder for animate.gif (animate.mp4 with ffmpeg) and animate.json;
        None: write nothing.
    :param motion: "simulate" (the direct dynamics under the feedback laws) or
        "inverse" (the file's prescribed trajectory).
    :param frames: most frames in the animation.
    :param mp4: also write animate.mp4 when ffmpeg is on the PATH.
    :param formulation: see ``numeric_model``.
    :param evaluator: see ``numeric_model``.
    :param cache: see ``numeric_model``.
    :param method: integrator, as ``simulate``.
    :param t_end: horizon of the simulation, s.
    :param output_step: step of the motion's rows, s.
    :returns: an ``Animation`` (``times``; ``images``: the frames as arrays;
        ``computation``: what computed the motion).
    """
    from .. import errors
    from ..errors import ModelError, NumericalError
    from ..numeric.frames import frames as kinematics
    from ..services import show as service

    errors.check("frames", frames)
    if motion not in ("simulate", "inverse"):
        raise ModelError(f"motion must be simulate or inverse, got {motion!r}")
    source = robot_source(robot)
    if motion == "inverse":
        run = inverse(source, formulation, evaluator, cache, output_step=output_step,
                      roundtrip=False)
        q = run.q
    else:
        run = simulate(source, formulation, evaluator, cache, method=method, t_end=t_end,
                       output_step=output_step)
        if not run.solution.success:
            raise NumericalError(f"{run.robot.source}: {run.solution.message}")
        q = run.x[:, :len(run.robot.coordinates)]
    animation = service.animate(kinematics(source, use_cache=cache), run.t, q,
                                f"{run.robot.name}: animate {motion}", max_frames=frames)
    animation.computation = {"formulation": run.formulation, "evaluator": run.evaluator}
    if out is not None:
        service.write_animation(animation, Path(out), mp4=mp4)
    return animation
