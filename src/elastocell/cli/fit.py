"""Command line: ``elastocell mastercurve compression`` and ``elastocell fit afm``.

Registered in :mod:`elastocell.cli.app` with ``app.add_typer(mastercurve_app, name="mastercurve")`` and
``app.add_typer(fit_app, name="fit")``. Impossible input exits with code 2 and one line (``user_errors``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from elastocell.cli.common import OPTION_NAMES, fail, user_errors
from elastocell.parameters.units import ParameterError
from elastocell.simulation.distributed import check_execution

for _name in ("model", "geometry", "contact_point", "nucleus_size_ratio", "bootstrap", "baseline_fraction",
              "threshold", "scheduler", "workers", "deformation", "deformation_error", "shear_stress",
              "shear_stress_error", "tank_treading_frequency", "tank_treading_frequency_error", "table",
              "confidence"):
    OPTION_NAMES.setdefault(_name, "--" + _name.replace("_", "-"))

mastercurve_app = typer.Typer(add_completion=False, no_args_is_help=True,
                              help="Master curves of a homogeneous cell (computed once, cached, shipped).")
fit_app = typer.Typer(add_completion=False, no_args_is_help=True,
                      help="Fit measurements: Young's modulus from AFM plate compression (afm) or from the "
                           "deformation in shear flow (shear).")


@mastercurve_app.command("compression")
@user_errors
def mastercurve_compression(
    poisson_ratio: float = typer.Option(0.48, "--poisson-ratio", help="nu in (-1, 0.5)."),
    material: str = typer.Option("neo-hookean", "--material", help="neo-hookean | mooney-rivlin."),
    out: Path | None = typer.Option(None, "--out", help="Write the curve (CSV with # JSON metadata) here."),  # noqa: UP007
    no_cache: bool = typer.Option(False, "--no-cache", help="Recompute even if shipped or cached."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress, no summary."),
):
    """F/(E R^2) against delta (0..0.75) of a homogeneous sphere: the shipped curve, the cached one, or a fresh
    computation on the default and a finer p2 mesh (their difference is the error column)."""
    from elastocell.inverse.mastercurve import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        cache_path,
        check_inputs,
        compute_master_curve,
        shipped,
    )

    check_inputs(poisson_ratio, material)
    curve, source = None, None
    if not no_cache:
        curve = shipped(poisson_ratio, material)
        source = "shipped" if curve is not None else None
        if curve is None and cache_path(poisson_ratio, material).exists():
            source = "cached"
    if curve is None:
        show = not quiet and sys.stderr.isatty()
        progress = (lambda mesh, delta: typer.echo(f"\r{mesh} mesh: delta = {delta:.3f}", err=True, nl=False)) \
            if show else None
        curve = compute_master_curve(poisson_ratio, material, use_cache=not no_cache, progress=progress)
        source = source or "computed"
        if show:
            typer.echo("", err=True)
    if out is not None:
        curve.to_csv(out)
    if not quiet:
        table = "  ".join(f"{d:.2f}:{curve(d):.4g}" for d in (0.1, 0.3, 0.5, 0.7))
        worst = float((curve.error / curve.force.clip(1e-300))[curve.delta >= curve.hertz_blend_below].max())
        typer.echo(f"nu={poisson_ratio:g} {material} ({source}): F/(E R^2) at delta {table}; largest relative "
                   f"mesh error above delta {curve.hertz_blend_below:g}: {100 * worst:.2f} %"
                   + (f" -> {out}" if out else ""))


@fit_app.command("afm")
@user_errors
def fit_afm(
    files: list[Path] = typer.Argument(..., help="Curves: plain CSV (columns displacement in m, force in N) or "
                                                  "afmformats files; a folder contributes its files."),
    radius: str = typer.Option(..., "--radius", help="Cell radius R, e.g. 8um (plain number: metres)."),
    geometry: str = typer.Option("parallel-plates", "--geometry", help="parallel-plates (the only one)."),
    poisson_ratio: float = typer.Option(0.48, "--poisson-ratio", help="nu (shipped: 0.45, 0.48, 0.49)."),
    material: str = typer.Option("neo-hookean", "--material", help="Master curve's law."),
    model: str = typer.Option("both", "--model", help="master | hertz | both (master is youngs_modulus)."),
    delta_max: float = typer.Option(0.75, "--delta-max", help="Fit the data up to this delta (<= 0.75)."),
    contact_point: str = typer.Option("auto", "--contact-point", help="auto, or a displacement (e.g. 1.2um)."),
    bootstrap: int = typer.Option(0, "--bootstrap", help="Residual-bootstrap replicas for a second CI."),
    seed: int = typer.Option(0, "--seed", help="Seed of the bootstrap."),
    nucleus_size_ratio: float | None = typer.Option(  # noqa: UP007
        None, "--nucleus-size-ratio", help="lambda: also report E_c and E_n (needs --stiffness-ratio)."),
    stiffness_ratio: float | None = typer.Option(None, "--stiffness-ratio", help="gamma = E_n/E_c."),  # noqa: UP007
    baseline_fraction: float = typer.Option(0.2, "--baseline-fraction", help="Share of the approach for the baseline."),
    threshold: float = typer.Option(5.0, "--threshold", help="Contact: force above threshold*sigma of the baseline."),
    baseline_tilt: bool = typer.Option(False, "--baseline-tilt", help="Subtract a sloped baseline (default: offset)."),
    out: Path = typer.Option(Path("fits"), "--out", help="Output directory."),
    no_plots: bool = typer.Option(False, "--no-plots", help="Skip the per-curve PNGs (faster for many curves)."),
    scheduler: str | None = typer.Option(  # noqa: UP007
        None, "--scheduler", help="Run one task per file on this Dask scheduler (e.g. tcp://host:8786); --out "
                                  "must be on a file system the workers share."),
    workers: int | None = typer.Option(  # noqa: UP007
        None, "--workers", help="Run one task per file on a local Dask cluster of N processes. Default: a plain "
                                "loop, or one worker per core from 150 files on (1200 with --no-plots)."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar, no summary."),
):
    """Young's modulus from plate-compression force curves: master-curve and Hertz fits, 95 % CIs."""
    from elastocell.inverse.fit import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        FitSettings,
        fit_files,
        parse_length,
    )

    radius_m = parse_length(radius, "radius")
    contact = None if contact_point.strip().lower() == "auto" else parse_length(contact_point, "contact_point")
    settings = FitSettings(radius=radius_m, poisson_ratio=poisson_ratio, material=material, geometry=geometry,
                           model=model, delta_max=delta_max, contact_point=contact, bootstrap=bootstrap, seed=seed,
                           baseline_fraction=baseline_fraction, threshold=threshold, baseline_tilt=baseline_tilt,
                           nucleus_size_ratio=nucleus_size_ratio, stiffness_ratio=stiffness_ratio)
    check_execution(scheduler, workers)
    for path in files:
        if not path.exists():
            raise ParameterError("file", f"{path}: no such file or directory")
    result = fit_files(files, settings, out, plots=not no_plots, progress=not quiet and sys.stderr.isatty(),
                       scheduler=scheduler, workers=workers)
    if not quiet and result["rows"]:
        for row in result["rows"][:20]:
            hertz = row.get("youngs_modulus_hertz")
            typer.echo(f"{row['file']}: E = {row['youngs_modulus']:.4g} Pa [{row['youngs_modulus_ci_low']:.4g}, "
                       f"{row['youngs_modulus_ci_high']:.4g}] ({row['model']}), delta up to {row['delta_max']:.3f}"
                       + (f", Hertz {hertz:.4g} Pa" if hertz == hertz else ""))
        typer.echo(f"{len(result['rows'])} curve(s) in {result['wall_time_s']:.2f} s ({result['execution']}) -> "
                   f"{out / 'fits.csv'}")
    if result["errors"]:
        for _, message in result["errors"]:
            typer.echo(f"elastocell: error: {message}", err=True)
        raise typer.Exit(code=2)
    if not result["rows"]:
        fail("no curve could be fitted")


