"""`anadyn batch`: the CI batch file, expectations, reports and config errors."""
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from anadyn_cli.studies import batch
from anadyn_cli.studies.batch import running
from anadyn_cli.cli import main

ROOT = Path(__file__).resolve().parents[1]
RR = ROOT / "robots" / "rr.yaml"


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    """The jobs' processes inherit it."""
    monkeypatch.setenv("ANADYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("CI", raising=False)


def config(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "batch.yaml"
    path.write_text(text.replace("RR", str(RR)))
    return path


JOB_LINE = re.compile(r"\[(\d+)/(\d+)\] (ok  |FAIL) (\w+) (\S+)  \d+\.\d s(: .*)?\Z")


def test_ci_config_covers_every_shipped_robot_with_every_command():
    plan = batch.load_batch(ROOT / "configs" / "ci.yaml")
    robots = {str(p.relative_to(ROOT)) for p in (ROOT / "robots").glob("*.yaml")}
    covered = {(j.command, str(Path(j.robot).resolve().relative_to(ROOT))) for j in plan.jobs
               if j.expect.exit_code == 0}
    judged = ("simulate", "inverse", "compare", "accuracy", "check")   # what ci.yaml judges
    # MJCF robots (robots/*.xml: no trajectory) are judged by compare and check at least
    mjcf = {str(p.relative_to(ROOT)) for p in (ROOT / "robots").glob("*.xml")}
    # scenes in robots' subfolders (contact/, drives/, ...) are judged as their pages say
    scenes = {(c, r) for c, r in covered if r.count("/") > 1}
    # a spherical joint (a floating base too) has no prescribed motions (inverse) yet;
    # the closed forms of the free robots of example-robot-data (18 and 35 speeds with a
    # quaternion) take minutes to derive: their recursive path is checked against
    # Pinocchio in tests/test_floating.py, and Kane = Lagrange on the smaller ones here
    spherical = {f"robots/{name}.yaml" for name in (
        "spherical_pendulum", "tumbling_box", "satellite", "space_robot", "solo12_free",
        "g1_free")}
    large = {f"robots/{name}.yaml" for name in ("solo12_free", "g1_free")}
    assert covered - scenes - {(c, r) for c in judged for r in mjcf} == {
        (c, r) for c in judged for r in robots
        if not (r in spherical and c == "inverse") and not (r in large and c == "compare")}
    assert {(c, r) for c in ("compare", "check") for r in mjcf} <= covered
    assert all(j.expect.paths for j in plan.jobs if j.expect.exit_code == 0)


def test_ci_config_passes(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    monkeypatch.setenv("ANADYN_PROGRESS", "plain")     # as in a CI log
    out = tmp_path / "ci"
    assert main(["batch", "configs/ci.yaml", "--jobs", "2", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    lines = captured.out.splitlines()
    jobs = len(batch.load_batch(ROOT / "configs" / "ci.yaml").jobs)
    logged = [line for line in captured.err.splitlines() if line.startswith("[")]
    progress = [JOB_LINE.match(line) for line in logged]       # one per finished job
    assert len(progress) == jobs and all(m and m.group(3) == "ok  " for m in progress), logged
    assert [int(m.group(1)) for m in progress] == list(range(1, jobs + 1))
    assert re.fullmatch(rf"batch configs/ci\.yaml: {jobs} jobs, {jobs} ok, 0 failed, [\d.]+ s "
                        r"on 2 workers", lines[-2])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["passed"] is True and summary["jobs_failed"] == 0
    by_key = {f"{j['command']} {j['name']}": j for j in summary["jobs"]}
    assert by_key["inverse rr"]["figures"]["roundtrip.max_error"] < 1e-6
    assert by_key["inverse rr-impossible-tolerance"]["exit_code"] == 1
    suite = ET.parse(out / "junit.xml").getroot()
    assert suite.tag == "testsuite" and suite.get("tests") == str(jobs)
    assert suite.get("failures") == "0" and suite.find(".//failure") is None
    for command in ("simulate", "inverse", "compare", "accuracy", "check"):
        assert (out / command / "rr" / f"{command}.json").is_file()


def test_an_impossible_expectation_fails_the_batch_and_names_the_job(tmp_path, capsys,
                                                                     monkeypatch):
    monkeypatch.setenv("ANADYN_PROGRESS", "plain")
    path = config(tmp_path, """\
jobs:
  - command: simulate
    robot: RR
    options: {no-plot: true, t-end: 1}
    expect: {max: {rows: 1000}, equal: {success: true}}
  - command: simulate
    robot: RR
    name: too-few-rows
    options: [--no-plot, --t-end, 1]
    expect: {max: {rows: 100}}
  - command: simulate
    robot: RR
    name: no-such-figure
    options: [--no-plot, --t-end, 1]
    expect: {max: {roundtrip.max_error: 1}}
""")
    out = tmp_path / "out"
    assert main(["batch", str(path), "--out", str(out)]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err[-1] == ("anadyn: error: batch: 2 of 3 jobs missed their expectations: "
                       "simulate too-few-rows (rows = 101 > max 100); "
                       "simulate no-such-figure (roundtrip.max_error: missing in "
                       "simulate.json)")
    lines = {m.group(5): m for m in map(JOB_LINE.match, [e for e in err if e[:1] == "["])}
    assert len(lines) == 3
    assert lines["rr"].group(3) == "ok  " and lines["rr"].group(6) is None
    assert lines["too-few-rows"].group(3) == "FAIL"
    assert lines["too-few-rows"].group(6) == ": rows = 101 > max 100"
    suite = ET.parse(out / "junit.xml").getroot()
    assert (suite.get("tests"), suite.get("failures")) == ("3", "2")
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert {c.get("classname") for c in cases.values()} == {"simulate"}
    assert cases["rr"].find("failure") is None
    assert cases["too-few-rows"].find("failure").get("message") == "rows = 101 > max 100"
    rows = (out / "summary.csv").read_text().splitlines()
    assert rows[0] == ("command,name,robot,status,exit_code,expected_exit_code,wall_s,"
                       "figures,failures,folder")
    assert rows[2].startswith(f"simulate,too-few-rows,{RR},FAIL,0,0,")
    assert rows[2].endswith(f",rows=101,rows = 101 > max 100,{out}/simulate/too-few-rows")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failed"] == ["simulate too-few-rows", "simulate no-such-figure"]


def test_exit_codes_must_fail_and_timeouts(tmp_path, capsys):
    path = config(tmp_path, """\
jobs:
  - command: simulate
    robot: RR
    name: bad-rtol
    options: [--rtol, -1]
    must_fail: 2
  - command: simulate
    robot: RR
    name: passes-but-should-fail
    options: [--no-plot, --t-end, 0.1]
    must_fail: true
  - command: simulate
    robot: RR
    name: unexpected-failure
    options: [--dt, 20]
  - command: simulate
    robot: RR
    name: slow
    timeout: 0.001
""")
    assert main(["batch", str(path), "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err == ("anadyn: error: batch: 3 of 4 jobs missed their expectations: "
                   "simulate passes-but-should-fail (exit code 0, expected a failure "
                   "(non-zero)); simulate unexpected-failure (exit code 2, expected 0 "
                   "(anadyn: error: output step 20 s is longer than t_end 15 s)); "
                   "simulate slow (anadyn batch: timed out after 0.001 s)\n")


def test_a_stale_figures_file_is_not_read(tmp_path, capsys):
    good = config(tmp_path, """\
jobs:
  - {command: simulate, robot: RR, options: [--no-plot, --t-end, 1], expect: {max: {rows: 101}}}
""")
    out = str(tmp_path / "out")
    assert main(["batch", str(good), "--out", out]) == 0
    bad = config(tmp_path, """\
jobs:
  - {command: simulate, robot: RR, options: [--rtol, -1], must_fail: 2, expect: {max: {rows: 101}}}
""")
    assert main(["batch", str(bad), "--out", out]) == 1
    assert capsys.readouterr().err.endswith(
        "simulate rr (simulate.json not written, so rows cannot be checked)\n")
    assert (tmp_path / "out" / "simulate" / "rr" / "simulate.json").is_file()   # kept


@pytest.mark.parametrize("text, message", [
    ("jobs: []\n", "1: jobs: expected at least one job"),
    ("job: []\n", "1: job: unknown key; did you mean 'jobs'? allowed: description, "
                  "timeout, jobs"),
    ("jobs:\n  - {command: simulat, robot: RR}\n",
     "2: jobs[0].command: must be one of simulate, inverse, compare, accuracy, check, sweep, "
     "linearize, export, equations, show, animate, view, import, got 'simulat'"),
    ("jobs:\n  - command: simulate\n    robot: RR\n    expct: {}\n",
     "4: jobs[0].expct: unknown key; did you mean 'expect'? allowed: command, robot, name, "
     "options, expect, must_fail, timeout"),
    ("jobs:\n  - {command: simulate}\n", "2: jobs[0]: missing required key 'robot'"),
    ("jobs:\n  - {command: simulate, robot: nowhere.yaml}\n",
     "2: jobs[0].robot: no such file 'TMP/nowhere.yaml' (robot paths are relative to the "
     "batch file's folder) and no library robot of that name; `anadyn robots` lists the "
     "library"),
    ("jobs:\n  - {command: simulate, robot: RR, options: [--out, x]}\n",
     "2: jobs[0].options: --out is set by the batch (OUT/<command>/<name>/); leave it out"),
    ("jobs:\n  - {command: simulate, robot: RR, options: [[1]]}\n",
     "2: jobs[0].options[0]: each option is text or a number, e.g. [--dt, 0.05]"),
    ("jobs:\n  - command: simulate\n    robot: RR\n    expect:\n      max: {rows: lots}\n",
     "5: jobs[0].expect.max.rows: expected a number, got 'lots'"),
    ("jobs:\n  - {command: simulate, robot: RR, must_fail: 1, expect: {exit_code: 1}}\n",
     "2: jobs[0].must_fail: give either must_fail or expect.exit_code, not both"),
    ("jobs:\n  - {command: simulate, robot: RR, must_fail: 0}\n",
     "2: jobs[0].must_fail: must be an exit code from 1 to 255 or true (any non-zero code), "
     "got 0"),
    ("jobs:\n  - {command: simulate, robot: RR}\n  - {command: simulate, robot: RR}\n",
     "3: jobs[1]: a second job 'simulate rr'; give one of them a different name"),
    ("jobs:\n  - {command: simulate, robot: RR, name: a/b}\n",
     "2: jobs[0].name: a job name is a letter or digit followed by up to 63 letters, "
     "digits, '_', '.' or '-', got 'a/b'"),
    ("timeout: -3\njobs:\n  - {command: simulate, robot: RR}\n",
     "1: timeout: must be a number of seconds more than 0 and at most 604800 (a week), "
     "got -3"),
    ("jobs:\n  - {command: simulate, robot: RR, timeout: 1e7}\n",
     "2: jobs[0].timeout: must be a number of seconds more than 0 and at most 604800 (a "
     "week), got 1e+07"),
    ("jobs:\n  - {command: simulate, robot: RR, options: [--, x]}\n",
     "2: jobs[0].options: '--' is set by the batch (before the robot); leave it out"),
    ("jobs:\n  - {command: import, robot: RR, options: {output: x.yaml}}\n",
     "2: jobs[0].options: --output is set by the batch (OUT/<command>/<name>/); leave it out"),
    ("jobs:\n  - {command: simulate, robot: qqqq}\n",
     "2: jobs[0].robot: no such file 'TMP/qqqq' (robot paths are relative to the "
     "batch file's folder) and no library robot of that name; `anadyn robots` lists the "
     "library"),
])
def test_config_mistakes_are_one_line_with_file_line_and_key(tmp_path, capsys, text, message):
    path = config(tmp_path, text)
    assert main(["batch", str(path), "--out", str(tmp_path / "out")]) == 2
    expected = f"anadyn: error: {path}:{message.replace('TMP', str(tmp_path))}\n"
    assert capsys.readouterr().err == expected
    assert not (tmp_path / "out").exists()


def test_options_and_expectations_are_read(tmp_path):
    path = config(tmp_path, """\
timeout: 60
jobs:
  - command: accuracy
    robot: RR
    options: {no-plot: true, plot: false, repeats: 1, t_end: 5, methods: "auto,RK45"}
    expect: {max: {rows.0.max_error: 1e-6}, min: {rows_on_grid: 2}, equal: {robot: rr}}
    timeout: 5
""")
    job = batch.load_batch(path).jobs[0]
    assert job.options == ("--no-plot", "--no-plot", "--repeats", "1", "--t-end", "5",
                           "--methods", "auto,RK45")
    assert job.expect == batch.Expectation(0, (("rows.0.max_error", 1e-6),),
                                           (("rows_on_grid", 2.0),), (("robot", "rr"),))
    assert job.timeout == 5 and job.name == "rr" and job.robot == str(RR)
    assert job.argv(Path("o"))[1:] == ["-m", "anadyn_cli", "accuracy", *job.options,
                                       "--out", str(Path("o") / "accuracy" / "rr"), "--", str(RR)]


def test_lookup_follows_dotted_paths():
    data = {"a": {"b": [{"c": 1.5}, {"c": None}]}, "x.y": 1}
    assert batch.lookup(data, "a.b.0.c") == (True, 1.5)
    assert batch.lookup(data, "a.b.-1.c") == (True, None)
    assert batch.lookup(data, "a.b.2.c") == (False, None)
    assert batch.lookup(data, "a.c") == (False, None)


def _shown(mode: str, stream) -> list:
    """What a batch of a job that passes and one that misses shows in ``mode``."""
    from anadyn_cli import progress

    done = batch.JobResult(batch.Job("simulate", "rr.yaml", "rr", (), batch.Expectation()),
                           0, 0.94)
    missed = batch.JobResult(batch.Job("inverse", "rr.yaml", "rr2", (), batch.Expectation()),
                             1, 2.5, failures=["exit code 1, expected 0"])
    screens = []
    with progress.session(stream, mode) as session:
        shown = running._Shown(12)
        shown.started(done.job)
        shown.started(missed.job)
        if mode == "live":
            for job in session.tasks:          # what the ticking thread does after LIVE_DELAY
                job.start -= progress.LIVE_DELAY
            session._tick_live()
            session.live.refresh()
            screens.append(stream.getvalue())
        shown.done(done)
        shown.done(missed)
        if mode == "live":
            session.live.refresh()
        shown.close(finished=True)
    screens.append(stream.getvalue())
    return screens


def test_progress_a_line_per_finished_job_in_a_log_bars_on_a_terminal():
    """Through anadyn_cli.progress: plain (a log, CI): exactly one line per finished job;
    live: the batch's count, a line per running job with its clock, the misses kept."""
    import io

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    (log,) = _shown("plain", io.StringIO())
    assert log.splitlines()[:2] == ["[1/12] ok   simulate rr  0.9 s",
                                    "[2/12] FAIL inverse rr2  2.5 s: exit code 1, expected 0"]
    assert len(log.splitlines()) == 3 and log.startswith("anadyn: batch: done in ", log.index(
        "anadyn:"))                         # and the batch's end, as every task's in a log
    running, shown = _shown("live", Terminal())
    assert "batch" in running and "0/12" in running and "2 running, 0 failed" in running
    assert "simulate rr" in running and "inverse rr2" in running
    assert "0:00:0" in running         # each line has its clock
    assert "[2/12] FAIL inverse rr2  2.5 s: exit code 1, expected 0" in shown   # kept
    assert "[1/12] ok" not in shown
    assert _shown("off", io.StringIO()) == [""]


# -- names, commands and reports that cannot go wrong (issues 22 and 23) ---------------------
def test_robot_files_named_like_options_or_dots_stay_robots_in_their_folders(tmp_path, capsys):
    """A robot named --help is passed after '--'; one named ...yaml (stem '..') would make
    the job's folder OUT itself, so it needs a name."""
    (tmp_path / "--help").write_text(RR.read_text())
    (tmp_path / "...yaml").write_text(RR.read_text())
    path = tmp_path / "batch.yaml"
    path.write_text("jobs:\n  - {command: simulate, robot: ...yaml, options: [--no-plot]}\n")
    out = tmp_path / "out"
    assert main(["batch", str(path), "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"anadyn: error: {path}:2: jobs[0].robot: the file name '...yaml' makes no job name; "
        "give the job a name (a letter or digit followed by letters, digits, '_', '.' or '-')\n")
    assert not out.exists()
    path.write_text("""\
jobs:
  - {command: simulate, robot: --help, options: [--no-plot, --t-end, 1], expect: {equal: {rows: 101}}}
  - {command: simulate, robot: ...yaml, name: dots, options: [--no-plot, --t-end, 1]}
""")
    assert main(["batch", str(path), "--out", str(out)]) == 0, capsys.readouterr()
    assert sorted(p.name for p in (out / "simulate").iterdir()) == ["dots", "help"]
    assert (out / "simulate" / "help" / "simulate.json").is_file()
    assert sorted(p.name for p in out.iterdir()) == ["junit.xml", "simulate", "summary.csv",
                                                     "summary.json"]


def test_library_names_and_every_command(tmp_path, capsys):
    """Library names as the other commands take them; commands beyond the judged five:
    equations prints only, import writes OUT/import/NAME/NAME.yaml."""
    path = config(tmp_path, """\
jobs:
  - {command: equations, robot: rr}
  - {command: export, robot: rr, options: [--lang, python], expect: {equal: {lang: python}}}
  - {command: linearize, robot: rr, expect: {equal: {robot: rr}}}
  - {command: import, robot: ur5}
""")
    out = tmp_path / "out"
    assert main(["batch", str(path), "--jobs", "2", "--out", str(out)]) == 0, \
        capsys.readouterr()
    from anadyn_cli.model import library

    plan = batch.load_batch(path)
    assert [j.robot for j in plan.jobs] == [str(library.find("rr"))] * 3 + [
        str(library.find("ur5"))]
    assert "q1" in (out / "equations" / "rr" / "stdout.txt").read_text()
    assert (out / "export" / "rr" / "rr.py").is_file()
    assert (out / "linearize" / "rr" / "linearize.json").is_file()
    assert "bodies:" in (out / "import" / "ur5" / "ur5.yaml").read_text()


def test_timeouts_are_junit_errors_misses_failures(tmp_path, capsys):
    path = config(tmp_path, """\
jobs:
  - {command: simulate, robot: RR, name: slow, timeout: 0.001}
  - {command: simulate, robot: RR, name: short, options: [--no-plot, --t-end, 1], expect: {max: {rows: 10}}}
""")
    out = tmp_path / "out"
    assert main(["batch", str(path), "--out", str(out)]) == 1
    capsys.readouterr()
    suite = ET.parse(out / "junit.xml").getroot()
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("2", "1", "1")
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert cases["slow"].find("failure") is None
    error = cases["slow"].find("error")
    assert (error.get("type"), error.get("message")) == (
        "timeout", "anadyn batch: timed out after 0.001 s")
    assert cases["short"].find("error") is None
    assert cases["short"].find("failure").get("type") == "expectation"


def test_control_characters_cannot_break_the_junit_report(tmp_path, capsys):
    """In the robot's file name and so in the job's output and the report's names."""
    robot = tmp_path / "bell\x07\x1b[31m.yaml"
    robot.write_text(RR.read_text())
    path = config(tmp_path, """\
jobs:
  - command: simulate
    robot: "bell\\a\\e[31m.yaml"
    options: [--no-plot, --t-end, 1]
    expect: {equal: {"rows\\x02": 1, rows: 101}}
""")
    out = tmp_path / "out"
    assert main(["batch", str(path), "--out", str(out)]) == 1
    assert "rows\x02: missing in simulate.json" in capsys.readouterr().err
    case = ET.parse(out / "junit.xml").getroot().find("testcase")      # well-formed
    assert case.get("name") == "bell___31m"
    assert case.find("failure").get("message") == "rows?: missing in simulate.json"
    assert case.find("properties/property").get("name") == "rows"
    assert case.find("system-out").text.startswith("       t (s)")


def test_every_text_and_attribute_of_the_report_is_xml():
    """What XML 1.0 forbids, anywhere (a batch file's name, a figure's key, a miss, the
    output), becomes '?'; the report parses."""
    job = batch.Job("simulate", "r\x01.yaml", "rr", (), batch.Expectation())
    result = batch.JobResult(job, 1, 1.0, stdout="out \x01\x1b[31m \x0c", stderr="err \x00",
                             figures={"a\x02": 1.0}, failures=["exit \x01 code"])
    suite = ET.fromstring(batch.junit_text(batch.BatchResult(
        batch.Batch("b\x03.yaml", (job,)), [result], 1, 1.0, "2026-01-01T00:00:00+00:00")))
    case = suite.find("testcase")
    assert suite.get("name") == "anadyn batch b?.yaml"
    assert case.find("properties/property").get("name") == "a?"
    assert case.find("failure").get("message") == "exit ? code"
    assert case.find("system-out").text == "out ??[31m ?"
    assert case.find("system-err").text == "err ?"


def test_reports_keep_the_whole_output_cut_in_the_middle():
    lines = [f"line {i:05d}" for i in range(100_000)]
    text = "header\n" + "\n".join(lines) + "\nanadyn: error: the end\n"
    kept = batch.excerpt(text)
    assert kept.startswith("header\nline 00000\n") and kept.endswith("\nanadyn: error: the end")
    assert len(kept) <= batch.OUTPUT_KEPT + 100
    head, marker, tail = kept.partition(" characters left out ...]\n")
    skipped = int(head.rpartition("[... ")[2])
    assert len(head.rpartition("[... ")[0]) + skipped + len(tail) == len(text.rstrip("\n"))
    assert batch.excerpt("short\n") == "short"
    job = batch.Job("inverse", "rr.yaml", "rr", (), batch.Expectation())
    missed = batch.JobResult(job, 1, 1.0, stdout=text, stderr=text,
                             failures=["exit code 1, expected 0"])
    report = ET.fromstring(batch.junit_text(batch.BatchResult(
        batch.Batch("b.yaml", (job,)), [missed], 1, 1.0, "2026-01-01T00:00:00+00:00")))
    case = report.find("testcase")
    assert case.find("system-out").text == kept
    assert case.find("failure").text.endswith("stderr:\n" + kept)


def test_commands_run_through_the_executor_in_order_with_timeouts_and_start_failures(tmp_path):
    """executors.run_commands: results in the commands' order whatever order they end in;
    one over its timeout is killed (code None, timed out); one that cannot start is
    data, not an exception."""
    import sys

    from anadyn_cli.studies import executors

    python = sys.executable
    commands = [executors.Command((python, "-c", "import time; time.sleep(0.5); print('a')")),
                executors.Command((python, "-c", "import sys; print('b'); sys.exit(3)")),
                executors.Command((python, "-c", "import time; time.sleep(60)"), timeout=0.5),
                executors.Command((str(tmp_path / "no-such-program"),))]
    started, ended = [], []
    ran = executors.run_commands(commands, 2, on_start=started.append,
                                 on_done=lambda i, f: ended.append(i))
    assert sorted(started) == sorted(ended) == [0, 1, 2, 3]
    a, b, slow, missing = ran.results
    assert (a.code, a.stdout, a.timed_out, a.started) == (0, "a\n", False, True)
    assert (b.code, b.stdout) == (3, "b\n")
    assert (slow.code, slow.timed_out) == (None, True)
    assert (missing.code, missing.started) == (None, False) and "no-such-program" in missing.stderr
    assert (ran.executor, ran.workers) == ("local processes", 2)
