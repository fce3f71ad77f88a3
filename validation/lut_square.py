"""elastocell's look-up-table points in the square RT-DC channel (or its equivalent cylinder) with MC-PBS, against
dclab's HE tables.

    nice python validation/lut_square.py [--radii 5,6] [--moduli 1,2] [--resolution 8] [--duration 60]
                                         [--workers 1] [--out /tmp/lut-square]

RT-DC measures in a square channel (20 um here) filled with a shear-thinning methylcellulose buffer. This script
runs ``elastocell lut --channel-shape square --channel-width 20um --medium 0.59%MC-PBS --temperature 23
--flow-rate 0.04uL/s`` (the duct itself, power-law medium, driving tau_w = G W/4 from the flow rate; resumable:
finished points are read back from ``--out``), then asks dclab which Young's modulus its tables give for each
(area_um, deform) elastocell measured, with dclab's own viscosity of that medium (Buyukurganci 2022) and no
pixelation correction. The independent references are dclab's HE-3D-FEM-22 (Wittwer et al. 2022, 3D FEM,
neo-Hookean cell in a square channel, shear-thinning fluid; the closest to this run) and HE-2D-FEM-22 (the same
authors' axisymmetric cylinder), shipped with dclab. E_dclab/E_input is 1 where both agree. A point that reached
the duration cap before a stationary shape is marked `no (cap)`: its deformation was still changing. The page is
docs/validation/lut_square.md (``validation/page.py``). ``--channel-shape cylinder`` runs the cylinder of radius
1.094 x 10 um instead (the convention of dclab's axisymmetric tables) against HE-2D-FEM-22 first, into the page's
section of ``validation/lut_cylinder.py``.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from elastocell.inverse.lut import FULL, compute_lut

TABLES_BY_SHAPE = {"square": ("HE-3D-FEM-22", "HE-2D-FEM-22"), "cylinder": ("HE-2D-FEM-22", "HE-3D-FEM-22")}
"""dclab's tables asked, per channel shape: the first is the reference of that geometry (the square duct:
Wittwer's 3D table; the cylinder of radius 1.094 W/2: his axisymmetric one), the second the other geometry's."""
TARGET = 0.05  # issue: within 5 % in E of HE-3D-FEM-22 over the common region at the default resolution (the
# same count is printed against HE-2D-FEM-22 for the cylinder, for information)


def _number(value) -> float:
    return float("nan") if value is None else float(value)


def drift(timeseries: Path) -> float:
    """Mean deformation over the last unit of time minus that over the unit before (the stationarity criterion's
    comparison; a positive value is a deformation still growing at the end)."""
    import pandas as pd

    table = pd.read_csv(timeseries)
    end = table["time"].iloc[-1]
    last = table[table["time"] > end - 1.0]["deformation"].mean()
    before = table[(table["time"] > end - 2.0) & (table["time"] <= end - 1.0)]["deformation"].mean()
    return float(last - before)


def relaxation_fit(timeseries: Path, start: float = 2.0) -> tuple[float, float]:
    """(D_inf, tau) of D(t) = D_inf - A exp(-t/tau) fitted to the deformation for t >= ``start`` (units of
    1/gdot_w): an estimate of the stationary deformation of a run stopped before it, trustworthy only where tau is
    well below the run's length (NaN where the fit fails)."""
    import pandas as pd
    from scipy.optimize import curve_fit

    table = pd.read_csv(timeseries)
    late = table[table["time"] >= start]
    t, d = late["time"].to_numpy(), late["deformation"].to_numpy()
    try:
        (d_inf, a, tau), _ = curve_fit(lambda x, d_inf, a, tau: d_inf - a * np.exp(-x / tau), t, d,
                                       p0=(d[-1] * 1.2, d[-1], 3.0), maxfev=20000)
    except RuntimeError:
        return float("nan"), float("nan")
    return float(d_inf), float(tau)


