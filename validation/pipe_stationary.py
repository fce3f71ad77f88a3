"""The pipe cell run to its stationary shape with the flow rate held, against dclab's LE-2D-FEM-19: the setting the
measurements of validation/pipe_flow_rate.py argue for as the pipe's default (R/dx 8 alone, the markers at R - c dx),
read where the runs of 16 units of 1/gdot_w had not settled, and at cells outside their four points.

The page's runs: ``--poisson-ratios 0.48 0.49 --extra 6:3:0.3:8,6:3:0.4:8,6:3:0.45:8,6:3:0.495:8,6:3:0.48:10,
6:3:0.49:10,6:3:0.48:8:p2,6:3:0.49:8:p2,6:3:0.48:8:p1:nodal,7.66:3:0.48:8:p1:nodal,7.66:4.5:0.48:8:p1:nodal,
6:2:0.48:8:p1:nodal,6.5:2.5:0.48:8:p1:nodal,5:1.5:0.48:8:p1:nodal,6:3:0.45:8:p1:nodal,6:3:0.49:8:p1:nodal,
6:3:0.495:8:p1:nodal,6:3:0.48:6,6:3:0.48:6:p1:nodal,6:3:0.48:10:p1:nodal,6:3:0.48:8:p1:standard:0.1667,
6:3:0.48:8:p1:nodal:0.1667,7.66:4.5:0.48:8:p1:nodal:0.1667,6.5:2.5:0.48:8:p1:nodal:0.1667`` (one Numba thread
each, two to four processes at a time on the 2-core machine: the six at nu 0.48 about 20 min, the others about
2.5 h).

    nice python validation/pipe_stationary.py [--points 7.66:3,7.66:4.5,6:2,6:3,5:1.5,6.5:2.5]
                                              [--resolution 8] [--corrections 0.3] [--duration 40]
                                              [--poisson-ratios 0.48 0.49]
                                              [--extra 6:3:0.3:8,6:3:0.48:10,6:3:0.49:8:p1:nodal]
                                              [--volumetric standard nodal]
                                              [--workers 2] [--out results/pipe-stationary] [--cached-only]

The cell, channel, flow, reading of the table and record format are validation/pipe_resolution.py's (its
``run_case``: a centred homogeneous cell, neo-Hookean, nu 0.48, linear tetrahedra on the flow scenarios' default
mesh, LE-2D-FEM-19's cylinder R_ch = 1.094 x 10 um, Q = 0.04 uL/s, eta = 15 mPa s; one resolution per run, no
stationarity stop, D and the area are means over the last unit of 1/gdot_w), here with the flow rate held (the
pipe's default, as RT-DC's pump and the table) for --duration units. The drift of D and of the area over the last
units says whether the shape is stationary; dV/V end is the volume the immersed boundary let the cell gain.
``--poisson-ratios``: the same cells at other nu, each with the shear modulus mu = E/(2 (1 + 0.48)) of the point's
E at nu 0.48 (its E scaled by (1 + nu)/1.48), so that Ca_w and the table's isoelastic stay those of the point: in the
immersed-boundary model the incompressible fluid inside the cell holds its volume whatever nu, so in the continuum
D does not depend on nu, and any change of D with nu is the discrete model's. ``--extra``: single cases
R:E:nu:R/dx[:element[:volumetric[:mesh size]]] (E at nu 0.48, scaled as above; the mesh size a uniform edge in
units of R, the flow's default edge of 2 dx where none is given) beside the grid, such as a sweep of nu, a finer
resolution or a denser mesh at one cell. ``--volumetric`` (and an extra case's last field): how J enters the tetrahedra's law
(``MeshParameters.volumetric``): ``standard``, kappa (J - 1) per element, or ``nodal``, the averaged nodal
dilatation that relieves the linear elements' volumetric locking (docs/theory.md).
Every run's record is appended to ``--out/runs.jsonl`` (a run already there is not repeated); ``--cached-only``
writes the page from that file alone. The section goes into docs/validation/pipe_dclab.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page
from pipe_dclab import DRIFT_WINDOW, parse_points, table_readings
from pipe_flow_rate import e_errors
from pipe_resolution import (
    CHANNEL_RADIUS_UM,
    FORMATS,
    POISSON_RATIO,
    cases,
    key,
    poisson_ratio,
    read,
    run_missing,
    shear_equivalent_modulus,
    with_table,
)

TARGET_PERCENT = 10.0
"""Issue 24's target for the RT-DC deformation and area against LE-2D-FEM-19, %."""


