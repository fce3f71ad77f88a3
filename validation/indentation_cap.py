"""A bead (rigid sphere, radius R_b) indenting an adherent cell, a homogeneous spherical cap of base radius R and
apex height H bonded to a rigid dish, on the axisymmetric solver: the error of the shipped cap master surface's
mesh, its small-depth limit against Hertz, its interpolation against held-out curves, and the fit's round trip.

    nice python validation/indentation_cap.py [--cached-only]

1. Refinement: the surface's default meridian mesh against every size x 0.7 (the surface's mesh-check curves) and,
   on the thinnest cap under the smallest bead, x 0.5.
2. Hertz: the tall caps (H = R, 0.75 R) under small beads against Hertz's sphere on a half-space (R_b) and Hertz's
   two curvatures (R_eff = R_b R_c/(R_b + R_c), R_c = (1 + H^2)/(2H) the apex's radius: the surface's reference).
3. Interpolation: the surface (interpolated in R_b/R, and in H) against the held-out curves stored in its file.
4. Round trip: curves computed by the indentation scenario (:func:`elastocell.scenarios.indentation.
   indentation_curve`, what ``elastocell indent --cell-shape cap`` runs) at (H/R, R_b/R) on no tabulated node, 0.5 %
   noise of the largest force, a flat baseline of 3 um before contact, 500 points, fitted by
   ``fit afm --geometry sphere-indenter --cell-shape cap``'s settings (R = 10 um, E = 1 kPa).

Every curve goes through the surface's curve cache (``cap_curve``): a rerun reads them (``--cached-only`` lists one
not in the cache as not run). Writes its section of docs/validation/indentation.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from page import Page

# jax's compilation cache tries ``from compression import zstd`` (Python 3.14's module): this directory's
# compression.py must not answer it
sys.path[:] = [entry for entry in sys.path if Path(entry or ".").resolve() != Path(__file__).resolve().parent]

from elastocell.body.axisymmetric import MeridianMeshParameters  # noqa: E402
from elastocell.inverse.fit import FitSettings, fit_curve  # noqa: E402
from elastocell.inverse.indentation_surface import (  # noqa: E402
    CAP_HEIGHTS,
    INDENTER_RATIOS,
    cap_curve,
    curve_function,
    depth_limit,
    load_indentation_surface,
    read_cached,
    shipped,
    small_depth_limit,
)
from elastocell.scenarios.axisymmetric import AxisymmetricError, hertz_half_space_force  # noqa: E402

NU = 0.48
REFINED = {(0.3, 0.125): (1.0, 0.7, 0.5), (0.3, 4.0): (1.0, 0.7), (1.0, 0.125): (1.0, 0.7)}
"""(H/R, R_b/R) of the refinement study and its mesh scales: the surface's mesh-check curves (x 0.7), and x 0.5 on
the thinnest cap under the smallest bead (the cost of the curves on a shared 2-core machine bounds the study)."""
ROUND_TRIP = ((0.55, 0.6), (0.35, 2.5), (0.85, 0.2))
"""(H/R, R_b/R) of the round trip: on no tabulated height or bead radius (held-out curves of the surface)."""
R, E_TRUE, CONTACT = 10e-6, 1000.0, 3e-6


def curve(height: float, ratio: float, scale: float = 1.0, cached_only: bool = False) -> dict | None:
    """A cap's curve on the default mesh with every size x ``scale`` (through the surface's curve cache); None
    when ``cached_only`` and it is not cached, or when it stopped early (the error printed)."""
    mesh = MeridianMeshParameters().scaled(scale)
    try:
        computed = cap_curve(height, ratio, mesh, NU, cached_only=cached_only)
    except AxisymmetricError as error:
        print(f"H/R = {height:g}, R_b/R = {ratio:g}, x {scale:g}: {error}", flush=True)
        return None
    if computed is None:
        return None
    depth, force, info = computed
    return {"depth": np.asarray(depth), "force": np.asarray(force), "nodes": info.get("n_nodes", 0),
            "seconds": info.get("wall_time_s", np.nan)}


def _force_at(record: dict | None, depth: float) -> float:
    if record is None or record["depth"][-1] < depth - 1e-9:
        return np.nan
    return float(np.interp(depth, record["depth"], record["force"]))


def refinement(page: Page, cached_only: bool) -> None:
    rows = []
    for (height, ratio), scales in REFINED.items():
        curves = {scale: curve(height, ratio, scale, cached_only) for scale in scales}
        end = float(depth_limit(ratio, "cap", height))
        finest = scales[-1]
        for fraction in (0.1, 0.2, 0.5, 1.0):
            depth = fraction * end
            reference = _force_at(curves[finest], depth)
            rows.append({"H / R": height, "R_b / R": ratio, "depth / R": depth,
                         "F/(E R^2) default": _force_at(curves[1.0], depth), "reference mesh": f"x {finest:g}",
                         "error default": _force_at(curves[1.0], depth) / reference - 1,
                         "error x 0.7": (_force_at(curves[0.7], depth) / reference - 1) if finest < 0.7 else np.nan,
                         "nodes": "/".join(str(c["nodes"]) if c else "not run" for c in curves.values()),
                         "seconds": "/".join(f"{c['seconds']:.0f}" if c else "-" for c in curves.values())})
    page.table(rows, "Meridian refinement of the cap (10 load steps to the surface's depth range ((H/2)^-2 + "
                     "R_b^-2)^(-1/2)): error = F/F(reference mesh) - 1, the reference every size x 0.5 on the thinnest "
                     "cap under the smallest bead, x 0.7 elsewhere (the surface's mesh-check curves); nodes and wall "
                     "time per mesh (1, 0.7, 0.5), the time on this loaded machine")


def hertz(page: Page, caps) -> None:
    rows = []
    for height in (1.0, 0.75):
        surface = caps.surfaces[height]
        for ratio in (0.125, 0.25, 0.5):
            end = surface.depth_max(ratio)
            for fraction in (0.05, 0.1, 0.2, 0.5):
                depth = fraction * end
                force = float(surface(depth, ratio))
                rows.append({"H / R": height, "R_b / R": ratio, "depth / R_b": depth / ratio,
                             "F / Hertz half-space (R_b)": force / hertz_half_space_force(depth, ratio, NU),
                             "F / Hertz apex (R_eff)": force / small_depth_limit(depth, ratio, NU, "cap", height),
                             "sqrt(R_eff / R_b)": float(np.sqrt(small_depth_limit(depth, ratio, NU, "cap", height)
                                                                / hertz_half_space_force(depth, ratio, NU)))})
    page.table(rows, "The tall caps' surface (default mesh) under small beads against Hertz: on a half-space with "
                     "the bead's radius, and with the apex's curvature too (R_eff; the two differ by the last "
                     "column's factor, which tends to 1 as R_b/R -> 0)")
    for height in (1.0, 0.75):
        worst = {ratio: max(abs(row["F / Hertz apex (R_eff)"] - 1) for row in rows if row["H / R"] == height
                            and row["R_b / R"] == ratio and row["depth / R_b"] <= 0.1 + 1e-9)
                 for ratio in (0.125, 0.25, 0.5)}
        page.print(f"H/R = {height:g}, depth <= 0.1 R_b: |F / Hertz(R_eff) - 1| at most "
                   + ", ".join(f"{100 * value:.2f} % (R_b/R {ratio:g})" for ratio, value in worst.items()))


def interpolation(page: Page, caps) -> None:
    rows = []
    for (height, ratio), (depth, force) in caps.held_out_curves().items():
        surface = caps.at_height(height)
        past = depth >= 0.1 * depth[-1]
        relative = surface(depth[past], ratio) / force[past] - 1
        worst = int(np.argmax(np.abs(relative)))
        mesh = surface.relative_error_at(depth[past], ratio)
        held = [name for name, tabulated in (("H", height in CAP_HEIGHTS), ("R_b", ratio in INDENTER_RATIOS))
                if not tabulated]
        rows.append({"H / R": height, "R_b / R": ratio, "untabulated": " and ".join(held),
                     "largest |surface / computed - 1|": float(np.abs(relative[worst])),
                     "at depth / range": float(depth[past][worst] / depth[-1]),
                     "mesh error there (interpolated)": float(mesh[worst])})
    page.table(rows, "The surface's interpolation against the held-out curves (computed on the same mesh, stored "
                     "in the surface file, used by no interpolation), past a tenth of each curve's depth range")


def round_trip(page: Page, cached_only: bool) -> None:
    rows = []
    for height, ratio in ROUND_TRIP:
        record = curve(height, ratio, 1.0, cached_only)
        if record is None:
            rows.append({"H / R": height, "R_b / R": ratio, "E / E_true - 1": np.nan, "note": "not run"})
            continue
        end = float(record["depth"][-1])
        s = curve_function(record["depth"], record["force"], ratio, NU, "cap", height)
        for seed in (0, 1, 2):
            displacement = np.linspace(0.0, CONTACT + end * R, 500)
            clean = E_TRUE * R**2 * s(np.maximum(displacement - CONTACT, 0.0) / R)
            force = clean + 0.005 * clean.max() * np.random.default_rng(seed).standard_normal(len(clean))
            settings = FitSettings(radius=R, geometry="sphere-indenter", cell_shape="cap", cap_height=height * R,
                                   indenter_radius=ratio * R)
            surface = load_indentation_surface(NU, cell_shape="cap", cap_height=height)
            row = fit_curve("synthetic", displacement, force, settings, surface)
            rows.append({"H / R": height, "R_b / R": ratio, "seed": seed,
                         "E / E_true - 1": row["youngs_modulus"] / E_TRUE - 1,
                         "95 % interval / E_true - 1": f"[{row['youngs_modulus_ci_low'] / E_TRUE - 1:.4f}, "
                                                       f"{row['youngs_modulus_ci_high'] / E_TRUE - 1:.4f}]",
                         "contact error / depth range": (row["contact_point"] - CONTACT) / (end * R),
                         "Hertz (R_b, half-space) / E_true": row["youngs_modulus_hertz"] / E_TRUE,
                         "flag": row["flag"] or "accepted"})
    page.table(rows, "Round trip: a cap computed by the indentation scenario (default mesh, to the surface's depth "
                     "range) at an untabulated (H/R, R_b/R), 0.5 % noise, 3 um baseline, fitted on the surface "
                     "interpolated there (R = 10 um, E_true = 1 kPa)")
    errors = [abs(row["E / E_true - 1"]) for row in rows if np.isfinite(row["E / E_true - 1"])]
    if errors:
        page.print(f"round trip: |E / E_true - 1| at most {100 * max(errors):.2f} % over {len(errors)} fits")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cached-only", action="store_true", help="list a curve not in the cache as not run")
    args = parser.parse_args()
    page = Page("indentation", "indentation_cap.py", intro=(
        "A rigid frictionless sphere (bead, radius R_b) pressed on the axis into a homogeneous neo-Hookean "
        "spherical cap (nu = 0.48) of base radius R and apex height H bonded to a rigid dish, by the axisymmetric "
        "solver (exact node-to-sphere contact). Lengths in R, forces F/(E R^2); depth: the bead's displacement "
        "after first contact. The shipped surface: `elastocell mastercurve indentation --cell-shape cap`."))
    refinement(page, args.cached_only)
    caps = shipped(NU, cell_shape="cap") or read_cached(NU, cell_shape="cap")
    if caps is None:
        page.print("no cap master surface (shipped or cached): elastocell mastercurve indentation --cell-shape cap")
        page.write()
        return
    hertz(page, caps)
    interpolation(page, caps)
    round_trip(page, args.cached_only)
    page.write()


if __name__ == "__main__":
    main()