def table_deformation(emodulus, area_um: float, modulus_kpa: float, **kwargs) -> float:
    """The deformation at which dclab's table (``lut_data`` in ``kwargs``) assigns ``modulus_kpa`` to a cell of
    projected area ``area_um``: E(deform) scanned on a fine grid and interpolated (E falls with deform); NaN where
    the table does not reach it."""
    deform = np.linspace(0.001, 0.15, 1500)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e = emodulus.get_emodulus(area_um=np.full_like(deform, area_um), deform=deform, **kwargs)
    inside = np.isfinite(e)
    if not inside.any() or not (e[inside].min() <= modulus_kpa <= e[inside].max()):
        return float("nan")
    order = np.argsort(e[inside])
    return float(np.interp(modulus_kpa, e[inside][order], deform[inside][order]))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--radii", default="5,6", help="cell radii (um), comma-separated")
    parser.add_argument("--moduli", default="1,2", help="Young's moduli (kPa), comma-separated",
                        type=lambda text: [f"{m.strip()}kPa" for m in text.split(",")])
    parser.add_argument("--medium", default="0.59%MC-PBS")
    parser.add_argument("--temperature", type=float, default=23.0, help="degC")
    parser.add_argument("--resolution", type=float, default=None, help="R/dx (default: the full grid's 8)")
    parser.add_argument("--duration", type=float, default=None, help="cap per point, 1/gdot_w (default: lut's)")
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--channel-shape", choices=tuple(TABLES_BY_SHAPE), default="square",
                        help="square: the 20 um duct itself (against HE-3D-FEM-22); cylinder: R_ch = 1.094 x 10 um "
                             "(against HE-2D-FEM-22, the same convention); its section is lut_cylinder.py's")
    parser.add_argument("--channel-wall", choices=("staircase", "interpolated"), default="staircase",
                        help="the cylinder's wall on the lattice (as elastocell lut; staircase: as the page's runs "
                             "were made); an interpolated cylinder writes its own section, "
                             "lut_cylinder.py:interpolated")
    parser.add_argument("--out", type=Path, default=Path("results/lut-square"))
    args = parser.parse_args(argv)
    shape = args.channel_shape
    TABLES = TABLES_BY_SHAPE[shape]  # noqa: N806 - the module's name for the tables, per shape
    from dclab.features import emodulus
    from page import Page

    geometry = ("a SQUARE channel of width 20 um" if shape == "square" else
                "a CYLINDER of radius R_ch = 1.094 x 10 um (the equivalent radius of the 20 um square channel, the "
                "convention of dclab's axisymmetric tables)")
    curved = shape == "cylinder" and args.channel_wall == "interpolated"
    section = ("lut_square.py" if shape == "square" else
               "lut_cylinder.py:interpolated" if curved else "lut_cylinder.py")
    geometry += ", its wall interpolated on every lattice link" if curved else ""
    page = Page("lut_square", section, intro=(
        f"Stationary shapes of a homogeneous cell (neo-Hookean, nu = 0.48, lattice Boltzmann + immersed boundary) "
        f"centred in {geometry}, at Q = 0.04 uL/s in {args.medium} at {args.temperature:g} degC "
        f"(power law of Buyukurganci et al. 2022), run by `elastocell lut --channel-shape {shape}` "
        f"(R/dx {args.resolution or FULL['resolution']:g}, markers at R - 0.3 dx, the flow rate held at the ideal "
        f"channel's Q as a syringe pump, stopped once the deformation is stationary to 1e-3 per unit of 1/gdot_w "
        f"or at {args.duration or FULL['duration']:g} units of 1/gdot_w); Ca_w = tau_w/mu with tau_w the wall shear stress of the gradient G that "
        "carries Q through the empty channel in that power-law medium (G W/4 in the duct, G R_ch/2 in the "
        "cylinder). The independent references are dclab's HE-3D-FEM-22 (Wittwer et al. 2022: 3D FEM, "
        "neo-Hookean cell, square channel, shear-thinning fluid) and HE-2D-FEM-22 (axisymmetric, cylinder), "
        f"{TABLES[0]} the one of this geometry; both "
        "shipped with dclab: dclab is asked which Young's modulus its table gives for each (area_um, deform) "
        "elastocell measured, with dclab's viscosity of the same medium (visc_model buyukurganci-2022) and no "
        "pixelation correction. E_dclab/E_input is 1 where both agree; NaN where the point lies outside dclab's "
        "table. A point that reached the duration cap before a stationary shape is marked `no (cap)`. `deform "
        "correction` is the size of the Richardson correction of an extrapolated point (NaN: one resolution); "
        "`deform at rest` the deformation the undeformed cell's outline reads before the flow acts (a discretisation "
        "offset that dclab's smooth FEM contours do not have); `drift` the mean deformation over the last unit "
        "of 1/gdot_w minus that over the unit before. For points stopped before a stationary shape, `D_inf fit` "
        "and `tau fit` are D(t) = D_inf - A exp(-t/tau) fitted to the deformation from t = 2 on (an estimate "
        f"only, trustworthy where tau is well below t_end), and the last column is {TABLES[0]}'s ratio at "
        f"(area_um, D_inf). `deform {TABLES[0]} at E` is the deformation {TABLES[0]} gives a cell of the same "
        "area and the input E (its table inverted along the deformation), and `deform / that` elastocell's "
        "deformation over it."),
        versions=("dclab", "numba"))
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    result = compute_lut(args.out / "lut.txt", None, "0.04uL/s", None, radii=args.radii, moduli=args.moduli,
                         resolution=args.resolution, duration=args.duration, workers=args.workers,
                         channel_width="20um", channel_shape=shape, medium=args.medium,
                         temperature=args.temperature, channel_wall=args.channel_wall)
    records, settings = result["records"], result["settings"]
    result_runs = Path(result["runs"])
    area = np.array([r["area_um"] for r in records])
    deform = np.array([r["deform"] for r in records])
    dclab_medium = args.medium.replace("%", "% ")
    e_dclab = {}
    for table in TABLES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # points outside the table come back as NaN
            e_dclab[table] = emodulus.get_emodulus(area_um=area, deform=deform, medium=dclab_medium,
                                                   channel_width=20.0, flow_rate=0.04, px_um=0,
                                                   temperature=args.temperature, visc_model="buyukurganci-2022",
                                                   lut_data=table)
    page.print(f"elastocell lut --channel-shape {shape} --channel-width 20um --flow-rate 0.04uL/s --medium "
               f"{args.medium} --temperature {args.temperature:g}: {len(records)} points, "
               f"{time.perf_counter() - start:.0f} s (finished points read back from {args.out})")
    page.print(f"K = {settings['consistency_pa_s_n']:.4g} Pa s^n, n = {settings['flow_index']:.4f}; "
               f"G = {settings['pressure_gradient_pa_m']:.4g} Pa/m, tau_w = {'G W/4' if shape == 'square' else 'G R_ch/2'} = "
               f"{settings['wall_shear_stress_pa']:.4g} Pa, gdot_w = (tau_w/K)^(1/n) = "
               f"{settings['wall_shear_rate_1_s']:.4g} 1/s; dclab's viscosity (fluid_viscosity) "
               f"{settings['viscosity_mpa_s']:.4g} mPa s")
    fits = [relaxation_fit(result_runs / record["key"] / "timeseries.csv") for record in records]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e_fit = emodulus.get_emodulus(area_um=area, deform=np.array([f[0] for f in fits]), medium=dclab_medium,
                                      channel_width=20.0, flow_rate=0.04, px_um=0, temperature=args.temperature,
                                      visc_model="buyukurganci-2022", lut_data=TABLES[0])
    rows = []
    for i, record in enumerate(records):
        row = {"R [um]": record["radius_um"], "E [kPa]": record["emodulus_kpa"],
               "Ca_w": record["options"]["capillary_number_wall"], "area_um": record["area_um"],
               "deform": record["deform"], "deform_std": _number(record.get("deform_std")),
               "deform correction": _number(((record.get("extrapolation") or {}).get("values", {})
                                             .get("deformation", {})).get("correction")),
               "deform at rest": _number(record.get("deformation_initial")),
               "drift": drift(result_runs / record["key"] / "timeseries.csv"),
               "stationary": "yes" if record.get("stationary") else "no (cap)",
               "t_end": _number(record.get("duration")), "wall [s]": _number(record.get("wall_time_s"))}
        for table in TABLES:
            row[f"E {table} [kPa]"] = e_dclab[table][i]
            row[f"ratio {table}"] = e_dclab[table][i] / record["emodulus_kpa"]
        reference = table_deformation(emodulus, record["area_um"], record["emodulus_kpa"], medium=dclab_medium,
                                      channel_width=20.0, flow_rate=0.04, px_um=0, temperature=args.temperature,
                                      visc_model="buyukurganci-2022", lut_data=TABLES[0])
        row[f"deform {TABLES[0]} at E"] = reference
        row["deform / that"] = record["deform"] / reference
        row["D_inf fit"], row["tau fit"] = fits[i]
        row[f"ratio {TABLES[0]} at D_inf"] = e_fit[i] / record["emodulus_kpa"]
        rows.append(row)
    formats = {"R [um]": "g", "E [kPa]": "g", "Ca_w": ".3f", "area_um": ".2f", "deform": ".4f",
               "deform_std": ".4f", "deform correction": ".4f", "deform at rest": ".4f", "drift": "+.4f",
               "t_end": ".2f", "wall [s]": ".0f"}
    formats.update({f"E {t} [kPa]": ".3f" for t in TABLES})
    formats.update({f"ratio {t}": ".3f" for t in TABLES})
    formats.update({f"deform {TABLES[0]} at E": ".4f", "deform / that": ".2f"})
    formats.update({"D_inf fit": ".4f", "tau fit": ".1f", f"ratio {TABLES[0]} at D_inf": ".3f"})
    page.table(rows, formats=formats)
    over = np.array([row["deform / that"] for row in rows])
    moving = sum(row["drift"] > 0 and row["stationary"] != "yes" for row in rows)
    page.print(f"elastocell's deformation over {TABLES[0]}'s at the same area and E: {np.nanmin(over):.2f} to "
               f"{np.nanmax(over):.2f}; {sum(r['stationary'] == 'yes' for r in rows)} of {len(rows)} points "
               f"stationary, {moving} of the others still deforming at t_end (drift > 0), so their ratio is an upper "
               "bound on the stationary E_dclab/E_input if the deformation keeps growing.")
    for column in (f"ratio {TABLES[0]}", f"ratio {TABLES[0]} at D_inf"):
        ratios = np.array([row[column] for row in rows])
        inside = ratios[np.isfinite(ratios)]
        if inside.size:
            page.print(f"{column} (E_dclab/E_input): {inside.min():.3f} to {inside.max():.3f}, median "
                       f"{np.median(inside):.3f}; within {TARGET:.0%} of 1 at {np.sum(np.abs(inside - 1) <= TARGET)} "
                       f"of {inside.size} points inside the table ({ratios.size - inside.size} outside).")
    for failure in result["failures"]:
        page.print(f"failed {failure['key']}: {failure['error']}")
    page.write()


if __name__ == "__main__":
    main()
