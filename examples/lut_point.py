"""One point of an RT-DC look-up table: a cell carried through the channel to its stationary shape, its projected
area and deformation (area_um, deform), and the Young's modulus dclab's LE-2D-FEM-19 table reads from them.

The channel is the cylinder that stands for a 20 um square RT-DC channel (R_ch = 1.094 x 10 um), at a flow rate of
0.04 uL/s in a 15 mPa s medium: the conditions of dclab's LE-2D-FEM-19 (axisymmetric FEM, linear elastic), so the
two can be compared. ``plan`` turns the physical inputs into the pipe run's dimensionless ones (wall capillary
number, confinement) and ``run_point`` runs it (a centred homogeneous cell, ``elastocell.pipe``) until the mean
deformation over the last unit of 1/gdot_w is stationary. ``elastocell lut`` (``compute_lut``) runs a grid of such
points through Dask and writes the table in dclab's format.

    python examples/lut_point.py                  # full size: R/dx 8, up to 20 units of 1/gdot_w
    ELASTOCELL_EXAMPLE_SMOKE=1 python examples/lut_point.py     # R/dx 4, half a unit of time

Time on a 2-core machine: full size measured 4.8 min with the cores shared with other jobs (the run 259 s,
stationary at t = 17.2: area_um 113.39, deform 0.0283, LE-2D-FEM-19 reads 2.551 kPa); smoke 25-60 s, most of it
importing elastocell and dclab.

At R/dx 8 elastocell's cell deforms more than LE-2D-FEM-19's at equal E, so dclab reads a lower modulus
(README: 2.55 kPa for this point, ratio 0.85; 0.92 at R/dx 12). The smoke run is far from stationary, and its
shape may lie outside dclab's table (then NaN). dclab is optional: without it the comparison is skipped.

Output: ``$ELASTOCELL_EXAMPLE_OUT`` (default ``example-output/lut_point``, ``-smoke`` appended in smoke mode):
``runs/<key>/`` (the pipe run's files and ``point.json``; a rerun reads a finished point back, an unfinished one
resumes) and ``lut_point.json``.
"""

import json
import os
import warnings
from pathlib import Path

from elastocell.inverse.lut import plan, run_point

SMOKE = os.environ.get("ELASTOCELL_EXAMPLE_SMOKE") == "1"
OUT = Path(os.environ.get("ELASTOCELL_EXAMPLE_OUT", "example-output/lut_point" + ("-smoke" if SMOKE else "")))

CHANNEL_WIDTH, FLOW_RATE, VISCOSITY = "20um", "0.04uL/s", "15mPa*s"
RADIUS, MODULUS = "6um", "3kPa"


def main():
    # quick: R/dx 4 and no stationarity test; otherwise R/dx 8, a cap of 20 units of 1/gdot_w, tolerance 1e-3
    size = dict(quick=True, duration=0.5) if SMOKE else {}
    points, settings = plan(None, FLOW_RATE, VISCOSITY, radii=[RADIUS], moduli=[MODULUS],
                            channel_width=CHANNEL_WIDTH, **size)
    point = points[0]
    options = point["options"]
    print(f"R = {RADIUS}, E = {MODULUS}: Ca_w = {options['capillary_number_wall']:.3f}, "
          f"R_ch/R = {options['channel_radius_ratio']:.3f}, gdot_w = {settings['wall_shear_rate_1_s']:.3g} 1/s, "
          f"R/dx = {options['resolution']:g}")

    # A finished point (its point.json) is read back. The pipe run may warn that its summary's means over the second
    # half describe a transient; area_um and deform are averaged over the last unit of time only, the stretch the
    # stop criterion judged stationary ("stationary" below).
    record = run_point((point, str(OUT / "runs")))
    print(f"area_um = {record['area_um']:.2f} um^2, deform = {record['deform']:.4f} +- {record['deform_std']:.4f} "
          f"(stationary: {record['stationary']}, t = {record['duration']:.2f}/gdot_w, {record['wall_time_s']:.0f} s)")

    try:
        from dclab.features import emodulus
    except ImportError:
        emodulus = None
        print("dclab is not installed: no comparison with LE-2D-FEM-19 (pip install dclab)")
    if emodulus is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a shape outside the table comes back as NaN, with a warning
            e_dclab = float(emodulus.get_emodulus(
                area_um=record["area_um"], deform=record["deform"], medium=15.0, channel_width=20.0,
                flow_rate=0.04, px_um=0, temperature=None, lut_data="LE-2D-FEM-19"))
        record["emodulus_le_2d_fem_19_kpa"] = e_dclab
        print(f"LE-2D-FEM-19 reads E = {e_dclab:.3f} kPa from this shape "
              f"(ratio {e_dclab / record['emodulus_kpa']:.3f} to the simulated {record['emodulus_kpa']:g} kPa)")

    (OUT / "lut_point.json").write_text(json.dumps(record, indent=1))
    print(f"record: {OUT / 'lut_point.json'}")


if __name__ == "__main__":
    main()
