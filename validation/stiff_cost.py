"""Cost of ``elastocell compress`` on its defaults for every stiffness ratio: the wall time of one curve from a new
process, against the homogeneous cell's in the same run.

    nice python validation/stiff_cost.py [--ratios 0 2 5 10 20] [--no-page]

Ratio 0 is the homogeneous cell (``--nucleus none``); every other ratio is a nucleus of size ratio 0.5
(``--stiffness-ratio G --size-ratio 0.5``), 40 load steps to delta 0.75, as in the accuracy table of
validation/stiff_mesh.py. Each command runs once with ``--delta-max 0.01 --steps 1`` first (its mesh into the mesh
cache, JAX's and Numba's kernels into theirs), then once timed: what a user pays for a curve after the first.
The commands run one after the other, so the figures are those of an idle machine only if nothing else ran:
the load average before and after each timed run is in the table. Writes its section of
docs/validation/axisymmetric.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from page import Page

DEFAULT_RATIOS = [0, 2, 5, 10, 20]


def command(ratio: float, out: Path, quick: bool) -> list[str]:
    cell = ["--nucleus", "none"] if ratio == 0 else ["--stiffness-ratio", f"{ratio:g}", "--size-ratio", "0.5"]
    load = ["--delta-max", "0.01", "--steps", "1"] if quick else ["--delta-max", "0.75"]
    return [sys.executable, "-m", "elastocell", "compress", *cell, *load, "--out", str(out), "--quiet"]


def timed(ratio: float, work: Path) -> dict:
    """Warm-up, then the timed curve; its metadata's mesh and its exit status."""
    subprocess.run(command(ratio, work / "warm", True), check=True, capture_output=True)
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    done = subprocess.run(command(ratio, work / "curve", False), capture_output=True, text=True)
    seconds = time.perf_counter() - start
    path = work / "curve" / "metadata.json"  # written by a curve that stopped early too (exit 1)
    metadata = json.loads(path.read_text()) if path.exists() else {}
    return {"seconds": seconds, "exit": done.returncode, "load_before": load_before,
            "load_after": os.getloadavg()[0], "metadata": metadata, "stderr": done.stderr[-300:]}


def mesh_of(metadata: dict) -> dict:
    """Nodes and sizes of the curve's mesh from its metadata (empty where the run failed)."""
    mesh = metadata.get("cell", {}).get("mesh", {})
    return {"nodes": metadata.get("mesh", {}).get("n_nodes", ""),
            "surface": mesh.get("interface_size", ""), "bulk": mesh.get("mesh_size", ""),
            "degree": mesh.get("quadrature_degree") or 2, "delta_reached": metadata.get("delta_reached", "")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ratios", type=float, nargs="+", default=DEFAULT_RATIOS,
                        help="stiffness ratios (0: the homogeneous cell)")
    parser.add_argument("--no-page", action="store_true", help="print only")
    args = parser.parse_args()
    page = Page("axisymmetric", "stiff_cost.py", intro=(
        "Wall time of `elastocell compress` on its defaults, 40 load steps to delta 0.75, from a new process "
        "(interpreter start, mesh from the mesh cache, kernels from their caches: a warm-up run of one tiny step "
        "came first), one command at a time. Ratio 0 is the homogeneous cell (`--nucleus none`); the others a "
        "nucleus of size ratio 0.5. x_homogeneous is the time over the homogeneous cell's in this run; the load "
        "average (1 min) before and after each timed run says whether the machine was idle."))
    rows, base = [], None
    with tempfile.TemporaryDirectory() as directory:
        for ratio in sorted(args.ratios):  # the homogeneous cell (0) first: the others' times are over its
            work = Path(directory) / f"ratio-{ratio:g}"
            record = timed(ratio, work)
            if ratio == 0:
                base = record["seconds"]
            rows.append({"stiffness ratio": "homogeneous" if ratio == 0 else f"{ratio:g}", **mesh_of(record["metadata"]),
                         "seconds": record["seconds"], "x_homogeneous": record["seconds"] / base if base else "",
                         "exit": record["exit"], "load before": record["load_before"],
                         "load after": record["load_after"]})
            if record["exit"]:
                print(record["stderr"], file=sys.stderr)
    page.table(rows, "One curve from a new process, after a warm-up",
               formats={"delta_reached": ".3f", "seconds": ".1f", "x_homogeneous": ".2f", "load before": ".2f", "load after": ".2f"})
    if not args.no_page:
        page.write()


if __name__ == "__main__":
    main()
