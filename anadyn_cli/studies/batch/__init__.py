"""Many anadyn runs from one YAML file, in parallel, with one summary and a CI exit code.

A batch file lists jobs; each runs one command on one robot in its own
process and is judged by its exit code and the key figures the command
writes to ``<command>.json``:

    description: what this batch is for            # optional
    timeout: 600                                   # optional, s per job (default: none)
    jobs:
      - command: inverse                           # any command that takes a robot
        robot: ../robots/rr.yaml                   # relative to this file's folder, or a
                                                   # library name (ur5)
        name: rr                                   # optional; default: the robot file's stem
        options: [--no-plot, --dt, 0.05]           # or a mapping {no-plot: true, dt: 0.05}
        expect:
          exit_code: 0                             # default 0
          max: {roundtrip.max_error: 1e-6}         # value <= bound
          min: {points: 100}                       # value >= bound
          equal: {roundtrip.passed: true}          # value == given
      - command: simulate
        robot: ../robots/broken.yaml
        must_fail: 2                               # shorthand for expect.exit_code: 2

Keys under max/min/equal are dotted paths into ``<command>.json``
(``rows.0.max_error`` indexes a list); a key that is missing there is a
miss that names it.  A mapping of options becomes ``--key value``
(``--key`` for true, ``--no-key`` for false); the job's folder is set by
the batch: ``OUT/<command>/<name>/`` (``--out``; ``import`` writes
``<name>.yaml`` there, ``equations`` prints only), which also receives
``stdout.txt`` and ``stderr.txt``.

Each job runs ``python -m anadyn_cli COMMAND OPTIONS --out FOLDER -- ROBOT``
(after ``--`` a robot named like an option is still a robot) as a command of
``studies.executors`` (``run_commands``: a process group of its own, up to
``workers`` at a time; or one piece each on a Dask cluster); ``run`` returns
every result.  A job over its timeout is killed with its whole group (its own
workers too).  An interruption of the batch (``Interrupted``,
KeyboardInterrupt) stops every running job's group (SIGTERM, then SIGKILL
after ``executors.STOP_GRACE`` s) and writes nothing more.  While it runs,
``run`` shows the jobs done, running and failed through ``anadyn_cli.progress``
(one line per finished job in a log).
``write`` gives summary.csv, summary.json and junit.xml (a miss is a
``<failure>``, a job that timed out or could not start an ``<error>``, each
with the job's whole output, cut in the middle beyond ``OUTPUT_KEPT``
characters); ``raise_if_failed`` raises ``CheckFailed`` naming each job that
missed its expectation.

Modules: ``plan`` (the file), ``running`` (the jobs), ``judge`` (their results),
``reports`` (what is written).
"""
from .judge import BatchResult, JobResult, judge, last_line, lookup, raise_if_failed
from .plan import COMMANDS, MAX_TIMEOUT, Batch, Expectation, Job, load_batch
from .reports import (OUTPUT_KEPT, csv_text, excerpt, figures_text, job_line, junit_text,
                      summary, table, totals_line, write)
from .running import run, run_job, run_remote

__all__ = ["Batch", "BatchResult", "COMMANDS", "Expectation", "Job", "JobResult",
           "MAX_TIMEOUT", "OUTPUT_KEPT", "csv_text", "excerpt", "figures_text", "job_line",
           "judge", "junit_text", "last_line", "load_batch", "lookup", "raise_if_failed",
           "run", "run_job", "run_remote", "summary", "table", "totals_line", "write"]
