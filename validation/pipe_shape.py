"""Where does a cell on the axis of a capillary take the paper's bullet shape (eps_x < 1 < eps_r)?

    python validation/pipe_shape.py [--ratios 2 3 4] [--cell-capillary 0.25 0.5] [--resolution 6]
                                    [--duration 20] [--workers 2] [--out results/bullet]

A homogeneous cell (uniform p1 mesh, edges 2 dx) starts on the axis of channels of radius R_ch/R = 2, 3, 4 and
is driven at the same cell-scale capillary number Ca_R = G R/(2 mu) = Ca_w R/R_ch (the local Ca at the cell's
equator), so that only the confinement changes along a row. Each run goes to ``--duration`` units of 1/gdot_w
(stationary means over the second half). One row per run: eps_x, eps_r (means and standard deviations),
the DC deformation, the volume change, steps and wall time. The paper's Fig. 6 caption states eps_x < 1 < eps_r.
The table goes into docs/validation/pipe.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path


def one_run(ratio: float, cell_capillary: float, resolution: float, duration: float) -> dict:
    import numba

    numba.set_num_threads(1)
    from elastocell.body.cell import Cell
    from elastocell.parameters.cell import cell_parameters
    from elastocell.parameters.flow import shear_mesh_size
    from elastocell.scenarios.pipe import PipeFlowParameters, run_pipe

    mesh = shear_mesh_size(resolution)
    cell = Cell.from_parameters(cell_parameters(nucleus="none", element="p1", mesh_size=mesh, pole_size=mesh))
    params = PipeFlowParameters(capillary_number_wall=cell_capillary * ratio, channel_radius_ratio=ratio,
                                resolution=resolution, hydrodynamic_radius_correction=0.0,  # markers at R and
                                channel_wall="staircase")  # the staircase, as on its page
    start = time.perf_counter()
    result = run_pipe(cell, params, duration=duration, record_interval=0.5)
    s = result.summary
    return {"channel_radius_ratio": ratio, "cell_capillary_number": cell_capillary,
            "capillary_number_wall": cell_capillary * ratio, "resolution": resolution, "duration": duration,
            "nodes": cell.mesh.n_nodes, "lattice": "x".join(map(str, result.units.shape)),
            "strain_axial_mean": s["strain_axial_mean"], "strain_axial_std": s["strain_axial_std"],
            "strain_radial_mean": s["strain_radial_mean"], "strain_radial_std": s["strain_radial_std"],
            "deformation_mean": s["deformation_mean"], "volume_change_max_abs": s.get("volume_change_max_abs"),
            "bullet": bool(s["strain_axial_mean"] < 1 < s["strain_radial_mean"]),
            "wall_time_s": time.perf_counter() - start}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ratios", type=float, nargs="+", default=[2.0, 3.0, 4.0])
    parser.add_argument("--cell-capillary", type=float, nargs="+", default=[0.25, 0.5])
    parser.add_argument("--resolution", type=float, default=6.0)
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="results/bullet")
    args = parser.parse_args(argv)
    from concurrent.futures import ProcessPoolExecutor

    from page import Page

    page = Page("pipe", "pipe_shape.py", intro=(
        "A homogeneous cell (uniform p1 mesh, edges 2 dx) on the axis of capillaries of radius R_ch/R, driven at "
        "the same cell-scale capillary number Ca_R = G R/(2 mu) = Ca_w R/R_ch, so that along a row only the "
        "confinement changes. eps_x and eps_r are the cell's axial and radial extents over its diameter, means "
        "(standard deviations) over the second half of each run. The reference is the paper's statement in its "
        "Fig. 6 caption, eps_x < 1 < eps_r (the bullet shape); `bullet` says whether the run shows it. Runs go "
        f"in parallel on {args.workers} single-threaded workers; `wall s` is each run's own time."))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = list(itertools.product(args.ratios, args.cell_capillary))
    rows, table = [], []
    print("R_ch/R  Ca_R  Ca_w   eps_x (std)          eps_r (std)          DC      bullet  wall s", flush=True)
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(one_run, r, c, args.resolution, args.duration) for r, c in jobs]
        for future in futures:
            row = future.result()
            rows.append(row)
            print(f"{row['channel_radius_ratio']:5.1f} {row['cell_capillary_number']:5.2f} "
                  f"{row['capillary_number_wall']:5.2f}  {row['strain_axial_mean']:.4f} ({row['strain_axial_std']:.1e})"
                  f"   {row['strain_radial_mean']:.4f} ({row['strain_radial_std']:.1e})   "
                  f"{row['deformation_mean']:.4f}  {str(row['bullet']):6s} {row['wall_time_s']:6.0f}", flush=True)
            (out / "pipe_shape.json").write_text(json.dumps(rows, indent=1))
            table.append({"R_ch/R": row["channel_radius_ratio"], "Ca_R": row["cell_capillary_number"],
                          "Ca_w": row["capillary_number_wall"], "R/dx": row["resolution"], "t_end": row["duration"],
                          "nodes": row["nodes"], "lattice": row["lattice"],
                          "eps_x (std)": f"{row['strain_axial_mean']:.4f} ({row['strain_axial_std']:.1e})",
                          "eps_r (std)": f"{row['strain_radial_mean']:.4f} ({row['strain_radial_std']:.1e})",
                          "DC": row["deformation_mean"], "max|dV/V|": row["volume_change_max_abs"],
                          "bullet": row["bullet"], "wall s": row["wall_time_s"]})
    page.table(table, formats={"DC": ".4f", "max|dV/V|": ".2e", "wall s": ".0f"}, echo=False)
    page.write()

if __name__ == "__main__":
    main()
