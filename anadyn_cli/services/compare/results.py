"""What ``compare`` finds, as data: the outcome of each check (symbolic, numeric per
quantity, trajectory) per robot, the settings it ran with, and compare.csv."""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

from ... import files as output

SAMPLES = 200
SEED = 0
RTOL = 1e-9                 # numeric check, relative to the quantity's size per state
TRAJECTORY_TOL = 1e-7       # scaled state difference over the output grid
SYMBOLIC_TERMS = 10_000     # expanded terms put in canonical form per robot (a few s)
ENTRY_TERMS = 5_000         # ... and per entry
ANGLE_RANGE = math.pi       # rad around the initial value
SLIDE_RANGE = 0.1           # m, at least; else |q0|
RATE_RANGE = 2.0            # rad/s or m/s, at least; else 2 |dq0|
QUANTITIES = ("M", "F", "B", "ddq")


@dataclass
class Symbolic:
    """Outcome of check (a)."""
    status: str                  # "zero", "numeric only", "nonzero", "off"
    entries: int = 0             # entries of M, F and B
    proven: int = 0              # differences shown identically zero
    too_large: int = 0           # left to the numeric check by the budget
    not_reduced: int = 0         # canonical residual that evaluates to zero (30 digits)
    terms: int = 0               # estimated expanded terms put in canonical form
    entry: str = ""              # the first entry found to differ
    residual: str = ""           # lagrange - kane there, in canonical form
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return self.status != "nonzero"

    def describe(self) -> str:
        if self.status == "zero":
            return f"0 exactly (all {self.entries} entries of M, F, B)"
        if self.status == "off":
            return "numeric only (symbolic check off)"
        if self.status == "nonzero":
            return f"{self.entry}: lagrange - kane = {self.residual}"
        why = ("too large for a symbolic check" if self.too_large
               else "canonical form does not reduce it")
        return (f"numeric only ({why}); {self.proven} of {self.entries} entries "
                f"proven 0")


@dataclass
class Difference:
    """Largest difference of one quantity between the formulations."""
    quantity: str                # "M", "F", "B", "ddq", "trajectory"
    max_abs: float
    max_rel: float               # relative to the quantity's size (scaled state: trajectory)
    tolerance: float
    passed: bool
    where: str = ""              # worst state or time
    note: str = ""

    def to_dict(self) -> dict:
        return {"max_abs": finite_or_none(self.max_abs), "max_rel": finite_or_none(self.max_rel),
                "tolerance": self.tolerance, "passed": self.passed, "where": self.where,
                "note": self.note}


@dataclass
class RobotComparison:
    name: str
    source: str
    symbolic: Symbolic
    numeric: dict[str, Difference]
    trajectory: Difference
    samples: int
    failure: str = ""            # a simulation that failed (NumericalError)
    timings: dict = field(default_factory=dict)

    @property
    def mismatches(self) -> list[str]:
        found = [] if self.symbolic.passed else ["symbolic"]
        found += [q for q, d in self.numeric.items() if not d.passed]
        if not self.failure and not self.trajectory.passed:
            found.append("trajectory")
        return found

    @property
    def passed(self) -> bool:
        return not self.mismatches and not self.failure


@dataclass
class CompareResult:
    robots: list[RobotComparison]
    samples: int
    seed: int
    rtol: float
    trajectory_tol: float
    symbolic_terms: int
    timings: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.robots)

    def to_csv(self, path) -> Path:
        """Write compare.csv (one row per robot and quantity) to ``path``."""
        output.write_text(Path(path), csv_text(self))
        return Path(path)



def number_text(value: float) -> str:
    return f"{value:.2e}" if value and math.isfinite(value) else ("0" if value == 0 else
                                                                  str(value))


def finite_or_none(value: float):
    return value if math.isfinite(value) else None



def csv_text(result: CompareResult) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["robot", "check", "max_abs", "max_rel", "tolerance", "passed", "detail"])
    for r in result.robots:
        s = r.symbolic
        writer.writerow([r.name, "symbolic", "", "", 0, s.passed, s.describe()])
        for d in [*r.numeric.values(), r.trajectory]:
            detail = r.failure if d.quantity == "trajectory" and r.failure else (
                "; ".join(p for p in (d.where, d.note) if p))
            passed = d.passed and not (d.quantity == "trajectory" and r.failure)
            writer.writerow([r.name, d.quantity, repr(d.max_abs), repr(d.max_rel),
                             d.tolerance, passed, detail])
    return buffer.getvalue()
