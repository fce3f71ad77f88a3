"""How long a look-up-table point must run: the relaxation of a cell's deformation in the RT-DC channel, and
whether the exponential fit of a shorter run predicts where a longer one ends.

    nice python validation/lut_relaxation.py --runs DIR [DIR ...] [--cuts 10 15 20 30] [--section standard]

The page's runs are lut_square.py's (capped at 20 units of 1/gdot_w) and one long point, made by
``elastocell lut --channel-shape square --channel-width 20um --flow-rate 0.04uL/s --medium 0.59%MC-PBS
--temperature 23 --radii 5um --moduli 1kPa --duration 60 --out /work/results/lut-square-long/lut.txt``.

Each DIR is a pipe run's directory with its timeseries.csv and summary.json (a point of ``elastocell lut``,
``<stem>_runs/<key>/``, or any ``elastocell pipe`` run; the page adds the Newtonian cylinder runs of
pipe_stationary.py). For each run: the relaxation time tau of D(t) = D_inf - A exp(-t/tau) fitted to the whole run from
t = 2 on (``lut_square.relaxation_fit``; NaN where tau comes out beyond the run's end: no exponential approach
within the run) and tau over Ca_w; then, for each cut time t_c of ``--cuts`` below the
run's end, the same fit to the run truncated at t_c, and its D_inf and the deformation the run itself had at t_c
(the mean of the last unit of 1/gdot_w before it: what a point capped at t_c reports) against the run's final
reading (the mean of its last unit), for the runs that reached their stationary stop only (the reference is the
run itself). The page is docs/validation/lut_square.md; ``--section standard`` writes the section of the standard
table's points (``validation/tables/lut_square_20um_0.04uLs_0.59MC-PBS_23C_runs/*``, whose time series stay in the
checkout that computed them: git keeps their point.json only).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
from lut_square import relaxation_fit
from page import Page


def last_unit_mean(time: np.ndarray, values: np.ndarray, end: float) -> float:
    """Mean of ``values`` over (end - 1, end] (units of 1/gdot_w)."""
    keep = (time > end - 1.0) & (time <= end + 1e-9)
    return float(values[keep].mean())


def main(argv=None) -> None:
    import pandas as pd

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, nargs="+", required=True, help="point run directories")
    parser.add_argument("--cuts", type=float, nargs="+", default=[10.0, 15.0, 20.0, 30.0],
                        help="cut times t_c (1/gdot_w)")
    parser.add_argument("--section", choices=("standard",), default=None,
                        help="write the section of the standard table's points instead of the exploratory runs'")
    args = parser.parse_args(argv)
    section = "lut_relaxation.py" + (f":{args.section}" if args.section else "")
    page = Page("lut_square", section, intro=(
        "The relaxation of a centred cell's RT-DC deformation in the channel (elastocell's pipe runs at R/dx 8 with "
        "the markers at R - 0.3 dx and the flow rate held, each with its own duration cap): tau of D(t) = D_inf - A exp(-t/tau) fitted from t = 2 on, over the wall capillary number; and, "
        "for the runs that ended on the stationary stop and are longer than a cut time t_c, what a point capped "
        "at t_c reads (its last unit's mean) and what the "
        "exponential fit of the run up to t_c extrapolates (D_inf), each against the long run's own final reading "
        "(its last unit's mean; `end` says whether the long run stopped on the stationary criterion, 1e-3 per "
        "unit, or at its cap). `hull records` counts the records whose side view fell back to the nodes' hull "
        "(the smooth outline left its trusted band: D jumps by tens of %); no fit is made for such a run, nor "
        "where the fitted tau is not within (0, t_end). Times in units of 1/gdot_w."))
    rows, cut_rows = [], []
    for run in args.runs:
        if not (run / "summary.json").is_file():  # a point still running (a glob of a table's runs)
            print(f"{run}: no summary.json (unfinished), left out")
            continue
        summary = json.loads((run / "summary.json").read_text())
        table = pd.read_csv(run / "timeseries.csv")
        t, d = table["time"].to_numpy(), table["deformation"].to_numpy()
        end = float(t[-1])
        final = last_unit_mean(t, d, end)
        capillary = float(summary.get("capillary_number_wall", float("nan")))
        hull = int(table["outline_fallback"].sum()) if "outline_fallback" in table else 0
        d_inf, tau = relaxation_fit(run / "timeseries.csv")
        if hull or not 0.0 < tau < end:  # a jump of the outline reading, or no exponential approach within the run
            d_inf = tau = float("nan")
        stop = "stationary" if summary.get("stop_reason") == "stationary" else str(summary.get("stop_reason"))
        confinement = 1.0 / float(summary.get("channel_radius_ratio", float("nan")))
        rows.append({"run": run.name, "channel": summary.get("channel_shape", "cylinder"),
                     "medium": summary.get("medium", "newtonian"), "R/R_ch": confinement, "Ca_w": capillary,
                     "t_end": end, "end": stop, "hull records": hull, "D final": final,
                     "tau fit": tau, "tau / Ca_w": tau / capillary, "D_inf fit / D final": d_inf / final})
        for cut in args.cuts:
            if stop != "stationary" or hull or cut > end - 1.0:  # only a run that ended stationary is a reference
                continue
            with tempfile.TemporaryDirectory() as scratch:  # the fit reads a time series file
                truncated = Path(scratch) / "timeseries.csv"
                table[table["time"] <= cut + 1e-9].to_csv(truncated, index=False)
                d_cut_inf, tau_cut = relaxation_fit(truncated)
            capped = last_unit_mean(t, d, cut)
            cut_rows.append({"run": run.name, "Ca_w": capillary, "t_c": cut, "t_c / tau": cut / tau,
                             "capped at t_c: D / D final - 1 %": 100.0 * (capped / final - 1.0),
                             "fit to t_c: tau": tau_cut,
                             "fit to t_c: D_inf / D final - 1 %": 100.0 * (d_cut_inf / final - 1.0)})
    page.table(rows, "Each run's relaxation",
               formats={"R/R_ch": ".3f", "Ca_w": ".3f", "t_end": ".1f", "D final": ".5f", "tau fit": ".2f",
                        "tau / Ca_w": ".2f", "D_inf fit / D final": ".4f"})
    page.table(cut_rows, "A run stopped at t_c: its reading, and the exponential fit's extrapolation, against the "
                         "long run's end",
               formats={"Ca_w": ".3f", "t_c": "g", "t_c / tau": ".2f", "capped at t_c: D / D final - 1 %": "+.2f",
                        "fit to t_c: tau": ".2f", "fit to t_c: D_inf / D final - 1 %": "+.2f"})
    page.write()


if __name__ == "__main__":
    main()
