"""The axisymmetric solver as the truth for compression between plates: its own mesh refinement, and the 3D
defaults against it for every stiffness ratio (FElupe's axisymmetric mode on the same problem:
validation/felupe_axisymmetric.py).

    python validation/axisymmetric.py [--only refinement peer three-d] [--ratios 1 2 5 10 20]
        [--fill-cache] [--fresh]

By default the page section holds the refinement and the peer line; the 3D defaults against this truth are
validation/stiff_mesh.py's section (each in a new process), the error budget of the earlier default mesh for a
stiff nucleus validation/stiff_3d.py's.

- refinement: ``compress_axisymmetric`` on the default meridian mesh with every size times each of ``--scales``
  (default 2, 1, 0.7, 0.5), for the homogeneous cell and the concentric nucleus of size ratio 0.5 and stiffness
  ratio 2, 5, 10, 20; F at delta 0.1, 0.3, 0.5, 0.7 against the finest mesh, and where a curve stopped, the
  smallest J of its last row and where it is; with three meshes or more, Richardson's estimate of the finest
  mesh's own error (the order observed on the three finest).
- three-d: ``elastocell.compress`` on its defaults (``compression_parameters_for``: p2, and the refined mesh
  and the rule with the nodes from ``NODAL_RULE_FROM_STIFFNESS_RATIO``, 5.5) against the finest axisymmetric curve, per stiffness ratio.
- peer: a pointer to validation/felupe_axisymmetric.py, which runs FElupe's axisymmetric mode beside
  ``compress_axisymmetric`` (its own section of the page).

The 3D curves cost minutes each; they are kept in the cache directory (``elastocell.files.cache_directory``,
``validation-axisymmetric/``) under the hash of the resolved cell parameters and the load steps, so that a rerun
takes them from there (``--fresh`` recomputes; ``--fill-cache`` computes the missing ones and writes no page, to
run in the background; ``--cached-only`` lists a curve not in the cache as not run).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from page import Page

from elastocell.body.cell import Cell

# isort: split
# body.cell imports JAX first: JAX tries `from compression import zstd`, which finds validation/compression.py,
# whose `from elastocell.body.cell import Cell` then fails as an ImportError JAX expects (the module is half
# imported); another elastocell module first would make it a circular import of JAX itself
from elastocell.body.axisymmetric import AxisymmetricCell, MeridianMeshParameters
from elastocell.files import cache_directory, parameter_hash, write_json
from elastocell.parameters.cell import cell_parameters
from elastocell.scenarios.axisymmetric import AxisymmetricError, compress_axisymmetric
from elastocell.scenarios.compression import (
    CompressionError,
    CompressionParameters,
    compress,
    compression_parameters_for,
)
from elastocell.simulation.extrapolation import richardson

DELTAS = np.array([0.1, 0.3, 0.5, 0.7])
ERRORS = [f"err@{d:g}" for d in DELTAS]
RATIOS = [1, 2, 5, 10, 20]
STEPS = 40
DELTA_MAX = 0.75
CACHE_FORMAT = 2
"""Version of the cached 3D curves (2: a p2 surface corner among pressed mid-side nodes stays in contact)."""
AXISYMMETRIC_CACHE_FORMAT = 2
"""Version of the cached axisymmetric curves (2: a pole on a plate stays in contact while its neighbour is)."""
def cell_options(ratio: float, **changes) -> dict:
    """The options of the cell of stiffness ratio ``ratio`` (1: the homogeneous cell) with size ratio 0.5."""
    options = {"nucleus": "none"} if ratio == 1 else {"stiffness_ratio": ratio, "size_ratio": 0.5}
    return {**options, **changes}


def _cache_path(cell, steps: int):
    key = parameter_hash(cell, {"delta_max": DELTA_MAX, "steps": steps}, format_version=CACHE_FORMAT)[:20]
    return cache_directory() / "validation-axisymmetric" / f"3d-{key}.json"


def three_d_curve(options: dict, fresh: bool = False, steps: int = STEPS, cached_only: bool = False) -> dict | None:
    """The 3D curve of ``elastocell.compress``'s defaults for the cell of ``options`` (from the cache unless
    ``fresh``; None when ``cached_only`` and not cached): delta, force (E_c R^2), nodes, seconds, the delta
    reached and the error message if it stopped."""
    cell = compression_parameters_for(cell_parameters(**options))
    path = _cache_path(cell, steps)
    if path.exists() and not fresh:
        return json.loads(path.read_text())
    if cached_only:
        return None
    body = Cell.from_parameters(cell)
    start = time.perf_counter()
    try:
        result, error = compress(body, CompressionParameters(delta_max=DELTA_MAX, steps=steps)), ""
    except CompressionError as failure:
        result, error = failure.partial, str(failure)
    record = {"options": options, "delta": result.delta.tolist(), "force": result.force.tolist(),
              "nodes": body.mesh.n_nodes, "seconds": time.perf_counter() - start, "error": error,
              "quadrature_degree": cell.mesh.quadrature_degree}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record


def axisymmetric_curve(options: dict, scale: float, fresh: bool = False, steps: int = STEPS,
                       cached_only: bool = False) -> dict | None:
    """The curve of ``compress_axisymmetric`` for the cell of ``options`` on the default meridian mesh with every
    size times ``scale`` (cached as the 3D curves; None when ``cached_only`` and not cached): delta, force, nodes, seconds, the stop message, and where it
    stopped the smallest J of the last converged row and the (r, z) of that point's element."""
    cell = cell_parameters(**options)
    mesh = MeridianMeshParameters().scaled(scale)
    key = parameter_hash(cell, mesh, {"delta_max": DELTA_MAX, "steps": steps},
                         format_version=AXISYMMETRIC_CACHE_FORMAT)[:20]
    path = cache_directory() / "validation-axisymmetric" / f"axi-{key}.json"
    if path.exists() and not fresh:
        return json.loads(path.read_text())
    if cached_only:
        return None
    body = AxisymmetricCell.from_parameters(cell, mesh)
    start = time.perf_counter()
    try:
        result, error = compress_axisymmetric(body, DELTA_MAX, steps), ""
    except AxisymmetricError as failure:
        result, error = failure.partial, str(failure)
    record = {"options": options, "scale": scale, "delta": result.load.tolist(), "force": result.force.tolist(),
              "nodes": body.mesh.n_nodes, "seconds": time.perf_counter() - start, "error": error,
              "min_volume_ratio": result.min_volume_ratio.tolist()}
    if error:
        record["last_newton"] = [list(map(str, entry)) for entry in result.history[-4:]]
        record["weakest_point"] = weakest_point(body, result.positions[-1])
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record