def last_unit_records(record: dict, out: Path) -> int | str:
    """The number of records in the run's last unit of 1/gdot_w, from its time series ('' where it is not at hand)."""
    import pandas as pd

    path = out / record["key"] / "timeseries.csv"
    if not path.exists():
        return ""
    times = pd.read_csv(path, usecols=["time"])["time"]
    return int((times > times.iloc[-1] - 1.0).sum())


def nu_table(records: list[dict], out: Path) -> list[dict]:
    """Per cell (radius, shear modulus) run at more than one nu: a row per nu, D against the nu 0.48 run's."""
    groups: dict[tuple, list[dict]] = {}
    for r, e_err in zip(records, e_errors(records) if records else [], strict=True):
        if r["mesh_size"] is not None:  # the denser meshes have their own table (mesh_table)
            continue
        groups.setdefault((r["radius_um"], round(shear_equivalent_modulus(r), 4), r["c"], r["resolution"],
                           r["element"], r.get("volumetric", "standard")), []).append(
            {**r, "E_err": e_err})
    rows = []
    for (radius, e_t, _, resolution, element, treatment), runs in sorted(groups.items()):
        if len({poisson_ratio(r) for r in runs}) < 2:
            continue
        base = [r for r in runs if poisson_ratio(r) == POISSON_RATIO]
        for r in sorted(runs, key=poisson_ratio):
            nu = poisson_ratio(r)
            rows.append({"R [um]": radius, "R/R_ch": radius / CHANNEL_RADIUS_UM, "mu [kPa]": e_t / 3,
                         "R/dx": resolution, "element": element, "J": treatment, "nu": nu,
                         "kappa/mu": 2 * (1 + nu) / (3 * (1 - 2 * nu)), "deform": r["deform"],
                         "D/D(nu 0.48)": r["deform"] / base[0]["deform"] if base else float("nan"),
                         "D err %": r["D_err"], "A err %": r["A_err"], "E err %": r["E_err"],
                         "dV/V end": r["volume_change_end"], "D drift %/t": 100 * r["drift_deformation"],
                         "reading": "hull" if r["fallback_last_unit"] else "outline"})
    return rows


SETTLED_DRIFT_PERCENT = 0.5
"""A run counts in the Poisson-ratio summary where its D drifts by at most this (% per unit of 1/gdot_w) ..."""
SETTLED_VOLUME = 0.02
"""... its volume changed by at most this fraction, and its last unit was read on the outline."""


def settled(row: dict) -> bool:
    return (row["reading"] == "outline" and abs(row["D drift %/t"]) <= SETTLED_DRIFT_PERCENT
            and abs(row["dV/V end"]) <= SETTLED_VOLUME)


def nu_summary(rows: list[dict]) -> str:
    """What the rows of :func:`nu_table` say, in numbers: D at nu 0.49 over D at 0.48 per resolution, and the
    spread of D over every nu run at one cell and resolution."""
    lines = []
    for resolution, element, treatment in sorted({(r["R/dx"], r["element"], r["J"]) for r in rows}):
        label = f"R/dx {resolution:g}, {element}, J {treatment}"
        same = [r for r in rows if (r["R/dx"], r["element"], r["J"]) == (resolution, element, treatment)]
        unsettled = {(r["R [um]"], r["mu [kPa]"]) for r in same if not settled(r)}
        ratios = [r["D/D(nu 0.48)"] for r in same if r["nu"] == 0.49
                  and (r["R [um]"], r["mu [kPa]"]) not in unsettled]
        if ratios:
            lines.append(f"{label}: D(nu 0.49)/D(nu 0.48) {min(ratios):.3f}-{max(ratios):.3f} "
                         f"over {len(ratios)} cell(s) settled at both nu")
        if unsettled:
            lines.append(f"{label}: not counted, a run not settled (read on the hull, |D drift| "
                         f"above {SETTLED_DRIFT_PERCENT:g} %/t or |dV/V| above {SETTLED_VOLUME:g}): "
                         + ", ".join(f"R {radius:g} um, mu {mu:.4f} kPa" for radius, mu in sorted(unsettled)))
    cells: dict[tuple, list[dict]] = {}
    for r in rows:
        cells.setdefault((r["R [um]"], r["mu [kPa]"], r["R/dx"], r["element"], r["J"]), []).append(r)
    for (radius, mu, resolution, element, treatment), runs in cells.items():
        runs = [r for r in runs if settled(r)]
        if len(runs) > 2:
            low, high = min(runs, key=lambda r: r["deform"]), max(runs, key=lambda r: r["deform"])
            ratios = ", ".join(f"{r['nu']:g}" for r in runs)
            lines.append(f"R {radius:g} um, mu {mu:.4f} kPa, R/dx {resolution:g}, {element}, J {treatment}, nu {ratios}: "
                         f"D from {low['deform']:.4f} (nu {low['nu']:g}, D err {low['D err %']:+.1f} %) to "
                         f"{high['deform']:.4f} (nu {high['nu']:g}, {high['D err %']:+.1f} %), "
                         f"{100 * (high['deform'] - low['deform']) / high['deform']:.0f} % of the largest")
    return "\n".join(lines)


