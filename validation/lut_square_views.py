"""The square duct's look-up-table points read from side views about the axis and extrapolated from R/dx 6 and 8,
against dclab's HE-3D-FEM-22.

    nice python validation/lut_square_views.py [--radii 4,5,6,7] [--moduli 1,1.5,2,3] [--duration 20]
                                               [--fine /work/results/lut-square-r8]
                                               [--coarse /work/results/lut-square-r6] [--workers 2]

The points of validation/lut_square.py (``elastocell lut --channel-shape square --channel-width 20um --flow-rate
0.04uL/s --medium 0.59%MC-PBS --temperature 23``, R/dx 8, markers at R - 0.3 dx; their runs read back from
``--fine``) and the same points at R/dx 6 (run here into ``--coarse``, resumable). Each run's last state (its
checkpoint) is read from the pipe's own side view (along z) and as the mean over ``--views`` side views about the
channel axis at azimuths k pi/views (``elastocell.body.observables.side_views_outline``). In the square duct the
continuum shape has the duct's four-fold symmetry, not the cylinder's axial one: the views along z (the camera's,
RT-DC images through the channel's height) and along y are equivalent, the diagonal ones are not, so the default is
2 (z and y); 6 views average in the diagonal ones the camera never sees. The two resolutions are combined by
Richardson extrapolation of order 2 (``elastocell.simulation.extrapolation.richardson``). dclab is asked which
modulus HE-3D-FEM-22 (Wittwer et al. 2022: 3D FEM, neo-Hookean cell, square channel, shear-thinning fluid) gives
each (area_um, deform), with its viscosity of the same medium (buyukurganci-2022) and no pixelation correction;
E_dclab/E_input is 1 where both agree (the issue's target: within 5 %). The section goes into
docs/validation/lut_square.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

TARGET = 0.05
"""Issue 25's target: within 5 % in E of HE-3D-FEM-22."""


def last_state_readings(directory: Path, record: dict, views: int) -> dict:
    """The run's last state read from the side view along z and as the mean over ``views`` side views: area
    (um^2) and D of each, and how many of the views fell back to the nodes' hull."""
    from elastocell.body.cell import Cell
    from elastocell.body.observables import (
        circularity_deformation,
        moments,
        side_views_outline,
        smooth_outline_checked,
    )
    from elastocell.parameters.flow import flow_cell

    options = record["options"]
    resolution, correction = float(options["resolution"]), float(options["hydrodynamic_radius_correction"])
    cell = Cell.from_parameters(flow_cell(None, {"nucleus": "none", "material": options["material"],
                                                 "poisson_ratio": options["poisson_ratio"]}, resolution))
    with np.load(directory / "checkpoint.npz") as data:
        x = data["positions"] / (resolution - correction)  # the markers' radius, as the pipe reads
    centre = moments(x, cell.mesh.elements).centre
    surface = x[cell.mesh.surface_nodes]
    area, perimeter, fitted = smooth_outline_checked(surface, centre)
    views_area, views_deformation, hull_views = side_views_outline(surface, centre, views=views)
    scale = record["radius_um"] ** 2
    return {"area one": area * scale, "D one": circularity_deformation(area, perimeter), "hull one": not fitted,
            "area views": views_area * scale, "D views": views_deformation, "hull views": hull_views}


