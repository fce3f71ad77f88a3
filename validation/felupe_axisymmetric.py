"""FElupe's axisymmetric mode beside elastocell's axisymmetric solver on the homogeneous cell between rigid
frictionless plates, in the same run: F/(E R^2) against the converged truth, and the wall time of each curve, so
that the time at equal accuracy can be read off.

    nice python validation/felupe_axisymmetric.py [--felupe-scales 2 1.4 1] [--elastocell-scales 2 1 0.7]
        [--penalties 1e3 1e4 1e5] [--delta-max 0.50625] [--steps 27] [--reach 0.75] [--contact multipoint]

The cell: R = 1, E = 1, nu = 0.48, W = mu/2 (J^(-2/3) I1 - 3) + kappa/2 (J - 1)^2 (``felupe.NeoHooke(mu, bulk)``,
checked against W by ``felupe_peer.check_material``), plates at z = +-(1 - delta), delta = 1 - h/(2R).

FElupe: the meridian half-disc (r >= 0) meshed by gmsh with 6-node triangles on the curved boundary
(``RegionQuadraticTriangle``, FElupe's default 3-point rule) with the sizes of elastocell's
``MeridianMeshParameters().scaled(s)`` (interior, surface and pole size, the same gradings); the quarter
z >= 0 is meshed and mirrored, so that the mesh is symmetric about z = 0. ``FieldAxisymmetric`` (dV = 2 pi r dA),
``SolidBody``; u_r = 0 on the axis; the centre node's u_z = 0 (its reaction vanishes by symmetry: reported).
Contact: two ``felupe.MultiPointContact`` (node-to-rigid-line penalty, only the z component), one per plate, on
the surface nodes of each half, each with a centre point (an extra point carrying the plate's displacement),
both plates moved by a ramped ``Boundary`` in a ``Step``/``Job`` (``newtonraphson``, ``pypardiso.spsolve``,
``CutbackPlugin``). F is the reaction at the upper plate's centre point: the sum of the penalty forces, each
the ring force of its node (the integral over the full circle), so F is the whole plate force. The penalty's
effect is measured by repeating the coarsest mesh with each of ``--penalties``. ``--contact plane`` uses
``felupe.ContactRigidPlane`` instead (its penalty a factor of the mean normal stiffness of the contact nodes).
Both codes go to delta 0.50625 in 27 steps (rows of the truth); one more FElupe curve on the coarsest mesh tries
``--reach`` and says where and why it stopped.

elastocell: ``compress_axisymmetric`` on ``MeridianMeshParameters().scaled(s)`` (exact frictionless contact by an
active set). The truth: its finest curve (scale 0.5) from the cache of ``validation/axisymmetric.py`` (not
recomputed here; that script prints its refinement and Richardson's estimate of its error).

Both codes are timed in this one process, one curve after the other (a warm-up curve of each first, so that
neither pays JIT compilation or imports inside its timed curves); the time of a curve includes making its mesh.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np
from page import Page

from elastocell.body.cell import Cell  # noqa: F401  (JAX first: see validation/axisymmetric.py)

# isort: split
from axisymmetric import DELTAS, axisymmetric_curve, cell_options
from felupe_peer import E, R, _get_solver, _mkl_threads, check_material

from elastocell.body.axisymmetric import AxisymmetricCell, MeridianMeshParameters
from elastocell.parameters.cell import cell_parameters
from elastocell.scenarios.axisymmetric import AxisymmetricError, compress_axisymmetric

NU = 0.48
TRUTH_SCALE = 0.5
DELTA_MAX, STEPS = 0.50625, 27
"""Both codes to delta 0.50625 in 27 steps: the rows of the truth (40 steps to 0.75); FElupe stops near 0.525."""
ERRORS = [f"err@{d:g}" for d in DELTAS]
_GMSH_TRIANGLE6 = 9
COMMON = 0.3
"""Every curve of the table reaches it: times and errors up to it compare the codes at equal accuracy."""
CONTACTS = {"multipoint": "MultiPointContact", "plane": "ContactRigidPlane"}


def mesh_meridian(scale: float):
    """The meridian half-disc {r >= 0, r^2 + z^2 <= R^2} in 6-node triangles (FElupe's node order), sized as
    elastocell's ``MeridianMeshParameters().scaled(scale)``; the quarter z >= 0 meshed by gmsh and mirrored.
    Returns points (n, 2), cells (m, 6), the surface (arc) points, the axis points and the centre point."""
    import gmsh

    sizes = MeridianMeshParameters().scaled(scale)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("meridian")
        occ = gmsh.model.occ
        centre, east, north = occ.addPoint(0, 0, 0), occ.addPoint(R, 0, 0), occ.addPoint(0, R, 0)
        arc = occ.addCircleArc(east, centre, north)
        bottom, axis = occ.addLine(centre, east), occ.addLine(north, centre)
        occ.addPlaneSurface([occ.addCurveLoop([bottom, arc, axis])])
        occ.synchronize()
        field = gmsh.model.mesh.field

        def graded(sources: str, tags: list[int], small: float, large: float, width: float) -> int:
            "A size growing linearly from ``small`` on the entities ``tags`` to ``large`` at distance ``width``."
            distance, threshold = field.add("Distance"), field.add("Threshold")
            field.setNumbers(distance, sources, tags)
            field.setNumber(distance, "Sampling", 400)
            for name, value in (("InField", distance), ("SizeMin", small * R), ("SizeMax", large * R),
                                ("DistMin", 0.0), ("DistMax", width * R)):
                field.setNumber(threshold, name, value)
            return threshold

        surface = graded("CurvesList", [arc], sizes.surface_size, sizes.mesh_size, sizes.surface_width)
        polar = graded("PointsList", [north], sizes.pole_size, sizes.surface_size, sizes.pole_radius)
        smallest = field.add("Min")
        field.setNumbers(smallest, "FieldsList", [surface, polar])
        field.setAsBackgroundMesh(smallest)
        for option in ("Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature", "Mesh.MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(option, 0)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        tags, coordinates, _ = gmsh.model.mesh.getNodes()
        index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        types, _, nodes = gmsh.model.mesh.getElements(2)
        cells = index[nodes[list(types).index(_GMSH_TRIANGLE6)].astype(np.int64)].reshape(-1, 6)
        quarter = coordinates.reshape(-1, 3)[:, :2]
    finally:
        gmsh.finalize()
    used = np.unique(cells)
    renumber = np.full(len(quarter), -1)
    renumber[used] = np.arange(len(used))
    quarter, cells = quarter[used], renumber[cells]
    on_plane = np.abs(quarter[:, 1]) < 1e-12 * R
    # the mirror image z -> -z: new points except on z = 0, triangles reoriented (corners 0 2 1, mid-sides 5 4 3)
    image = np.where(on_plane, np.arange(len(quarter)), len(quarter) + np.cumsum(~on_plane) - 1)
    points = np.vstack([quarter, quarter[~on_plane] * [1.0, -1.0]])
    cells = np.vstack([cells, image[cells][:, [0, 2, 1, 5, 4, 3]]])
    radius = np.hypot(points[:, 0], points[:, 1])
    arc_points = np.flatnonzero(np.abs(radius - R) < 1e-9 * R)
    axis_points = np.flatnonzero(np.abs(points[:, 0]) < 1e-12 * R)
    centre_point = int(np.argmin(radius))
    return points, cells, arc_points, axis_points, centre_point


def felupe_curve(scale: float, delta_max: float, steps: int, penalty: float = 1e4 * E * R,
                 contact: str = "multipoint", solver: str = "pypardiso", linesearch: bool = False,
                 cutbacks: int = 6) -> dict:
    """F/(E R^2) against delta from FElupe's axisymmetric mode on the mesh of ``scale``: delta, force, nodes,
    seconds (mesh and solve), Newton iterations, the delta reached, the error that stopped it, and the largest
    reaction at the centre node over F."""
    import felupe as fem

    start = time.perf_counter()
    spsolve, _ = _get_solver(solver)
    mu, kappa = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
    points, cells, arc, axis, centre = mesh_meridian(scale)
    n = len(points)
    offset = 1e-6 * R  # the plates start just off the poles: the sign of every gap is defined at delta 0
    # FElupe's axisymmetric coordinates are (axial, radial): (z, r), the triangles turned counter-clockwise again
    axial = np.vstack([points[:, ::-1], [[R + offset, 0.0], [-R - offset, 0.0]]])
    mesh = fem.Mesh(axial, cells[:, [0, 2, 1, 5, 4, 3]], "triangle6")
    top, bottom = n, n + 1
    region = fem.RegionQuadraticTriangle(mesh)
    displacement = fem.FieldAxisymmetric(region, dim=2)
    field = fem.FieldContainer([displacement])
    solid = fem.SolidBody(umat=fem.NeoHooke(mu=mu, bulk=kappa), field=field)
    if contact == "multipoint":
        contacts = [fem.MultiPointContact(field, points=arc[points[arc, 1] * sign > 0], centerpoint=plate,
                                          skip=(False, True), multiplier=penalty)
                    for sign, plate in ((1, top), (-1, bottom))]
    else:  # the plane's outward normal points into the cell; penalty: times the mean normal stiffness of its nodes
        contacts = [fem.ContactRigidPlane(field, points=arc[points[arc, 1] * sign > 0], centerpoint=plate,
                                          normal=[-sign, 0.0], multiplier=penalty, items=[solid])
                    for sign, plate in ((1, top), (-1, bottom))]
    every = np.arange(mesh.npoints)
    boundaries = {
        "axis": fem.Boundary(displacement, mask=np.isin(every, axis), skip=(1, 0)),
        "centre": fem.Boundary(displacement, mask=every == centre, skip=(0, 1)),
        "plates-r": fem.Boundary(displacement, mask=(every == top) | (every == bottom), skip=(1, 0)),
        "top": fem.Boundary(displacement, mask=every == top, skip=(0, 1)),
        "bottom": fem.Boundary(displacement, mask=every == bottom, skip=(0, 1)),
    }
    deltas = np.linspace(0.0, delta_max, steps + 1)
    travel = R * deltas + offset  # plate at z = +-(R - R delta)
    step = fem.Step(items=[solid, *contacts], boundaries=boundaries,
                    ramp={boundaries["top"]: -travel, boundaries["bottom"]: travel})
    record = {"delta": [0.0], "force": [0.0], "centre": [0.0], "iterations": 0, "times": [0.0]}

    class Recorder(fem.Plugin):
        def after_iteration(self, context, state):
            record["iterations"] += 1

        def after_substep(self, context, state):
            if state.substepnumber == 0:
                return
            reactions = context.substep.fun.reshape(-1, 2)
            force = -reactions[top, 0]
            record["delta"].append(float(deltas[state.substepnumber]))
            record["force"].append(float(force))
            record["centre"].append(float(abs(reactions[centre, 0]) / max(abs(force), 1e-300)))
            record["times"].append(time.perf_counter() - start)

    plugins = [fem.CutbackPlugin(factor=0.5, max_cutbacks=cutbacks, growth=2.0), Recorder()]
    job = fem.Job(steps=[step], plugins=[fem.LinesearchPlugin(), *plugins] if linesearch else plugins)
    error = ""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", RuntimeWarning)  # trial states with det F <= 0, then cut back
        try:
            job.evaluate(solver=spsolve, verbose=False, tol=1e-8, maxiter=30)
        except Exception as failure:  # noqa: BLE001  (the step that failed after every cut-back)
            error = f"{type(failure).__name__}: {failure}"[:160]
    return {"delta": record["delta"], "force": record["force"], "nodes": n, "elements": len(cells),
            "seconds": time.perf_counter() - start, "newton": record["iterations"], "error": error,
            "times": record["times"],
            "centre_reaction": max(record["centre"]), "penalty": penalty}


def elastocell_curve(scale: float, delta_max: float, steps: int) -> dict:
    """``compress_axisymmetric`` on ``MeridianMeshParameters().scaled(scale)``, timed with its mesh."""
    start, times = time.perf_counter(), []
    body = AxisymmetricCell.from_parameters(cell_parameters(**cell_options(1)), MeridianMeshParameters().scaled(scale))
    try:
        result, error = compress_axisymmetric(body, delta_max, steps,
                                              on_row=lambda _: times.append(time.perf_counter() - start)), ""
    except AxisymmetricError as failure:
        result, error = failure.partial, str(failure)[:160]
    return {"delta": result.load.tolist(), "force": result.force.tolist(), "nodes": body.mesh.n_nodes,
            "elements": len(body.mesh.elements), "seconds": time.perf_counter() - start, "error": error,
            "times": [0.0, *times],
            "newton": result.newton_iterations}


def at_deltas(record: dict) -> np.ndarray:
    """F at DELTAS (log-log interpolation between rows, NaN beyond the last row), as validation/axisymmetric.py."""
    from axisymmetric import at_deltas as interpolate

    return interpolate(record) if len(record["delta"]) > 1 else np.full(len(DELTAS), np.nan)


def time_to(record: dict, delta: float) -> float:
    """Wall time from the start of the curve (its mesh included) to its first row at ``delta`` or beyond."""
    reached = np.flatnonzero(np.asarray(record["delta"]) >= delta - 1e-9)
    return record["times"][reached[0]] if len(reached) and reached[0] < len(record["times"]) else np.nan


def row(code: str, scale: float, record: dict, truth: np.ndarray, **extra) -> dict:
    errors = at_deltas(record) / truth - 1
    return {"code": code, "scale": scale, "nodes": record["nodes"], "elements": record["elements"],
            "time_s": record["seconds"], "time_0.3_s": time_to(record, COMMON), "delta_reached": record["delta"][-1],
            **{name: e for name, e in zip(ERRORS, errors, strict=True)},
            "max_abs_err": float(np.nanmax(np.abs(errors))) if np.isfinite(errors).any() else np.nan,
            **extra, "stop": record["error"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--felupe-scales", nargs="+", type=float, default=[2.0, 1.4, 1.0])
    parser.add_argument("--elastocell-scales", nargs="+", type=float, default=[2.0, 1.0, 0.7])
    parser.add_argument("--penalty", type=float, default=1e4, help="FElupe's contact penalty (multipoint: force "
                        "per length per node, in E R; plane: times the mean normal stiffness of the contact nodes)")
    parser.add_argument("--penalties", nargs="+", type=float, default=[1e3, 1e4, 1e5],
                        help="the penalties tried on the coarsest FElupe mesh")
    parser.add_argument("--delta-max", type=float, default=DELTA_MAX, help="the delta both codes go to")
    parser.add_argument("--steps", type=int, default=STEPS, help="equal load steps to --delta-max")
    parser.add_argument("--reach", type=float, default=0.75,
                        help="delta that one more FElupe curve on the coarsest mesh tries to reach (0: none)")
    parser.add_argument("--threads", type=int, default=1, help="MKL threads of PARDISO (1: the cores are shared)")
    parser.add_argument("--contact", choices=["multipoint", "plane"], default="multipoint",
                        help="FElupe's contact: MultiPointContact or ContactRigidPlane")
    parser.add_argument("--no-page", action="store_true", help="print only")
    args = parser.parse_args()
    import felupe as fem

    _mkl_threads(args.threads)
    truth_record = axisymmetric_curve(cell_options(1), TRUTH_SCALE, cached_only=True)
    if truth_record is None:
        raise SystemExit("the truth is not in the cache: run `nice python validation/axisymmetric.py --only "
                         "refinement --ratios 1` first")
    truth = at_deltas(truth_record)
    page = Page("axisymmetric", "felupe_axisymmetric.py", versions=("felupe", "pypardiso", "gmsh"), intro=(
        "The homogeneous cell (R = 1, E = 1, nu 0.48, the same neo-Hookean W) between rigid frictionless plates, "
        f"{args.steps} equal load steps to delta {args.delta_max:g}, solved by FElupe's axisymmetric mode "
        "(`FieldAxisymmetric`, `RegionQuadraticTriangle` on a gmsh half-disc with elastocell's meridian sizes "
        f"times scale; contact by two `{CONTACTS[args.contact]}`, a node-to-rigid-line penalty) and by elastocell's "
        "`compress_axisymmetric` (exact frictionless contact by an active set), one curve after the other in this "
        "process. Every error is F/F_truth - 1, the truth being elastocell's curve on the meridian mesh of scale "
        f"{TRUTH_SCALE:g} ({truth_record['nodes']} nodes; from the cache of `validation/axisymmetric.py`, whose "
        "section above gives its refinement). time_s is the wall time of one curve including its mesh, after a "
        "warm-up curve of each code (imports and JIT compilation not counted), on a shared 2-core machine: the "
        "load average is in the footer, and only the ratios of times in this run mean anything."))
    page.print(f"FElupe {fem.__version__}, PARDISO with {args.threads} MKL thread(s); material check "
               f"(NeoHooke against W, largest relative error) {check_material(NU):.1e}; "
               f"load average at the start {os.getloadavg()[0]:.1f}")
    coarse = max(args.felupe_scales)
    page.print("warm-up (not timed in the table): FElupe and elastocell, 2 load steps on the coarsest mesh")
    felupe_curve(coarse, 0.05, 2)
    elastocell_curve(max(args.elastocell_scales), 0.05, 2)

    rows, loads = [], []
    for scale in sorted(args.elastocell_scales, reverse=True):
        record = elastocell_curve(scale, args.delta_max, args.steps)
        rows.append(row("elastocell", scale, record, truth, newton=record["newton"], penalty=""))
        loads.append(os.getloadavg()[0])
        page.print(f"elastocell scale {scale:g}: {record['nodes']} nodes, {record['seconds']:.1f} s, "
                   f"delta {record['delta'][-1]:.3f}, load {loads[-1]:.1f}")
    penalty_rows = []
    for scale in sorted(args.felupe_scales, reverse=True):
        record = felupe_curve(scale, args.delta_max, args.steps, args.penalty, args.contact)
        rows.append(row("FElupe", scale, record, truth, newton=record["newton"], penalty=f"{record['penalty']:.0e}"))
        loads.append(os.getloadavg()[0])
        page.print(f"FElupe scale {scale:g}: {record['nodes']} nodes, {record['seconds']:.1f} s, "
                   f"delta {record['delta'][-1]:.3f}, centre reaction/F {record['centre_reaction']:.1e}, "
                   f"load {loads[-1]:.1f}" + (f" ({record['error']})" if record["error"] else ""))
        if scale == coarse:
            penalty_rows.append((record, rows[-1]))
    for penalty in args.penalties:
        if penalty == args.penalty:
            continue
        record = felupe_curve(coarse, args.delta_max, args.steps, penalty=penalty, contact=args.contact)
        penalty_rows.append((record, row("FElupe", coarse, record, truth, newton=record["newton"],
                                         penalty=f"{penalty:.0e}")))
        page.print(f"FElupe scale {coarse:g}, penalty {penalty:.0e}: {record['seconds']:.1f} s, "
                   f"delta {record['delta'][-1]:.3f}")
    if args.reach > args.delta_max:
        steps = round(args.steps * args.reach / args.delta_max)
        record = felupe_curve(coarse, args.reach, steps, args.penalty, args.contact)
        reach = row("FElupe", coarse, record, truth, newton=record["newton"], penalty=f"{record['penalty']:.0e}")
        page.print(f"FElupe scale {coarse:g} towards delta {args.reach:g} ({steps} steps, up to 6 cut-backs of a "
                   f"step): reached {record['delta'][-1]:.4f} in {record['seconds']:.1f} s, errors "
                   + " ".join(f"{name} {reach[name]:+.3%}" for name in ERRORS)
                   + (f"; stopped by {record['error']}" if record["error"] else ""))
    shown = [name for d, name in zip(DELTAS, ERRORS, strict=True) if d <= args.delta_max + 1e-12]
    columns = ["code", "scale", "nodes", "elements", "time_s", "time_0.3_s", "newton", "delta_reached", *shown, "max_abs_err",
               "stop"]
    formats = {"time_s": ".1f", "time_0.3_s": ".1f", "delta_reached": ".3f", "max_abs_err": ".3%", **{e: "+.3%" for e in ERRORS}}
    page.table(rows, "Error against the truth and wall time per curve (max_abs_err: the largest |error| at "
               + ", ".join(name.removeprefix("err@") for name in shown) + "; newton: Newton iterations of the "
               "curve, cut-back tries included; time_0.3_s: from the start of the curve to its row at delta 0.3; penalty: "
               "of FElupe's contact, see --penalty)",
               columns=columns, formats=formats)
    early = [name for d, name in zip(DELTAS, ERRORS, strict=True) if d <= COMMON + 1e-12]
    for felupe in (r for r in rows if r["code"] == "FElupe"):
        error = max(abs(felupe[name]) for name in early)
        matches = [r for r in rows if r["code"] == "elastocell" and max(abs(r[name]) for name in early) <= error]
        best = min(matches, key=lambda r: r["time_0.3_s"]) if matches else None
        page.print(f"FElupe scale {felupe['scale']:g}: largest |error| to delta {COMMON:g} {error:.3%} in "
                   f"{felupe['time_0.3_s']:.1f} s; " + (
                       f"elastocell's cheapest curve as accurate (scale {best['scale']:g}, "
                       f"{max(abs(best[name]) for name in early):.3%}) took {best['time_0.3_s']:.1f} s: "
                       f"ratio FElupe/elastocell {felupe['time_0.3_s'] / best['time_0.3_s']:.1f}"
                       if best else "no elastocell curve of this run is as accurate"))
    reference = at_deltas(penalty_rows[0][0])
    penalty_table = [{"penalty": r["penalty"], "time_s": r["time_s"], "delta_reached": r["delta_reached"],
                      **{f"dF@{d:g}": change for d, change, name in
                         zip(DELTAS, at_deltas(record) / reference - 1, ERRORS, strict=True) if name in shown},
                      **{name: r[name] for name in shown}} for record, r in penalty_rows]
    page.table(penalty_table, f"The contact penalty's effect on FElupe's F (scale {coarse:g}): dF is the change "
               f"from the penalty {args.penalty:.0e} of the table above", formats={
                   "time_s": ".1f", "delta_reached": ".3f", **{f"dF@{d:g}": "+.1e" for d in DELTAS},
                   **{e: "+.3%" for e in ERRORS}})
    page.print(f"load average (1 min) after each curve: {' '.join(f'{x:.1f}' for x in loads)}")
    if not args.no_page:
        page.write()


if __name__ == "__main__":
    main()
