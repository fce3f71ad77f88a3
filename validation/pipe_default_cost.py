"""The cost and the answer of ``elastocell pipe`` at its default in a cylinder (R/dx 8 and 6, stationary values
Richardson-extrapolated, the RT-DC reading the mean of six side views; the markers at R - 0.3 dx, the wall
interpolated) against the single R/dx 8 run (``--no-extrapolate``, the default before) and against the default
issue 24 started from (``--extrapolate --hydrodynamic-radius-correction 0 --channel-wall staircase``: the pair with
the markers at R on the staircase wall), each in a new process, in one script (issue 24's target: the default at most
1.5x the wall time of the one it started from).

Usage::

    nice python validation/pipe_default_cost.py --page         # R 6 um, E 3 kPa in LE-2D-FEM-19's channel, t = 10

The cell is a centred homogeneous one (neo-Hookean, nu 0.48) in dclab's LE-2D-FEM-19 cylinder (R_ch = 1.094 x
10 um, Q = 0.04 uL/s, eta = 15 mPa s), as validation/pipe_dclab.py's points, at the command's default duration (10
units of 1/gdot_w, the flow rate held). The runs are made in the order default, single, issue-24 start, default
again, so that a change of the machine's load shows as a difference between the two default runs; CPU time is user
+ system of the child process. Each run is read twice: the view along z (``deformation_mean``) and the RT-DC reading
the command prints (``elastocell.api.pipe.rtdc_reading``: the side views' mean where the window has it), both
extrapolated for a pair, against the table as pipe_dclab.py reads them (D err at the run's area on the isoelastic of
the same shear modulus; E err the table's modulus at the run's (area, D) over the cell's E_t = 3 mu). t = 10 is the
command's default, not a stationary shape (docs/validation/pipe_dclab.md has the stationary runs).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from flow_default_cost import print_if_shared, timed_command  # noqa: E402
from page import Page  # noqa: E402
from pipe_dclab import FLOW_RATE_UL_S, VISCOSITY_MPA_S, percent, table_readings  # noqa: E402
from pipe_resolution import CHANNEL_RADIUS_UM, POISSON_RATIO, wall_capillary_number  # noqa: E402

from elastocell.api.pipe import rtdc_reading  # noqa: E402

PLAN = [("default (cylinder: R/dx 8 and 6, six views, c 0.3, interpolated wall)", "default-1", []),
        ("one resolution (--no-extrapolate, the default before)", "single", ["--no-extrapolate"]),
        ("issue 24's start (--extrapolate, c 0, staircase wall)", "earlier",
         ["--extrapolate", "--hydrodynamic-radius-correction", "0", "--channel-wall", "staircase"]),
        ("default, again", "default-2", [])]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--radius", type=float, default=6.0, help="cell radius, um")
    parser.add_argument("--modulus", type=float, default=3.0, help="Young's modulus, kPa")
    parser.add_argument("--duration", type=float, default=None, help="units of 1/gdot_w (default: the command's)")
    parser.add_argument("--resolution", type=float, default=None, help="R/dx (default: the command's, 8)")
    parser.add_argument("--threads", type=int, default=1, help="Numba threads of each run (NUMBA_NUM_THREADS)")
    parser.add_argument("--workdir", type=Path, default=None)
    parser.add_argument("--page", action="store_true", help="write the section of docs/validation/flow_default.md")
    args = parser.parse_args()

    ca_w = wall_capillary_number(args.modulus)
    common = ["--capillary-number-wall", f"{ca_w:.10g}", "--nucleus", "none", "--channel-radius-ratio",
              f"{CHANNEL_RADIUS_UM / args.radius:.10g}", "--poisson-ratio", f"{POISSON_RATIO:g}", "--quiet",
              "--vtk-interval", "1000"]
    if args.duration is not None:
        common += ["--duration", f"{args.duration:g}"]
    if args.resolution is not None:
        common += ["--resolution", f"{args.resolution:g}"]
    command = "elastocell pipe " + " ".join(common)
    e_t = 3 * args.modulus / (2 * (1 + POISSON_RATIO))
    page = Page("flow_default", "pipe_default_cost.py", intro=(
        f"Wall and CPU time of `{command}` (R = {args.radius:g} um, E = {args.modulus:g} kPa, nu {POISSON_RATIO:g}, "
        f"in LE-2D-FEM-19's cylinder R_ch = {CHANNEL_RADIUS_UM:.2f} um, Q = {FLOW_RATE_UL_S:g} uL/s, eta = "
        f"{VISCOSITY_MPA_S:g} mPa s; Ca_w = {ca_w:.4f}) at its default in a cylinder (R/dx 8 and 6, "
        "Richardson-extrapolated, the RT-DC reading the six side views' mean; the markers at R - 0.3 dx, the wall "
        "interpolated) against the single R/dx 8 run (`--no-extrapolate`, the default before) and against the default "
        "issue 24 started from (`--extrapolate --hydrodynamic-radius-correction 0 --channel-wall staircase`), each a "
        "new process (imports and compilation included), in the order default, single, issue-24 start, default. "
        "Each run read twice: `view z` (deformation_mean) and `RT-DC` (the reading the command prints: the side "
        "views' mean), extrapolated for a pair. D err, A err, E err: against LE-2D-FEM-19 as "
        "docs/validation/pipe_dclab.md reads it; the command's default duration is not a stationary shape (that page "
        "has them). `hull records`: records of the averaging window read through the nodes' hull, view z and the "
        "views (the finer run's for a pair; the default's guard keeps a pair's outline at R/dx 8 if either run has "
        "any)."))
    workdir = args.workdir or Path(tempfile.mkdtemp(prefix="pipe-default-"))
    rows, times = [], {}
    for label, name, options in PLAN:
        out = workdir / name
        wall, cpu = timed_command(["pipe", "--out", str(out), *common, *options], args.threads)
        summary = json.loads((out / "summary.json").read_text())
        extrapolation = summary.get("extrapolation")
        times[name] = (wall, cpu)
        for reading, (deform, area_r2) in (("view z", (summary["deformation_mean"], summary["projected_area_mean"])),
                                           ("RT-DC", rtdc_reading(summary)[:2])):
            area = area_r2 * args.radius**2
            (d_t, a_t, e_read), = table_readings([(area, deform, e_t)])
            rows.append({"run": label, "reading": reading,
                         "R/dx": (f"{extrapolation['fine_resolution']:g} & {extrapolation['coarse_resolution']:g}"
                                  if extrapolation else f"{summary['lattice']['radius']:g}"),
                         "c [dx]": summary["flow"].get("hydrodynamic_radius_correction", 0.0), "deform": deform,
                         "D err %": percent(deform, d_t), "A err %": percent(area, a_t),
                         "E err %": percent(e_read, e_t),
                         "hull records": f"{summary.get('outline_fallback_records')}, "
                                         f"{summary.get('outline_fallback_views_records')}",
                         "guard": "kept R/dx 8" if extrapolation and extrapolation.get("outline_guard") else "",
                         "stationary": summary["stationary"], "wall (s)": wall, "CPU (s)": cpu})
        print(f"{label}: wall {wall:.1f} s, CPU {cpu:.1f} s, D = {deform:.5f}", flush=True)
    default_wall = 0.5 * (times["default-1"][0] + times["default-2"][0])
    default_cpu = 0.5 * (times["default-1"][1] + times["default-2"][1])
    for row in rows:
        row["wall / single"] = row["wall (s)"] / times["single"][0]
        row["CPU / single"] = row["CPU (s)"] / times["single"][1]
        row["CPU / start"] = row["CPU (s)"] / times["earlier"][1]
    page.table(rows, f"{command}, NUMBA_NUM_THREADS={args.threads}", formats={
        "c [dx]": "g", "deform": ".5f", "D err %": "+.1f", "A err %": "+.1f", "E err %": "+.1f", "wall (s)": ".1f",
        "CPU (s)": ".1f", "wall / single": ".2f", "CPU / single": ".2f", "CPU / start": ".2f"})
    for name, reference in (("single", "the single R/dx 8 run"), ("earlier", "issue 24's starting default")):
        cpu_ratio, wall_ratio = default_cpu / times[name][1], default_wall / times[name][0]
        page.print(f"default / {reference}: CPU {cpu_ratio:.2f}x, wall {wall_ratio:.2f}x"
                   + (f" (issue 24's target <= 1.5x: {'met' if cpu_ratio <= 1.5 else 'not met'} in CPU time)"
                      if name == "earlier" else ""))
    page.print(f"the two default runs' walls differ by {100 * abs(times['default-1'][0] / times['default-2'][0] - 1):.0f} %")
    print_if_shared(page)
    if args.page:
        page.write()


if __name__ == "__main__":
    main()
