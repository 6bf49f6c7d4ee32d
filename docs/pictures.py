"""Regenerate the documentation's pictures (small PNGs in docs/images/):

    python docs/pictures.py

show_rrt.png      anadyn show robots/rrt.yaml --at q2=60deg
simulate_rrt.png  anadyn simulate robots/rrt.yaml (the plot, rates included)
animate_rr.png    four frames of anadyn animate robots/rr.yaml (t = 0, 0.2, 0.6, 3 s)

They are drawn by the same code as the commands, at a lower resolution and
with a 128-colour palette to stay small.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from anadyn_cli.numeric.build import numeric_model
from anadyn_cli.numeric.frames import frames
from anadyn_cli.output import drawing
from anadyn_cli.output.plots import figure_bytes
from anadyn_cli.services import show, simulate

ROOT = Path(__file__).resolve().parent.parent
IMAGES = ROOT / "docs" / "images"


def save(image: Image.Image, name: str) -> None:
    small = image.convert("RGB").quantize(colors=128, method=Image.Quantize.MEDIANCUT)
    small.save(IMAGES / name, optimize=True)
    print(f"{name}: {image.size[0]}x{image.size[1]}, {(IMAGES / name).stat().st_size // 1024} KiB")


def png(figure, dpi: int) -> Image.Image:
    return Image.open(io.BytesIO(figure_bytes(figure, "png", dpi=dpi)))


def main() -> None:
    rrt = ROOT / "robots" / "rrt.yaml"
    picture = show.draw(frames(rrt), ["q2=60deg"])
    save(png(picture.figure(), 72), "show_rrt.png")

    result = simulate.simulate(numeric_model(rrt), t_end=15.0)
    save(png(result.figure(rates=True), 80), "simulate_rrt.png")

    rr = ROOT / "robots" / "rr.yaml"
    run = simulate.simulate(numeric_model(rr), t_end=3.0)
    fk = frames(rr)
    rows = [0, 20, 60, 300]                       # t = 0, 0.2, 0.6, 3 s
    poses = fk(run.x[rows, :2])
    movie = drawing.Animation(fk.skeleton, drawing.Frame.around(fk(run.x[:, :2])),
                              "rr (odeint)", dpi=60)
    images = [movie.frame(poses.at(k), float(run.t[row])) for k, row in enumerate(rows)]
    grid = np.concatenate([np.concatenate(images[:2], axis=1),
                           np.concatenate(images[2:], axis=1)], axis=0)
    save(Image.fromarray(grid), "animate_rr.png")

if __name__ == "__main__":
    main()
