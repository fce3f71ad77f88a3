"""Wall time of the studies: `elastocell reproduce --quick` with 1 and 2 workers, and an estimate of the full
reproduction from a sample of full-size runs.

    python validation/studies.py --quick-dir paper-quick          # summarise an existing reproduction
    python validation/studies.py --run --workers 1 2 --out /tmp/b  # run reproduce --quick per worker count
    python validation/studies.py --full-dir paper                  # estimate the full reproduction

Prints one table: invocations (studies, workers, wall time, runs, summed run time, parallel efficiency) and,
for a directory, the summed run time per scenario. The full estimate multiplies the mean measured run time of
each scenario in --full-dir by the number of runs the full studies declare (stated as an estimate). The tables
go into docs/validation/studies.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

from page import Page


def invocations(directory: Path) -> list[dict]:
    path = directory / "timings.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def run_times(directory: Path) -> dict[str, list[float]]:
    times = defaultdict(list)
    for path in sorted((directory / "runs").glob("*/run.json")):
        record = json.loads(path.read_text())
        if record.get("wall_time_s") is not None:
            times[record["scenario"]].append(record["wall_time_s"])
    return times


def summarise(directory: Path, page) -> None:
    rows = []
    for entry in invocations(directory):
        workers = entry.get("workers") or 1
        efficiency = entry["run_time_sum_s"] / (workers * entry["wall_time_s"]) if entry["wall_time_s"] else 0
        rows.append({"studies": len(entry["studies"]), "workers": workers, "wall (s)": entry["wall_time_s"],
                     "runs": entry["runs"], "sum of runs (s)": entry["run_time_sum_s"], "efficiency": efficiency})
    page.table(rows, f"Invocations recorded in {directory}/timings.jsonl",
               formats={"wall (s)": ".0f", "sum of runs (s)": ".0f", "efficiency": ".2f"})
    page.table([{"scenario": scenario, "runs": len(times), "sum (s)": sum(times), "mean (s)": sum(times) / len(times),
                 "max (s)": max(times)} for scenario, times in run_times(directory).items()],
               f"Run time per scenario in {directory}/runs",
               formats={"sum (s)": ".0f", "mean (s)": ".1f", "max (s)": ".1f"})


def estimate_full(directory: Path, workers: int, page) -> None:
    from elastocell.studies import STUDIES

    runs = {m.run for study in STUDIES.values() for m in study.members(False)}
    counts = defaultdict(int)
    for run in runs:
        counts[run.scenario] += 1
    measured = run_times(directory)
    total = 0.0
    rows = []
    for scenario, count in counts.items():
        sample = measured.get(scenario)
        if not sample:
            rows.append({"scenario": scenario, "runs declared": count, "note": "no measured sample"})
            continue
        mean = sum(sample) / len(sample)
        total += count * mean
        rows.append({"scenario": scenario, "runs declared": count, "mean run (s)": mean, "sample": len(sample),
                     "estimate (h)": count * mean / 3600})
    page.table(rows, f"Full reproduction, an estimate from the runs measured in {directory}",
               columns=["scenario", "runs declared", "mean run (s)", "sample", "estimate (h)", "note"],
               formats={"mean run (s)": ".1f", "estimate (h)": ".2f"})
    page.print(f"sum {total / 3600:.2f} h of run time; on {workers} workers at least {total / workers / 3600:.2f} h "
               "(an estimate)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick-dir", type=Path, action="append", default=[])
    parser.add_argument("--full-dir", type=Path)
    parser.add_argument("--run", action="store_true", help="run `elastocell reproduce --quick` per worker count")
    parser.add_argument("--workers", type=int, nargs="+", default=[2])
    parser.add_argument("--out", type=Path, default=Path("/tmp/elastocell-bench-studies"))
    args = parser.parse_args()
    page = Page("studies", "studies.py", intro=(
        "A cost measurement, not a comparison with a reference: the wall time of `elastocell reproduce` (the "
        "paper's studies as Dask tasks), the number of runs and their summed run time, and the parallel "
        "efficiency = summed run time / (workers x wall time), which is 1 for perfect use of the workers. With "
        "`--full-dir`, the full reproduction is estimated from the mean measured run time of each scenario times "
        "the number of runs the studies declare (an estimate, stated as one)."), versions=("dask", "distributed"))
    directories = list(args.quick_dir)
    if args.run:
        for workers in args.workers:
            directory = args.out / f"workers{workers}"
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "elastocell", "reproduce", "--quick", "--quiet", "--workers",
                            str(workers), "--out", str(directory)], check=False)
            page.print(f"reproduce --quick, {workers} workers: {time.perf_counter() - start:.0f} s")
            directories.append(directory)
    for directory in directories:
        summarise(directory, page)
    if args.full_dir:
        summarise(args.full_dir, page)
        estimate_full(args.full_dir, max(args.workers), page)
    page.write()

if __name__ == "__main__":
    main()
