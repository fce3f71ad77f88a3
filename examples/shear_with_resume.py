"""A homogeneous cell in shear flow, run in two sessions: one cut short by a wall-clock limit, then resumed from its
checkpoint to the full duration, and its stationary Taylor deformation against the small-deformation theory
D = 5/4 Ca.

Lattice Boltzmann fluid + immersed-boundary cell (docs/theory.md). The first call stops when ``wall_clock``
seconds have passed (``stop_reason`` "wall_clock") and leaves ``checkpoint.npz``; the second, with ``resume=True``
and the same options, continues from it (exactly, as if never stopped) up to ``duration``. A batch job that may be
killed is run the same way: start it again with ``resume=True``.

    python examples/shear_with_resume.py          # full size: R/dx 8 and 6, extrapolated (the default), strain 4
    ELASTOCELL_EXAMPLE_SMOKE=1 python examples/shear_with_resume.py   # R/dx 3, strain 1

At full size the run is the default extrapolated one: R/dx 8 (64x80x64 lattice), then R/dx 6, each in its own
resumable sub-directory, and D Richardson-extrapolated from the two (docs/usage/flow.md); the wall clock of the
first session stops it inside the R/dx 8 run, and the second session finishes both. Its cost beside a single
R/dx 8 run: docs/validation/flow_default.md. Smoke (R/dx 3, a single resolution): about 15 s.

Output: ``$ELASTOCELL_EXAMPLE_OUT`` (default ``example-output/shear_with_resume``, ``-smoke`` appended in smoke
mode): ``timeseries.csv``, ``summary.json``, ``taylor_deformation.png``, ``checkpoint.npz`` and (full size)
``vtk/`` (at full size each resolution's in ``resolution-8/``, ``resolution-6/``). Same as ``elastocell shear --nucleus none --capillary-number 0.05 --wall-clock ... --out DIR``, then
the same command with ``--resume``.
"""

import os
import warnings
from pathlib import Path

import elastocell

SMOKE = os.environ.get("ELASTOCELL_EXAMPLE_SMOKE") == "1"
OUT = Path(os.environ.get("ELASTOCELL_EXAMPLE_OUT", "example-output/shear_with_resume" + ("-smoke" if SMOKE else "")))

CA = 0.05  # capillary number eta * shear_rate / mu: small, where D = 5/4 Ca holds


def main():
    options = dict(capillary_number=CA, nucleus="none", progress=not SMOKE)
    if SMOKE:  # a tiny lattice: R/dx 3, walls closer (confinement 2R/H = 0.3), one unit of strain
        options.update(resolution=3, mesh_size=0.5, duration=1.0, record_interval=0.1, checkpoint_every=2,
                       vtk_interval=None, flow_options={"confinement": 0.3})
        wall_clock = 0.3
    else:      # R/dx 8 and 6, extrapolated (the default), strain 4: D is stationary from strain 1-2 on
        options.update(resolution=8, duration=4.0)
        wall_clock = 45.0

    # Session 1: stops after wall_clock seconds of time stepping (or at the duration, if that comes first).
    with warnings.catch_warnings():  # its means describe a transient, which it would warn about: expected here
        warnings.simplefilter("ignore", UserWarning)
        first = elastocell.shear(out=OUT, wall_clock=wall_clock, **options)
    print(f"session 1: stopped by {first['stop_reason']} at strain {first['duration_strain']:.2f}")

    # Session 2: the same options and resume=True continue from OUT/checkpoint.npz to the full duration.
    final = elastocell.shear(out=OUT, resume=True, **options)
    print(f"session 2: resumed={final['resumed']}, stopped by {final['stop_reason']} at strain "
          f"{final['duration_strain']:.2f}, {final['wall_time_cumulative_s']:.1f} s of time stepping in all")

    # Means over the second half of the run; "stationary" says whether D and the inclination stopped drifting there.
    d = final["taylor_deformation_mean"]
    single = final.get("taylor_deformation_mean_rdx8")  # present when extrapolated: the R/dx 8 run's own D
    print(f"averaging window stationary: {final['stationary']}")
    print(f"Taylor deformation D = {d:.4f} +- {final['taylor_deformation_std']:.4f}, 5/4 Ca = {1.25 * CA:.4f}, "
          f"D/Ca = {d / CA:.3f} (theory 1.25; a single run's excess falls like (dx/R)^2"
          + (f"; R/dx 8 alone: D/Ca = {single / CA:.3f})" if single is not None else ")"))
    print(f"inclination {final['inclination_deg_mean']:.1f} deg, tank treading {final['tank_treading_frequency']:.3f} "
          f"x shear rate (theory 45 deg and 1/2 as Ca -> 0)")
    print(f"plot: {OUT / 'taylor_deformation.png'}")


if __name__ == "__main__":
    main()
