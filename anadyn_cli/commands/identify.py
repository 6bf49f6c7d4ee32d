"""anadyn identify: the robot's base parameters from measured motion and efforts."""
from __future__ import annotations

from pathlib import Path

import typer

from .common import OutOpt, RobotArg, SmoothingOrderOpt, SmoothingWindowOpt, out_dir


def identify(
    robot: Path = RobotArg,
    data: Path = typer.Argument(..., help="Measured data: a CSV with the columns of "
                                          "inverse.csv (t, each coordinate, optionally d<q> "
                                          "and dd<q>, each actuator's effort).",
                                show_default=False, dir_okay=False),
    out: Path = OutOpt,
    holdout: float = typer.Option(0.2, "--holdout",
                                  help="Fraction of the samples, the last ones, kept out of "
                                       "the estimate to judge its predictions."),
    physical: bool = typer.Option(False, "--physical",
                                  help="Fit physically consistent parameters (positive "
                                       "masses, inertias a rigid body can have, friction "
                                       ">= 0) for the identified robot file."),
    plot: bool = typer.Option(True, help="Write identify.png and identify_residuals.png."),
    smoothing_window: int = SmoothingWindowOpt,
    smoothing_order: int = SmoothingOrderOpt,
) -> None:
    """Estimate the base parameters by weighted least squares: identify.csv (measured
    and predicted efforts), identify.png, identify_residuals.png, NAME_identified.yaml
    (the robot with the estimate) and identify.json (estimates, standard deviations,
    condition number, residuals on training and held-out data).

    Exit 2 for a data file with missing or non-numeric columns, too few samples or a
    motion that leaves a base parameter unexcited.
    """
    from ..numeric import measured
    from ..studies.identification import estimate as service
    from ..studies.identification.regressor import parametric_model
    from ..model import load_robot

    model = parametric_model(load_robot(robot))
    how = measured.Differentiator.given(smoothing_window, smoothing_order)
    result = service.identify(model, service.read_measurements(data, model, how),
                              holdout=holdout, physical=physical)
    written = service.write(result, out_dir(out, model.name), plot=plot)
    held = int((~result.train).sum())
    typer.echo(f"{model.name}: {result.base.rank} base parameters from "
               f"{int(result.train.sum())} samples ({held} held out); {result.data.motion}; "
               f"condition number {result.condition:.4g}")
    width = max(len(n) for n in result.base.base_names)
    for name, value, std in zip(result.base.base_names, result.estimate, result.std):
        relative = f"{100 * std / abs(value):7.2f} %" if value else "      -"
        typer.echo(f"  {name:<{width}}  {value:+.6g}  +- {std:.3g}  ({relative})")
    for label, rms in (("training", result.rms()), ("held out", result.rms(True))):
        if label == "training" or held:
            typer.echo(f"residual RMS, {label}: " + ", ".join(
                f"{a} {v:.4g}" for a, v in zip(model.actuators, rms)))
    if result.note:
        typer.echo(result.note)
    typer.echo("wrote " + ", ".join(str(p) for p in written))
