"""Shear targets: the homogeneous cell's stationary Taylor deformation, inclination and tank-treading frequency
against Roscoe's finite-Ca theory for a Kelvin-Voigt sphere of viscosity ratio 1 (issue targets: D within 3 %,
inclination within 2 degrees, tank-treading frequency within 3 %, at Ca = 0.05, 0.1, 0.2, 0.3).

Usage::

    nice python validation/shear_targets.py --run --resolutions 8 6 --threads 1   # the runs (cached, JSON lines)
    python validation/shear_targets.py --page                                     # the page from the cache

Runs: ``elastocell.shear`` with its default flow (confinement 2R/H = 0.2, box 8R, particle Reynolds number 0.1,
tau 1, trilinear kernel, uniform p1 mesh with edges of 2 dx), a homogeneous neo-Hookean cell (nu = 0.48, no
nucleus), strain 4, stationary means over strain 2..4 (``summary.json``), at R/dx 8 and 6. Every run's row is
appended to ``--cache`` (JSON lines) as soon as it finishes, so the runs can be made as separate processes and the
page composed from the cache without rerunning.
"""

from __future__ import annotations

import argparse
import inspect
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CAPILLARY_NUMBERS = (0.05, 0.1, 0.2, 0.3)
RESOLUTIONS = (8.0, 6.0)
DURATION = 4.0
CACHE = Path(__file__).resolve().parents[1] / "results" / "shear_targets.jsonl"
KEYS = ("Ca", "R/dx", "duration", "method", "flow")
CONFINEMENT = 0.2  # the default 2R/H of ShearFlowParameters
FLOW_OPTIONS = {"confinement": "2R/H", "box_length": "box (R)", "reynolds_number": "Re_p"}
"""ShearFlowParameters a run may change from the default (``--confinement`` etc.) to size a systematic gap."""


def load_cache(path: Path) -> list[dict]:
    if not path.exists():
        return []
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    for row in rows:
        if "flow" not in row:  # rows written with a confinement only
            confinement = row.get("confinement", CONFINEMENT)
            row["flow"] = {} if confinement == CONFINEMENT else {"confinement": confinement}
    return rows


def cached(rows: list[dict], case: dict) -> dict | None:
    for row in reversed(rows):
        if all(row.get(k) == case[k] for k in KEYS):
            return row
    return None


def run_case(ca: float, resolution: float, duration: float, flow: dict | None = None) -> dict:
    """One ``elastocell.shear`` run of the homogeneous cell; its stationary values as a cache row."""
    import elastocell

    options = {"extrapolate": False} if "extrapolate" in inspect.signature(elastocell.shear).parameters else {}
    with tempfile.TemporaryDirectory(prefix="shear-targets-") as out:
        start = time.perf_counter()
        summary = elastocell.shear(out, capillary_number=ca, resolution=resolution, duration=duration,
                                   vtk_interval=None, nucleus="none", progress=False,
                                   flow_options=dict(flow or {}), **options)
        wall = time.perf_counter() - start
    return {"Ca": ca, "R/dx": resolution, "duration": duration, "method": "single", "flow": dict(flow or {}),
            "D": summary["taylor_deformation_mean"], "D_std": summary.get("taylor_deformation_std"),
            "incl_deg": summary["inclination_deg_mean"], "tt_freq": summary["tank_treading_frequency"],
            "stationary": summary.get("stationary"), "lattice": (summary.get("lattice") or {}).get("shape"),
            "volume_change_max_abs": summary.get("volume_change_max_abs"), "wall_s": round(wall, 1)}


