"""elastocell's look-up-table points against an independent reference: dclab's LE-2D-FEM-19 table.

    python validation/lut_dclab.py [--radii 5] [--moduli 2,3,5] [--workers 2] [--out results/lut-dclab]

LE-2D-FEM-19 (Mokbel et al. 2017, ACS Biomater. Sci. Eng. 3, 2962; shipped with dclab) holds stationary shapes of
a linear-elastic sphere in the cylinder that stands for a 20 um square channel (R_ch = 1.094 x 10 um), at
Q = 0.04 uL/s and eta = 15 mPa s, computed with axisymmetric FEM. This script runs the same channel and flow with
``elastocell lut --channel-width 20um`` (resumable: finished points are read back from ``--out``), then asks dclab
which Young's modulus LE-2D-FEM-19 gives for each (area_um, deform) elastocell measured. The ratio
E_dclab/E_elastocell is 1 where both models agree; differences come from the material (neo-Hookean, nu = 0.48,
against linear elastic, nu = 0.5), from the discretisations and from elastocell's cell being filled with fluid of
the medium's viscosity (irrelevant at a stationary shape). Points that reached the duration cap before a stationary
shape are marked: their deformation is still growing. The table goes into docs/validation/lut.md
(``validation/page.py``).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from elastocell.inverse.lut import compute_lut


def _number(value) -> float:
    return float("nan") if value is None else float(value)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--radii", default="5", help="cell radii (um), comma-separated")
    parser.add_argument("--moduli", default="2,3,5", help="Young's moduli (kPa), comma-separated",
                        type=lambda text: [f"{m.strip()}kPa" for m in text.split(",")])
    parser.add_argument("--resolution", type=float, default=None, help="R/dx (default: the full grid's 8)")
    parser.add_argument("--duration", type=float, default=None, help="cap per point, 1/gdot_w (default 20)")
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--out", type=Path, default=Path("results/lut-dclab"))
    args = parser.parse_args(argv)
    from dclab.features import emodulus
    from page import Page

    page = Page("lut", "lut_dclab.py", intro=(
        "Stationary shapes of a cell in the channel that stands for a 20 um square channel (R_ch = 1.094 x 10 um) "
        "at Q = 0.04 uL/s and eta = 15 mPa s, run by `elastocell lut --channel-width 20um` (neo-Hookean, "
        "nu = 0.48, lattice Boltzmann + immersed boundary). The independent reference is dclab's LE-2D-FEM-19 "
        "table (Mokbel et al. 2017, axisymmetric FEM of a linear-elastic sphere, nu = 0.5), shipped with dclab: "
        "dclab is asked which Young's modulus its table gives for each (area_um, deform) elastocell measured. "
        "The ratio E_dclab/E_elastocell is 1 where both models agree; differences come from the material, the "
        "discretisations and elastocell's interior fluid (irrelevant at a stationary shape). A point that reached "
        "the duration cap before a stationary shape is marked `no (cap)`: its deformation was still growing."), versions=("dclab", "numba"))
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    result = compute_lut(args.out / "lut.txt", None, "0.04uL/s", "15mPa*s", radii=args.radii, moduli=args.moduli,
                         resolution=args.resolution, duration=args.duration, workers=args.workers,
                         channel_width="20um", channel_wall="staircase")  # the wall its runs had
    records = result["records"]
    area = np.array([r["area_um"] for r in records])
    deform = np.array([r["deform"] for r in records])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # points outside the table come back as NaN
        e_dclab = emodulus.get_emodulus(area_um=area, deform=deform, medium=15.0, channel_width=20.0,
                                        flow_rate=0.04, px_um=0, temperature=None, lut_data="LE-2D-FEM-19")
    page.print(f"elastocell lut --channel-width 20um --flow-rate 0.04uL/s --viscosity 15mPa*s: {len(records)} points, "
               f"{time.perf_counter() - start:.0f} s (finished points read back from {args.out})")
    page.table([{"R [um]": record["radius_um"], "E [kPa]": record["emodulus_kpa"], "area_um": record["area_um"],
                 "deform": record["deform"], "deform_std": _number(record.get("deform_std")),
                 "stationary": "yes" if record.get("stationary") else "no (cap)",
                 "t_end": _number(record.get("duration")), "E_dclab LE-2D-FEM-19 [kPa]": e,
                 "ratio": e / record["emodulus_kpa"]} for record, e in zip(records, e_dclab, strict=True)],
               formats={"R [um]": "g", "E [kPa]": "g", "area_um": ".2f", "deform": ".4f", "deform_std": ".4f",
                        "t_end": ".2f", "E_dclab LE-2D-FEM-19 [kPa]": ".3f", "ratio": ".3f"})
    for failure in result["failures"]:
        page.print(f"failed {failure['key']}: {failure['error']}")
    page.write()

if __name__ == "__main__":
    main()
