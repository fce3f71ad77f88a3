"""Command line: ``elastocell mastercurve compression|shear`` and ``elastocell fit afm|shear``.

Registered in :mod:`elastocell.cli.app` with ``app.add_typer(mastercurve_app, name="mastercurve")`` and
``app.add_typer(fit_app, name="fit")``. Impossible input exits with code 2 and one line (``user_errors``).
"""

from __future__ import annotations

from pathlib import Path

import typer

from elastocell.cli.common import fail, user_errors
from elastocell.cli.options import opt, takes
from elastocell.parameters.units import ParameterError
from elastocell.simulation.distributed import check_execution

mastercurve_app = typer.Typer(add_completion=False, no_args_is_help=True,
                              help="Master curves of a homogeneous cell (computed once, cached, shipped).")
fit_app = typer.Typer(add_completion=False, no_args_is_help=True,
                      help="Fit measurements: Young's modulus from AFM plate compression (afm) or from the "
                           "deformation in shear flow (shear).")

MASTERCURVE_OPTIONS = ("poisson_ratio", "material",
                       opt("out", annotation=Path | None, default=None,
                           help="Write the curve (CSV with # JSON metadata) here.", shown="not written"),
                       "no_cache", opt("quiet", help="No progress, no summary."))


def shipped_cached_or_computed(no_cache: bool, shipped, cache_exists, compute) -> tuple:
    """(curve, source): the shipped curve, the cached one or ``compute()`` (``no_cache``: always computed), and
    which of "shipped", "cached", "computed" it is."""
    curve, source = None, None
    if not no_cache:
        curve = shipped()
        source = "shipped" if curve is not None else None
        if curve is None and cache_exists():
            source = "cached"
    if curve is None:
        curve = compute()
        source = source or "computed"
    return curve, source


@mastercurve_app.command("compression")
@user_errors
@takes(*MASTERCURVE_OPTIONS)
def mastercurve_compression(poisson_ratio: float, material: str, out: Path | None, no_cache: bool, quiet: bool):
    """F/(E R^2) against delta (0..0.75) of a homogeneous sphere: the shipped curve, the cached one, or a fresh
    computation on the default and a finer p2 mesh (their difference is the error column)."""
    from elastocell.inverse.mastercurve import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        cache_path,
        check_inputs,
        compute_master_curve,
        shipped,
    )

    check_inputs(poisson_ratio, material)

    def compute():
        progress = None if quiet else (
            lambda mesh, delta: typer.echo(f"\r{mesh} mesh: delta = {delta:.3f}", err=True, nl=False))
        curve = compute_master_curve(poisson_ratio, material, use_cache=not no_cache, progress=progress)
        if not quiet:
            typer.echo("", err=True)
        return curve

    curve, source = shipped_cached_or_computed(no_cache, lambda: shipped(poisson_ratio, material),
                                               lambda: cache_path(poisson_ratio, material).exists(), compute)
    if out is not None:
        curve.to_csv(out)
    if not quiet:
        table = "  ".join(f"{d:.2f}:{curve(d):.4g}" for d in (0.1, 0.3, 0.5, 0.7))
        worst = float((curve.error / curve.force.clip(1e-300))[curve.delta >= curve.hertz_blend_below].max())
        typer.echo(f"nu={poisson_ratio:g} {material} ({source}): F/(E R^2) at delta {table}; largest relative "
                   f"mesh error above delta {curve.hertz_blend_below:g}: {100 * worst:.2f} %"
                   + (f" -> {out}" if out else ""))


