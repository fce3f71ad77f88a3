"""A bead (rigid sphere, radius R_b) indenting a cell on a dish, on the axisymmetric solver: the small-depth
limits against closed forms and the force's change under mesh refinement (the bonded layer's width, refinement
and master surface: ``validation/indentation_layer.py``).

    nice python validation/indentation.py [--quick]

1. Hertz limits (homogeneous, nu = 0.48): the suspended sphere against the two Hertz contacts in series (bead on
   cell, cell on dish); a hemispherical cap (bonded) under a small bead against Hertz with the two curvatures
   (R_eff = R_b R/(R_b + R)) and the plain half-space; a thick bonded layer against the half-space and against
   Dimitriadis et al. (2002)'s bonded-layer correction.
2. Refinement: F(depth) on the default mesh against the mesh with every size times 0.7, per shape, at depth
   0.1, 0.2 and 0.3 (units of R; the layer's of R_b), 3 load steps, and the wall time of each curve (measured
   with other work running on the machine).

Writes docs/validation/indentation.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from page import Page

# jax's compilation cache tries ``from compression import zstd`` (Python 3.14's module): this directory's
# compression.py must not answer it
sys.path[:] = [entry for entry in sys.path if Path(entry or ".").resolve() != Path(__file__).resolve().parent]

from elastocell.body.axisymmetric import MeridianMeshParameters  # noqa: E402
from elastocell.inverse.indentation_surface import dimitriadis_bonded_force as dimitriadis_bonded  # noqa: E402
from elastocell.parameters.cell import cell_parameters  # noqa: E402
from elastocell.scenarios.axisymmetric import (  # noqa: E402
    AxisymmetricError,
    hertz_half_space_force,
    hertz_sphere_indentation_force,
    indent_axisymmetric,
)
from elastocell.scenarios.indentation import indentation_curve  # noqa: E402

NU = 0.48
HERTZ_MESH = MeridianMeshParameters(mesh_size=0.1, surface_size=0.02, pole_size=0.0025, pole_radius=0.3)
REFINEMENT_DEPTHS = np.array([0.1, 0.2, 0.3])
STEPS = 3


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    try:
        return function(*args, **kwargs), time.perf_counter() - start, ""
    except AxisymmetricError as error:
        return error.partial, time.perf_counter() - start, str(error)


def hertz_limits(page: Page, quick: bool) -> None:
    homogeneous = cell_parameters(nucleus="none")
    rows = []
    result, seconds, error = timed(indent_axisymmetric, homogeneous, 0.5, depth_max=0.02, steps=2, mesh=HERTZ_MESH)
    for d, f in zip(result.load[1:], result.force[1:], strict=True):
        rows.append({"shape": "sphere on dish", "R_b": 0.5, "depth": d, "F/(E R^2)": f,
                     "ratio to reference": f / hertz_sphere_indentation_force(d, 0.5, NU),
                     "reference": "Hertz, bead and dish in series"})
    bead = 0.05
    result, seconds, error = timed(indentation_curve, homogeneous, "cap", bead, cap_height=1.0, depth_max=0.004,
                                   steps=2, mesh=HERTZ_MESH)
    effective = bead / (1 + bead)
    for d, f in zip(result.load[1:], result.force[1:], strict=True):
        rows.append({"shape": "hemispherical cap", "R_b": bead, "depth": d, "F/(E R^2)": f,
                     "ratio to reference": f / hertz_half_space_force(d, effective, NU),
                     "reference": "Hertz, R_eff = R_b R/(R_b + R)"})
        rows.append({"shape": "hemispherical cap", "R_b": bead, "depth": d, "F/(E R^2)": f,
                     "ratio to reference": f / hertz_half_space_force(d, bead, NU), "reference": "Hertz, half-space"})
    thickness = 5.0 if quick else 10.0
    result, seconds, error = timed(indentation_curve, homogeneous, "layer", 1.0, layer_thickness=thickness,
                                   depth_max=0.04, steps=2)
    if error:
        page.print(f"layer h = {thickness:g} R_b: {error}")
    for d, f in zip(result.load[1:], result.force[1:], strict=True):
        rows.append({"shape": f"layer h = {thickness:g} R_b", "R_b": 1.0, "depth": d, "F/(E R^2)": f,
                     "ratio to reference": f / hertz_half_space_force(d, 1.0, NU), "reference": "Hertz, half-space"})
        rows.append({"shape": f"layer h = {thickness:g} R_b", "R_b": 1.0, "depth": d, "F/(E R^2)": f,
                     "ratio to reference": f / dimitriadis_bonded(d, 1.0, thickness),
                     "reference": "Dimitriadis, bonded layer"})
    page.table(rows, "Small depth against closed forms (homogeneous, nu = 0.48; lengths in R, the layer's in R_b)")


SHAPES = {  # name -> (cell, indentation_curve options)
    "cap H = 0.6 R (nucleus gamma 2, radius 0.2 R)": (dict(size_ratio=0.2),
                                                   dict(cell_shape="cap", indenter_radius=0.5, cap_height=0.6)),
    "layer h = 5 R_b": (dict(nucleus="none"), dict(cell_shape="layer", indenter_radius=1.0, layer_thickness=5.0)),
}


def refinement(page: Page, quick: bool) -> None:
    rows = []
    for name, (cell_options, options) in SHAPES.items():
        cell = cell_parameters(**cell_options)
        default, seconds, error = timed(indentation_curve, cell, depth_max=0.3, steps=STEPS, **options)
        fine, fine_seconds, fine_error = timed(indentation_curve, cell, depth_max=0.3, steps=STEPS,
                                               mesh=MeridianMeshParameters().scaled(0.7), **options)
        row = {"shape": name, "nodes": default.n_nodes if default is not None else 0,
               "Newton iterations": default.newton_iterations if default is not None else 0,
               f"seconds (default, {STEPS} steps)": seconds, f"seconds (fine, {STEPS} steps)": fine_seconds}
        for depth in REFINEMENT_DEPTHS:
            reached = default is not None and fine is not None and min(default.load[-1], fine.load[-1]) >= depth - 1e-9
            f_default = np.interp(depth, default.load, default.force) if reached else np.nan
            f_fine = np.interp(depth, fine.load, fine.force) if reached else np.nan
            row[f"F({depth:g}) default"] = f_default
            row[f"error at {depth:g}"] = f_default / f_fine - 1
        row["note"] = "; ".join(e for e in (error, fine_error) if e) or ""
        rows.append(row)
        print(row, flush=True)
    page.table(rows, "F(depth) on the default mesh against every size x 0.7 (error = F_default/F_fine - 1); "
                     "wall time of each curve on this loaded machine")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller problems (a smoke run, not the page)")
    parser.add_argument("--only", nargs="*", default=["hertz", "refinement"])
    args = parser.parse_args()
    page = Page("indentation", "indentation.py", intro=(
        "A rigid frictionless sphere (bead, radius R_b) pressed into a cell on a rigid dish by the axisymmetric "
        "solver (exact node-to-sphere contact, 6-node triangles in the meridian plane): a suspended sphere of "
        "radius R on a frictionless dish, a spherical cap of base radius R bonded to the dish, a layer of "
        "thickness h bonded to the dish (lengths in units of R_b). Depth: the bead's displacement after first "
        "contact. Forces F/(E_c R^2) (the layer: F/(E R_b^2))."))
    for name, section in (("hertz", hertz_limits), ("refinement", refinement)):
        if name in args.only:
            section(page, args.quick)
            page.write()  # what is measured so far is on the page


if __name__ == "__main__":
    main()
