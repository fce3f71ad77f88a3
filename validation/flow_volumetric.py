"""The cell's Poisson ratio in shear flow at a fixed shear modulus: what the discrete body's volumetric stiffness
does to the immersed-boundary cell's deformation.

    nice python validation/flow_volumetric.py [--poisson-ratios 0.45 0.48 0.49] [--resolutions 6 8]
                                              [--volumetric standard nodal]
                                              [--capillary-number 0.05] [--out results/flow-volumetric]
                                              [--cached-only]

The page's runs: ``--volumetric standard nodal --resolutions 6 8 --poisson-ratios 0.45 0.48 0.49`` (one Numba
thread, beside other work).

In the immersed-boundary model the cell is carried by an incompressible fluid that fills it: the continuum motion
of its body is isochoric whatever its Poisson ratio, so the volumetric term of its strain energy
(kappa/2 (J - 1)^2, kappa/mu = 2 (1 + nu)/(3 (1 - 2 nu))) stays at zero, and at a fixed shear modulus (Ca =
eta gdot/mu) the deformation does not depend on nu. The discrete body's does: its linear tetrahedra do not follow the
kernel-smoothed, divergence-free velocity with J = 1 exactly, so kappa can act on them. Each run is
``elastocell.shear`` of the homogeneous cell at its defaults (linear tetrahedra of edge 2 dx, the matched
relaxation time) at one resolution (``extrapolate=False``) for ``--duration`` units of strain, the cell's nu
changed and nothing else, with either volumetric treatment of the tetrahedra (``--volumetric``: ``standard``,
kappa (J - 1) per element, or ``nodal``, the averaged nodal dilatation, docs/theory.md); D/Ca against Taylor's
small-deformation limit 5/4 of an incompressible elastic sphere
(docs/theory.md). Each run's record is appended to ``--out/runs.jsonl`` (a run found there is not repeated);
``--cached-only`` writes the page from that file. The pipe's runs at two Poisson ratios are in
docs/validation/pipe_dclab.md (section 'The stationary shape at R/dx 8').
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import numpy as np
from page import Page

SMALL_CA_SLOPE = 1.25  # D -> (5/4) Ca, Taylor's small-deformation limit of an incompressible elastic sphere


def key(nu: float, resolution: float, ca: float, duration: float, volumetric: str = "standard") -> str:
    return f"nu{nu:g}-Rdx{resolution:g}-Ca{ca:g}-t{duration:g}" + ("" if volumetric == "standard" else f"-{volumetric}")


def run(nu: float, resolution: float, ca: float, duration: float, out: Path, volumetric: str = "standard") -> dict:
    from elastocell.api.shear import shear

    start = time.perf_counter()
    summary = shear(out / key(nu, resolution, ca, duration, volumetric), ca, nucleus="none", poisson_ratio=nu,
                    resolution=resolution, extrapolate=False, duration=duration, vtk_interval=None, progress=False,
                    volumetric=volumetric)
    return {"key": key(nu, resolution, ca, duration, volumetric), "nu": nu, "resolution": resolution, "Ca": ca,
            "volumetric": volumetric,
            "duration": duration, "D": summary["taylor_deformation_mean"],
            "inclination": summary["inclination_deg_mean"], "tank_treading": summary["tank_treading_frequency"],
            "volume_change_max_abs": summary["volume_change_max_abs"], "stationary": summary["stationary"],
            "nodes": summary["mesh"]["n_nodes"], "wall_s": time.perf_counter() - start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--poisson-ratios", type=float, nargs="+", default=[0.45, 0.48, 0.49])
    parser.add_argument("--resolutions", type=float, nargs="+", default=[6.0], help="R/dx")
    parser.add_argument("--volumetric", nargs="+", default=["standard"], choices=["standard", "nodal"],
                        help="how J enters the tetrahedra's law (MeshParameters.volumetric)")
    parser.add_argument("--capillary-number", type=float, default=0.05)
    parser.add_argument("--duration", type=float, default=4.0, help="strain")
    parser.add_argument("--out", type=Path, default=Path("results/flow-volumetric"))
    parser.add_argument("--cached-only", action="store_true")
    args = parser.parse_args()
    path = args.out / "runs.jsonl"
    args.out.mkdir(parents=True, exist_ok=True)

    def cache() -> dict:
        lines = path.read_text().splitlines() if path.exists() else []
        return {r["key"]: r for r in map(json.loads, filter(None, lines))}

    runs = [(volumetric, resolution, nu) for volumetric in args.volumetric for resolution in args.resolutions
            for nu in args.poisson_ratios]
    todo = [key(nu, resolution, args.capillary_number, args.duration, volumetric) for volumetric, resolution, nu in runs]
    if not args.cached_only:
        for volumetric, resolution, nu in runs:
            if key(nu, resolution, args.capillary_number, args.duration, volumetric) in cache():
                continue
            record = run(nu, resolution, args.capillary_number, args.duration, args.out, volumetric)
            with path.open("a") as handle:
                handle.write(json.dumps(record) + "\n")
            print(f"{volumetric} R/dx {resolution:g} nu {nu:g}: D/Ca {record['D'] / args.capillary_number:.4f} "
                  f"({record['wall_s']:.0f} s)", flush=True)
    records = [cache()[k] for k in todo if k in cache()]

    def base(r: dict) -> float:
        same = [b["D"] for b in records if b["nu"] == 0.48 and b["resolution"] == r["resolution"]
                and b.get("volumetric", "standard") == r.get("volumetric", "standard")]
        return r["D"] / same[0] if same else float("nan")

    rows = [{"volumetric": r.get("volumetric", "standard"), "R/dx": r["resolution"], "nu": r["nu"],
             "kappa/mu": 2 * (1 + r["nu"]) / (3 * (1 - 2 * r["nu"])), "D/Ca": r["D"] / r["Ca"],
             "over 5/4 (%)": 100 * (r["D"] / r["Ca"] / SMALL_CA_SLOPE - 1),
             "D/D(nu 0.48)": base(r), "inclination (deg)": r["inclination"],
             "tank treading": r["tank_treading"], "max |dV/V|": r["volume_change_max_abs"],
             "stationary": r["stationary"], "nodes": r["nodes"], "wall_s": r["wall_s"]} for r in records]
    page = Page("flow_accuracy", "flow_volumetric.py", intro=(
        f"The homogeneous cell in shear flow at Ca = eta gdot/mu = {args.capillary_number:g} (the same shear modulus "
        f"at every nu), R/dx {', '.join(f'{r:g}' for r in args.resolutions)} alone, {args.duration:g} units of strain, `elastocell.shear`'s "
        "defaults otherwise (linear tetrahedra of edge 2 dx), the cell's Poisson ratio changed and nothing else, "
        "with either volumetric treatment of the tetrahedra (standard: kappa (J - 1) per element, the default; nodal: "
        "the averaged nodal dilatation, one volumetric constraint per node, which does not lock; docs/theory.md). "
        "The fluid that fills the immersed-boundary cell is incompressible, so its continuum motion is isochoric and "
        "D does not depend on nu; a change of D with nu here is the discrete model's, not the continuum's (kappa/mu "
        "is the tetrahedra's volumetric over shear stiffness). D/Ca against Taylor's small-deformation limit 5/4; max |dV/V| the largest "
        "volume change of the cell in the run. Runs one after the other, one Numba thread each, beside other work "
        f"on the 2-core machine (wall_s is not a benchmark; the footer's wall time is that of the command that wrote the "
        f"page, which reads the runs it finds in the cache). {len(records)} of {len(todo)} runs."))
    page.table(rows, f"Shear flow, Ca {args.capillary_number:g}: D/Ca against nu at a "
                     "fixed shear modulus", formats={
                         "R/dx": "g", "nu": "g", "kappa/mu": ".1f", "D/Ca": ".4f", "over 5/4 (%)": "+.1f", "D/D(nu 0.48)": ".4f",
                         "inclination (deg)": ".2f", "tank treading": ".4f", "max |dV/V|": ".1e", "wall_s": ".0f"})
    pairs = extrapolated_rows(records, args.capillary_number)
    if pairs:
        page.table(pairs, f"Shear flow, Ca {args.capillary_number:g}: R/dx 8 and 6 combined by Richardson extrapolation "
                          "of order 2 (elastocell.simulation.extrapolation.richardson, the shear default's), against "
                          "Roscoe's D/Ca at viscosity ratio 1", formats={
                              "nu": "g", "D/Ca R/dx 6": ".4f", "D/Ca R/dx 8": ".4f", "D/Ca extrapolated": ".4f",
                              "Roscoe D/Ca": ".4f", "R/dx 8 err %": "+.1f", "extrapolated err %": "+.1f"})
    page.write()


def extrapolated_rows(records: list[dict], ca: float) -> list[dict]:
    """Per volumetric treatment and nu with runs at R/dx 8 and 6: their Richardson extrapolation against Roscoe."""
    from elastocell.scenarios.roscoe import roscoe_steady_state
    from elastocell.simulation.extrapolation import richardson

    axes = roscoe_steady_state(np.array([ca]), 1.0).semi_axes[0]
    roscoe = (axes.max() - axes.min()) / (axes.max() + axes.min()) / ca
    runs = {(r.get("volumetric", "standard"), r["nu"], r["resolution"]): r["D"] / r["Ca"] for r in records}
    rows = []
    for (treatment, nu, resolution), fine in sorted(runs.items()):
        coarse = runs.get((treatment, nu, 6.0))
        if resolution != 8.0 or coarse is None:
            continue
        value = float(richardson(fine, coarse, 8.0 / 6.0))
        rows.append({"volumetric": treatment, "nu": nu, "D/Ca R/dx 6": coarse, "D/Ca R/dx 8": fine,
                     "D/Ca extrapolated": value, "Roscoe D/Ca": roscoe, "R/dx 8 err %": 100 * (fine / roscoe - 1),
                     "extrapolated err %": 100 * (value / roscoe - 1)})
    return rows


if __name__ == "__main__":
    main()
