"""Compute the shipped master curves into src/elastocell/data/.

    python validation/mastercurves.py [NU ...]          compression (nu = 0.45, 0.48, 0.49 by default;
                                                        ELASTOCELL_MASTERCURVE_STEPS=N: load steps, default 60)
    python validation/mastercurves.py shear [NU ...]    shear flow (nu = 0.48 by default)

Compression, each curve: the default p2 mesh and the fine one (mastercurve.MESHES), 60 steps to delta = 0.75
(nu = 0.49: 50 steps -- with 60 the default mesh stops converging at delta = 0.597).

Shear: the shear scenario at every Ca of mastercurve_shear.CAPILLARY_NUMBERS, R/dx = 6 and 8, strain 4 each
(one process, single-threaded compiled steps); the runs go to the cache directory, so an interrupted
computation resumes where it stopped.
"""

import os
import sys
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "src" / "elastocell" / "data"


def compression(values):
    from elastocell.inverse.mastercurve import SHIPPED_POISSON_RATIOS, compute_master_curve, shipped_name

    for nu in values or SHIPPED_POISSON_RATIOS:
        start = time.perf_counter()
        steps = int(os.environ.get("ELASTOCELL_MASTERCURVE_STEPS", 60))
        curve = compute_master_curve(nu, "neo-hookean", use_cache=False, steps=steps)
        prefix = f"ELASTOCELL_MASTERCURVE_STEPS={steps} " if steps != 60 else ""
        curve.metadata["command"] = (f"{prefix}python validation/mastercurves.py {nu:g}  (== elastocell mastercurve "
                                     f"compression --poisson-ratio {nu:g} --material neo-hookean, {steps} steps)")
        curve.to_csv(DATA / shipped_name(nu), force_default_mesh=curve.force_default_mesh)
        print(f"nu={nu}: {time.perf_counter() - start:.1f} s, meshes {curve.metadata['meshes']}", flush=True)


def shear(values):
    from elastocell.inverse.mastercurve_shear import (
        SHIPPED_POISSON_RATIOS,
        compute_shear_master_curve,
        shipped_name,
    )

    for nu in values or SHIPPED_POISSON_RATIOS:
        start = time.perf_counter()

        def report(ca, resolution, summary, start=start):
            print(f"  Ca={ca:g} R/dx={resolution:g}: D={summary['taylor_deformation_mean']:.5f} "
                  f"incl={summary['inclination_deg_mean']:.2f} tt={summary['tank_treading_frequency']:.4f} "
                  f"({summary.get('wall_time_cumulative_s', 0):.0f} s; {time.perf_counter() - start:.0f} s so far)",
                  flush=True)

        curve = compute_shear_master_curve(nu, "neo-hookean", progress=report)
        curve.metadata["command"] = (f"python validation/mastercurves.py shear {nu:g}  (== elastocell mastercurve "
                                     f"shear --poisson-ratio {nu:g} --material neo-hookean)")
        curve.metadata["total_wall_time_s"] = round(time.perf_counter() - start, 1)
        curve.to_csv(DATA / shipped_name(nu))
        print(f"nu={nu}: {time.perf_counter() - start:.1f} s -> {DATA / shipped_name(nu)}", flush=True)


if __name__ == "__main__":
    arguments = sys.argv[1:]
    if arguments[:1] == ["shear"]:
        shear([float(v) for v in arguments[1:]])
    else:
        compression([float(v) for v in arguments])
