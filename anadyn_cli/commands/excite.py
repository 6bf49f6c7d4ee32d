"""anadyn excite: an exciting trajectory for identification."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import OutOpt, RobotArg, out_dir


def excite(
    robot: Path = RobotArg,
    out: Path = OutOpt,
    period: float = typer.Option(10.0, "--period", help="Period of the series, s."),
    harmonics: int = typer.Option(5, "--harmonics", help="Harmonics of each series."),
    samples: int = typer.Option(100, "--samples",
                                help="Times of one period where the condition number and "
                                     "the limits are taken."),
    margin: float = typer.Option(0.9, "--margin", help="Fraction of each limit used."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random start."),
    iterations: int = typer.Option(100, "--iterations", help="Optimizer iterations (SLSQP)."),
    dt: float = typer.Option(0.01, "--dt", help="Step of excite.csv, s."),
) -> None:
    """A periodic Fourier-series motion within the joint limits (position, rate,
    effort) that minimizes the condition number of the base parameters' regressor:
    excite.csv (for inverse --motion and identify), NAME_excite.yaml (the robot with
    this trajectory, for inverse) and excite.json.
    """
    from ..model import load_robot
    from ..studies.identification import excite as service
    from ..studies.identification.regressor import parametric_model

    model = parametric_model(load_robot(robot))
    result = service.excite(model, period=period, harmonics=harmonics, samples=samples,
                            margin=margin, seed=seed, iterations=iterations, output_step=dt)
    written = service.write(result, out_dir(out, model.name))
    typer.echo(f"{model.name}: {harmonics} harmonics, period {period:g} s; condition number "
               f"of the base regressor {result.condition:.4g} ({result.base.rank} base "
               f"parameters); optimizer: {result.message}")
    typer.echo("wrote " + ", ".join(str(p) for p in written))
