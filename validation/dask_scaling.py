"""Speed-up of a sweep through Dask: the same pipe-flow look-up-table grid with 1 and with N local workers.

    python validation/dask_scaling.py [--workers 1 2] [--duration 30] [--resolution 4]

Workload: a 2 x 2 look-up-table grid (``--radii`` 5, 6 um x ``--moduli`` 3, 5 kPa, R_ch = 10 um,
Q = 0.04 uL/s, eta = 15 mPa s) run for ``--duration`` units of 1/gdot_w at ``--resolution`` R/dx with no
stationarity stop, so every worker count does the same work, each in a fresh directory (nothing is read back).
Softer cells at long durations reach the wall at R/dx 4 and fail, which would spoil the comparison.

Every worker is a single-threaded process (``elastocell.simulation.distributed``), so one worker runs the points one after
the other on one core. Printed: first, the same points one after the other in this process with all its Numba
threads (the alternative to Dask on one machine); then, per worker count, the wall time of the whole grid
(cluster start included), the sum of the per-point run times, the speed-up against the first worker count and
the parallel efficiency. Run it on an otherwise idle machine: another job on the same cores makes the figures
meaningless. The tables go into docs/validation/studies.md
(``validation/page.py``).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numba
from page import Page

from elastocell.inverse.lut import compute_lut, plan, run_point


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--resolution", type=float, default=4.0)
    parser.add_argument("--radii", default="5,6", help="um, comma-separated")
    parser.add_argument("--moduli", default="3,5", help="kPa, comma-separated",
                        type=lambda text: [f"{m.strip()}kPa" for m in text.split(",")])
    args = parser.parse_args(argv)
    page = Page("studies", "dask_scaling.py", intro=(
        "What Dask buys on this machine: the same pipe-flow look-up-table grid (radii x moduli, R_ch = 10 um, "
        "Q = 0.04 uL/s, eta = 15 mPa s) run for a fixed duration at a fixed R/dx with no stationarity stop, so "
        "every worker count does the same work. The reference is the same points one after the other in this "
        "process with all its Numba threads; per worker count, the wall time of the whole grid (cluster start "
        "included), the sum of the per-point run times, the speed-up against the first worker count and the "
        "parallel efficiency. Every worker is a single-threaded process. Other jobs on the same cores make the "
        "figures meaningless: the load average in the footer says how idle the machine was."),
        versions=("numba", "dask", "distributed"))
    page.print(f"cores available: {len(os.sched_getaffinity(0))}, load average before: {os.getloadavg()[0]:.2f}")
    points, _ = plan("10um", "0.04uL/s", "15mPa*s", radii=args.radii, moduli=args.moduli, quick=True,
                     duration=args.duration, resolution=args.resolution)
    with tempfile.TemporaryDirectory() as folder:
        run_point((points[0], folder))  # compile / warm the kernels of this process
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        for point in points:
            run_point((point, folder))
        loop = time.perf_counter() - start
    page.print(f"in this process, one point after the other, {numba.get_num_threads()} Numba threads: {loop:.1f} s")
    rows = []
    first = None
    for workers in args.workers:
        with tempfile.TemporaryDirectory() as folder:
            start = time.perf_counter()
            result = compute_lut(Path(folder) / "lut.txt", "10um", "0.04uL/s", "15mPa*s", quick=True,
                                 radii=args.radii, moduli=args.moduli, duration=args.duration,
                                 resolution=args.resolution, workers=workers)
            wall = time.perf_counter() - start
            summed = sum(record["wall_time_s"] for record in result["records"])
        for failure in result["failures"]:
            page.print(f"failed {failure['key']}: {failure['error']}")
        if result["failures"]:
            page.print("some points failed: the worker counts did different work; no speed-up printed")
            break
        first = first or wall
        speedup = first / wall
        rows.append({"workers": workers, "points": len(result["records"]), "wall_s": wall, "summed_point_s": summed,
                     "speed-up": speedup, "efficiency": speedup / workers * args.workers[0]})
    page.table(rows, "Dask local cluster", formats={"wall_s": ".1f", "summed_point_s": ".1f", "speed-up": ".2f",
                                                     "efficiency": ".2f"})
    page.write()

if __name__ == "__main__":
    main()
