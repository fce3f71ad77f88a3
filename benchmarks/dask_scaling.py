"""Speed-up of a sweep through Dask: the same pipe-flow look-up-table grid with 1 and with N local workers.

    python benchmarks/dask_scaling.py [--workers 1 2] [--duration 3] [--resolution 4]

Workload: ``elastocell lut --quick``'s 2 x 2 grid (R = 5, 6 um x E = 1, 2 kPa, R_ch = 10 um, Q = 0.04 uL/s,
eta = 15 mPa s) run for ``--duration`` units of 1/gdot_w at ``--resolution`` R/dx, each worker count in a fresh
directory (nothing is read back). Every worker is a single-threaded process (``elastocell.distributed``), so one
worker runs the points one after the other on one core. Printed: wall time of the whole grid (cluster start
included), the sum of the per-point run times, speed-up against the first worker count, and parallel efficiency.
Run it on an otherwise idle machine: another job on the same cores makes the figures meaningless.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from elastocell.lut import compute_lut


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--duration", type=float, default=3.0)
    parser.add_argument("--resolution", type=float, default=4.0)
    args = parser.parse_args(argv)
    print(f"cores available: {len(os.sched_getaffinity(0))}, load average before: {os.getloadavg()[0]:.2f}")
    print("workers | points | wall_s | summed_point_s | speed-up | efficiency")
    first = None
    for workers in args.workers:
        with tempfile.TemporaryDirectory() as folder:
            start = time.perf_counter()
            result = compute_lut(Path(folder) / "lut.txt", "10um", "0.04uL/s", "15mPa*s", quick=True,
                                 duration=args.duration, resolution=args.resolution, workers=workers)
            wall = time.perf_counter() - start
            summed = sum(record["wall_time_s"] for record in result["records"])
        first = first or wall
        speedup = first / wall
        print(f"{workers} | {len(result['records'])} | {wall:.1f} | {summed:.1f} | {speedup:.2f} | "
              f"{speedup / workers * args.workers[0]:.2f}")


if __name__ == "__main__":
    main()
