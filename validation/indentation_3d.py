"""A bead (rigid sphere, radius R_b = 0.5 R) indenting the suspended cell on a dish with the 3D solver
(:mod:`elastocell.scenarios.indentation_3d`, the tetrahedral cell of ``elastocell compress``), the path
``elastocell indent`` takes for a cell that is not axisymmetric.

    nice python validation/indentation_3d.py [--quick] [--fresh]

1. Against the axisymmetric solver (homogeneous, nu = 0.48, depth to 0.3 R in 6 steps): F(depth) of the 3D
   solver on indent's 3D default mesh (compression's with the size at the poles, both contacts, times
   ``POLE_SIZE_FACTOR_3D`` and the pole radius ``POLE_RADIUS_3D``), with compression's pole radius, with
   compression's mesh x 0.8 and the default's poles (a similar node count, compression's pole radius), with the poles x 0.5, on compression's default mesh and on compression's mesh with every size x 1.4, over
   the axisymmetric solver's on the meridian mesh with every size x 0.7 (its own refinement error,
   docs/validation/indentation.md, is far below these), and the axisymmetric default beside them. The same for a centred nucleus (gamma 5, lambda 0.5), which
   both solvers can run, and the two defaults for gamma 2 and 10.
2. Small depth (0.01 and 0.02 R): indent's 3D default mesh against Hertz's two contacts in series (bead on cell with
   R_eff = R_b R/(R_b + R), cell on dish).
3. Cells only the 3D solver can run, to depth 0.3 R, on indent's 3D default mesh: a nucleus (gamma 5, lambda 0.5) offset 0.2 R along x, and
   the random cell (gamma_i ~ U[1, 10] per element, seed 0). The check: the elastic energy W is E times a
   function of the deformation (neo-Hookean, fixed nu), and the feasible set (outside the dish and the bead)
   does not depend on the moduli, so the minimum energy at a given depth is monotone in every element's modulus:
   W_hom(E_c) <= W <= W_hom(E_max) = gamma_max W_hom(E_c), with W_hom the homogeneous cell's on the same mesh.
   The force ratios F/F_hom and (F/E_eff)/F_hom are reported beside it, and the offset nucleus against the
   centred one (axisymmetric solver, same gamma and lambda), and the largest rigid-mode pin reaction over F.

Curves are kept in the cache directory (``validation-indentation-3d/``); ``--fresh`` recomputes. Wall times were
measured on a machine shared with other work. Writes its section of docs/validation/indentation.md
(``validation/page.py``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from page import Page

# jax's compilation cache tries ``from compression import zstd`` (Python 3.14's module): this directory's
# compression.py must not answer it
sys.path[:] = [entry for entry in sys.path if Path(entry or ".").resolve() != Path(__file__).resolve().parent]

from elastocell.body.axisymmetric import MeridianMeshParameters  # noqa: E402
from elastocell.body.cell import Cell  # noqa: E402
from elastocell.files import cache_directory, parameter_hash  # noqa: E402
from elastocell.parameters.cell import cell_parameters  # noqa: E402
from elastocell.scenarios.axisymmetric import hertz_sphere_indentation_force  # noqa: E402
from elastocell.scenarios.compression import compression_parameters_for  # noqa: E402
from elastocell.scenarios.indentation import POLE_RADIUS_3D, POLE_SIZE_FACTOR_3D, indentation_curve  # noqa: E402
from elastocell.scenarios.indentation_3d import Indentation3DError, indent_3d  # noqa: E402

NU = 0.48
BEAD = 0.5
DEPTH, STEPS = 0.3, 6
COMPARED = np.array([0.05, 0.1, 0.2, 0.3])
NUCLEUS = {"nucleus": "sphere", "stiffness_ratio": 5.0, "size_ratio": 0.5}
FORMAT = 2
"""Version of the cached curves (2: a p2 surface corner among pressed mid-side nodes stays in contact)."""
POLES = POLE_SIZE_FACTOR_3D  # the 3D indentation's default: compression's mesh with the poles this much finer
POLE_RADIUS = POLE_RADIUS_3D  # and its pole refinement reaching this far (compression's: 1.4)
EVEN = 0.8  # compression's mesh this much finer, poles as the default's: about the default's node count


def curve_3d(options: dict, depth: float, steps: int, scale: float = 1.0, fresh: bool = False,
             pole_scale: float = 1.0, pole_radius: float | None = None) -> dict:
    """The 3D curve (depth, force, energy per row, pin reaction, nodes, seconds, note), cached; the default mesh
    with every size times ``scale``, the poles' times ``pole_scale`` more, the pole radius ``pole_radius``
    (None: compression's)."""
    default = cell_parameters().mesh  # the 3D default mesh, every size times ``scale``
    more = {} if pole_scale == 1.0 else {"pole_scale": pole_scale}
    if pole_radius is not None:
        more["pole_radius"] = pole_radius
    key = parameter_hash(options, {"depth": depth, "steps": steps, "scale": scale, "bead": BEAD, **more,
                                   "mesh": default.model_dump(mode="json")}, format_version=FORMAT)
    path = cache_directory() / "validation-indentation-3d" / f"{key}.npz"
    if path.exists() and not fresh:
        data = np.load(path)
        return {name: data[name] for name in data.files} | {"note": str(data["note"])}
    # the nucleus surface's size follows mesh_size in proportion (cell_parameters)
    parameters = compression_parameters_for(cell_parameters(**options, mesh_size=default.mesh_size * scale,
                                                            pole_size=default.pole_size * scale * pole_scale,
                                                            pole_radius=pole_radius))
    cell = Cell.from_parameters(parameters)
    start = time.perf_counter()
    note = ""
    try:
        result = indent_3d(cell, BEAD, depth, steps)
    except Indentation3DError as error:
        result, note = error.partial, str(error)
    seconds = time.perf_counter() - start
    data = {"depth": result.load, "force": result.force, "support": result.force_support,
            "energy": np.array([cell.energy(x) for x in result.positions]),
            "reaction": result.max_rigid_reaction, "nodes": np.array(cell.mesh.n_nodes),
            "iterations": np.array(result.newton_iterations), "seconds": np.array(seconds),
            "gamma_eff": np.array(cell.effective_stiffness_ratio), "gamma_max": np.array(cell.youngs_moduli.max()),
            "note": np.array(note)}
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, **data)
    print(f"3D {options} scale {scale}: {seconds:.0f} s, {int(data['nodes'])} nodes {note}", flush=True)
    return {name: value for name, value in data.items()} | {"note": note}