def weakest_point(body: AxisymmetricCell, x: np.ndarray) -> dict:
    """Where the smallest J of positions ``x`` is: its element's reference centroid (r, z), region, and J."""
    values, gradients, _ = body.geometry
    planar = np.einsum("eki,eqkj->eqij", x[body.mesh.elements], gradients)
    radius = np.einsum("qk,ek->eq", values, body.mesh.nodes[body.mesh.elements][:, :, 0])
    hoop = np.einsum("qk,ek->eq", values, x[body.mesh.elements][:, :, 0]) / radius
    volume_ratio = np.linalg.det(planar) * hoop
    element = int(np.argmin(volume_ratio.min(axis=1)))
    centroid = body.mesh.nodes[body.mesh.elements[element]].mean(axis=0)
    return {"J": float(volume_ratio.min()), "r": float(centroid[0]), "z": float(centroid[1]),
            "region": "nucleus" if body.mesh.region[element] else "cytoplasm"}


def at_deltas(record: dict) -> np.ndarray:
    """F at DELTAS, interpolated in log F against log delta between the rows (F ~ delta^1.5 near the start: a
    linear interpolation there would err by 0.3 % at delta 0.1 with 40 steps); NaN beyond the last row."""
    delta, force = np.asarray(record["delta"][1:]), np.asarray(record["force"][1:])
    values = np.exp(np.interp(np.log(DELTAS), np.log(delta), np.log(np.maximum(force, 1e-300))))
    return np.where(DELTAS <= delta[-1] + 1e-12, values, np.nan)


