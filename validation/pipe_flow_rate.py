"""The pipe cell with the flow rate held (the default, as RT-DC's pump and dclab's tables) against the pressure
gradient held (``hold_flow_rate=False``), against dclab's LE-2D-FEM-19.

    nice python validation/pipe_flow_rate.py [--points 7.66:3,7.66:4.5,6:2,6:3] [--corrections 0 0.3]
                                             [--refinement-correction 0.3] [--finest-points 6:3]
                                             [--duration 16] [--workers 2] [--out results/pipe-flow-rate]
                                             [--cached-only]

The cell, channel, flow, reading of the table and record format are validation/pipe_resolution.py's (its
``run_case``: a centred homogeneous cell, neo-Hookean, nu 0.48, linear tetrahedra on the flow scenarios' default
mesh, LE-2D-FEM-19's cylinder R_ch = 1.094 x 10 um, Q = 0.04 uL/s, eta = 15 mPa s; one resolution per run, no
stationarity stop, D and the area are means over the last unit). Per point (R um : E kPa) and correction c
(markers at R - c dx): R/dx 8 holding G and holding Q, and R/dx 6 holding Q, with the Richardson extrapolation
(order 2) of their last-unit means (the method ``elastocell pipe`` applies on its defaults, with the markers at R, to
the second half of a run of 10 units). A run whose last unit has records read through the nodes' hull (the smooth
outline's fallback, ``outline_fallback``: D then jumps) is flagged, and no extrapolation uses it. The flow-rate ratio
Q/Q_ideal is the lattice's flow rate at the end over that of the nominal G in the ideal cylinder; G/G_0 is the
body force that held Q at the end over the nominal one. A second table follows the Q-held cell with the markers
at R - ``--refinement-correction`` dx through R/dx 6, 8, 10 (every point) and 12 (``--finest-points``).

Every run's record is appended to ``--out/runs.jsonl`` (a run already there is not repeated); ``--cached-only``
writes the page from that file alone. The section goes into docs/validation/pipe_dclab.md.
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
from pipe_dclab import parse_points, percent, table_readings
from pipe_resolution import (
    CHANNEL_RADIUS_UM,
    POISSON_RATIO,
    cases,
    key,
    read,
    run_missing,
    shear_equivalent_modulus,
    with_table,
)

from elastocell.simulation.extrapolation import richardson


def all_cases(points, corrections, duration: float) -> list[dict]:
    """R/dx 8 holding G and Q, R/dx 6 holding Q, on the default mesh, for every point and correction."""
    out = []
    for point in points:
        out += [{**c, "hold": False} for c in cases(point, [8.0], corrections, duration, meshes=False)]
        out += [{**c, "hold": True} for c in cases(point, [8.0, 6.0], corrections, duration, meshes=False)]
    return out


def refinement_cases(points, finest_points, correction: float, duration: float) -> list[dict]:
    """Q held, markers at R - ``correction`` dx: R/dx 10 at every point, and 12 at ``finest_points``."""
    out = []
    for point in points:
        resolutions = [10.0, 12.0] if point in finest_points else [10.0]
        out += [{**c, "hold": True} for c in cases(point, resolutions, [correction], duration, meshes=False)]
    return out


def extrapolated(fine: dict, coarse: dict) -> dict:
    """The default's reading: D and the area Richardson-extrapolated (order 2) from R/dx 6 and 8, against the table."""
    ratio = fine["resolution"] / coarse["resolution"]
    deform = richardson(fine["deform"], coarse["deform"], ratio, 2.0)
    area = richardson(fine["area_r2"], coarse["area_r2"], ratio, 2.0)
    radius, modulus = fine["radius_um"], fine["emodulus_kpa"]
    (d_t, a_t, e_read), = table_readings([(area * radius**2, deform, 3 * modulus / (2 * (1 + POISSON_RATIO)))])
    return {"deform": deform, "D_err": percent(deform, d_t), "A_err": percent(area * radius**2, a_t),
            "E_err": percent(e_read, 3 * modulus / (2 * (1 + POISSON_RATIO)))}


