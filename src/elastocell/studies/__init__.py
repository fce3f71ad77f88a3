"""The paper's figures as studies: declarative runs executed on Dask, one tidy table each, figures, and a report
that sets every claim of the paper beside what was measured.

    from elastocell.studies import run_studies, reproduce
    run_studies(["compression-stiffness"], out="paper", quick=True)   # = elastocell study run ... --quick
    reproduce(out="paper", quick=True)                                # = elastocell reproduce --quick

``quick`` uses coarse meshes (linear tetrahedra, edge 0.3 R, 15 load steps) and coarse lattices (R/dx = 5,
a few strain units): every study on a 2-core machine in minutes, as a first look and a smoke test. Its
numbers carry the discretisation error of those meshes; the report says which mode produced it. The full
mode uses the converged defaults of each scenario.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict
from pathlib import Path

from elastocell.files import software_versions, write_json
from elastocell.parameters.units import ParameterError
from elastocell.simulation.directory import output_directory
from elastocell.simulation.distributed import check_execution, default_workers
from elastocell.studies.base import Claim, Study, read_study_table, run_members, write_study_table
from elastocell.studies.compression import locking
from elastocell.studies.registry import STUDIES, get_study, load_claims, study_names
from elastocell.studies.report import write_report
from elastocell.version import __version__


def run_studies(names, out, quick: bool = False, scheduler: str | None = None, workers: int | None = None,
                progress: bool = False, security=None) -> dict:
    """Run the named studies (their distinct runs once, through Dask), then write each study's table, figure
    and claims and ``out/report.md``. Finished runs in ``out/runs`` are reused: kill and rerun to resume.

    ``security``: a ``distributed.Security`` for a TLS scheduler (or the local cluster), see
    docs/usage/cluster.md. Returns ``{name: {"runs", "failed", "figures", "claims"}}``."""

    studies = [get_study(name) for name in names]
    check_execution(scheduler, workers)
    out = Path(out).resolve()  # workers of a remote cluster need the absolute path
    with output_directory(out):  # one invocation at a time per results directory
        _check_mode(out, quick)
        members = {study.name: study.members(quick) for study in studies}
        everything = [member for group in members.values() for member in group]
        start = time.perf_counter()
        pairs, failures, executed = run_members(everything, out, scheduler=scheduler, workers=workers, security=security,
                                                progress=progress)
        records = {id(member): record for member, record in pairs}
        summary = {}
        for study in studies:
            own = [(member, records[id(member)]) for member in members[study.name]]
            frame = study.table(own, out, quick)
            failed = sorted({record["run_id"] for _, record in own if record["status"] == "failed"})
            write_study_table(frame, out, study.name, {
                "study": study.name, "title": study.title, "figure": study.figure, "description": study.description,
                "quick": quick, "runs": len({record["run_id"] for _, record in own}), "failed_runs": failed,
                "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **_versions()})
            try:
                summary[study.name] = _finish(study, frame, out)
            except Exception as error:  # one study's analysis must not cost the others their figures and the report
                summary[study.name] = {"figures": [], "claims": []}
                failures.append((study.name, f"analysis failed: {type(error).__name__}: {error}"))
            summary[study.name].update({"runs": len({record["run_id"] for _, record in own}), "failed": failed})

        write_report(out)
        summary["_wall_time_s"] = time.perf_counter() - start
        summary["_failures"] = failures
        _log_timing(out, names, quick, scheduler, workers, summary["_wall_time_s"], pairs, executed)
        return summary


def _log_timing(out: Path, names, quick: bool, scheduler, workers, wall_time: float, pairs, executed) -> None:
    """Append this invocation to ``out/timings.jsonl`` (read by ``validation/studies.py``): the runs it
    executed and their summed run time (runs read back from earlier invocations are counted apart)."""

    records = {record["run_id"]: record for _, record in pairs}
    ran = [records[run_id] for run_id in executed if run_id in records]
    entry = {"studies": list(names), "quick": quick, "scheduler": scheduler,
             "workers": None if scheduler else (workers or default_workers()), "wall_time_s": wall_time,
             "runs": len(ran), "runs_reused": len(records) - len(ran),
             "run_time_sum_s": sum(r.get("wall_time_s") or 0.0 for r in ran),
             "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    with open(out / "timings.jsonl", "a") as handle:
        handle.write(json.dumps(entry) + "\n")


def run_study(name: str, out, quick: bool = False, scheduler: str | None = None, workers: int | None = None,
              progress: bool = False, security=None) -> dict:
    """One study (``elastocell study run NAME``): :func:`run_studies` with a single name."""
    return run_studies([name], out, quick=quick, scheduler=scheduler, workers=workers, progress=progress,
                       security=security)


def reproduce(out, quick: bool = False, scheduler: str | None = None, workers: int | None = None,
              progress: bool = False, security=None) -> dict:
    """Every study, sharing runs, into one directory with one report."""
    return run_studies(study_names(), out, quick=quick, scheduler=scheduler, workers=workers, progress=progress,
                       security=security)


def plot_study(name: str, directory) -> dict:
    """Redraw a study's figure and re-derive its claims from its table (no simulation); rewrite the report."""
    study = get_study(name)
    directory = Path(directory)
    frame, _ = read_study_table(directory, name)
    result = _finish(study, frame, directory)

    write_report(directory)
    return result


def _finish(study: Study, frame, out: Path) -> dict:
    figures = study.plot(frame, out, study.name)
    claims, moved = judge(study, frame)

    write_json(out / f"{study.name}.claims.json", {"study": study.name, "claims": [asdict(c) for c in claims],
                                                    "discretisation": moved})
    return {"figures": [str(p) for p in figures], "claims": claims}


def judge(study: Study, frame) -> tuple[list[Claim], dict]:
    """The study's claims on its primary discretisation, each with its verdict on the other discretisations
    (does it survive on the converged mesh?), and how far the others move each curve (:func:`locking`)."""

    if not study.by_discretisation or "discretisation" not in frame or frame.empty:
        return study.claims(frame), {}
    names = list(dict.fromkeys(frame["discretisation"]))
    claims = study.claims(frame[frame["discretisation"] == names[0]])
    for claim in claims:
        claim.discretisation = names[0]
    for name in names[1:]:
        others = {c.claim: c for c in study.claims(frame[frame["discretisation"] == name])}
        for claim in claims:
            if claim.claim in others:
                claim.other_discretisations[name] = {"verdict": others[claim.claim].verdict,
                                                     "measured": others[claim.claim].measured}
    return claims, locking(frame)


def _check_mode(out: Path, quick: bool) -> None:
    """A directory holds one mode: mixing quick and full runs in one report would mislead."""
    marker = out / "study_mode.json"
    mode = "quick" if quick else "full"
    if marker.exists():
        previous = json.loads(marker.read_text()).get("mode")
        if previous != mode:
            raise ParameterError("out", f"{out} holds {previous} results; use another directory for {mode} runs")
    else:
        marker.write_text(json.dumps({"mode": mode}) + "\n")


def _versions() -> dict:

    return {"elastocell_version": __version__, "software": software_versions()}


__all__ = ["STUDIES", "Claim", "Study", "get_study", "load_claims", "plot_study", "reproduce", "run_studies", "run_study",
           "study_names"]
