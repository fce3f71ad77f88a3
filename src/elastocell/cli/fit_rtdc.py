"""``elastocell fit rtdc``: Young's moduli of the events of RT-DC measurements (``.rtdc`` files) through look-up
tables (see :mod:`elastocell.inverse.rtdc`). Registered on ``fit_app`` of :mod:`elastocell.cli.fit`."""

from __future__ import annotations

from pathlib import Path

import typer

from elastocell.cli.common import user_errors
from elastocell.cli.fit import fit_app
from elastocell.cli.options import opt, takes

HINTS = {"no temperature": " (give --temperature)", "medium unknown to dclab": " (give --medium)"}
"""What to give for the events of a reason that an option can remedy (the exit-3 message)."""


@fit_app.command("rtdc")
@user_errors
@takes(opt("files", annotation=list[Path], help="RT-DC measurements (.rtdc, read by dclab); a folder contributes "
                                                 "its .rtdc files."),
       opt("lut", default=["LE-2D-FEM-19"], shown=None),
       opt("medium", annotation=str | None, default=None,
           help="Medium of a file that records none, or one dclab does not know: one whose viscosity dclab knows, "
                "in any of dclab's spellings, case and blanks ignored (0.49%MC-PBS = CellCarrier | 0.59%MC-PBS = "
                "CellCarrierB | 0.83%MC-PBS | water); a recorded one is kept.", shown="the file's"),
       opt("temperature", help="Temperature of the medium of a file that records none, neither in setup:temperature "
                               "nor per event (temp); a recorded one is kept. Within the viscosity model's range: "
                               "MC-PBS 22-37 degC, water 0-40 degC.",
           shown="the file's"),
       opt("out", default=Path("fits")), opt("no_plots", help="Skip the figure rtdc_events.png."), "quiet")
def fit_rtdc_command(files: list[Path], lut: list[str], medium: str | None, temperature: str | None, out: Path,
                     no_plots: bool, quiet: bool):
    """Young's modulus of every event of RT-DC measurements through look-up tables (dclab's or one elastocell lut
    wrote): dclab scales each table to the file's channel width, flow rate and medium viscosity and corrects the
    deformation for pixelation. Writes rtdc_fits.csv (one row per event and table), rtdc_coverage.csv (per file
    and table) and fit_settings.json; exits 3 when no event of any file has a trustworthy modulus (none lies in a
    table, none could be converted, or only through tables that are not converged)."""
    from elastocell.inverse.rtdc import (
        fit_rtdc,  # lazy: a command loads dclab only when it runs
    )

    result = fit_rtdc(files, lut, out, medium=medium, temperature=temperature, plots=not no_plots)
    coverage = result["coverage"]
    for message in result["warnings"]:  # said even with --quiet: they change what the numbers mean
        typer.echo(f"warning: {message}", err=True)
    if not quiet:
        for row in coverage.to_dict("records"):
            if row.get("flag"):
                typer.echo(f"{row['file']} ({row['lut']}): not converted: {row['flag']}")
                continue
            median = row.get("youngs_modulus_median", float("nan"))
            others = [part for part in str(row.get("not_converted") or "").split("; ")
                      if part and not part.endswith("outside the table")]
            typer.echo(f"{row['file']} ({row['lut']}): {row['converted']} of {row['events']} events in the table"
                       + (f", median E = {median / 1e3:.3g} kPa" if median == median else "")
                       + (" (not trustworthy: the table is not converged)" if row.get("lut_caveat") else "")
                       + "".join(f"; {part}" for part in others))
        for name, (converted, events) in result["totals"].items():
            typer.echo(f"{name}: {converted} of {events} events converted"
                       + (" (not trustworthy: the table is not converged)" if result["caveats"][name] else "")
                       + f" -> {out / 'rtdc_fits.csv'}")
    if not any(result["trusted"].values()):
        reasons = result["reasons"]
        where = f"{out / 'rtdc_coverage.csv'} gives each file's reason"
        if set(reasons) <= {"outside the table"}:
            message = f"no event of any file lies in a table ({where})"
        else:
            counts = "; ".join(f"{count} unreadable file(s)" if reason == "unreadable files"
                               else f"{count} event(s): {reason}{HINTS.get(reason, '')}"
                               for reason, count in sorted(reasons.items(), key=lambda item: -item[1]))
            message = f"no event of any file has a trustworthy modulus ({counts}; {where})"
        typer.echo(f"elastocell: error: {message}", err=True)
        raise typer.Exit(code=3)
