"""How well the pipe's reference itself is known: dclab's LE-2D-FEM-19 against the analytical LE-2D-ana-18.

    python validation/pipe_references.py

The pipe's target (issue: RT-DC deformation within 10 % of LE-2D-FEM-19) assumes that table is the truth. dclab
ships a second, independent model of the same physics in the same channel, flow and medium: LE-2D-ana-18 (Mietke
et al. 2015, Biophys. J. 109, 2023: the analytical small-deformation solution for an incompressible linear-elastic
sphere in the cylinder of radius 1.094 x 10 um, Q = 0.04 uL/s, eta = 15 mPa s), shipped as isoelastics only (no
look-up table), valid up to deform 0.03. This script compares the two where both are defined, nothing run:

- LE-2D-FEM-19's deformation at (area, E): dclab's look-up table (``get_emodulus``) inverted along the
  deformation on a fine grid (``pipe_dclab.table_readings``, the reading the pipe pages use);
- LE-2D-ana-18's deformation at (area, E): its isoelastics (``dclab.isoelastics``) interpolated in area along each
  line, then between the two lines that bracket E, linearly in (ln E, ln D); NaN where the two lines do not both
  reach that area.

Both are read at the same (area, E) on a grid of areas and moduli, and at the four cells of the pipe pages (radius
R, modulus E) at their undeformed area pi R^2. ``D FEM-19 / D ana-18 - 1`` is the references' disagreement in
deformation; ``E FEM-19 / E`` the modulus LE-2D-FEM-19 assigns to the analytical solution's (area, D) over the
modulus the analytical solution was computed for (what a user would see switching between the two). The section
goes into docs/validation/pipe_dclab.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from page import Page
from pipe_dclab import CHANNEL_WIDTH_UM, FLOW_RATE_UL_S, TABLE, VISCOSITY_MPA_S, table_modulus, table_readings

ANALYTICAL = "LE-2D-ana-18"
ANALYTICAL_MAX_DEFORM = 0.03  # the analytical isoelastics stop there (small-deformation theory)
FEM_MIN_DEFORM = 0.005  # LE-2D-FEM-19's header: FEM points were missing below it (and below 200 um^2), filled in
# with analytical results at a few points
FEM_MAX_AREA = math.pi * 7.66**2  # the pipe pages' largest cell, R = 7.66 um (R/R_ch 0.70)
PIPE_CELLS = ((6.0, 2.0), (6.0, 3.0), (7.66, 3.0), (7.66, 4.5))  # (R um, E kPa) of the pipe pages


def analytical_isoelastics() -> list[np.ndarray]:
    """LE-2D-ana-18's isoelastics in LE-2D-FEM-19's channel, flow and medium (no pixelation offset): a list of
    (n, 3) arrays (area_um, deform, emodulus kPa), each sorted by area, sorted by modulus."""
    from dclab import isoelastics

    lines = isoelastics.get_default().get(col1="area_um", col2="deform", channel_width=CHANNEL_WIDTH_UM,
                                          flow_rate=FLOW_RATE_UL_S, viscosity=VISCOSITY_MPA_S,
                                          lut_identifier=ANALYTICAL, add_px_err=False)
    lines = [line[np.argsort(line[:, 0])] for line in lines]
    return sorted(lines, key=lambda line: line[0, 2])


def analytical_deformation(lines: list[np.ndarray], area_um: float, modulus_kpa: float) -> float:
    """LE-2D-ana-18's deformation of a cell of projected area ``area_um`` and modulus ``modulus_kpa``: each
    isoelastic interpolated at that area, then the two lines bracketing the modulus, linearly in (ln E, ln D);
    NaN where either of them does not reach the area."""
    moduli = np.array([line[0, 2] for line in lines])
    upper = int(np.searchsorted(moduli, modulus_kpa))
    if upper == 0 or upper == len(lines):
        return float("nan")
    pair = (lines[upper - 1], lines[upper])
    if not all(line[0, 0] <= area_um <= line[-1, 0] for line in pair):
        return float("nan")
    log_d = [math.log(np.interp(area_um, line[:, 0], line[:, 1])) for line in pair]
    weight = (math.log(modulus_kpa) - math.log(pair[0][0, 2])) / (math.log(pair[1][0, 2]) - math.log(pair[0][0, 2]))
    return math.exp(log_d[0] + weight * (log_d[1] - log_d[0]))


def compare(points: list[tuple[float, float]]) -> list[dict]:
    """For each (area_um, E kPa): both references' deformation and LE-2D-FEM-19's modulus at the analytical
    (area, D); NaN where either is undefined."""
    lines = analytical_isoelastics()
    d_analytical = [analytical_deformation(lines, area, modulus) for area, modulus in points]
    d_fem = [reading[0] for reading in table_readings([(area, float("nan"), modulus) for area, modulus in points])]
    e_fem = table_modulus([area for area, _ in points], d_analytical)
    return [{"area_um": area, "E [kPa]": modulus, "D ana-18": da, "D FEM-19": df,
             "D FEM-19 / D ana-18 - 1 %": 100.0 * (df / da - 1.0), "E FEM-19 / E at ana-18's D": float(ef) / modulus}
            for (area, modulus), da, df, ef in zip(points, d_analytical, d_fem, e_fem, strict=True)]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--areas", type=float, nargs="+", default=[50, 75, 100, 125, 150, 175, 200, 225, 250],
                        help="projected areas of the grid (um^2)")
    parser.add_argument("--moduli", type=float, nargs="+", default=[1.5, 2, 2.5, 3, 4, 5, 6, 8, 10],
                        help="Young's moduli of the grid (kPa)")
    args = parser.parse_args(argv)
    page = Page("pipe_dclab", "pipe_references.py", intro=(
        f"dclab ships two models of the pipe's physics in the same channel (R_ch = 1.094 x 10 um), flow (Q = "
        f"{FLOW_RATE_UL_S} uL/s) and medium (eta = {VISCOSITY_MPA_S:g} mPa s): the FEM table {TABLE} (Mokbel et "
        f"al. 2017), the pipe's reference, and the analytical small-deformation solution {ANALYTICAL} (Mietke et al. "
        "2015, isoelastics up to deform 0.03). Both are read at the same (area, E) where both are defined: "
        f"{TABLE} through dclab's look-up table inverted along the deformation (the pipe pages' reading), "
        f"{ANALYTICAL} through its isoelastics interpolated in area and, between the two bracketing lines, in "
        f"(ln E, ln D). `E FEM-19 / E at ana-18's D` is the modulus {TABLE} assigns to the analytical (area, D) "
        "over the modulus it was computed for. Nothing is simulated: this is how well the truth of the pipe's "
        f"target is known. {TABLE}'s header says its FEM simulations were missing a few points at deform < "
        f"{FEM_MIN_DEFORM} and area < 200 um^2, complemented with analytical results: the 0.0 % rows are such "
        "points (the two agree by construction there), while other points below that deformation differ by up to "
        f"+15 %. The second summary line keeps deform >= {FEM_MIN_DEFORM} and the pipe pages' confinements."))
    cells = compare([(math.pi * radius ** 2, modulus) for radius, modulus in PIPE_CELLS])
    for cell, (radius, _) in zip(cells, PIPE_CELLS, strict=True):
        cell["R [um]"] = radius
    formats = {"R [um]": "g", "area_um": ".1f", "E [kPa]": "g", "D ana-18": ".4f", "D FEM-19": ".4f",
               "D FEM-19 / D ana-18 - 1 %": "+.1f", "E FEM-19 / E at ana-18's D": ".3f"}
    page.table(cells, "The pipe pages' cells at their undeformed area pi R^2",
               columns=["R [um]", *[c for c in cells[0] if c != "R [um]"]], formats=formats)
    grid = compare([(area, modulus) for area in args.areas for modulus in args.moduli])
    both = [row for row in grid if np.isfinite(row["D ana-18"]) and np.isfinite(row["D FEM-19"])]
    page.table(both, f"The grid where both are defined ({len(both)} of {len(grid)} points)", formats=formats)
    for label, rows in (("every point where both are defined", both),
                        (f"deform >= {FEM_MIN_DEFORM} and area <= {FEM_MAX_AREA:.1f} um^2 (the pipe pages' "
                         "confinements)",
                         [row for row in both if row["D FEM-19"] >= FEM_MIN_DEFORM and row["area_um"] <= FEM_MAX_AREA])):
        ratio_d = np.array([row["D FEM-19 / D ana-18 - 1 %"] for row in rows])
        ratio_e = np.array([row["E FEM-19 / E at ana-18's D"] for row in rows])
        page.print(f"{label}: {TABLE} over {ANALYTICAL} in deformation at the same (area, E) median "
                   f"{np.median(ratio_d):+.1f} %, range {ratio_d.min():+.1f} to {ratio_d.max():+.1f} % ({len(rows)} "
                   f"points); the modulus {TABLE} reads from the analytical (area, D) over E: median "
                   f"{np.nanmedian(ratio_e):.3f}, range {np.nanmin(ratio_e):.3f} to {np.nanmax(ratio_e):.3f}.")
    page.write()


if __name__ == "__main__":
    main()
