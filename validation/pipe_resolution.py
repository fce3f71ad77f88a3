"""The pipe cell's deformation under refinement and across meshes, against dclab's LE-2D-FEM-19: how much of the
error is a bias the resolution removes, how much the particular mesh decides, and what the hydrodynamic radius
correction does to each.

    nice python validation/pipe_resolution.py [--point 6:2] [--resolutions 6 8 10 12] [--corrections 0 0.3]
                                              [--other-points 7.66:3,7.66:4.5,6:3] [--other-resolutions 8 10 12]
                                              [--other-correction 0.3] [--duration 16] [--long-duration 40]
                                              [--workers 2]
                                              [--out results/pipe-resolution] [--cached-only]

A centred homogeneous cell (neo-Hookean, nu = 0.48, linear tetrahedra: the pipe's default element) in
LE-2D-FEM-19's own cylinder and flow (R_ch = 1.094 x 10 um, Q = 0.04 uL/s, eta = 15 mPa s; the reference and its
reading as in pipe_dclab.py: D_t is the table's deformation on the isoelastic of the same shear modulus at
elastocell's area, A_t the table's area at elastocell's deformation), one resolution per run (no
extrapolation), --duration units of 1/gdot_w with no stationarity stop; D and the area are means over the last
unit, and the drift says what the run still changed at its end. These runs hold the pressure gradient G (the pipe's
``hold_flow_rate=False``; validation/pipe_flow_rate.py compares it with the default, the flow rate held). At each
resolution the cell runs on the flow
scenarios' default mesh (uniform, edges of 2 dx) and on the other uniform meshes MESHES lists (edges of
1.8-2.25 dx: the same element and nearly the same marker spacing; what one unstructured mesh alone does to D),
each with the markers at R and at R - c dx (hydrodynamic_radius_correction c, --corrections).
The summary gives, per resolution and correction, the mean error over the meshes and their spread, and the
Richardson extrapolation (order 2) of the mean deformation from each pair of neighbouring resolutions (the means
are over the meshes each resolution has: four at R/dx 6 and 8, three at 10, two at 12). The other
points (the other pipe_dclab.py points: confinement 0.70 and a stiffer cell at 0.55) run on the default mesh with
one correction (--other-correction) at --other-resolutions. The default mesh at R/dx 8 also runs for
--long-duration with both corrections: how far the last unit of the shorter runs is from the stationary state;
its last state is also read three ways (the degree-6 fit without its guard, the nodes' hull, and the ratio of their
areas): where the fit's area leaves [1, 1.1] x the hull's (below it, or above 1.1 times it), the run's outline
switches to the hull.

Every run's record is appended to ``--out/runs.jsonl`` as it finishes (a run already there is not repeated);
``--cached-only`` writes the page from that file alone. The section goes into docs/validation/pipe_dclab.md. The runs on the page were made, with
the same run function and record format, by a driver that ran them two at a time on the 2-core machine, one
thread each (their wall times are those, not a benchmark); the cases the defaults list but the page lacks are
listed as missing ("N of M runs").
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

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
from elastocell.simulation.extrapolation import richardson

POISSON_RATIO = 0.48
CHANNEL_RADIUS_UM = SQUARE_CHANNEL_RADIUS_FACTOR * CHANNEL_WIDTH_UM / 2.0
MESHES = {6.0: [None, 0.30, 0.32, 0.345], 8.0: [None, 0.235, 0.265, 0.28], 10.0: [None, 0.185, 0.215],
          12.0: [None, 0.18]}
"""Uniform mesh sizes (units of R) per resolution R/dx; None is the default edge of 2 dx."""


def wall_capillary_number(modulus_kpa: float) -> float:
    """Ca_w = tau_w / G of a cell of Young's modulus E [kPa] (Poisson ratio POISSON_RATIO) in LE-2D-FEM-19's channel:
    equivalent radius CHANNEL_RADIUS_UM, flow rate FLOW_RATE_UL_S, Newtonian viscosity VISCOSITY_MPA_S."""
    return capillary_number_wall(FLOW_RATE_UL_S * 1e-9, CHANNEL_RADIUS_UM * 1e-6, VISCOSITY_MPA_S * 1e-3,
                                 modulus_kpa * 1e3, POISSON_RATIO)


def poisson_ratio(case: dict) -> float:
    """The cell's nu in ``case`` (:data:`POISSON_RATIO` where it says none)."""
    return float(case.get("poisson_ratio", POISSON_RATIO))


def shear_equivalent_modulus(case: dict) -> float:
    """E_t = 3 mu (kPa): the incompressible table's modulus of the same shear modulus as the case's cell."""
    return 3 * case["emodulus_kpa"] / (2 * (1 + poisson_ratio(case)))


