"""Compute the shipped master curves into src/elastocell/data/.

    python validation/mastercurves.py [NU ...]          compression (nu = 0.45, 0.48, 0.49 by default;
                                                        ELASTOCELL_MASTERCURVE_STEPS=N: load steps, default 60)
    python validation/mastercurves.py shear [NU ...]    shear flow (nu = 0.48 by default)

Compression, each curve: the default p2 mesh and the fine one (mastercurve.MESHES), 60 steps to delta = 0.75
(nu = 0.49: 50 steps -- with 60 the default mesh stops converging at delta = 0.597).

Shear: the shear scenario at every Ca of mastercurve_shear.CAPILLARY_NUMBERS, R/dx = 6 and 8, strain 4 each
(one process, single-threaded compiled steps); the runs go to the cache directory, so an interrupted
computation resumes where it stopped.

The computed curves are summarised in docs/validation/fit.md (``validation/page.py``).
"""

import os
import sys
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "src" / "elastocell" / "data"


PROBES = (0.1, 0.3, 0.5, 0.7)


def compression(values, page):
    import numpy as np

    from elastocell.inverse.mastercurve import SHIPPED_POISSON_RATIOS, compute_master_curve, shipped_name
    from elastocell.scenarios.compression import hertz_force

    rows = []
    for nu in values or SHIPPED_POISSON_RATIOS:
        start = time.perf_counter()
        steps = int(os.environ.get("ELASTOCELL_MASTERCURVE_STEPS", 60))
        curve = compute_master_curve(nu, "neo-hookean", use_cache=False, steps=steps)
        prefix = f"ELASTOCELL_MASTERCURVE_STEPS={steps} " if steps != 60 else ""
        curve.metadata["command"] = (f"{prefix}python validation/mastercurves.py {nu:g}  (== elastocell mastercurve "
                                     f"compression --poisson-ratio {nu:g} --material neo-hookean, {steps} steps)")
        curve.to_csv(DATA / shipped_name(nu), force_default_mesh=curve.force_default_mesh)
        seconds = time.perf_counter() - start
        print(f"nu={nu}: {seconds:.1f} s, meshes {curve.metadata['meshes']}", flush=True)
        probes = np.array(PROBES)
        force, error = curve(probes), curve.relative_error_at(probes)
        meshes = curve.metadata["meshes"]
        rows.append({"nu": nu, "steps": steps,
                     "nodes (default, fine)": f"{meshes['default']['n_nodes']}, {meshes['fine']['n_nodes']}",
                     "F/F_Hertz@0.1": float(force[0] / hertz_force(probes[0], nu)),
                     **{f"F@{d}": float(f) for d, f in zip(PROBES, force, strict=True)},
                     **{f"err@{d}": float(e) for d, e in zip(PROBES, error, strict=True)},
                     "wall_s": seconds})
    page.table(rows, "Compression master curves (F/(E R^2) of the fine mesh; err: |fine - default mesh| over F)",
               formats={"F/F_Hertz@0.1": ".4f", **{f"F@{d}": ".5f" for d in PROBES},
                                    **{f"err@{d}": ".2%" for d in PROBES}, "wall_s": ".0f"})


def shear(values, page):
    from elastocell.inverse.mastercurve_shear import (
        SHIPPED_POISSON_RATIOS,
        compute_shear_master_curve,
        shipped_name,
    )

    for nu in values or SHIPPED_POISSON_RATIOS:
        start = time.perf_counter()

        def report(ca, resolution, summary, start=start):
            print(f"  Ca={ca:g} R/dx={resolution:g}: D={summary['taylor_deformation_mean']:.5f} "
                  f"incl={summary['inclination_deg_mean']:.2f} tt={summary['tank_treading_frequency']:.4f} "
                  f"({summary.get('wall_time_cumulative_s', 0):.0f} s; {time.perf_counter() - start:.0f} s so far)",
                  flush=True)

        curve = compute_shear_master_curve(nu, "neo-hookean", progress=report)
        curve.metadata["command"] = (f"python validation/mastercurves.py shear {nu:g}  (== elastocell mastercurve "
                                     f"shear --poisson-ratio {nu:g} --material neo-hookean)")
        curve.metadata["total_wall_time_s"] = round(time.perf_counter() - start, 1)
        curve.to_csv(DATA / shipped_name(nu))
        print(f"nu={nu}: {time.perf_counter() - start:.1f} s -> {DATA / shipped_name(nu)}", flush=True)
        table = curve.table
        page.table([{"Ca": ca, "D": d, "D/Ca": d / ca, "D error": e, "inclination (deg)": i,
                     "tank treading (x shear rate)": t}
                    for ca, d, e, i, t in zip(table["capillary_number"], table["deformation"],
                                              table["deformation_error"], table["inclination_deg"],
                                              table["tank_treading_frequency"], strict=True)],
                   f"Shear master curve, nu = {nu:g} (Richardson of R/dx 6 and 8; small-Ca theory: D/Ca -> 1.25, "
                   f"45 deg, 0.5); {time.perf_counter() - start:.0f} s",
                   formats={"Ca": "g", "D": ".5f", "D/Ca": ".4f", "D error": ".2e", "inclination (deg)": ".2f",
                            "tank treading (x shear rate)": ".4f"})


INTRO = {
    "compression": (
        "The compression master curves that ship with the package (`src/elastocell/data/`), computed by "
        "this script: F/(E R^2) of a homogeneous neo-Hookean sphere between rigid frictionless plates on the "
        "package's fine p2 mesh, with its discretisation error estimated against the default mesh. The "
        "independent reference is Hertz's closed form, F/(E R^2) = 4/(3 (1 - nu^2)) delta^1.5, which the "
        "curve must approach as delta -> 0: F/F_Hertz at delta = 0.1, where the blend ends (below it the "
        "shipped curve is Hertz's law times a ratio going linearly to 1 at delta = 0). FElupe's curve of the "
        "same sphere is compared in `validation/compression.py` and fitted in `validation/fit.py --felupe`."),
    "shear": (
        "The shear master curve that ships with the package: stationary D, inclination and tank-treading "
        "frequency of a homogeneous cell in shear flow against Ca, Richardson-extrapolated from R/dx = 6 and 8. "
        "The independent reference is the small-deformation limit (docs/theory.md): D/Ca -> 5/4, 45 deg and "
        "1/2 as Ca -> 0."),
}


if __name__ == "__main__":
    from page import Page

    arguments = sys.argv[1:]
    kind = "shear" if arguments[:1] == ["shear"] else "compression"
    page = Page("fit", "mastercurves.py", intro=INTRO[kind])
    if kind == "shear":
        shear([float(v) for v in arguments[1:]], page)
    else:
        compression([float(v) for v in arguments], page)
    page.write()
