"""Wall time of the studies: `elastocell reproduce --quick` with 1 and 2 workers, and an estimate of the full
reproduction from a sample of full-size runs.

    python validation/studies.py --quick-dir paper-quick          # summarise an existing reproduction
    python validation/studies.py --run --workers 1 2 --out /tmp/b  # run reproduce --quick per worker count
    python validation/studies.py --full-dir paper                  # estimate the full reproduction

Prints one table: invocations (studies, workers, wall time, runs, summed run time, parallel efficiency) and,
for a directory, the summed run time per scenario. The full estimate multiplies the mean measured run time of
each scenario in --full-dir by the number of runs the full studies declare (stated as an estimate).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path


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


def summarise(directory: Path) -> None:
    print(f"\n{directory}")
    print(f"{'studies':>10} {'workers':>7} {'wall (s)':>9} {'runs':>5} {'sum of runs (s)':>16} {'efficiency':>10}")
    for entry in invocations(directory):
        workers = entry.get("workers") or 1
        efficiency = entry["run_time_sum_s"] / (workers * entry["wall_time_s"]) if entry["wall_time_s"] else 0
        print(f"{len(entry['studies']):>10} {workers:>7} {entry['wall_time_s']:>9.0f} {entry['runs']:>5} "
              f"{entry['run_time_sum_s']:>16.0f} {efficiency:>10.2f}")
    for scenario, times in run_times(directory).items():
        print(f"  {scenario:8s} {len(times):4d} runs, {sum(times):8.0f} s in all, mean {sum(times) / len(times):7.1f} s,"
              f" max {max(times):7.1f} s")


def estimate_full(directory: Path, workers: int) -> None:
    from elastocell.studies import STUDIES

    runs = {m.run for study in STUDIES.values() for m in study.members(False)}
    counts = defaultdict(int)
    for run in runs:
        counts[run.scenario] += 1
    measured = run_times(directory)
    total = 0.0
    print(f"\nfull reproduction (estimate from the runs measured in {directory}):")
    for scenario, count in counts.items():
        sample = measured.get(scenario)
        if not sample:
            print(f"  {scenario:8s} {count:4d} runs: no measured sample")
            continue
        mean = sum(sample) / len(sample)
        total += count * mean
        print(f"  {scenario:8s} {count:4d} runs x {mean:7.1f} s (mean of {len(sample)}) = {count * mean / 3600:6.2f} h")
    print(f"  sum {total / 3600:.2f} h of run time; on {workers} workers at least {total / workers / 3600:.2f} h")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick-dir", type=Path, action="append", default=[])
    parser.add_argument("--full-dir", type=Path)
    parser.add_argument("--run", action="store_true", help="run `elastocell reproduce --quick` per worker count")
    parser.add_argument("--workers", type=int, nargs="+", default=[2])
    parser.add_argument("--out", type=Path, default=Path("/tmp/elastocell-bench-studies"))
    args = parser.parse_args()
    directories = list(args.quick_dir)
    if args.run:
        for workers in args.workers:
            directory = args.out / f"workers{workers}"
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "elastocell", "reproduce", "--quick", "--quiet", "--workers",
                            str(workers), "--out", str(directory)], check=False)
            print(f"reproduce --quick, {workers} workers: {time.perf_counter() - start:.0f} s")
            directories.append(directory)
    for directory in directories:
        summarise(directory)
    if args.full_dir:
        summarise(args.full_dir)
        estimate_full(args.full_dir, max(args.workers))


if __name__ == "__main__":
    main()