@mastercurve_app.command("shear")
@user_errors
def mastercurve_shear(
    poisson_ratio: float = typer.Option(0.48, "--poisson-ratio", help="nu in (-1, 0.5)."),
    material: str = typer.Option("neo-hookean", "--material", help="neo-hookean | mooney-rivlin."),
    out: Path | None = typer.Option(None, "--out", help="Write the curve (CSV with # JSON metadata) here."),  # noqa: UP007
    no_cache: bool = typer.Option(False, "--no-cache", help="Recompute even if shipped or cached (runs too)."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress, no summary."),
):
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
    curve, source = None, None
    if not no_cache:
        curve = shipped(poisson_ratio, material)
        source = "shipped" if curve is not None else None
        if curve is None and cache_path(poisson_ratio, material).exists():
            source = "cached"
    if curve is None:
        def report(ca, resolution, summary):
            typer.echo(f"Ca = {ca:g}, R/dx = {resolution:g}: D = {summary['taylor_deformation_mean']:.4f} "
                       f"({summary.get('wall_time_s', 0):.0f} s)", err=True)

        curve = compute_shear_master_curve(poisson_ratio, material, use_cache=not no_cache,
                                           progress=None if quiet else report)
        source = source or "computed"
    if out is not None:
        curve.to_csv(out)
    if not quiet:
        table = "  ".join(f"{ca:g}:{curve(ca) / ca:.4g}" for ca in curve.table["capillary_number"])
        worst = float(np.max(curve.table["deformation_error"] / curve.table["deformation"]))
        typer.echo(f"nu={poisson_ratio:g} {material} ({source}): D/Ca at Ca {table} (small-Ca theory 1.25); "
                   f"largest relative error of D: {100 * worst:.2f} %" + (f" -> {out}" if out else ""))


@fit_app.command("shear")
@user_errors
def fit_shear_command(
    deformation: float | None = typer.Option(  # noqa: UP007
        None, "--deformation", help="Stationary Taylor deformation D = (a-b)/(a+b)."),
    shear_stress: str | None = typer.Option(  # noqa: UP007
        None, "--shear-stress", help="tau = eta * shear rate, e.g. 15Pa (plain number: Pa)."),
    deformation_error: float = typer.Option(0.0, "--deformation-error", help="Standard uncertainty of D (1 sigma)."),
    shear_stress_error: str = typer.Option("0", "--shear-stress-error", help="Standard uncertainty of tau (Pa)."),
    tank_treading_frequency: str | None = typer.Option(  # noqa: UP007
        None, "--tank-treading-frequency", help="Angular frequency, e.g. 300rad/s (Hz is converted x 2 pi); "
                                                "needs --shear-rate. A second, independent estimate."),
    tank_treading_frequency_error: str = typer.Option("0", "--tank-treading-frequency-error",
                                                      help="Its standard uncertainty (rad/s)."),
    shear_rate: str | None = typer.Option(None, "--shear-rate", help="e.g. 1000/s."),  # noqa: UP007
    radius: str | None = typer.Option(None, "--radius", help="Cell radius (recorded only; D and Ca are "  # noqa: UP007
                                                             "dimensionless)."),
    table: Path | None = typer.Option(  # noqa: UP007
        None, "--table", help="CSV of cells: deformation, shear_stress (Pa), optional deformation_error, "
                              "shear_stress_error, tank_treading_frequency (rad/s), shear_rate (1/s), cell."),
    poisson_ratio: float = typer.Option(0.48, "--poisson-ratio", help="nu (shipped: 0.48)."),
    material: str = typer.Option("neo-hookean", "--material", help="Master curve's law."),
    confidence: float = typer.Option(0.95, "--confidence", help="Confidence level of the intervals."),
    out: Path = typer.Option(Path("fits"), "--out", help="Output directory."),
    quiet: bool = typer.Option(False, "--quiet", help="No summary."),
):
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
