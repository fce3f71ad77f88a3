"""Compression benchmark: accuracy and cost of a full curve against mesh size and element order, and the
same problem solved by FElupe (a peer FE code, if installed) in the same run.

    python validation/compression.py [--cell homogeneous|reference] [--quick] [--no-peer]
        [--meshes p2:0.3:0.06:0.15 ...] [--reference-forces F0.1 F0.3 F0.5 F0.7] [--peer-one-blas-thread]

For each mesh: nodes, wall time of a full curve (0 -> 0.75, 40 steps; meshes and compiled code cached, i.e.
a warm-up run first), Newton iterations, factorisations, and F at delta = 0.1, 0.3, 0.5, 0.7 with its error
against the finest p2 mesh (the mesh-converged reference; its own error is estimated from the next-finest).
Prints a table and writes it into docs/validation/compression.md (``validation/page.py``); timings are
measurements of this machine, never asserted. ``--meshes`` runs only the given
meshes (``element:mesh_size:pole_size[:interface_size[:pole_radius]]``, ``-`` for no interface refinement and
for the default pole grading; the interface size applies to the reference cell's nucleus surface) and ``--reference-forces`` takes the converged F at the four deltas from
an earlier full run instead of the finest mesh of this one (then every p2 mesh also runs on the peer).
"""

from __future__ import annotations

import argparse
import contextlib
import time

import numpy as np
from page import Page
from threadpoolctl import ThreadpoolController

from elastocell.body.cell import Cell
from elastocell.parameters.cell import cell_parameters
from elastocell.scenarios.compression import CompressionParameters, compress

DELTAS = np.array([0.1, 0.3, 0.5, 0.7])
MESHES = [  # (element, mesh_size, pole_size, interface_size, pole_radius; None: default grading)
    ("p1", 0.2, 0.05, None, None),
    ("p1", 0.12, 0.04, None, None),
    ("p2", 0.5, 0.12, 0.21, None),
    ("p2", 0.35, 0.08, 0.15, None),
    ("p2", 0.25, 0.06, 0.11, None),
    ("p2", 0.15, 0.04, 0.075, 0.9),
]
QUICK_MESHES = [("p1", 0.3, 0.08, None, None), ("p2", 0.5, 0.15, 0.25, None), ("p2", 0.35, 0.1, 0.2, None),
                ("p2", 0.25, 0.06, 0.125, None)]


def run(element: str, mesh_size: float, pole_size: float, interface_size: float | None, pole_radius: float | None,
        cell_kind: str, steps: int) -> dict:
    options = dict(element=element, mesh_size=mesh_size, pole_size=pole_size, pole_radius=pole_radius,
                   interface_size=mesh_size if interface_size is None else interface_size)
    if cell_kind == "homogeneous":
        options["nucleus"] = "none"
    cell = Cell.from_parameters(cell_parameters(**options))
    params = CompressionParameters(delta_max=0.75, steps=steps)
    compress(cell, CompressionParameters(delta_max=0.02, steps=1))  # compile (cached afterwards)
    start = time.perf_counter()
    result = compress(cell, params)
    seconds = time.perf_counter() - start
    return {
        "element": element, "mesh_size": mesh_size, "pole_size": pole_size,
        "interface_size": cell.parameters.mesh.interface_size or mesh_size, "nodes": cell.mesh.n_nodes,
        "seconds": seconds, "newton": result.newton_iterations, "factorisations": result.factorisations,
        "force": np.interp(DELTAS, result.delta, result.force), "curve": (result.delta, result.force),
    }


def _mesh_spec(text: str) -> tuple[str, float, float, float | None, float | None]:
    """``element:h:h_pole[:h_interface[:pole_radius]]`` (``-`` or absent: no interface refinement, default
    grading)."""
    parts = text.split(":") + ["-", "-"]
    interface = float(parts[3]) if parts[3] != "-" else None
    radius = float(parts[4]) if parts[4] != "-" else None
    return parts[0], float(parts[1]), float(parts[2]), interface, radius


