"""anadyn batch: many runs from one YAML file, in parallel, for CI."""
from __future__ import annotations

from pathlib import Path

import typer



def batch(
    config: Path = typer.Argument(..., help="Batch file (YAML) listing the jobs.",
                                  show_default=False),
    jobs: int = typer.Option(None, "--jobs", "-j", help="Jobs run at the same time "
                                                        "[default: all cores]."),
    out: Path = typer.Option(None, "--out", help="Output folder [default: results/NAME/, "
                                                 "NAME the batch file's stem]."),
    scheduler: str = typer.Option(None, "--scheduler", metavar="ADDRESS",
                                  help="Run the jobs on a Dask cluster, e.g. "
                                       "tcp://10.0.0.5:8786 [default: $ANADYN_SCHEDULER, "
                                       "else local processes]."),
) -> None:
    """Run the jobs of CONFIG in parallel processes and judge each against its expectations.

    Shows the jobs done, running and failed on a terminal, and one line per
    finished job on stderr otherwise (or when CI is set); writes summary.csv,
    summary.json and junit.xml; exit 1 naming every job that missed its expectation.
    """
    from ..studies import batch as service
    from ..studies import executors

    plan = service.load_batch(config)
    address = executors.scheduler_address(scheduler)
    client = executors.connect(address) if address is not None else None
    folder = out if out is not None else Path("results") / config.stem
    try:
        result = service.run(plan, folder, jobs, scheduler=client)
    finally:
        if client is not None:
            client.close()
    written = service.write(result, folder)
    typer.echo(service.table(result))
    typer.echo(service.totals_line(result))
    typer.echo("wrote " + ", ".join(str(p) for p in written))
    service.raise_if_failed(result)
