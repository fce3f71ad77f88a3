"""The cell in plane Couette (shear) flow: stationary deformation, inclination and tank treading, and the cost
of a coupled lattice-Boltzmann + immersed-boundary step.

Run::

    python validation/shear.py                      # everything below (about 25 min on 1 thread)
    python validation/shear.py --only split         # per-step cost split and MLUPS (about 1 min)
    python validation/shear.py --only homogeneous --capillary-numbers 0.05 0.1 0.3
    python validation/shear.py --only reference     # nucleus cell (gamma = 2, lambda = 0.5) and equivalent
    python validation/shear.py --only resolution --resolutions 4 6 8

Every run uses the shear settings its page was made with (``ShearFlowParameters`` with tau = 1 pinned, which
were the defaults then: R/dx = 8, confinement 2R/H = 0.2, box 8R, particle Reynolds number 0.1, trilinear kernel) and a uniform p1 mesh with edges of 2 dx
(``shear_mesh_size``). Stationary values are means over strain >= duration/2; the tank-treading
frequency is the r^2-weighted mean angular velocity of the surface nodes about the cell centre over the
same window, in units of the shear rate. Reference (docs/theory.md): D -> (5/4) Ca, 45 deg and 1/2 as Ca -> 0.

The cost split times each part of the coupled step alone, in the same compiled kernels the coupled step
calls (the LB sweep with the force field, the compiled elastic forces, spreading + interpolation), over
many steps; MLUPS = lattice nodes x steps / second. The tables go into docs/validation/shear.md
(``validation/page.py``).
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
from elastocell.coupling import ibm
from elastocell.parameters.flow import shear_mesh_size
from elastocell.scenarios import shear as flow

PINNED = {"relaxation_time": 1.0}
"""tau 1, the shear defaults' before the matched tau (ShearFlowParameters.relaxation_time): this page's runs."""


def make_cell(resolution: float, nucleus: str = "none", element: str = "p1") -> Cell:
    size = shear_mesh_size(resolution)
    return Cell.from_parameters(elastocell.cell_parameters(nucleus=nucleus, element=element, mesh_size=size,
                                                           pole_size=size, interface_size=size))


def run(cell: Cell, ca: float, resolution: float, duration: float, **overrides) -> dict:
    params = flow.ShearFlowParameters(capillary_number=ca, resolution=resolution, **{**PINNED, **overrides})
    start = time.perf_counter()
    result = flow.run_shear(cell, params, duration=duration, record_interval=0.05)
    s = result.summary
    return {
        "Ca": ca,
        "R/dx": resolution,
        "nodes": cell.mesh.n_nodes,
        "D": s["taylor_deformation_mean"],
        "D_std": s["taylor_deformation_std"],
        "D/Ca": s["taylor_deformation_mean"] / ca,
        "incl_deg": s["inclination_deg_mean"],
        "tt_freq": s["tank_treading_frequency"],
        "max|dV/V|": s["volume_change_max_abs"],
        "lattice": "x".join(str(n) for n in result.units.shape),
        "steps": s["steps"],
        "limit": result.units.limiting,
        "wall_s": time.perf_counter() - start,
    }


def cost_split(resolution: float, steps: int = 200) -> list[dict]:
    """Seconds per step of each part of the coupled step, and MLUPS with and without the cell."""
    cell = make_cell(resolution)
    params = flow.ShearFlowParameters(capillary_number=0.1, resolution=resolution, **PINNED)
    units = flow.shear_lattice_units(cell, params)
    system = flow.shear_setup(cell, params, units)
    system.advance(10)  # compile, and a deformed state
    lattice = system.lattice
    n_nodes = int(np.prod(lattice.shape))
    rows = []

    def timed(label, function, repeats=3):
        function()  # warm-up (compilation)
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            function()
            best = min(best, time.perf_counter() - t0)
        per_step = best / steps
        rows.append({"part": label, "ms_per_step": 1e3 * per_step, "MLUPS": n_nodes / per_step / 1e6})

    timed("coupled step (LB + forces + spread + interp + move)", lambda: system.advance(steps))
    timed("LB step alone (with force field)", lambda: lattice.step(steps))
    forces = system.forces
    x = system.positions.copy()
    out = np.empty_like(x)

    def elastic():
        for _ in range(steps):
            forces(x, out)

    timed("elastic forces (compiled)", elastic)
    args = ibm.lattice_arguments(lattice)
    field = lattice.force_density
    velocity = np.empty_like(x)
    kid = ibm.kernel_id(params.kernel)

    def coupling():
        for _ in range(steps):
            ibm._clear_field(x, kid, False, field)
            ibm._spread_field(out, x, kid, False, field)
            ibm._interpolate_populations(*args, x, kid, velocity)

    timed("clear + spread + interpolate", coupling)
    for row in rows:
        row["lattice"] = "x".join(str(n) for n in lattice.shape)
        row["markers"] = cell.mesh.n_nodes
        row["threads"] = numba.get_num_threads()
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", choices=["split", "homogeneous", "reference", "resolution"], nargs="*")
    parser.add_argument("--resolution", type=float, default=flow.ShearFlowParameters.model_fields["resolution"].default)
    parser.add_argument("--resolutions", type=float, nargs="*", default=[4.0, 6.0, 8.0])
    parser.add_argument("--capillary-numbers", type=float, nargs="*", default=[0.05, 0.1, 0.3])
    parser.add_argument("--duration", type=float, default=4.0, help="strain (shear_rate * t) per run")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--json", action="store_true", help="print every table as JSON at the end")
    args = parser.parse_args(argv)
    if args.threads:
        numba.set_num_threads(max(1, min(args.threads, numba.config.NUMBA_NUM_THREADS)))
    parts = args.only or ["split", "homogeneous", "reference"]
    page = Page("shear", "shear.py", intro=(
        "A cell in plane Couette flow (lattice Boltzmann + immersed boundary, uniform p1 mesh with edges of 2 dx, "
        "confinement 2R/H = 0.2, tau = 1, particle Reynolds number 0.1): the stationary Taylor deformation D, the "
        "inclination and the tank-treading frequency (in units of the shear rate), means over strain >= "
        "duration/2. The independent reference is the closed-form small-deformation limit for an unbounded elastic "
        "sphere in Stokes flow (docs/theory.md): D/Ca -> 5/4, inclination -> 45 deg and tank-treading frequency "
        "-> 1/2 as Ca -> 0; the resolution table shows the discretisation's share of the difference at the "
        "smallest Ca. The cost table times each part of the coupled step alone, in the kernels the "
        "coupled step calls; MLUPS = lattice nodes x steps / second."), versions=("numba",))
    tables = {}
    page.print(f"threads: {numba.get_num_threads()}, R/dx = {args.resolution:g}, duration {args.duration:g} strain")
    shear_formats = {"wall_s": ".1f"}
    if "split" in parts:
        tables["split"] = cost_split(args.resolution)
        page.table(tables["split"], f"Cost per coupled step, R/dx = {args.resolution:g}",
                   formats={"ms_per_step": ".3g", "MLUPS": ".3g"})
    if "homogeneous" in parts:
        cell = make_cell(args.resolution)
        rows = []
        for ca in args.capillary_numbers:
            rows.append(run(cell, ca, args.resolution, args.duration))
            print(f"  done homogeneous Ca = {ca:g}: D/Ca = {rows[-1]['D/Ca']:.4g}, {rows[-1]['wall_s']:.0f} s", flush=True)
        tables["homogeneous"] = rows
        page.table(rows, f"Homogeneous cell, R/dx = {args.resolution:g} (reference: D/Ca -> 1.25, 45 deg, 0.5 as "
                   "Ca -> 0)", formats=shear_formats)
    if "reference" in parts:
        cell = make_cell(args.resolution, nucleus="sphere")
        rows = []
        for label, body in (("nucleus (gamma=2, lambda=0.5)", cell), ("homogeneous equivalent", cell.equivalent())):
            row = {"cell": label, "gamma_eff": body.effective_stiffness_ratio}
            row.update(run(body, 0.1, args.resolution, args.duration))
            rows.append(row)
            print(f"  done {label}: D = {row['D']:.4g}, {row['wall_s']:.0f} s", flush=True)
        tables["reference"] = rows
        page.table(rows, "Reference cell and its equivalent at Ca = 0.1 (Ca with mu_c for the nucleus cell, "
                         "mu_eff for the equivalent)", formats=shear_formats)
    if "resolution" in parts:
        rows = []
        for resolution in args.resolutions:
            rows.append(run(make_cell(resolution), args.capillary_numbers[0], resolution, args.duration))
            print(f"  done R/dx = {resolution:g}: D/Ca = {rows[-1]['D/Ca']:.4g}, {rows[-1]['wall_s']:.0f} s",
                  flush=True)
        tables["resolution"] = rows
        page.table(rows, f"Resolution study, homogeneous cell, Ca = {args.capillary_numbers[0]:g}",
                   formats=shear_formats)
    page.write()
    if args.json:
        print(json.dumps(tables))


if __name__ == "__main__":
    main()
