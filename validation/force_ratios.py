"""Force of a nucleus cell over the force of its homogeneous equivalent (same mesh), at delta = 0.1, 0.3,
0.5, 0.7, for stiffness ratios 2, 10, 20 (size ratio 0.5), with quadratic (default) and linear elements.

    python validation/force_ratios.py [--element p2 p1] [--quadrature-degree 2] [--steps 40]
        [--out results/force_ratios.csv]

Without --quadrature-degree each p2 cell uses the degree of ``elastocell compress`` (5 for stiffness ratios 10
and 20, the rule with the nodes; 2 otherwise); ``--quadrature-degree 2`` gives the 4-point rule throughout.

Prints a table and writes it into docs/validation/compression.md (``validation/page.py``); the ratios are
measurements, not assumptions (the paper claims they are close to 1).
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

DELTAS = (0.1, 0.3, 0.5, 0.7)


def _curve(body: Cell, params: CompressionParameters, notes: list[str]):
    """The curve of ``body``; where it stops early, its converged part (and a note)."""
    try:
        return compress(body, params)
    except CompressionError as error:
        notes.append(str(error).split(":")[0])
        return error.partial


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--element", nargs="+", default=["p2", "p1"])
    parser.add_argument("--stiffness-ratio", nargs="+", type=float, default=[2.0, 10.0, 20.0])
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--delta-max", type=float, default=0.75)
    parser.add_argument("--mesh-size", type=float, default=None)
    parser.add_argument("--pole-size", type=float, default=None)
    parser.add_argument("--quadrature-degree", type=int, default=None,
                        help="p2 only (default: that of elastocell compress)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    page = Page("compression", "force_ratios.py", intro=(
        "The force on a cell with a spherical nucleus (size ratio 0.5) over the force on its homogeneous "
        "equivalent (the same mesh with every element at the effective modulus E_eff), at delta = 0.1, 0.3, 0.5 "
        "and 0.7, for several nucleus-to-cytoplasm stiffness ratios gamma. The reference is the paper's claim "
        "that the equivalent reproduces the nucleus cell's force, i.e. ratios close to 1; the table measures how "
        "close, and whether quadratic and linear elements agree (nan: the curve stopped before that delta)."))
    rows = []
    print(f"{'element':>7} {'gamma':>6} {'gamma_eff':>9} {'nodes':>6} " + " ".join(f"F/Feq@{d:<4}" for d in DELTAS) + "  seconds")
    table = []
    for element in args.element:
        for gamma in args.stiffness_ratio:
            start = time.perf_counter()
            # without --quadrature-degree: the degree `elastocell compress` uses for this cell
            cell = Cell.from_parameters(compression_parameters_for(cell_parameters(
                stiffness_ratio=gamma, element=element, mesh_size=args.mesh_size, pole_size=args.pole_size,
                quadrature_degree=args.quadrature_degree)))
            params = CompressionParameters(delta_max=args.delta_max, steps=args.steps)
            notes: list[str] = []
            nucleus, equivalent = _curve(cell, params, notes), _curve(cell.equivalent(), params, notes)
            ratios = [np.interp(d, nucleus.delta, nucleus.force, right=np.nan)
                      / np.interp(d, equivalent.delta, equivalent.force, right=np.nan) for d in DELTAS]
            note = "; ".join(notes)
            seconds = time.perf_counter() - start
            rows.append((element, gamma, cell.effective_stiffness_ratio, cell.mesh.n_nodes, *ratios, seconds))
            table.append({"element": element, "quadrature": cell.parameters.mesh.quadrature_degree, "gamma": gamma,
                          "gamma_eff": cell.effective_stiffness_ratio, "nodes": cell.mesh.n_nodes,
                          **{f"F/F_eq@{d}": r for d, r in zip(DELTAS, ratios, strict=True)}, "seconds": seconds,
                          "note": note})
            print(f"{element:>7} {gamma:>6g} {cell.effective_stiffness_ratio:>9.4f} {cell.mesh.n_nodes:>6} "
                  + " ".join(f"{r:>10.4f}" for r in ratios) + f"  {seconds:7.1f} {note}", flush=True)
    page.table(table, f"{args.steps} steps to delta {args.delta_max:g}", echo=False,
               formats={"gamma": "g", "gamma_eff": ".4f", "seconds": ".1f", **{f"F/F_eq@{d}": ".4f" for d in DELTAS}})
    if args.out:
        header = "element,stiffness_ratio,effective_stiffness_ratio,n_nodes," + ",".join(f"ratio_{d}" for d in DELTAS) + ",seconds"
        with open(args.out, "w") as handle:
            handle.write(header + "\n")
            for row in rows:
                handle.write(",".join(str(v) for v in row) + "\n")
    page.write()

if __name__ == "__main__":
    main()