def treatment_table(rows: list[dict]) -> list[dict]:
    """Per cell, resolution and nu run with both volumetric treatments: D standard and nodal, their ratio, the
    errors against the table and whether each run settled (:func:`settled`)."""
    runs = {(r["R [um]"], r["mu [kPa]"], r["R/dx"], r["nu"], r["J"]): r for r in rows
            if r["element"] == "p1" and r["mesh"] == "default"}
    out = []
    for (radius, mu, resolution, nu, treatment), nodal in sorted(runs.items()):
        standard = runs.get((radius, mu, resolution, nu, "standard"))
        if treatment != "nodal" or standard is None:
            continue
        out.append({"R [um]": radius, "R/R_ch": radius / CHANNEL_RADIUS_UM, "mu [kPa]": mu, "R/dx": resolution,
                    "nu": nu, "D standard": standard["deform"], "D nodal": nodal["deform"],
                    "nodal/standard": nodal["deform"] / standard["deform"], "D err % standard": standard["D err %"],
                    "D err % nodal": nodal["D err %"], "settled standard": "yes" if settled(standard) else "no",
                    "settled nodal": "yes" if settled(nodal) else "no", "dV/V end nodal": nodal["dV/V end"],
                    "D drift %/t nodal": nodal["D drift %/t"]})
    return out


MESH_WINDOW = (8.0, 12.0)
"""The window (units of 1/gdot_w) in which a denser mesh's run is compared with the default mesh's: before the
denser meshes' side views left the smooth outline for the nodes' hull."""