def curve_axisymmetric(options: dict, scale: float) -> tuple[np.ndarray, np.ndarray]:
    mesh = MeridianMeshParameters().scaled(scale)
    result = indentation_curve(cell_parameters(**options), "sphere", BEAD, depth_max=DEPTH, steps=STEPS, mesh=mesh)
    return result.load, result.force


def at(curve: dict, depth: float) -> float:
    return float(np.interp(depth, curve["depth"], curve["force"])) if curve["depth"][-1] >= depth - 1e-9 else np.nan


def against_axisymmetric(page: Page, fresh: bool, quick: bool) -> None:
    rows = []
    cells = {"homogeneous": {"nucleus": "none"}} if quick else {
        "homogeneous": {"nucleus": "none"}, "centred nucleus (gamma 2, lambda 0.5)": {**NUCLEUS, "stiffness_ratio": 2.0},
        "centred nucleus (gamma 5, lambda 0.5)": NUCLEUS,
        "centred nucleus (gamma 10, lambda 0.5)": {**NUCLEUS, "stiffness_ratio": 10.0}}
    for name, options in cells.items():
        truth_depth, truth = curve_axisymmetric(options, 0.7)
        axi_depth, axi = curve_axisymmetric(options, 1.0)
        variants = [(f"3D indent default (compress's, poles x {POLES:g}, pole radius {POLE_RADIUS:g})", 1.0, POLES,
                     POLE_RADIUS),
                    (f"3D compress's poles x {POLES:g} (pole radius 1.4)", 1.0, POLES, None),
                    (f"3D compress's mesh x {EVEN:g}, poles x {POLES:g} (pole radius 1.4)", EVEN, POLES / EVEN, None),
                    ("3D compress's poles x 0.5", 1.0, 0.5, None),
                    ("3D compress's default mesh", 1.0, 1.0, None), ("3D compress's mesh x 1.4", 1.4, 1.0, None)]
        if "gamma 2" in name or "gamma 10" in name:  # the defaults only
            variants = variants[:2]
        for label, scale, pole_scale, pole_radius in variants:
            if quick and scale == 1.0 and pole_scale in (1.0, 0.5):
                continue
            curve = curve_3d(options, DEPTH, STEPS, scale, fresh, pole_scale, pole_radius)
            row = {"cell": name, "curve": label, "nodes": int(curve["nodes"]), "seconds": float(curve["seconds"]),
                   "max pin reaction / F": float(curve["reaction"].max())}
            for depth in COMPARED:
                row[f"error at {depth:g}"] = at(curve, depth) / np.interp(depth, truth_depth, truth) - 1
            row["note"] = curve["note"]
            rows.append(row)
        rows.append({"cell": name, "curve": "axisymmetric default", **{
            f"error at {depth:g}": np.interp(depth, axi_depth, axi) / np.interp(depth, truth_depth, truth) - 1
            for depth in COMPARED}})
        rows.append({"cell": name, "curve": "truth F/(E_c R^2): axisymmetric x 0.7", **{
            f"error at {depth:g}": np.interp(depth, truth_depth, truth) for depth in COMPARED}})
    page.table(rows, "3D solver over the axisymmetric solver on its fine meridian mesh (error = F/F_truth - 1; the "
                     "last row of each cell is the truth itself, F/(E_c R^2)); R_b = 0.5 R")


