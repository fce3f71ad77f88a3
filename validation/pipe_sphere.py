"""A rigid sphere on the axis of the pipe scenario's staircase cylinder: its hydrodynamic radius in confinement,
with the markers at R and at R - c dx (``hydrodynamic_radius_correction`` c).

    nice python validation/pipe_sphere.py [--resolutions 4 6 8] [--confinements 0.55 0.7] [--corrections 0 0.3]
                                          [--problems held free] [--cache results/pipe_sphere.jsonl] [--page]

Problems (lattice units, tau = 1, TRT, float64): the cylinder of radius R_ch = R/lambda dx (the pipe scenario's
staircase, half-way bounce-back), periodic over 8 R along x (the pipe scenario's box; the disturbance of a sphere
in a tube decays like exp(-4.47 x/R_ch), below 1e-6 at the half-length), driven by a uniform body force G (the
pipe scenario's driving), the sphere of markers (the nodes of the flow cell's mesh, uniform p1 of edge 2 dx, as
the pipe runs) on the axis at radius R - c dx, Reynolds number u_max R/nu = 0.05.

* **held**: the markers held at rest (``elastocell.coupling.held.HeldMarkers``, integral feedback, as the
  held sphere of docs/validation/flow_accuracy.md): the drag F on the sphere against Haberman & Sayre (1958, David
  Taylor Model Basin report 1143; Happel & Brenner, Low Reynolds number hydrodynamics, 1965, sec. 7-4) for a
  sphere held on the axis of a tube in Poiseuille flow of centre-line speed V:
  F = 6 pi eta a V (1 - (2/3) lambda^2 - 0.20217 lambda^5) / (1 - 2.105 lambda + 2.0865 lambda^3
  - 1.7068 lambda^5 + 0.72603 lambda^6), lambda = a/R_ch. Its denominator is the wall factor of a sphere
  translating along the axis; Bohlin's (1960) longer series for it, 1 - 2.10443 lambda + 2.08877 lambda^3
  - 0.94813 lambda^5 - 1.372 lambda^6 + 3.87 lambda^8 - 4.19 lambda^10, differs by 2 % at lambda = 0.55 and
  by 50 % at 0.7: the held drag is used at lambda = 0.55 only, where 2 % in F is 0.003 in lambda (0.03 dx).
* **free**: a force-free rigid sphere moving with the flow (each step every marker moves by the mean of the
  fluid velocities interpolated at the markers, and the feedback integrates each marker's velocity relative to
  that mean, so that the net force on the fluid stays zero and at the steady state the sphere translates
  rigidly: a neutrally buoyant sphere at vanishing Reynolds number). Its speed U against Haberman & Sayre's free
  sphere, U/V = (1 - (2/3) lambda^2 - 0.20217 lambda^5)/(1 - 0.75857 lambda^5) (the same reflections; the
  wall factor cancels; Faxen's small-lambda law U/V = 1 - (2/3) lambda^2 is its first term).

V and R_ch are the lattice's own: the far field is the empty staircase channel's steady profile (same G, the
lattice's own relaxation of one cross-section, ``elastocell.scenarios.pipe.steady_profile``) scaled by the flow
rate ratio Q/Q_0 (the sphere adds resistance), V = u_c0 Q/Q_0, and the wall's effective radius R_eff is the
hydraulic one, Q_0 = pi G R_eff^4/(8 eta). Solving the closed form for a at lambda = a/R_eff gives the
hydrodynamic radius a_h; the tables give (a_h - R)/dx, the sphere's excess over its nominal radius R, and
(R_eff - R_ch)/dx, the wall's. Along LE-2D-FEM-19's isoelastics D ~ (R/R_ch)^4.4 near the pipe_dclab points, so a
cell whose sphere is seen as a_h in a channel seen as R_eff deforms as one at confinement (a_h/R_eff): the last
column, 4.4 ln((a_h/R_eff)/(R/R_ch)), is the deformation shift (%) these two effective radii predict.

Each case's row is cached (JSON lines); ``--page`` composes the section from the cache alone.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.optimize

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from flow_accuracy import make_cell, run_until_stationary
from page import Page

from elastocell.coupling import ibm
from elastocell.coupling.held import HeldMarkers
from elastocell.coupling.markers import marker_radius
from elastocell.scenarios import pipe

CACHE = Path(__file__).resolve().parents[1] / "results" / "pipe_sphere.jsonl"
REYNOLDS = 0.05  # u_max R / nu
BOX = 8.0  # periodic length, units of R (the pipe scenario's default)
DEFORMATION_EXPONENT = 4.4  # d ln D / d ln(R/R_ch) along LE-2D-FEM-19's isoelastics near the pipe_dclab points


def haberman_held(lam: float) -> float:
    """F/(6 pi eta a V) of a sphere held on the axis of a tube in Poiseuille flow (Haberman & Sayre)."""
    return (1 - 2 / 3 * lam**2 - 0.20217 * lam**5) / (1 - 2.105 * lam + 2.0865 * lam**3 - 1.7068 * lam**5
                                                       + 0.72603 * lam**6)


def haberman_free(lam: float) -> float:
    """U/V of a force-free sphere on the axis of a tube in Poiseuille flow (Haberman & Sayre)."""
    return (1 - 2 / 3 * lam**2 - 0.20217 * lam**5) / (1 - 0.75857 * lam**5)


class FreeSphere(HeldMarkers):
    """Markers of a force-free rigid sphere translating with the fluid (see the module's text): each step they
    move by the mean interpolated velocity U, and the feedback integrates each one's velocity relative to U."""

    def __init__(self, lattice, positions, kernel: str = "trilinear"):
        super().__init__(lattice, positions, kernel)
        self.speed = np.zeros(3)

    def advance(self, n_steps: int) -> None:
        field = self.lattice.force_density
        for _ in range(int(n_steps)):
            ibm.clear(field, self.positions, self.kernel, self.periodic_y)
            self.forces = -self.gain * self.integral
            ibm.spread(self.forces, self.positions, self.lattice.shape, self.kernel, self.periodic_y, out=field)
            velocity = ibm.interpolate_lattice_velocity(self.lattice, self.positions, self.kernel)
            self.speed = velocity.mean(axis=0)
            self.integral += velocity - self.speed
            self.lattice.step(1)
            self.positions[:, 0] += self.speed[0]  # along the axis only (the sphere stays on it by symmetry)
            self.time_step += 1


def solve_radius(function, target: float, r_eff: float) -> float:
    """The radius a (dx) at which function(a/R_eff) equals ``target`` (NaN if none in (0.05, 0.95) R_eff)."""
    lo, hi = 0.05 * r_eff, 0.95 * r_eff
    values = [function(lo / r_eff) - target, function(hi / r_eff) - target]
    if values[0] * values[1] > 0:
        return float("nan")
    return float(scipy.optimize.brentq(lambda a: function(a / r_eff) - target, lo, hi))


def sphere_case(problem: str, resolution: float, confinement: float, correction: float) -> dict:
    start = time.perf_counter()
    cell = make_cell(resolution)
    channel_radius = resolution / confinement
    length = int(round(BOX * resolution))
    eta = 1.0 / 6.0
    speed = REYNOLDS * eta / resolution  # u_max aimed at
    g = 4.0 * eta * speed / channel_radius**2
    lattice = pipe.empty_channel(channel_radius, length, 1.0, g, "float64")
    shape = lattice.shape
    ay, az = pipe.channel_axis(shape)
    profile = pipe.steady_profile(shape, pipe.channel_solid(shape, channel_radius), g, 1.0, None, "cylinder",
                                  channel_radius, channel_radius)
    q0, u0 = float(profile.sum()), float(profile.max())
    r_eff = (8.0 * eta * q0 / (math.pi * g)) ** 0.25
    centre = np.array([length / 2.0, ay, az])
    positions = centre + marker_radius(resolution, correction) * cell.mesh.nodes
    body = (HeldMarkers if problem == "held" else FreeSphere)(lattice, positions)
    chunk = max(50, int(0.25 * channel_radius**2 / eta))  # a quarter of the channel's viscous time
    if problem == "held":
        observe = lambda: float(-body.forces[:, 0].sum())  # noqa: E731  drag on the sphere
    else:
        observe = lambda: float(body.speed[0])  # noqa: E731
    value, steps, verdict = run_until_stationary(body, observe, chunk, 120 * chunk)
    q = pipe.flow_rate(lattice)
    v = u0 * q / q0  # centre-line speed of the far field
    row = {"problem": problem, "R/dx": resolution, "lambda": confinement, "c_dx": correction,
           "R_ch/dx": channel_radius, "(R_eff-R_ch)/dx": r_eff - channel_radius, "Q/Q_0": q / q0}
    if problem == "held":
        ratio = value / (6.0 * math.pi * eta * v)  # = a f(a/R_eff)
        row["F/F_HS(R)"] = value / (6.0 * math.pi * eta * resolution * v * haberman_held(resolution / r_eff))
        a_h = solve_radius(lambda lam: lam * r_eff * haberman_held(lam), ratio, r_eff)
    else:
        row["U/V"] = value / v
        row["U/V HS(R)"] = haberman_free(resolution / r_eff)
        a_h = solve_radius(lambda lam: -haberman_free(lam), -value / v, r_eff)
    row.update({"(a_h-R)/dx": a_h - resolution,
                "D shift % (pred.)": 100 * DEFORMATION_EXPONENT * math.log((a_h / r_eff) / confinement),
                "markers": cell.mesh.n_nodes, "steps": steps, "stationary": bool(verdict["stationary"]),
                "lattice": "x".join(map(str, shape)), "wall_s": time.perf_counter() - start})
    return row


KEYS = ("problem", "R/dx", "lambda", "c_dx")


def load_cache(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


FORMATS = {"R/dx": "g", "lambda": "g", "c_dx": "g", "R_ch/dx": ".2f", "(R_eff-R_ch)/dx": "+.3f", "Q/Q_0": ".4f",
           "F/F_HS(R)": ".4f", "U/V": ".4f", "U/V HS(R)": ".4f", "(a_h-R)/dx": "+.3f", "D shift % (pred.)": "+.1f",
           "wall_s": ".0f"}


def page_rows(rows: list[dict]) -> None:
    intro = __doc__.split("Problems (", 1)[1].split("Each case's row")[0]
    page = Page("pipe_dclab", "pipe_sphere.py", intro="Problems (" + intro.strip())
    latest = {tuple(r[k] for k in KEYS): r for r in rows}
    ordered = sorted(latest.values(), key=lambda r: (r["problem"], r["lambda"], r["c_dx"], r["R/dx"]))
    for problem, title in (("held", "Sphere held on the axis: drag against Haberman & Sayre"),
                           ("free", "Force-free sphere on the axis: speed against Haberman & Sayre")):
        page.table([{k: v for k, v in r.items() if k != "problem"} for r in ordered if r["problem"] == problem],
                   title, formats=FORMATS)
    page.table(split_excess(ordered), "The excess split into a part constant in dx and a part proportional to R: "
               "(a_h - R)/dx = b + k R/dx, least squares over the resolutions (b: the immersed boundary's, first order "
               "in dx/R; k: what refinement keeps, the closed form's own error at that lambda or a physical effect)",
               formats={"lambda": "g", "c_dx": "g", "b [dx]": "+.3f", "k [%]": "+.2f", "max residual [dx]": ".3f"})
    page.write()


def split_excess(rows: list[dict]) -> list[dict]:
    """Per (problem, lambda, c) with two resolutions or more: the least-squares (b, k) of (a_h - R)/dx = b + k R/dx."""
    out = []
    for key in sorted({(r["problem"], r["lambda"], r["c_dx"]) for r in rows}):
        group = [r for r in rows if (r["problem"], r["lambda"], r["c_dx"]) == key]
        if len(group) < 2:
            continue
        res = np.array([r["R/dx"] for r in group])
        excess = np.array([r["(a_h-R)/dx"] for r in group])
        k, b = np.polyfit(res, excess, 1)
        out.append({"problem": key[0], "lambda": key[1], "c_dx": key[2],
                    "resolutions": " ".join(f"{v:g}" for v in res), "b [dx]": b, "k [%]": 100 * k,
                    "max residual [dx]": float(np.abs(excess - (b + k * res)).max())})
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--resolutions", type=float, nargs="+", default=[4.0, 6.0])
    parser.add_argument("--confinements", type=float, nargs="+", default=[0.55, 0.7])
    parser.add_argument("--corrections", type=float, nargs="+", default=[0.0, 0.3])
    parser.add_argument("--problems", nargs="+", default=["held", "free"], choices=["held", "free"])
    parser.add_argument("--cache", type=Path, default=CACHE)
    parser.add_argument("--page", action="store_true", help="write the page section from the cache alone")
    args = parser.parse_args(argv)
    if args.page:
        page_rows(load_cache(args.cache))
        return
    args.cache.parent.mkdir(parents=True, exist_ok=True)
    done = {tuple(r[k] for k in KEYS) for r in load_cache(args.cache)}
    for problem in args.problems:
        for lam in args.confinements:
            for c in args.corrections:
                for r in args.resolutions:
                    if (problem, r, lam, c) in done:
                        continue
                    row = sphere_case(problem, r, lam, c)
                    print(json.dumps(row), flush=True)
                    with args.cache.open("a") as handle:
                        handle.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
