"""The volumetric treatment of the 3D p2 cell (``MeshParameters.volumetric``) against the axisymmetric truth for a
stiff nucleus: does the crushed cytoplasm between nucleus and plates lock?

    nice python validation/stiff_volumetric.py [--ratios 20 10] [--candidate-ratios 10] [--cached-only]

The truth and the screening are validation/stiff_3d.py's (``compress_axisymmetric`` on the meridian mesh of scale
0.5; 14 load steps to delta 0.7; every curve cached there): the default (J at each quadrature point), J
L2-projected per element onto the linear polynomials (``projected``) or onto the constants (``mean``: the mean
dilatation, a constant pressure per element), and for comparison the refined mesh of stiff_3d.py's budget (polar
layer 0.1 within 40 degrees and nucleus surface 0.075) with the standard treatment. The candidate table runs
``elastocell compress --volumetric mean`` (40 steps to delta 0.75, a new process) for ``--candidate-ratios``.
Writes its section of docs/validation/axisymmetric.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse

from page import Page
from stiff_3d import BASE, SCREEN_DELTA, SCREEN_STEPS, STEPS, default_curve, errors, screened_curve, truth

from axisymmetric import ERRORS  # isort: skip

VARIANTS = [("standard (the mesh before the stiff nucleus's refinement)", {}), ("projected J (P1)", {"volumetric": "projected"}),
            ("mean dilatation (P0)", {"volumetric": "mean"}),
            ("standard, polar layer 0.1 within 40 deg, nucleus surface 0.075",
             {"layer_size": 0.1, "layer_angle": 40, "interface_size": 0.075})]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--ratios", nargs="+", type=float, default=[20.0, 10.0])
    parser.add_argument("--candidate-ratios", nargs="*", type=float, default=[10.0])
    parser.add_argument("--cached-only", action="store_true", help="list a curve not in the cache as not run")
    args = parser.parse_args()
    page = Page("axisymmetric", "stiff_volumetric.py", intro=(
        "F/(E_c R^2) of the 3D solver (p2 tetrahedra, nucleus of size ratio 0.5, neo-Hookean, nu 0.48) against the "
        "axisymmetric truth (meridian mesh of scale 0.5), error F/F_truth - 1 at the same delta; one change to the "
        "default at a time. `volumetric` replaces J in the law by J_bar, its L2 projection per element (F_bar = "
        "(J_bar/J)^(1/3) F): onto the linear polynomials (`projected`) or the constants (`mean`). Wall times on "
        "a 2-core machine shared with other runs (load in the footer)."))
    form = {"time_s": ".0f", "delta_reached": ".3f", **{name: "+.2%" for name in ERRORS}}
    rows = []
    for ratio in args.ratios:
        for label, changes in VARIANTS:
            record = screened_curve(ratio, {}, {**BASE, **changes}, cached_only=args.cached_only)
            if record is None:
                rows.append({"gamma": ratio, "variation": label, "nodes": "not run"})
                continue
            rows.append({"gamma": ratio, "variation": label, "nodes": record["nodes"], "time_s": record["seconds"],
                         "delta_reached": record["delta"][-1], **errors(record, truth(ratio)),
                         "stop": record["error"].split(":")[0] if record["error"] else ""})
    page.table(rows, f"{SCREEN_STEPS} steps to delta {SCREEN_DELTA:g}", columns=[
        "gamma", "variation", "nodes", "time_s", "delta_reached", *ERRORS, "stop"], formats=form)
    rows = []
    for ratio in args.candidate_ratios:
        record = default_curve(ratio, STEPS, cached_only=args.cached_only, changes={"volumetric": "mean"})
        if record is None:
            rows.append({"gamma": ratio, "nodes": "not run"})
            continue
        lines = record["stderr"].strip().splitlines()  # the end of the process's stderr (its last 500 characters)
        if lines and len(record["stderr"]) >= 500:
            lines[0] = "..." + lines[0]
        rows.append({"gamma": ratio, "steps": record["steps"], "nodes": record["nodes"],
                     "curve_s": record["curve_s"], "process_s": record["process_s"],
                     "delta_reached": record["delta"][-1], **errors(record, truth(ratio)),
                     "exit": record["returncode"],
                     "stop": " ".join(line.split(";")[0] for line in lines if not line.startswith("warning")),
                     "warning": " ".join(line for line in lines if line.startswith("warning"))})
    if rows:
        page.table(rows, f"`elastocell compress --volumetric mean` ({STEPS} steps to delta 0.75, a new process)",
                   columns=["gamma", "steps", "nodes", "curve_s", "process_s", "delta_reached", *ERRORS, "exit",
                            "stop", "warning"], formats={**form, "curve_s": ".0f", "process_s": ".0f"})
    page.write()


if __name__ == "__main__":
    main()
