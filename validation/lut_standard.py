"""The shipped RT-DC look-up tables: compute the standard one in pieces and ship it, with the tables scaled from it,
into src/elastocell/data.

    python validation/lut_standard.py run [--workers 2] [--tables DIR]
    python validation/lut_standard.py status [--tables DIR]
    python validation/lut_standard.py ship [--tables DIR] [--data DIR]
    python validation/lut_standard.py compare [--tables DIR] [--page]

``run`` computes the standard table (20 um square channel, 0.04 uL/s, 0.59 % MC-PBS, 23 degC, the default grid of
``elastocell lut``) with exactly the command a user gives, in ``validation/tables/`` by default. It is resumable:
each finished point leaves ``<stem>_runs/<key>/point.json``, which git keeps (the checkpoints and time series
beside it are ignored), so a computation that takes longer than one sitting goes on from the committed points;
an unfinished point resumes from its checkpoint where that is still on disk, otherwise from its start. A checkpoint
also restarts from the start when the lattice's numbers change even at round-off: its fingerprint holds the run's
lattice units, whose centre-line speed of a power-law channel the lattice itself computes (the tau table of the
power-law kernels moved it by 2e-11 and so restarted two points at t 42 and 30): a change of the kernels costs
every unfinished point its progress.

The other standard configurations (20 um at 0.08 uL/s, 30 um at 0.16 uL/s) are the same dimensionless problem: a
power-law medium of one flow index n (MC-PBS at one temperature) makes the stationary shape a function of Ca_w =
tau_w/mu, R_ch/R and n only, and tau_w scales as (Q/W^3)^n. Their tables are therefore the standard table's
points scaled as dclab scales every table (``dclab.features.emodulus.scale_linear``: area by (W'/W)^2, the modulus
by the ratio of the wall shear stresses), not new runs: tests/test_lut_grid.py checks on the code's own inputs that each scaled point plans the standard
point's run (the same options, Ca_w equal to rounding). dclab would scale the standard table to those setups the
same way; the scaled tables give them their own identifiers, not new information.

``compare`` reads the finished points through dclab's HE-3D-FEM-22 at the same conditions (section
"lut_standard.py" of docs/validation/lut_square.md), and sets each beside the same cell run with the volume
projection (``--volume-correction projection``, the runs' keys of that option) where such a twin was finished in
the runs directory: the size of the immersed boundary's volume leak's effect on the table.

``ship`` writes the finished standard table (every point finished, none failed) and the scaled ones into
src/elastocell/data as ``lut_<name>.txt`` with their isoelastics; ``elastocell.register_lut()`` registers them.
The table (as every table ``elastocell lut`` writes) holds the computed points and, between them, rows
interpolated in the grid's parameters (``elastocell.inverse.lut.refined_rows``: ln area and ln deform bilinear in
ln R and ln E, 8 steps per interval), because dclab reads a table linearly in (area, deform), which between the
grid's points overstates E by several per cent; its metadata say how many rows are which (``elastocell.rows``),
the isoelastics are the computed points'. ``compare`` measures both readings against HE-3D-FEM-22 over the common
region.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TABLES = ROOT / "validation" / "tables"
DATA = ROOT / "src" / "elastocell" / "data"

MEDIUM, TEMPERATURE = "0.59%MC-PBS", 23.0
STANDARD = {"channel_width_um": 20.0, "flow_rate_ul_s": 0.04}
SCALED = ({"channel_width_um": 20.0, "flow_rate_ul_s": 0.08}, {"channel_width_um": 30.0, "flow_rate_ul_s": 0.16})


def table_name(config: dict) -> str:
    """``lut_square_20um_0.04uLs_0.59MC-PBS_23C``: the file stem (and, with ``elastocell-``, the identifier)."""
    return (f"lut_square_{config['channel_width_um']:g}um_{config['flow_rate_ul_s']:g}uLs_"
            f"{MEDIUM.replace('%', '')}_{TEMPERATURE:g}C")


def command(config: dict, out: Path, workers: int) -> list[str]:
    """The ``elastocell lut`` command line of a configuration (the user's command, so the keys are the user's)."""
    return [sys.executable, "-m", "elastocell", "lut", "--channel-shape", "square",
            "--channel-width", f"{config['channel_width_um']:g}um", "--flow-rate", f"{config['flow_rate_ul_s']:g}uL/s",
            "--medium", MEDIUM, "--temperature", f"{TEMPERATURE:g}", "--workers", str(workers), "--out", str(out)]


def plan_of(config: dict, volume_correction: str | None = None):
    """The points and settings of a configuration's table (``volume_correction`` "projection": those of its twins
    run with the volume projection)."""
    from elastocell.inverse.lut import plan

    return plan(None, f"{config['flow_rate_ul_s']:g}uL/s", None, channel_width=f"{config['channel_width_um']:g}um",
                channel_shape="square", medium=MEDIUM, temperature=TEMPERATURE, volume_correction=volume_correction)


def finished(tables: Path, config: dict) -> dict[str, dict]:
    """The finished points of a configuration's table in ``tables``: {key: point.json's record}."""
    runs = tables / f"{table_name(config)}_runs"
    return {path.parent.name: json.loads(path.read_text()) for path in sorted(runs.glob("*/point.json"))}


def checkpoint_time(run: Path) -> float | None:
    """The time (1/gdot_w) an unfinished point's checkpoint has reached, None without one."""
    import numpy as np

    path = run / "checkpoint.npz"
    try:
        with np.load(path, allow_pickle=False) as data:
            return float(data["series_time"][-1])
    except (OSError, KeyError, ValueError):  # none yet, or being replaced
        return None