def table_deformation(emodulus, area_um: float, modulus_kpa: float) -> float:
    """The deformation at which HE-3D-FEM-22 (this page's conditions) assigns ``modulus_kpa`` to a cell of area
    ``area_um``: E(deform) on a fine logarithmic grid, interpolated (E falls with deform); NaN outside the table."""
    deform = np.geomspace(5e-4, 0.15, 4000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e = np.asarray(emodulus.get_emodulus(area_um=np.full_like(deform, area_um), deform=deform,
                                             medium="0.59% MC-PBS", channel_width=20.0, flow_rate=0.04, px_um=0,
                                             temperature=23.0, visc_model="buyukurganci-2022",
                                             lut_data="HE-3D-FEM-22"))
    inside = np.isfinite(e)
    if not inside.any() or not (e[inside].min() <= modulus_kpa <= e[inside].max()):
        return float("nan")
    order = np.argsort(e[inside])
    return float(np.interp(modulus_kpa, e[inside][order], deform[inside][order]))


def predicted(row: dict, resolution: float) -> float:
    """The D at ``resolution`` that order-2 convergence through the R/dx 6 and 8 views' readings predicts:
    D_inf + (D_8 - D_inf) (8/resolution)^2."""
    limit, fine = row["8/6 views"][1], row["8 views"][1]
    return limit + (fine - limit) * (8.0 / resolution) ** 2


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--radii", default="4,5,6,7")
    parser.add_argument("--moduli", default=["1kPa", "1.5kPa", "2kPa", "3kPa"], help="kPa, comma-separated",
                        type=lambda text: [f"{m.strip()}kPa" for m in text.split(",")])
    parser.add_argument("--duration", type=float, default=20.0, help="cap per point, 1/gdot_w")
    parser.add_argument("--fine", type=Path, default=Path("/work/results/lut-square-r8"))
    parser.add_argument("--coarse", type=Path, default=Path("/work/results/lut-square-r6"))
    parser.add_argument("--finest", type=Path, default=Path("/work/results/lut-square-r10"),
                        help="finished points of a finer resolution (not run here: made by compute_lut with that "
                             "resolution into this folder), shown beside the extrapolation that predicts them")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--views", type=int, default=2,
                        help="side views about the axis (k pi/views): 2, along z and y, the duct's equivalent ones")
    args = parser.parse_args(argv)
    from dclab.features import emodulus
    from page import Page

    from elastocell.inverse.lut import compute_lut
    from elastocell.simulation.extrapolation import richardson

    common = dict(radii=args.radii, moduli=args.moduli, duration=args.duration, channel_width="20um",
                  channel_shape="square", medium="0.59%MC-PBS", temperature=23.0)
    start = time.perf_counter()
    results = {}
    for name, resolution, folder in (("fine", 8.0, args.fine), ("coarse", 6.0, args.coarse)):
        folder.mkdir(parents=True, exist_ok=True)
        results[name] = compute_lut(folder / "lut.txt", None, "0.04uL/s", None, resolution=resolution,
                                    workers=args.workers, **common)
    wall = time.perf_counter() - start
    coarse_by_point = {(r["radius_um"], r["emodulus_kpa"]): r for r in results["coarse"]["records"]}
    finest_by_point = {}
    for marker in sorted(args.finest.glob("*_runs/*/point.json")):
        record = json.loads(marker.read_text())
        finest_by_point[(record["radius_um"], record["emodulus_kpa"])] = (marker.parent, record)
    rows = []
    for fine in results["fine"]["records"]:
        point = (fine["radius_um"], fine["emodulus_kpa"])
        coarse = coarse_by_point[point]
        readings = {name: last_state_readings(Path(results[name]["runs"]) / record["key"], record, args.views)
                    for name, record in (("fine", fine), ("coarse", coarse))}
        row = {"R [um]": point[0], "E [kPa]": point[1], "state 8": fine["state"], "state 6": coarse["state"],
               "lut": (fine["area_um"], fine["deform"]),
               "8 one": (readings["fine"]["area one"], readings["fine"]["D one"]),
               "8 views": (readings["fine"]["area views"], readings["fine"]["D views"]),
               "6 views": (readings["coarse"]["area views"], readings["coarse"]["D views"])}
        for reading in ("one", "views"):
            row[f"8/6 {reading}"] = tuple(float(richardson(readings["fine"][f"{q} {reading}"],
                                                          readings["coarse"][f"{q} {reading}"], 8.0 / 6.0))
                                          for q in ("area", "D"))
        row["hull views 8/6"] = f"{readings['fine']['hull views']}/{readings['coarse']['hull views']}"
        if point in finest_by_point:
            directory, record = finest_by_point[point]
            finest = last_state_readings(directory, record, args.views)
            row["finest"] = (finest["area views"], finest["D views"])
            row["finest R/dx"] = record["options"]["resolution"]
        else:
            row["finest"] = (float("nan"), float("nan"))
        rows.append(row)
    readings_names = ("lut", "8 one", "8 views", "8/6 one", "8/6 views", "finest")
    ratios = {}
    for name in readings_names:
        area = np.array([r[name][0] for r in rows])
        deform = np.array([r[name][1] for r in rows])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # points outside the table come back as NaN
            e = emodulus.get_emodulus(area_um=area, deform=deform, medium="0.59% MC-PBS", channel_width=20.0,
                                      flow_rate=0.04, px_um=0, temperature=23.0, visc_model="buyukurganci-2022",
                                      lut_data="HE-3D-FEM-22")
        ratios[name] = np.asarray(e) / np.array([r["E [kPa]"] for r in rows])  # dclab answers in kPa
    table = []
    for i, r in enumerate(rows):
        table.append({"R [um]": r["R [um]"], "E [kPa]": r["E [kPa]"], "state 8 / 6": f"{r['state 8']} / {r['state 6']}",
                      "hull views 8/6": r["hull views 8/6"],
                      **{f"D {name}": r[name][1] for name in readings_names},
                      **{f"E ratio {name}": ratios[name][i] for name in readings_names}})
    page = Page("lut_square", "lut_square_views.py", versions=("dclab", "numba"), intro=(
        "The square duct's points of lut_square.py (20 um, 0.04 uL/s, 0.59 % MC-PBS at 23 degC, neo-Hookean cell, "
        f"nu 0.48, markers at R - 0.3 dx, {args.duration:g} units of 1/gdot_w or a stationary shape) at R/dx 8 and "
        f"at R/dx 6, each run's last state read from the pipe's side view along z (`one`) and as the mean over "
        f"{args.views} side views about the channel axis at azimuths k pi/{args.views} (`views`, "
        "elastocell.body.observables.side_views_outline; 2: along z and y, the duct's equivalent views), and the two "
        "resolutions combined by Richardson extrapolation of order 2 (`8/6`); `lut`: the table's own reading "
        "(R/dx 8, the view along z, the mean over the last unit). E ratio: the modulus dclab's HE-3D-FEM-22 gives "
        "the (area_um, deform) over the run's E (1 where both agree; viscosity buyukurganci-2022, no pixelation "
        "correction; NaN outside the table). `hull views 8/6`: of the views of each run's last state, how "
        "many fell back to the nodes' hull (an extrapolation with one is not trusted). `state`: stationary, or "
        "cap where the run reached the duration first."))
    page.table(table, "Deformation and E_HE-3D-FEM-22/E_input of each reading", formats={
        **{f"D {n}": ".4f" for n in readings_names}, **{f"E ratio {n}": ".3f" for n in readings_names}})
    for name in readings_names:
        ratio = ratios[name]
        finite = ratio[np.isfinite(ratio)]
        clean = [i for i, r in enumerate(rows) if r["hull views 8/6"] == "0/0" and np.isfinite(ratio[i])]
        page.print(f"{name}: within {100 * TARGET:g} % of HE-3D-FEM-22 in E at "
                   f"{int(np.sum(np.abs(finite - 1) <= TARGET))} of {finite.size} points (E ratio "
                   f"{finite.min():.3f}-{finite.max():.3f}, median {np.median(finite):.3f}); on the {len(clean)} "
                   f"points whose views all read the smooth outline at both resolutions: "
                   f"{int(np.sum(np.abs(ratio[clean] - 1) <= TARGET))}")
    from pipe_orientation import three_resolution_line

    for r in rows:
        if r.get("finest R/dx") == 10.0:
            d_t = table_deformation(emodulus, r["finest"][0], r["E [kPa]"])
            page.print(three_resolution_line(f"R {r['R [um]']:g} um, E {r['E [kPa]']:g} kPa, {args.views} views",
                                             {6.0: r["6 views"][1], 8.0: r["8 views"][1], 10.0: r["finest"][1]},
                                             d_t))
    for r in rows:
        if "finest R/dx" in r:
            i = rows.index(r)
            page.print(f"R {r['R [um]']:g} um, E {r['E [kPa]']:g} kPa at R/dx {r['finest R/dx']:g} "
                       f"({args.views} views): "
                       f"D {r['finest'][1]:.4f}, E ratio {ratios['finest'][i]:.3f}; R/dx 8 {r['8 views'][1]:.4f} "
                       f"({ratios['8 views'][i]:.3f}), 8/6 extrapolated {r['8/6 views'][1]:.4f} "
                       f"({ratios['8/6 views'][i]:.3f}); order 2 from 8 and 6 predicts R/dx "
                       f"{r['finest R/dx']:g} at {predicted(r, r['finest R/dx']):.4f}")
    page.print(f"wall time {wall:.0f} s (finished points read back from {args.fine} and {args.coarse})")
    page.write()


if __name__ == "__main__":
    main()
