"""``elastocell lut``: a look-up table for RT-DC (dclab's text format) from pipe-flow runs over a grid of cell
radii and Young's moduli (see :mod:`elastocell.inverse.lut`)."""

from __future__ import annotations

from pathlib import Path

import typer

from elastocell.cli.common import user_errors
from elastocell.cli.options import opt, takes


@user_errors
@takes("channel_radius", "channel_width",
       opt("channel_shape", help="cylinder (the cylinder R_ch = 1.094 W/2 stands for a square channel of width W, "
                                 "as dclab's LE-2D-FEM-19) | square (the square duct itself, as HE-3D-FEM-22); a "
                                 "rectangle is refused.", shown="cylinder"),
       opt("channel_height", help="Height H of the channel: a table is made for square channels only (H = W).",
           shown="--channel-width"), "channel_wall", "volume_correction",
       "flow_rate", opt("viscosity", help="Viscosity of a Newtonian medium.",
                        shown="none: required with --medium newtonian"),
       opt("medium", help="newtonian (with --viscosity) | 0.49%MC-PBS | 0.59%MC-PBS | 0.83%MC-PBS (RT-DC buffers: "
                          "power laws of Buyukurganci et al. 2022 at --temperature, as dclab)."),
       opt("temperature", help="Temperature of an MC-PBS medium, within its fit (22-37 degC)."),
       opt("flow_index", help="Not taken by lut: a Newtonian medium has n = 1 and an MC-PBS preset sets its own n "
           "at --temperature (a bare power law is refused: a table needs its consistency K too)."),
       opt("channel_length", help="Length L of the channel (RT-DC chips: about 300um, measured near the outlet): each "
           "point is read when its cell, started undeformed at the inlet, has travelled L, instead of at its "
           "stationary shape; --duration is then the cap and --stationary-tolerance is refused."),
       opt("out", help="LUT file to write (dclab text format); the isoelastics go to <stem>_isoelastics.txt and the "
                       "runs to <stem>_runs/."),
       opt("radii", shown="the default grid: 6 radii spanning the (area, deformation) region of dclab's table for "
           "the channel shape (LE-2D-FEM-19, HE-3D-FEM-22) at this channel and flow (docs/usage/lut.md); --quick: "
           "5,6 um"),
       opt("moduli", shown="the default grid: 8 moduli at about equal steps of log deformation over that region; "
           "--quick: 1,2 kPa"),
       opt("quick", help="2 x 2 grid at R/dx 4 for one unit of time (tests; not converged)."),
       opt("stiffness_ratio", annotation=float | None, default=None,
           help="gamma = E_n/E_c: a table for a cell with a centred spherical nucleus (the pipe's nucleus cell); "
                "its emodulus column is then the cytoplasm's E_c.", shown="none: a homogeneous cell"),
       opt("size_ratio", annotation=float | None, default=None, help="lambda = R_n/R of the nucleus (needs "
           "--stiffness-ratio).", shown="0.5 with --stiffness-ratio"),
       opt("poisson_ratio", help="Cell Poisson ratio."), opt("material", help="Hyperelastic law of the cell."),
       opt("resolution", annotation=float | None, default=None, shown="8; --quick: 4"),
       opt("extrapolate", default=False, shown="off: one run per point, the markers at R - 0.3 dx",
           help="Also run each point at --coarse-resolution (in <stem>_runs/<point>/resolution-<R/dx>/) "
                "and extrapolate its area and deformation to dx -> 0 (Richardson, order 2)."),
       "coarse_resolution", opt("hydrodynamic_radius_correction", default=0.3),  # the pipe's default
       opt("duration", annotation=float | None, default=None, help="Longest run per point.", units="1/gdot_w",
           shown="120, stopping earlier once stationary; --quick: 1; with --channel-length 1.5 times the transit at the mean flow speed"),
       opt("stationary_tolerance", help="Stop a point once its deformation is stationary to this fraction.",
           shown="1e-3; --quick and --channel-length: off"),
       "identifier", "subdivisions", opt("scheduler", help="Dask scheduler address."),
       opt("workers", help="Local Dask workers."), "quiet")
