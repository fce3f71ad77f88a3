"""Command line: ``elastocell study list|run|plot`` and ``elastocell reproduce`` (the paper's figures as
studies, run through Dask). Registered in :mod:`elastocell.cli.app`."""

from __future__ import annotations

from pathlib import Path

import typer

from elastocell.cli.common import fail, user_errors
from elastocell.cli.options import opt, takes

study_app = typer.Typer(add_completion=False, no_args_is_help=True,
                        help="The paper's figures as studies: list, run (through Dask), plot.")

STUDY_OUT = opt("out", help="Output directory (rerun to resume).")


@study_app.command("list")
def study_list():
    """Name, paper figure and content of every study."""
    from elastocell.studies import (
        STUDIES,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    for study in STUDIES.values():
        typer.echo(f"{study.name:28s} {study.figure:45s} {study.title}")


def _report(summary: dict, out: Path, quiet: bool) -> None:
    failures = summary.get("_failures", [])
    if not quiet:
        for name, result in summary.items():
            if name.startswith("_"):
                continue
            verdicts = [c.verdict for c in result["claims"]]
            typer.echo(f"{name}: {result['runs']} runs, {len(result['failed'])} failed; claims: "
                       + (", ".join(f"{verdicts.count(v)} {v}" for v in dict.fromkeys(verdicts)) or "none")
                       + f" -> {out / (name + '.png')}")
        typer.echo(f"report: {out / 'report.md'} ({summary['_wall_time_s']:.0f} s)")
    for run_id, message in failures:
        typer.echo(f"elastocell: error: run {run_id} failed: {message}", err=True)
    if failures:
        raise typer.Exit(code=1)


@study_app.command("run")
@user_errors
@takes("name", "quick", "scheduler", "workers", STUDY_OUT, "quiet")
def study_run(name: str, quick: bool, scheduler: str | None, workers: int | None, out: Path, quiet: bool):
    """Run one study: its simulations through Dask, then its table, figure, claims and DIR/report.md."""
    from elastocell.studies import (
        run_studies,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    summary = run_studies([name], out, quick=quick, scheduler=scheduler, workers=workers,
                          progress=not quiet)
    _report(summary, out, quiet)


@study_app.command("plot")
@user_errors
@takes(opt("name", help="Study name."), "directory")
def study_plot(name: str, directory: Path):
    """Redraw a study's figure (PNG, PDF) and re-derive its claims from its table; no simulation."""
    from elastocell.studies import (
        plot_study,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    if not directory.is_dir():
        fail(f"DIRECTORY: {directory} is not a directory")
    result = plot_study(name, directory)
    typer.echo(f"{name}: {', '.join(result['figures'])}; report: {directory / 'report.md'}")


@user_errors
@takes("quick", "scheduler", "workers", STUDY_OUT, "quiet")
def reproduce(quick: bool, scheduler: str | None, workers: int | None, out: Path, quiet: bool):
    """Run every study of the paper (shared runs once) and write DIR/report.md with each claim's verdict."""
    from elastocell.studies import (
        reproduce as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    summary = run(out, quick=quick, scheduler=scheduler, workers=workers, progress=not quiet)
    _report(summary, out, quiet)
