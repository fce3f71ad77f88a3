"""``elastocell lut``: a look-up table for RT-DC (dclab's text format) from pipe-flow runs over a grid of cell
radii and Young's moduli (see :mod:`elastocell.inverse.lut`)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from elastocell.cli.common import OPTION_NAMES, fail, user_errors

for _name in ("channel_radius", "channel_width", "flow_rate", "viscosity", "radii", "moduli", "quick", "poisson_ratio",
              "material", "resolution", "duration", "stationary_tolerance", "identifier", "scheduler",
              "workers", "out"):
    OPTION_NAMES.setdefault(_name, "--" + _name.replace("_", "-"))


@user_errors
def lut(
    channel_radius: str | None = typer.Option(None, "--channel-radius",  # noqa: UP007
                                              help="Radius R_ch of the cylindrical channel, e.g. 10.94um (a "
                                                   "number: um). Give this or --channel-width. The table is "
                                                   "labelled for the square channel of width 2 R_ch/1.094."),
    channel_width: str | None = typer.Option(None, "--channel-width",  # noqa: UP007
                                             help="Width W of a square RT-DC channel, e.g. 20um (a number: um): "
                                                  "the cylinder R_ch = 1.094 W/2 stands for it (Mietke et al. "
                                                  "2015; dclab's LE-2D-FEM-19)."),
    flow_rate: str = typer.Option(..., "--flow-rate", help="Flow rate Q, e.g. 0.04uL/s (a number: uL/s)."),
    viscosity: str = typer.Option(..., "--viscosity",
                                  help="Medium viscosity (Newtonian), e.g. 15mPa*s (a number: mPa s)."),
    out: Path = typer.Option(..., "--out", help="LUT file to write (dclab text format); the isoelastics go "
                                                "to <stem>_isoelastics.txt and the runs to <stem>_runs/."),
    radii: str | None = typer.Option(None, "--radii",  # noqa: UP007
                                     help="Cell radii, comma-separated (numbers: um). Default 3,4,5,6,7,8 "
                                          "(--quick: 5,6)."),
    moduli: str | None = typer.Option(None, "--moduli",  # noqa: UP007
                                      help="Young's moduli, comma-separated (numbers: kPa). Default "
                                           "0.5,0.75,1,1.5,2,3,5 (--quick: 1,2)."),
    quick: bool = typer.Option(False, "--quick", help="2 x 2 grid at R/dx 4 for one unit of time (tests; "
                                                      "not converged)."),
    poisson_ratio: float = typer.Option(0.48, "--poisson-ratio", help="Cell Poisson ratio."),
    material: str = typer.Option("neo-hookean", "--material", help="Hyperelastic law of the cell."),
    resolution: float | None = typer.Option(None, "--resolution",  # noqa: UP007
                                            help="R/dx (default 8; --quick 4)."),
    duration: float | None = typer.Option(None, "--duration",  # noqa: UP007
                                          help="Longest run per point, units of 1/gdot_w (default 20; --quick 1)."),
    stationary_tolerance: float | None = typer.Option(None, "--stationary-tolerance",  # noqa: UP007
                                                      help="Stop a point once its deformation is stationary "
                                                           "to this fraction (default 1e-3; --quick: off)."),
    identifier: str | None = typer.Option(None, "--identifier",  # noqa: UP007
                                          help="LUT identifier for dclab (default elastocell-<stem>)."),
    scheduler: str | None = typer.Option(None, "--scheduler", help="Dask scheduler address (default: a "  # noqa: UP007
                                                                   "local cluster)."),
    workers: int | None = typer.Option(None, "--workers", help="Local Dask workers (default: one per core)."),  # noqa: UP007
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar, no summary."),
):
    """Look-up table for deformability cytometry: pipe-flow runs over cell radii x moduli (Dask, resumable)
    written as area_um / deform / emodulus in dclab's format, with isoelastics. Register it with
    dclab.features.emodulus.register_lut(FILE)."""
    from elastocell.inverse.lut import (
        compute_lut,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    result = compute_lut(out, channel_radius, flow_rate, viscosity, radii=radii, moduli=moduli, quick=quick,
                         poisson_ratio=poisson_ratio, material=material, resolution=resolution, duration=duration,
                         stationary_tolerance=stationary_tolerance, identifier=identifier, scheduler=scheduler,
                         workers=workers, progress=not quiet and sys.stderr.isatty(), channel_width=channel_width)
    if not quiet:
        settings = result["settings"]
        typer.echo(f"gdot_w = {settings['wall_shear_rate_1_s']:.4g} 1/s, G = {settings['pressure_gradient_pa_m']:.4g} "
                   f"Pa/m; {len(result['records'])} of {len(result['records']) + len(result['failures'])} points "
                   f"in {result['wall_time_s']:.1f} s")
        if result["not_stationary"]:
            typer.echo(f"warning: {len(result['not_stationary'])} point(s) reached the duration cap before a "
                       "stationary shape (listed in the metadata, elastocell.not_stationary): raise --duration",
                       err=True)
        for failure in result["failures"]:
            typer.echo(f"failed {failure['key']}: {failure['error']}", err=True)
        if result["records"]:
            typer.echo(f"wrote {result['lut']} (identifier {result['identifier']}) and {result['isoelastics']}")
    if not result["records"]:
        fail(f"no grid point finished ({result['failures'][0]['error'] if result['failures'] else 'empty grid'})")
    if result["failures"]:
        raise typer.Exit(code=1)
