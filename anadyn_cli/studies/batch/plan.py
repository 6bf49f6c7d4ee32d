"""The batch file: reading and validating it into a ``Batch`` of ``Job``s (see the
package's docstring for the format)."""
from __future__ import annotations

import math
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path

#: what a job may run: every command that takes a robot
COMMANDS = ("simulate", "inverse", "compare", "accuracy", "check", "sweep", "linearize",
            "export", "equations", "show", "animate", "view", "import")
#: where a command writes its results: --out FOLDER, except these
OUTPUT_OPTION = {"equations": None, "import": "--output"}
TOP_KEYS = ("description", "timeout", "jobs")
JOB_KEYS = ("command", "robot", "name", "options", "expect", "must_fail", "timeout")
EXPECT_KEYS = ("exit_code", "max", "min", "equal")
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}\Z")
MAX_TIMEOUT = 7 * 86400.0            # s: a week (the system's waits end at ~24 days)


@dataclass(frozen=True)
class Expectation:
    exit_code: int | None = 0                    # None: any non-zero code
    max: tuple[tuple[str, float], ...] = ()
    min: tuple[tuple[str, float], ...] = ()
    equal: tuple[tuple[str, object], ...] = ()

    @property
    def paths(self) -> list[str]:
        return [p for group in (self.max, self.min, self.equal) for p, _ in group]

    def describe_exit(self) -> str:
        return "non-zero" if self.exit_code is None else str(self.exit_code)


@dataclass(frozen=True)
class Job:
    command: str
    robot: str                                   # path as given to the command
    name: str
    options: tuple[str, ...]
    expect: Expectation
    timeout: float | None = None
    line: int | None = None

    @property
    def key(self) -> str:
        return f"{self.command} {self.name}"

    def folder(self, out: Path) -> Path:
        return Path(out) / self.command / self.name

    def argv(self, out: Path) -> list[str]:
        flag = OUTPUT_OPTION.get(self.command, "--out")
        where = ([] if flag is None else
                 [flag, str(self.folder(out) / f"{self.name}.yaml")] if flag == "--output" else
                 [flag, str(self.folder(out))])
        return [sys.executable, "-m", "anadyn_cli", self.command, *self.options, *where,
                "--", self.robot]


@dataclass(frozen=True)
class Batch:
    source: str
    jobs: tuple[Job, ...]
    description: str = ""



def load_batch(path: str | Path) -> Batch:
    """Read and validate a batch file; ModelError (exit 2) naming file, line and key path."""
    from ...model.yamlschema import load
    from ...model.yamlsource import read_text

    text, source = read_text(path)
    data, lines = load(text, source)
    from ...model.loader import Cursor

    root = Cursor(data, "", source, lines)
    top = root.mapping(TOP_KEYS, required=("jobs",))
    description = top["description"].text() if "description" in top else ""
    timeout = _seconds(top["timeout"]) if "timeout" in top else None
    items = top["jobs"].sequence()
    if not items:
        raise top["jobs"].error("expected at least one job")
    folder = Path(source).parent
    jobs: list[Job] = []
    taken: dict[str, int] = {}
    for item in items:
        job = _job(item, folder, timeout)
        if job.key in taken:
            raise (item.mapping()["name"] if "name" in item.value else item).error(
                f"a second job {job.key!r}; give one of them a different name")
        taken[job.key] = 1
        jobs.append(job)
    return Batch(source, tuple(jobs), description)