def key(case: dict) -> str:
    """The run's name: ``-Q`` ends that of a run holding the flow rate (``hold``; this page's own runs hold G),
    ``-nu<nu>`` precedes it for a cell of another nu than :data:`POISSON_RATIO`, ``-<volumetric>`` for a cell
    whose J enters the law otherwise than at each point (``MeshParameters.volumetric``), ``-interpolated`` ends that
    of a run whose cylinder wall is interpolated (``PipeFlowParameters.channel_wall``)."""
    mesh = case["mesh_size"] or "default"
    nu = "" if poisson_ratio(case) == POISSON_RATIO else f"-nu{poisson_ratio(case):g}"
    treatment = case.get("volumetric", "standard")
    return (f"{case['radius_um']:g}um-{case['emodulus_kpa']:g}kPa-{case['element']}-{mesh}-Rdx{case['resolution']:g}"
            f"-c{case['c']:g}-t{case['duration']:g}" + nu + ("" if treatment == "standard" else f"-{treatment}")
            + ("-Q" if case.get("hold") else "") + ("-interpolated" if case.get("wall") == "interpolated" else ""))


def cases(point: tuple[float, float], resolutions: list[float], corrections: list[float],
          duration: float, meshes: bool = True) -> list[dict]:
    """The runs of ``point`` (R um, E kPa): every resolution and correction, on the meshes :data:`MESHES` lists
    (``meshes``) or on the default mesh alone."""
    return [{"radius_um": point[0], "emodulus_kpa": point[1], "element": "p1", "mesh_size": mesh,
             "resolution": float(resolution), "c": float(c), "duration": float(duration)}
            for c in corrections for resolution in resolutions
            for mesh in (MESHES.get(float(resolution), [None]) if meshes else [None])]


def mesh_options(case: dict) -> dict:
    """The cell options of ``case``'s uniform mesh (none for the flow scenarios' default)."""
    size = case["mesh_size"]
    treatment = {} if case.get("volumetric", "standard") == "standard" else {"volumetric": case["volumetric"]}
    return treatment if size is None else {"mesh_size": size, "pole_size": size, "interface_size": size, **treatment}


def run_case(case: dict, out: Path) -> dict:
    """One pipe run of ``case`` (in a worker process): the final-window means and the run's state."""
    import pandas as pd

    from elastocell.api.pipe import pipe

    ca_w = capillary_number_wall(FLOW_RATE_UL_S * 1e-9, CHANNEL_RADIUS_UM * 1e-6, VISCOSITY_MPA_S * 1e-3,
                                 case["emodulus_kpa"] * 1e3, poisson_ratio(case))
    flow = {"hold_flow_rate": bool(case.get("hold", False)), "hydrodynamic_radius_correction": float(case["c"]),
            "channel_wall": case.get("wall", "staircase")}  # said: the runs of the pages were made on the staircase
    directory = out / key(case)
    start = time.perf_counter()
    summary = pipe(directory, capillary_number_wall=ca_w, channel_radius_ratio=CHANNEL_RADIUS_UM / case["radius_um"],
                   start_offset=0.0, resolution=case["resolution"], extrapolate=False, duration=case["duration"],
                   vtk_interval=None, progress=False, nucleus="none", element=case["element"],
                   poisson_ratio=poisson_ratio(case), flow_options=flow, **mesh_options(case))
    series = pd.read_csv(directory / "timeseries.csv")
    last = series[series["time"] > series["time"].iloc[-1] - 1.0]
    return {**case, "key": key(case), "nodes": int(summary["mesh"]["n_nodes"]),
            "deform": float(last["deformation"].mean()), "area_r2": float(last["projected_area"].mean()),
            "fallback_last_unit": int((last["outline_fallback"] > 0).sum()),
            "end": float(series["time"].iloc[-1]), **drifts(directory / "timeseries.csv"),
            "capillary_number_wall": ca_w, "pressure_gradient_ratio": summary.get("pressure_gradient_ratio", 1.0),
            "flow_rate_ratio": summary.get("flow_rate_ratio"), "wall_s": time.perf_counter() - start}


