"""Where the error of the lattice-Boltzmann + immersed-boundary flow comes from: cheap problems with known
answers against resolution R/dx, kernel, marker spacing and the marker placement.

Run::

    python validation/flow_accuracy.py --only torque --resolutions 4 6 8      # fixed sphere in shear
    python validation/flow_accuracy.py --only drag --resolutions 4 6 8        # fixed sphere, periodic array
    python validation/flow_accuracy.py --only deformation --resolutions 4 6   # the cell, D/Ca at Ca = 0.05
    python validation/flow_accuracy.py --page                                 # the page from the cached rows

Problems (lattice units, tau = 1, TRT, float64 storage for the fixed spheres):

* **torque**: a sphere of markers held fixed at the centre of the shear scenario's channel
  (``shear_setup``: confinement 2R/H = 0.2, box 8R, particle Reynolds number 0.1). A held sphere in simple
  shear u_x = gdot y feels the torque T_z = -4 pi eta R^3 gdot (8 pi eta R^3 times the fluid's rotation rate
  -gdot/2) and exerts the stresslet S_xy = (10/3) pi eta R^3 gdot ((20/3) pi eta R^3 E_xy, E_xy = gdot/2);
  both are Stokes' closed forms for an unbounded fluid (Kim & Karrila, Microhydrodynamics, 1991, ch. 2-3); the
  walls (2R/H = 0.2) and the periodic images (8R) change them by O((R/H)^3, (R/L)^3) ~ 1e-3. Each gives a
  hydrodynamic radius R_h = (T/(4 pi eta gdot))^(1/3), (S/((10/3) pi eta gdot))^(1/3).
* **drag**: the sphere held fixed in a periodic cube of side L = 6R, the fluid driven by a uniform body force
  g: the sphere holds F = g L^3. Hasimoto (J. Fluid Mech. 5, 317, 1959), with the higher terms of Sangani &
  Acrivos (Int. J. Multiphase Flow 8, 343, 1982) for a simple cubic array:
  F = 6 pi eta R U / (1 - 1.7601 phi^(1/3) + phi - 1.5593 phi^2 + 3.9799 phi^(8/3) - 3.0734 phi^(10/3)),
  phi = (4/3) pi R^3/L^3, U the mean fluid velocity over the periodic cell. Solving it for R gives R_h.
* **deformation**: the homogeneous p1 cell (nu = 0.48, neo-Hookean, viscosity ratio 1) of the shear
  scenario at Ca = 0.05, D/Ca against Taylor's small-deformation limit 5/4 (docs/theory.md), inclination and
  tank-treading frequency (the rotation rate: 1/2 of the shear rate as Ca -> 0).

Reading the tables: the held sphere's hydrodynamic radius exceeds its marker radius by a constant number of
lattice spacings for a kernel (the first rows of the error-source table): the rigid-body error is first order,
3 (R_h - R)/R in a torque or stresslet, and the wider peskin4 kernel doubles it. Placing the markers at R - c dx
(``hydrodynamic_radius_correction``) removes it for the held sphere. The cell's D/Ca excess grows with the
kernel width too, but placing its markers further in raises D/Ca: the deformation is scale-free and depends on
the ratio of the hydrodynamic to the elastic radius, not on where the markers lie; mesh spacing changes it by a
few per cent only. The last table extrapolates D/Ca from two resolutions with an error ~ (dx/R)^2, the order the
resolution study quoted with ``ShearFlowParameters.resolution`` shows ((D/Ca - 5/4) (R/dx)^2 about constant from
R/dx = 6 to 10).

The sphere's markers are the nodes of the cell's own mesh (surface and interior, uniform p1, edge ``edge`` dx)
at radius R - c dx (``hydrodynamic_radius_correction`` c). A marker is held by integral feedback: its force on
the fluid is -k times the time integral of the fluid velocity interpolated at it, so at the steady state the
interpolated velocity vanishes, the immersed boundary's no-slip condition, as for the cell's markers (which
move with that velocity); k = 0.5/lambda_max(W), W the kernel overlap matrix. A run stops when the torque (or
mean fluid velocity) over its last 10 records is stationary (``simulation.runner.stationarity``, drift < 2e-4
relative). The page's rows come from ``--only torque --resolutions 4 6 8`` (and ``--corrections 0.3 0.34``;
``--resolutions 4 6 --kernels peskin4``; ``--resolutions 4 6 --edges 1.33 3``), ``--only drag --resolutions 4 6 8``
(and ``--resolutions 4 6 --corrections 0.34``), ``--only deformation --resolutions 4 --kernels trilinear peskin4``
(and ``--corrections 0.3 0.36``; ``--edges 1.33 3``), ``--only deformation --resolutions 6 8 --capillary-numbers
0.05 0.1`` and ``--only deformation --resolutions 6 --corrections 0.34``, each with ``--threads 1``, run two or
three at a time on a shared 2-core machine. Every case's row is cached (``--cache``, JSON lines) so the parts can run as separate processes;
``--page`` writes docs/validation/flow_accuracy.md from the cache.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

try:
    import elastocell
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
    import elastocell

import numba
import scipy.optimize
from page import Page
from shear import run as shear_run

from elastocell.body.cell import Cell
from elastocell.coupling import ibm
from elastocell.coupling.held import HeldMarkers
from elastocell.coupling.markers import marker_radius
from elastocell.lattice import Lattice, LatticeParams
from elastocell.parameters.flow import shear_mesh_size
from elastocell.scenarios import shear as flow
from elastocell.simulation.runner import stationarity

CACHE = Path(__file__).resolve().parents[1] / "results" / "flow_accuracy.jsonl"
CAPILLARY_NUMBER = 0.05
STATIONARY_TOLERANCE = 2e-4
RECORDS_JUDGED = 10


def make_cell(resolution: float, edge: float = 2.0) -> Cell:
    size = shear_mesh_size(resolution, edge)
    return Cell.from_parameters(elastocell.cell_parameters(nucleus="none", element="p1", mesh_size=size,
                                                           pole_size=size, interface_size=size))


def hasimoto_factor(phi: float) -> float:
    """F / (6 pi eta R U) of a simple cubic array of spheres at volume fraction phi (Hasimoto; Sangani-Acrivos)."""
    c = phi ** (1.0 / 3.0)
    return 1.0 / (1.0 - 1.7601 * c + phi - 1.5593 * phi**2 + 3.9799 * c**8 - 3.0734 * c**10)


def run_until_stationary(body: HeldMarkers, observe, chunk: int, max_steps: int) -> tuple[float, int, dict]:
    """Advance in chunks until observe() over the last records is stationary; (value, steps, verdict)."""
    values, steps = [], 0
    verdict = {"stationary": False}
    while steps < max_steps:
        body.advance(chunk)
        steps += chunk
        values.append(observe())
        if len(values) >= RECORDS_JUDGED:
            verdict = stationarity(values[-RECORDS_JUDGED:], STATIONARY_TOLERANCE)
            if verdict["stationary"]:
                break
    return float(np.mean(values[-RECORDS_JUDGED // 2:])), steps, verdict


def _case_row(kind: str, resolution: float, kernel: str, edge: float, correction: float, cell: Cell) -> dict:
    return {"problem": kind, "R/dx": resolution, "kernel": kernel, "edge_dx": edge, "c_dx": correction,
            "Ca": None, "mesh_edge_dx": shear_mesh_size(resolution, edge) * resolution, "markers": cell.mesh.n_nodes}


def torque_case(resolution: float, kernel: str, edge: float, correction: float) -> dict:
    start = time.perf_counter()
    cell = make_cell(resolution, edge)
    params = flow.ShearFlowParameters(capillary_number=CAPILLARY_NUMBER, resolution=resolution, kernel=kernel,
                                      dtype="float64", relaxation_time=1.0)  # the page's "tau = 1"
    units = flow.shear_lattice_units(cell, params)
    lattice = flow.shear_setup(cell, params, units).lattice  # the channel with the Couette profile
    radius = marker_radius(resolution, correction)
    sphere = HeldMarkers(lattice, units.centre + radius * cell.mesh.nodes, kernel)
    eta, rate = units.viscosity, units.shear_rate
    chunk = max(50, int(resolution**2 / units.viscosity))  # the viscous time over R
    t, steps, verdict = run_until_stationary(sphere, lambda: float(sphere.torque(units.centre)[2]), chunk,
                                             400 * chunk)
    f = sphere.forces
    stresslet = float(sphere.stresslet(units.centre)[0, 1])
    row = _case_row("torque", resolution, kernel, edge, correction, cell)
    row.update({
        "T/T_Stokes": t / (-4.0 * math.pi * eta * rate * resolution**3),
        "S/S_Stokes": abs(stresslet) / (10.0 / 3.0 * math.pi * eta * rate * resolution**3),
        "(R_h-R)/dx torque": (abs(t) / (4.0 * math.pi * eta * rate)) ** (1 / 3) - resolution,
        "(R_h-R)/dx stresslet": (abs(stresslet) / (10.0 / 3.0 * math.pi * eta * rate)) ** (1 / 3) - resolution,
        "net_force": float(np.abs(f.sum(axis=0)).max() / max(abs(stresslet) / resolution, 1e-300)),
        "steps": steps, "stationary": verdict["stationary"], "lattice": "x".join(map(str, lattice.shape)),
        "wall_s": time.perf_counter() - start,
    })  # fmt: skip
    return row


def drag_case(resolution: float, kernel: str, edge: float, correction: float, box: float = 6.0) -> dict:
    start = time.perf_counter()
    cell = make_cell(resolution, edge)
    n = int(round(box * resolution))
    eta = 1.0 / 6.0  # tau = 1
    phi = 4.0 / 3.0 * math.pi * resolution**3 / n**3
    speed = 0.005  # mean fluid speed aimed at (dx/dt)
    g = 6.0 * math.pi * eta * resolution * hasimoto_factor(phi) * speed / n**3
    lattice = Lattice(LatticeParams((n, n, n), relaxation_time=1.0, dtype="float64", body_force=(g, 0.0, 0.0)))
    lattice.initialize()
    centre = np.array([n / 2.0 + 0.1, n / 2.0 + 0.2, n / 2.0 + 0.3])  # off the lattice's symmetry points
    sphere = HeldMarkers(lattice, centre + marker_radius(resolution, correction) * cell.mesh.nodes, kernel)

    def mean_speed():
        return float(lattice.velocity()[0].mean())

    chunk = max(50, int(n**2 / eta / (4 * math.pi**2)))  # the decay time of the box's slowest mode
    u, steps, verdict = run_until_stationary(sphere, mean_speed, chunk, 200 * chunk)
    force = g * n**3
    ratio = force / (6.0 * math.pi * eta * u)  # = R_h K(phi(R_h))

    def residual(radius):
        return radius * hasimoto_factor(4.0 / 3.0 * math.pi * radius**3 / n**3) - ratio

    r_h = float(scipy.optimize.brentq(residual, 0.5 * resolution, 2.0 * resolution))
    row = _case_row("drag", resolution, kernel, edge, correction, cell)
    row.update({
        "F/F_Hasimoto": force / (6.0 * math.pi * eta * resolution * hasimoto_factor(phi) * u),
        "(R_h-R)/dx drag": r_h - resolution, "markers_force/F": float(-sphere.forces[:, 0].sum() / force),
        "steps": steps, "stationary": verdict["stationary"], "lattice": f"{n}^3", "wall_s": time.perf_counter() - start,
    })  # fmt: skip
    return row


def deformation_case(resolution: float, kernel: str, edge: float, correction: float, ca: float,
                     duration: float) -> dict:
    cell = make_cell(resolution, edge)
    out = shear_run(cell, ca, resolution, duration, kernel=kernel, hydrodynamic_radius_correction=correction)
    row = _case_row("deformation", resolution, kernel, edge, correction, cell)
    row["Ca"] = ca
    row.update({k: out[k] for k in ("D/Ca", "incl_deg", "tt_freq", "max|dV/V|", "lattice", "steps", "limit", "wall_s")})
    row["duration"] = duration
    return row


KEYS = ("problem", "R/dx", "kernel", "edge_dx", "c_dx", "Ca")


def load_cache(path: Path) -> list[dict]:
    if not path.exists():
        return []
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    for row in rows:  # rows of the held-sphere problems carry no Ca
        row.setdefault("Ca", None)
        row.setdefault("mesh_edge_dx", shear_mesh_size(row["R/dx"], row["edge_dx"]) * row["R/dx"])
    return rows


def cached(rows: list[dict], case: dict) -> dict | None:
    for row in reversed(rows):
        if all(row.get(k) == case[k] for k in KEYS):
            return row
    return None


INTRO = __doc__.split("Problems (", 1)[1].split("``--page`` writes")[0] + "``--page`` composes this page from it."


def find(rows: list[dict], column: str, **match) -> float | None:
    """``column`` of the row with ``match`` (defaults: trilinear, edges 2 dx, no correction), None if not run."""
    keys = {"kernel": "trilinear", "edge_dx": 2.0, "c_dx": 0.0, **match}
    for row in rows:
        if all(row.get(key.replace("R", "R/dx") if key == "R" else key) == value for key, value in keys.items()):
            return row.get(column)
    return None


def _join(values, spec: str = ".3f") -> str:
    return " / ".join("-" if v is None else format(v, spec) for v in values)


def diagnosis(rows: list[dict], resolutions=(4.0, 6.0, 8.0)) -> list[dict]:
    """One row per error source: its measured size at each resolution (values joined by '/')."""
    def each(column, problem, spec=".3f", transform=lambda v: v, **match):
        values = [find(rows, column, problem=problem, R=r, **match) for r in resolutions]
        return _join([None if v is None else transform(v) for v in values], spec)

    excess = lambda v: 100.0 * (v / 1.25 - 1.0)  # noqa: E731  D/Ca over 5/4, %
    edges = sorted({r["edge_dx"] for r in rows if r["problem"] == "deformation" and r["R/dx"] == resolutions[0]})
    torque_edges = sorted({r["edge_dx"] for r in rows if r["problem"] == "torque"})
    mesh_edges = [find(rows, "mesh_edge_dx", problem="deformation", R=resolutions[0], Ca=0.05, edge_dx=e)
                  for e in edges]
    corrections = sorted({r["c_dx"] for r in rows if r["problem"] == "deformation"})
    first = resolutions[0]
    return [
        {"source": "hydrodynamic radius, trilinear: (R_h - R)/dx from torque", "measured": each("(R_h-R)/dx torque", "torque")},
        {"source": "  the same from the stresslet", "measured": each("(R_h-R)/dx stresslet", "torque")},
        {"source": "  the same from the drag (Hasimoto)", "measured": each("(R_h-R)/dx drag", "drag")},
        {"source": "hydrodynamic radius, peskin4: (R_h - R)/dx torque / stresslet",
         "measured": each("(R_h-R)/dx torque", "torque", kernel="peskin4") + "  |  "
         + each("(R_h-R)/dx stresslet", "torque", kernel="peskin4")},
        *({"source": f"(R_h - R)/dx from torque at R/dx = {r:g}, mesh edges "
                     f"{_join([find(rows, 'mesh_edge_dx', problem='torque', R=r, edge_dx=e) for e in torque_edges], '.3g')} dx",
           "measured": _join([find(rows, "(R_h-R)/dx torque", problem="torque", R=r, edge_dx=e) for e in torque_edges])}
          for r in resolutions[:2]),
        {"source": "stresslet excess S/S_Stokes - 1 (%), trilinear",
         "measured": each("S/S_Stokes", "torque", ".1f", lambda v: 100 * (v - 1))},
        {"source": "cell: D/Ca over 5/4 (%), Ca = 0.05, trilinear", "measured": each("D/Ca", "deformation", ".1f", excess, Ca=0.05)},
        {"source": "cell: D/Ca over 5/4 (%), Ca = 0.05, peskin4",
         "measured": each("D/Ca", "deformation", ".1f", excess, Ca=0.05, kernel="peskin4")},
        {"source": f"cell: D/Ca at R/dx = {first:g}, Ca = 0.05, mesh edges {_join(mesh_edges, '.3g')} dx",
         "measured": _join([find(rows, "D/Ca", problem="deformation", R=first, Ca=0.05, edge_dx=e) for e in edges], ".4g")},
        *({"source": f"cell: D/Ca at R/dx = {r:g}, Ca = 0.05, markers at R - c dx, c = {_join(corrections, '.3g')}",
           "measured": _join([find(rows, "D/Ca", problem="deformation", R=r, Ca=0.05, c_dx=c) for c in corrections],
                             ".4g")}
          for r in resolutions[:2]),
        {"source": "held sphere, markers at R - 0.3 dx: T/T_Stokes", "measured": each("T/T_Stokes", "torque", ".4f", c_dx=0.3)},
        {"source": "held sphere, markers at R - 0.34 dx: T/T_Stokes | S/S_Stokes",
         "measured": each("T/T_Stokes", "torque", ".4f", c_dx=0.34) + "  |  " + each("S/S_Stokes", "torque", ".4f", c_dx=0.34)},
        {"source": "held sphere, markers at R - 0.34 dx: F/F_Hasimoto", "measured": each("F/F_Hasimoto", "drag", ".4f", c_dx=0.34)},
    ]  # fmt: skip


def richardson(rows: list[dict], coarse: float = 6.0, fine: float = 8.0) -> list[dict]:
    """D/Ca extrapolated from two resolutions, error taken as (dx/R)^2 and as dx/R; cost of the pair over the fine run."""
    out = []
    for ca in sorted({r["Ca"] for r in rows if r["problem"] == "deformation" and r["Ca"] is not None}):
        d1, d2 = (find(rows, "D/Ca", problem="deformation", R=r, Ca=ca) for r in (coarse, fine))
        w1, w2 = (find(rows, "wall_s", problem="deformation", R=r, Ca=ca) for r in (coarse, fine))
        if d1 is None or d2 is None:
            continue
        second = (fine**2 * d2 - coarse**2 * d1) / (fine**2 - coarse**2)
        first_order = (fine * d2 - coarse * d1) / (fine - coarse)
        out.append({"Ca": ca, f"D/Ca R/dx={coarse:g}": d1, f"D/Ca R/dx={fine:g}": d2,
                    "Richardson (dx/R)^2": second, "over 5/4 (%)": 100 * (second / 1.25 - 1),
                    "Richardson dx/R": first_order, "cost (pair / fine run)": (w1 + w2) / w2})
    return out


def write_page(rows: list[dict]) -> None:
    page = Page("flow_accuracy", "flow_accuracy.py", intro="Problems (" + INTRO.strip(), versions=("numba",))
    page.table(diagnosis(rows), "Error sources (values at R/dx = 4 / 6 / 8; '-' not run)")
    page.table(richardson(rows), "The cell's D/Ca extrapolated from R/dx = 6 and 8 (small-Ca limit 1.25; the "
               "finite-Ca value is lower at Ca = 0.1, see docs/validation/shear.md)",
               formats={"Richardson (dx/R)^2": ".4f", "over 5/4 (%)": ".1f", "Richardson dx/R": ".4f",
                        "cost (pair / fine run)": ".2f", "D/Ca R/dx=6": ".4f", "D/Ca R/dx=8": ".4f"})
    page.print("Wall times are of runs sharing 2 cores with other work (load average 10-18), one Numba thread "
               "each: the cost ratio is indicative only.")
    formats = {"wall_s": ".0f", "T/T_Stokes": ".4f", "S/S_Stokes": ".4f", "F/F_Hasimoto": ".4f", "D/Ca": ".4g",
               "(R_h-R)/dx torque": ".3f", "(R_h-R)/dx stresslet": ".3f", "(R_h-R)/dx drag": ".3f",
               "net_force": ".1e", "markers_force/F": ".5f", "incl_deg": ".2f", "tt_freq": ".4f",
               "max|dV/V|": ".1e"}
    order = lambda r: (r["Ca"] or 0.0, r["R/dx"], r["kernel"], r["edge_dx"], r["c_dx"])  # noqa: E731
    for problem, heading in (("torque", "Sphere held in shear: torque and stresslet against Stokes"),
                             ("drag", "Sphere held in a periodic array (L = 6R): drag against Hasimoto"),
                             ("deformation", "Homogeneous cell: D/Ca against 5/4 (small-Ca limit)")):
        chosen = sorted((r for r in rows if r["problem"] == problem), key=order)
        if chosen:
            drop = {"problem"} if problem == "deformation" else {"problem", "Ca"}
            page.table(chosen, heading, columns=[c for c in chosen[0] if c not in drop], formats=formats)
    page.write()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", choices=["torque", "drag", "deformation"], nargs="*", default=[])
    parser.add_argument("--resolutions", type=float, nargs="*", default=[4.0, 6.0, 8.0])
    parser.add_argument("--kernels", nargs="*", default=["trilinear"], choices=list(ibm.KERNELS))
    parser.add_argument("--edges", type=float, nargs="*", default=[2.0], help="mesh edge (dx)")
    parser.add_argument("--corrections", type=float, nargs="*", default=[0.0], help="c (dx): markers at R - c dx")
    parser.add_argument("--duration", type=float, default=4.0, help="strain of a deformation run")
    parser.add_argument("--capillary-numbers", type=float, nargs="*", default=[CAPILLARY_NUMBER],
                        help="Ca of the deformation runs")
    parser.add_argument("--cache", type=Path, default=CACHE)
    parser.add_argument("--rerun", action="store_true", help="recompute cached cases")
    parser.add_argument("--page", action="store_true", help="write the page from the cache")
    parser.add_argument("--threads", type=int, default=None)
    args = parser.parse_args(argv)
    if args.threads:
        numba.set_num_threads(max(1, min(args.threads, numba.config.NUMBA_NUM_THREADS)))
    args.cache.parent.mkdir(parents=True, exist_ok=True)
    functions = {"torque": torque_case, "drag": drag_case, "deformation": deformation_case}
    for problem in args.only:
        for resolution in args.resolutions:
            for kernel in args.kernels:
                for edge in args.edges:
                    for correction in args.corrections:
                        for ca in args.capillary_numbers if problem == "deformation" else [None]:
                            case = {"problem": problem, "R/dx": resolution, "kernel": kernel, "edge_dx": edge,
                                    "c_dx": correction, "Ca": ca}
                            if not args.rerun and cached(load_cache(args.cache), case):
                                continue
                            extra = (ca, args.duration) if problem == "deformation" else ()
                            row = functions[problem](resolution, kernel, edge, correction, *extra)
                            print(json.dumps(row), flush=True)
                            with args.cache.open("a") as handle:
                                handle.write(json.dumps(row) + "\n")
    if args.page:
        rows = load_cache(args.cache)
        latest = {tuple(r[k] for k in KEYS): r for r in rows}
        write_page(list(latest.values()))


if __name__ == "__main__":
    main()
