"""Benchmark: a CSV table's text by the compiled writer against the Python path.

    python bench/csv_text.py [--rows 1000] [--columns 193] [--repeat 5]

``output.csv_table.csv_text`` of a rows x columns table (the warm TIAGo inverse.csv
is 1000 x 193) of doubles of all magnitudes, as a run's efforts are (random
normals times 10^-3..10^3), with the compiled writer (``csv_rows.c``, built first
in a temporary cache folder, removed at the end) and with the Python rows; CPU seconds, the best of
``--repeat``, and their ratio, measured in this run.  Exits 1 if the two texts differ.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import timeit
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1000)
    parser.add_argument("--columns", type=int, default=193)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="anadyn-csv-") as work:
        os.environ["ANADYN_CACHE_DIR"] = str(Path(work, "cache"))   # its -native folder too
        run(args)


def run(args) -> None:
    from anadyn_cli.output import csv_table

    timings: dict = {}
    compiled = csv_table.writer(timings, how="wait")
    if compiled is None:
        sys.exit("no CSV writer: no C compiler or Python headers")
    rng = np.random.default_rng(0)
    shape = (args.rows, args.columns)
    columns = list((rng.normal(size=shape) * 10.0 ** rng.integers(-3, 4, size=shape)).T)
    header = [f"c{k}" for k in range(args.columns)]
    texts, cpu = {}, {}
    for label, writer in (("C writer", compiled), ("Python rows", None)):
        csv_table._WRITER[:] = [writer]
        texts[label] = csv_table.csv_text(header, columns)
        cpu[label] = min(timeit.repeat(lambda: csv_table.csv_text(header, columns),
                                       timer=time.process_time, number=1, repeat=args.repeat))
    print(f"csv_text of {args.rows} x {args.columns} doubles ({len(texts['C writer'])} "
          f"characters), CPU s, best of {args.repeat}; writer compiled in "
          f"{timings.get('native_compile', 0.0):.2f} s")
    for label, seconds in cpu.items():
        print(f"  {label:12s} {seconds * 1e3:7.1f} ms")
    print(f"  ratio C / Python {cpu['C writer'] / cpu['Python rows']:.2f}")
    if texts["C writer"] != texts["Python rows"]:
        sys.exit("the two texts differ")


if __name__ == "__main__":
    main()
