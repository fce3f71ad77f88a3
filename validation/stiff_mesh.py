"""The mesh a compression gives a stiff nucleus, and ``elastocell compress``'s defaults against the axisymmetric
truth for every stiffness ratio.

    nice python validation/stiff_mesh.py [--only screen defaults sizes] [--cached-only]

- screen: the nucleus surface's size and width, the bulk size and the polar layer, one mesh at a time, for
  stiffness ratios 20 and 10 (size ratio 0.5), 14 load steps to delta 0.7 in this process; the first row of each
  ratio is the mesh a compression used before ``compression.STIFF_NUCLEUS_MESHES`` (nucleus surface 0.15 over
  0.25 R, bulk 0.35).
- defaults: ``elastocell compress`` on its defaults (40 steps to delta 0.75) for stiffness ratios 1, 2, 5, 5.4,
  5.5, 7, 10, 15 and 20 (``--ratios``; 5.4 and 5.5 either side of the refined meshes' threshold, 15 inside the
  finer band), each in a new process: the wall time of the process and of the curve, and the error at delta
  0.1-0.7; a truth not in the cache is computed (about two minutes). Then the threshold: the earlier mesh (the
  default p2 sizes and the 4-point rule) at stiffness ratios 5, 5.4 and 6.9, where its error crosses 3 %.
- sizes: the same for the size ratios 0.1, 0.3, 0.7 and 0.9 (``--sizes``) at stiffness ratio 2 (the truth on the meridian mesh of scale
  0.7, within 0.13 % of scale 0.5 for size ratio 0.5).

The truth is validation/axisymmetric.py's: ``compress_axisymmetric`` on the meridian mesh of scale 0.5 (within
0.13 % of its Richardson limit at delta 0.1-0.7), from that script's cache. Every curve is cached (the cache
directory, ``validation-stiff-3d/``, shared with validation/stiff_3d.py); ``--cached-only`` lists a curve not in
the cache as not run, so that two invocations (``--only screen`` and ``--only defaults``) can compute in parallel
and a third writes the page.
"""

from __future__ import annotations

import argparse
import json
import time

from axisymmetric import ERRORS, axisymmetric_curve, cell_options
from page import Page
from stiff_3d import (
    BASE,
    DELTA_MAX,
    STEPS,
    TRUTH_SCALE,
    VARIED_TRUTH_SCALE,
    _path,
    default_curve,
    errors,
    screened_curve,
    truth,
)

from elastocell.body.cell import Cell
from elastocell.files import write_json
from elastocell.parameters.cell import cell_parameters
from elastocell.scenarios.compression import (
    NODAL_RULE_FROM_STIFFNESS_RATIO,
    CompressionError,
    CompressionInterrupted,
    CompressionParameters,
    compress,
)

SCREEN = [  # (label, mesh of the compression with a stiff nucleus, ratios)
    ("before: surface 0.15 over 0.25, bulk 0.35", BASE, [20, 10]),
    ("surface 0.075 over 0.4 (the default to stiffness ratio 10)",
     {"interface_size": 0.075, "interface_width": 0.4, "mesh_size": 0.35}, [20, 10]),
    ("surface 0.075 over 0.4, bulk 0.25", {"interface_size": 0.075, "interface_width": 0.4, "mesh_size": 0.25}, [20]),
    ("surface 0.075 over 0.4, bulk 0.25, polar layer 0.1 within 40 deg",
     {"interface_size": 0.075, "interface_width": 0.4, "mesh_size": 0.25, "layer_size": 0.1, "layer_angle": 40}, [20]),
    ("surface 0.06 over 0.4, bulk 0.25 (the default above 10)",
     {"interface_size": 0.06, "interface_width": 0.4, "mesh_size": 0.25}, [20]),
]
SCREEN_RATIOS = [20, 10]
RATIOS = [1, 2, 5, 5.4, 5.5, 7, 10, 15, 20]  # 5.4 and 5.5: either side of the refined meshes' threshold
# (compression.NODAL_RULE_FROM_STIFFNESS_RATIO); 15: inside the band of the finer mesh above 10
EARLIER = [5, 5.4, 6.9]  # the earlier mesh up to the threshold and beyond it (where it was used up to 7)


