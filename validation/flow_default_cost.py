"""The cost of the extrapolated default of ``elastocell shear``: wall time (and CPU time) of the default command,
which runs R/dx 8 and R/dx 6 and Richardson-extrapolates their stationary values, against the same command with
``--no-extrapolate`` (the single R/dx 8 run), each in a new process, in one script (target: at most 1.5x).

Usage::

    nice python validation/flow_default_cost.py --page                 # Ca 0.05, homogeneous cell, duration 6
    python validation/flow_default_cost.py --resolution 4 --coarse-resolution 3 --duration 0.3   # a quick check

The runs are made in the order single, extrapolated, single again, so that a change of the machine's load during
the script shows as a difference between the two single runs. Each run's CPU time (user + system of the child
process, ``resource.getrusage``) is printed beside its wall time: on a shared machine the CPU time is the steadier
measure of the work, the wall time is what a user waits. The cell is the homogeneous one (``--nucleus none``, the
default of ``--nucleus`` here; ``--nucleus sphere`` times the command's reference cell, whose lattice is the same):
its D/Ca has the small-deformation limit 5/4 (Taylor; docs/theory.md), given for the single run and the
extrapolation (Roscoe's finite-Ca value: docs/validation/shear_targets.md).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from page import Page  # noqa: E402

SMALL_CA_SLOPE = 1.25  # D -> (5/4) Ca, Taylor's small-deformation limit of an elastic sphere


def timed_command(arguments: list[str], threads: int | None) -> tuple[float, float]:
    """Run ``python -m elastocell <arguments>`` in a new process; (wall s, CPU s of the child)."""
    env = dict(os.environ)
    if threads is not None:
        env["NUMBA_NUM_THREADS"] = str(threads)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "elastocell", *arguments], check=True, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def timed_previous(out: Path, capillary_number: float, nucleus: str, resolution, duration,
                   threads: int | None) -> tuple[float, float]:
    """The single R/dx 8 run with the flow settings the default had before (tau 1, Re_p 0.1), in a new process
    through the Python API (the command line has no tau); (wall s, CPU s of the child)."""
    options = {"capillary_number": capillary_number, "nucleus": nucleus, "extrapolate": False, "progress": False,
               "flow_options": PREVIOUS_FLOW}  # VTK as the command writes it
    if resolution is not None:
        options["resolution"] = resolution
    if duration is not None:
        options["duration"] = duration
    code = f"import elastocell; elastocell.shear({str(out)!r}, **{options!r})"
    env = dict(os.environ)
    if threads is not None:
        env["NUMBA_NUM_THREADS"] = str(threads)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def print_if_shared(page: Page) -> None:
    """Say on the page when the machine was shared at the end of the timings (load above the core count)."""
    if os.getloadavg()[0] > (os.cpu_count() or 1):
        page.print(f"The machine was shared with other work (load average {os.getloadavg()[0]:.1f} on "
                   f"{os.cpu_count()} cores at the end): the wall times are indicative; the CPU times are steadier.")


PREVIOUS_FLOW = {"relaxation_time": 1.0, "reynolds_number": 0.1}
"""The shear defaults' flow settings before the matched tau (tau 1; the matched tau keeps its lattice shear rate):
the single run at these is the cost the issue's 1.5x is counted against."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--capillary-number", type=float, default=0.05)
    parser.add_argument("--resolution", type=float, default=None, help="R/dx (default: the command's, 8)")
    parser.add_argument("--coarse-resolution", type=float, default=None, help="default: the command's, 6")
    parser.add_argument("--duration", type=float, default=None, help="strain (default: the command's, 6)")
    parser.add_argument("--threads", type=int, default=1, help="Numba threads of each run (NUMBA_NUM_THREADS)")
    parser.add_argument("--nucleus", default="none", help="--nucleus of the runs: none (homogeneous) or sphere")
    parser.add_argument("--workdir", type=Path, default=None)
    parser.add_argument("--page", action="store_true", help="write docs/validation/flow_default.md")
    args = parser.parse_args()

    homogeneous = args.nucleus == "none"
    page = Page("flow_default", "flow_default_cost.py", intro=(
        f"Wall time of `elastocell shear --capillary-number {args.capillary_number:g} --nucleus {args.nucleus}` at "
        "its defaults (R/dx 8 and R/dx 6, stationary values Richardson-extrapolated with order 2) against the same "
        "command with `--no-extrapolate` (the single R/dx 8 run), each a new process (imports and compilation "
        "included), run in the order single, the single run with the flow settings the default had before (tau 1; through the "
        "Python API, the command line has no tau), extrapolated, single. CPU time: user + system time of the process."
        + (" D/Ca against Taylor's small-deformation limit 5/4 of the homogeneous cell; the finite-Ca values are "
           "on [shear_targets](shear_targets.md), the resolution series on [flow_accuracy](flow_accuracy.md)."
           if homogeneous else "")))
    common = ["--capillary-number", f"{args.capillary_number:g}", "--nucleus", args.nucleus, "--quiet"]
    if args.resolution is not None:
        common += ["--resolution", f"{args.resolution:g}"]
    if args.duration is not None:
        common += ["--duration", f"{args.duration:g}"]
    extrapolated = ([] if args.coarse_resolution is None else ["--coarse-resolution", f"{args.coarse_resolution:g}"])
    workdir = args.workdir or Path(tempfile.mkdtemp(prefix="flow-default-"))
    plan = [("single (--no-extrapolate)", "single-1", ["--no-extrapolate"]),
            ("single R/dx 8 at tau 1 (the previous default's flow)", "previous", None),
            ("extrapolated (default)", "extrapolated", extrapolated),
            ("single (--no-extrapolate), again", "single-2", ["--no-extrapolate"])]
    rows, walls = [], {}
    for label, name, options in plan:
        out = workdir / name
        if options is None:
            wall, cpu = timed_previous(out, args.capillary_number, args.nucleus, args.resolution, args.duration,
                                       args.threads)
        else:
            wall, cpu = timed_command(["shear", "--out", str(out), *common, *options], args.threads)
        summary = json.loads((out / "summary.json").read_text())
        walls[name] = (wall, cpu)
        ca = summary["capillary_number"]
        row = {"run": label, "R/dx": f"{summary['lattice']['radius']:g}", "D": summary["taylor_deformation_mean"],
               "D/Ca": summary["taylor_deformation_mean"] / ca, "stationary": summary["stationary"],
               "inclination (deg)": summary["inclination_deg_mean"],
               "tank treading": summary["tank_treading_frequency"], "wall (s)": wall, "CPU (s)": cpu}
        extrapolation = summary.get("extrapolation")
        if extrapolation:
            row["R/dx"] = f"{extrapolation['fine_resolution']:g} & {extrapolation['coarse_resolution']:g}"
            row["D correction"] = extrapolation["values"]["taylor_deformation_mean"]["correction"]
        if homogeneous:
            row["over 5/4 (%)"] = 100 * (summary["taylor_deformation_mean"] / ca / SMALL_CA_SLOPE - 1)
        rows.append(row)
        print(f"{label}: wall {wall:.1f} s, CPU {cpu:.1f} s, D = {row['D']:.5f}", flush=True)
    single_wall = 0.5 * (walls["single-1"][0] + walls["single-2"][0])
    single_cpu = 0.5 * (walls["single-1"][1] + walls["single-2"][1])
    for row in rows:
        row["wall / single"] = row["wall (s)"] / single_wall
        row["CPU / single"] = row["CPU (s)"] / single_cpu
        row["CPU / previous"] = row["CPU (s)"] / walls["previous"][1]
    formats = {"D": ".5f", "D/Ca": ".4f", "over 5/4 (%)": ".1f", "inclination (deg)": ".2f", "tank treading": ".4f",
               "wall (s)": ".1f", "CPU (s)": ".1f", "wall / single": ".2f", "CPU / single": ".2f",
               "D correction": ".5f", "CPU / previous": ".2f"}
    columns = ["run", "R/dx", "D", "D/Ca", *(["over 5/4 (%)"] if homogeneous else []), "D correction", "stationary",
               "inclination (deg)", "tank treading", "wall (s)", "CPU (s)", "wall / single", "CPU / single",
               "CPU / previous"]
    page.table(rows, f"elastocell shear --capillary-number {args.capillary_number:g} --nucleus {args.nucleus}"
                     + (f" --resolution {args.resolution:g}" if args.resolution is not None else "")
                     + (f" --duration {args.duration:g}" if args.duration is not None else "")
                     + f", NUMBA_NUM_THREADS={args.threads} (ratios against the mean of the two single runs)",
               columns=columns, formats=formats)
    ratio = walls["extrapolated"][1] / single_cpu
    page.print(f"extrapolated default / single run: CPU {ratio:.2f}x, wall "
               f"{walls['extrapolated'][0] / single_wall:.2f}x (target <= 1.5x: "
               f"{'met' if ratio <= 1.5 else 'not met'} in CPU time); the two single runs' walls differ by "
               f"{100 * abs(walls['single-1'][0] / walls['single-2'][0] - 1):.0f} %")
    previous_ratio = walls["extrapolated"][1] / walls["previous"][1]
    page.print(f"extrapolated default / the single run at the previous default's flow (tau 1): CPU "
               f"{previous_ratio:.2f}x, wall {walls['extrapolated'][0] / walls['previous'][0]:.2f}x (target <= 1.5x: "
               f"{'met' if previous_ratio <= 1.5 else 'not met'} in CPU time)")
    print_if_shared(page)
    if args.page:
        page.write()


if __name__ == "__main__":
    main()
