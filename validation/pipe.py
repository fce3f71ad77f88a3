"""The cell in a capillary (pressure-driven Poiseuille flow through a cylinder): accuracy of the empty channel,
stationary strains of the reference cell and its homogeneous equivalent, migration, and the cost of a coupled
step against pure lattice Boltzmann in the same channel.

Run::

    python validation/pipe.py                          # everything below
    python validation/pipe.py --only poiseuille        # Poiseuille error against R_ch/dx and its order (~1 min)
    python validation/pipe.py --only mlups             # MLUPS with the cell against pure LB (~1 min)
    python validation/pipe.py --only reference         # nucleus cell (gamma = 2, lambda = 0.5) and equivalent
    python validation/pipe.py --only migration         # off-axis start, time to halve the offset

Defaults (``PipeFlowParameters``): R/dx = 8, R_ch/R = 2, box 8R, tau = 1, particle Reynolds number 0.1 (with
the wall shear rate), trilinear kernel, uniform p1 mesh with edges of 2 dx; Ca_w = 0.2
(``pipe_flow.DEFAULT_CAPILLARY_NUMBER_WALL``). Time is in units of the inverse wall shear rate 1/gdot_w.
Stationary values are means over the second half of each run. The equivalent runs at the same pressure
gradient G and E_c (the paper's "same flow conditions"), i.e. at Ca_w(mu_eff) = Ca_w/gamma_eff.
MLUPS = all lattice nodes (fluid and solid) x steps / second; the fluid fraction is printed beside it. The
tables go into docs/validation/pipe.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

try:
    import elastocell
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
    import elastocell

import numba
from page import Page

from elastocell.body.cell import Cell
from elastocell.parameters.flow import shear_mesh_size
from elastocell.scenarios import pipe


def make_cell(resolution: float, nucleus: str = "sphere") -> Cell:
    size = shear_mesh_size(resolution)
    return Cell.from_parameters(elastocell.cell_parameters(nucleus=nucleus, stiffness_ratio=2.0, size_ratio=0.5,
                                                           element="p1", mesh_size=size, pole_size=size))


PAGE: list[Page] = []  # the page of this run (set by main)


def print_table(rows: list[dict], title: str, formats: dict | None = None) -> None:
    PAGE[0].table(rows, title, formats=formats or {"wall_s": ".1f"})


def poiseuille(radii) -> list[dict]:
    rows = []
    for radius in radii:
        start = time.perf_counter()
        e = pipe.poiseuille_error(float(radius))
        rows.append({"R_ch/dx": float(radius), "Q_err": e["flow_rate_error"], "L2_err": e["profile_l2_error"],
                     "max_err/u_max": e["profile_max_error"], "centre_err": e["centre_speed_error"],
                     "steps": e["steps"], "wall_s": time.perf_counter() - start})
    print_table(rows, "Empty channel (float64, tau = 1, steady) against u(r) = G (R_ch^2 - r^2)/(4 eta)")
    r = np.array([row["R_ch/dx"] for row in rows])
    for name in ("Q_err", "L2_err", "max_err/u_max"):
        err = np.abs([row[name] for row in rows])
        slope = np.polyfit(np.log(r), np.log(err), 1)[0]
        PAGE[0].print(f"least-squares order of |{name}| over R_ch/dx = {r.min():g}..{r.max():g}: {-slope:.2f}")
    return rows


def run_case(cell: Cell, ca: float, duration: float, **overrides) -> dict:
    params = pipe.PipeFlowParameters(capillary_number_wall=ca, **{"hydrodynamic_radius_correction": 0.0,
                                                                   "channel_wall": "staircase",
                                                                   **overrides})  # markers at R, staircase: its page
    start = time.perf_counter()
    result = pipe.run_pipe(cell, params, duration=duration, record_interval=0.1)
    s = result.summary
    return {
        "cell": "equivalent" if cell.is_equivalent else ("homogeneous" if cell.effective_stiffness_ratio == 1 else
                                                         f"nucleus g_eff={cell.effective_stiffness_ratio:.4f}"),
        "Ca_w": ca, "R/dx": params.resolution, "R_ch/R": params.channel_radius_ratio, "r0/R_ch": params.start_offset,
        "nodes": cell.mesh.n_nodes,
        "eps_x": s["strain_axial_mean"], "eps_x_std": s["strain_axial_std"],
        "eps_r": s["strain_radial_mean"], "eps_r_std": s["strain_radial_std"],
        "eps_z": s["strain_transverse_mean"],
        "deformation": s["deformation_mean"], "deformation_t0": s["deformation_initial"],
        "area/R^2": s["projected_area_mean"], "u/u_max": s["axial_velocity_mean"],
        "r_end/R_ch": s["radial_position"], "t_half": s["migration_half_time"],
        "max|dV/V|": s["volume_change_max_abs"], "t_end": s["duration"],
        "lattice": "x".join(str(n) for n in result.units.shape), "steps": s["steps"],
        "limit": result.units.limiting, "wall_s": time.perf_counter() - start,
        "_series": {k: v.tolist() for k, v in result.series.items()},
    }


def reference(resolution: float, duration: float, ca: float) -> list[dict]:
    cell = make_cell(resolution)
    equivalent = cell.equivalent()
    rows = [run_case(cell, ca, duration, resolution=resolution)]
    print(f"  done reference nucleus cell: {rows[-1]['wall_s']:.0f} s", flush=True)
    rows.append(run_case(equivalent, ca / cell.effective_stiffness_ratio, duration, resolution=resolution))
    print_table([{k: v for k, v in row.items() if not k.startswith("_")} for row in rows],
                f"Centred cell, gamma = 2, lambda = 0.5, and its equivalent at the same G (Ca_w = {ca:g} with mu_c)")
    return rows


def migration(resolution: float, duration: float, ca: float, offset: float) -> list[dict]:
    cell = make_cell(resolution)
    rows = [run_case(cell, ca, duration, resolution=resolution, start_offset=offset)]
    row = rows[0]
    print_table([{k: v for k, v in row.items() if not k.startswith("_")}],
                f"Migration of the reference cell from r0/R_ch = {offset:g} (Ca_w = {ca:g})")
    t = np.asarray(row["_series"]["time"])
    r = np.asarray(row["_series"]["radial_position"])
    for mark in np.linspace(0, t[-1], 9):
        i = int(np.argmin(abs(t - mark)))
        PAGE[0].print(f"  t = {t[i]:7.2f}/gdot_w  r/R_ch = {r[i]:.4f}")
    return rows


def mlups(resolution: float, steps: int, ca: float, repeats: int = 7) -> dict:
    """Coupled steps against pure LB in the same channel, interleaved: ``repeats`` pairs of chunks of
    ``steps // repeats`` steps, each chunk timed alone. Best-of per variant (the least disturbed by other
    processes on a shared machine) and the median of the pairwise ratios are both printed."""
    cell = make_cell(resolution)
    params = pipe.PipeFlowParameters(capillary_number_wall=ca, resolution=resolution, channel_wall="staircase",
                                     hydrodynamic_radius_correction=0.0)  # markers at R, staircase: as on its page
    units = pipe.pipe_lattice_units(cell, params)
    system = pipe.pipe_setup(cell, params, units)
    lattice = pipe.pipe_setup(cell, params, units).lattice  # same channel, no cell
    lattice.set_force_density(None)
    system.advance(10)  # compile / warm
    lattice.step(10)
    chunk = max(steps // repeats, 1)
    with_cell, pure = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        system.advance(chunk)
        with_cell.append((time.perf_counter() - start) / chunk)
        start = time.perf_counter()
        lattice.step(chunk)
        pure.append((time.perf_counter() - start) / chunk)
    with_cell, pure = np.array(with_cell), np.array(pure)
    n = int(np.prod(units.shape))
    fluid = 1.0 - float(lattice.solid.mean())
    out = {"lattice": "x".join(str(v) for v in units.shape), "fluid_fraction": fluid, "markers": cell.mesh.n_nodes,
           "steps": chunk * repeats, "threads": numba.get_num_threads(),
           "MLUPS_pure": n / pure.min() / 1e6, "MLUPS_cell": n / with_cell.min() / 1e6,
           "slowdown_best": with_cell.min() / pure.min(), "slowdown_median": float(np.median(with_cell / pure)),
           "ms/step_pure": 1e3 * pure.min(), "ms/step_cell": 1e3 * with_cell.min()}
    print_table([out], f"Cost of a step in the default channel, best of {repeats} interleaved chunks of {chunk} "
                "steps (all nodes counted; solid nodes are skipped by the kernel)")
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", choices=("poiseuille", "mlups", "reference", "migration"), action="append")
    parser.add_argument("--radii", type=float, nargs="+", default=[4, 6, 8, 12, 16, 24, 32])
    parser.add_argument("--resolution", type=float, default=8.0)
    parser.add_argument("--capillary-number-wall", type=float, default=pipe.DEFAULT_CAPILLARY_NUMBER_WALL)
    parser.add_argument("--duration", type=float, default=8.0, help="reference runs (1/gdot_w)")
    parser.add_argument("--migration-resolution", type=float, default=4.0)
    parser.add_argument("--migration-duration", type=float, default=60.0)
    parser.add_argument("--start-offset", type=float, default=0.25)
    parser.add_argument("--mlups-steps", type=int, default=2000)
    parser.add_argument("--json", type=Path, help="write every figure to this file")
    args = parser.parse_args(argv)
    only = set(args.only or ("poiseuille", "mlups", "reference", "migration"))
    PAGE[:] = [Page("pipe", "pipe.py", intro=(
        "Pressure-driven flow through a cylinder on the lattice (D3Q19, half-way bounce-back on the staircase "
        "wall, tau = 1). The empty channel is measured against the closed form, Poiseuille's profile "
        "u(r) = G (R_ch^2 - r^2)/(4 eta) and its flow rate, over R_ch/dx, with the least-squares order of the "
        "error. With the reference cell (nucleus gamma = 2, lambda = 0.5; R/dx = 8, R_ch/R = 2, uniform p1 mesh with "
        "edges of 2 dx) and its homogeneous equivalent at the same pressure gradient: the stationary strains, "
        "deformation and speed, means over the second half of each run (time in 1/gdot_w). The cost table "
        "times coupled steps against pure lattice Boltzmann in the same channel, interleaved; MLUPS counts all "
        "lattice nodes (solid ones are skipped by the kernel)."), versions=("numba",))]
    PAGE[0].print(f"elastocell {elastocell.__version__}, numba threads {numba.get_num_threads()}")
    results = {}
    if "poiseuille" in only:
        results["poiseuille"] = poiseuille(args.radii)
    if "mlups" in only:
        results["mlups"] = mlups(args.resolution, args.mlups_steps, args.capillary_number_wall)
    if "reference" in only:
        results["reference"] = reference(args.resolution, args.duration, args.capillary_number_wall)
    if "migration" in only:
        results["migration"] = migration(args.migration_resolution, args.migration_duration,
                                         args.capillary_number_wall, args.start_offset)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1, default=float))
    PAGE[0].write()


if __name__ == "__main__":
    main()