def status(tables: Path) -> None:
    points, metadata = plan_of(STANDARD)
    done = finished(tables, STANDARD)
    runs = tables / f"{table_name(STANDARD)}_runs"
    states, started = {}, []
    for point in points:
        record = done.get(point["key"])
        states.setdefault(point["radius_um"], []).append(
            "." if record is None else "h" if (record.get("outline_fallback") or 0) > 0
            else {"stationary": "s"}.get(record.get("state"), "c"))
        reached = None if record is not None else checkpoint_time(runs / point["key"])
        if reached is not None:
            started.append(f"R {point['radius_um']:g} um / E {point['emodulus_kpa']:g} kPa at t {reached:.1f}")
    print(f"{table_name(STANDARD)}: {sum(p['key'] in done for p in points)} of {len(points)} points finished "
          "(s stationary, h read on the nodes' hull: left out of the table's rows, c duration cap, . to run; moduli "
          "ascending)")
    for radius, marks in sorted(states.items()):
        print(f"  R {radius:4.1f} um  {' '.join(marks)}")
    if started:
        print(f"checkpoints of unfinished points (cap t {metadata['duration']:g}): " + "; ".join(started))


def run(tables: Path, workers: int) -> None:
    out = tables / f"{table_name(STANDARD)}.txt"
    subprocess.run(command(STANDARD, out, workers), check=False)
    status(tables)


