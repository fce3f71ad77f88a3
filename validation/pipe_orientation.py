"""The pipe cell's deformation against the orientation of its own mesh: one mesh, turned.

In shear flow the cell tank-treads, so every material direction of its tetrahedral mesh passes through every
direction of the flow and the mesh's own directional stiffness (an unstructured mesh of a few hundred linear
tetrahedra is not isotropic) averages out over a turn. In a pipe the stationary cell does not turn: the flow sees
one orientation of the mesh, and of its markers against the lattice, for the whole run. This script measures how
much that one orientation decides: the default mesh of the pipe (uniform, edges of 2 dx) turned by rigid rotations
(the identity and ``--orientations`` - 1 uniformly random ones, scipy's ``Rotation.random`` seeded 1, 2, ...), each
run at the pipe's defaults otherwise. The spread of D over the orientations is an error of one run that no
resolution-independent correction removes; the mean over orientations is what the model gives without it.

The side view the pipe reads (along z) sees one azimuth of a shape the mesh makes slightly non-axisymmetric, so each
run's last state is also read from VIEWS side views about the channel axis and averaged (the continuum shape of a
centred cell is axisymmetric: every view reads the same D). Each reading at R/dx 6 and 8 is combined by Richardson
extrapolation (order 2), the remedy the shear flow uses, per orientation and of the orientations' means.

    nice python validation/pipe_orientation.py [--set 6:3/4/16 --set 7.66:3,6:3/1/40 ...] [--resolutions 6 8]
                                               [--workers 2] [--out results/pipe-orientation] [--cached-only]

The cell and the reading are validation/pipe_stationary.py's (a centred homogeneous cell, neo-Hookean, nu 0.48,
LE-2D-FEM-19's cylinder R_ch = 1.094 x 10 um, Q = 0.04 uL/s held, eta = 15 mPa s, the markers at R - 0.3 dx, the
interpolated wall, D and the area the means over the last unit of 1/gdot_w; D err at elastocell's area on the
isoelastic of the same shear modulus). Each run's record is appended to ``--out/runs.jsonl`` as it finishes (a
run already there is not repeated). The section goes into docs/validation/pipe_dclab.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page
from pipe_dclab import DRIFT_WINDOW, parse_points
from pipe_resolution import CHANNEL_RADIUS_UM, cases, key, read, run_case, run_missing, with_table

DEFAULT_SETS = ("6:3/4/16", "7.66:3,7.66:4.5,6:2,6:3,5:1.5,6.5:2.5/1/40", "6:3,7.66:4.5/1/40/10")
"""The runs on the page: POINTS/ORIENTATIONS/DURATION[/RESOLUTIONS] (see --set)."""


def parse_set(text: str, resolutions: list[float]) -> tuple[list[tuple[float, float]], int, float, list[float]]:
    """"R:E,R:E/ORIENTATIONS/DURATION[/R1+R2...]" -> (points, orientations, duration, resolutions R/dx; default
    ``resolutions``)."""
    points, orientations, duration, *own = text.split("/")
    own_resolutions = [float(r) for r in own[0].split("+")] if own else list(resolutions)
    return parse_points(points), int(orientations), float(duration), own_resolutions


def three_resolution_line(label: str, deformations: dict[float, float], reference: float) -> str:
    """D at R/dx 6, 8 and 10 of one cell: the observed order p of D(h) = D* + C h^p (h = 1/(R/dx)), what order 2
    through 6 and 8 predicts at 10, and the Richardson limits from 8 and 10 at orders 2 and p, each against
    ``reference`` (the table's D)."""
    import scipy.optimize

    from elastocell.simulation.extrapolation import richardson

    d6, d8, d10 = (deformations[r] for r in (6.0, 8.0, 10.0))
    ratio = (d6 - d8) / (d8 - d10) if d8 != d10 else float("nan")

    def gap(p: float) -> float:
        return (6.0**-p - 8.0**-p) / (8.0**-p - 10.0**-p) - ratio

    order = (float(scipy.optimize.brentq(gap, 0.05, 12.0)) if np.isfinite(ratio) and gap(0.05) * gap(12.0) < 0
             else float("nan"))
    limit_68 = float(richardson(d8, d6, 8.0 / 6.0))
    parts = [f"{label}: D {d6:.5f}, {d8:.5f}, {d10:.5f} at R/dx 6, 8, 10 (reference {reference:.5f}); observed "
             f"order {order:.2f}; order 2 through 6 and 8 predicts {limit_68 + (d8 - limit_68) * 0.64:.5f} at 10 "
             f"and the limit {limit_68:.5f} ({100 * (limit_68 / reference - 1):+.1f} %)"]
    for p in (2.0, order):
        if np.isfinite(p):
            value = float(richardson(d10, d8, 10.0 / 8.0, p))
            parts.append(f"order {p:.2f} from 8 and 10: {value:.5f} ({100 * (value / reference - 1):+.1f} %)")
    return "; ".join(parts)


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


def extrapolated_rows(records: list[dict], resolutions: list[float]) -> list[dict]:
    """Richardson (order 2) of D and the area from the runs at ``resolutions`` (coarse, fine) of each point and
    orientation, and of the orientations' means, each read against the table at its extrapolated area."""
    from elastocell.simulation.extrapolation import richardson

    coarse_resolution, fine_resolution = resolutions
    pairs = {}
    for r in records:
        pairs.setdefault((r["radius_um"], r["emodulus_kpa"], r["duration"], r["orientation"]), {})[r["resolution"]] = r
    rows, pseudo = [], []
    complete = {k: v for k, v in pairs.items() if coarse_resolution in v and fine_resolution in v}
    groups = [(k, [v]) for k, v in sorted(complete.items())]
    for point in sorted({k[:3] for k in complete}):
        members = [v for k, v in complete.items() if k[:3] == point]
        if len(members) > 1:
            groups.append(((*point, "mean"), members))
    for (radius, modulus, duration, orientation), members in groups:
        mean = {name: {res: float(np.mean([m[res][name] for m in members])) for res in resolutions}
                for name in ("deform", "area_r2")}
        value = {name: float(richardson(mean[name][fine_resolution], mean[name][coarse_resolution],
                                        fine_resolution / coarse_resolution)) for name in mean}
        fine = members[0][fine_resolution]
        pseudo.append({**fine, "deform": value["deform"], "area_r2": value["area_r2"]})
        rows.append({"R [um]": radius, "E [kPa]": modulus, "t": duration, "orientation": orientation,
                     "runs": 2 * len(members),
                     "D coarse": mean["deform"][coarse_resolution], "D fine": mean["deform"][fine_resolution],
                     "D extrapolated": value["deform"],
                     "D err % fine": float(np.mean([m[fine_resolution]["D_err"] for m in members]))})
    for row, reading in zip(rows, with_table(pseudo), strict=True):
        row.update({"D_t": reading["D_t"], "D err % extrapolated": reading["D_err"],
                    "A err % extrapolated": reading["A_err"]})
    return rows


VIEWS = 6
"""Side views averaged about the channel axis: angles k pi/VIEWS, k = 0 .. VIEWS - 1 (view 0: the pipe's own, along
z)."""


def view_readings(record: dict, out: Path, views: int = VIEWS) -> dict:
    """The run's last state (its checkpoint) read from ``views`` side views about the channel axis through the
    cell's centroid as the pipe reads them (elastocell.body.observables.side_view_readings, lengths in the markers'
    radius): view 0's D and area, their means over the views read on the smooth outline (mean_side_view), the
    range of D over those views and how many views fell back to the nodes' hull."""
    from elastocell.body.cell import Cell
    from elastocell.body.observables import (
        circularity_deformation,
        mean_side_view,
        moments,
        side_view_readings,
    )
    from elastocell.parameters.flow import flow_cell

    cell = Cell.from_parameters(flow_cell(None, {"nucleus": "none", "element": record["element"],
                                                 "poisson_ratio": 0.48}, record["resolution"]))
    directory = out / f"o{record['orientation']}" / record["key"].rsplit("-o", 1)[0]
    with np.load(directory / "checkpoint.npz") as data:
        x = data["positions"] / (record["resolution"] - record["c"])  # the markers' radius, as the pipe reads
    readings = side_view_readings(x[cell.mesh.surface_nodes], moments(x, cell.mesh.elements).centre, views)
    area, deformation, hull_views = mean_side_view(readings)
    fitted = [circularity_deformation(a, p) for a, p, ok in readings if ok] or [deformation]
    return {"D view 0": circularity_deformation(*readings[0][:2]), "area view 0": readings[0][0],
            "D views": deformation, "area views": area, "D views min": min(fitted), "D views max": max(fitted),
            "hull views": hull_views}


def views_cost(record: dict, out: Path, repeats: int = 20) -> str:
    """The side views' cost per record in the pipe: :func:`side_views_outline` against the one view of
    :func:`smooth_outline_checked` on ``record``'s last state (best of ``repeats``), and the run's wall time per
    record."""
    import time

    from elastocell.body.cell import Cell
    from elastocell.body.observables import moments, side_views_outline, smooth_outline_checked
    from elastocell.parameters.flow import flow_cell

    cell = Cell.from_parameters(flow_cell(None, {"nucleus": "none", "element": record["element"],
                                                 "poisson_ratio": 0.48}, record["resolution"]))
    directory = out / f"o{record['orientation']}" / record["key"].rsplit("-o", 1)[0]
    with np.load(directory / "checkpoint.npz") as data:
        x = data["positions"] / (record["resolution"] - record["c"])
    centre, surface = moments(x, cell.mesh.elements).centre, x[cell.mesh.surface_nodes]

    def best(function) -> float:
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            function(surface, centre)
            times.append(time.perf_counter() - start)
        return min(times)

    one, views = best(smooth_outline_checked), best(side_views_outline)
    records = round(record["end"] / 0.1) + 1
    per_record = record["wall_s"] / records
    return (f"cost per record, R {record['radius_um']:g} um, R/dx {record['resolution']:g}: one view {1e3 * one:.1f} "
            f"ms, {VIEWS} views {1e3 * views:.1f} ms (the pipe measures the views, view 0 among them: "
            f"{1e3 * (views - one):.1f} ms added); the run's "
            f"wall time per record {1e3 * per_record:.0f} ms ({records} records), so the views add "
            f"{100 * (views - one) / per_record:.1f} % to it")


def views_rows(records: list[dict], out: Path, pair: list[float]) -> list[dict]:
    """Per point and orientation: the last state's view 0 and view mean at each resolution, and the Richardson
    (order 2) of the view means of the two finest, each against LE-2D-FEM-19 at its own area."""
    from elastocell.simulation.extrapolation import richardson

    readings = {r["key"]: {**r, **view_readings(r, out)} for r in records}
    coarse_resolution, fine_resolution = pair
    groups: dict = {}
    for r in readings.values():
        groups.setdefault((r["radius_um"], r["emodulus_kpa"], r["duration"], r["orientation"]), {})[r["resolution"]] = r
    rows, pseudo = [], []
    for (radius, modulus, duration, orientation), runs in sorted(groups.items()):
        for resolution, r in sorted(runs.items()):
            for reading in ("view 0", "views"):
                pseudo.append({**r, "deform": r[f"D {reading}"], "area_r2": r[f"area {reading}"]})
                rows.append({"R [um]": radius, "E [kPa]": modulus, "t": duration,
                             "orientation": orientation, "R/dx": f"{resolution:g}", "reading": reading,
                             "deform": r[f"D {reading}"],
                             "views' D range %": 100 * (r["D views max"] - r["D views min"]) / r["D views"],
                             "hull views": r["hull views"]})
        if coarse_resolution in runs and fine_resolution in runs:
            for reading in ("view 0", "views"):
                value = {name: float(richardson(runs[fine_resolution][f"{name} {reading}"],
                                                runs[coarse_resolution][f"{name} {reading}"],
                                                fine_resolution / coarse_resolution)) for name in ("D", "area")}
                pseudo.append({**runs[fine_resolution], "deform": value["D"], "area_r2": value["area"]})
                rows.append({"R [um]": radius, "E [kPa]": modulus, "t": duration,
                             "orientation": orientation,
                             "R/dx": f"{fine_resolution:g}/{coarse_resolution:g} extrapolated", "reading": reading,
                             "deform": value["D"], "views' D range %": float("nan"),
                             "hull views": max(runs[fine_resolution]["hull views"],
                                               runs[coarse_resolution]["hull views"])})
    for row, reading in zip(rows, with_table(pseudo), strict=True):
        row.update({"D_t": reading["D_t"], "D err %": reading["D_err"], "A err %": reading["A_err"],
                    "target met": "yes" if max(abs(reading["D_err"]), abs(reading["A_err"])) <= 10 else "no"})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--set", dest="sets", action="append", default=None,
                        help="POINTS/ORIENTATIONS/DURATION, repeatable: the points R:E,R:E (um, kPa), each run on "
                             "the identity and ORIENTATIONS - 1 random orientations for DURATION units of 1/gdot_w "
                             f"(default {' '.join(DEFAULT_SETS)})")
    parser.add_argument("--resolutions", type=float, nargs="+", default=[6.0, 8.0],
                        help="R/dx, each run of a set that names none")
    parser.add_argument("--pair", type=float, nargs=2, default=[6.0, 8.0],
                        help="the coarse and fine R/dx combined by Richardson extrapolation")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/pipe-orientation"))
    parser.add_argument("--cached-only", action="store_true")
    args = parser.parse_args()
    sets = [parse_set(text, args.resolutions) for text in (args.sets or DEFAULT_SETS)]
    todo = [{**c, "hold": True, "wall": "interpolated", "orientation": k}
            for points, orientations, duration, resolutions in sets for point in points
            for c in cases(point, resolutions, [0.3], duration, meshes=False)
            for k in range(orientations)]
    page = Page("pipe_dclab", "pipe_orientation.py", versions=("dclab", "numba"))
    if not args.cached_only:
        run_missing(todo, args.out, args.workers, key_of=oriented_key, run=run_oriented)
    cached = {r["key"]: r for r in read(args.out / "runs.jsonl")}
    records = with_table([cached[oriented_key(c)] for c in todo if oriented_key(c) in cached])
    page.intro = (
        "The pipe's default mesh of the cell (uniform linear tetrahedra, edges of 2 dx) turned by rigid rotations "
        "(orientation 0: as generated; 1, 2, ...: scipy's uniformly random rotations seeded with that number), "
        "each run at the pipe's defaults otherwise (nu 0.48, LE-2D-FEM-19's cylinder R_ch = "
        f"{CHANNEL_RADIUS_UM:.2f} um, Q = 0.04 uL/s held, eta = 15 mPa s, R/dx "
        f"{' and '.join(f'{r:g}' for r in sorted({r for *_, rs in sets for r in rs}))} as each set of runs "
        "says, markers at "
        "R - 0.3 dx, the interpolated wall, t units of 1/gdot_w; D and the area the means over "
        "the last unit, read against the table as on pipe_stationary.py's section; D drift the slope of D over "
        f"the last {DRIFT_WINDOW:g} units). The stationary cell in a pipe does not turn, so the flow sees one "
        "orientation of the mesh's directional stiffness and of its markers against the lattice for the whole "
        "run (in shear flow tank treading averages them): the spread over orientations is how much one mesh's "
        "orientation decides. The last table reads each run's last state from its own side view (view 0, along z, "
        f"what the time series holds) and as the mean over {VIEWS} side views about the channel axis (the "
        "continuum shape of a centred cell is axisymmetric), and combines R/dx 6 and 8 by Richardson "
        "extrapolation of order 2 (the shear flow's remedy); a run with views read on the nodes' hull (`hull "
        "views`, the fallback where the smooth fit is not trusted: the coarse runs of the larger deformations) "
        "cannot be extrapolated. "
        "The R/dx 8 runs of 40 units are pipe_wall.py's interpolated runs (the same run function and case), "
        "their records and directories taken over as orientation 0. "
        f"{len(records)} of {len(todo)} runs; wall_s is each run's own wall time (runs two "
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
    for points, _, duration, resolutions in sets:
        for point, resolution in ((p, r) for p in points for r in resolutions):
            runs = [r for r in records if (r["radius_um"], r["emodulus_kpa"], r["duration"]) == (*point, duration)
                    and r["resolution"] == resolution]
            if len(runs) < 2:
                continue
            d = np.array([r["deform"] for r in runs])
            errors = np.array([r["D_err"] for r in runs])
            summary.append({"R [um]": point[0], "E [kPa]": point[1], "t": duration, "R/dx": resolution,
                            "orientations": len(runs),
                            "mean D": d.mean(), "std D / mean %": 100 * d.std(ddof=1) / d.mean(),
                            "(max - min) / mean %": 100 * (d.max() - d.min()) / d.mean(),
                            "mean D err %": errors.mean(), "min D err %": errors.min(),
                            "max D err %": errors.max()})
    page.table(summary, "The spread over orientations", formats={
        "mean D": ".4f", "std D / mean %": ".1f", "(max - min) / mean %": ".1f", "mean D err %": "+.1f",
        "min D err %": "+.1f", "max D err %": "+.1f", "R/dx": "g"})
    page.table(extrapolated_rows(records, list(args.pair)),
               f"Richardson (order 2) from R/dx {args.pair[0]:g} and {args.pair[1]:g}, per orientation and of the "
               "orientations' mean D and area, against LE-2D-FEM-19 at the extrapolated area", formats={
                   "D coarse": ".4f", "D fine": ".4f", "D extrapolated": ".4f", "D_t": ".4f",
                   "D err % fine": "+.1f", "D err % extrapolated": "+.1f", "A err % extrapolated": "+.1f"})
    views = views_rows(records, args.out, list(args.pair))
    page.table(views,
               f"The last state read from one side view (view 0, the pipe's) and averaged over {VIEWS} side views "
               "about the channel axis, each resolution and extrapolated, against LE-2D-FEM-19 at its own area",
               formats={"deform": ".4f", "D_t": ".4f", "D err %": "+.1f", "A err %": "+.1f",
                        "views' D range %": ".1f"})
    fine = [r for r in records if r["resolution"] == max(args.resolutions) and r["orientation"] == 0
            and (r["radius_um"], r["emodulus_kpa"]) == (6.0, 3.0)]
    if fine:
        page.print(views_cost(max(fine, key=lambda r: r["end"]), args.out))
    for (radius, modulus, duration), reading in ((k, reading) for k in sorted({(r["R [um]"], r["E [kPa]"], r["t"])
                                                                             for r in views})
                                                  for reading in ("view 0", "views")):
        by_resolution = {float(r["R/dx"]): r for r in views if (r["R [um]"], r["E [kPa]"], r["t"]) ==
                         (radius, modulus, duration) and r["orientation"] == 0 and r["reading"] == reading
                         and not r["R/dx"].endswith("extrapolated")}
        if {6.0, 8.0, 10.0} <= set(by_resolution):
            page.print(three_resolution_line(f"R {radius:g} um, E {modulus:g} kPa, t {duration:g}, {reading}",
                                             {r: by_resolution[r]["deform"] for r in (6.0, 8.0, 10.0)},
                                             by_resolution[10.0]["D_t"]))
    for reading in ("view 0", "views"):
        rows = [r for r in views if r["reading"] == reading and r["R/dx"].endswith("extrapolated")]
        clean = [r for r in rows if r["hull views"] == 0]
        page.print(f"extrapolated, {reading}: D and A within 10 % at {sum(r['target met'] == 'yes' for r in clean)} "
                   f"of {len(clean)} read on the outline at both resolutions (D err "
                   + ", ".join(f"{r['D err %']:+.1f} %" for r in clean) + f"); {len(rows) - len(clean)} more with "
                   "a view of a run read on the nodes' hull")
    missing = [oriented_key(c) for c in todo if oriented_key(c) not in cached]
    if missing:
        page.print("Not run (no record in the cache): " + ", ".join(missing))
    page.write()


if __name__ == "__main__":
    main()
