"""Where the pipe flow's RT-DC error comes from: the measured outline and the staircase wall, on cheap problems.

    nice python validation/pipe_contour.py [--runs results/pipe-dclab] [--resolutions 4 6 8 10]

Three measurements, none of them a coupled run:

1. **The outline at rest.** The undeformed flow cell (homogeneous, nu = 0.48, p1 mesh of edge 2 dx) at R/dx
   ``--resolutions``: deformation 1 - circularity and area of its side view, (a) the convex hull of the nodes
   projected on the x-y plane and (b) ``elastocell.body.observables.smooth_outline`` (the hull of the projected
   smooth surface fitted through the surface nodes), against the circle's 0 and pi.
2. **The staircase wall.** The steady empty cylinder (``elastocell.scenarios.pipe.poiseuille_error``, half-way
   bounce-back on the lattice's staircase) at the channel radii in dx of the pipe_dclab runs (R_ch = 10.94 um with
   R = 6 or 7.66 um at R/dx 6 and 8) and under refinement, against Poiseuille: flow rate Q and centre-line speed at
   the same body force. A channel passing Q (1 + e) has the hydraulic radius R_ch (1 + e)^(1/4): the cell sees the
   confinement R/R_ch (1 + e)^(-1/4), and along LE-2D-FEM-19's isoelastics D ~ (R/R_ch)^4.4 (its E = 3 kPa deformations
   0.0199 and 0.0583 at R/R_ch 0.548 and 0.700), so the wall shifts D by about -1.1 e.
3. **The outline of the pipe_dclab runs.** The last state of every run in ``--runs`` (its checkpoint at the end,
   t = 16/gdot_w or stationary; one snapshot, not the final-window mean of the main table) measured both ways,
   the smooth outline at degrees 4 to 8 (its spread is the fit's uncertainty; the default is 6), each against the table
   (pipe_dclab.py's D_t at the run's own area, on the isoelastic of the same shear modulus), and Richardson-extrapolated
   (order 2) from R/dx 6 and 8 per measure.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page
from pipe_dclab import CHANNEL_WIDTH_UM, TABLE, percent, table_readings

from elastocell.body.cell import Cell
from elastocell.body.observables import OUTLINE_DEGREE, moments, smooth_outline
from elastocell.parameters.flow import flow_cell
from elastocell.scenarios.pipe import poiseuille_error, side_view

CHANNEL_RADIUS_UM = 1.094 * CHANNEL_WIDTH_UM / 2
CELL_OPTIONS = {"nucleus": "none", "material": "neo-hookean", "poisson_ratio": 0.48}
DEGREES = (4, 5, 6, 8)
CONFINEMENT_EXPONENT = float(np.log(0.0583 / 0.0199) / np.log(0.700 / 0.548))  # LE-2D-FEM-19, E = 3 kPa


def outline_d(area: float, perimeter: float) -> float:
    return 1.0 - 2.0 * np.sqrt(np.pi * area) / perimeter


def rest_rows(resolutions) -> list[dict]:
    rows = []
    for resolution in resolutions:
        mesh = Cell.from_parameters(flow_cell(None, dict(CELL_OPTIONS), resolution)).mesh
        surface = mesh.nodes[mesh.surface_nodes]
        hull = side_view(mesh.nodes)
        smooth = smooth_outline(surface, np.zeros(3))
        rows.append({"R/dx": resolution, "surface nodes": len(mesh.surface_nodes),
                     "hull D": outline_d(*hull), "hull A/pi - 1": hull[0] / np.pi - 1,
                     "smooth D": outline_d(*smooth), "smooth A/pi - 1": smooth[0] / np.pi - 1})
    return rows


def wall_rows(radii) -> list[dict]:
    rows = []
    for label, radius in radii:
        error = poiseuille_error(radius)
        rows.append({"case": label, "R_ch/dx": radius, "Q err %": 100 * error["flow_rate_error"],
                     "u_centre err %": 100 * error["centre_speed_error"],
                     "profile L2 err %": 100 * error["profile_l2_error"],
                     "D shift % (est.)": -100 * CONFINEMENT_EXPONENT / 4 * error["flow_rate_error"]})
    return rows


def snapshot_measures(directory: Path, resolution: int, cells: dict) -> dict:
    """(area/R^2, D) of a run's last state: the nodes' hull and the smooth outline at each degree."""
    if resolution not in cells:
        cells[resolution] = Cell.from_parameters(flow_cell(None, dict(CELL_OPTIONS), resolution)).mesh
    mesh = cells[resolution]
    x = np.load(directory / "checkpoint.npz")["positions"] / resolution  # units of R
    centre = moments(x, mesh.elements).centre
    out = {"hull": side_view(x)}
    for degree in DEGREES:
        out[f"smooth L{degree}"] = smooth_outline(x[mesh.surface_nodes], centre, degree=degree)
    return {name: (area, outline_d(area, perimeter)) for name, (area, perimeter) in out.items()}


def run_rows(runs: Path) -> tuple[list[dict], list[str]]:
    rows, notes, cells = [], [], {}
    for point_file in sorted(runs.glob("runs/*/point.json")):
        point = json.loads(point_file.read_text())
        ext = point.get("extrapolation")
        if not ext:
            continue
        radius, modulus = point["radius_um"], point["emodulus_kpa"]
        e_table = 3.0 * modulus / (2.0 * (1.0 + point["options"]["poisson_ratio"]))
        fine, coarse = int(ext["fine_resolution"]), int(ext["coarse_resolution"])
        measured = {r: snapshot_measures(point_file.parent / f"resolution-{r}", r, cells) for r in (coarse, fine)}
        ratio2 = (fine / coarse) ** 2
        variants = []
        for name in measured[fine]:
            (a_c, d_c), (a_f, d_f) = measured[coarse][name], measured[fine][name]
            variants += [(name, f"R/dx {coarse}", a_c, d_c), (name, f"R/dx {fine}", a_f, d_f),
                         (name, f"extrapolated {fine}/{coarse}", a_f + (a_f - a_c) / (ratio2 - 1),
                          d_f + (d_f - d_c) / (ratio2 - 1))]
        readings = table_readings([(a * radius**2, d, e_table) for _, _, a, d in variants])
        errors = {}
        for (name, label, area, deform), (deform_t, area_t, _) in zip(variants, readings, strict=True):
            err_d = percent(deform, deform_t)
            errors[(name, label)] = deform - deform_t
            rows.append({"R [um]": radius, "R/R_ch": radius / CHANNEL_RADIUS_UM, "E [kPa]": modulus,
                         "outline": name, "run": label, "deform": deform, "D_t": deform_t, "D err %": err_d,
                         "A/(pi R^2)": area / np.pi, "A err %": percent(area * radius**2, area_t)})
        for name in measured[fine]:
            e_c, e_f = errors[(name, f"R/dx {coarse}")], errors[(name, f"R/dx {fine}")]
            order = np.log(e_c / e_f) / np.log(fine / coarse) if e_c * e_f > 0 else float("nan")
            notes.append(f"R = {radius:g} um, E = {modulus:g} kPa, {name}: D - D_t {e_c:+.4f} at R/dx {coarse}, "
                         f"{e_f:+.4f} at R/dx {fine}: apparent order {order:.2f}")
    return rows, notes


FORMATS = {"hull D": ".2e", "hull A/pi - 1": "+.2e", "smooth D": ".2e", "smooth A/pi - 1": "+.2e",
           "R_ch/dx": ".2f", "Q err %": "+.2f", "u_centre err %": "+.2f", "profile L2 err %": ".2f",
           "D shift % (est.)": "+.1f", "R [um]": "g", "R/R_ch": ".3f", "E [kPa]": "g", "deform": ".4f",
           "D_t": ".4f", "D err %": "+.1f", "A/(pi R^2)": ".4f", "A err %": "+.1f"}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=Path("results/pipe-dclab"),
                        help="pipe_dclab.py's --out whose runs' last states are measured")
    parser.add_argument("--resolutions", type=float, nargs="+", default=[4, 6, 8, 10])
    args = parser.parse_args(argv)
    page = Page("pipe_dclab", "pipe_contour.py", intro=__doc__.split("\n\n", 2)[2].strip().replace(
        "Three measurements", "Three measurements (the outline's default degree is "
        f"{OUTLINE_DEGREE})"))
    page.table(rest_rows(args.resolutions), "The undeformed cell's side view: nodes' hull and smooth outline",
               formats=FORMATS)
    radii = [(f"R = {r:g} um at R/dx {res}", CHANNEL_RADIUS_UM / r * res) for r in (6.0, 7.66) for res in (6, 8)]
    radii += [(f"refinement {n}", float(n)) for n in (8, 12, 16, 24)]
    page.table(wall_rows(radii), "The staircase cylinder against Poiseuille (same body force)", formats=FORMATS)
    rows, notes = run_rows(args.runs)
    if rows:
        page.table(rows, f"The pipe_dclab runs' last states, each outline against {TABLE}", formats=FORMATS)
        page.print("Apparent order of the deformation error, ln(err_6/err_8)/ln(8/6):\n" + "\n".join(notes))
    else:
        page.print(f"No pipe_dclab run with checkpoints under {args.runs}.")
    page.write()


if __name__ == "__main__":
    main()
