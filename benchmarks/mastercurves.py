"""Compute the shipped master curves (nu = 0.45, 0.48, 0.49, neo-Hookean) into src/elastocell/data/.

    python benchmarks/mastercurves.py [NU ...]          (ELASTOCELL_MASTERCURVE_STEPS=N: load steps, default 60)

Each curve: the default p2 mesh and the fine one (mastercurve.MESHES), 60 steps to delta = 0.75 (nu = 0.49:
50 steps -- with 60 the default mesh stops converging at delta = 0.597).
"""

import os
import sys
import time
from pathlib import Path

from elastocell.mastercurve import SHIPPED_POISSON_RATIOS, compute_master_curve, shipped_name

DATA = Path(__file__).resolve().parents[1] / "src" / "elastocell" / "data"

for nu in [float(v) for v in sys.argv[1:]] or SHIPPED_POISSON_RATIOS:
    start = time.perf_counter()
    steps = int(os.environ.get("ELASTOCELL_MASTERCURVE_STEPS", 60))
    curve = compute_master_curve(nu, "neo-hookean", use_cache=False, steps=steps)
    prefix = f"ELASTOCELL_MASTERCURVE_STEPS={steps} " if steps != 60 else ""
    curve.metadata["command"] = (f"{prefix}python benchmarks/mastercurves.py {nu:g}  (== elastocell mastercurve "
                                 f"compression --poisson-ratio {nu:g} --material neo-hookean, {steps} steps)")
    curve.to_csv(DATA / shipped_name(nu), force_default_mesh=curve.force_default_mesh)
    print(f"nu={nu}: {time.perf_counter() - start:.1f} s, meshes {curve.metadata['meshes']}", flush=True)
