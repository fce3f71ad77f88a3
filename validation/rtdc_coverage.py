"""Real RT-DC measurements through look-up tables: coverage and moduli, dclab's tables and elastocell's.

    python validation/rtdc_coverage.py [--shipped] [--lut elastocell_table.txt ...] [--temperature 23] [--out DIR]

The measurements are dclab's own test files (tests/data/rtdc, 79 events: 20 and 30 um channels, CellCarrier and
CellCarrierB, see the README there). Every event is converted by ``elastocell fit rtdc`` (dclab's
``get_emodulus``: the table scaled to the file's channel width, flow rate and medium viscosity, pixelation
correction, no extrapolation) through dclab's LE-2D-FEM-19, HE-2D-FEM-22 and HE-3D-FEM-22, the tables elastocell
ships (``--shipped``: ``elastocell.shipped_luts()``, by identifier) and any table given with ``--lut`` (one ``elastocell lut``
wrote). A file that records no temperature is converted at
``--temperature`` (the RT-DC standard 23 degC by default: an assumption, said in the table). Reported: each
table's coverage (events inside it) per file and in all, and each table's modulus over HE-3D-FEM-22's (the 3D
square-channel, shear-thinning reference) on the events both convert. The page is docs/validation/rtdc.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
from page import Page

# validation/compression.py would shadow the standard library's `compression` package that JAX tries first
sys.path.remove(str(Path(__file__).resolve().parent))

from elastocell.inverse.rtdc import DCLAB_TABLES, fit_rtdc, table_name  # noqa: E402
from elastocell.inverse.shipped_luts import shipped_luts  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "rtdc"
REFERENCE = "HE-3D-FEM-22"


def unpack(directory: Path) -> list[Path]:
    files = []
    for archive in sorted(DATA.glob("*.zip")):
        with zipfile.ZipFile(archive) as z:
            z.extractall(directory / archive.stem)
        files += sorted((directory / archive.stem).rglob("*.rtdc"))
    return files


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lut", action="append", default=[], help="elastocell table(s) in dclab's format")
    parser.add_argument("--shipped", action="store_true", help="also the tables elastocell ships")
    parser.add_argument("--temperature", type=float, default=23.0, help="degC, for files that record none")
    parser.add_argument("--out", type=Path, default=None)
    arguments = parser.parse_args()
    start = time.time()
    page = Page("rtdc", "rtdc_coverage.py", intro=(
        "dclab's test measurements (tests/data/rtdc: 8 files, 79 events) converted event by event by `elastocell "
        "fit rtdc` through dclab's tables and elastocell's: coverage, and the modulus over HE-3D-FEM-22's on the "
        "events both convert. A real event's modulus has no known truth; the spread between tables built on "
        "different models is the point."))
    out = arguments.out or Path(tempfile.mkdtemp(prefix="rtdc-coverage-"))
    files = unpack(out / "measurements")
    shipped = list(shipped_luts()) if arguments.shipped else []  # by identifier, as a user names them
    if arguments.shipped and not shipped:
        raise SystemExit("--shipped: this elastocell ships no look-up table")
    tables = [*DCLAB_TABLES, *shipped, *arguments.lut]
    result = fit_rtdc(files, tables, out / "fit", temperature=arguments.temperature, plots=False)
    coverage, events = result["coverage"], result["events"]

    page.print(f"files that record no temperature are converted at {arguments.temperature:g} degC (marked *); "
               "tables: " + ", ".join(table_name(t) for t in tables))
    rows = []
    for name in dict.fromkeys(coverage["file"]):
        part = coverage[coverage["file"] == name].set_index("lut")
        first = part.iloc[0]
        assumed = "" if first.get("flag") or "temperature_c" not in part else (
            "*" if "--temperature" in str(first.get("temperature_source", "")) else "")
        row = {"file": name, "channel_um": first.get("channel_width_um", float("nan")),
               "flow_uL_s": first.get("flow_rate_ul_s", float("nan")),
               "medium": first.get("medium", ""), "T_degC": f"{first.get('temperature_c', float('nan')):.4g}{assumed}",
               "events": int(first["events"])}
        for table in tables:
            entry = part.loc[table_name(table)]
            row[table_name(table)] = "-" if entry.get("flag") else int(entry["converted"])
        row["flag"] = first.get("flag") or ""
        rows.append(row)
    totals = {"file": "all", "events": int(coverage.groupby("file")["events"].first().sum())}
    for table in tables:
        converted, count = result["totals"][table_name(table)]
        totals[table_name(table)] = f"{converted} ({100 * converted / count:.0f} %)"
    rows.append(totals)
    page.table(rows, "events inside each table, per file (-: not converted, the flag says why)")

    reference = events[events["lut"] == REFERENCE].set_index(["file", "event"])["youngs_modulus"]
    ratios = []
    for table in tables:
        name = table_name(table)
        if name == REFERENCE:
            continue
        values = events[events["lut"] == name].set_index(["file", "event"])["youngs_modulus"]
        ratio = (values / reference).to_numpy()
        ratio = ratio[np.isfinite(ratio)]
        q1, median, q3 = np.percentile(ratio, [25, 50, 75]) if len(ratio) else (np.nan,) * 3
        ratios.append({"table": name, "events_both": len(ratio), "median": median, "q1": q1, "q3": q3,
                       "min": np.min(ratio) if len(ratio) else np.nan,
                       "max": np.max(ratio) if len(ratio) else np.nan})
    page.table(ratios, f"E_table / E_{REFERENCE} on the events both convert",
               formats={"median": ".3f", "q1": ".3f", "q3": ".3f", "min": ".3f", "max": ".3f"})
    page.print(f"wall time {time.time() - start:.0f} s; per-event moduli in {out / 'fit' / 'rtdc_fits.csv'}")
    page.write()


if __name__ == "__main__":
    main()
