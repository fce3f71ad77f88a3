"""Shear-thinning medium and rectangular channels on the lattice: errors against closed forms vs resolution, and
the cost of the power-law collision.

Run::

    python validation/medium.py                                   # everything below (a few minutes)
    python validation/medium.py --only slab duct                  # closed forms only
    python validation/medium.py --only mlups --baseline-kernels /tmp/kernels_before.py

References:

* slab: a power-law liquid (nu = K gdot^(n-1)) between plates driven by G, half-way walls at rest; closed form
  u(y) = n/(n+1) (G/K)^(1/n) (h^(1+1/n) - |y|^(1+1/n)) and its flow rate (``lattice.rheology``); K is set so that
  tau = 1 at the wall, the local tau is clamped to [0.52, 10];
* duct: Newtonian flow through a rectangular duct, the series of White (Viscous Fluid Flow, eqs. 3-48/3-49),
  half-way walls at +-a, +-b (a, b whole half-node counts), tau = 1;
* tube: a power-law liquid through the staircase cylinder, Q = pi n/(3n+1) (G/2K)^(1/n) R^(3+1/n);
* power-law square duct: no closed form; an independent finite-volume solution of the same clamped law
  (``pipe.finite_difference_duct_flow_rate``: Picard iteration on div(nu grad u) = -G), Kozicki et al.'s (1966)
  relation Q = a^3 (G a/(2K))^(1/n)/(b_k + a_k/n) (a_k = 0.2121, b_k = 0.6771; exact at n = 1, an approximation
  otherwise) and the lattice's own refinement;
* mlups: the fused step (Numba, float32, periodic cube, body force) with a Newtonian and a power-law medium in
  the same run; with ``--baseline-kernels`` also another kernels.py (e.g. ``git show REV:src/elastocell/lattice/
  kernels.py``) on the Newtonian lattice, timed interleaved with the current one.

Errors: flow rate Q_lattice/Q - 1 (Q_lattice the node sum of u_x); profile L2 over fluid nodes relative to the
closed form's L2 norm; order = log2 of the error ratio between successive doublings.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page

from elastocell.lattice import Lattice, LatticeParams, kernels
from elastocell.lattice.rheology import PowerLaw, tube_flow_rate
from elastocell.parameters.medium import KOZICKI_SQUARE, mc_pbs
from elastocell.scenarios import pipe

PAGE: list[Page] = []


def with_order(rows: list[dict], key: str, column: str) -> None:
    """Add the observed order of ``column`` between successive rows of the same ``key``."""
    previous: dict = {}
    for row in rows:
        old = previous.get(row[key])
        value = abs(row[column])
        row[f"order_{column}"] = math.log2(old / value) if old and value > 0 else float("nan")
        previous[row[key]] = value


def slab(nodes, indices) -> None:
    rows = []
    for n in indices:
        for size in nodes:
            start = time.perf_counter()
            err = pipe.power_law_slab_error(size, n)
            rows.append({"n": n, "nodes": size, "flow_rate_error": err["flow_rate_error"],
                         "profile_l2_error": err["profile_l2_error"], "profile_max_error": err["profile_max_error"],
                         "steps": err["steps"], "wall_s": time.perf_counter() - start})
    with_order(rows, "n", "profile_l2_error")
    PAGE[0].print("n = 1: TRT with magic 3/16 puts half-way walls exactly where a parabola needs them, so the "
                  "Newtonian profile is exact to round-off (its order column is noise) and the flow-rate error is "
                  "the node sum's against the integral.")
    PAGE[0].table(rows, "Power-law slab against the closed form (half-way walls, tau = 1 at the wall)",
                  formats={"flow_rate_error": ".2e", "profile_l2_error": ".2e", "profile_max_error": ".2e",
                           "order_profile_l2_error": ".2f", "wall_s": ".1f"})


def duct(half_widths, aspects) -> None:
    rows = []
    for aspect in aspects:
        for a in half_widths:
            start = time.perf_counter()
            err = pipe.duct_error(a, aspect)
            rows.append({"H/W": aspect, "a_dx": err["half_width"], "b_dx": err["half_height"],
                         "flow_rate_error": err["flow_rate_error"], "profile_l2_error": err["profile_l2_error"],
                         "profile_max_error": err["profile_max_error"], "wall_s": time.perf_counter() - start})
    with_order(rows, "H/W", "flow_rate_error")
    PAGE[0].table(rows, "Newtonian rectangular duct against the series (White 3-48/3-49)",
                  formats={"flow_rate_error": ".2e", "profile_l2_error": ".2e", "profile_max_error": ".2e",
                           "order_flow_rate_error": ".2f", "wall_s": ".1f"})


def power_law_duct(half_widths, indices, tau_max_values, reference_cells: int) -> None:
    rows = []
    ak, bk = KOZICKI_SQUARE
    nu, rate = 1.0 / 6.0, 1e-3
    for n in indices:
        for tau_max in tau_max_values:
            # finite volumes on the same clamped law at a = 1: with G a fixed the rate field is scale-free, Q ~ a^3
            law = PowerLaw.matching(n, nu, rate, relaxation_time_max=tau_max)
            start = time.perf_counter()
            q_fd_unit = pipe.finite_difference_duct_flow_rate(law, 2 * nu * rate, 1.0, 1.0, reference_cells)
            PAGE[0].print(f"n = {n:.4g}, tau_max = {tau_max:g}: finite-volume reference on {reference_cells}^2 cells "
                          f"in {time.perf_counter() - start:.1f} s")
            for a in half_widths:
                start = time.perf_counter()
                shape, _, a_lat, b_lat = pipe.channel_geometry("square", a, 1.0, 1)
                law = PowerLaw.matching(n, nu, rate, relaxation_time_max=tau_max)
                g = 2 * nu * rate / a_lat
                profile = pipe.channel_profile(shape, "square", a_lat, b_lat, g, 1.0, law)
                q = float(profile.sum())
                q_kozicki = a_lat**3 * (g * a_lat / (2 * law.consistency)) ** (1 / n) / (bk + ak / n)
                q_newtonian = pipe.duct_flow_rate(g, nu, a_lat, b_lat)
                q_fd = q_fd_unit * a_lat**3
                rows.append({"n": round(n, 4), "tau_max": tau_max, "a_dx": a_lat, "Q/Q_fv-1": q / q_fd - 1,
                             "Q/Q_kozicki-1": q / q_kozicki - 1, "Q_fv/Q_kozicki-1": q_fd / q_kozicki - 1,
                             "Q/Q_newtonian": q / q_newtonian, "wall_s": time.perf_counter() - start})
    PAGE[0].table(rows, "Power-law square duct: lattice flow rate against the finite-volume reference (fv), Kozicki's "
                  "relation and the Newtonian duct (same G, viscosity at the nominal wall shear rate)",
                  formats={"Q/Q_fv-1": ".2e", "Q/Q_kozicki-1": ".4f", "Q_fv/Q_kozicki-1": ".4f",
                           "Q/Q_newtonian": ".4f", "wall_s": ".1f"})


def tube(radii, indices) -> None:
    rows = []
    nu, rate = 1.0 / 6.0, 1e-3
    for n in indices:
        for radius in radii:
            start = time.perf_counter()
            shape, _, a, b = pipe.channel_geometry("cylinder", radius, 1.0, 1)
            law = PowerLaw.matching(n, nu, rate)
            g = 2 * nu * rate / radius
            q = float(pipe.channel_profile(shape, "cylinder", a, b, g, 1.0, law).sum())
            rows.append({"n": round(n, 4), "R_dx": radius,
                         "flow_rate_error": q / tube_flow_rate(g, law.consistency, n, radius) - 1,
                         "wall_s": time.perf_counter() - start})
    with_order(rows, "n", "flow_rate_error")
    PAGE[0].table(rows, "Power-law flow through the staircase cylinder against Q = pi n/(3n+1) (G/2K)^(1/n) "
                  "R^(3+1/n) (first order: the staircase wall)",
                  formats={"flow_rate_error": ".2e", "order_flow_rate_error": ".2f", "wall_s": ".1f"})


def load_kernels(path: str):
    """Import another kernels.py from a fresh copy (its Numba cache then cannot be a stale one of an earlier run:
    a cached function of a module loaded from a path does not load back)."""
    copy = Path(tempfile.mkdtemp(prefix="baseline-kernels-")) / "baseline_kernels.py"
    shutil.copyfile(path, copy)
    spec = importlib.util.spec_from_file_location("baseline_kernels", copy)
    module = importlib.util.module_from_spec(spec)
    sys.modules["baseline_kernels"] = module
    spec.loader.exec_module(module)
    return module


def mlups(size: int, repeats: int, steps: int, baseline: str | None) -> None:
    """Million node updates per second of the fused step, Newtonian and power law (and an older kernels.py's),
    interleaved in one run, on a decaying shear wave (so the power law's strain rates span their range)."""
    shape = (size, size, size)

    def lattice(rheology=None):  # a shear wave u_x = 0.01 sin(2 pi y/L): every strain rate from 0 to its largest
        out = Lattice(LatticeParams(shape, relaxation_time=0.8, body_force=(1e-6, 0.0, 0.0), rheology=rheology))
        velocity = np.zeros((3,) + shape)
        velocity[0] = 0.01 * np.sin(2 * np.pi * np.arange(size) / size)[None, :, None]
        out.initialize(velocity=velocity)
        return out

    def timed(module, lat, n):
        tables = lat._tables()
        if module is not kernels:  # an older kernels.py reads only the constants it knows
            tables = tables[:8] + (tables[8][: module.N_CONSTS],) + tables[9:]
        force, has_field = lat._force_arguments()
        start = time.perf_counter()
        lat._parity = module.run_steps(lat._storage, n, lat._parity, shape[2], force, has_field, *tables,
                                       lat._no_output)
        return n * size**3 / (time.perf_counter() - start) / 1e6

    cases = {"newtonian": (kernels, lattice()),
             "power law (0.59%MC-PBS, 23 C)": (kernels, lattice(PowerLaw.matching(mc_pbs("0.59%MC-PBS").flow_index,
                                                                                  0.1, 1e-3)))}
    if baseline:
        old = load_kernels(baseline)
        cases["newtonian, baseline kernels"] = (old, lattice())
        cases["power law, baseline kernels"] = (old, lattice(PowerLaw.matching(mc_pbs("0.59%MC-PBS").flow_index,
                                                                               0.1, 1e-3)))
    for module, lat in cases.values():
        timed(module, lat, 2)  # compile
    samples: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(repeats):  # interleaved: the machine's load hits every case alike
        for name, (module, lat) in cases.items():
            samples[name].append(timed(module, lat, steps))
    reference = float(np.median(samples["newtonian"]))
    rows = [{"case": name, "median_mlups": float(np.median(v)), "min_mlups": float(np.min(v)),
             "max_mlups": float(np.max(v)), "ratio_to_newtonian": float(np.median(v)) / reference}
            for name, v in samples.items()]
    if baseline:
        same = np.array_equal(cases["newtonian"][1]._storage, cases["newtonian, baseline kernels"][1]._storage)
        PAGE[0].print(f"newtonian state after {2 + repeats * steps} steps identical with the baseline kernels: {same}")
        power, power_baseline = (cases[name][1] for name in ("power law (0.59%MC-PBS, 23 C)",
                                                             "power law, baseline kernels"))
        difference = np.abs(power.velocity() - power_baseline.velocity()).max() / np.abs(power.velocity()).max()
        PAGE[0].print(f"power-law velocity after {2 + repeats * steps} steps, largest difference from the baseline "
                      f"kernels' over the largest speed: {difference:.2e}")
    PAGE[0].table(rows, f"Fused step, {size}^3 float32, {repeats} x {steps} steps interleaved",
                  formats={"median_mlups": ".1f", "min_mlups": ".1f", "max_mlups": ".1f", "ratio_to_newtonian": ".3f"})


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", nargs="+", default=["slab", "duct", "power-duct", "tube", "mlups"],
                        choices=["slab", "duct", "power-duct", "tube", "mlups"])
    parser.add_argument("--nodes", nargs="+", type=int, default=[8, 16, 32, 64])
    parser.add_argument("--indices", nargs="+", type=float, default=[1.0, 0.6, 0.4])
    parser.add_argument("--half-widths", nargs="+", type=float, default=[4, 8, 16])
    parser.add_argument("--reference-cells", type=int, default=96, help="cells across the finite-volume duct")
    parser.add_argument("--size", type=int, default=96)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--baseline-kernels", default=None, help="an older kernels.py to time beside the current")
    args = parser.parse_args(argv)
    PAGE.append(Page("medium", "medium.py", intro=(
        "The power-law (shear-thinning) medium and the rectangular channel of the lattice against closed forms, "
        "by resolution, and the cost of the power-law collision (per-node tau from Pi_neq) against the Newtonian "
        "one. The machine is shared with other jobs: speeds are compared inside one run only.")))
    if "slab" in args.only:
        slab(args.nodes, args.indices)
    if "duct" in args.only:
        duct(args.half_widths, [1.0, 2.0])
    if "power-duct" in args.only:
        power_law_duct(args.half_widths, [mc_pbs("0.59%MC-PBS").flow_index, 0.4], [10.0], args.reference_cells)
        power_law_duct([8.0], [mc_pbs("0.59%MC-PBS").flow_index], [100.0], args.reference_cells)
    if "tube" in args.only:
        tube([4.0, 8.0, 16.0], [1.0, mc_pbs("0.59%MC-PBS").flow_index])
    if "mlups" in args.only:
        mlups(args.size, args.repeats, args.steps, args.baseline_kernels)
    PAGE[0].write()


if __name__ == "__main__":
    main()
