"""What a batch reports: the line per finished job, the table and totals on stdout,
summary.csv, summary.json and junit.xml."""
from __future__ import annotations

import csv
import io
import re
from pathlib import Path

from ... import files as output
from .judge import BatchResult, JobResult, show_value

OUTPUT_KEPT = 200_000                # characters of a job's stdout (and stderr) in the reports


def excerpt(text: str, kept: int = OUTPUT_KEPT) -> str:
    """``text`` whole, or beyond ``kept`` characters its first and last lines around one
    saying how much was left out between them (table headers and the final error stay)."""
    text = text.rstrip("\n")
    if len(text) <= kept:
        return text
    head, tail = text[: kept // 2], text[len(text) - kept // 2:]
    head = head[: head.rfind("\n") + 1] or head          # whole lines, where there are any
    tail = tail[tail.find("\n") + 1:] or tail
    return f"{head}[... {len(text) - len(head) - len(tail)} characters left out ...]\n{tail}"


def job_line(result: JobResult, finished: int, total: int) -> str:
    """``[3/12] ok   simulate rr  0.9 s`` (the first miss after a colon)."""
    line = (f"[{finished}/{total}] {result.status:<4} {result.job.command} {result.job.name}"
            f"  {result.wall:.1f} s")
    return line + (f": {'; '.join(result.failures)}" if result.failures else "")


def figures_text(result: JobResult) -> str:
    return "; ".join(f"{k}={show_value(v)}" for k, v in result.figures.items())


def table(result: BatchResult) -> str:
    header = ["job", "status", "exit", "expected", "wall s", "figures"]
    body = [[r.job.key, r.status, "-" if r.exit_code is None else str(r.exit_code),
             r.job.expect.describe_exit(), f"{r.wall:.1f}", figures_text(r)]
            for r in result.results]
    widths = [max(len(row[i]) for row in [header, *body]) for i in range(len(header) - 1)]
    return "\n".join("  ".join(f"{c:<{w}}" for c, w in zip(row, widths)) + "  " + row[-1]
                     for row in [header, *body])


def totals_line(result: BatchResult) -> str:
    failed = len(result.failed)
    return (f"batch {result.batch.source}: {len(result.results)} jobs, "
            f"{len(result.results) - failed} ok, {failed} failed, {result.wall:.1f} s "
            f"on {result.workers} worker{'s' if result.workers != 1 else ''}")


def _job_dict(result: JobResult, out: Path) -> dict:
    job = result.job
    return {"name": job.name, "command": job.command, "robot": job.robot,
            "options": list(job.options), "status": result.status, "ok": result.ok,
            "exit_code": result.exit_code, "expected_exit_code": job.expect.exit_code,
            "wall_s": result.wall, "figures": result.figures, "failures": result.failures,
            "folder": str(job.folder(out)), "argv": job.argv(out)[1:],
            "stdout": excerpt(result.stdout), "stderr": excerpt(result.stderr)}


def summary(result: BatchResult, out: Path) -> dict:
    """``summary.json``."""
    return {"batch": result.batch.source, "description": result.batch.description,
            "started": result.started, "wall_s": result.wall, "workers": result.workers,
            "jobs_total": len(result.results), "jobs_failed": len(result.failed),
            "passed": not result.failed,
            "failed": [r.job.key for r in result.failed],
            "jobs": [_job_dict(r, out) for r in result.results]}


def csv_text(result: BatchResult, out: Path) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["command", "name", "robot", "status", "exit_code", "expected_exit_code",
                     "wall_s", "figures", "failures", "folder"])
    for r in result.results:
        writer.writerow([r.job.command, r.job.name, r.job.robot, r.status,
                         "" if r.exit_code is None else r.exit_code,
                         r.job.expect.describe_exit(), f"{r.wall:.3f}", figures_text(r),
                         "; ".join(r.failures), str(r.job.folder(out))])
    return buffer.getvalue()


_NOT_XML = re.compile("[^\t\n\r\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _xml_text(text: str) -> str:
    """``text`` with what XML 1.0 forbids, or discourages (controls, noncharacters),
    as ``?``: a control character in a job's output cannot break the report."""
    return _NOT_XML.sub("?", str(text))


def junit_text(result: BatchResult) -> str:
    """One <testsuite>, one <testcase> per job (classname = command, name = job name): a
    miss is a <failure>, a job that did not finish (timed out, could not start) an
    <error>; every text and attribute goes through ``_xml_text``."""
    import xml.etree.ElementTree as ET

    def element(parent, tag: str, text: str | None = None, **attributes):
        node = (ET.Element(tag) if parent is None else ET.SubElement(parent, tag))
        node.attrib.update({k: _xml_text(v) for k, v in attributes.items()})
        if text is not None:
            node.text = _xml_text(text)
        return node

    errors = [r for r in result.failed if r.error]
    suite = element(None, "testsuite", name=f"anadyn batch {result.batch.source}",
                    tests=str(len(result.results)),
                    failures=str(len(result.failed) - len(errors)), errors=str(len(errors)),
                    skipped="0", time=f"{result.wall:.3f}", timestamp=result.started)
    for r in result.results:
        case = element(suite, "testcase", classname=r.job.command, name=r.job.name,
                       time=f"{r.wall:.3f}")
        if r.failures:
            kind = (("error", "timeout" if r.timed_out else "not-run") if r.error
                    else ("failure", "expectation"))
            element(case, kind[0], "\n".join(r.failures) + "\n\nstderr:\n" + excerpt(r.stderr),
                    message=r.failures[0], type=kind[1])
        if r.figures:
            properties = element(case, "properties")
            for key, value in r.figures.items():
                element(properties, "property", name=key, value=show_value(value))
        element(case, "system-out", excerpt(r.stdout))
        if r.stderr.strip():
            element(case, "system-err", excerpt(r.stderr))
    ET.indent(suite)
    return ET.tostring(suite, encoding="unicode", xml_declaration=True) + "\n"


@output.one_set
def write(result: BatchResult, out: Path) -> list[Path]:
    """summary.csv, summary.json and junit.xml in ``out``, written with signals held."""
    from ... import progress

    out = output.prepare_dir(out)
    written = [out / "summary.csv", out / "summary.json", out / "junit.xml"]
    texts = (csv_text(result, out), summary(result, out), junit_text(result))
    with progress.uninterrupted():        # the three of this batch, or those there before
        output.write_text(written[0], texts[0])
        output.write_json(written[1], texts[1])
        output.write_text(written[2], texts[2])
    return written
