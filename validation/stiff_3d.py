"""The error budget of ``elastocell compress``'s 3D defaults for a stiff nucleus, and the defaults against the
axisymmetric truth for every stiffness ratio.

    nice python validation/stiff_3d.py [--only budget defaults] [--ratios 1 2 5 10 20] [--cached-only] [--fresh]

The truth is validation/axisymmetric.py's: ``compress_axisymmetric`` on the meridian mesh of scale 0.5 (within
0.13 % of its Richardson limit at delta 0.1-0.7 for stiffness ratios 1-20, size ratio 0.5), from that script's
cache (``--fill-cache`` there computes it); a variation of the Poisson ratio takes the truth at that ratio on the
meridian mesh of scale 0.7 (within 0.13 % of scale 0.5 at nu 0.48).

- budget: one factor of the mesh a stiff nucleus had before ``compression.STIFF_NUCLEUS_MESHES`` (p2; bulk 0.35,
  poles 0.08 over 1.4 R, nucleus surface 0.15 over 0.25 R, no polar layer; the 25-point rule with the nodes for a
  stiffness ratio >= 7, the threshold then) changed at a time, stiffness ratios 20 and
  10, 14 load steps to delta 0.7 (the four deltas are rows; the page gives how far the default's 14-step curve is
  from its 40-step one): (a) the cytoplasm between nucleus and plates (poles, the polar layer), (b) the
  nucleus surface, (c) the quadrature rule, (d) the Poisson ratio in both solvers (the crushed layer's volumetric
  stiffness), (e) the contact's resolution (the cell surface alone in the polar cone).
- defaults: ``elastocell compress`` on its defaults to delta 0.75, each in a new process (the wall time of the
  process, mesh from the cache or not as the column says, and of the curve alone); the default 40 steps for the
  stiffness ratios of ``--ratios-at-40``, else ``--steps`` (15: rows every 0.05, the four deltas among them).

Every 3D curve is cached (``elastocell.files.cache_directory``, ``validation-stiff-3d/``) under the hash of the
resolved cell and the load steps; ``--cached-only`` lists a curve not in the cache as not run.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from axisymmetric import DELTAS, ERRORS, at_deltas, axisymmetric_curve, cell_options, three_d_curve
from page import Page

from elastocell.body.cell import Cell
from elastocell.files import cache_directory, parameter_hash, read_curve_csv, write_json
from elastocell.parameters.cell import MeshParameters, cell_parameters
from elastocell.scenarios.compression import (
    CompressionError,
    CompressionParameters,
    compress,
    compression_parameters_for,
)

CACHE_FORMAT = 2
"""Version of the cached 3D curves (2: a p2 surface corner among pressed mid-side nodes stays in contact)."""
TRUTH_SCALE, VARIED_TRUTH_SCALE = 0.5, 0.7
SCREEN_STEPS, SCREEN_DELTA = 14, 0.7
STEPS, DELTA_MAX = 40, 0.75
BASE = {"layer_size": None, "interface_size": 0.15, "interface_width": 0.25, "mesh_size": 0.35}
"""The default p2 mesh (no polar layer; the nucleus surface and bulk a stiff nucleus had before
``compression.STIFF_NUCLEUS_MESHES``), kept explicit so that the budget's rows stay changes of this mesh."""
BUDGET = [  # (factor, label, cell changes, mesh changes from the default, truth changes)
    ("", "the mesh before (surface 0.15 over 0.25, bulk 0.35)", {}, {}, {}),
    ("a", "poles 0.04", {}, {"pole_size": 0.04}, {}),
    ("a", "polar layer 0.1 within 40 deg", {}, {"layer_size": 0.1, "layer_angle": 40}, {}),
    ("b", "nucleus surface 0.075", {}, {"interface_size": 0.075}, {}),
    ("a+b", "polar layer 0.1 within 40 deg, nucleus surface 0.075", {},
     {"layer_size": 0.1, "layer_angle": 40, "interface_size": 0.075}, {}),
    ("c", "quadrature degree 2 (4 points)", {}, {"quadrature_degree": 2}, {}),
    ("c", "quadrature degree 7 (64 points)", {}, {"quadrature_degree": 7}, {}),
    ("d", "nu 0.45 (also the truth)", {"poisson_ratio": 0.45}, {}, {"poisson_ratio": 0.45}),
    ("e", "cell surface 0.1 within 40 deg, 0.08 deep", {}, {"layer_size": 0.1, "layer_angle": 40, "layer_depth": 0.08},
     {}),
    ("f", "projected J (P1, volumetric projected)", {}, {"volumetric": "projected"}, {}),
    ("f", "mean dilatation (P0, volumetric mean)", {}, {"volumetric": "mean"}, {}),
    ("b+f", "nucleus surface 0.075, projected J", {}, {"interface_size": 0.075, "volumetric": "projected"}, {}),
    ("b+f", "nucleus surface 0.075, mean dilatation", {}, {"interface_size": 0.075, "volumetric": "mean"}, {}),
    ("a+b+f", "polar layer 0.1 within 40 deg, nucleus surface 0.075, projected J", {},
     {"layer_size": 0.1, "layer_angle": 40, "interface_size": 0.075, "volumetric": "projected"}, {}),
]
BUDGET_RATIOS = [20, 10]
RATIOS = [1, 2, 5, 10, 20]