def lut(channel_radius: str | None, channel_width: str | None, channel_shape, channel_height: str | None, channel_wall,
        volume_correction,
        flow_rate: str, viscosity: str | None, medium: str, temperature: str | None, flow_index: float | None,
        channel_length: str | None, out: Path,
        radii: str | None, moduli: str | None, quick: bool, stiffness_ratio: float | None,
        size_ratio: float | None, poisson_ratio: float, material: str,
        resolution: float | None, extrapolate: bool, coarse_resolution: float | None,
        hydrodynamic_radius_correction: float, duration: float | None,
        stationary_tolerance: float | None,
        identifier: str | None, subdivisions: int, scheduler: str | None, workers: int | None, quiet: bool):
    """Look-up table for deformability cytometry: pipe-flow runs over cell radii x moduli (Dask, resumable)
    written as area_um / deform / emodulus in dclab's format, with isoelastics. Register it with
    dclab.features.emodulus.register_lut(FILE)."""
    from elastocell.inverse.lut import (  # lazy: a command loads JAX/Numba only when it runs (--help 0.3 s, not 2.5 s)
        VOLUME_DRIFT,
        compute_lut,
    )

    result = compute_lut(out, channel_radius, flow_rate, viscosity, radii=radii, moduli=moduli, quick=quick,
                         poisson_ratio=poisson_ratio, material=material, resolution=resolution, duration=duration,
                         stationary_tolerance=stationary_tolerance, identifier=identifier, scheduler=scheduler,
                         workers=workers, progress=not quiet, channel_width=channel_width,
                         channel_shape=None if channel_shape is None else channel_shape.value,
                         channel_height=channel_height, medium=medium, temperature=temperature,
                         flow_index=flow_index, extrapolate=extrapolate, coarse_resolution=coarse_resolution,
                         hydrodynamic_radius_correction=hydrodynamic_radius_correction,
                         stiffness_ratio=stiffness_ratio, size_ratio=size_ratio, channel_length=channel_length,
                         channel_wall=channel_wall.value, volume_correction=volume_correction.value,
                         subdivisions=subdivisions)
    if not quiet:
        settings = result["settings"]
        typer.echo(f"{settings.get('cell_description', 'homogeneous cell')}, "
                   f"{settings['channel_shape']} channel, {settings['medium']}: G = "
                   f"{settings['pressure_gradient_pa_m']:.4g} Pa/m, tau_w = {settings['wall_shear_stress_pa']:.4g} Pa, "
                   f"gdot_w = {settings['wall_shear_rate_1_s']:.4g} 1/s; {len(result['records'])} of {len(result['records']) + len(result['failures'])} points "
                   f"in {result['wall_time_s']:.1f} s")
        if result["not_stationary"]:
            typer.echo(f"warning: {len(result['not_stationary'])} point(s) reached the duration cap before "
                       f"their state ({settings['state']}; listed in the metadata, elastocell.not_stationary): "
                       "raise --duration", err=True)
        if result.get("outline_fallback"):
            typer.echo(f"warning: {len(result['outline_fallback'])} point(s) were read partly through the nodes' hull, "
                       "not the smooth side-view outline (listed in the metadata, elastocell.outline_fallback): their "
                       "deform is biased by the mesh-scale roughness, and the table leaves them out", err=True)
        if result.get("volume_drift"):
            typer.echo(f"warning: the cell's volume drifted by more than {VOLUME_DRIFT:.1%} at "
                       f"{len(result['volume_drift'])} point(s) (the immersed boundary's leak; listed in the metadata, "
                       "elastocell.volume_drift): their shape is swollen; --volume-correction projection holds the "
                       "volume", err=True)
        for failure in result["failures"]:
            typer.echo(f"failed {failure['key']}: {failure['error']}", err=True)
        if result["records"]:
            typer.echo(f"wrote {result['lut']} (identifier {result['identifier']}) and {result['isoelastics']}")
    if not result["records"]:  # the runs failed (exit code 1), the input was checked before they started
        typer.echo(f"elastocell: error: no grid point finished "
                   f"({result['failures'][0]['error'] if result['failures'] else 'empty grid'})", err=True)
        raise typer.Exit(code=1)
    if result["failures"]:
        raise typer.Exit(code=1)


@user_errors
def shipped_luts():
    """The RT-DC look-up tables that ship with elastocell: identifier, file, channel, flow rate, medium. In Python,
    elastocell.register_lut() registers them all with dclab by their identifiers."""
    from elastocell.inverse.shipped_luts import (
        shipped_luts as tables,  # lazy: a command loads its modules only when it runs
    )

    found = tables()
    if not found:  # an empty listing, not an error of the input (exit code 2 is for those)
        typer.echo("this version of elastocell ships no look-up table: make one with elastocell lut")
        return
    for identifier, table in found.items():
        meta = table["metadata"]
        settings = meta.get("elastocell", {})
        typer.echo(f"{identifier}: {settings.get('channel_shape', '?')} channel {meta['channel_width']:g} um, "
                   f"{meta['flow_rate']:g} uL/s, {settings.get('medium', 'newtonian')}"
                   + (f" at {settings['temperature_c']:g} degC" if settings.get("temperature_c") is not None else "")
                   + f", {settings.get('state', 'stationary')}\n  {table['path']}"
                   + (f"\n  {table['isoelastics']}" if table["isoelastics"] else ""))