def richardson(h: list[float], forces: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(observed order p, extrapolated F) per delta from three meshes F(h) = F* + C h^p, h decreasing. Where
    the differences change sign or p leaves [0.5, 4] (not asymptotic), p is NaN and F* the finest value."""
    h1, h2, h3 = h
    if not h1 > h2 > h3:
        return np.full(len(forces[0]), np.nan), np.asarray(forces[2], dtype=float)
    f1, f2, f3 = (np.asarray(f, dtype=float) for f in forces)
    orders, limits = [], []
    for a, b, c in zip(f1, f2, f3, strict=True):
        ratio = (a - b) / (b - c) if b != c else np.nan

        def mismatch(p, ratio=ratio):
            return (h1**p - h2**p) / (h2**p - h3**p) - ratio

        low, high = 0.5, 4.0
        if not (ratio > 0 and mismatch(low) * mismatch(high) < 0):
            orders.append(np.nan)
            limits.append(c)
            continue
        for _ in range(60):
            middle = 0.5 * (low + high)
            low, high = (middle, high) if mismatch(low) * mismatch(middle) > 0 else (low, middle)
        p = 0.5 * (low + high)
        orders.append(p)
        limits.append(c - (b - c) * h3**p / (h2**p - h3**p))
    return np.array(orders), np.array(limits)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--cell", choices=["homogeneous", "reference"], default="homogeneous")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--no-peer", action="store_true")
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--meshes", nargs="+", metavar="ELEMENT:H:H_POLE[:H_INTERFACE]")
    parser.add_argument("--reference-forces", nargs=4, type=float, metavar="F")
    parser.add_argument("--peer-one-blas-thread", action="store_true",
                        help="run FElupe with OpenBLAS on one thread, as elastocell's compress runs")
    args = parser.parse_args()
    meshes = QUICK_MESHES if args.quick else MESHES
    if args.meshes:
        meshes = [_mesh_spec(m) for m in args.meshes]
    if not args.reference_forces and sum(m[0] == "p2" for m in meshes) < 2:
        parser.error("need two p2 meshes (the finest is the reference) or --reference-forces")
    page = Page("compression", "compression.py", intro=(
        f"F/(E R^2) of the {args.cell} cell (nu = 0.48, neo-Hookean) between rigid frictionless plates, one full "
        f"curve to delta = 0.75 in {args.steps} load steps per mesh, against mesh size and element order. Errors "
        "are against the finest p2 mesh of the same run (or the forces given by `--reference-forces`) and, where "
        "the three finest p2 meshes show an asymptotic order, against their Richardson limit. The independent "
        "reference is FElupe, a peer finite-element code solving the same problem in the same run (same "
        "energy, quadratic tetrahedra on its own gmsh mesh from the same size parameters, penalty contact, "
        "PARDISO; `validation/felupe_peer.py`), with the time each code needs for equal accuracy. Times are "
        "per curve after a warm-up (compiled code and meshes cached)."), versions=("felupe", "pypardiso"))
    rows = []
    for element, mesh_size, pole_size, interface_size, pole_radius in meshes:
        row = run(element, mesh_size, pole_size, interface_size, pole_radius, args.cell, args.steps)
        rows.append(row)
        print(f"  done {element} h={mesh_size} hp={pole_size} hi={row['interface_size']}: {row['nodes']} nodes, "
              f"{row['seconds']:.1f} s", flush=True)
    quadratic = [r for r in rows if r["element"] == "p2"]
    page.heading(f"Compression, {args.cell} cell, {args.steps} steps to delta 0.75")
    if args.reference_forces:
        reference = {"force": np.array(args.reference_forces), "nodes": None}
        page.print("reference: F = " + ", ".join(f"{f:g}" for f in reference["force"]) + " (given)")
    else:
        reference = max(quadratic, key=lambda r: r["nodes"])
        second = sorted(quadratic, key=lambda r: r["nodes"])[-2]
        ref_error = np.abs(second["force"] / reference["force"] - 1)
        page.print(f"reference: p2 {reference['nodes']} nodes, F = " + ", ".join(f"{f:.6g}" for f in reference["force"])
                   + "; its next-finest differs by " + ", ".join(f"{e:.2%}" for e in ref_error) + " at delta "
                   + ", ".join(f"{d:g}" for d in DELTAS))
        finest = sorted(quadratic, key=lambda r: r["nodes"])[-3:]
        if len(finest) == 3:
            order, limit = richardson([r["nodes"] ** (-1 / 3) for r in finest], [r["force"] for r in finest])
            # h ~ nodes^(-1/3) assumes similar gradings; where no asymptotic order shows, "n/a"
            page.print("Richardson extrapolation of the three finest p2 meshes (h ~ nodes^(-1/3)): order "
                       + ", ".join(f"{p:.2f}" for p in order) + "; finest mesh against the limit "
                       + ", ".join("n/a" if np.isnan(p) else f"{e:+.2%}"
                                   for p, e in zip(order, reference["force"] / limit - 1, strict=True)))
            page.print("errors against the extrapolated limit: "
                       + "; ".join(f"{r['element']} {r['nodes']} nodes " + " ".join(f"{e:+.2%}" for e in r["force"] / limit - 1)
                                   for r in rows))
    error_columns = [f"err@{d:g}" for d in DELTAS]
    page.table([{"element": r["element"], "h": r["mesh_size"], "h_pole": r["pole_size"], "h_int": r["interface_size"],
                 "nodes": r["nodes"], "time_s": r["seconds"], "newton": r["newton"], "factor": r["factorisations"],
                 **dict(zip(error_columns, r["force"] / reference["force"] - 1, strict=True))} for r in rows],
               formats={"time_s": ".1f", **{c: "+.2%" for c in error_columns}})
    if args.no_peer or args.cell != "homogeneous":
        page.write()
        return
    try:
        from felupe_peer import felupe_compression_curve
    except Exception as error:  # pragma: no cover - optional peer
        page.print(f"FElupe peer skipped: {error}")
        page.write()
        return
    peer_rows, peer_table = [], []
    peer_meshes = [m for m in meshes if m[0] == "p2"]
    for _, mesh_size, pole_size, _, _ in (peer_meshes if args.reference_forces else peer_meshes[:-1]):
        try:
            with (ThreadpoolController().select(internal_api="openblas").limit(limits=1)
                  if args.peer_one_blas_thread else contextlib.nullcontext()):
                peer = felupe_compression_curve(mesh_size, pole_size, delta_max=0.75, n_steps=args.steps)
        except Exception as error:  # pragma: no cover
            peer_table.append({"h": mesh_size, "h_pole": pole_size, "nodes": f"failed: {error}"})
            continue
        force = np.interp(DELTAS, peer["delta"], peer["force_per_E_R2"], right=np.nan)
        errors = force / reference["force"] - 1
        peer_rows.append((peer["wall_time_s"], np.max(np.abs(np.nan_to_num(errors, nan=np.inf)))))  # early stop: no match
        peer_table.append({"h": mesh_size, "h_pole": pole_size, "nodes": peer["n_nodes"], "time_s": peer["wall_time_s"],
                           **dict(zip(error_columns, errors, strict=True))})
        print(f"  done FElupe h={mesh_size} hp={pole_size}: {peer['n_nodes']} nodes, {peer['wall_time_s']:.1f} s",
              flush=True)
    page.table(peer_table, "FElupe (same problem: full ball, quadratic tets, rigid-plate contact, PARDISO"
               + ("; OpenBLAS on one thread)" if args.peer_one_blas_thread else ")"),
               formats={"time_s": ".1f", **{c: "+.2%" for c in error_columns}})
    ours = [(r["seconds"], np.max(np.abs(r["force"] / reference["force"] - 1))) for r in quadratic if r is not reference]
    if peer_rows and ours:
        equal = []
        for target in (0.03, 0.02, 0.01, 0.005):
            t_ours = min((t for t, e in ours if e <= target), default=np.nan)
            t_peer = min((t for t, e in peer_rows if e <= target), default=np.nan)
            equal.append({"max error <=": f"{target:.1%}", "elastocell_s": t_ours, "FElupe_s": t_peer,
                          "FElupe / elastocell": t_peer / t_ours})
        page.table(equal, "Time at equal accuracy (largest error over the four deltas; nan: no mesh of this run "
                   "reaches it)", formats={"elastocell_s": ".1f", "FElupe_s": ".1f", "FElupe / elastocell": ".2f"})
    page.write()

if __name__ == "__main__":
    main()