def observed_order(forces: list[np.ndarray], scales: list[float]) -> np.ndarray:
    """The convergence order p per delta that three curves on meshes of ``scales`` (coarsest first) follow,
    F_s = F_0 + c s^p: the root of (F_1 - F_2) / (F_2 - F_3) = (s_1^p - s_2^p) / (s_2^p - s_3^p) in [0.3, 8]; NaN
    where the differences change sign or no root lies there (no asymptotic range)."""
    from scipy.optimize import brentq

    (f1, f2, f3), (s1, s2, s3) = forces, scales
    orders = np.full(len(DELTAS), np.nan)
    for k in range(len(DELTAS)):
        ratio = (f1[k] - f2[k]) / (f2[k] - f3[k]) if f2[k] != f3[k] else np.nan
        if not np.isfinite(ratio) or ratio <= 0:
            continue
        gap = lambda p, ratio=ratio: (s1**p - s2**p) / (s2**p - s3**p) - ratio  # noqa: E731
        if gap(0.3) * gap(8.0) < 0:
            orders[k] = brentq(gap, 0.3, 8.0)
    return orders


def three_d_jobs(ratios: list[float]) -> list[dict]:
    """Every 3D cell the three-d table needs, the stiffest first."""
    return [cell_options(ratio) for ratio in sorted(ratios, reverse=True)]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", nargs="+", choices=["refinement", "three-d", "peer"],
                        default=["refinement", "peer"],
                        help="three-d: the 3D defaults in this process (validation/stiff_mesh.py runs them from a new "
                             "process, its section of the page)")
    parser.add_argument("--ratios", nargs="+", type=float, default=RATIOS)
    parser.add_argument("--fill-cache", action="store_true", help="compute the missing 3D curves, no page")
    parser.add_argument("--fresh", action="store_true", help="recompute every curve")
    parser.add_argument("--cached-only", action="store_true", help="list a curve not in the cache as not run")
    parser.add_argument("--scales", nargs="+", type=float, default=[2.0, 1.0, 0.7, 0.5],
                        help="meridian mesh scales, coarsest first (the last is the truth)")
    args = parser.parse_args()
    if args.fill_cache:
        for options in three_d_jobs(args.ratios):
            record = three_d_curve(options, args.fresh)
            print(f"3D {options}: {record['nodes']} nodes, {record['seconds']:.0f} s, delta {record['delta'][-1]:.3f}"
                  + (f" ({record['error']})" if record["error"] else ""), flush=True)
        return
    page = Page("axisymmetric", "axisymmetric.py", intro=(
        "F/(E_c R^2) between rigid frictionless plates, 40 load steps to delta 0.75, neo-Hookean, nu 0.48, "
        "nucleus of size ratio 0.5 (stiffness ratio 1: the homogeneous cell). The truth is the axisymmetric "
        "solver (`compress_axisymmetric`: meridian section, 6-node triangles, exact frictionless contact) on its "
        "finest meridian mesh of this run; every error is F/F_truth - 1 at the same delta, F interpolated in "
        "log-log between rows. Times are of a shared 2-core machine under load (see the footer), not of the "
        "solvers alone."))
    if not args.fresh:
        page.print("Curves found in the cache were computed by earlier runs of this script (--fill-cache) on this "
                   "machine: time_s is the wall time of the run that computed each, on a machine shared with other "
                   "jobs, so it is not a cost of the solver alone; this run's wall time and load are in the footer.")
    truth, estimates = {}, []
    if "refinement" in args.only or "three-d" in args.only:
        rows = []
        for ratio in args.ratios:
            curves = [axisymmetric_curve(cell_options(ratio), scale, args.fresh, cached_only=args.cached_only)
                      for scale in args.scales]
            finest = next((curve for curve in curves[::-1] if curve is not None), None)
            truth[ratio] = at_deltas(finest) if finest is not None else np.full(len(DELTAS), np.nan)
            done = [(scale, at_deltas(curve)) for scale, curve in zip(args.scales, curves, strict=True) if curve is not None]
            if len(done) >= 3:
                (_, middle), (finest_scale, fine) = done[-2], done[-1]
                order = observed_order([forces for _, forces in done[-3:]], [scale for scale, _ in done[-3:]])
                limit = richardson(fine, middle, done[-2][0] / finest_scale, order)
                estimates.append({"gamma": ratio, "scales": " ".join(f"{scale:g}" for scale, _ in done[-3:]),
                                  **{f"p@{d:g}": p for d, p in zip(DELTAS, order, strict=True)},
                                  **{f"err@{d:g}": e for d, e in zip(DELTAS, fine / limit - 1, strict=True)}})
            for scale, curve in zip(args.scales, curves, strict=True):
                if curve is None:
                    rows.append({"gamma": ratio, "scale": scale, "nodes": "not run"})
                    continue
                errors = at_deltas(curve) / truth[ratio] - 1
                weakest = curve.get("weakest_point")
                rows.append({"gamma": ratio, "scale": curve["scale"], "nodes": curve["nodes"],
                             "time_s": curve["seconds"], "delta_reached": curve["delta"][-1],
                             **{f"err@{d:g}": e for d, e in zip(DELTAS, errors, strict=True)},
                             "stop": (f"J {weakest['J']:.2f} at r {weakest['r']:.3f}, z {weakest['z']:.3f} "
                                      f"({weakest['region']})") if weakest else ""})
        page.table(rows, "Axisymmetric refinement: every meridian size times scale, against the finest (stop: "
                   "the smallest J of the last converged row and where)",
                   columns=["gamma", "scale", "nodes", "time_s", "delta_reached", *ERRORS, "stop"],
                   formats={"time_s": ".0f", "delta_reached": ".3f", **{f"err@{d:g}": "+.3%" for d in DELTAS}})
        if estimates:
            page.table(estimates, "Error of the finest meridian mesh: Richardson's limit from the two finest, with the "
                       "order p observed on the three finest (F_s = F_0 + c s^p; nan: the differences change sign)",
                       columns=["gamma", "scales", *[f"p@{d:g}" for d in DELTAS], *ERRORS],
                       formats={**{f"p@{d:g}": ".2f" for d in DELTAS}, **{f"err@{d:g}": "+.3%" for d in DELTAS}})
        page.print("A pole (the surface node on the axis) lying on a plate is held in contact while the mid-side node "
                   "of its surface edge is: the share of a uniform pressure that a quadratic edge gives its node at "
                   "radius 0 is zero, so the sign of the pole's own multiplier says nothing about contact "
                   "(docs/theory.md, 'Axisymmetric path').")
    if "three-d" in args.only:
        rows = []
        for ratio in args.ratios:
            record = three_d_curve(cell_options(ratio), args.fresh, cached_only=args.cached_only)
            if record is None:
                rows.append({"gamma": ratio, "nodes": "not run"})
                continue
            errors = at_deltas(record) / truth[ratio] - 1
            rows.append({"gamma": ratio, "nodes": record["nodes"], "degree": record["quadrature_degree"] or 2,
                         "time_s": record["seconds"], "delta_reached": record["delta"][-1],
                         **{f"err@{d:g}": e for d, e in zip(DELTAS, errors, strict=True)}})
        page.table(rows, "3D defaults (`elastocell.compress`) against the axisymmetric truth (nan: the truth "
                   "stopped before this delta)", columns=["gamma", "nodes", "degree", "time_s", "delta_reached", *ERRORS],
                   formats={"time_s": ".0f", "delta_reached": ".3f", **{f"err@{d:g}": "+.2%" for d in DELTAS}})
    if "peer" in args.only:
        page.print("FElupe's axisymmetric mode: run beside compress_axisymmetric by validation/felupe_axisymmetric.py "
                   "(its section of this page: error against this truth and time per curve). The 3D defaults against "
                   "this truth: validation/stiff_mesh.py's section.")
    page.write()



if __name__ == "__main__":
    main()
