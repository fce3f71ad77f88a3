"""The cell's Poisson ratio in shear flow at a fixed shear modulus: what the discrete body's volumetric stiffness
does to the immersed-boundary cell's deformation.

    nice python validation/flow_volumetric.py [--poisson-ratios 0.45 0.48 0.49] [--resolution 6]
                                              [--capillary-number 0.05] [--out results/flow-volumetric]
                                              [--cached-only]

In the immersed-boundary model the cell is carried by an incompressible fluid that fills it: the continuum motion
of its body is isochoric whatever its Poisson ratio, so the volumetric term of its strain energy
(kappa/2 (J - 1)^2, kappa/mu = 2 (1 + nu)/(3 (1 - 2 nu))) stays at zero, and at a fixed shear modulus (Ca =
eta gdot/mu) the deformation does not depend on nu. The discrete body's does: its linear tetrahedra do not follow the
kernel-smoothed, divergence-free velocity with J = 1 exactly, so kappa can act on them. Each run is
``elastocell.shear`` of the homogeneous cell at its defaults (linear tetrahedra of edge 2 dx, the matched
relaxation time) at one resolution (``extrapolate=False``) for ``--duration`` units of strain, the cell's nu
changed and nothing else; D/Ca against Taylor's small-deformation limit 5/4 of an incompressible elastic sphere
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

from page import Page

SMALL_CA_SLOPE = 1.25  # D -> (5/4) Ca, Taylor's small-deformation limit of an incompressible elastic sphere


def key(nu: float, resolution: float, ca: float, duration: float) -> str:
    return f"nu{nu:g}-Rdx{resolution:g}-Ca{ca:g}-t{duration:g}"


def run(nu: float, resolution: float, ca: float, duration: float, out: Path) -> dict:
    from elastocell.api.shear import shear

    start = time.perf_counter()
    summary = shear(out / key(nu, resolution, ca, duration), ca, nucleus="none", poisson_ratio=nu,
                    resolution=resolution, extrapolate=False, duration=duration, vtk_interval=None, progress=False)
    return {"key": key(nu, resolution, ca, duration), "nu": nu, "resolution": resolution, "Ca": ca,
            "duration": duration, "D": summary["taylor_deformation_mean"],
            "inclination": summary["inclination_deg_mean"], "tank_treading": summary["tank_treading_frequency"],
            "volume_change_max_abs": summary["volume_change_max_abs"], "stationary": summary["stationary"],
            "nodes": summary["mesh"]["n_nodes"], "wall_s": time.perf_counter() - start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--poisson-ratios", type=float, nargs="+", default=[0.45, 0.48, 0.49])
    parser.add_argument("--resolution", type=float, default=6.0, help="R/dx")
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

    todo = [key(nu, args.resolution, args.capillary_number, args.duration) for nu in args.poisson_ratios]
    if not args.cached_only:
        for nu in args.poisson_ratios:
            if key(nu, args.resolution, args.capillary_number, args.duration) in cache():
                continue
            record = run(nu, args.resolution, args.capillary_number, args.duration, args.out)
            with path.open("a") as handle:
                handle.write(json.dumps(record) + "\n")
            print(f"nu {nu:g}: D/Ca {record['D'] / args.capillary_number:.4f} ({record['wall_s']:.0f} s)", flush=True)
    records = [cache()[k] for k in todo if k in cache()]
    base = [r for r in records if r["nu"] == 0.48]
    rows = [{"nu": r["nu"], "kappa/mu": 2 * (1 + r["nu"]) / (3 * (1 - 2 * r["nu"])), "D/Ca": r["D"] / r["Ca"],
             "over 5/4 (%)": 100 * (r["D"] / r["Ca"] / SMALL_CA_SLOPE - 1),
             "D/D(nu 0.48)": r["D"] / base[0]["D"] if base else float("nan"), "inclination (deg)": r["inclination"],
             "tank treading": r["tank_treading"], "max |dV/V|": r["volume_change_max_abs"],
             "stationary": r["stationary"], "nodes": r["nodes"], "wall_s": r["wall_s"]} for r in records]
    page = Page("flow_accuracy", "flow_volumetric.py", intro=(
        f"The homogeneous cell in shear flow at Ca = eta gdot/mu = {args.capillary_number:g} (the same shear modulus "
        f"at every nu), R/dx {args.resolution:g} alone, {args.duration:g} units of strain, `elastocell.shear`'s "
        "defaults otherwise (linear tetrahedra of edge 2 dx), the cell's Poisson ratio changed and nothing else. "
        "The fluid that fills the immersed-boundary cell is incompressible, so its continuum motion is isochoric and "
        "D does not depend on nu; a change of D with nu here is the discrete model's, not the continuum's (kappa/mu "
        "is the tetrahedra's volumetric over shear stiffness). D/Ca against Taylor's small-deformation limit 5/4; max |dV/V| the largest "
        "volume change of the cell in the run. Runs one after the other, one Numba thread each, beside other work "
        f"on the 2-core machine (wall_s is not a benchmark; the footer's wall time is that of the command that wrote the "
        f"page, which reads the runs it finds in the cache). {len(records)} of {len(todo)} runs."))
    page.table(rows, f"Shear flow, Ca {args.capillary_number:g}, R/dx {args.resolution:g}: D/Ca against nu at a "
                     "fixed shear modulus", formats={
                         "nu": "g", "kappa/mu": ".1f", "D/Ca": ".4f", "over 5/4 (%)": "+.1f", "D/D(nu 0.48)": ".4f",
                         "inclination (deg)": ".2f", "tank treading": ".4f", "max |dV/V|": ".1e", "wall_s": ".0f"})
    page.write()


if __name__ == "__main__":
    main()