@mastercurve_app.command("indentation")
@user_errors
@takes(*MASTERCURVE_OPTIONS[:2], opt("out", annotation=Path | None, default=None,
                                     help="Write the surface (CSV with # JSON metadata) here.", shown="not written"),
       *MASTERCURVE_OPTIONS[3:], opt("workers", annotation=int, default=1, help="Curves computed at a time."),
       opt("cell_shape", help="sphere (a suspended cell on the dish; R the cell radius) | cap (an adherent cell, "
           "a spherical cap bonded to the dish; R its base radius; apex heights H/R 0.3, 0.4, 0.5, 0.75, 1) | layer (a "
           "layer bonded to the dish; R = h, its thickness)."),
       opt("indenter", help="sphere (a bead: F over depth and R_b/R) | cone (--cell-shape layer: F/(E h^2) over "
           "depth/h and the half-angle, 20-75 deg)."))
def mastercurve_indentation(poisson_ratio: float, material: str, out: Path | None, no_cache: bool, quiet: bool,
                            workers: int, cell_shape: str, indenter: str):
    """F/(E R^2) over depth/R and R_b/R of a homogeneous suspended cell indented by a bead (sphere on a dish), of
    an adherent cap (at each tabulated apex height), or of a bonded layer (R = h): the shipped surface, the cached
    one, or a fresh computation with the axisymmetric solver (default mesh; a finer mesh at a few ratios for the
    error)."""
    import numpy as np

    from elastocell.inverse.indentation_surface import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        cache_path,
        check_inputs,
        check_shape,
        compute_indentation_surface,
        shipped,
        surface_shape,
    )

    check_inputs(poisson_ratio, material)
    check_shape(cell_shape)
    cell_shape = surface_shape(cell_shape, indenter)
    def curve_name(label: str) -> str:  # the cone's ratio is tan(alpha): say the half-angle
        if cell_shape != "cone-layer":
            return f"R_b/{'h' if cell_shape == 'layer' else 'R'} = {label}"
        return f"half-angle {np.degrees(np.arctan(float(label))):.4g} deg"

    progress = None if quiet else (
        lambda label, mesh, seconds: typer.echo(f"{curve_name(label)}, {mesh} mesh: {seconds:.0f} s", err=True))
    surface, source = shipped_cached_or_computed(
        no_cache, lambda: shipped(poisson_ratio, material, cell_shape),
        lambda: cache_path(poisson_ratio, material, cell_shape).exists(),
        lambda: compute_indentation_surface(poisson_ratio, material, cell_shape, use_cache=not no_cache,
                                            progress=progress, workers=workers))
    if out is not None:
        surface.to_csv(out)
    if not quiet:
        error = surface.error / surface.force.clip(1e-300)
        past = surface.depth_fraction() >= 0.1
        worst = float(np.nanmax(np.where(past, error, np.nan)))
        heights = (f" at H/R {', '.join(f'{height:g}' for height in surface.heights)}" if cell_shape == "cap"
                   else "")
        span = (f"R_b/{'h' if cell_shape == 'layer' else 'R'} {surface.ratio_range[0]:g}..."
                f"{surface.ratio_range[1]:g}" if cell_shape != "cone-layer" else
                f"half-angle {np.degrees(np.arctan(surface.ratio_range[0])):.3g}..."
                f"{np.degrees(np.arctan(surface.ratio_range[1])):.3g} deg")
        typer.echo(f"nu={poisson_ratio:g} {material} ({source}): {span}{heights}; largest relative mesh error past a tenth of the depth range: "
                   f"{100 * worst:.2f} %" + (f" -> {out}" if out else ""))