def earlier_curve(ratio: float, cached_only: bool = False) -> dict | None:
    """The curve of stiffness ratio ``ratio`` (size ratio 0.5, 40 steps to 0.75) on the default p2 sizes with the
    4-point rule, what a compression used below the threshold: from the cache of :func:`default_curve` where that
    was the default (the same resolved cell), else computed in this process (cached as kind "earlier")."""
    cell = cell_parameters(**cell_options(ratio))
    for kind in ("cli", "earlier"):
        path = _path(kind, cell, DELTA_MAX, STEPS)
        if path.exists():
            return json.loads(path.read_text())
    if cached_only:
        return None
    start = time.perf_counter()
    body = Cell.from_parameters(cell)
    try:
        result = compress(body, CompressionParameters(delta_max=DELTA_MAX, steps=STEPS))
    except CompressionInterrupted:
        raise
    except CompressionError as failure:
        result = failure.partial
    record = {"ratio": ratio, "steps": STEPS, "delta": result.delta.tolist(), "force": result.force.tolist(),
              "nodes": body.mesh.n_nodes, "curve_s": time.perf_counter() - start, "run": "in process"}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record
SIZES = [0.1, 0.3, 0.7, 0.9]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", nargs="+", choices=["screen", "defaults", "sizes"],
                        default=["screen", "defaults", "sizes"])
    parser.add_argument("--cached-only", action="store_true", help="list a curve not in the cache as not run")
    parser.add_argument("--ratios", type=float, nargs="+", default=RATIOS, help="stiffness ratios of the defaults")
    parser.add_argument("--sizes", type=float, nargs="+", default=SIZES, help="size ratios of the size series")
    parser.add_argument("--no-page", action="store_true", help="compute and print, write no page")
    args = parser.parse_args()
    page = Page("axisymmetric", "stiff_mesh.py", intro=(
        "F/(E_c R^2) of the 3D solver (p2 tetrahedra; the quadrature as the degree column or the title says) "
        "against the axisymmetric truth "
        "(meridian mesh of scale 0.5), neo-Hookean, nu 0.48, nucleus of size ratio 0.5; every error is "
        "F/F_truth - 1 at the same delta. A compression gives a nucleus at least 5.5 times stiffer than the "
        "cytoplasm a refined mesh (`compression.STIFF_NUCLEUS_MESHES`): the screen shows what each refinement "
        "removes, the second table the defaults that result. Wall times are of a 2-core machine running two "
        "curves at a time and, part of the time, a test suite: they say little of the cost (the footer's load is "
        "that of the run that wrote the page)."))
    form = {"time_s": ".0f", "process_s": ".0f", "curve_s": ".0f", "delta_reached": ".3f",
            **{name: "+.2%" for name in ERRORS}}
    if "screen" in args.only:
        rows = []
        for ratio in SCREEN_RATIOS:
            for label, mesh, ratios in SCREEN:
                if ratio not in ratios:
                    continue
                record = screened_curve(ratio, {}, {"layer_size": None, **mesh}, cached_only=args.cached_only)
                if record is None:
                    rows.append({"gamma": ratio, "mesh": label, "nodes": "not run"})
                    continue
                rows.append({"gamma": ratio, "mesh": label, "nodes": record["nodes"], "time_s": record["seconds"],
                             "delta_reached": record["delta"][-1], **errors(record, truth(ratio)),
                             "stop": record["error"].split(":")[0] if record["error"] else ""})
        page.table(rows, "Screen: one mesh at a time (14 steps to delta 0.7, in this process)",
                   columns=["gamma", "mesh", "nodes", "time_s", "delta_reached", *ERRORS, "stop"], formats=form)
    if "defaults" in args.only:
        rows = []
        for ratio in args.ratios:
            if axisymmetric_curve(cell_options(ratio), TRUTH_SCALE, cached_only=args.cached_only) is None:
                rows.append({"gamma": ratio, "nodes": "not run (truth)"})
                continue
            record = default_curve(ratio, STEPS, cached_only=args.cached_only)
            if record is None:
                rows.append({"gamma": ratio, "nodes": "not run"})
                continue
            mesh = record["mesh"]
            rows.append({"gamma": ratio, "nodes": record["nodes"], "surface": mesh.get("interface_size"),
                         "width": mesh.get("interface_width"), "bulk": mesh["mesh_size"],
                         "degree": mesh["quadrature_degree"] or 2, "process_s": record["process_s"],
                         "curve_s": record["curve_s"], "exit": record.get("returncode"),
                         "delta_reached": record["delta"][-1], **errors(record, truth(ratio))})
        page.table(rows, f"`elastocell compress` on its defaults ({STEPS} steps to delta 0.75), each in a new "
                   "process, against the axisymmetric truth (surface, width, bulk: the resolved mesh's nucleus "
                   "surface size, its grading width and the bulk size, units of R)",
                   columns=["gamma", "nodes", "surface", "width", "bulk", "degree", "process_s", "curve_s", "exit",
                            "delta_reached", *ERRORS], formats={**form, "surface": "g", "width": "g", "bulk": "g"})
    if "defaults" in args.only:
        rows = []
        for ratio in EARLIER:
            if axisymmetric_curve(cell_options(ratio), TRUTH_SCALE, cached_only=args.cached_only) is None:
                rows.append({"gamma": ratio, "nodes": "not run (truth)"})
                continue
            record = (default_curve(ratio, STEPS, cached_only=args.cached_only)  # the earlier mesh is the default
                      if ratio < NODAL_RULE_FROM_STIFFNESS_RATIO else earlier_curve(ratio, args.cached_only))
            if record is None:
                rows.append({"gamma": ratio, "nodes": "not run"})
                continue
            rows.append({"gamma": ratio, "nodes": record["nodes"], "delta_reached": record["delta"][-1],
                         **errors(record, truth(ratio))})
        page.table(rows, "The threshold: the earlier mesh (the default p2 sizes, nucleus surface 0.15 over 0.25, bulk "
                   f"0.35, and the 4-point rule) on either side of the refined meshes' stiffness ratio "
                   f"{NODAL_RULE_FROM_STIFFNESS_RATIO:g}, 40 steps to delta 0.75",
                   columns=["gamma", "nodes", "delta_reached", *ERRORS], formats=form)
    if "sizes" in args.only:
        rows = []
        for size in args.sizes:
            changes = {"size_ratio": size}
            if axisymmetric_curve(cell_options(2, **changes), VARIED_TRUTH_SCALE, cached_only=args.cached_only) is None:
                rows.append({"lambda": size, "nodes": "not run (truth)"})
                continue
            record = default_curve(2, STEPS, cached_only=args.cached_only, changes=changes)
            if record is None:
                rows.append({"lambda": size, "nodes": "not run"})
                continue
            rows.append({"lambda": size, "nodes": record["nodes"], "process_s": record["process_s"],
                         "curve_s": record["curve_s"], "exit": record.get("returncode"),
                         "delta_reached": record["delta"][-1], **errors(record, truth(2, changes))})
        page.table(rows, f"The size series at stiffness ratio 2: `elastocell compress --size-ratio LAMBDA` ({STEPS} "
                   "steps, new process) against the truth on the meridian mesh of scale 0.7",
                   columns=["lambda", "nodes", "process_s", "curve_s", "exit", "delta_reached", *ERRORS], formats=form)
    if not args.no_page:
        page.write()


if __name__ == "__main__":
    main()