def mesh_table(records: list[dict], out: Path) -> list[dict]:
    """Per run on a mesh other than the default, beside the default-mesh run of the same cell and treatment: the
    mean D over :data:`MESH_WINDOW` and how many of the window's records were read on the hull."""
    import pandas as pd

    def window(record: dict) -> tuple[float, str, float]:
        """(mean D, hull records, the table's D at the window's mean area on the record's isoelastic)."""
        series = pd.read_csv(out / record["key"] / "timeseries.csv")
        inside = series[(series["time"] >= MESH_WINDOW[0]) & (series["time"] <= MESH_WINDOW[1])]
        deform = float(inside["deformation"].mean())
        area = float(inside["projected_area"].mean()) * record["radius_um"] ** 2
        table = table_readings([(area, deform, shear_equivalent_modulus(record))])[0][0]
        return deform, f"{int(inside['outline_fallback'].sum())} of {len(inside)}", table

    def same(a: dict, b: dict) -> bool:
        return all(a.get(k) == b.get(k) for k in ("radius_um", "emodulus_kpa", "resolution", "c", "element",
                                                    "poisson_ratio", "volumetric", "duration"))

    rows = []
    for record in records:
        default = [r for r in records if r["mesh_size"] is None and same(r, record)]
        if record["mesh_size"] is None or not default:
            continue
        d_mesh, hull_mesh, table_mesh = window(record)
        d_default, hull_default, table_default = window(default[0])
        rows.append({"R [um]": record["radius_um"], "E [kPa]": record["emodulus_kpa"], "R/dx": record["resolution"],
                     "J": record.get("volumetric", "standard"), "edge [dx]": record["mesh_size"] * record["resolution"],
                     "nodes": record["nodes"], "D (edge 2 dx)": d_default, "D": d_mesh, "D/D(edge 2 dx)": d_mesh / d_default,
                     "hull records": hull_mesh, "hull records (edge 2 dx)": hull_default,
                     "D err % (edge 2 dx)": 100 * (d_default / table_default - 1),
                     "D err %": 100 * (d_mesh / table_mesh - 1)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", default="7.66:3,7.66:4.5,6:2,6:3,5:1.5,6.5:2.5", help="R:E,R:E (um, kPa)")
    parser.add_argument("--resolution", type=float, default=8.0, help="R/dx")
    parser.add_argument("--corrections", type=float, nargs="+", default=[0.3], help="c: markers at R - c dx")
    parser.add_argument("--duration", type=float, default=40.0, help="units of 1/gdot_w")
    parser.add_argument("--poisson-ratios", type=float, nargs="+", default=[POISSON_RATIO],
                        help="nu of the cell, each at the shear modulus of the point's E at nu 0.48")
    parser.add_argument("--extra", default="", help="R:E:nu:R/dx[:element[:volumetric[:mesh size]]],... single "
                        "cases beside the grid")
    parser.add_argument("--volumetric", nargs="+", default=["standard"], choices=["standard", "nodal"],
                        help="how J enters the linear tetrahedra's law (MeshParameters.volumetric), for every grid run")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/pipe-stationary"))
    parser.add_argument("--cached-only", action="store_true")
    args = parser.parse_args()
    points = parse_points(args.points)
    runs = [(nu, point, args.resolution, "p1", treatment, None) for treatment in args.volumetric
            for nu in args.poisson_ratios for point in points]
    for item in filter(None, args.extra.split(",")):
        fields = item.split(":")
        radius, modulus, nu, resolution = map(float, fields[:4])
        element = fields[4] if len(fields) > 4 else "p1"
        treatment = fields[5] if len(fields) > 5 else "standard"
        size = float(fields[6]) if len(fields) > 6 else None
        if (nu, (radius, modulus), resolution, element, treatment, size) not in runs:
            runs.append((nu, (radius, modulus), resolution, element, treatment, size))
    todo = [{**c, "hold": True, "element": element, "mesh_size": size,
             **({} if nu == POISSON_RATIO else {"poisson_ratio": nu}),
             **({} if treatment == "standard" else {"volumetric": treatment})}
            for nu, point, resolution, element, treatment, size in runs
            for c in cases((point[0], round(point[1] * (1 + nu) / (1 + POISSON_RATIO), 6)), [resolution],
                           args.corrections, args.duration, meshes=False)]
    page = Page("pipe_dclab", "pipe_stationary.py", versions=("dclab", "numba"))
    if not args.cached_only:
        run_missing(todo, args.out, args.workers)
    cached = {r["key"]: r for r in read(args.out / "runs.jsonl")}
    records = with_table([cached[key(c)] for c in todo if key(c) in cached])
    moduli = e_errors(records) if records else []
    rows = [{"R [um]": r["radius_um"], "R/R_ch": r["radius_um"] / CHANNEL_RADIUS_UM, "E [kPa]": r["emodulus_kpa"],
             "R/dx": r["resolution"], "element": r["element"], "J": r.get("volumetric", "standard"),
             "mesh": "default" if r["mesh_size"] is None else f"edge {r['mesh_size'] * r['resolution']:.2f} dx", "nu": poisson_ratio(r), "mu [kPa]": shear_equivalent_modulus(r) / 3, "Ca_w": r["capillary_number_wall"], "c [dx]": r["c"], "t [1/gdot_w]": r["end"],
             "reading": "hull" if r["fallback_last_unit"] else "outline", "deform": r["deform"],
             "D_t": r["D_t"], "D err %": r["D_err"], "A err %": r["A_err"], "E err %": e_err,
             "D drift %/t": 100 * r["drift_deformation"], "A drift %/t": 100 * r["drift_projected_area"],
             "hull records": f"{r['fallback_last_unit']} of {last_unit_records(r, args.out)}",
             "G/G_0": r["pressure_gradient_ratio"], "dV/V end": r["volume_change_end"], "nodes": r["nodes"],
             "wall_s": r["wall_s"],
             "target met": "yes" if abs(r["D_err"]) <= TARGET_PERCENT and abs(r["A_err"]) <= TARGET_PERCENT else "no"}
            for r, e_err in zip(records, moduli, strict=True)]
    page.intro = (
        f"A centred homogeneous cell (neo-Hookean, nu 0.48 unless the row says, linear tetrahedra on the default mesh) in LE-2D-FEM-19's "
        f"cylinder (R_ch = {CHANNEL_RADIUS_UM:.2f} um, Q = 0.04 uL/s, eta = 15 mPa s), the flow rate held, R/dx "
        f"{args.resolution:g} alone unless the row says (no extrapolation), the markers at R - c dx, {args.duration:g} units of "
        "1/gdot_w; D and the area are means over the last unit. A row at another nu has the shear modulus mu of its "
        "point at nu 0.48 (E scaled by (1 + nu)/1.48): the same Ca_w and the same isoelastic of the table; in the "
        "immersed-boundary model the incompressible fluid inside the cell holds its volume whatever nu, so in the "
        "continuum D does not depend on nu and a change of D with nu is the discrete model's. J: how the volume ratio "
        "enters the linear tetrahedra's law: `standard` (kappa (J - 1) per element, the default) or `nodal` (the "
        "averaged nodal dilatation, one volumetric constraint per node instead of per element: no volumetric "
        "locking; docs/theory.md). Ca_w = G R_ch/(2 mu) is the wall capillary number of "
        "the nominal flow (mu the cell's shear modulus). Against the table (validation/pipe_dclab.py's reading): D "
        "err at elastocell's area on the isoelastic of the same shear modulus, A err at elastocell's D, E err the "
        "table's modulus at elastocell's (area, D) over the run's shear-equivalent modulus. D and A drift: the "
        f"least-squares slope of D and of the area over the last {DRIFT_WINDOW:g} units of 1/gdot_w over their mean, "
        "per unit (0 at a stationary shape). `reading`: `outline` where every record of the last unit is the smooth "
        "outline fitted through the surface nodes, `hull` where some are its fallback, the convex hull of the nodes "
        "(`hull records`: how many of the unit's records): D jumps there with the change of reading, not with the "
        "cell, so a `hull` row is not the cell's shape. G/G_0: the pressure gradient that held Q at the end over the "
        "nominal one; dV/V end: the volume the immersed boundary let the cell gain by the end. `target met`: D and "
        f"A within {TARGET_PERCENT:g} % (issue 24). wall_s is each run's own wall time (runs two or three at a time on the "
        f"2-core machine; {sum(r['wall_s'] for r in records):.0f} s in all); the footer's wall time is that of the "
        f"command that wrote the page, which reads runs found in the cache. {len(records)} of {len(todo)} runs.")
    page.table(rows, f"The shape at t = {args.duration:g}/gdot_w against LE-2D-FEM-19", formats={
        **FORMATS, "R/R_ch": ".3f", "Ca_w": ".3f", "E [kPa]": ".4g", "mu [kPa]": ".4f", "nu": "g", "R/dx": "g", "t [1/gdot_w]": ".1f", "E err %": "+.1f", "A drift %/t": "+.2f",
        "G/G_0": ".4f"})
    both = treatment_table(rows)
    if both:
        page.table(both, "The two volumetric treatments of the linear tetrahedra at the same cell: D standard "
                   "(kappa (J - 1) per element) and nodal (the averaged nodal dilatation); settled: read on the "
                   f"outline, |D drift| <= {SETTLED_DRIFT_PERCENT:g} %/t and |dV/V| <= {SETTLED_VOLUME:g}", formats={
                       "R/R_ch": ".3f", "mu [kPa]": ".4f", "R/dx": "g", "nu": "g", "D standard": ".4f",
                       "D nodal": ".4f", "nodal/standard": ".3f", "D err % standard": "+.1f", "D err % nodal": "+.1f",
                       "dV/V end nodal": "+.4f", "D drift %/t nodal": "+.2f"})
    meshes = mesh_table(records, args.out)
    if meshes:
        page.table(meshes, f"A denser mesh (more markers per dx) against the default edge of 2 dx: D averaged over t = "
                   f"{MESH_WINDOW[0]:g}-{MESH_WINDOW[1]:g}/gdot_w, where the dense runs were still read on the outline "
                   "(`hull records`: the window's records read on the nodes' hull, whose D is biased high); D err "
                   "against the table's D at the window's mean area (the shape is not yet stationary there: a "
                   "comparison of the two meshes at the same time)", formats={
                       "edge [dx]": ".2f", "D (edge 2 dx)": ".4f", "D": ".4f", "D/D(edge 2 dx)": ".3f",
                       "D err % (edge 2 dx)": "+.1f", "D err %": "+.1f", "R/dx": "g"})
    by_nu = nu_table(records, args.out)
    if by_nu:
        page.table(by_nu, "The same cells at other Poisson ratios, at the same shear modulus: D and its error "
                   "against LE-2D-FEM-19 (kappa/mu = 2 (1 + nu)/(3 (1 - 2 nu)), the tetrahedra's volumetric "
                   "stiffness over their shear stiffness; `hull`: the last unit read on the nodes' hull)",
                   formats={"R/R_ch": ".3f", "mu [kPa]": ".4f", "nu": "g", "R/dx": "g", "kappa/mu": ".1f", "deform": ".4f",
                            "D/D(nu 0.48)": ".3f", "D err %": "+.1f", "A err %": "+.1f", "E err %": "+.1f",
                            "dV/V end": "+.4f", "D drift %/t": "+.2f"})
        page.print(nu_summary(by_nu))
    missing = [key(c) for c in todo if key(c) not in cached]
    if missing:
        page.print("Not run (no record in the cache): " + ", ".join(missing))
    page.write()


if __name__ == "__main__":
    main()
