"""The default grid of ``elastocell lut``: where its points lie and which real RT-DC events its table covers.

    python validation/lut_grid.py

The default radii and moduli of a table (``elastocell.inverse.lut.default_grid``) come from dclab's table of the
channel shape (LE-2D-FEM-19 for the cylinder, HE-3D-FEM-22 for the square duct) scaled to the channel and flow rate.
Without running the grid (hours), each (R, E) point is placed where the reference table puts a cell of area pi R^2
and modulus E (``predicted_table``; points outside the reference are left out), and dclab's own conversion
(``get_emodulus``: scaled to each file's channel and flow rate, pixelation corrected, no extrapolation) says which
of dclab's test measurements (tests/data/rtdc, 79 events) fall inside that table and inside the reference
(LE-2D-FEM-19 for the cylinder grid, HE-3D-FEM-22 for the square duct's). The ratio E_grid/E_reference on the
events both cover is the interpolation error of the grid's spacing alone (the grid's points carry the reference's
own deformation). The section is in docs/validation/rtdc.md.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from page import Page

# importing it removes validation/ from the path (validation/compression.py would shadow the standard library's
# `compression` package that JAX tries first)
from rtdc_coverage import unpack

from elastocell.inverse.lut import grid_coverage, plan, predicted_table, read_events  # noqa: E402


def main() -> None:
    start = time.time()
    page = Page("rtdc", "lut_grid.py", intro=(
        "The default grid of `elastocell lut` for the 20 um channel at 0.04 uL/s (15 mPa s), derived from dclab's "
        "tables at run time, and the share of dclab's test measurements it covers, as a fraction of those "
        "LE-2D-FEM-19 covers. The grid is not run here: its points are placed where LE-2D-FEM-19 puts such a cell "
        "(area pi R^2), so the coverage is the grid's, not the simulation's; the simulated cells deform within "
        "-14..+8 % of LE-2D-FEM-19 ([pipe_dclab.md](pipe_dclab.md))."))
    rows, grids = [], {}
    for label, kwargs in (("cylinder, Newtonian 15 mPa s", {"viscosity": "15mPa*s"}),
                          ("square duct, 0.59% MC-PBS at 23 degC", {"channel_shape": "square",
                                                                    "medium": "0.59%MC-PBS"})):
        _, settings = plan(None, "0.04uL/s", kwargs.pop("viscosity", None), channel_width="20um", **kwargs)
        grid = settings["default_grid"]
        rows.append({"channel": label, "reference": grid["reference"],
                     "radii_um": ", ".join(f"{r:g}" for r in grid["radii_um"]),
                     "moduli_kPa": ", ".join(f"{e:g}" for e in grid["moduli_kpa"]),
                     "D at R_mid": ", ".join("-" if d is None else f"{d:.2g}" for d in grid["deformation_at_middle_radius"]),
                     "R_mid_um": grid["middle_radius_um"]})
        grids[grid["reference"]] = grid, settings["viscosity_mpa_s"]
    page.table(rows, "the default grids (D at R_mid: the reference table's deformation of the middle radius at "
                     "each modulus, equal steps in log D; -: beyond the table, the softest modulus one step of E further)")
    events = read_events(unpack(Path(tempfile.mkdtemp(prefix="lut-grid-"))))
    for (reference, shape), label in ((("LE-2D-FEM-19", "cylinder"), "cylinder"),
                                      (("HE-3D-FEM-22", "square"), "square duct, MC-PBS")):
        grid, viscosity = grids[reference]
        table = predicted_table(grid, shape, 20.0, 0.04, viscosity)
        coverage = grid_coverage(table, events, reference, viscosity)
        if shape == "cylinder":
            page.table(coverage["files"], f"events per file: inside {reference} (reference) and inside both it and "
                                          "the default grid's table (both)")
        q = np.percentile(coverage["ratios"], [0, 25, 50, 75, 100])
        page.print(f"the default grid ({label}, 20 um, 0.04 uL/s) covers {coverage['both']} of the "
                   f"{coverage['reference']} events {reference} covers ({100 * coverage['fraction']:.0f} %), of "
                   f"{coverage['events']} events in all; its {len(table)} points inside {reference} (of "
                   f"{len(grid['radii_um']) * len(grid['moduli_kpa'])}); E_grid / E_{reference} on those events "
                   f"(interpolation of the grid's spacing): min {q[0]:.3f}, q1 {q[1]:.3f}, median {q[2]:.3f}, "
                   f"q3 {q[3]:.3f}, max {q[4]:.3f}")
    page.print(f"wall time {time.time() - start:.0f} s")
    page.write()


if __name__ == "__main__":
    main()
