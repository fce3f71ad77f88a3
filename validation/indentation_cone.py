"""A rigid cone pressed into a bonded layer, a suspended cell and a cap (``elastocell indent --indenter cone``).

References: Sneddon's cone on a half-space, F = 2/pi E/(1 - nu^2) tan(alpha) depth^2 (closed form), and nanite's
``hertz_cone`` model evaluated on the same depths (peer); the mesh's own refinement (every meridian size x 0.7);
the rounded apex's effect (its radius doubled). On a half-space the cone's problem has no length: F/depth^2 is
the same at every depth, so that its large-deformation correction is a constant of the angle (it shrinks as
cot(alpha) -> 0, not with depth), while the dish under a layer of thickness h adds a correction that grows with
depth/h. Writes docs/validation/indentation_cone.md (``validation/page.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from page import Page

# jax's compilation cache tries ``from compression import zstd`` (Python 3.14's module): this directory's
# compression.py must not answer it
sys.path[:] = [entry for entry in sys.path if Path(entry or ".").resolve() != Path(__file__).resolve().parent]

from elastocell.parameters.cell import cell_parameters  # noqa: E402
from elastocell.scenarios.axisymmetric import AxisymmetricError, sneddon_cone_force  # noqa: E402
from elastocell.scenarios.indentation import cone_curve, cone_half_angle, cone_mesh, cone_tip_radius  # noqa: E402

NU = 0.48
CELL = cell_parameters(nucleus="none", poisson_ratio=NU)
FINE = cone_mesh("layer", 45.0, 0.05).scaled(0.7)  # the layer's default cone mesh, every size x 0.7


def layer(angle: float, depth_max: float, steps: int, mesh=None, tip_radius=None):
    """F/(E h^2) over depth/h of a cone on a layer of thickness h = 1."""
    result = cone_curve(CELL, "layer", "cone", angle, layer_thickness=1.0, depth_max=depth_max, steps=steps,
                        mesh=mesh, tip_radius=tip_radius)
    return result.load[1:], result.force[1:], result


def ratio(angle: float, depth, force):
    return force / sneddon_cone_force(depth, np.radians(angle), NU)


def main() -> None:
    page = Page("indentation_cone", "indentation_cone.py", intro=(
        "A rigid frictionless cone (half-angle alpha between axis and flank, apex rounded by a sphere of "
        "1e-4 s, s = depth_max max(tan(alpha), 1)) pressed into a neo-Hookean layer (nu = 0.48) bonded to a "
        "rigid dish, thickness h = 1, on the axisymmetric solver at its default cone mesh. Sneddon's cone on a "
        "half-space is the closed form; nanite's hertz_cone the peer; refinement: every meridian size x 0.7."))

    # 1. refinement and the Sneddon limit at 70 degrees, depth/h up to 0.05
    depth, force, result = layer(70.0, 0.05, 10)
    _, fine, fine_result = layer(70.0, 0.05, 10, mesh=FINE)
    import nanite.model.model_conical_indenter as nanite_cone

    peer = nanite_cone.hertz_conical(-depth, 1.0, 70.0, NU)
    rows = [{"depth/h": d, "F/(E h^2)": f, "F/Sneddon": f / s, "F/nanite hertz_cone": f / p,
             "sizes x 0.7 change %": 100 * (g / f - 1)}
            for d, f, s, p, g in zip(depth, force, sneddon_cone_force(depth, np.radians(70.0), NU), peer, fine)]
    page.table(rows, f"alpha = 70 deg, default mesh {result.n_nodes} nodes ({result.wall_time:.0f} s), x 0.7: "
                     f"{fine_result.n_nodes} nodes ({fine_result.wall_time:.0f} s)")
    deep = depth >= 0.01
    slope, intercept = np.polyfit(depth[deep], ratio(70.0, depth, force)[deep], 1)
    page.print(f"alpha = 70 deg: F/Sneddon = {intercept:.4f} + {slope:.3f} depth/h (least squares over depth/h "
               f"0.01-0.05): the half-space limit (depth/h -> 0) is {100 * (intercept - 1):+.2f} % from Sneddon; "
               f"largest refinement change {np.abs(fine / force - 1).max() * 100:.2f} % (from depth/h 0.01: "
               f"{np.abs(fine / force - 1)[deep].max() * 100:.2f} %)")

    # 2. the angle: the large-deformation correction of the half-space limit
    rows, sharp = [], None
    for angle in (20.0, 45.0, 70.0, 80.0):
        if angle == 70.0:
            d, f, r = depth, force, result
        else:
            d, f, r = layer(angle, 0.05, 10)
        if angle == 20.0:
            sharp = (d, f, r)
        q = ratio(angle, d, f)
        slope, intercept = np.polyfit(d[d >= 0.01], q[d >= 0.01], 1)
        rows.append({"alpha deg": angle, "cot(alpha)": 1 / np.tan(np.radians(angle)), "nodes": r.n_nodes,
                     "F/Sneddon at depth/h 0.01": float(np.interp(0.01, d, q)),
                     "at 0.02": float(np.interp(0.02, d, q)), "at 0.05": float(q[-1]),
                     "limit depth/h -> 0 (linear fit 0.01-0.05)": intercept, "slope per depth/h": slope,
                     "curve s": r.wall_time, "substeps": r.substeps})
    page.table(rows, "F over Sneddon's half-space cone against the angle (layer h = 1, depth to 0.05 h, 10 steps)")

    # the sharp cone's refinement
    d, f, r = sharp
    _, g, rf = layer(20.0, 0.05, 10, mesh=FINE)
    page.table([{"depth/h": a, "F/Sneddon": q, "sizes x 0.7 change %": 100 * (b / c - 1)}
                for a, q, b, c in zip(d, ratio(20.0, d, f), g, f)],
               f"alpha = 20 deg: default mesh {r.n_nodes} nodes, x 0.7: {rf.n_nodes} nodes ({rf.wall_time:.0f} s)")

    # 3. the rounded apex: its radius doubled
    rows = []
    for angle in (70.0, 45.0):
        d, f, _ = layer(angle, 0.05, 5) if angle != 70.0 else (depth[1::2], force[1::2], None)
        rho = cone_tip_radius(angle, 0.05)
        _, doubled, _ = layer(angle, 0.05, 5, tip_radius=2 * rho)
        for dd, a, b in zip(d, f, doubled):
            rows.append({"alpha deg": angle, "tip radius / h": rho, "depth/h": dd,
                         "F change with the radius doubled %": 100 * (b / a - 1)})
    page.table(rows, "The rounded apex: its effect on F is about the change when its radius is doubled")

    # 4. the other shapes: a suspended cell and a hemispherical cap under a 45 degree cone, and a pyramid
    rows = []
    for shape, indenter, angle in (("sphere", "cone", 45.0), ("cap", "cone", 45.0), ("layer", "pyramid", 35.0)):
        kwargs = {"layer_thickness": 1.0} if shape == "layer" else {}
        try:
            r, stop = cone_curve(CELL, shape, indenter, angle, depth_max=0.05 if shape == "layer" else 0.1, steps=5,
                                 **kwargs), ""
        except AxisymmetricError as error:  # a curve that stops is a row that says so
            r, stop = error.partial, str(error)
        equivalent = cone_half_angle(indenter, angle)
        q = r.force[1:] / sneddon_cone_force(r.load[1:], np.radians(equivalent), NU)
        rows.append({"shape": shape, "indenter": f"{indenter} {angle:g} deg (cone {equivalent:.2f})",
                     "nodes": r.n_nodes, "first depth": r.load[1], "F/Sneddon first": q[0],
                     "last depth": r.load[-1], "F/Sneddon last": q[-1], "curve s": r.wall_time,
                     "stop": stop or "reached"})
    page.table(rows, "Sphere (R = 1, on a frictionless dish) and hemispherical cap (base radius 1): depth in R; "
                     "the layer with the four-sided pyramid's equivalent cone: depth in h")
    page.print("the suspended sphere adds its dish contact in series and its curvature, the cap its curvature: "
               "F/Sneddon below 1 there is the geometry, not an error")

    # 5. the master surface `fit afm --geometry cone` uses: its held-out curve and a round trip through the fit
    surface_section(page)
    page.write()


def surface_section(page: Page) -> None:
    """The shipped cone-layer surface: its mesh error, the held-out angle against the interpolation, and curves
    made from the held-out curve (E = 2 kPa, h = 5 um, 0.5 % noise, a 1 um baseline) refitted by ``fit_curve``."""
    from scipy.interpolate import PchipInterpolator

    from elastocell.inverse.fit import FitSettings, fit_curve
    from elastocell.inverse.indentation_surface import load_indentation_surface

    surface = load_indentation_surface(NU, "neo-hookean", "cone-layer")
    past = surface.depth_fraction() >= 0.1
    mesh_error = float(np.nanmax(np.where(past, surface.error / surface.force.clip(1e-300), np.nan)))
    ((tangent, (depth, force)),) = surface.held_out_curves().items()
    angle = float(np.degrees(np.arctan(tangent)))
    inside = (depth >= 0.1 * depth[-1])
    interpolated = surface.curve(tangent)(depth[inside])
    page.print(f"the shipped surface (half-angles {', '.join(f'{np.degrees(np.arctan(r)):.4g}' for r in surface.ratios)} "
               f"deg, depth to h/4): largest mesh error past a tenth of the depth {100 * mesh_error:.2f} % (sizes x 0.7 "
               f"at {', '.join(f'{np.degrees(np.arctan(r)):.4g}' for r in np.unique(surface.indenter_ratio[np.isfinite(surface.error)]))} "
               f"deg); the held-out {angle:.4g} deg curve against the surface interpolated there: "
               f"largest |difference| {100 * np.abs(interpolated / force[inside] - 1).max():.2f} % past a tenth of "
               "the depth")
    ratio_curve = PchipInterpolator(depth[1:], force[1:] / sneddon_cone_force(depth[1:], np.radians(angle), NU))
    points = np.linspace(depth[1], depth[-1], 300)
    thickness, modulus = 5e-6, 2e3
    rows = []
    for seed in range(5):
        rng = np.random.default_rng(seed)
        x = np.r_[np.linspace(-1e-6, 0, 100, endpoint=False), points * thickness]
        f = np.r_[np.zeros(100), modulus * thickness**2 * sneddon_cone_force(points, np.radians(angle), NU)
                  * ratio_curve(points)]
        f = f + 0.005 * f.max() * rng.standard_normal(len(f))
        row = fit_curve(f"seed {seed}", x, f, FitSettings(geometry="cone", cell_shape="layer", layer_thickness="5um",
                                                         half_angle=f"{angle}deg"))
        rows.append({"noise seed": seed, "E / E_true - 1 %": 100 * (row["youngs_modulus"] / modulus - 1),
                     "95 % interval / E_true": f"{row['youngs_modulus_ci_low'] / modulus:.4f} to "
                                                f"{row['youngs_modulus_ci_high'] / modulus:.4f}",
                     "Sneddon half-space E / E_true": row["youngs_modulus_hertz"] / modulus,
                     "contact point error (nm)": 1e9 * row["contact_point"], "flag": row["flag"] or "accepted"})
    page.table(rows, f"Round trip: the held-out {angle:.4g} deg curve on a {thickness * 1e6:g} um layer, E = "
                     f"{modulus:g} Pa, 0.5 % noise, a 1 um baseline, fitted by `fit afm --geometry cone` (contact "
                     "point free)")


if __name__ == "__main__":
    main()