@fit_app.command("afm")
@user_errors
@takes("files", opt("radius", annotation=str | None, default=None, help="Cell radius R.", scale=None,
                    shown="required, except with --cell-shape layer"), "geometry",
       opt("cell_shape", help="sphere-indenter: the cell's shape (sphere: a suspended cell resting on the dish; "
           "cap: an adherent cell, a spherical cap of base radius --radius and apex height --cap-height bonded to "
           "the dish, H/R in [0.3, 1]; layer: a tissue section, gel or flat cell of thickness --layer-thickness "
           "bonded to the dish)."),
       opt("indenter_radius", annotation=str | None, default=None, scale=None, shown="required with sphere-indenter"),
       opt("cap_height", scale=None, shown="required with --cell-shape cap"), opt("layer_thickness", scale=None),
       opt("half_angle", help="--geometry cone: the cone's half-angle (axis to flank); --geometry pyramid: the "
           "face half-angle (axis to face), fitted as the cone of tan(alpha_c) = 2/sqrt(pi) tan(alpha).",
           shown="required with --geometry cone or pyramid"),
       opt("depth_max", annotation=float | None, default=None, help="sphere-indenter, cone, pyramid: fit the data up "
           "to this indenter depth after contact (at most the master surface's range).",
           units="R, the cell radius (the layer: h, its thickness)",
           shown="the master surface's range: min(R_b, R/2) (the cap: about min(R_b, H/2); the cone: h/4)"),
       "spring_constant",
       # parsed by FitSettings (first thing the command does): parse_quantity has no ampere for NT-MDT's nm/nA
       opt("sensitivity", quantity=None, help="Deflection sensitivity (InvOLS): overrides the file's or supplies a "
           "missing one (deflection = sensitivity x detector signal). A quantity like 50nm/V (NT-MDT, whose signal "
           "is a photodiode current: 61nm/nA); a bare number is in nm/V (NT-MDT: nm/nA)."),
       opt("poisson_ratio", help="nu (shipped: 0.45, 0.48, 0.49)."),
       opt("material", help="Master curve's law."),
       "model", opt("delta_max", help="Parallel plates: fit the data up to this delta = 1 - h/(2R) (<= 0.75)."),
       "contact_point",
       "bootstrap", opt("seed", annotation=int, default=0, help="Seed of the bootstrap."), "nucleus_size_ratio",
       opt("stiffness_ratio", annotation=float | None, default=None, help="gamma = E_n/E_c.",
           shown="none: homogeneous"),
       "baseline_fraction", "threshold", "baseline_tilt", opt("out", default=Path("fits")), "no_plots",
       opt("scheduler", help="Run one task per file on this Dask scheduler (e.g. tcp://host:8786); --out must be on "
           "a file system the workers share.", shown="none"),
       opt("workers", help="Run one task per file on a local Dask cluster of N processes.",
           shown="a plain loop, or one worker per core from 150 files on, 1200 with --no-plots"),
       "quiet")