def _job(cursor, folder: Path, timeout: float | None) -> Job:
    keys = cursor.mapping(JOB_KEYS, required=("command", "robot"))
    command = keys["command"].choice(COMMANDS)
    robot = _robot(keys["robot"], folder)
    if "name" in keys:
        name = keys["name"].value
        if not isinstance(name, str) or not NAME.match(name):
            raise keys["name"].error("a job name is a letter or digit followed by up to 63 "
                                     f"letters, digits, '_', '.' or '-', got {name!r}")
    else:
        name = re.sub(r"[^A-Za-z0-9_.-]", "_", robot.stem).lstrip("._-")[:64]
        if not NAME.match(name):
            raise keys["robot"].error(f"the file name {robot.name!r} makes no job name; "
                                      "give the job a name (a letter or digit followed by "
                                      "letters, digits, '_', '.' or '-')")
    options = _options(keys["options"]) if "options" in keys else ()
    expect = _expectation(keys["expect"]) if "expect" in keys else Expectation()
    if "must_fail" in keys:
        cursor_fail = keys["must_fail"]
        if "expect" in keys and "exit_code" in keys["expect"].value:
            raise cursor_fail.error("give either must_fail or expect.exit_code, not both")
        value = cursor_fail.value
        if value is True:
            code = None
        elif isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= 255:
            code = value
        else:
            raise cursor_fail.error(f"must be an exit code from 1 to 255 or true (any "
                                    f"non-zero code), got {value!r}")
        expect = Expectation(code, expect.max, expect.min, expect.equal)
    job_timeout = _seconds(keys["timeout"]) if "timeout" in keys else timeout
    return Job(command, str(robot), name, options, expect, job_timeout,
               cursor.lines.get(cursor.path))


def _robot(cursor, folder: Path) -> Path:
    """The robot file of a job: relative to the batch file's folder, else (a bare name)
    the library's robot of that name; always an absolute path."""
    from ...model import library

    given = cursor.text()
    robot = Path(os.path.abspath(folder / given))
    if robot.is_file():
        return robot
    found = library.find(given) if len(Path(given).parts) == 1 else None
    if found is not None:
        return Path(os.path.abspath(found))
    raise cursor.error(f"no such file {str(robot)!r} (robot paths are relative to the batch "
                       f"file's folder){library.missing_hint(given)}")


def _options(cursor) -> tuple[str, ...]:
    result: list[str] = []
    if isinstance(cursor.value, dict):
        for key, item in cursor.mapping().items():
            flag = "--" + key.lstrip("-").replace("_", "-")
            value = item.value
            if value is True:
                result.append(flag)
            elif value is False:
                result.append("--no-" + flag[2:])
            elif isinstance(value, (str, int, float)):
                result += [flag, str(value)]
            else:
                raise item.error("an option's value is text, a number, true or false")
    else:
        for item in cursor.sequence():
            if isinstance(item.value, bool) or not isinstance(item.value, (str, int, float)):
                raise item.error("each option is text or a number, e.g. [--dt, 0.05]")
            result.append(str(item.value))
    for word in result:
        if word in ("--out", "--output", "-o") or word.startswith(("--out=", "--output=")):
            raise cursor.error(f"{word.partition('=')[0]} is set by the batch "
                               "(OUT/<command>/<name>/); leave it out")
        if word == "--":
            raise cursor.error("'--' is set by the batch (before the robot); leave it out")
    return tuple(result)


def _expectation(cursor) -> Expectation:
    keys = cursor.mapping(EXPECT_KEYS)
    code = 0
    if "exit_code" in keys:
        value = keys["exit_code"].value
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 255:
            raise keys["exit_code"].error(f"must be an exit code from 0 to 255, got {value!r}")
        code = value
    bounds = {}
    for group in ("max", "min"):
        pairs = []
        if group in keys:
            for path, item in keys[group].mapping().items():
                pairs.append((path, _number(item)))
        bounds[group] = tuple(pairs)
    equal = []
    if "equal" in keys:
        for path, item in keys["equal"].mapping().items():
            if isinstance(item.value, (dict, list)):
                raise item.error("expected a single value (text, number, true, false or null)")
            equal.append((path, item.value))
    return Expectation(code, bounds["max"], bounds["min"], tuple(equal))


def _number(cursor) -> float:
    """A number; YAML 1.1 reads 1e-6 as text, so numeric text is accepted too."""
    value = cursor.value
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        raise cursor.error(f"expected a number, got {cursor.value!r}")
    return float(value)


def _seconds(cursor) -> float:
    """A job's timeout: more than 0 s, at most ``MAX_TIMEOUT``."""
    value = _number(cursor)
    if not 0 < value <= MAX_TIMEOUT:
        raise cursor.error(f"must be a number of seconds more than 0 and at most "
                           f"{MAX_TIMEOUT:g} (a week), got {value:g}")
    return value