TARGETS = {"D": 3.0, "incl_deg": 2.0, "tt_freq": 3.0}  # %, degrees, %
INTRO = """The issue's shear targets at the default flow settings: the stationary Taylor deformation D within 3 %,
the inclination within 2 degrees and the tank-treading frequency within 3 % of Roscoe's theory (J. Fluid Mech.
28, 273-293, 1967; ``elastocell.scenarios.roscoe``, tested against its known limits in tests/test_roscoe.py)
for a Kelvin-Voigt sphere of viscosity ratio 1, at Ca = 0.05, 0.1, 0.2, 0.3. Reference: Roscoe's incompressible
neo-Hookean solid of shear modulus mu = E/(2(1+nu)), the modulus of Ca = eta shear_rate / mu, in unbounded Stokes
flow; D = (a1 - a2)/(a1 + a2) of its shear-plane semi-axes (the vorticity semi-axis lies between them, so this is
elastocell's D of the largest and smallest semi-axes), the inclination of a1 from the flow direction, the
tank-treading frequency as the rate of a material point's ellipse phase over the shear rate (elastocell's
definition). elastocell: ``elastocell.shear`` with the default flow (confinement 2R/H = 0.2, box 8R, particle
Reynolds number 0.1, tau 1, trilinear kernel, uniform p1 mesh with edges of 2 dx), a homogeneous neo-Hookean
cell with nu = 0.48 (filled with the outer fluid: viscosity ratio 1), strain 4, means over strain 2..4, at
R/dx 8 (the single-resolution default, "before") and 6; "extrapolated" is their Richardson extrapolation of
order 2 (``elastocell.simulation.extrapolation.richardson``), the two-resolution method, with the size of its
correction |X - X_8| as its uncertainty estimate (columns *_unc). Error: (elastocell - Roscoe)/Roscoe;
difference: elastocell - Roscoe. The target and "before" tables come from this script's runs (cached in
results/shear_targets.jsonl); the cross-check puts the shipped shear master curve (the same method at Ca
0.025-0.4, made by ``validation/mastercurves.py``) beside the same reference. Sizing the gap that is left: the
flow-settings table repeats R/dx 6 runs with one setting changed (lower confinement, larger periodic box, lower
Reynolds number), each against the same run at the defaults; the last table takes Ca = 0.3 to three
resolutions with the shipped curve's one R/dx 10 run (its metadata) and extrapolates with the observed order
and with order 2 from R/dx 8 and 10. Roscoe's solid is incompressible and the cell's nu = 0.48: that enters
at second order in the strain (docs/theory.md), of the size of the volume change (column max|dV/V| of the
runs, which also holds the immersed boundary's leak), and is not separated here. The runs were made by
``nice python validation/shear_targets.py --run --threads 1`` with ``--resolutions 8`` and ``--resolutions 6``
(all four Ca), and ``--resolutions 6`` with ``--capillary-numbers 0.3 0.05 --confinement 0.1``,
``--capillary-numbers 0.3 --box-length 12`` and ``--capillary-numbers 0.3 --reynolds-number 0.05``; the
defaults' table by ``--default --capillary-numbers 0.3``, ``0.05``, ``0.1`` and ``0.2`` (``elastocell.shear``
with no resolution options: its extrapolated default with strain 6, means over 3..6, where the tables above use
strain 4); two processes at a time on the shared 2-core machine (most at load average 15-29: their wall times
are not costs)."""


def comparison_rows(values: dict, theory) -> list[dict]:
    """Rows of the target table: ``values`` {Ca: {"D", "incl_deg", "tt_freq"}} against Roscoe's state."""
    rows = []
    for k, ca in enumerate(sorted(values)):
        v = values[ca]
        d, incl, tt = (float(theory.taylor_deformation[k]), float(theory.inclination_deg[k]),
                       float(theory.tank_treading_frequency[k]))
        d_err, incl_diff, tt_err = 100 * (v["D"] / d - 1), v["incl_deg"] - incl, 100 * (v["tt_freq"] / tt - 1)
        rows.append({"Ca": ca, "D": v["D"], "D_Roscoe": d, "D_err_%": d_err,
                     "D_met": "yes" if abs(d_err) <= TARGETS["D"] else "no",
                     "incl_deg": v["incl_deg"], "incl_Roscoe": incl, "incl_diff_deg": incl_diff,
                     "incl_met": "yes" if abs(incl_diff) <= TARGETS["incl_deg"] else "no",
                     "tt_freq": v["tt_freq"], "tt_Roscoe": tt, "tt_err_%": tt_err,
                     "tt_met": "yes" if abs(tt_err) <= TARGETS["tt_freq"] else "no",
                     **{f"_{name}_unc": v.get(f"{name}_unc") for name in ("D", "incl_deg", "tt_freq")}})
    return rows