def resolved_cell(ratio: float, cell_changes: dict, mesh_changes: dict):
    """The cell ``elastocell.compress`` takes for stiffness ratio ``ratio`` (size ratio 0.5) with ``cell_changes``
    to its options, then ``mesh_changes`` to its resolved mesh."""
    cell = compression_parameters_for(cell_parameters(**cell_options(ratio, **cell_changes)))
    if mesh_changes:
        cell = cell.model_copy(update={"mesh": MeshParameters(**{**cell.mesh.model_dump(), **mesh_changes})})
    return cell


def _path(kind: str, cell, delta_max: float, steps: int):
    key = parameter_hash(cell, {"delta_max": delta_max, "steps": steps}, format_version=CACHE_FORMAT)[:20]
    return cache_directory() / "validation-stiff-3d" / f"{kind}-{key}.json"


def screened_curve(ratio: float, cell_changes: dict, mesh_changes: dict, fresh: bool = False,
                   cached_only: bool = False) -> dict | None:
    """One budget curve, SCREEN_STEPS steps to SCREEN_DELTA, in this process (cached)."""
    cell = resolved_cell(ratio, cell_changes, mesh_changes)
    path = _path("3d", cell, SCREEN_DELTA, SCREEN_STEPS)
    if path.exists() and not fresh:
        return json.loads(path.read_text())
    if cached_only:
        return None
    start = time.perf_counter()
    body = Cell.from_parameters(cell)
    try:
        result, error = compress(body, CompressionParameters(delta_max=SCREEN_DELTA, steps=SCREEN_STEPS)), ""
    except CompressionError as failure:
        result, error = failure.partial, str(failure)
    record = {"ratio": ratio, "cell_changes": cell_changes, "mesh_changes": mesh_changes,
              "delta": result.delta.tolist(), "force": result.force.tolist(), "nodes": body.mesh.n_nodes,
              "seconds": time.perf_counter() - start, "error": error}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record


def default_curve(ratio: float, steps: int = STEPS, fresh: bool = False, cached_only: bool = False,
                  changes: dict | None = None) -> dict | None:
    """``elastocell compress`` on its defaults for stiffness ratio ``ratio`` (with the cell options ``changes``, a
    candidate for the defaults: e.g. ``{"volumetric": "projected"}``), ``steps`` steps to DELTA_MAX, run in a new
    process (cached under the resolved cell): the curve, nodes, the process's and the curve's wall time. With
    STEPS steps, a default curve of the same cell in validation/axisymmetric.py's cache is taken from there."""
    changes = changes or {}
    cell = compression_parameters_for(cell_parameters(**cell_options(ratio, **changes)))
    path = _path("cli", cell, DELTA_MAX, steps)
    if path.exists() and not fresh:
        return json.loads(path.read_text())
    shared = (three_d_curve(cell_options(ratio), cached_only=True) if steps == STEPS and not changes
              else None)  # same cell, same steps
    if shared is not None and not fresh:
        return {**shared, "process_s": float("nan"), "curve_s": shared["seconds"], "mesh_cached": None,
                "mesh": cell.mesh.model_dump(mode="json"), "run": "axisymmetric.py"}
    if cached_only:
        return None
    options = [item for name, value in cell_options(ratio, **changes).items()
               for item in (f"--{name.replace('_', '-')}", str(value))]
    with tempfile.TemporaryDirectory() as out:
        from elastocell.body.mesh import mesh_cache_path, mesh_parameters  # lazy: only when a curve is computed

        nucleus = cell.nucleus
        cached_mesh = mesh_cache_path(mesh_parameters(nucleus, cell.mesh)).exists()
        start = time.perf_counter()
        completed = subprocess.run([sys.executable, "-m", "elastocell", "compress", "--out", out, *options,
                                    "--delta-max", f"{DELTA_MAX:g}", "--steps", str(steps), "--quiet"],
                                   capture_output=True, text=True)
        wall = time.perf_counter() - start
        metadata = json.loads((Path(out) / "metadata.json").read_text())
        _, table = read_curve_csv(Path(out) / "compression.csv")
    record = {"ratio": ratio, "steps": steps, "changes": changes, "delta": np.asarray(table["delta"]).tolist(),
              "force": np.asarray(table["force_per_Ec_R2"]).tolist(), "nodes": metadata["mesh"]["n_nodes"],
              "process_s": wall, "curve_s": metadata["solver"]["curve_time_s"], "mesh_cached": cached_mesh,
              "returncode": completed.returncode, "stderr": completed.stderr[-500:],
              "mesh": cell.mesh.model_dump(mode="json"), "run": "new process"}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record


