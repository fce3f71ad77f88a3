"""Does the pipe's extrapolation converge as it assumes? The RT-DC reading at R/dx 6, 8 and 10 for the cells where
the default pair meets the target, the observed order, and the pair's Richardson estimate against R/dx 10 and 8's.

    nice python validation/pipe_order.py [--points 7.66:4.5,6:3] [--duration 40] [--out results/pipe-order] [--page]

Each point: ``elastocell pipe`` at its defaults (the R/dx 8 and 6 pair in a cylinder, six side views; as
pipe_target.py) and the same cell at R/dx 10 alone (``resolution=10, extrapolate=False``), both to t = 40/gdot_w
in LE-2D-FEM-19's cylinder (centred neo-Hookean cell, nu 0.48). Runs resume from their directories under ``--out``.
Reported per resolution: the six views' mean D and area over the averaging window against the table (pipe_target's
reading); then the observed order p from the three (D6 - D8)/(D8 - D10) = (6^-p - 8^-p)/(8^-p - 10^-p), and the
order-2 Richardson estimates from (8, 6) (the default) and from (10, 8). If the pair's estimate is an estimate of
the converged value, the two agree and p is near 2. The section goes into docs/validation/pipe_dclab.md.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from page import Page  # noqa: E402
from pipe_dclab import observed_order, parse_points, percent, table_readings  # noqa: E402
from pipe_resolution import CHANNEL_RADIUS_UM, POISSON_RATIO, wall_capillary_number  # noqa: E402

import elastocell  # noqa: E402
from elastocell.simulation.extrapolation import richardson  # noqa: E402


def run_point(radius: float, modulus: float, duration: float, out: Path) -> dict:
    ca_w = wall_capillary_number(modulus)
    common = dict(nucleus="none", poisson_ratio=POISSON_RATIO, channel_radius_ratio=CHANNEL_RADIUS_UM / radius,
                  duration=duration, resume=True, progress=False, vtk_interval=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # stationarity and guard warnings: the table shows the flags
        pair = elastocell.pipe(out / f"{radius:g}um-{modulus:g}kPa-t{duration:g}", ca_w, **common)
        finest = elastocell.pipe(out / f"{radius:g}um-{modulus:g}kPa-rdx10-t{duration:g}", ca_w, resolution=10,
                                 extrapolate=False, **common)
    readings = {8.0: (pair.get("deformation_views_mean_rdx8"), pair.get("projected_area_views_mean_rdx8")),
                6.0: (pair.get("deformation_views_mean_rdx6"), pair.get("projected_area_views_mean_rdx6")),
                10.0: (finest.get("deformation_views_mean"), finest.get("projected_area_views_mean"))}
    return {"readings": readings, "guard": bool((pair.get("extrapolation") or {}).get("outline_guard")),
            "hull": finest.get("outline_fallback_views_records"),
            "stationary": {8.0: pair.get("stationary"), 10.0: finest.get("stationary")},
            "wall": {"pair": pair.get("wall_time_cumulative_s"), 10.0: finest.get("wall_time_cumulative_s")}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", default="7.66:4.5,6:3", help="R:E,R:E (um, kPa)")
    parser.add_argument("--duration", type=float, default=40.0, help="units of 1/gdot_w")
    parser.add_argument("--out", type=Path, default=Path("results/pipe-order"))
    parser.add_argument("--page", action="store_true", help="write the section of docs/validation/pipe_dclab.md")
    args = parser.parse_args()
    page = Page("pipe_dclab", "pipe_order.py", intro=(
        "The two cells where the default pair meets issue 24's target (pipe_target.py), read at R/dx 6, 8 (the "
        "default pair's runs) and 10 (alone), the RT-DC reading (six side views' mean over the averaging window), "
        f"t = {args.duration:g}/gdot_w, against LE-2D-FEM-19 in its own cylinder. `p`: the observed order of the "
        "three; `(8, 6)`: the default's order-2 estimate; `(10, 8)`: the same from the two finer runs. Wall times: "
        "made beside other work (not a benchmark)."))
    rows, summary_rows = [], []
    for radius, modulus in parse_points(args.points):
        result = run_point(radius, modulus, args.duration, args.out)
        e_t = 3 * modulus / (2 * (1 + POISSON_RATIO))
        d = {r: v[0] for r, v in result["readings"].items()}
        a = {r: v[1] for r, v in result["readings"].items()}
        for r in (6.0, 8.0, 10.0):
            (d_t, a_t, _), = table_readings([(a[r] * radius**2, d[r], e_t)])
            rows.append({"R [um]": radius, "E [kPa]": modulus, "R/R_ch": radius / CHANNEL_RADIUS_UM,
                         "reading": f"R/dx {r:g}", "deform": d[r], "area/R^2": a[r], "D_t": d_t,
                         "D err %": percent(d[r], d_t), "A err %": percent(a[r] * radius**2, a_t)})
        for label, (fine, coarse) in (("(8, 6)", (8.0, 6.0)), ("(10, 8)", (10.0, 8.0))):
            ratio = fine / coarse
            d_x, a_x = float(richardson(d[fine], d[coarse], ratio)), float(richardson(a[fine], a[coarse], ratio))
            (d_t, a_t, _), = table_readings([(a_x * radius**2, d_x, e_t)])
            rows.append({"R [um]": radius, "E [kPa]": modulus, "R/R_ch": radius / CHANNEL_RADIUS_UM,
                         "reading": f"extrapolated {label}", "deform": d_x, "area/R^2": a_x, "D_t": d_t,
                         "D err %": percent(d_x, d_t), "A err %": percent(a_x * radius**2, a_t)})
        summary_rows.append({"R [um]": radius, "E [kPa]": modulus, "p (D)": observed_order(d[6.0], d[8.0], d[10.0]),
                             "p (area)": observed_order(a[6.0], a[8.0], a[10.0]),
                             "(8, 6) - (10, 8) in D %": percent(float(richardson(d[8.0], d[6.0], 8 / 6)),
                                                                float(richardson(d[10.0], d[8.0], 10 / 8))),
                             "R/dx 10 hull views": result["hull"],
                             "stationary (8, 10)": f"{result['stationary'][8.0]}, {result['stationary'][10.0]}",
                             "wall pair (s)": result["wall"]["pair"], "wall R/dx 10 (s)": result["wall"][10.0]})
        for row in rows[-5:]:
            print(f"{radius:g} um / {modulus:g} kPa, {row['reading']}: D {row['deform']:.5f} "
                  f"(err {row['D err %']:+.1f} %, A err {row['A err %']:+.1f} %)", flush=True)
    page.table(rows, f"RT-DC reading per resolution and extrapolated, t = {args.duration:g}/gdot_w", formats={
        "R/R_ch": ".3f", "deform": ".5f", "area/R^2": ".4f", "D_t": ".5f", "D err %": "+.1f", "A err %": "+.1f"})
    page.table(summary_rows, "Observed order and the agreement of the two estimates", formats={
        "p (D)": ".2f", "p (area)": ".2f", "(8, 6) - (10, 8) in D %": "+.1f", "wall pair (s)": ".0f",
        "wall R/dx 10 (s)": ".0f"})
    if args.page:
        page.write()


if __name__ == "__main__":
    main()