def fit_afm(files: list[Path], radius: str | None, geometry: str, cell_shape: str, indenter_radius: str | None,
            cap_height: str | None, layer_thickness: str | None, half_angle: str | None, depth_max: float | None,
            spring_constant: str | None, sensitivity: str | None,
            poisson_ratio: float, material: str, model: str, delta_max: float, contact_point: str, bootstrap: int,
            seed: int, nucleus_size_ratio: float | None, stiffness_ratio: float | None, baseline_fraction: float,
            threshold: float, baseline_tilt: bool, out: Path, no_plots: bool, scheduler: str | None,
            workers: int | None, quiet: bool):
    """Young's modulus from force curves (plain CSV or instrument files, every curve of a map): master-curve and
    Hertz fits of plate compression, or (--geometry sphere-indenter) master-surface and Hertz-sphere fits of a
    bead indenting a cell on a dish, 95 % CIs; a curve that fails a check is flagged in fits.csv (exit code 3
    when no curve is accepted)."""
    from elastocell.inverse.fit import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        FitSettings,
        fit_files,
    )

    settings = FitSettings(radius=radius, poisson_ratio=poisson_ratio, material=material, geometry=geometry,
                           model=model, delta_max=delta_max, contact_point=contact_point, bootstrap=bootstrap,
                           seed=seed,
                           baseline_fraction=baseline_fraction, threshold=threshold, baseline_tilt=baseline_tilt,
                           nucleus_size_ratio=nucleus_size_ratio, stiffness_ratio=stiffness_ratio,
                           spring_constant=spring_constant, sensitivity=sensitivity, indenter_radius=indenter_radius,
                           cell_shape=cell_shape, cap_height=cap_height, layer_thickness=layer_thickness,
                           depth_max=depth_max, half_angle=half_angle)
    check_execution(scheduler, workers)
    for path in files:
        if not path.exists():
            raise ParameterError("file", f"{path}: no such file or directory")
    result = fit_files(files, settings, out, plots=not no_plots, progress=not quiet,
                       scheduler=scheduler, workers=workers)
    rows, accepted = result["rows"], result["accepted"]
    if not quiet and accepted:
        for row in rows[:20]:
            if row.get("flag"):
                value = row.get("youngs_modulus", float("nan"))
                typer.echo(f"{row['file']}: flagged: {row['flag']}"
                           + (f" (E = {value:.4g} Pa not accepted)" if value == value else ""))
                continue
            hertz = row.get("youngs_modulus_hertz")
            reach = f"delta up to {row['delta_max']:.3f}" if settings.geometry == "parallel-plates" else \
                f"depth up to {row['depth_max'] * 1e6:.3g} um"
            typer.echo(f"{row['file']}: E = {row['youngs_modulus']:.4g} Pa [{row['youngs_modulus_ci_low']:.4g}, "
                       f"{row['youngs_modulus_ci_high']:.4g}] ({row['model']}), {reach}"
                       + (f", Hertz {hertz:.4g} Pa" if hertz == hertz else ""))
        unreadable = f", {len(result['errors'])} unreadable" if result["errors"] else ""
        typer.echo(f"{len(rows)} curve(s), {accepted} accepted, {len(rows) - accepted} flagged{unreadable}, in "
                   f"{result['wall_time_s']:.2f} s ({result['execution']}) -> {out / 'fits.csv'}")
    if result["errors"]:
        for _, message in result["errors"]:
            typer.echo(f"elastocell: error: {message}", err=True)
        raise typer.Exit(code=2)
    if not rows:
        fail("no curve could be fitted")
    if not accepted:
        first = rows[0]
        where = first.get("source", first["file"]) if len(rows) == 1 else \
            f"{len(rows)} curves, the flag column of {out / 'fits.csv'} gives each one's reason; first {first['file']}"
        typer.echo(f"elastocell: error: no curve accepted ({where}): {first['flag']}".replace("\n", " "), err=True)
        raise typer.Exit(code=3)


@mastercurve_app.command("shear")
@user_errors
@takes(*MASTERCURVE_OPTIONS[:3], opt("no_cache", help="Recompute even if shipped or cached (runs too)."),
       MASTERCURVE_OPTIONS[4])
def mastercurve_shear(poisson_ratio: float, material: str, out: Path | None, no_cache: bool, quiet: bool):
    """Stationary D, inclination (degrees) and tank-treading frequency (x shear rate) against Ca of a homogeneous
    cell in shear flow: the shipped curve, the cached one, or a fresh computation (shear runs at 7 Ca and
    R/dx = 6 and 8, about 20 min on one core; resumable); the curve is their Richardson extrapolation."""
    import numpy as np

    from elastocell.inverse.mastercurve_shear import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        cache_path,
        check_inputs,
        compute_shear_master_curve,
        shipped,
    )

    check_inputs(poisson_ratio, material)

    def report(ca, resolution, summary):
        typer.echo(f"Ca = {ca:g}, R/dx = {resolution:g}: D = {summary['taylor_deformation_mean']:.4f} "
                   f"({summary.get('wall_time_s', 0):.0f} s)", err=True)

    curve, source = shipped_cached_or_computed(
        no_cache, lambda: shipped(poisson_ratio, material), lambda: cache_path(poisson_ratio, material).exists(),
        lambda: compute_shear_master_curve(poisson_ratio, material, use_cache=not no_cache,
                                           progress=None if quiet else report))
    if out is not None:
        curve.to_csv(out)
    if not quiet:
        table = "  ".join(f"{ca:g}:{curve(ca) / ca:.4g}" for ca in curve.table["capillary_number"])
        worst = float(np.max(curve.table["deformation_error"] / curve.table["deformation"]))
        typer.echo(f"nu={poisson_ratio:g} {material} ({source}): D/Ca at Ca {table} (small-Ca theory 1.25); "
                   f"largest relative error of D: {100 * worst:.2f} %" + (f" -> {out}" if out else ""))