def e_errors(records: list[dict]) -> list[float]:
    """The table's modulus at each record's (area, D) against the shear-equivalent modulus of the run, %."""
    moduli = [shear_equivalent_modulus(r) for r in records]
    readings = table_readings([(r["area_r2"] * r["radius_um"] ** 2, r["deform"], e)
                               for r, e in zip(records, moduli, strict=True)])
    return [percent(e_read, e) for (_, _, e_read), e in zip(readings, moduli, strict=True)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", default="7.66:3,7.66:4.5,6:2,6:3", help="R:E,R:E (um, kPa)")
    parser.add_argument("--corrections", type=float, nargs="+", default=[0.0, 0.3])
    parser.add_argument("--duration", type=float, default=16.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("results/pipe-flow-rate"))
    parser.add_argument("--refinement-correction", type=float, default=0.3,
                        help="the correction of the refinement table (R/dx 6-12, Q held)")
    parser.add_argument("--finest-points", default="6:3", help="R:E,... also run at R/dx 12; '' for none")
    parser.add_argument("--cached-only", action="store_true")
    args = parser.parse_args()
    points = parse_points(args.points)
    finest = parse_points(args.finest_points) if args.finest_points else []
    todo = all_cases(points, args.corrections, args.duration)
    todo += refinement_cases(points, finest, args.refinement_correction, args.duration)
    page = Page()
    if not args.cached_only:
        run_missing(todo, args.out, args.workers)
    records = {r["key"]: r for r in with_table(read(args.out / "runs.jsonl"))}
    found = [records[key(c)] for c in todo if key(c) in records]
    for record, e_err in zip(found, e_errors(found), strict=True):
        record["E_err"] = e_err
    page.print(
        "A centred cell in LE-2D-FEM-19's cylinder (R_ch = 1.094 x 10 um, Q = 0.04 uL/s, eta = 15 mPa s), "
        "neo-Hookean, nu 0.48, linear tetrahedra on the default mesh, markers at R - c dx; "
        f"{args.duration:g} units of 1/gdot_w, means over the last unit. Against the table: D err at elastocell's "
        "area on the isoelastic of the same shear modulus, A err at elastocell's D, E err the table's modulus at "
        "elastocell's (area, D) over the run's. Q/Q_ideal: the lattice's flow rate at the end over Poiseuille's for "
        "the nominal pressure gradient; G/G_0: the pressure gradient that held Q at the end over the nominal. "
        f"{len(found)} of {len(todo)} runs.")
    rows = []
    for radius, modulus in points:
        for c in args.corrections:
            def pick(resolution, hold, radius=radius, modulus=modulus, c=c):
                return records.get(key({"radius_um": radius, "emodulus_kpa": modulus, "element": "p1",
                                        "mesh_size": None, "resolution": resolution, "c": c,
                                        "duration": args.duration, "hold": hold}))
            fixed, held, coarse = pick(8.0, False), pick(8.0, True), pick(6.0, True)
            row = {"R [um]": radius, "R/R_ch": radius / CHANNEL_RADIUS_UM, "E [kPa]": modulus, "c [dx]": c,
                   "hull records (G 8, Q 8, Q 6)": " ".join(
                       str(r.get("fallback_last_unit", "?")) if r else "-" for r in (fixed, held, coarse))}
            for label, record in (("G held", fixed), ("Q held", held)):
                row[f"{label}: Q/Q_ideal"] = record.get("flow_rate_ratio") if record else None
                row[f"{label}: G/G_0"] = record.get("pressure_gradient_ratio") if record else None
                for name in ("D_err", "A_err", "E_err"):
                    row[f"{label}: {name.replace('_', ' ')} %"] = record[name] if record else None
                row[f"{label}: D drift %/t"] = 100 * record["drift_deformation"] if record else None
            row["Q held, R/dx 6: D err %"] = coarse["D_err"] if coarse else None
            row["Q held, R/dx 6: D drift %/t"] = 100 * coarse["drift_deformation"] if coarse else None
            if held and coarse and held.get("fallback_last_unit") == 0 and coarse.get("fallback_last_unit") == 0:
                extra = extrapolated(held, coarse)
                row.update({f"Q held, 8/6 extrapolated: {k.replace('_', ' ')} %": extra[k]
                            for k in ("D_err", "A_err", "E_err")})
            rows.append(row)
    formats = {"R [um]": "g", "R/R_ch": ".3f", "E [kPa]": "g", "c [dx]": "g", "hull records (G 8, Q 8, Q 6)": None}
    columns = list(dict.fromkeys(name for row in rows for name in row))  # a row without the extrapolation lacks some
    formats.update({name: ".4f" if ("Q/Q" in name or "G/G" in name) else "+.1f" for name in columns
                    if name not in formats})
    page.table(rows, "R/dx 8 holding G and holding Q, R/dx 6 holding Q, and the Richardson extrapolation from "
                     "R/dx 6 and 8 (Q held; none where a run's last unit was read through the nodes' hull)",
               columns=columns, formats=formats)
    refined = []
    for radius, modulus in points:
        row = {"R [um]": radius, "R/R_ch": radius / CHANNEL_RADIUS_UM, "E [kPa]": modulus}
        for resolution in (6.0, 8.0, 10.0, 12.0):
            record = records.get(key({"radius_um": radius, "emodulus_kpa": modulus, "element": "p1",
                                      "mesh_size": None, "resolution": resolution, "c": args.refinement_correction,
                                      "duration": args.duration, "hold": True}))
            if record is None:
                continue
            hull = record.get("fallback_last_unit", "?")
            row[f"R/dx {resolution:g}: D err %"] = record["D_err"] if hull == 0 else None
            row[f"R/dx {resolution:g}: E err %"] = record["E_err"] if hull == 0 else None
        refined.append(row)
    names = list(dict.fromkeys(name for row in refined for name in row))
    page.table(refined, f"Q held, markers at R - {args.refinement_correction:g} dx, under refinement (blank: not run, "
                        "or its last unit read through the nodes' hull)", columns=names,
               formats={name: formats.get(name, "+.1f") for name in names})
    page.print("Wall time per run (s, two at a time on the 2-core machine, one thread each): " + ", ".join(
        f"{r['key']} {r['wall_s']:.0f}" for r in found))
    page.write()


if __name__ == "__main__":
    main()