def scaled_metadata(metadata: dict, config: dict, rows: list[dict]) -> dict:
    """The metadata of the table of ``config`` scaled from the standard one (``metadata``): dclab's keys for the
    new channel, flow rate and viscosity; the date, method and summary say that it is the standard table scaled,
    and the standard table's per-point bookkeeping (its run keys and states) moves under ``scaled_from_points``."""
    from elastocell.inverse.lut import lut_metadata

    _, settings = plan_of(config)
    settings.pop("default_grid", None)  # the configuration's own rounded grid: not the rows of this table
    name = table_name(config)
    scaled = lut_metadata(settings, f"elastocell-{name}")
    origin = (f"Scaled from {metadata['identifier']} by dclab.features.emodulus.scale_linear (area by (W'/W)^2, "
              "emodulus by the wall shear stress ratio): in a power-law medium of one flow index the same "
              "dimensionless runs (Ca_w, R_ch/R, n); dclab scales the standard table to this channel and flow "
              "rate the same way, so this table adds a name for the setup, not new runs. ")
    scaled["summary"] = origin + metadata["summary"]
    scaled["method"] = f"{metadata['method']}, scaled from {metadata['identifier']}"
    scaled["date"] = metadata["date"]
    points = {k: v for k, v in metadata["elastocell"].items()
              if k in ("points", "finished", "failed", "not_stationary", "not_extrapolated", "outline_fallback",
                       "point_states", "rows")}
    scaled["elastocell"] = {**settings, "scaled_from": metadata["identifier"], "scaled_from_points": points,
                            "moduli_kpa": sorted({round(r["emodulus_kpa"], 6) for r in rows})}
    return scaled


def ship(tables: Path, data: Path = DATA) -> None:
    from elastocell.inverse.lut import isoelastics_path, read_lut, write_isoelastics, write_lut

    points, _ = plan_of(STANDARD)
    done = finished(tables, STANDARD)
    missing = [p["key"] for p in points if p["key"] not in done]
    if missing:
        raise SystemExit(f"ship: {len(missing)} of {len(points)} points of the standard table are not finished "
                         f"({', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''}): run it first")
    source = tables / f"{table_name(STANDARD)}.txt"
    if not source.is_file():
        raise SystemExit(f"ship: no {source}: run `python validation/lut_standard.py run` once (it reads the "
                         "finished points back and writes the table)")
    table, metadata, _ = read_lut(source)
    own = metadata["elastocell"]
    keys = set(own.get("point_states", {}))
    computed = len(points) - len(own.get("outline_fallback", []))  # hull readings are left out
    counted = own.get("rows", {})
    if (keys != {p["key"] for p in points} or own.get("failed") or counted.get("computed") != computed
            or len(table) != computed + counted.get("interpolated", 0)):
        raise SystemExit(f"ship: {source} is not the table of the {len(points)} finished points (its rows, point "
                         "keys or failed points differ): run it once more so that it is rewritten from them")
    isoelastics, _, _ = read_lut(isoelastics_path(source))  # the computed points
    outputs = [(source.name, table, isoelastics, metadata)]
    for config in SCALED:  # the same rows scaled, as dclab scales any table
        lines = scaled_rows(isoelastics, metadata, config)
        outputs.append((f"{table_name(config)}.txt", scaled_rows(table, metadata, config), lines,
                        scaled_metadata(metadata, config, _records(lines))))
    for name, rows, lines, meta in outputs:
        write_lut(data / name, _records(rows), meta)
        write_isoelastics(isoelastics_path(data / name), _records(lines), meta)
        print(f"wrote {data / name} ({len(rows)} rows, {computed} of them computed)")


def _records(rows) -> list[dict]:
    return [{"area_um": a, "deform": d, "emodulus_kpa": e} for a, d, e in rows]


def scaled_rows(rows, metadata: dict, config: dict):
    """The rows (area_um, deform, emodulus in kPa) of the standard table scaled to ``config``'s channel and flow
    rate as dclab scales any table (``dclab.features.emodulus.scale_linear``)."""
    import numpy as np
    from dclab.features.emodulus.scale_linear import scale_area_um, scale_emodulus

    _, settings = plan_of(config)
    width = float(config["channel_width_um"])
    area = scale_area_um(rows[:, 0], metadata["channel_width"], width)
    emodulus = scale_emodulus(rows[:, 2], metadata["channel_width"], width, metadata["flow_rate"],
                              float(config["flow_rate_ul_s"]), metadata["fluid_viscosity"], settings["viscosity_mpa_s"])
    return np.column_stack([area, rows[:, 1], np.asarray(emodulus)])