FORMATS = {"Ca": "g", "D": ".4f", "D_Roscoe": ".4f", "D_err_%": "+.2f", "incl_deg": ".2f", "incl_Roscoe": ".2f",
           "incl_diff_deg": "+.2f", "tt_freq": ".4f", "tt_Roscoe": ".4f", "tt_err_%": "+.2f", "D_unc": ".4f",
           "incl_unc": ".2f", "tt_unc": ".4f"}


def write_page(rows: list[dict]) -> None:
    """The page from the cached runs: targets with the extrapolated values, R/dx 8 alone, the runs, the shipped
    curve; runs missing from the cache are listed as such."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from page import Page
    from scipy.optimize import brentq

    from elastocell.inverse.mastercurve_shear import load_shear_master_curve
    from elastocell.scenarios.roscoe import roscoe_steady_state
    from elastocell.simulation.extrapolation import richardson

    page = Page("shear_targets", "shear_targets.py", intro=INTRO)
    runs = {(r["Ca"], r["R/dx"]): r for r in rows if r.get("method") == "single" and not r["flow"]}
    names = ("D", "incl_deg", "tt_freq")
    fine, extrapolated, missing = {}, {}, []
    for ca in CAPILLARY_NUMBERS:
        f, c = runs.get((ca, 8.0)), runs.get((ca, 6.0))
        if f is None or c is None:
            missing += [f"Ca {ca:g} R/dx {r:g}" for r, run in ((8.0, f), (6.0, c)) if run is None]
        if f is not None:
            fine[ca] = {n: f[n] for n in names}
        if f is not None and c is not None:
            extrapolated[ca] = {n: float(richardson(f[n], c[n], 8.0 / 6.0)) for n in names}
            extrapolated[ca].update({f"{n}_unc": abs(extrapolated[ca][n] - f[n]) for n in names})
    theory = roscoe_steady_state(np.array(CAPILLARY_NUMBERS), 1.0)
    at = {ca: k for k, ca in enumerate(CAPILLARY_NUMBERS)}

    def table(values: dict, heading: str, uncertainty: bool = False) -> None:
        if not values:
            page.print(f"{heading}: no runs in the cache")
            return
        keep = [at[ca] for ca in sorted(values)]
        state = roscoe_steady_state(np.array(sorted(values)), 1.0)
        assert np.allclose(state.taylor_deformation, theory.taylor_deformation[keep])
        out = comparison_rows(values, state)
        columns = ["Ca", "D", "D_Roscoe", "D_err_%", "D_met", "incl_deg", "incl_Roscoe", "incl_diff_deg", "incl_met",
                   "tt_freq", "tt_Roscoe", "tt_err_%", "tt_met"]
        if uncertainty:
            for row in out:
                row.update(D_unc=row["_D_unc"], incl_unc=row["_incl_deg_unc"], tt_unc=row["_tt_freq_unc"])
            columns += ["D_unc", "incl_unc", "tt_unc"]
        page.table(out, heading, columns=columns, formats=FORMATS)
        met = {name: [f"{row['Ca']:g}" for row in out if row[f"{name}_met"] == "yes"] for name in ("D", "incl", "tt")}
        every = ", ".join(f"{row['Ca']:g}" for row in out)
        labels = (("D", "D"), ("incl", "inclination"), ("tt", "tank treading"))
        page.print("within the target at Ca: " + "; ".join(f"{label} {', '.join(met[name]) or 'none'}"
                                                          for name, label in labels) + f" (of {every})")

    page.print(f"targets: |D error| <= {TARGETS['D']:g} %, |inclination difference| <= {TARGETS['incl_deg']:g} deg, "
               f"|tank-treading error| <= {TARGETS['tt_freq']:g} %; Roscoe at viscosity ratio 1")
    if missing:
        page.print("not in the cache (not run): " + ", ".join(missing))
    table(extrapolated, "Targets: extrapolated from R/dx 8 and 6 against Roscoe", uncertainty=True)
    table(fine, "Before: R/dx 8 alone against Roscoe")
    defaults = {r["Ca"]: r for r in rows if r.get("method") == "default"}
    table(defaults, "elastocell.shear at its defaults (R/dx 8 and 6 extrapolated, strain 6, means over 3..6) "
                    "against Roscoe", uncertainty=True)
    raw = [{"Ca": r["Ca"], "R/dx": r["R/dx"], "D": r["D"], "D_std": r["D_std"], "incl_deg": r["incl_deg"],
            "tt_freq": r["tt_freq"], "max|dV/V|": r["volume_change_max_abs"], "wall_s": r["wall_s"]} for r in sorted(runs.values(), key=lambda r: (r["R/dx"], r["Ca"]))]
    page.table(raw, "The runs (strain 4, means over strain 2..4; wall time on one thread of a shared machine)",
               formats={"D": ".5f", "D_std": ".2g", "incl_deg": ".3f", "tt_freq": ".4f", "max|dV/V|": ".2g"})
    curve = load_shear_master_curve(0.48)
    shipped = {ca: {"D": float(curve.value("deformation", ca)), "incl_deg": float(curve.value("inclination_deg", ca)),
                    "tt_freq": float(curve.value("tank_treading_frequency", ca)),
                    "D_unc": float(curve.error("deformation", ca)),
                    "incl_deg_unc": float(curve.error("inclination_deg", ca)),
                    "tt_freq_unc": float(curve.error("tank_treading_frequency", ca))} for ca in CAPILLARY_NUMBERS}
    table(shipped, "Cross-check: the shipped master curve (nu 0.48, R/dx 8 and 6 extrapolated) against Roscoe",
          uncertainty=True)
    gap_rows = []
    for r in sorted(rows, key=lambda r: (r["R/dx"], r["Ca"])):
        base = runs.get((r["Ca"], r["R/dx"]))
        if r.get("method") == "single" and r["flow"] and base is not None:
            gap_rows.append({"Ca": r["Ca"], "R/dx": r["R/dx"],
                             "changed": ", ".join(f"{FLOW_OPTIONS[k]} {v:g}" for k, v in r["flow"].items()),
                             "D_change_%": 100 * (r["D"] / base["D"] - 1),
                             "incl_change_deg": r["incl_deg"] - base["incl_deg"],
                             "tt_change_%": 100 * (r["tt_freq"] / base["tt_freq"] - 1)})
    if gap_rows:
        page.table(gap_rows, "Flow settings: the same run with one setting changed, against the default (2R/H 0.2, "
                             "box 8R, Re_p 0.1)",
                   formats={"D_change_%": "+.2f", "incl_change_deg": "+.2f", "tt_change_%": "+.2f"})
    check = curve.metadata.get("check_rdx10")
    if check:  # three resolutions at Ca = 0.3: the shipped curve's R/dx 6 and 8 and its one R/dx 10 run
        k = int(np.flatnonzero(np.isclose(curve.table["capillary_number"], 0.3))[0])
        state = roscoe_steady_state(0.3, 1.0)
        reference = {"deformation": float(state.taylor_deformation), "inclination_deg": float(state.inclination_deg),
                     "tank_treading_frequency": float(state.tank_treading_frequency)}
        three = []
        for name in reference:
            x6, x8 = curve.table[f"{name}_rdx6"][k], curve.table[f"{name}_rdx8"][k]
            x10 = check[f"{name}_rdx10"]
            # spacings 1/6 : 1/8 : 1/10 are not in a constant ratio: the observed order solves
            # (x6 - x8) / (x8 - x10) = (h6^p - h8^p) / (h8^p - h10^p)
            def gap(p, x6=x6, x8=x8, x10=x10):
                return (x6 - x8) / (x8 - x10) - ((1 / 6) ** p - (1 / 8) ** p) / ((1 / 8) ** p - (1 / 10) ** p)

            order = brentq(gap, 0.2, 6.0) if gap(0.2) * gap(6.0) < 0 else np.nan
            limit = x10 + (x10 - x8) / ((10 / 8) ** order - 1) if np.isfinite(order) else np.nan
            order2 = x10 + (x10 - x8) / ((10 / 8) ** 2 - 1)
            scale = reference[name] / 100 if name != "inclination_deg" else 1.0
            three.append({"quantity": name, "R/dx 6": x6, "R/dx 8": x8, "R/dx 10": x10, "observed order": order,
                          "limit (observed order)": limit, "limit (order 2, 8 and 10)": order2,
                          "Roscoe": reference[name],
                          "gap (observed order)": (limit - reference[name]) / scale,
                          "gap (order 2, 8 and 10)": (order2 - reference[name]) / scale})
        page.table(three, "Ca = 0.3 at three resolutions (the shipped curve's R/dx 6 and 8 runs and its R/dx 10 "
                          "check, strain 4); gap: % for D and the tank treading, degrees for the inclination",
                   formats={"R/dx 6": ".4f", "R/dx 8": ".4f", "R/dx 10": ".4f", "observed order": ".2f",
                            "limit (observed order)": ".4f", "limit (order 2, 8 and 10)": ".4f", "Roscoe": ".4f",
                            "gap (observed order)": "+.2f", "gap (order 2, 8 and 10)": "+.2f"})
    page.write()


def run_default(ca: float) -> dict:
    """``elastocell.shear`` at every default (R/dx 8 and 6 extrapolated, strain 6); its stationary values."""
    import elastocell

    with tempfile.TemporaryDirectory(prefix="shear-targets-default-") as out:
        start = time.perf_counter()
        summary = elastocell.shear(out, capillary_number=ca, vtk_interval=None, nucleus="none", progress=False)
        wall = time.perf_counter() - start
    names = {"D": "taylor_deformation_mean", "incl_deg": "inclination_deg_mean", "tt_freq": "tank_treading_frequency"}
    row = {"Ca": ca, "R/dx": 8.0, "duration": summary["duration_strain"], "method": "default", "flow": {},
           "stationary": summary.get("stationary"), "wall_s": round(wall, 1)}
    for short, name in names.items():
        row[short] = summary[name]
        row[f"{short}_unc"] = summary.get(f"{name}_correction")
    return row


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", action="store_true", help="make the runs not in the cache")
    parser.add_argument("--capillary-numbers", type=float, nargs="*", default=list(CAPILLARY_NUMBERS))
    parser.add_argument("--resolutions", type=float, nargs="*", default=list(RESOLUTIONS))
    parser.add_argument("--duration", type=float, default=DURATION, help="strain of a run")
    parser.add_argument("--confinement", type=float, default=None, help="2R/H of the runs (default 0.2)")
    parser.add_argument("--box-length", type=float, default=None, help="periodic box (R) of the runs (default 8)")
    parser.add_argument("--reynolds-number", type=float, default=None, help="particle Re limit (default 0.1)")
    parser.add_argument("--cache", type=Path, default=CACHE)
    parser.add_argument("--rerun", action="store_true", help="recompute cached runs")
    parser.add_argument("--page", action="store_true", help="write the page from the cache")
    parser.add_argument("--default", action="store_true",
                        help="also run elastocell.shear at its defaults (extrapolated, strain 6) at these Ca")
    parser.add_argument("--threads", type=int, default=None)
    args = parser.parse_args(argv)
    if args.threads:
        import numba

        numba.set_num_threads(max(1, min(args.threads, numba.config.NUMBA_NUM_THREADS)))
    args.cache.parent.mkdir(parents=True, exist_ok=True)
    flow = {k: getattr(args, k) for k in FLOW_OPTIONS if getattr(args, k) is not None}
    if args.run:
        for resolution in args.resolutions:
            for ca in args.capillary_numbers:
                case = {"Ca": ca, "R/dx": resolution, "duration": args.duration, "method": "single",
                        "flow": flow}
                if not args.rerun and cached(load_cache(args.cache), case):
                    continue
                row = run_case(ca, resolution, args.duration, flow)
                print(json.dumps(row), flush=True)
                with args.cache.open("a") as handle:
                    handle.write(json.dumps(row) + "\n")
    if args.default:
        for ca in args.capillary_numbers:
            if not args.rerun and any(r["Ca"] == ca and r["method"] == "default" for r in load_cache(args.cache)):
                continue
            row = run_default(ca)
            print(json.dumps(row), flush=True)
            with args.cache.open("a") as handle:
                handle.write(json.dumps(row) + "\n")
    if args.page:
        write_page(load_cache(args.cache))


if __name__ == "__main__":
    sys.exit(main())
