"""A bead (rigid sphere, radius R_b) indenting a homogeneous layer bonded to a rigid dish (a tissue section, a gel,
a flat cell), on the axisymmetric solver: how wide the layer must be, how fine its meridian mesh, and the shipped
layer master surface against the closed forms of a bonded layer.

    nice python validation/indentation_layer.py [--quick] [--fresh] [--cached-only]

1. Lateral extent: F at the master surface's depth range (min(h/2, R_b/2)) with the default width 2 h + 4 R_b,
   2 h + 8 and 2 h + 16 R_b, at h = 2.5 and 5 R_b (R_b/h = 0.4 and 0.2).
2. Refinement: the default meridian mesh against every size x 0.7 and x 0.5 at h = 2.5 R_b.
3. The shipped layer master surface (``elastocell mastercurve indentation --cell-shape layer``) against Hertz's
   half-space, Dimitriadis et al. (2002, Biophys. J. 82, 2798)'s bonded-layer series (its nu-dependent
   coefficients, nu = 0.48) and Garcia & Garcia (2018, Biophys. J. 114, 2923)'s bottom-effect correction.

The curves of 1 and 2 are kept in the cache directory (``validation-indentation/``): a rerun reads them
(``--fresh`` recomputes; ``--cached-only`` lists one not in the cache as not run). Writes its section of
docs/validation/indentation.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from indentation import timed  # a curve, its wall time and why it stopped early
from page import Page

# jax's compilation cache tries ``from compression import zstd`` (Python 3.14's module): this directory's
# compression.py must not answer it
sys.path[:] = [entry for entry in sys.path if Path(entry or ".").resolve() != Path(__file__).resolve().parent]

from elastocell.body.axisymmetric import MeridianGeometry, MeridianMeshParameters, layer_width  # noqa: E402
from elastocell.files import cache_directory, parameter_hash, write_json  # noqa: E402
from elastocell.inverse.indentation_surface import (  # noqa: E402
    depth_limit,
    load_indentation_surface,
)
from elastocell.inverse.indentation_surface import dimitriadis_bonded_force as dimitriadis_bonded  # noqa: E402
from elastocell.inverse.indentation_surface import garcia_bonded_force as garcia_bonded  # noqa: E402
from elastocell.parameters.cell import cell_parameters  # noqa: E402
from elastocell.parameters.units import ParameterError  # noqa: E402
from elastocell.scenarios.axisymmetric import (  # noqa: E402
    hertz_half_space_force,
    indent_axisymmetric,
    sneddon_sphere_force,
)

NU = 0.48


LAYER_CACHE_FORMAT = 1
LAYER_STEPS = 10
WIDTH_THICKNESSES = (2.5, 5.0)
"""h/R_b of the width study (R_b/h = 0.4 and 0.2)."""
REFINED_THICKNESS = 2.5


def layer_curve(thickness: float, width: float | None = None, scale: float = 1.0, fresh: bool = False,
                cached_only: bool = False) -> dict | None:
    """The force curve of a homogeneous layer of ``thickness`` (units of R_b, bonded base) ``width`` wide (None:
    the default), R_b = 1, to the depth range of the layer's master surface in LAYER_STEPS steps (its stepping), on
    the default meridian mesh with every size times ``scale``; kept in the cache directory (``fresh``: recomputed;
    ``cached_only``: None when not cached)."""
    cell = cell_parameters(nucleus="none")
    mesh = MeridianMeshParameters().scaled(scale)
    width = layer_width(thickness) if width is None else width
    depth = float(depth_limit(1 / thickness, "layer")) * thickness
    key = parameter_hash(cell, mesh, {"thickness": thickness, "width": width, "depth": depth,
                                      "steps": LAYER_STEPS}, format_version=LAYER_CACHE_FORMAT)[:20]
    path = cache_directory() / "validation-indentation" / f"layer-{key}.json"
    if path.exists() and not fresh:
        return json.loads(path.read_text())
    if cached_only:
        return None
    geometry = MeridianGeometry(shape="layer", height=thickness, width=width)
    result, seconds, error = timed(indent_axisymmetric, cell, 1.0, depth_max=depth, steps=LAYER_STEPS, mesh=mesh,
                                   geometry=geometry)
    record = {"thickness": thickness, "width": width, "scale": scale, "depth": result.load.tolist(),
              "force": result.force.tolist(), "nodes": int(result.n_nodes), "seconds": seconds, "error": error}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    print(record["thickness"], record["width"], record["scale"], record["depth"][-1], record["force"][-1],
          f"{seconds:.0f} s", error, flush=True)
    return record


def _force_at(record: dict | None, depth: float) -> float:
    if record is None or record["depth"][-1] < depth - 1e-9:
        return np.nan
    return float(np.interp(depth, record["depth"], record["force"]))


NOT_RUN = {"depth": [0.0], "force": [0.0], "nodes": 0, "seconds": np.nan, "error": "not run (not in the cache)"}


def layer_study(page: Page, quick: bool, fresh: bool = False, cached_only: bool = False) -> None:
    thicknesses = WIDTH_THICKNESSES[:1] if quick else WIDTH_THICKNESSES

    def curve(*args, **kwargs):
        return layer_curve(*args, fresh=fresh, cached_only=cached_only, **kwargs) or NOT_RUN

    rows = []
    for h in thicknesses:
        curves = {extra: curve(h, 2 * h + extra) for extra in (4, 8, 16)}
        end = float(depth_limit(1 / h, "layer")) * h
        for fraction in (0.5, 1.0):
            widest = _force_at(curves[16], fraction * end)
            for extra, record in curves.items():
                force = _force_at(record, fraction * end)
                rows.append({"h / R_b": h, "width / R_b": f"2h + {extra} = {2 * h + extra:g}", "depth": fraction * end,
                             "F/(E R_b^2)": force, "change against 2h + 16": force / widest - 1,
                             "nodes": record["nodes"], "seconds": record["seconds"], "note": record["error"]})
    page.table(rows, "The layer's lateral extent (bonded base, free outer side, R_b = 1, the master surface's depth "
                     f"range min(h/2, R_b/2), {LAYER_STEPS} steps; wall time on this loaded machine)")
    h = REFINED_THICKNESS
    curves = {scale: curve(h, scale=scale) for scale in (1.0, 0.7, 0.5)}
    end = float(depth_limit(1 / h, "layer")) * h
    rows = []
    for fraction in (0.2, 0.5, 1.0):
        depth = fraction * end
        finest = _force_at(curves[0.5], depth)
        rows.append({"h / R_b": h, "depth": depth, "F default": _force_at(curves[1.0], depth),
                     "error default": _force_at(curves[1.0], depth) / finest - 1,
                     "error x 0.7": _force_at(curves[0.7], depth) / finest - 1,
                     "nodes (1, 0.7, 0.5)": "/".join(str(c["nodes"]) for c in curves.values()),
                     "seconds (1, 0.7, 0.5)": "/".join(f"{c['seconds']:.0f}" for c in curves.values())})
    page.table(rows, "Meridian refinement of the layer (default width): error = F/F(every size x 0.5) - 1")
    try:
        surface = load_indentation_surface(NU, cell_shape="layer")
    except ParameterError as error:
        page.print(f"no layer master surface: {error}")
        return
    thickest = surface.ratio_range[0]
    thick_curve = surface.curve(thickest)
    rows = []
    for ratio in np.unique(surface.indenter_ratio):
        rows_of = surface.indenter_ratio == ratio
        depth, force, error = surface.depth[rows_of], surface.force[rows_of], surface.error[rows_of]
        for index in sorted({1, len(depth) // 2, len(depth) - 1}):
            d, f = depth[index] / ratio, force[index] / ratio**2  # units of R_b
            thickness = 1 / ratio
            rows.append({"R_b / h": ratio, "held out": bool(surface.held_out[rows_of][0]), "depth / R_b": d,
                         "chi": np.sqrt(d) / thickness, "F/(E R_b^2)": f,
                         "mesh error (x 0.7)": error[index] / force[index],
                         "/ Hertz": f / hertz_half_space_force(d, 1.0, NU),
                         "/ Sneddon sphere": f / float(sneddon_sphere_force(d, 1.0, NU)),
                         "/ Dimitriadis": f / dimitriadis_bonded(d, 1.0, thickness),
                         "/ Garcia": f / garcia_bonded(d, 1.0, thickness),
                         "bottom effect / Dimitriadis'": (f / (thick_curve(d * thickest) / thickest**2))
                         / (dimitriadis_bonded(d, 1.0, thickness) / dimitriadis_bonded(d, 1.0, 1 / thickest))})
    page.table(rows, "The shipped layer master surface (default width and mesh, nu = 0.48) against Hertz's "
                     "half-space, Sneddon's exact sphere on a half-space (linear), Dimitriadis et al. (2002, bonded, nu-dependent coefficients) and Garcia & Garcia "
                     "(2018, bonded, derived for nu = 0.5); chi = sqrt(R_b d)/h; both series are small-chi "
                     "expansions of a paraboloid at small strain; mesh error: |F(every size x 0.7) - F|/F where "
                     f"computed; bottom effect: F over the thickest layer's F at the same depth (R_b/h = {thickest:g}), "
                     "over the same ratio of Dimitriadis' series (the sphere's shape and the large strain cancel)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="h = 2.5 R_b only (a smoke run, not the page)")
    parser.add_argument("--fresh", action="store_true", help="recompute the cached curves")
    parser.add_argument("--cached-only", action="store_true", help="list a curve not in the cache as not run")
    args = parser.parse_args()
    page = Page("indentation", "indentation_layer.py", intro=(
        "A rigid frictionless sphere (bead, radius R_b = 1) pressed into a homogeneous neo-Hookean layer (nu = 0.48) "
        "of thickness h bonded to a rigid dish, free on its outer side, by the axisymmetric solver (exact "
        "node-to-sphere contact). Lengths in R_b, forces F/(E R_b^2); depth: the bead's displacement after first "
        "contact."))
    layer_study(page, args.quick, args.fresh, args.cached_only)
    page.write()


if __name__ == "__main__":
    main()
