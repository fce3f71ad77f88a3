"""A sweep over the nucleus stiffness ratio through Dask: each cell and its homogeneous equivalent, and a tidy table
of the force ratio F/F_eq against delta.

Every curve is one run of ``elastocell.compress`` declared with the studies' machinery (``Run``/``Member``);
``run_members`` executes the distinct runs on a local Dask cluster (``--workers N``) or on an existing one
(``--scheduler tcp://HOST:8786``, with the output directory on a file system the workers share). Each run keeps
its files in ``OUT/runs/<run_id>/``; a finished run (its ``run.json``) is read back, so a killed sweep resumes
where it stopped when started again.

    python examples/parameter_sweep.py --workers 2     # full size: ratios 2, 5, 10, 20, each cell and equivalent
    python examples/parameter_sweep.py --scheduler tcp://HOST:8786
    ELASTOCELL_EXAMPLE_SMOKE=1 python examples/parameter_sweep.py   # ratio 5 only, coarse p1 mesh, 1 worker

Time on a 2-core machine: full size estimated (not run) at 5-8 min on 2 workers when idle: 8 curves on the
default p2 mesh of 40-100 s each (a reference-cell curve took 292 s here with the cores shared). Smoke: 25-35 s,
most of it starting the local cluster; a rerun reads both runs back in under 10 s.

Output: ``$ELASTOCELL_EXAMPLE_OUT`` (default ``example-output/parameter_sweep``, ``-smoke`` appended in smoke
mode): ``sweep.csv`` (one row per stiffness ratio and delta) and ``runs/``.
"""

import argparse
import os
from pathlib import Path

import numpy as np
import pandas as pd

from elastocell.studies.base import Member, Run, rows_per_delta, run_members

SMOKE = os.environ.get("ELASTOCELL_EXAMPLE_SMOKE") == "1"
OUT = Path(os.environ.get("ELASTOCELL_EXAMPLE_OUT", "example-output/parameter_sweep" + ("-smoke" if SMOKE else ""))).resolve()


def main():
    parser = argparse.ArgumentParser(description="F/F_eq against delta for several nucleus stiffness ratios")
    parser.add_argument("--workers", type=int, default=None, help="local Dask cluster of N processes (default: 1 per core)")
    parser.add_argument("--scheduler", default=None, help="address of an existing Dask scheduler")
    args = parser.parse_args()
    workers = 1 if SMOKE and args.scheduler is None and args.workers is None else args.workers

    if SMOKE:
        ratios = [5.0]
        options = dict(element="p1", mesh_size=0.5, pole_size=0.5, delta_max=0.3, steps=4, vtk=False)
    else:
        ratios = [2.0, 5.0, 10.0, 20.0]
        options = dict(vtk=False)  # default p2 mesh and 40 load steps; no VTK files for a table

    # One Member per curve: the run (the keyword arguments of elastocell.compress) and labels for the table.
    members = []
    for gamma in ratios:
        cell = dict(stiffness_ratio=gamma, size_ratio=0.5, **options)
        members.append(Member(Run.of("compress", **cell), {"stiffness_ratio": gamma, "curve": "cell"}))
        members.append(Member(Run.of("compress", **cell, equivalent=True), {"stiffness_ratio": gamma, "curve": "equivalent"}))

    pairs, failures, executed = run_members(members, OUT, scheduler=args.scheduler, workers=workers, progress=not SMOKE)
    print(f"{len(executed)} curve(s) computed now, {len({m.run for m in members}) - len(executed)} read back from {OUT / 'runs'}")
    for run_id, error in failures:
        print(f"failed: {run_id}: {error}")

    # rows_per_delta: one row per converged delta of every curve, with its labels. Pair cell and equivalent on delta
    # (both use the same load steps); a curve that stopped early keeps the deltas it reached.
    rows = pd.DataFrame(rows_per_delta(pairs))
    rows = rows[rows["status"] != "failed"]
    forces = rows.pivot_table(index=["stiffness_ratio", "delta"], columns="curve", values="force_per_Ec_R2")
    table = forces.rename(columns={"cell": "force_cell", "equivalent": "force_equivalent"}).reset_index()
    table["force_ratio"] = table["force_cell"] / table["force_equivalent"]
    table = table[table["delta"] > 0].dropna(subset=["force_ratio"])
    table.to_csv(OUT / "sweep.csv", index=False, float_format="%.6g")

    # F/F_eq at a few deltas (interpolated between load steps), one column per stiffness ratio.
    deltas = [0.1, 0.3, 0.5, 0.7]
    summary = pd.DataFrame({gamma: [np.interp(d, g["delta"], g["force_ratio"]) if d <= g["delta"].max() + 1e-9
                                    else np.nan for d in deltas]
                            for gamma, g in table.groupby("stiffness_ratio")}, index=pd.Index(deltas, name="delta"))
    summary.columns.name = "F/F_eq at stiffness ratio"
    print(summary.dropna(how="all").round(3).to_string())  # NaN: a curve that stopped before delta
    print(f"table: {OUT / 'sweep.csv'}")


if __name__ == "__main__":  # required: the local cluster starts worker processes that import this file
    main()
