"""The pipe cell's deformation against the orientation of its own mesh: one mesh, turned.

In shear flow the cell tank-treads, so every material direction of its tetrahedral mesh passes through every
direction of the flow and the mesh's own directional stiffness (an unstructured mesh of a few hundred linear
tetrahedra is not isotropic) averages out over a turn. In a pipe the stationary cell does not turn: the flow sees
one orientation of the mesh, and of its markers against the lattice, for the whole run. This script measures how
much that one orientation decides: the default mesh of the pipe (uniform, edges of 2 dx) turned by rigid rotations
(the identity and ``--orientations`` - 1 uniformly random ones, scipy's ``Rotation.random`` seeded 1, 2, ...), each
run at the pipe's defaults otherwise. The spread of D over the orientations is an error of one run that no
resolution-independent correction removes; the mean over orientations is what the model gives without it.

    nice python validation/pipe_orientation.py [--points 6:3] [--orientations 4] [--resolution 8]
                                               [--duration 16] [--workers 2] [--out results/pipe-orientation]
                                               [--cached-only]

The cell and the reading are validation/pipe_stationary.py's (a centred homogeneous cell, neo-Hookean, nu 0.48,
LE-2D-FEM-19's cylinder R_ch = 1.094 x 10 um, Q = 0.04 uL/s held, eta = 15 mPa s, the markers at R - 0.3 dx, the
interpolated wall, D and the area the means over the last unit of 1/gdot_w; D err at elastocell's area on the
isoelastic of the same shear modulus). Each run's record is appended to ``--out/runs.jsonl`` as it finishes (a
run already there is not repeated). The section goes into docs/validation/pipe_dclab.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page
from pipe_dclab import DRIFT_WINDOW, parse_points
from pipe_resolution import CHANNEL_RADIUS_UM, cases, key, read, run_case, with_table


def rotation(orientation: int) -> np.ndarray:
    """The rotation matrix of ``orientation``: the identity for 0, else scipy's uniformly random rotation seeded
    with it."""
    from scipy.spatial.transform import Rotation

    return np.eye(3) if orientation == 0 else Rotation.random(random_state=orientation).as_matrix()


def oriented_key(case: dict) -> str:
    return f"{key(case)}-o{case['orientation']}"


def run_oriented(case: dict, out: Path) -> dict:
    """``case`` run (in a worker process) on the default mesh turned by :func:`rotation`: the cell module's mesh
    builder is wrapped so the reference nodes X become Q X (the elements, the surface and the regions unchanged)."""
    import dataclasses

    import elastocell.body.cell as cell_module

    matrix = rotation(case["orientation"])
    build = cell_module.build_mesh

    def turned(*args, **kwargs):
        mesh = build(*args, **kwargs)
        return dataclasses.replace(mesh, nodes=mesh.nodes @ matrix.T)

    cell_module.build_mesh = turned
    record = run_case(case, out / f"o{case['orientation']}")
    return {**record, "key": oriented_key(case), "orientation": case["orientation"]}


def run_missing(todo: list[dict], out: Path, workers: int) -> None:
    path = out / "runs.jsonl"
    done = {r["key"] for r in read(path)}
    todo = [c for c in todo if oriented_key(c) not in done]
    if not todo:
        return
    out.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(run_oriented, c, out) for c in todo]
        for future in as_completed(futures):
            record = future.result()
            with path.open("a") as handle:
                handle.write(json.dumps(record) + "\n")
            print(f"{record['key']}: D {record['deform']:.4f} (t={record['end']:g}, {record['wall_s']:.0f} s)",
                  flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", default="6:3", help="R:E,R:E (um, kPa)")
    parser.add_argument("--orientations", type=int, default=4, help="the identity and this many - 1 random ones")
    parser.add_argument("--resolution", type=float, default=8.0, help="R/dx")
    parser.add_argument("--duration", type=float, default=16.0, help="units of 1/gdot_w")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/pipe-orientation"))
    parser.add_argument("--cached-only", action="store_true")
    args = parser.parse_args()
    todo = [{**c, "hold": True, "wall": "interpolated", "orientation": k}
            for point in parse_points(args.points)
            for c in cases(point, [args.resolution], [0.3], args.duration, meshes=False)
            for k in range(args.orientations)]
    page = Page("pipe_dclab", "pipe_orientation.py", versions=("dclab", "numba"))
    if not args.cached_only:
        run_missing(todo, args.out, args.workers)
    cached = {r["key"]: r for r in read(args.out / "runs.jsonl")}
    records = with_table([cached[oriented_key(c)] for c in todo if oriented_key(c) in cached])
    page.intro = (
        "The pipe's default mesh of the cell (uniform linear tetrahedra, edges of 2 dx) turned by rigid rotations "
        "(orientation 0: as generated; 1, 2, ...: scipy's uniformly random rotations seeded with that number), "
        "each run at the pipe's defaults otherwise (nu 0.48, LE-2D-FEM-19's cylinder R_ch = "
        f"{CHANNEL_RADIUS_UM:.2f} um, Q = 0.04 uL/s held, eta = 15 mPa s, R/dx {args.resolution:g}, markers at "
        f"R - 0.3 dx, the interpolated wall, {args.duration:g} units of 1/gdot_w; D and the area the means over "
        "the last unit, read against the table as on pipe_stationary.py's section; D drift the slope of D over "
        f"the last {DRIFT_WINDOW:g} units). The stationary cell in a pipe does not turn, so the flow sees one "
        "orientation of the mesh's directional stiffness and of its markers against the lattice for the whole "
        "run (in shear flow tank treading averages them): the spread over orientations is how much one mesh's "
        f"orientation decides. {len(records)} of {len(todo)} runs; wall_s is each run's own wall time (runs two "
        "at a time beside other work on the 2-core machine).")
    rows = [{"R [um]": r["radius_um"], "E [kPa]": r["emodulus_kpa"], "orientation": r["orientation"],
             "t [1/gdot_w]": r["end"], "reading": "outline" if r["fallback_last_unit"] == 0 else "hull",
             "deform": r["deform"], "D_t": r["D_t"], "D err %": r["D_err"], "A err %": r["A_err"],
             "D drift %/t": 100 * r["drift_deformation"], "dV/V end": r["volume_change_end"],
             "wall_s": r["wall_s"]} for r in records]
    page.table(rows, "Each orientation of the default mesh against LE-2D-FEM-19", formats={
        "deform": ".4f", "D_t": ".4f", "D err %": "+.1f", "A err %": "+.1f", "D drift %/t": "+.2f",
        "dV/V end": "+.4f", "wall_s": ".0f", "t [1/gdot_w]": "g"})
    summary = []
    for point in parse_points(args.points):
        runs = [r for r in records if (r["radius_um"], r["emodulus_kpa"]) == point]
        if len(runs) < 2:
            continue
        d = np.array([r["deform"] for r in runs])
        errors = np.array([r["D_err"] for r in runs])
        summary.append({"R [um]": point[0], "E [kPa]": point[1], "orientations": len(runs), "mean D": d.mean(),
                        "std D / mean %": 100 * d.std(ddof=1) / d.mean(),
                        "(max - min) / mean %": 100 * (d.max() - d.min()) / d.mean(),
                        "mean D err %": errors.mean(), "min D err %": errors.min(), "max D err %": errors.max()})
    page.table(summary, "The spread over orientations", formats={
        "mean D": ".4f", "std D / mean %": ".1f", "(max - min) / mean %": ".1f", "mean D err %": "+.1f",
        "min D err %": "+.1f", "max D err %": "+.1f"})
    missing = [oriented_key(c) for c in todo if oriented_key(c) not in cached]
    if missing:
        page.print("Not run (no record in the cache): " + ", ".join(missing))
    page.write()


if __name__ == "__main__":
    main()
