"""The paper's compression claims as a reproduction measured them, and which verdicts the stiff nucleus's refined
mesh moved.

    elastocell study run compression-stiffness --out paper           # (and the other compression studies)
    nice python validation/claims.py --dir paper [--no-earlier] [--no-page]

For every compression study whose table is in ``--dir`` (``NAME.parquet``, written by ``elastocell study run`` or
``reproduce``): each claim, what was measured and the verdict, re-derived from the table by the study's own
claims function, and the compression half of equivalent-modulus (the best-fit modulus of every cell of
compression-normalised's table, whose runs are that half's). Unless ``--no-earlier``, the same claims again with the stiffness ratio 10 and 20 cells on the
mesh a compression gave them before ``compression.STIFF_NUCLEUS_MESHES`` (the default p2 sizes: nucleus surface
0.15 over 0.25 R, bulk 0.35; the rule with the nodes, 40 steps to delta 0.75), cell and equivalent both, computed
here in this process and cached (``elastocell.files.cache_directory()/validation-claims/``): every other run of
the table is the same in both columns, so a verdict that differs is one the refined mesh moved. Writes its section
of docs/validation/studies.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from page import Page

from elastocell.api.compression import CHECKPOINT_FORMAT
from elastocell.body.cell import Cell
from elastocell.files import cache_directory, parameter_hash, write_json
from elastocell.parameters.cell import MeshParameters, cell_parameters
from elastocell.scenarios.compression import (
    CompressionError,
    CompressionInterrupted,
    CompressionParameters,
    compress,
)
from elastocell.studies import judge
from elastocell.studies.base import read_study_table
from elastocell.studies.equivalent_modulus import claims as modulus_claims
from elastocell.studies.equivalent_modulus import compression_fits
from elastocell.studies.registry import STUDIES

COMPRESSION_STUDIES = ("compression-stiffness", "compression-normalised", "compression-position-shape",
                       "compression-mooney-rivlin")
EARLIER_RATIOS = (10, 20)
EARLIER_FORMAT = 1
LOAD = CompressionParameters(delta_max=0.75, steps=40)


def earlier_cell(ratio: float):
    """The nucleus cell of size ratio 0.5 on the default p2 sizes with the rule with the nodes: what a
    compression meshed it with before the refined meshes."""
    cell = cell_parameters(stiffness_ratio=ratio, size_ratio=0.5)
    return cell.model_copy(update={"mesh": MeshParameters(**{**cell.mesh.model_dump(), "quadrature_degree": 5})})


def earlier_curves(ratio: float) -> dict:
    """{False: cell, True: equivalent} curves (delta, F/(E_c R^2)) on the earlier mesh, with the meshed E_eff/E_c
    and the wall time, cached under the hash of the cell, the load and EARLIER_FORMAT."""
    cell = earlier_cell(ratio)
    key = parameter_hash({"cell": cell, "load": LOAD, "checkpoint_format": CHECKPOINT_FORMAT},
                         format_version=EARLIER_FORMAT)[:16]
    path = cache_directory() / "validation-claims" / f"earlier-{ratio:g}-{key}.json"
    if path.exists():
        return json.loads(path.read_text())
    body = Cell.from_parameters(cell)
    record = {"effective_stiffness_ratio": float(body.effective_stiffness_ratio), "nodes": int(body.mesh.n_nodes)}
    for equivalent in (False, True):
        start = time.perf_counter()
        try:
            result = compress(body.equivalent() if equivalent else body, LOAD)
        except CompressionInterrupted:
            raise
        except CompressionError as error:
            result = error.partial
        record[str(equivalent)] = {"delta": result.delta.tolist(), "force": result.force.tolist(),
                                   "seconds": time.perf_counter() - start}
        print(f"earlier mesh, stiffness ratio {ratio:g}{' equivalent' if equivalent else ''}: delta up to "
              f"{result.delta[-1]:.3f} in {time.perf_counter() - start:.0f} s", flush=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, record)
    return record


PAIRS = ("gamma {:g}", "neo-hookean gamma {:g}")  # the stiffness and normalised tables; Mooney-Rivlin's twins


def on_earlier_mesh(frame):
    """``frame`` with the p2 rows of the neo-Hookean stiffness ratio 10 and 20 cells and their equivalents
    replaced, in place, by the earlier mesh's curves (None if the table has no such rows). A table whose rows are
    already on the earlier mesh (its node count) is refused: both columns would be the same."""
    import pandas as pd

    if "pair" not in frame or "discretisation" not in frame:
        return None
    targets = {pattern.format(ratio): ratio for ratio in EARLIER_RATIOS for pattern in PAIRS}
    pieces, replaced = [], False
    for (pair, discretisation, equivalent), group in frame.groupby(["pair", "discretisation", "equivalent"],
                                                                    sort=False):
        if pair not in targets or discretisation != "p2":
            pieces.append(group)
            continue
        ratio = targets[pair]
        curves = earlier_curves(ratio)
        if int(group["nodes"].iloc[0]) == curves["nodes"]:
            raise SystemExit(f"{pair} in this table is on the earlier mesh already ({curves['nodes']} nodes): a "
                             "reproduction from before the refined meshes")
        curve = curves[str(bool(equivalent))]
        delta, force = np.asarray(curve["delta"]), np.asarray(curve["force"])
        base = {**group.iloc[0].to_dict(), "error": "", "wall_time_s": curve["seconds"]}
        pieces.append(pd.DataFrame([{**base, "delta": d, "force_per_Ec_R2": f,
                                     "force_per_Eeff_R2": f / curves["effective_stiffness_ratio"],
                                     "effective_stiffness_ratio": curves["effective_stiffness_ratio"],
                                     "delta_reached": float(delta[-1]), "nodes": curves["nodes"],
                                     "status": "complete" if delta[-1] >= LOAD.delta_max - 1e-9 else "partial",
                                     "run_id": f"earlier mesh, {pair}{', equivalent' if equivalent else ''}",
                                     "run_directory": ""} for d, f in zip(delta, force, strict=True)]))
        replaced = True
    return pd.concat(pieces, ignore_index=True) if replaced else None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dir", type=Path, required=True, help="a reproduction's output directory")
    parser.add_argument("--no-earlier", action="store_true", help="leave out the earlier mesh's verdicts")
    parser.add_argument("--no-page", action="store_true", help="print only")
    args = parser.parse_args()
    page = Page("studies", "claims.py", intro=(
        "The paper's compression claims, each re-derived by its study's claims function from the table of a "
        "reproduction on the converged defaults (`elastocell study run NAME --out DIR`: p2 tetrahedra, 40 steps "
        "to delta 0.75, and p1 for the stiffness series as the paper's element). The verdict is the study's own "
        "rule (in the report beside each claim: largest |F/F_eq - 1| within 2 % agree, 5 % partly, unless the claim "
        "states another). `earlier mesh` is the verdict on the same table with the stiffness ratio 10 and 20 cells "
        "and their equivalents on the mesh a compression gave them before its refined stiff-nucleus meshes "
        "(`compression.STIFF_NUCLEUS_MESHES`: nucleus surface 0.15 over 0.25 R, bulk 0.35, rule with the nodes), "
        "whose curves were up to 5-8 % too stiff against the axisymmetric truth (docs/validation/axisymmetric.md); "
        "every other run is the same in both columns."))
    rows, runs = [], []
    for name in COMPRESSION_STUDIES:
        if not (args.dir / f"{name}.parquet").exists():
            continue
        frame, metadata = read_study_table(args.dir, name)
        study = STUDIES[name]
        claims, _ = judge(study, frame)
        earlier = None if args.no_earlier else on_earlier_mesh(frame)
        before = judge(study, earlier)[0] if earlier is not None else [None] * len(claims)
        runs.append({"study": name, "mode": "quick" if metadata.get("quick") else "full", "runs": int(frame["run_id"].nunique()),
                     "complete": int(frame.drop_duplicates("run_id")["status"].eq("complete").sum())})
        for claim, old in zip(claims, before, strict=True):
            others = "; ".join(f"{key}: {other['verdict']}" for key, other in claim.other_discretisations.items())
            rows.append({"study": name, "claim": claim.claim, "measured": claim.measured, "verdict": claim.verdict,
                         "other discretisations": others,
                         "earlier mesh": "" if old is None else old.verdict,
                         "earlier mesh measured": "" if old is None or old.measured == claim.measured
                         else old.measured})
    if (args.dir / "compression-normalised.parquet").exists():  # its runs are the compression half of
        import pandas as pd  # equivalent-modulus's (the shear half does not use the compression meshes)

        frame, _ = read_study_table(args.dir, "compression-normalised")
        earlier = None if args.no_earlier else on_earlier_mesh(frame)
        claims = modulus_claims(pd.DataFrame(compression_fits(frame)))
        before = modulus_claims(pd.DataFrame(compression_fits(earlier))) if earlier is not None \
            else [None] * len(claims)
        for claim, old in zip(claims, before, strict=True):
            rows.append({"study": "equivalent-modulus (compression half)", "claim": claim.claim,
                         "measured": claim.measured, "verdict": claim.verdict, "other discretisations": "",
                         "earlier mesh": "" if old is None else old.verdict,
                         "earlier mesh measured": "" if old is None or old.measured == claim.measured
                         else old.measured})
    if not rows:
        raise SystemExit(f"no compression study table in {args.dir}")
    page.table(runs, f"Studies found in {args.dir}")
    page.table(rows, "Each claim: measured on the refined meshes, and the verdict on the earlier mesh",
               columns=["study", "claim", "verdict", "earlier mesh", "other discretisations", "measured",
                        "earlier mesh measured"])
    moved = [row for row in rows if row["earlier mesh"] and row["earlier mesh"] != row["verdict"]]
    page.print(f"verdicts moved by the refined meshes: {len(moved)} of {len(rows)}"
               + "".join(f"\n- {row['study']}: {row['claim']} {row['earlier mesh']} -> {row['verdict']}"
                         for row in moved))
    if not args.no_page:
        page.write()


if __name__ == "__main__":
    main()