def hertz(page: Page, fresh: bool, quick: bool) -> None:
    scale = 1.4 if quick else 1.0
    curve = curve_3d({"nucleus": "none"}, 0.02, 2, scale, fresh, POLES, POLE_RADIUS)
    rows = [{"depth / R": depth, "F/(E_c R^2)": force, "F/F_Hertz in series": force /
             hertz_sphere_indentation_force(depth, BEAD, NU), "dish force / F": support / force}
            for depth, force, support in zip(curve["depth"][1:], curve["force"][1:], curve["support"][1:], strict=True)]
    page.table(rows, f"3D solver, homogeneous, indent's 3D default mesh x {scale:g} ({int(curve['nodes'])} nodes), against Hertz's two "
                     "contacts in series")


def heterogeneous(page: Page, fresh: bool, quick: bool) -> None:
    scale = 1.4 if quick else 1.0
    homogeneous = curve_3d({"nucleus": "none"}, DEPTH, STEPS, scale, fresh, POLES, POLE_RADIUS)
    centred_depth, centred = curve_axisymmetric(NUCLEUS, 1.0)
    cells = {"nucleus offset 0.2 R along x (gamma 5, lambda 0.5)": {**NUCLEUS, "offset": 0.2, "offset_axis": "x"},
             "random cell (U[1, 10], seed 0)": {"random": True, "seed": 0}}
    rows = []
    for name, options in cells.items():
        curve = curve_3d(options, DEPTH, STEPS, scale, fresh, POLES, POLE_RADIUS)
        n = min(len(curve["depth"]), len(homogeneous["depth"]))
        for index in range(1, n):
            depth = float(curve["depth"][index])
            energy_ratio = curve["energy"][index] / homogeneous["energy"][index]
            force_ratio = curve["force"][index] / homogeneous["force"][index]
            row = {"cell": name, "depth / R": depth, "W / W_hom": energy_ratio,
                   "bounds [1, gamma_max]": f"[1, {float(curve['gamma_max']):g}]",
                   "within": bool(1 <= energy_ratio <= float(curve["gamma_max"])), "F / F_hom": force_ratio,
                   "F / (E_eff F_hom)": force_ratio / float(curve["gamma_eff"]),
                   "pin reaction / F": float(curve["reaction"][index])}
            if "offset" in options:
                row["F / F_centred (axisym.)"] = curve["force"][index] / np.interp(depth, centred_depth, centred)
            rows.append(row)
        if curve["note"]:
            page.print(f"{name}: {curve['note']}")
        page.print(f"{name}: {int(curve['nodes'])} nodes, E_eff/E_c = {float(curve['gamma_eff']):.4f}, "
                   f"{float(curve['seconds']):.0f} s")
    page.table(rows, f"Cells only the 3D solver runs (indent's 3D default mesh x {scale:g}) against the homogeneous cell on the same "
                     "mesh: energy bounds, force ratios, pin reactions")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="coarser meshes only (a smoke run, not the page)")
    parser.add_argument("--fresh", action="store_true", help="recompute the cached curves")
    parser.add_argument("--only", nargs="*", default=["axisymmetric", "hertz", "heterogeneous"])
    args = parser.parse_args()
    page = Page("indentation", "indentation_3d.py", intro=(
        "The suspended cell (the 3D tetrahedral mesh of compression, p2) on a frictionless dish under a bead of "
        "R_b = 0.5 R on the axis, exact frictionless contact (active set in the nodes' local frames, no penalty), "
        "rigid modes held as in compression. Depth: the bead's displacement after first contact; F/(E_c R^2)."))
    for name, section in (("axisymmetric", against_axisymmetric), ("hertz", hertz),
                          ("heterogeneous", heterogeneous)):
        if name in args.only:
            section(page, args.fresh, args.quick)
            if not args.quick:
                page.write()  # what is measured so far is on the page


if __name__ == "__main__":
    main()
