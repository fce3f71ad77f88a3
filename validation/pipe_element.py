"""The cell's elements in the pipe: linear against quadratic tetrahedra, against dclab's LE-2D-FEM-19.

    nice python validation/pipe_element.py [--points 6:2,6:3,7.66:3,7.66:4.5] [--workers 2]
                                           [--out results/pipe-element] [--cached-only]

A centred homogeneous cell (neo-Hookean, nu = 0.48) in LE-2D-FEM-19's own cylinder and flow (R_ch = 1.094 x 10 um,
Q = 0.04 uL/s, eta = 15 mPa s; the reference and its reading as in pipe_dclab.py: D_t is the table's deformation on
the isoelastic of the same shear modulus at elastocell's area, A_t its area at elastocell's deformation), one
resolution per run (no extrapolation), each run for 20 units of 1/gdot_w with no stop on stationarity (the
stationarity stop fires on a turning point of the transient: the quadratic cell of R = 6 um, E = 2 kPa at R/dx 6
reaches D 0.0486 at t = 9, where a stop at 1e-3 ends it, and falls to 0.0387 by t = 20); D and the area are means
over the last unit, and the drifts say what the run still changed at its end. The cell's mesh is the flow
scenarios' uniform one with edges of 2 dx, or of the sizes :data:`MESHES` lists (the same element on several
unstructured meshes: what one mesh alone does to D), of linear (p1, the pipe's default: the markers are the
vertices, 2 dx apart) or quadratic tetrahedra (p2: vertices and mid-edge nodes, 1 dx apart). Linear elements with
edges of 1 dx separate the marker spacing from the element order.

1. **Four meshes of each element at the point R = 6 um, E = 2 kPa** (the rtdc-nucleus study's cell), R/dx 6,
   and each element at R/dx 8.
2. **The four points of pipe_dclab.py** with quadratic elements at R/dx 6 and 8.

Every run's record is appended to ``--out/runs.jsonl`` as it finishes; ``--cached-only`` writes the page from
that file alone. The section goes into docs/validation/pipe_dclab.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page
from pipe_dclab import (
    CHANNEL_WIDTH_UM,
    FLOW_RATE_UL_S,
    VISCOSITY_MPA_S,
    drifts,
    parse_points,
    percent,
    table_readings,
)

from elastocell.inverse.lut import SQUARE_CHANNEL_RADIUS_FACTOR, capillary_number_wall

POISSON_RATIO = 0.48
DURATION = 20.0
STUDY_POINT = (6.0, 2.0)
MESHES = {"p1": [None, 0.30, 0.32, 0.345], "p2": [None, 0.30, 0.32, 0.345]}
"""Mesh sizes (units of R) at R/dx 6 for the meshes of each element at the study's point: None is the default
edge of 2 dx (1/3 at R/dx 6)."""
CHANNEL_RADIUS_UM = SQUARE_CHANNEL_RADIUS_FACTOR * CHANNEL_WIDTH_UM / 2.0


def cases(points: list[tuple[float, float]]) -> list[dict]:
    out = [{"radius_um": STUDY_POINT[0], "emodulus_kpa": STUDY_POINT[1], "element": element, "mesh_size": size,
            "resolution": 6.0} for element, sizes in MESHES.items() for size in sizes]
    out += [{"radius_um": STUDY_POINT[0], "emodulus_kpa": STUDY_POINT[1], "element": "p1", "mesh_size": 1 / 6,
             "resolution": 6.0}]
    out += [{"radius_um": STUDY_POINT[0], "emodulus_kpa": STUDY_POINT[1], "element": "p1", "mesh_size": None,
             "resolution": 8.0}]
    out += [{"radius_um": r, "emodulus_kpa": e, "element": "p2", "mesh_size": None, "resolution": res}
            for r, e in points for res in (6.0, 8.0)]
    unique = {key(c): c for c in out}
    return list(unique.values())


def key(case: dict) -> str:
    size = "default" if case["mesh_size"] is None else f"{case['mesh_size']:.4f}"
    return f"{case['radius_um']:g}um-{case['emodulus_kpa']:g}kPa-{case['element']}-{size}-Rdx{case['resolution']:g}"


def run_case(case: dict, out: Path) -> dict:
    """One pipe run of ``case`` (in a worker process): the final-window means and the run's state."""
    import pandas as pd

    from elastocell.api.pipe import pipe

    radius, modulus = case["radius_um"], case["emodulus_kpa"]
    ca_w = capillary_number_wall(FLOW_RATE_UL_S * 1e-9, CHANNEL_RADIUS_UM * 1e-6, VISCOSITY_MPA_S * 1e-3,
                                 modulus * 1e3, POISSON_RATIO)
    mesh = {} if case["mesh_size"] is None else {"mesh_size": case["mesh_size"], "pole_size": case["mesh_size"],
                                                 "interface_size": case["mesh_size"]}
    directory = out / key(case)
    start = time.perf_counter()
    summary = pipe(directory, capillary_number_wall=ca_w, channel_radius_ratio=CHANNEL_RADIUS_UM / radius,
                   start_offset=0.0, resolution=case["resolution"], extrapolate=False, duration=DURATION,
                   vtk_interval=None, progress=False, nucleus="none", element=case["element"],
                   poisson_ratio=POISSON_RATIO, **mesh)
    series = pd.read_csv(directory / "timeseries.csv")
    last = series[series["time"] > series["time"].iloc[-1] - 1.0]
    return {**case, "key": key(case), "nodes": int(summary["mesh"]["n_nodes"]),
            "mesh_edge_dx": float(summary["cell"]["mesh"]["mesh_size"]) * case["resolution"],
            "deform": float(last["deformation"].mean()), "area_r2": float(last["projected_area"].mean()),
            "end": float(series["time"].iloc[-1]), **drifts(directory / "timeseries.csv"),
            "max_volume_change": float(series["volume_change"].abs().max()),
            "capillary_number_wall": ca_w, "wall_s": time.perf_counter() - start}