def truth(ratio: float, changes: dict | None = None) -> np.ndarray:
    """F of the axisymmetric truth at DELTAS (NaN where it is not in validation/axisymmetric.py's cache)."""
    scale = VARIED_TRUTH_SCALE if changes else TRUTH_SCALE
    record = axisymmetric_curve(cell_options(ratio, **(changes or {})), scale, cached_only=True)
    return at_deltas(record) if record is not None else np.full(len(DELTAS), np.nan)


def errors(record: dict, reference: np.ndarray) -> dict:
    return dict(zip(ERRORS, at_deltas(record) / reference - 1, strict=True))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", nargs="+", choices=["budget", "defaults", "candidate"],
                        default=["budget", "defaults", "candidate"])
    parser.add_argument("--candidate", nargs="+", default=["volumetric=projected"],
                        help="cell options NAME=VALUE of the candidate defaults (the candidate table)")
    parser.add_argument("--candidate-ratios", nargs="+", type=float, default=RATIOS)
    parser.add_argument("--ratios", nargs="+", type=float, default=RATIOS)
    parser.add_argument("--budget-ratios", nargs="+", type=float, default=BUDGET_RATIOS)
    parser.add_argument("--steps", type=int, default=15, help="load steps of a default curve not in the cache")
    parser.add_argument("--ratios-at-40", nargs="*", type=float, default=RATIOS,
                        help="stiffness ratios whose default curve has the default 40 steps")
    parser.add_argument("--fresh", action="store_true", help="recompute every 3D curve")
    parser.add_argument("--cached-only", action="store_true", help="list a curve not in the cache as not run")
    parser.add_argument("--no-page", action="store_true", help="compute and print, write no page")
    args = parser.parse_args()
    page = Page("axisymmetric", "stiff_3d.py", intro=(
        "F/(E_c R^2) of the 3D solver (p2 tetrahedra) against the axisymmetric truth (`compress_axisymmetric`, "
        "meridian mesh of scale 0.5, section above), neo-Hookean, nu 0.48, nucleus of size ratio 0.5; every "
        "error is F/F_truth - 1 at the same delta. Times are wall times on a 2-core machine shared with other "
        "jobs (load in the footer, up to some 30 runnable threads while these curves ran): they say little of "
        "the solver's cost. The refined polar layer (`MeshParameters.layer_size`, `layer_angle`: the cytoplasm "
        "within an angle of the plate axis, the soft layer a stiff nucleus crushes against the plates) is an "
        "option of the mesh, not a default: the budget shows how much of the error it removes. A variation "
        "listed as not run was not computed (its curve is not in the cache)."))
    form = {"time_s": ".0f", "process_s": ".0f", "curve_s": ".0f", "delta_reached": ".3f",
            **{name: "+.2%" for name in ERRORS}}
    if "budget" in args.only:
        rows = []
        for ratio in args.budget_ratios:
            base = None
            for factor, label, cell_changes, mesh_changes, truth_changes in BUDGET:
                record = screened_curve(ratio, cell_changes, {**BASE, **mesh_changes}, args.fresh,
                                        args.cached_only)
                if record is None:
                    rows.append({"gamma": ratio, "factor": factor, "variation": label, "nodes": "not run"})
                    continue
                row = errors(record, truth(ratio, truth_changes))
                if not factor:
                    base = row
                rows.append({"gamma": ratio, "factor": factor, "variation": label, "nodes": record["nodes"],
                             "time_s": record["seconds"], "delta_reached": record["delta"][-1], **row,
                             **({f"removed@{d:g}": 1 - row[f"err@{d:g}"] / base[f"err@{d:g}"] for d in (0.5, 0.7)}
                                if factor and base else {}),
                             "stop": record["error"].split(":")[0] if record["error"] else ""})
        for ratio in args.budget_ratios:
            screened = screened_curve(ratio, {}, BASE, cached_only=True)
            full = three_d_curve(cell_options(ratio), cached_only=True)
            same_mesh = resolved_cell(ratio, {}, BASE) == compression_parameters_for(cell_parameters(**cell_options(ratio)))
            if screened is not None and full is not None and same_mesh:
                gap = np.abs(at_deltas(screened) / at_deltas(full) - 1)
                page.print(f"gamma {ratio:g}: the default's {SCREEN_STEPS}-step curve differs from its {STEPS}-step "
                           f"curve (validation/axisymmetric.py) by at most {np.nanmax(gap):.2%} at delta 0.1-0.7.")
        page.table(rows, f"Error budget: one factor of the default changed at a time ({SCREEN_STEPS} "
                   f"steps to delta {SCREEN_DELTA:g}; removed@0.5, @0.7: the share of the default's error at that "
                   "delta that the change removes)", columns=["gamma", "factor", "variation", "nodes", "time_s",
                                                             "delta_reached", *ERRORS, "removed@0.5", "removed@0.7", "stop"],
                   formats={**form, "removed@0.5": ".0%", "removed@0.7": ".0%"})
    if "defaults" in args.only:
        rows = []
        for ratio in args.ratios:
            steps = STEPS if ratio in args.ratios_at_40 else args.steps
            record = default_curve(ratio, steps, args.fresh, args.cached_only)
            if record is None:
                rows.append({"gamma": ratio, "nodes": "not run"})
                continue
            mesh = record["mesh"]
            rows.append({"gamma": ratio, "steps": record.get("steps", STEPS), "nodes": record["nodes"],
                         "layer": "none" if mesh.get("layer_size") is None else
                         f"{mesh['layer_size']:g} within {mesh['layer_angle']:g} deg",
                         "degree": mesh["quadrature_degree"] or 2, "process_s": record["process_s"],
                         "curve_s": record["curve_s"], "run": record["run"],
                         "mesh_cached": {True: "yes", False: "no", None: ""}[record["mesh_cached"]],
                         "delta_reached": record["delta"][-1], **errors(record, truth(ratio))})
        page.table(rows, f"`elastocell compress` on its defaults but the steps (to delta {DELTA_MAX:g}; {STEPS}, the "
                   "default, or 15: rows every 0.05), each in a new process, against the axisymmetric truth",
                   columns=["gamma", "steps", "nodes", "layer", "degree", "run", "process_s", "curve_s", "mesh_cached",
                            "delta_reached", *ERRORS], formats=form)
    if "candidate" in args.only:
        changes = dict(item.split("=", 1) for item in args.candidate)
        rows = []
        for ratio in args.candidate_ratios:
            record = default_curve(ratio, args.steps, args.fresh, args.cached_only, changes)
            if record is None:
                rows.append({"gamma": ratio, "nodes": "not run"})
                continue
            default = default_curve(ratio, args.steps, cached_only=True) or default_curve(ratio, cached_only=True)
            rows.append({"gamma": ratio, "steps": record["steps"], "nodes": record["nodes"],
                         "degree": record["mesh"]["quadrature_degree"] or 2, "process_s": record["process_s"],
                         "curve_s": record["curve_s"],
                         "curve_s/default": record["curve_s"] / default["curve_s"] if default else float("nan"),
                         "delta_reached": record["delta"][-1], **errors(record, truth(ratio))})
        page.table(rows, f"Candidate defaults: `elastocell compress` with {' '.join(f'--{k.replace(chr(95), chr(45))} {v}' for k, v in changes.items())} "
                   f"({args.steps} steps to delta {DELTA_MAX:g}), each in a new process, against the axisymmetric "
                   "truth; curve_s/default: its curve's wall time over the default's (a different run, other load)",
                   columns=["gamma", "steps", "nodes", "degree", "process_s", "curve_s", "curve_s/default",
                            "delta_reached", *ERRORS], formats={**form, "curve_s/default": ".1f"})
    if not args.no_page:
        page.write()


if __name__ == "__main__":
    main()