@fit_app.command("shear")
@user_errors
@takes("deformation", "shear_stress", "deformation_error", "shear_stress_error", "tank_treading_frequency",
       "tank_treading_frequency_error",
       opt("shear_rate", help="Shear rate of the flow (normalises --tank-treading-frequency).", shown="none"),
       opt("radius", annotation=str | None, default=None, help="Cell radius (recorded only; D and Ca are "
           "dimensionless).", scale=None, shown="none"),
       "table", opt("poisson_ratio", help="nu (shipped: 0.48)."), opt("material", help="Master curve's law."),
       "confidence", opt("out", default=Path("fits")), opt("quiet", help="No summary."))
def fit_shear_command(deformation: float | None, shear_stress: str | None, deformation_error: float,
                      shear_stress_error: str, tank_treading_frequency: str | None,
                      tank_treading_frequency_error: str, shear_rate: str | None, radius: str | None,
                      table: Path | None, poisson_ratio: float, material: str, confidence: float, out: Path,
                      quiet: bool):
    """Shear and Young's modulus from the stationary deformation in shear flow (inverts the shear master curve)."""
    from elastocell.inverse.fit import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        fit_shear_cells,
        read_shear_table,
    )

    if table is not None:
        if deformation is not None or shear_stress is not None:
            raise ParameterError("table", "give either --table or --deformation/--shear-stress, not both")
        cells, source = read_shear_table(table), str(table)
    else:
        if deformation is None:
            raise ParameterError("deformation", "missing (or give --table)")
        if shear_stress is None:
            raise ParameterError("shear_stress", "missing (or give --table)")
        cell = {"deformation": deformation, "shear_stress": shear_stress, "deformation_error": deformation_error,
                "shear_stress_error": shear_stress_error, "radius": radius, "cell": "1"}
        if tank_treading_frequency is not None:
            cell.update(tank_treading_frequency=tank_treading_frequency,
                        tank_treading_frequency_error=tank_treading_frequency_error)
        if shear_rate is not None:
            cell["shear_rate"] = shear_rate
        cells, source = [cell], None
    result = fit_shear_cells(cells, out, poisson_ratio=poisson_ratio, material=material, confidence=confidence,
                             source=source)
    if not quiet:
        for row in result["rows"][:20]:
            line = (f"cell {row['cell']}: D = {row['deformation']:.4g} -> Ca = {row['capillary_number']:.4g}, "
                    f"mu = {row['shear_modulus']:.4g} Pa [{row['shear_modulus_ci_low']:.4g}, "
                    f"{row['shear_modulus_ci_high']:.4g}], E = {row['youngs_modulus']:.4g} Pa "
                    f"[{row['youngs_modulus_ci_low']:.4g}, {row['youngs_modulus_ci_high']:.4g}] "
                    f"(small-deformation theory: E = {row['youngs_modulus_small_deformation']:.4g} Pa)")
            if "shear_modulus_tank_treading" in row:
                line += (f"; tank treading: mu = {row['shear_modulus_tank_treading']:.4g} Pa "
                         f"({'consistent' if row['tank_treading_consistent'] else 'INCONSISTENT'}, "
                         f"z = {row['tank_treading_z']:.2f})")
            typer.echo(line)
        typer.echo(f"{len(result['rows'])} cell(s) -> {out / 'shear_fits.csv'}")
