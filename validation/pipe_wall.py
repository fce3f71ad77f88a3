"""The cylinder's wall on the lattice: the staircase (half-way bounce-back on the solid nodes r > R_ch) against the
interpolated wall (linearly interpolated bounce-back with the wall at r = R_ch, Bouzidi et al. 2001;
``PipeFlowParameters.channel_wall``), first on the empty channel against Poiseuille's closed form, then on the
cell against dclab's LE-2D-FEM-19, each cell run both ways at the pipe's defaults.

    nice python validation/pipe_wall.py [--radii 4.3 6.6 10.2 14.6 20.3]
                                        [--points 7.66:3,7.66:4.5,6:2,6:3,5:1.5,6.5:2.5] [--resolution 8]
                                        [--duration 40] [--workers 2] [--out results/pipe-stationary] [--cached-only]

The empty channel: a steady periodic slice of a cylinder of radius R_ch (dx), tau 1, float64, against
u = G (R_ch^2 - r^2)/(4 eta) (scenarios.pipe.poiseuille_error): the flow rate's error and the profile's L2 and
largest errors (units of u_max).

The cost: the lattice step of the 6 um cell's cylinder with each wall, stepped alternately in one process. The
mass: interpolated bounce-back does not conserve it exactly; its drift over the first steps of the 6 um cell's run.

The cell: validation/pipe_stationary.py's runs (a centred homogeneous cell, neo-Hookean, nu 0.48, linear
tetrahedra on the default mesh, LE-2D-FEM-19's cylinder R_ch = 1.094 x 10 um, Q = 0.04 uL/s held, eta = 15 mPa s,
R/dx 8, the markers at R - 0.3 dx, --duration units of 1/gdot_w, D and the area the means over the last unit) with
the same run function, record format and cache (``--out/runs.jsonl``; a run already there is not repeated, so the
staircase runs are pipe_stationary.py's own), and the same reading of the table. The section goes into
docs/validation/pipe_dclab.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page
from pipe_dclab import DRIFT_WINDOW, parse_points
from pipe_flow_rate import e_errors
from pipe_resolution import CHANNEL_RADIUS_UM, cases, key, read, run_missing, with_table
from pipe_stationary import TARGET_PERCENT

WALLS = ("staircase", "interpolated")


def empty_channel_rows(radii: list[float]) -> list[dict]:
    from elastocell.scenarios.pipe import poiseuille_error

    rows = []
    for radius in radii:
        errors = {wall: poiseuille_error(radius, wall=wall) for wall in WALLS}
        rows.append({"R_ch [dx]": radius, **{f"{name} {wall}": 100 * errors[wall][field] for wall in WALLS
                                             for name, field in (("Q err %", "flow_rate_error"),
                                                                 ("L2 err %", "profile_l2_error"),
                                                                 ("max err %", "profile_max_error"))},
                     "L2 ratio": errors["staircase"]["profile_l2_error"] / errors["interpolated"]["profile_l2_error"]})
    return rows


def step_cost_rows(channel_radius: float, length: int, steps: int = 400, repeats: int = 9) -> list[dict]:
    """The lattice step's cost with each wall in one process: the pipe's cylinder of ``channel_radius`` dx over
    ``length`` nodes (float32, tau 1, a body force), the two lattices stepped alternately ``repeats`` times;
    the best time of each."""
    import time

    import numpy as np

    from elastocell.lattice import Lattice, LatticeParams
    from elastocell.scenarios.pipe import channel_shape, channel_solid, channel_wall_fraction

    shape = channel_shape(channel_radius, length)
    solid = channel_solid(shape, channel_radius)
    lattices = {wall: Lattice(LatticeParams(shape, relaxation_time=1.0, solid=solid, body_force=(1e-6, 0, 0),
                                            wall_fraction=channel_wall_fraction("cylinder", wall, shape,
                                                                                channel_radius)))
                for wall in WALLS}
    for lattice in lattices.values():
        lattice.step(2)  # compile
    best = {wall: np.inf for wall in WALLS}
    for _ in range(repeats):
        for wall, lattice in lattices.items():
            start = time.perf_counter()
            lattice.step(steps)
            best[wall] = min(best[wall], (time.perf_counter() - start) / steps)
    fluid = int((~solid).sum())
    return [{"wall": wall, "lattice": "x".join(map(str, shape)), "fluid nodes": fluid,
             "links": lattices[wall]._geometry.n_links, "ms per step": 1e3 * best[wall],
             "MLUPS (fluid)": fluid / best[wall] / 1e6, "cost / staircase": best[wall] / best["staircase"]}
            for wall in WALLS]


def mass_rows(resolution: float, steps: int = 3000) -> list[dict]:
    """The fluid's mass with each wall over ``steps`` coupled steps of the 6 um / 2 kPa cell's run (nu 0.48, Ca_w
    of LE-2D-FEM-19's flow, float32): interpolated bounce-back does not conserve mass exactly (Bouzidi et al.
    2001); the drift per step and over 60 units of 1/gdot_w (half the lut's cap)."""
    from pipe_resolution import FLOW_RATE_UL_S, POISSON_RATIO, VISCOSITY_MPA_S, capillary_number_wall

    from elastocell.body.cell import Cell
    from elastocell.parameters.flow import flow_cell
    from elastocell.scenarios.pipe import PipeFlowParameters, pipe_lattice_units, pipe_setup

    cell = Cell.from_parameters(flow_cell(None, {"nucleus": "none", "poisson_ratio": POISSON_RATIO}, resolution))
    ca_w = capillary_number_wall(FLOW_RATE_UL_S * 1e-9, CHANNEL_RADIUS_UM * 1e-6, VISCOSITY_MPA_S * 1e-3, 2e3,
                                 POISSON_RATIO)
    rows = []
    for wall in WALLS:
        params = PipeFlowParameters(capillary_number_wall=ca_w, resolution=resolution, channel_wall=wall,
                                    channel_radius_ratio=CHANNEL_RADIUS_UM / 6.0)
        units = pipe_lattice_units(cell, params)
        system = pipe_setup(cell, params, units)
        start = system.lattice.total_mass()
        system.advance(steps)
        per_step = (system.lattice.total_mass() / start - 1.0) / steps
        rows.append({"wall": wall, "steps": steps, "dM/M per step": per_step,
                     "dM/M over 60/gdot_w": per_step * 60 * units.steps_per_time})
    return rows


def cell_rows(records: list[dict]) -> list[dict]:
    """One row per cell run both ways: D, its error against the table, and the modulus the table reads."""
    moduli = dict(zip((r["key"] for r in records), e_errors(records) if records else [], strict=True))
    by_cell: dict[tuple, dict] = {}
    for r in records:
        by_cell.setdefault((r["radius_um"], r["emodulus_kpa"]), {})[r.get("wall", "staircase")] = r
    rows = []
    for (radius, modulus), runs in sorted(by_cell.items()):
        row = {"R [um]": radius, "R/R_ch": radius / CHANNEL_RADIUS_UM, "E [kPa]": modulus}
        for wall in WALLS:
            r = runs.get(wall)
            row.update({f"D {wall}": r["deform"] if r else float("nan"),
                        f"D err % {wall}": r["D_err"] if r else float("nan"),
                        f"A err % {wall}": r["A_err"] if r else float("nan"),
                        f"E err % {wall}": moduli[r["key"]] if r else float("nan"),
                        f"D drift %/t {wall}": 100 * r["drift_deformation"] if r else float("nan"),
                        f"reading {wall}": ("hull" if r["fallback_last_unit"] else "outline") if r else ""})
        both = all(wall in runs for wall in WALLS)
        row["D interp/stair"] = (runs["interpolated"]["deform"] / runs["staircase"]["deform"]) if both else float("nan")
        row["wall_s interpolated"] = runs["interpolated"]["wall_s"] if "interpolated" in runs else float("nan")
        rows.append(row)
    return rows


def summary(rows: list[dict]) -> list[str]:
    lines = []
    for wall in WALLS:
        read_ok = [r for r in rows if r[f"reading {wall}"] == "outline"]
        if not read_ok:
            continue
        errors = [r[f"D err % {wall}"] for r in read_ok]
        met = sum(abs(r[f"D err % {wall}"]) <= TARGET_PERCENT and abs(r[f"A err % {wall}"]) <= TARGET_PERCENT
                  for r in read_ok)
        lines.append(f"{wall}: D err {min(errors):+.1f} to {max(errors):+.1f} % (mean |D err| "
                     f"{sum(abs(e) for e in errors) / len(errors):.1f} %), D and A within {TARGET_PERCENT:g} % at "
                     f"{met} of {len(read_ok)} cells read on the outline")
    ratios = [r["D interp/stair"] for r in rows if r["D interp/stair"] == r["D interp/stair"]]
    if ratios:
        lines.append(f"D interpolated / D staircase: {min(ratios):.3f} to {max(ratios):.3f} over {len(ratios)} cells")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--radii", type=float, nargs="+", default=[4.3, 6.6, 10.2, 14.6, 20.3],
                        help="empty-channel radii R_ch (dx)")
    parser.add_argument("--points", default="7.66:3,7.66:4.5,6:2,6:3,5:1.5,6.5:2.5", help="R:E,R:E (um, kPa)")
    parser.add_argument("--resolution", type=float, default=8.0, help="R/dx")
    parser.add_argument("--duration", type=float, default=40.0, help="units of 1/gdot_w")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/pipe-stationary"))
    parser.add_argument("--cached-only", action="store_true")
    args = parser.parse_args()
    todo = [{**c, "hold": True, **({} if wall == "staircase" else {"wall": wall})}
            for wall in WALLS for point in parse_points(args.points)
            for c in cases(point, [args.resolution], [0.3], args.duration, meshes=False)]
    page = Page("pipe_dclab", "pipe_wall.py", versions=("dclab", "numba"))
    if not args.cached_only:
        run_missing(todo, args.out, args.workers)
    channel = empty_channel_rows(args.radii)
    cost = step_cost_rows(CHANNEL_RADIUS_UM / 6.0 * args.resolution, int(round(8 * args.resolution)))
    mass = mass_rows(args.resolution)
    cached = {r["key"]: r for r in read(args.out / "runs.jsonl")}
    records = with_table([cached[key(c)] for c in todo if key(c) in cached])
    rows = cell_rows(records)
    page.intro = (
        "The cylinder's wall on the lattice: `staircase` (half-way bounce-back on the solid nodes r > R_ch, the "
        "pipe's wall before the choice existed; `elastocell pipe --channel-wall staircase`) against `interpolated` "
        "(linearly interpolated bounce-back with the wall at r = R_ch on every link, Bouzidi et al. 2001; the "
        "pipe's default, chosen on these measurements). First the empty channel, "
        "a steady periodic slice at tau 1 in float64, against Poiseuille's closed form (Q err: the flow rate; L2 "
        "and max err: the profile, relative to the closed form's L2 norm and to u_max). Then the cell of "
        f"validation/pipe_stationary.py (nu 0.48, linear tetrahedra, LE-2D-FEM-19's cylinder R_ch = "
        f"{CHANNEL_RADIUS_UM:.2f} um, Q = 0.04 uL/s held, eta = 15 mPa s, R/dx {args.resolution:g}, markers at "
        f"R - 0.3 dx, {args.duration:g} units of 1/gdot_w, D and the area the means over the last unit) run both "
        "ways; D err, A err and E err read against the table as on that section, D drift the slope of D over the "
        f"last {DRIFT_WINDOW:g} units, `reading` whether the last unit was read on the smooth outline or partly "
        f"on the nodes' hull. {len(records)} of {len(todo)} runs; wall_s is each run's own wall time (runs two to "
        "four at a time on the 2-core machine).")
    page.table(channel, "The empty cylinder against Poiseuille's closed form", formats={
        "R_ch [dx]": "g", **{f"{n} {w}": ".3f" for n in ("Q err %", "L2 err %", "max err %") for w in WALLS},
        "L2 ratio": ".1f"})
    page.table(cost, "The lattice step's cost with each wall: the cylinder of the 6 um cell's runs (R_ch = "
               f"{CHANNEL_RADIUS_UM / 6.0 * args.resolution:.2f} dx, a box of 8 R), float32, one process stepping the "
               "two lattices alternately, best of nine times 400 steps, the machine's threads", formats={
                   "ms per step": ".3f", "MLUPS (fluid)": ".1f", "cost / staircase": ".3f"})
    page.table(mass, "The fluid's mass with each wall: the 6 um / 2 kPa cell's run at R/dx "
               f"{args.resolution:g} (float32), the relative change per step over its first steps, and that rate "
               "over 60 units of 1/gdot_w (half the lut's cap)", formats={"dM/M per step": ".2e",
                                                                      "dM/M over 60/gdot_w": ".2e"})
    if rows:
        page.table(rows, f"The cell at t = {args.duration:g}/gdot_w against LE-2D-FEM-19, both walls", formats={
            "R [um]": "g", "R/R_ch": ".3f", "E [kPa]": "g", "D interp/stair": ".3f", "wall_s interpolated": ".0f",
            **{f"{n} {w}": f for w in WALLS for n, f in (("D", ".4f"), ("D err %", "+.1f"), ("A err %", "+.1f"),
                                                          ("E err %", "+.1f"), ("D drift %/t", "+.2f"))}})
        for line in summary(rows):
            page.print(line)
    missing = [key(c) for c in todo if key(c) not in cached]
    if missing:
        page.print("Not run (no record in the cache): " + ", ".join(missing))
    page.write()


if __name__ == "__main__":
    main()