def read(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def run_missing(todo: list[dict], out: Path, workers: int, key_of=key, run=run_case) -> None:
    """Run the cases of ``todo`` whose ``key_of`` is not yet in ``out/runs.jsonl`` with ``run(case, out)`` (in
    worker processes; the finest first), appending each record as it finishes."""
    path = out / "runs.jsonl"
    done = {r["key"] for r in read(path)}
    todo = [c for c in todo if key_of(c) not in done]
    if not todo:
        return
    out.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(max_workers=workers) as pool:  # the finest first: the longest runs start early
        futures = [pool.submit(run, c, out) for c in sorted(todo, key=lambda c: -c["resolution"])]
        for future in as_completed(futures):
            record = future.result()
            with path.open("a") as handle:
                handle.write(json.dumps(record) + "\n")
            print(f"{record['key']}: D {record['deform']:.4f} (t={record['end']:g}, {record['wall_s']:.0f} s)",
                  flush=True)


def with_table(records: list[dict]) -> list[dict]:
    """Each record with D_t, A_t and the errors against LE-2D-FEM-19."""
    if not records:
        return []
    readings = table_readings([(r["area_r2"] * r["radius_um"] ** 2, r["deform"], shear_equivalent_modulus(r))
                               for r in records])
    return [{**r, "D_t": d_t, "A_t": a_t, "D_err": percent(r["deform"], d_t),
             "A_err": percent(r["area_r2"] * r["radius_um"] ** 2, a_t)}
            for r, (d_t, a_t, _) in zip(records, readings, strict=True)]


FORMATS = {"deform": ".4f", "D_t": ".4f", "D err %": "+.1f", "A err %": "+.1f", "D drift %/t": "+.2f",
           "dV/V end": "+.4f", "wall_s": ".0f", "edge [dx]": ".2f", "mean D err %": "+.1f",
           "min D err %": "+.1f", "max D err %": "+.1f", "mean A err %": "+.1f", "mean wall_s": ".0f",
           "D": ".4f", "D err % (vs D_t of the finer)": "+.1f"}


def last_state_outlines(record: dict, out: Path) -> dict:
    """The run's last state (its checkpoint) read through the degree-6 fit without the guard and through the
    nodes' hull: D of each and the ratio of their areas."""
    from scipy.spatial import ConvexHull

    from elastocell.body.cell import Cell
    from elastocell.body.observables import fitted_outline_hull, moments
    from elastocell.parameters.flow import flow_cell

    cell = Cell.from_parameters(flow_cell(None, {"nucleus": "none", "element": record["element"],
                                                 "poisson_ratio": POISSON_RATIO, **mesh_options(record)},
                                                record["resolution"]))
    with np.load(out / record["key"] / "checkpoint.npz") as data:
        x = data["positions"] / record["resolution"]
    surface = x[cell.mesh.surface_nodes]
    fit = fitted_outline_hull(surface, moments(x, cell.mesh.elements).centre)
    hull = ConvexHull(surface[:, :2])

    def deformation(h):
        return 1.0 - 2.0 * np.sqrt(np.pi * h.volume) / h.area

    return {"D fit (last state)": deformation(fit), "D nodes' hull (last state)": deformation(hull),
            "fit/hull area": fit.volume / hull.volume}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--point", default="6:2", help="R:E (um, kPa)")
    parser.add_argument("--resolutions", type=float, nargs="+", default=[6, 8, 10, 12])
    parser.add_argument("--corrections", type=float, nargs="+", default=[0.0, 0.3])
    parser.add_argument("--other-points", default="7.66:3,7.66:4.5,6:3", help="R:E,R:E (um, kPa); '' for none")
    parser.add_argument("--other-resolutions", type=float, nargs="+", default=[8, 10, 12])
    parser.add_argument("--other-correction", type=float, default=0.3)
    parser.add_argument("--duration", type=float, default=16.0)
    parser.add_argument("--long-duration", type=float, default=40.0, help="0: no long runs")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/pipe-resolution"))
    parser.add_argument("--cached-only", action="store_true")
    args = parser.parse_args()
    point = parse_points(args.point)[0]
    todo = cases(point, args.resolutions, args.corrections, args.duration)
    others = [c for p in (parse_points(args.other_points) if args.other_points else [])
              for c in cases(p, args.other_resolutions, [args.other_correction], args.duration, meshes=False)]
    long = [{**c, "duration": args.long_duration} for c in todo
            if c["resolution"] == 8.0 and c["mesh_size"] is None] if args.long_duration else []
    if not args.cached_only:
        run_missing(todo + others + long, args.out, args.workers)
    cached = {r["key"]: r for r in read(args.out / "runs.jsonl")}
    records = [cached[key(c)] for c in todo if key(c) in cached]
    records = with_table(sorted(records, key=lambda r: (r["c"], r["resolution"], r["mesh_size"] or 0.0)))
    other_records = with_table([cached[key(c)] for c in others if key(c) in cached])
    long_records = with_table([cached[key(c)] for c in long if key(c) in cached])

    page = Page(intro=__doc__.split("\n\n", 2)[2].split("\n\nEvery run's")[0])
    page.print(f"R = {point[0]:g} um, E = {point[1]:g} kPa, R/R_ch = {point[0] / CHANNEL_RADIUS_UM:.3f}, "
               f"Ca_w = {records[0]['capillary_number_wall']:.3f}; {len(records)} of {len(todo)} runs in "
               f"{args.out}" if records else "no runs")
    page.table([{"c [dx]": r["c"], "R/dx": r["resolution"],
                 "edge [dx]": (r["mesh_size"] or 2.0 / r["resolution"]) * r["resolution"], "nodes": r["nodes"],
                 "deform": r["deform"], "D_t": r["D_t"], "D err %": r["D_err"], "A err %": r["A_err"],
                 "D drift %/t": 100 * r["drift_deformation"], "dV/V end": r["volume_change_end"],
                 "wall_s": r["wall_s"]} for r in records],
               "Every run: the last unit's means against LE-2D-FEM-19", formats=FORMATS)

    groups: dict[tuple[float, float], list[dict]] = {}
    for r in records:
        groups.setdefault((r["c"], r["resolution"]), []).append(r)
    summary = []
    for (c, resolution), runs in sorted(groups.items()):
        errors = np.array([r["D_err"] for r in runs])
        summary.append({"c [dx]": c, "R/dx": resolution, "meshes": len(runs), "mean D err %": errors.mean(),
                        "min D err %": errors.min(), "max D err %": errors.max(),
                        "mean A err %": float(np.mean([r["A_err"] for r in runs])),
                        "mean wall_s": float(np.mean([r["wall_s"] for r in runs]))})
    page.table(summary, "Per resolution: the meshes' mean error and its range", formats=FORMATS)

    extrapolated = []
    for c in sorted({c for c, _ in groups}):
        levels = sorted(resolution for cc, resolution in groups if cc == c)
        for coarse, fine in zip(levels[:-1], levels[1:], strict=True):
            d_coarse = np.mean([r["deform"] for r in groups[(c, coarse)]])
            d_fine = np.mean([r["deform"] for r in groups[(c, fine)]])
            d_t = np.mean([r["D_t"] for r in groups[(c, fine)]])
            extrapolated.append({"c [dx]": c, "resolutions": f"{fine:g}/{coarse:g}",
                                 "D": richardson(d_fine, d_coarse, fine / coarse, 2.0),
                                 "D err % (vs D_t of the finer)": percent(
                                     richardson(d_fine, d_coarse, fine / coarse, 2.0), d_t)})
    page.table(extrapolated, "Richardson (order 2) from the meshes' mean deformation at neighbouring resolutions",
               formats=FORMATS)
    if other_records:
        page.print(f"{len(other_records)} of {len(others)} runs of the other points in {args.out}")
        page.table([{"R [um]": r["radius_um"], "E [kPa]": r["emodulus_kpa"],
                     "R/R_ch": r["radius_um"] / CHANNEL_RADIUS_UM, "Ca_w": r["capillary_number_wall"],
                     "c [dx]": r["c"], "R/dx": r["resolution"], "deform": r["deform"], "D_t": r["D_t"],
                     "D err %": r["D_err"], "A err %": r["A_err"], "D drift %/t": 100 * r["drift_deformation"],
                     "dV/V end": r["volume_change_end"], "wall_s": r["wall_s"]}
                    for r in sorted(other_records, key=lambda r: (r["radius_um"], r["emodulus_kpa"], r["resolution"]))],
                   "The other points on the default mesh", formats={**FORMATS, "R/R_ch": ".3f", "Ca_w": ".3f"})
    if long_records:
        short = {(r["c"], r["resolution"]): r for r in records if r["mesh_size"] is None}
        page.table([{"c [dx]": r["c"], "R/dx": r["resolution"], "duration": r["duration"], "deform": r["deform"],
                     "D_t": r["D_t"], "D err %": r["D_err"], "A err %": r["A_err"],
                     "D drift %/t": 100 * r["drift_deformation"], "dV/V end": r["volume_change_end"],
                     f"D err % at t = {args.duration:g}": short[(r["c"], r["resolution"])]["D_err"]
                     if (r["c"], r["resolution"]) in short else float("nan"),
                     **last_state_outlines(r, args.out), "wall_s": r["wall_s"]}
                    for r in long_records],
                   f"The default mesh run for {args.long_duration:g} units: the last unit against LE-2D-FEM-19",
                   formats={**FORMATS, f"D err % at t = {args.duration:g}": "+.1f", "duration": "g",
                            "D fit (last state)": ".4f", "D nodes' hull (last state)": ".4f", "fit/hull area": ".4f"})
    page.write()


if __name__ == "__main__":
    main()
