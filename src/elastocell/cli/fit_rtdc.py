"""``elastocell fit rtdc``: Young's moduli of the events of RT-DC measurements (``.rtdc`` files) through look-up
tables (see :mod:`elastocell.inverse.rtdc`). Registered on ``fit_app`` of :mod:`elastocell.cli.fit`."""

from __future__ import annotations

from pathlib import Path

import typer

from elastocell.cli.common import user_errors
from elastocell.cli.fit import fit_app
from elastocell.cli.options import opt, takes


@fit_app.command("rtdc")
@user_errors
@takes(opt("files", annotation=list[Path], help="RT-DC measurements (.rtdc, read by dclab); a folder contributes "
                                                 "its .rtdc files."),
       opt("lut", default=["LE-2D-FEM-19"], shown=None),
       opt("medium", annotation=str | None, default=None,
           help="Medium of a file that records none, or one dclab does not know (0.49%MC-PBS | 0.59%MC-PBS | "
                "0.83%MC-PBS | CellCarrier | CellCarrierB | water); a recorded one is kept.", shown="the file's"),
       opt("temperature", help="Temperature of the medium of a file that records none (a recorded one is kept).",
           shown="the file's"),
       opt("out", default=Path("fits")), opt("no_plots", help="Skip the figure rtdc_events.png."), "quiet")
def fit_rtdc_command(files: list[Path], lut: list[str], medium: str | None, temperature: str | None, out: Path,
                     no_plots: bool, quiet: bool):
    """Young's modulus of every event of RT-DC measurements through look-up tables (dclab's or one elastocell lut
    wrote): dclab scales each table to the file's channel width, flow rate and medium viscosity and corrects the
    deformation for pixelation. Writes rtdc_fits.csv (one row per event and table), rtdc_coverage.csv (per file
    and table) and fit_settings.json; exits 3 when no event of any file lies in a table."""
    from elastocell.inverse.rtdc import (
        fit_rtdc,  # lazy: a command loads dclab only when it runs
    )

    result = fit_rtdc(files, lut, out, medium=medium, temperature=temperature, plots=not no_plots)
    coverage = result["coverage"]
    if not quiet:
        for row in coverage.to_dict("records"):
            if row.get("flag"):
                typer.echo(f"{row['file']} ({row['lut']}): not converted: {row['flag']}")
                continue
            median = row.get("youngs_modulus_median", float("nan"))
            typer.echo(f"{row['file']} ({row['lut']}): {row['converted']} of {row['events']} events in the table"
                       + (f", median E = {median / 1e3:.3g} kPa" if median == median else ""))
        for name, (converted, events) in result["totals"].items():
            typer.echo(f"{name}: {converted} of {events} events converted -> {out / 'rtdc_fits.csv'}")
    if not any(converted for converted, _ in result["totals"].values()):
        typer.echo(f"elastocell: error: no event of any file lies in a table ({out / 'rtdc_coverage.csv'} gives "
                   "each file's reason)", err=True)
        raise typer.Exit(code=3)
