"""Does a full compression curve reach delta_max = 0.75 for every cell the compression issue names?

    python validation/compression_reach.py [--element p2] [--quadrature-degree 2] [--only NAME ...]
        [--out results/reach.csv]

Without --quadrature-degree each p2 cell uses the degree of ``elastocell compress`` (5 for a neo-Hookean nucleus
at least 5.5 times stiffer, the rule with the nodes; 2 otherwise).

One row per cell: the delta reached, F/(E_c R^2) there, the rows whose equilibrium is a saddle of the discrete
energy (the symmetric branch lost stability), Newton iterations, substeps and wall time. A curve that stops
early is a measurement too: the row says where and why. The table goes into docs/validation/compression.md
(``validation/page.py``).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from page import Page

from elastocell.body.cell import Cell
from elastocell.parameters.cell import cell_parameters
from elastocell.scenarios.compression import (
    CompressionError,
    CompressionParameters,
    compress,
    compression_parameters_for,
)

CELLS = {
    "homogeneous": dict(nucleus="none"),
    **{f"gamma-{g:g}": dict(stiffness_ratio=g) for g in (2.0, 5.0, 10.0, 20.0)},
    **{f"size-{s:g}": dict(size_ratio=s) for s in (0.1, 0.3, 0.7, 0.9)},
    **{f"offset-0.45-{a}": dict(offset=0.45, offset_axis=a) for a in ("x", "y", "z")},
    **{f"ellipsoid-{a}": dict(nucleus="ellipsoid", nucleus_axis=a) for a in ("x", "y", "z")},
    "random": dict(random=True, seed=0),
    "mooney-rivlin": dict(material="mooney-rivlin"),
}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--element", default="p2", choices=["p1", "p2"])
    parser.add_argument("--quadrature-degree", type=int, default=None,
                        help="p2 only (default: that of elastocell compress)")
    parser.add_argument("--only", nargs="+", default=None)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    names = args.only or list(CELLS)
    page = Page("compression", "compression_reach.py", intro=(
        "Robustness rather than accuracy: does one full compression curve reach delta_max = 0.75 for every cell "
        "the compression studies name (nucleus stiffness and size ratios, offsets, ellipsoids, the random cell, "
        "Mooney-Rivlin)? Each row: the delta reached and F/(E_c R^2) there, the rows whose equilibrium is a saddle "
        "of the discrete energy (the symmetric branch lost stability) and the first of them, Newton iterations, "
        "substeps, wall time and the smallest volume ratio J; a curve that stops early says where and why. The "
        "reference is the target itself, delta = 0.75."))
    rows = []
    print(f"{'cell':>18} {'nodes':>6} {'delta':>7} {'F/EcR2':>8} {'saddles':>7} {'first':>6} {'newton':>6} "
          f"{'subst':>5} {'s':>6} {'min J':>6}  note")
    for name in names:
        # without --quadrature-degree: the degree `elastocell compress` uses for this cell
        cell = Cell.from_parameters(compression_parameters_for(cell_parameters(
            element=args.element, quadrature_degree=args.quadrature_degree, **CELLS[name])))
        start = time.perf_counter()
        note = ""
        try:
            result = compress(cell, CompressionParameters())
        except CompressionError as error:
            result, note = error.partial, str(error).split(";")[0]
        seconds = time.perf_counter() - start
        saddles = int(result.unstable.sum())
        first = float(result.delta[np.argmax(result.unstable)]) if saddles else float("nan")
        row = dict(cell=name, element=args.element, quadrature_degree=cell.parameters.mesh.quadrature_degree,
                   nodes=cell.mesh.n_nodes, delta_reached=float(result.delta[-1]),
                   force_per_Ec_R2=float(result.force[-1]), saddle_rows=saddles, first_saddle_delta=first,
                   newton_iterations=result.newton_iterations, substeps=result.substeps, seconds=seconds,
                   min_volume_ratio=float(result.min_volume_ratio.min()), note=note)
        rows.append(row)
        print(f"{name:>18} {row['nodes']:>6} {row['delta_reached']:>7.4f} {row['force_per_Ec_R2']:>8.4f} {saddles:>7} "
              f"{first:>6.3f} {row['newton_iterations']:>6} {row['substeps']:>5} {seconds:>6.1f} "
              f"{row['min_volume_ratio']:>6.3f}  {note}", flush=True)
    page.table(rows, f"{args.element} elements", echo=False, formats={
        "delta_reached": ".4f", "force_per_Ec_R2": ".4f", "first_saddle_delta": ".3f", "seconds": ".1f",
        "min_volume_ratio": ".3f"})
    if args.out:
        import pandas as pd

        pd.DataFrame(rows).to_csv(args.out, index=False)
    page.write()

if __name__ == "__main__":
    main()
