"""The paper's reference cell squeezed between two plates, beside its homogeneous equivalent.

The reference cell is a ball with a centred spherical nucleus twice as stiff as the cytoplasm (stiffness ratio 2,
size ratio 0.5, neo-Hookean, Poisson ratio 0.48). Its homogeneous equivalent has the same mesh with every element at
the volume-averaged modulus E_eff. ``compare=True`` runs both curves up to delta = 0.75 and writes the force ratio
F/F_eq (``comparison.csv``) and a plot of both curves (``comparison.png``).

    python examples/reference_cell.py                            # full size: default p2 mesh (4,656 nodes), 40 steps
    ELASTOCELL_EXAMPLE_SMOKE=1 python examples/reference_cell.py   # coarse p1 mesh, 6 load steps to delta 0.3

Time on a 2-core machine: full size 2-3 min when idle (two curves of 60-90 s and about 50 s); measured 9.4 min
with the cores shared with other jobs (292 s and 258 s for the curves). Smoke: 14-23 s, mostly imports.

Output: ``$ELASTOCELL_EXAMPLE_OUT`` (default ``example-output/reference_cell``, ``-smoke`` appended in smoke mode).
Same as ``elastocell compress --compare --out DIR``.
"""

import os
from pathlib import Path

import numpy as np
import pandas as pd

import elastocell

SMOKE = os.environ.get("ELASTOCELL_EXAMPLE_SMOKE") == "1"
OUT = Path(os.environ.get("ELASTOCELL_EXAMPLE_OUT", "example-output/reference_cell" + ("-smoke" if SMOKE else "")))


def main():
    # The cell: these are the defaults, spelled out so that they are easy to change.
    cell = dict(stiffness_ratio=2.0, size_ratio=0.5, poisson_ratio=0.48, material="neo-hookean")
    if SMOKE:  # linear tetrahedra on a coarse mesh, a short curve, no VTK files
        run = dict(element="p1", mesh_size=0.5, pole_size=0.5, delta_max=0.3, steps=6, vtk=False)
    else:      # the converged default: quadratic tetrahedra refined at the poles and the nucleus, 40 load steps
        run = dict(delta_max=0.75, steps=40)

    summary = elastocell.compress(out=OUT, compare=True, progress=not SMOKE, **cell, **run)
    print(f"E_eff/E_c = {summary['effective_stiffness_ratio']:.4f} (analytic 1 + (2 - 1) 0.5^3 = 1.125)")

    # comparison.csv: delta, force_cell, force_equivalent, force_ratio (forces in E_c R^2).
    table = pd.read_csv(OUT / "comparison.csv")
    reached = table["delta"].max()
    print(f"{'delta':>6} {'F/(E_c R^2)':>12} {'F_eq/(E_c R^2)':>15} {'F/F_eq':>7}")
    for delta in [d for d in (0.1, 0.3, 0.5, 0.7) if d <= reached + 1e-9]:
        force = np.interp(delta, table["delta"], table["force_cell"])
        force_eq = np.interp(delta, table["delta"], table["force_equivalent"])
        print(f"{delta:6.2f} {force:12.4f} {force_eq:15.4f} {force / force_eq:7.3f}")

    print(f"plot: {OUT / 'comparison.png'}  (single curves: {OUT / 'compression.png'}, "
          f"{OUT / 'equivalent' / 'compression.png'})")


if __name__ == "__main__":
    main()