COMPARED = "HE-3D-FEM-22"
"""dclab's table of the same problem (square channel, neo-Hookean cell, shear-thinning MC-PBS; Wittwer et al.)."""


def compare(tables: Path, write_page: bool) -> None:
    """Each finished point of the standard table read through dclab's HE-3D-FEM-22 at the table's own conditions
    (20 um, 0.04 uL/s, 0.59 % MC-PBS at 23 degC, dclab's buyukurganci-2022 viscosity, no pixelation correction):
    E_dclab / E_input per point and the share within 5 % (issue 25's target) among the points inside dclab's
    table; written into docs/validation/lut_square.md with ``--page``."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import numpy as np
    from page import Page

    from elastocell.inverse.rtdc import MC_PBS_VISCOSITY_MODEL, Conditions, emodulus_of_events

    points, metadata = plan_of(STANDARD)
    done = finished(tables, STANDARD)
    records = [done[p["key"]] for p in points if p["key"] in done]
    conditions = Conditions(STANDARD["channel_width_um"], STANDARD["flow_rate_ul_s"], 0.0, "0.59% MC-PBS",
                            TEMPERATURE, MC_PBS_VISCOSITY_MODEL)
    e_pa, notes = emodulus_of_events(np.array([r["area_um"] for r in records]),
                                     np.array([r["deform"] for r in records]), conditions, COMPARED)
    rows = [{"R [um]": r["radius_um"], "E [kPa]": r["emodulus_kpa"], "state": r["state"],
             "t_end": r.get("duration"), "area_um": r["area_um"], "deform": r["deform"],
             f"E {COMPARED} [kPa]": 1e-3 * e, "ratio": 1e-3 * e / r["emodulus_kpa"],
             "max |dV/V|": r.get("volume_change_max_abs", float("nan")),
             "hull": r.get("outline_fallback", float("nan"))}
            for r, e in zip(records, e_pa, strict=True)]
    hull = [row for row in rows if (row["hull"] or 0) > 0]  # left out of the table's rows
    kept = [row for row in rows if not (row["hull"] or 0) > 0]
    inside = [row for row in kept if np.isfinite(row["ratio"])]
    within = [row for row in inside if abs(row["ratio"] - 1.0) <= 0.05]
    summary = (f"{len(records)} of {len(points)} points finished, {len(hull)} of them read on the nodes' hull and left "
               f"out of the table; of the {len(kept)} others {len(inside)} inside {COMPARED}, "
               f"E_dclab/E_input within 5 % at {len(within)} of them"
               + (f" (ratios {min(r['ratio'] for r in inside):.3f} to {max(r['ratio'] for r in inside):.3f})"
                  if inside else "") + f"; {len(kept) - len(inside)} outside its (area, deformation) range")
    page = Page("lut_square", "lut_standard.py", intro=(
        f"The finished points of the standard table ({table_name(STANDARD)}: `elastocell lut`'s default grid, "
        "square channel 20 um, 0.04 uL/s, 0.59 % MC-PBS at 23 degC, R/dx 8, each point to a stationary shape or "
        f"the duration cap t = {metadata['duration']:g}/gdot_w, state `cap`) read through dclab's {COMPARED} at the same conditions "
        "(buyukurganci-2022 viscosity, no pixelation correction). `ratio`: E_dclab/E_input (1 where the two "
        "tables agree); `max |dV/V|`: the largest volume change of the cell in its run (the immersed boundary's "
        "leak, docs/validation/pipe_dclab.md); `hull`: the share of the final window's records whose side view is "
        "the nodes' hull, not the smooth outline (its deform is biased high; `elastocell lut` leaves such a point out of "
        "the table's rows, state `hull` where it stopped on it). The runs' ducts are the channel's own width (whole lattice nodes, the cell's R/dx moved to "
        "make it so: 7.90-8.13). Near its convex hull (the "
        "softest, most deformed cells of an area) dclab's HE-3D-FEM-22 is not FEM runs but its isoelastics "
        "extrapolated by third-order polynomials (the header of dclab's lut_HE-3D-FEM-22.txt), so a ratio there "
        "compares with an extrapolation. The table is computed in pieces (`python validation/lut_standard.py run`), so this section "
        "grows with it; dclab's notes: " + ("; ".join(n.rstrip(".") for n in notes) or "none") + "."))
    page.table(rows, f"Finished points of the standard table against {COMPARED}",
               formats={"t_end": ".1f", "area_um": ".2f", "deform": ".5f", f"E {COMPARED} [kPa]": ".3f",
                        "ratio": ".3f", "max |dV/V|": ".2g", "hull": ".2f"})
    page.print(summary)
    # ``done`` holds every point.json of the runs directory: the table's and its twins run with the projection
    projected = {(p["radius_um"], p["emodulus_kpa"]): done.get(p["key"]) for p in plan_of(STANDARD, "projection")[0]}
    pairs = [(r, projected.get((r["radius_um"], r["emodulus_kpa"]))) for r in records]
    effect = [{"R [um]": r["radius_um"], "E [kPa]": r["emodulus_kpa"], "deform": r["deform"],
               "deform projected": twin["deform"], "deform ratio": twin["deform"] / r["deform"],
               "area ratio": twin["area_um"] / r["area_um"], "max |dV/V|": r.get("volume_change_max_abs"),
               "t_end": r.get("duration"), "t_end projected": twin.get("duration")}
              for r, twin in pairs if twin is not None]
    if effect:
        page.table(effect, "The volume leak's effect: table points against their twins run with the projection",
                   formats={"deform": ".5f", "deform projected": ".5f", "deform ratio": ".4f", "area ratio": ".4f",
                            "max |dV/V|": ".2g", "t_end": ".1f", "t_end projected": ".1f"})
        page.print(f"{len(effect)} points also run with --volume-correction projection (their volume held to 1e-14): "
                   f"deform projected / table {min(e['deform ratio'] for e in effect):.4f} to "
                   f"{max(e['deform ratio'] for e in effect):.4f}, area {min(e['area ratio'] for e in effect):.4f} to "
                   f"{max(e['area ratio'] for e in effect):.4f}; `max |dV/V|`: the table point's largest volume "
                   "change, which the projection holds at zero.")
    interpolation(page, records, conditions)
    if write_page:
        page.write()


def interpolation(page, records: list[dict], conditions) -> None:
    """How the table is read between its points. (1) Left-one-out along E at each radius: each interior point
    predicted from its two neighbours (twice the grid's spacing) by the shipped tables' interpolation (ln deform
    linear in ln E, ``refined_rows``) and by dclab's linear reading in deform, as the error of the E each assigns
    to the point's true deformation. (2) The common region: a grid of (area, deform) read through HE-3D-FEM-22
    and through the table's kept points written with 1, 2, 4 and 8 subdivisions (1: the computed points alone,
    dclab's linear reading between them) and through the shipped file."""
    import math
    import tempfile

    import numpy as np

    from elastocell.inverse.lut import REFINE_SUBDIVISIONS, read_lut, refined_rows, write_lut
    from elastocell.inverse.rtdc import emodulus_of_events

    kept = {(r["radius_um"], r["emodulus_kpa"]): r for r in records if not r.get("outline_fallback", 0) > 0}
    moduli = sorted({e for _, e in kept})
    errors = []
    for radius in sorted({r for r, _ in kept}):
        for low, mid, high in zip(moduli, moduli[1:], moduli[2:], strict=False):
            if not all((radius, e) in kept for e in (low, mid, high)):
                continue
            d_low, d_mid, d_high = (kept[(radius, e)]["deform"] for e in (low, mid, high))
            slope = math.log(d_high / d_low) / math.log(high / low)  # d ln D / d ln E over the pair
            log_e = math.log(low) + math.log(d_mid / d_low) / slope  # the E whose interpolated D is the point's
            linear = low + (high - low) * (d_mid - d_low) / (d_high - d_low)
            errors.append({"R [um]": radius, "E [kPa]": mid, "deform": d_mid,
                           "E error, ln D linear in ln E": math.exp(log_e) / mid - 1,
                           "E error, dclab's linear reading": linear / mid - 1})
    page.table(errors, "Left-one-out: each interior point from its neighbours at twice the spacing",
               formats={"deform": ".5f", "E error, ln D linear in ln E": "+.4f",
                        "E error, dclab's linear reading": "+.4f"})
    for column in ("E error, ln D linear in ln E", "E error, dclab's linear reading"):
        values = np.abs([e[column] for e in errors])
        page.print(f"|{column}|: median {np.median(values):.4f}, largest {values.max():.4f} ({len(values)} points)")

    area, deform = (a.ravel() for a in np.meshgrid(np.linspace(30.0, 200.0, 35), np.geomspace(0.002, 0.06, 30)))
    reference, _ = emodulus_of_events(area, deform, conditions, COMPARED)
    shipped = DATA / f"{table_name(STANDARD)}.txt"
    if not shipped.is_file():
        return
    _, metadata, _ = read_lut(shipped)
    folder = Path(tempfile.mkdtemp(prefix="lut-subdivisions-"))
    tables = []
    for subdivisions in (1, 2, 4, REFINE_SUBDIVISIONS):  # the same computed points, written with each count
        path = folder / f"subdivisions-{subdivisions}.txt"
        planned = ([r["radius_um"] for r in records], [r["emodulus_kpa"] for r in records])
        write_lut(path, refined_rows(list(kept.values()), subdivisions, planned), metadata)
        tables.append((f"--subdivisions {subdivisions}", path))
    rows = []
    for label, path in [*tables, ("as shipped", shipped)]:
        values, _ = emodulus_of_events(area, deform, conditions, str(path))
        ratio = values / reference
        ratio = ratio[np.isfinite(ratio)]
        if not ratio.size:
            continue
        q = np.percentile(ratio, [0, 25, 50, 75, 100])
        rows.append({"table": label, "rows": len(read_lut(path)[0]), "samples in both": ratio.size,
                     "within 5 %": float(np.mean(np.abs(ratio - 1) <= 0.05)), "min": q[0], "q1": q[1],
                     "median": q[2], "q3": q[3], "max": q[4]})
    page.table(rows, f"The common region: E_table / E_{COMPARED} on a grid of (area, deform)",
               formats={"within 5 %": ".3f", "min": ".3f", "q1": ".3f", "median": ".3f", "q3": ".3f",
                        "max": ".3f"})
    page.print("grid: area 30-200 um^2 (35 values, linear) x deform 0.002-0.06 (30 values, logarithmic), the samples "
               "inside both tables; the same conditions as above. `--subdivisions N`: the kept points written as "
               "`elastocell lut --subdivisions N` writes them (1: the computed points alone); `as shipped`: the "
               f"shipped file (--subdivisions {REFINE_SUBDIVISIONS}, the default).")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("run", "status", "ship", "compare"))
    parser.add_argument("--tables", type=Path, default=TABLES, help="where the tables and their runs are")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--data", type=Path, default=DATA, help="ship: where the tables go (the package's data)")
    parser.add_argument("--page", action="store_true", help="compare: write its section of docs/validation/lut_square.md")
    arguments = parser.parse_args()
    if arguments.action == "run":
        run(arguments.tables, arguments.workers)
    elif arguments.action == "status":
        status(arguments.tables)
    elif arguments.action == "compare":
        compare(arguments.tables, arguments.page)
    else:
        ship(arguments.tables, arguments.data)


if __name__ == "__main__":
    main()
