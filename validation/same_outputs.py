"""Same outputs: a fixed set of cheap runs whose numbers are recorded and compared, so that a change of the code
that should not change results (a restructuring, a refactoring) is seen to leave them equal to round-off.

The runs (each a few seconds on a 2-core machine; all of them about a minute, plus Numba's first compilation
of the flow kernels when the package was just installed or moved):

- ``compress_reference``: the reference cell (gamma 2, lambda 0.5) and its homogeneous equivalent
  (``elastocell.compress(compare=True)``), coarse p2 mesh (mesh_size 0.6), 8 load steps to delta 0.5;
- ``compress_stiff_nucleus``: gamma 10 on the same mesh (the automatic degree-5 quadrature rule), 6 steps to 0.4;
- ``compress_random``: the random cell (seed 3), linear tetrahedra (mesh_size 0.5), 6 steps to 0.4;
- ``equivalent``: ``elastocell.equivalent`` of two cells (gamma 10; an off-centre ellipsoid) and the
  ``elastocell equivalent --json`` command;
- ``shear``: the reference cell in shear flow, Ca 0.1, R/dx 4, strain 1 (Numba backend);
- ``pipe``: the reference cell in pipe flow, Ca_w 0.2, R/dx 4, started off-axis (r0 = 0.2 R_ch), 1/gdot_w
  (Numba backend), and ``pipe_jax``: the same for 0.3/gdot_w on the JAX backend (CPU);
- ``lut``: one look-up-table point (``elastocell lut --quick --radii 5 --moduli 1kPa --duration 0.5``, one worker);
- ``fit_afm``: ``elastocell fit afm`` of a synthetic curve that this script writes (deterministic: a fixed
  analytic force law plus noise from NumPy's frozen legacy ``RandomState(7)``), with a 20-replica bootstrap and
  the nucleus conversion;
- ``fit_shear``: ``elastocell fit shear`` of one deformation with a tank-treading frequency.

Only the stable public interface is used:
``elastocell.compress``, ``elastocell.equivalent``, ``elastocell.shear``, ``elastocell.pipe`` and the
``elastocell`` command line (``python -m elastocell ...``, run as a subprocess with this interpreter).

What is compared: every number of the CSV tables the runs write and of their JSON summaries/metadata (and the
LUT file's table and metadata), flattened to ``run/file:key`` quantities. Not compared: timings, rates derived
from timings, software versions, dates, paths, prose strings (descriptions longer than 60 characters) and the
metadata of the shipped master-curve files that the fits echo.

    python validation/same_outputs.py --record               # write tests/data/same_outputs/expected.json
    python validation/same_outputs.py --check                # rerun and compare; exit code 1 on a difference
    python validation/same_outputs.py --check --only shear pipe --workdir /tmp/so

``tests/data/same_outputs/expected.json`` names the commit its numbers were recorded at (``recorded_from``; a
run recorded again on its own, ``--record --only RUN``, carries its own ``recorded_from``). To rerun the script
on the code of such a commit: ``git worktree add /tmp/baseline COMMIT`` and
``PYTHONPATH=/tmp/baseline/src python validation/same_outputs.py --check``.

Meshes are rebuilt in a fresh cache (``ELASTOCELL_CACHE`` under the work directory, unless ``--cache``), so the
meshing code is compared too; VTK output is switched off (``ELASTOCELL_NO_VTK``).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
DEFAULT_EXPECTED = REPOSITORY / "tests" / "data" / "same_outputs" / "expected.json"

# ------------------------------------------------------------------------------------------------ tolerances
# A quantity passes when max |now - recorded| / scale <= tolerance, where scale is |recorded| for a single number
# and the largest |recorded| of the column for a table column (so that entries that are 0 by construction, e.g.
# the force at delta 0 or the volume change at t = 0, do not divide by zero). Integers, booleans and strings
# must be equal. A value read back from a text table cannot be compared more finely than the digits the table
# was written with (compression/flow CSV 10 significant digits, fits.csv 8, the LUT file 7): the tolerance of
# such a value is at least one unit of its last printed digit.
#
# Measured on this 2-core machine with the code of commit d968b99: one --record, then --check 8 times (two of
# them at once, each on a busy machine). Largest relative difference over the 8 checks:
# - compression: the CSV tables (10 digits) equal every time; in metadata.json max_pin_reaction_over_force
#   4.3e-12, min_nodal_jacobian and min_volume_ratio 1.3e-14, every other number and count equal, except the
#   two quantities in SPECIAL below (PARDISO's threaded mixed-precision factorisation is not bitwise
#   reproducible). Tolerance 1e-9, as asked: 230x the largest spread.
# - flows (shear and pipe on Numba's 2 threads, pipe on JAX/CPU, the LUT point): bitwise equal every time (the
#   float32 lattice kernels reduce in a fixed order for a fixed thread count). Tolerance 1e-6, 10x float32
#   round-off, should the order of a threaded float32 sum ever change (e.g. another thread count). A real change
#   is far above it: the TRT magic parameter changed by 1e-4 of itself moved these outputs by up to 7e-5.
# - fits (float64, fixed bootstrap seed): bitwise equal every time. Tolerance 1e-9; fits.csv holds 8 significant
#   digits, so its numbers are compared to one unit of the 8th digit (1e-7).
TOLERANCES = {"compression": 1e-9, "flow": 1e-6, "fit": 1e-9}

# Quantities that are round-off by nature, matched by the end of their key. Measured: they vary between two runs
# of the same code (PARDISO's threaded mixed-precision factorisation is not bitwise reproducible).
# - max_plate_force_imbalance, |F_upper - F_lower| = 1e-9..2e-8 E_c R^2, is the round-off of the plate forces
#   itself: compared on the scale of F (floor 1 E_c R^2; these runs are dimensionless), not relative to itself
#   (up to 2.4e-14 E_c R^2 apart over 8 checks, i.e. 6e-6 of the value).
# - refinement_steps of the single-precision factorisation: 83 or 84, 147 or 148 for the same curve; compared
#   within 5 %.
#
# Measured on a second 2-core machine (another CPU than the record's) with the code of 521fec0: compression and
# fits as above; the float32 flows (shear, and pipe on JAX/CPU) differ from the record by up to 7.3e-6 of the
# value, all of it in quantities that are near zero by symmetry or are the spread of a stationary window: the
# cell's and nucleus's centre off their start or the axis (about 1e-3 R), the radial position and the local
# capillary number of a cell on the axis (1e-6 R_ch), the volume change (1e-4 V0), and the standard deviations
# over the averaged window (every ``_std``: 1e-7 to 1e-4): 1e-12 to 7e-10 absolute, float32 round-off of
# another instruction set. These are compared on the scale of the quantity they belong to, 1 in the runs' own
# units (R, R_ch, V0, u_max, R^2 for an area of pi, Ca_w = 0.2), not relative to their own near-zero value; with
# that, every flow quantity on the second machine is within 6.8e-8 of the record (shear's max_speed), 15x below
# the tolerance.
CELL_SCALE = {"floor": 1.0, "kinds": ("flow",)}
SPECIAL = {
    "solver.max_plate_force_imbalance": {"floor": 1.0},
    "solver.refinement_steps": {"tolerance": 0.05},
    **{suffix: CELL_SCALE for suffix in (
        "centre_x", "centre_y", "centre_z", "radial_position", "radial_position_mean", "volume_change",
        "volume_change_mean", "volume_change_max_abs", "local_capillary_number", "local_capillary_number_mean",
        "_std")},
}


INTENDED_CHANGES = {
    "lut/point.json.key": "a LUT point's key is the hash of its resolved parameters (no history of defaults)",
    "lut/lut.txt:metadata.elastocell.not_stationary": "lists those keys",
    "lut/lut_isoelastics.txt:metadata.elastocell.not_stationary": "lists those keys",
}
"""Quantities whose change from the recorded value is intended, each named in full (``run/file:key``, without a
row index) with the reason; they are shown, not compared. A run whose outputs changed as a whole is recorded
again (``--record --only RUN``) instead of being listed here."""


def _intended(key: str) -> str | None:
    return INTENDED_CHANGES.get(key.split("[")[0])


def _special(key: str, kind: str) -> dict:
    """The rule of SPECIAL whose suffix ends ``key`` and that applies to runs of ``kind`` (a rule with ``kinds``
    only to those: the flows' near-zero quantities, not a fit's ``contact_point_std``)."""
    return next((rule for suffix, rule in SPECIAL.items()
                 if key.endswith(suffix) and kind in rule.get("kinds", (kind,))), {})


# Keys of JSON files (at any depth) and table columns that are not compared: timings, rates from timings,
# versions, dates, paths and the execution environment.
# "master_curve" in fit_settings.json is the metadata of the shipped master-curve file (how and when it was
# computed, with timings and prose); the fits themselves are compared. Strings longer than PROSE characters are
# descriptions (a method, a definition), not outputs, and may be reworded without changing any number.
SKIPPED_KEYS = {"software", "date", "files", "source", "device", "command", "wall_time_s",
                "wall_time_cumulative_s", "curve_time_s", "time_stepping_s", "time_stepping_session_s",
                "wall_time_per_strain_s", "lattice_updates_per_s", "fit_time_s", "this_call_s", "master_curve"}
SKIPPED_PATTERN = re.compile(r"(wall_time|time_s$|_per_s$|(^|_)version$)")
PROSE = 60


def _skipped(key: str) -> bool:
    return key in SKIPPED_KEYS or bool(SKIPPED_PATTERN.search(key))


# ------------------------------------------------------------------------------------------------ reading outputs
def _number(text: str) -> float | None:
    if text.strip() == "":
        return math.nan
    try:
        return float(text)
    except ValueError:
        return None


def read_csv(path: Path, digits: int, prefix: str, into: dict, resolution: dict) -> None:
    """Every column of a CSV table (header row first): numeric columns as lists of floats, others as strings."""
    with open(path, newline="") as handle:
        rows = [row for row in csv.reader(handle) if row and not row[0].startswith("#")]
    header, body = rows[0], rows[1:]
    for j, name in enumerate(header):
        if _skipped(name):
            continue
        cells = [row[j] if j < len(row) else "" for row in body]
        numbers = [_number(cell) for cell in cells]
        key = f"{prefix}:{name}"
        if all(value is not None for value in numbers):
            into[key] = numbers
            resolution[key] = 10.0 ** (1 - digits)
        else:
            into[key] = cells


def flatten(value, key: str, into: dict, workdir: str) -> None:
    """JSON leaves as ``key.sub.sub`` (lists of numbers stay lists); skipped keys and path-like strings dropped."""
    if isinstance(value, dict):
        for name, item in value.items():
            if not _skipped(str(name)):
                flatten(item, f"{key}.{name}", into, workdir)
    elif isinstance(value, list) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                   for v in value):
        into[key] = [float(v) for v in value]
    elif isinstance(value, list):
        for index, item in enumerate(value):
            flatten(item, f"{key}[{index}]", into, workdir)
    elif isinstance(value, str) and (workdir in value or value.startswith("/") or len(value) > PROSE):
        return  # a path or prose
    else:
        into[key] = value


def read_json(path: Path, prefix: str, into: dict, workdir: str) -> None:
    flatten(json.loads(Path(path).read_text()), prefix, into, workdir)


def read_lut(path: Path, prefix: str, into: dict, resolution: dict, workdir: str) -> None:
    """A dclab LUT/isoelastics text file: the JSON between BEGIN/END METADATA and the table (7 digits)."""
    lines = Path(path).read_text().splitlines()
    start = lines.index("# BEGIN METADATA")
    end = lines.index("# END METADATA")
    metadata = json.loads("\n".join(line[1:] for line in lines[start + 1:end]))
    flatten(metadata, f"{prefix}:metadata", into, workdir)
    header = None
    rows = []
    for line in lines[end + 1:]:
        if line.startswith("#") and "\t" in line:
            header = [name.strip() for name in line[1:].split("\t")]
        elif line.strip() and not line.startswith("#"):
            rows.append([float(v) for v in line.split()])
    for j, name in enumerate(header or []):
        key = f"{prefix}:{name}"
        into[key] = [row[j] for row in rows]
        resolution[key] = 1e-6  # %.6e: 7 significant digits


# ------------------------------------------------------------------------------------------------ the runs
def _cli(args: list[str], cwd: Path) -> str:
    """``python -m elastocell ARGS`` with this interpreter and this environment; raise on a non-zero exit."""
    done = subprocess.run([sys.executable, "-m", "elastocell", *args], cwd=cwd, env=os.environ.copy(),
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"elastocell {' '.join(args)} exited with {done.returncode}:\n{done.stdout}\n{done.stderr}")
    return done.stdout


def _compression_outputs(out: Path, prefix: str, into: dict, resolution: dict, workdir: str) -> None:
    read_csv(out / "compression.csv", 10, f"{prefix}/compression.csv", into, resolution)
    read_json(out / "metadata.json", f"{prefix}/metadata.json", into, workdir)


def run_compress_reference(work: Path, into: dict, resolution: dict) -> None:
    import elastocell

    out = work / "compress_reference"
    elastocell.compress(out, compare=True, mesh_size=0.6, steps=8, delta_max=0.5, vtk=False, progress=False)
    _compression_outputs(out, "compress_reference", into, resolution, str(work))
    _compression_outputs(out / "equivalent", "compress_reference/equivalent", into, resolution, str(work))
    read_csv(out / "comparison.csv", 10, "compress_reference/comparison.csv", into, resolution)


def run_compress_stiff_nucleus(work: Path, into: dict, resolution: dict) -> None:
    import elastocell

    out = work / "compress_stiff_nucleus"
    elastocell.compress(out, stiffness_ratio=10, mesh_size=0.6, steps=6, delta_max=0.4, vtk=False, progress=False)
    _compression_outputs(out, "compress_stiff_nucleus", into, resolution, str(work))


def run_compress_random(work: Path, into: dict, resolution: dict) -> None:
    import elastocell

    out = work / "compress_random"
    elastocell.compress(out, random=True, seed=3, element="p1", mesh_size=0.5, steps=6, delta_max=0.4, vtk=False,
                        progress=False)
    _compression_outputs(out, "compress_random", into, resolution, str(work))


def run_equivalent(work: Path, into: dict, resolution: dict) -> None:
    import elastocell

    flatten(elastocell.equivalent(stiffness_ratio=10, mesh_size=0.6), "equivalent/gamma10", into, str(work))
    flatten(elastocell.equivalent(nucleus="ellipsoid", semi_axes=(0.8, 0.4, 0.4), nucleus_axis="y", offset=0.1,
                                  offset_axis="z", mesh_size=0.6),
            "equivalent/ellipsoid", into, str(work))
    text = _cli(["equivalent", "--stiffness-ratio", "10", "--mesh-size", "0.6", "--json"], work)
    flatten(json.loads(text), "equivalent/cli", into, str(work))


def _flow_outputs(out: Path, prefix: str, into: dict, resolution: dict, workdir: str) -> None:
    read_csv(out / "timeseries.csv", 10, f"{prefix}/timeseries.csv", into, resolution)
    read_json(out / "summary.json", f"{prefix}/summary.json", into, workdir)


def run_shear(work: Path, into: dict, resolution: dict) -> None:
    import elastocell

    out = work / "shear"
    elastocell.shear(out, 0.1, resolution=4, duration=1.0, record_interval=0.1, vtk_interval=None, progress=False)
    _flow_outputs(out, "shear", into, resolution, str(work))


PIPE_FLOW = dict(channel_radius_ratio=2.5, box_length=6)  # as the tests' small channel


def run_pipe(work: Path, into: dict, resolution: dict) -> None:
    import elastocell

    out = work / "pipe"
    elastocell.pipe(out, 0.2, start_offset=0.2, resolution=4, duration=1.0, record_interval=0.1, vtk_interval=None,
                    progress=False, flow_options=dict(PIPE_FLOW))
    _flow_outputs(out, "pipe", into, resolution, str(work))


def run_pipe_jax(work: Path, into: dict, resolution: dict) -> None:
    import elastocell

    out = work / "pipe_jax"
    elastocell.pipe(out, 0.2, start_offset=0.2, resolution=4, duration=0.3, record_interval=0.1, vtk_interval=None,
                    progress=False, flow_options=dict(PIPE_FLOW, backend="jax"))
    _flow_outputs(out, "pipe_jax", into, resolution, str(work))


def run_lut(work: Path, into: dict, resolution: dict) -> None:
    out = work / "lut"
    _cli(["lut", "--channel-radius", "10um", "--flow-rate", "0.04uL/s", "--viscosity", "15mPa*s", "--quick",
          "--radii", "5", "--moduli", "1kPa", "--duration", "0.5", "--workers", "1", "--quiet",
          "--out", str(out / "lut.txt")], work)
    read_lut(out / "lut.txt", "lut/lut.txt", into, resolution, str(work))
    read_lut(out / "lut_isoelastics.txt", "lut/lut_isoelastics.txt", into, resolution, str(work))
    points = sorted((out / "lut_runs").glob("*/point.json"))
    if len(points) != 1:
        raise RuntimeError(f"expected one LUT point, found {len(points)}")
    read_json(points[0], "lut/point.json", into, str(work))  # its "key" names the run folder: kept (resume)
    _flow_outputs(points[0].parent, "lut/run", into, resolution, str(work))


def write_afm_curve(path: Path) -> None:
    """A synthetic plate-compression curve, the same on every machine and NumPy version: E = 1 kPa, R = 8 um,
    contact at 5 um, F = E R^2 (2 delta^1.5 + 15.7 delta^4) (close to the homogeneous master curve) up to
    delta 0.7, plus a force offset and Gaussian noise of 1 % of the largest force from the legacy
    ``RandomState`` (its stream is frozen by NumPy's compatibility policy), written at 17 digits."""
    import numpy as np

    youngs_modulus, radius, contact, n = 1000.0, 8e-6, 5e-6, 400
    displacement = np.linspace(0.0, contact + 2 * radius * 0.7, n)
    delta = np.maximum(displacement - contact, 0.0) / (2 * radius)
    force = youngs_modulus * radius**2 * (2.0 * delta**1.5 + 15.7 * delta**4)
    force = force + 2e-10 + np.random.RandomState(7).normal(0.0, 0.01 * force.max(), n)
    lines = ["displacement,force"] + [f"{float(d):.17g},{float(f):.17g}" for d, f in zip(displacement, force, strict=True)]
    path.write_text("\n".join(lines) + "\n")


def run_fit_afm(work: Path, into: dict, resolution: dict) -> None:
    out = work / "fit_afm"
    out.mkdir(parents=True, exist_ok=True)
    curve = out / "synthetic.csv"
    write_afm_curve(curve)
    _cli(["fit", "afm", str(curve), "--radius", "8um", "--model", "both", "--bootstrap", "20", "--seed", "1",
          "--nucleus-size-ratio", "0.5", "--stiffness-ratio", "2", "--no-plots", "--quiet",
          "--out", str(out / "fits")], work)
    read_csv(out / "fits" / "fits.csv", 8, "fit_afm/fits.csv", into, resolution)
    read_json(out / "fits" / "fit_settings.json", "fit_afm/fit_settings.json", into, str(work))


def run_fit_shear(work: Path, into: dict, resolution: dict) -> None:
    out = work / "fit_shear"
    _cli(["fit", "shear", "--deformation", "0.1", "--shear-stress", "12Pa", "--deformation-error", "0.005",
          "--tank-treading-frequency", "470rad/s", "--tank-treading-frequency-error", "10",
          "--shear-rate", "1000/s", "--quiet", "--out", str(out)], work)
    read_csv(out / "shear_fits.csv", 8, "fit_shear/shear_fits.csv", into, resolution)
    read_json(out / "fit_settings.json", "fit_shear/fit_settings.json", into, str(work))


RUNS = {  # name: (function, tolerance class)
    "compress_reference": (run_compress_reference, "compression"),
    "compress_stiff_nucleus": (run_compress_stiff_nucleus, "compression"),
    "compress_random": (run_compress_random, "compression"),
    "equivalent": (run_equivalent, "compression"),
    "shear": (run_shear, "flow"),
    "pipe": (run_pipe, "flow"),
    "pipe_jax": (run_pipe_jax, "flow"),
    "lut": (run_lut, "flow"),
    "fit_afm": (run_fit_afm, "fit"),
    "fit_shear": (run_fit_shear, "fit"),
}


def run_all(work: Path, names: list[str] | None = None, cache: Path | None = None, echo=print) -> dict:
    """Run the chosen runs in ``work``; return {run: {"kind", "seconds", "quantities", "resolution"}}."""
    work = Path(work).resolve()
    work.mkdir(parents=True, exist_ok=True)
    os.environ["ELASTOCELL_CACHE"] = str(Path(cache).resolve() if cache else work / "cache")
    os.environ["ELASTOCELL_NO_VTK"] = "1"
    results = {}
    for name in names or list(RUNS):
        function, kind = RUNS[name]
        quantities, resolution = {}, {}
        start = time.perf_counter()
        function(work, quantities, resolution)
        seconds = time.perf_counter() - start
        echo(f"  {name}: {len(quantities)} quantities, {seconds:.1f} s")
        results[name] = {"kind": kind, "seconds": round(seconds, 1), "quantities": quantities,
                         "resolution": resolution}
    return results


# ------------------------------------------------------------------------------------------------ comparison
def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _difference(recorded, now, floor: float = 0.0, counts: bool = False) -> tuple[float, str, str, str]:
    """(relative difference, recorded shown, now shown, where): inf for a type, length or exact-value mismatch.

    floor: the smallest scale a difference is divided by. counts: integers are compared relatively, not exactly."""
    if isinstance(recorded, list) and isinstance(now, list):
        if len(recorded) != len(now):
            return math.inf, f"{len(recorded)} rows", f"{len(now)} rows", ""
        if not all(_is_number(v) for v in recorded + now):
            bad = [i for i, (a, b) in enumerate(zip(recorded, now, strict=True)) if a != b]
            return (math.inf if bad else 0.0), str(recorded[bad[0]] if bad else ""), str(now[bad[0]] if bad else ""), \
                (f"[{bad[0]}]" if bad else "")
        finite = [abs(v) for v in recorded if math.isfinite(v)]
        scale = max(finite + [floor])
        worst, where = 0.0, 0
        for i, (a, b) in enumerate(zip(recorded, now, strict=True)):
            if math.isnan(a) and math.isnan(b) or a == b:
                continue
            d = abs(b - a) / scale if scale > 0 and math.isfinite(a) and math.isfinite(b) else math.inf
            if d > worst:
                worst, where = d, i
        return worst, f"{recorded[where]:.10g}", f"{now[where]:.10g}", f"[{where}]"
    if _is_number(recorded) and _is_number(now) and (counts or not (isinstance(recorded, int) and isinstance(now, int))):
        a, b = float(recorded), float(now)
        if a == b or math.isnan(a) and math.isnan(b):
            return 0.0, f"{a:.10g}", f"{b:.10g}", ""
        scale = max(abs(a), floor)
        d = abs(b - a) / scale if scale > 0 and math.isfinite(a) and math.isfinite(b) else math.inf
        return d, f"{a:.10g}", f"{b:.10g}", ""
    return (0.0 if recorded == now and type(recorded) is type(now) else math.inf), str(recorded), str(now), ""


def compare(expected: dict, results: dict, echo=print, failures_only: bool = False) -> bool:
    """Print the table quantity / recorded / now / relative difference; True when every recorded quantity is
    still written and within its tolerance (quantities added since the record are listed, not compared)."""
    tolerances = TOLERANCES  # this script's (the recorded copy in the JSON is for information)
    ok = True
    rows = []
    for name, now_run in results.items():
        recorded_run = expected["runs"].get(name)
        if recorded_run is None:
            rows.append((f"{name} (not recorded)", "-", "-", "inf", "FAIL"))
            ok = False
            continue
        tolerance = tolerances[recorded_run["kind"]]
        recorded_q, now_q = recorded_run["quantities"], now_run["quantities"]
        for key in list(recorded_q) + [k for k in now_q if k not in recorded_q]:
            if _intended(key):
                if not failures_only:
                    rows.append((key, "-", "-", "-", f"intended: {_intended(key)}"))
                continue
            if key not in recorded_q:  # an output added since the record (e.g. a verdict): an extension, not a change
                if not failures_only:
                    rows.append((key, "-", "new", "-", "added"))
                continue
            if key not in now_q:  # an output the record has and the code no longer writes: a broken contract
                rows.append((key, "recorded", "missing", "inf", "FAIL"))
                ok = False
                continue
            rule = _special(key, recorded_run["kind"])
            difference, shown_recorded, shown_now, where = _difference(
                recorded_q[key], now_q[key], rule.get("floor", 0.0), "tolerance" in rule)
            allowed = max(rule.get("tolerance", tolerance), now_run["resolution"].get(key, 0.0),
                          recorded_run["resolution"].get(key, 0.0))
            passed = difference <= allowed * (1 + 1e-9)
            ok &= passed
            if not passed or not failures_only:
                rows.append((key + where, shown_recorded, shown_now, f"{difference:.2e}",
                             "ok" if passed else f"FAIL (> {allowed:.0e})"))
    width = max([len(r[0]) for r in rows] + [8])
    echo(f"{'quantity':<{width}}  {'recorded':>18}  {'now':>18}  {'rel. diff':>9}")
    for key, a, b, d, verdict in rows:
        echo(f"{key:<{width}}  {a:>18}  {b:>18}  {d:>9}  {verdict}")
    return ok


def summary_of_differences(expected: dict, results: dict) -> dict:
    """Per run: (largest relative difference, its quantity) over the quantities held to the run's tolerance class
    (not those of SPECIAL with a tolerance of their own); the measure of run-to-run spread."""
    out = {}
    for name, now_run in results.items():
        recorded_q = expected["runs"].get(name, {}).get("quantities", {})
        kind = expected["runs"].get(name, {}).get("kind", "")
        worst, where = 0.0, ""
        for key, value in now_run["quantities"].items():
            rule = _special(key, kind)
            if key in recorded_q and "tolerance" not in rule and not _intended(key):
                difference, _, _, index = _difference(recorded_q[key], value, rule.get("floor", 0.0))
                if difference > worst:
                    worst, where = difference, key + index
        out[name] = (worst, where)
    return out


# ------------------------------------------------------------------------------------------------ modes
def _code_origin() -> dict:
    import elastocell

    origin = {"elastocell_version": getattr(elastocell, "__version__", None)}
    try:
        origin["commit"] = subprocess.run(["git", "rev-parse", "HEAD"], cwd=Path(elastocell.__file__).parent,
                                          capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        origin["commit"] = None
    return origin


def record(expected_path: Path, work: Path, names=None, cache=None, echo=print) -> dict:
    results = run_all(work, names, cache, echo)
    import numpy

    document = {
        "description": "Outputs of validation/same_outputs.py at the commit named in recorded_from (a run recorded "
                       "again on its own names its own); compare with `python validation/same_outputs.py "
                       "--check`.",
        "recorded_from": {**_code_origin(), "python": sys.version.split()[0], "numpy": numpy.__version__},
        "tolerances": TOLERANCES,
        "runs": results,
    }
    if names and expected_path.exists():  # a partial record updates only those runs, each naming its origin
        old = json.loads(expected_path.read_text())
        for result in results.values():
            result["recorded_from"] = document["recorded_from"]
        old["runs"].update(results)
        old["tolerances"] = TOLERANCES
        document = old
    expected_path.parent.mkdir(parents=True, exist_ok=True)
    expected_path.write_text(json.dumps(document, indent=1, sort_keys=False) + "\n")
    echo(f"recorded {sum(len(r['quantities']) for r in results.values())} quantities of {len(results)} runs "
         f"in {expected_path}")
    return document


def check(expected_path: Path, work: Path, names=None, cache=None, echo=print, failures_only=False) -> bool:
    """Rerun, print the comparison table and return True when everything agrees."""
    expected = json.loads(Path(expected_path).read_text())
    names = names or list(expected["runs"])
    results = run_all(work, names, cache, echo)
    ok = compare(expected, results, echo, failures_only)
    echo("largest relative difference per run (tolerance class):")
    for name, (value, where) in summary_of_differences(expected, results).items():
        echo(f"  {name:<24} {value:.2e} ({expected['runs'].get(name, {}).get('kind')})  {where}")
    echo("SAME OUTPUTS" if ok else "DIFFERENT OUTPUTS")
    return ok


def _expected_path(value: str | None) -> Path:
    path = Path(value) if value else DEFAULT_EXPECTED
    if path.is_dir() or path.suffix != ".json":
        path = path / "expected.json"
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--record", nargs="?", const="", metavar="PATH",
                      help=f"run and write the outputs (a .json file, or a folder for expected.json; default "
                           f"{DEFAULT_EXPECTED.relative_to(REPOSITORY)})")
    mode.add_argument("--check", nargs="?", const="", metavar="PATH",
                      help="run and compare with the recorded outputs (same default); exit 1 on a difference")
    mode.add_argument("--list", action="store_true", help="list the runs")
    parser.add_argument("--only", nargs="+", choices=list(RUNS), help="only these runs")
    parser.add_argument("--workdir", help="where the runs write (default: a temporary folder, removed after)")
    parser.add_argument("--keep", action="store_true", help="keep the temporary work folder")
    parser.add_argument("--cache", help="ELASTOCELL_CACHE for meshes (default: a fresh one in the work folder)")
    parser.add_argument("--failures-only", action="store_true", help="print only the quantities that differ")
    args = parser.parse_args(argv)
    if args.list:
        for name, (_, kind) in RUNS.items():
            print(f"{name} ({kind}, tolerance {TOLERANCES[kind]:g})")
        return 0
    import elastocell

    print(f"elastocell from {Path(elastocell.__file__).parent}")
    work = Path(args.workdir) if args.workdir else Path(tempfile.mkdtemp(prefix="same-outputs-"))
    try:
        if args.record is not None:
            record(_expected_path(args.record), work, args.only, args.cache)
            return 0
        return 0 if check(_expected_path(args.check), work, args.only, args.cache,
                          failures_only=args.failures_only) else 1
    finally:
        if not args.workdir and not args.keep:
            shutil.rmtree(work, ignore_errors=True)
        elif not args.workdir:
            print(f"outputs kept in {work}")


if __name__ == "__main__":
    sys.exit(main())