def run_missing(todo: list[dict], out: Path, workers: int) -> None:
    path = out / "runs.jsonl"
    done = {r["key"] for r in read(path)}
    todo = [c for c in todo if key(c) not in done]
    if not todo:
        return
    out.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(run_case, c, out): c for c in sorted(todo, key=lambda c: c["resolution"])}
        for future in as_completed(futures):
            record = future.result()
            with path.open("a") as handle:
                handle.write(json.dumps(record) + "\n")
            print(f"{record['key']}: D {record['deform']:.4f} (t={record['end']:g}, {record['wall_s']:.0f} s)",
                  flush=True)


def read(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def rows(records: list[dict]) -> list[dict]:
    readings = table_readings([(r["area_r2"] * r["radius_um"] ** 2, r["deform"],
                                3 * r["emodulus_kpa"] / (2 * (1 + POISSON_RATIO))) for r in records])
    out = []
    for r, (d_t, a_t, e_dclab) in zip(records, readings, strict=True):
        e_t = 3 * r["emodulus_kpa"] / (2 * (1 + POISSON_RATIO))
        out.append({"R [um]": r["radius_um"], "E [kPa]": r["emodulus_kpa"], "element": r["element"],
                    "R/dx": r["resolution"], "edge [dx]": r["mesh_edge_dx"], "nodes": r["nodes"],
                    "deform": r["deform"], "D_t": d_t,
                    "D err %": percent(r["deform"], d_t), "A/(pi R^2)": r["area_r2"] / 3.141592653589793,
                    "A err %": percent(r["area_r2"] * r["radius_um"] ** 2, a_t),
                    "E_dclab/E_t": e_dclab / e_t, "D drift %/t": 100 * r["drift_deformation"],
                    "A drift %/t": 100 * r["drift_projected_area"], "dV/V end": r["volume_change_end"],
                    "max |dV/V|": r["max_volume_change"], "wall_s": r["wall_s"]})
    return out


FORMATS = {"deform": ".4f", "D_t": ".4f", "D err %": "+.1f", "A err %": "+.1f",
           "A/(pi R^2)": ".4f", "E_dclab/E_t": ".3f", "D drift %/t": "+.2f", "A drift %/t": "+.2f",
           "dV/V end": "+.4f", "max |dV/V|": ".4f", "wall_s": ".0f", "edge [dx]": ".2f"}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", default="6:2,6:3,7.66:3,7.66:4.5", help="R:E (um:kPa) of the second table")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/pipe-element"))
    parser.add_argument("--cached-only", action="store_true", help="write the page from --out/runs.jsonl alone")
    args = parser.parse_args(argv)
    todo = cases(parse_points(args.points))
    if not args.cached_only:
        run_missing(todo, args.out, args.workers)
    records = {r["key"]: r for r in read(args.out / "runs.jsonl")}
    have = [records[key(c)] for c in todo if key(c) in records]
    missing = [key(c) for c in todo if key(c) not in records]
    page = Page("pipe_dclab", "pipe_element.py", intro=__doc__.split("\n\n", 2)[2].strip())
    study = [r for r in have if (r["radius_um"], r["emodulus_kpa"]) == STUDY_POINT
             and not (r["element"] == "p2" and r["mesh_size"] is None and r["resolution"] > 6.0)]
    page.table(rows(study), f"The cell of R = {STUDY_POINT[0]:g} um, E = {STUDY_POINT[1]:g} kPa on several meshes "
               "of each element", formats=FORMATS)
    points = [r for r in have if r["element"] == "p2" and r["mesh_size"] is None]
    page.table(rows(sorted(points, key=lambda r: (r["radius_um"], r["emodulus_kpa"], r["resolution"]))),
               "Quadratic elements at the four points of pipe_dclab.py", formats=FORMATS)
    if missing:
        page.print("Not run (not in the cache): " + ", ".join(missing))
    page.write()


if __name__ == "__main__":
    main()
