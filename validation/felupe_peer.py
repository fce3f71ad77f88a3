"""FElupe peer solver for elastocell's parallel-plate compression benchmark.

A homogeneous compressible neo-Hookean ball (radius ``R = 1``, Young's modulus
``E = 1``, Poisson ratio ``nu``) is squeezed between two rigid, frictionless,
parallel plates with normal ``z``.  The lower plate rests at ``z = -R``, the upper
plate moves down.  The deformation is ``delta = 1 - h / (2 R)`` with ``h`` the
plate gap; the output is the total normal force on the upper plate, ``F / (E R^2)``.

Strain energy per reference volume (identical to elastocell's)::

    W = mu/2 (J^(-2/3) I1 - 3) + kappa/2 (J - 1)^2,
    mu = E / (2 (1 + nu)),  kappa = E / (3 (1 - 2 nu)),

which is exactly ``felupe.NeoHooke(mu=mu, bulk=kappa)`` (closed-form energy,
stress and elasticity; checked against finite differences of ``W`` in
:func:`check_material`).

Discretisation: full 3D ball (no symmetry), gmsh OCC sphere meshed with quadratic
10-node tetrahedra (``gmsh.model.mesh.setOrder(2)``, curved boundary), FElupe
``RegionQuadraticTetra`` with the 4-point ``TetrahedronQuadrature(order=2)``.

Contact: two ``felupe.MultiPointContact`` items (frictionless node-to-rigid-plane
penalty contact, only the z-component is connected), one per plate, each with its
own centre point (an extra mesh point carrying the plate's rigid-body dof), acting
on the surface nodes of the upper / lower hemisphere.  The upper plate's centre
point is moved by a ramped ``Boundary`` in a ``felupe.Step`` / ``felupe.Job``
(``felupe.newtonraphson`` with ``pypardiso.spsolve``, ``felupe.CutbackPlugin`` for
failed steps), the lower one is fixed.  The plate force is the reaction force on the
upper centre point.  The rigid-body modes left free by frictionless plates (x, y
translation, rotation about z and -- for a sphere -- the "rolling" rotations about
x and y) are removed by 5 point constraints compatible with the axisymmetric
solution; the z-translation is left free (carried by the two contacts).

Run ``python validation/felupe_peer.py`` for a small mesh-convergence table (also written into
docs/validation/compression.md by ``validation/page.py``).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

R = 1.0  # ball radius
E = 1.0  # Young's modulus

# gmsh Tetra10 -> VTK/FElupe QuadraticTetra: gmsh mid-edge nodes are ordered
# (0,1),(1,2),(2,0),(3,0),(3,2),(3,1); FElupe expects (0,1),(1,2),(2,0),(0,3),(1,3),(2,3).
_GMSH_TO_FELUPE_TET10 = np.array([0, 1, 2, 3, 4, 5, 6, 7, 9, 8])


def _mkl_threads(n: int | None):
    "Set the number of MKL threads of pypardiso's mkl_rt (None: leave as is)."
    if n is None:
        return
    try:
        import pypardiso

        lib = pypardiso.scipy_aliases.pypardiso_solver.libmkl
        lib.MKL_Set_Num_Threads(int(n))
    except Exception:  # pragma: no cover
        pass


def _get_solver(name: str = "pypardiso"):
    """Return (spsolve, name).

    ``"pypardiso"``: ``pypardiso.spsolve`` (MKL PARDISO, real unsymmetric LU);
    ``"pypardiso-sym"``: PARDISO symmetric-indefinite LDL^T on the upper triangle
    (the tangent of a hyperelastic body with penalty contact is symmetric);
    ``"scipy"`` (or pypardiso missing): ``scipy.sparse.linalg.spsolve``.
    """
    if name.startswith("pypardiso"):
        try:
            import pypardiso
        except Exception:  # pragma: no cover - fallback
            pypardiso = None
        if pypardiso is not None and name == "pypardiso":
            return pypardiso.spsolve, "pypardiso"
        if pypardiso is not None and name == "pypardiso-sym":
            import scipy.sparse as sp

            sym = pypardiso.PyPardisoSolver(mtype=-2)

            def spsolve_sym(A, b):
                return sym.solve(sp.triu(A, format="csr"), np.asarray(b, dtype=float))

            return spsolve_sym, "pypardiso-sym"
    from scipy.sparse.linalg import spsolve

    return spsolve, "scipy"


def mesh_ball(mesh_size: float, pole_size: float | None = None, radius: float = R):
    """Mesh a ball with quadratic (10-node) tetrahedra by gmsh.

    Parameters
    ----------
    mesh_size : float
        Characteristic element length relative to the radius.
    pole_size : float or None
        If given, element length at the two poles ``z = +-R`` (where the plates
        touch), blended to ``mesh_size`` by a Distance + Threshold field.

    Returns
    -------
    points : (n, 3) ndarray
    cells : (m, 10) ndarray of int, FElupe/VTK ordering
    surface_points : (k,) ndarray of int, ids of the points on the sphere surface
    """
    import gmsh

    h = mesh_size * radius
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.Verbosity", 1)
        gmsh.model.add("ball")
        vol = gmsh.model.occ.addSphere(0.0, 0.0, 0.0, radius)
        gmsh.model.occ.synchronize()

        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay
        gmsh.option.setNumber("Mesh.Optimize", 1)

        if pole_size is not None and pole_size < mesh_size:
            hp = pole_size * radius
            gmsh.option.setNumber("Mesh.MeshSizeMin", hp)
            # the OCC sphere has its two vertices at the poles (0, 0, +-R); use
            # them as the source of the distance field
            pole_tags = []
            for _dim, tag in gmsh.model.getEntities(0):
                xyz = gmsh.model.getValue(0, tag, [])
                if abs(abs(xyz[2]) - radius) < 1e-6 * radius and np.hypot(xyz[0], xyz[1]) < 1e-6 * radius:
                    pole_tags.append(tag)
            if len(pole_tags) != 2:
                raise RuntimeError("OCC sphere without vertices at the two poles")
            dist = gmsh.model.mesh.field.add("Distance")
            gmsh.model.mesh.field.setNumbers(dist, "PointsList", pole_tags)
            thr = gmsh.model.mesh.field.add("Threshold")
            gmsh.model.mesh.field.setNumber(thr, "InField", dist)
            gmsh.model.mesh.field.setNumber(thr, "SizeMin", hp)
            gmsh.model.mesh.field.setNumber(thr, "SizeMax", h)
            # fine up to ~ the Hertz contact radius at delta ~ 0.1 (a = R sqrt(delta))
            gmsh.model.mesh.field.setNumber(thr, "DistMin", 0.3 * radius)
            gmsh.model.mesh.field.setNumber(thr, "DistMax", 0.8 * radius)
            gmsh.model.mesh.field.setAsBackgroundMesh(thr)
        else:
            gmsh.option.setNumber("Mesh.MeshSizeMin", h)

        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)  # curved (geometry-conforming) quadratic mesh

        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        coords = coords.reshape(-1, 3)
        index = np.zeros(int(node_tags.max()) + 1, dtype=np.int64)
        index[node_tags.astype(np.int64)] = np.arange(len(node_tags))

        etypes, _, enodes = gmsh.model.mesh.getElements(3, vol)
        tet10 = gmsh.model.mesh.getElementType("Tetrahedron", 2)
        (k,) = [i for i, t in enumerate(etypes) if t == tet10]
        cells = index[enodes[k].astype(np.int64)].reshape(-1, 10)

        surf_nodes = []
        for _, stag in gmsh.model.getEntities(2):
            tags, _, _ = gmsh.model.mesh.getNodes(2, stag, includeBoundary=True)
            surf_nodes.append(tags)
        surface = np.unique(index[np.concatenate(surf_nodes).astype(np.int64)])
    finally:
        gmsh.finalize()

    # keep only points which belong to the volume cells (renumber)
    used = np.unique(cells)
    renumber = -np.ones(len(coords), dtype=np.int64)
    renumber[used] = np.arange(len(used))
    points = coords[used]
    cells = renumber[cells][:, _GMSH_TO_FELUPE_TET10]
    surface = renumber[surface]
    surface = surface[surface >= 0]
    return points, cells, surface


def check_material(poisson_ratio: float = 0.48, seed: int = 0) -> float:
    """Return the max. relative error of felupe.NeoHooke's energy/stress vs. the
    required W = mu/2 (J^-2/3 I1 - 3) + kappa/2 (J - 1)^2 (finite differences)."""
    import felupe as fem

    nu = poisson_ratio
    mu = E / (2 * (1 + nu))
    kappa = E / (3 * (1 - 2 * nu))

    def w(F):
        J = np.linalg.det(F)
        return mu / 2 * (J ** (-2 / 3) * np.trace(F.T @ F) - 3) + kappa / 2 * (J - 1) ** 2

    umat = fem.NeoHooke(mu=mu, bulk=kappa)
    rng = np.random.default_rng(seed)
    F = np.eye(3) + 0.2 * rng.standard_normal((3, 3))
    if np.linalg.det(F) <= 0:
        F[0] *= -1
    Fx = F[:, :, None, None]
    W_fe = umat.function([Fx])[0].ravel()[0]
    P_fe = umat.gradient([Fx, np.zeros(0)])[0][:, :, 0, 0]
    eps = 1e-6
    P_fd = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            Fp, Fm = F.copy(), F.copy()
            Fp[i, j] += eps
            Fm[i, j] -= eps
            P_fd[i, j] = (w(Fp) - w(Fm)) / (2 * eps)
    return max(abs(W_fe - w(F)) / abs(w(F)), np.abs(P_fe - P_fd).max() / np.abs(P_fd).max())


def felupe_compression_curve(
    mesh_size: float,
    pole_size: float | None = None,
    delta_max: float = 0.75,
    n_steps: int = 40,
    poisson_ratio: float = 0.48,
    *,
    penalty: float | None = None,
    linesearch: bool = False,
    tol: float = 1e-7,
    solver: str = "pypardiso",
    threads: int | None = 1,
    verbose: bool = False,
) -> dict:
    """Force-deformation curve of a neo-Hookean ball between two rigid plates.

    Parameters
    ----------
    mesh_size : float
        gmsh characteristic length relative to R.
    pole_size : float or None
        Element length near the poles z = +-R (Distance + Threshold field), or None.
    delta_max, n_steps : float, int
        Final deformation delta = 1 - h/(2R) and number of equal load steps (failed
        steps are cut back automatically by ``felupe.CutbackPlugin``).
    poisson_ratio : float
        nu; mu = E/(2(1+nu)), kappa = E/(3(1-2nu)), E = 1.

    Keyword-only (not part of the benchmark interface): ``penalty`` (contact
    multiplier, default 1e4 E R), ``linesearch`` (add ``felupe.LinesearchPlugin``),
    ``tol`` (relative residual tolerance of ``felupe.newtonraphson``), ``solver``
    ("pypardiso" = ``pypardiso.spsolve``, "pypardiso-sym", "scipy"), ``threads``
    (MKL threads, default 1 because the cores are shared), ``verbose``.

    Returns
    -------
    dict with ``delta`` (converged load steps, starting at 0), ``force_per_E_R2``
    (upper-plate force, same shape), ``wall_time_s`` (solver only), ``mesh_time_s``,
    ``n_nodes``, ``n_elements``, ``newton_iterations`` (all Newton iterations,
    incl. those of failed/cut-back attempts) and diagnostics: ``converged``
    (reached ``delta_max``), ``failed_at_delta`` (None or the delta of the load step
    that failed after all cutbacks), ``n_increments`` (Newton solves incl. cutbacks),
    ``force_bottom_per_E_R2`` (lower-plate force; equals the upper one at
    equilibrium because the z-translation is free), ``rigid_reaction_rel`` /
    ``max_rigid_reaction`` (largest reaction at the rigid-body-mode supports relative
    to F per step / overall), ``cutback_at_delta`` (load steps which were
    subdivided), ``penalty``, ``solver``, ``felupe_version``.
    """
    import felupe as fem

    solver, solver_name = _get_solver(solver)
    _mkl_threads(threads)

    nu = poisson_ratio
    mu = E / (2 * (1 + nu))
    kappa = E / (3 * (1 - 2 * nu))

    # --- mesh -------------------------------------------------------------------
    t0 = time.perf_counter()
    points, cells, surface = mesh_ball(mesh_size, pole_size)
    mesh_time = time.perf_counter() - t0
    n_nodes, n_elements = len(points), len(cells)

    # plate centre points: slightly outside the ball, so that the initial sign of the
    # gap of every surface point is well defined (MultiPointContact activates a point
    # when the sign of its gap to the centre point changes)
    offset = 1e-6 * R
    z_top0, z_bot0 = R + offset, -R - offset
    mesh = fem.Mesh(
        np.vstack([points, [[0.0, 0.0, z_top0], [0.0, 0.0, z_bot0]]]),
        cells,
        "tetra10",
    )
    itop, ibot = n_nodes, n_nodes + 1
    region = fem.RegionQuadraticTetra(mesh, quadrature=fem.TetrahedronQuadrature(order=2))
    displacement = fem.Field(region, dim=3)
    field = fem.FieldContainer([displacement])

    umat = fem.NeoHooke(mu=mu, bulk=kappa)
    solid = fem.SolidBody(umat=umat, field=field)

    zs = points[surface, 2]
    if penalty is None:
        # penalty stiffness per contact point (force / length).  FElupe's default is
        # 1e6; 1e4 E R gives the same forces to ~5 digits (penetration ~1e-6 R) and a
        # much better conditioned tangent (PARDISO ~4x faster, lower residual floor)
        penalty = 1e4 * E * R
    contact_top = fem.MultiPointContact(
        field,
        points=surface[zs > 0],
        centerpoint=itop,
        skip=(True, True, False),
        multiplier=penalty,
    )
    contact_bot = fem.MultiPointContact(
        field,
        points=surface[zs < 0],
        centerpoint=ibot,
        skip=(True, True, False),
        multiplier=penalty,
    )

    # rigid-body modes left free by frictionless plates: x, y translation and the
    # rotation about z, and -- because the body is a sphere, whose rotated shape is the
    # same sphere -- also (to first order) the rotations about x and y ("rolling").
    # They are removed by constraints which are compatible with the axisymmetric
    # solution: ux = uy = 0 at the point nearest to the centre and at a point near
    # (0, 0, R/2) on the z-axis, uy = 0 at a point near (R/2 .. R, 0, 0).  The
    # z-translation stays free (fixed by the contact with both plates).  At
    # equilibrium the reactions vanish up to the asymmetry of the unstructured mesh
    # (reported as ``max_rigid_reaction``).
    ic = int(np.argmin(np.linalg.norm(points, axis=1)))
    iz = int(np.argmin(np.linalg.norm(points - [0.0, 0.0, 0.5 * R], axis=1)))
    cand = np.where(points[:, 0] > 0.5 * R)[0]
    ix = int(cand[np.argmin(points[cand, 1] ** 2 + points[cand, 2] ** 2)])
    mask = np.zeros((mesh.npoints, 3), dtype=bool)
    mask[ic, [0, 1]] = True
    mask[iz, [0, 1]] = True
    mask[ix, 1] = True
    boundaries = {
        "rigid": fem.Boundary(displacement, mask=mask),
        "bottom": fem.Boundary(displacement, mask=np.arange(mesh.npoints) == ibot),
        "top-xy": fem.Boundary(displacement, mask=np.arange(mesh.npoints) == itop, skip=(0, 0, 1)),
        "move": fem.Boundary(displacement, mask=np.arange(mesh.npoints) == itop, skip=(1, 1, 0)),
    }
    # the lower plate stays exactly at z = -R (its centre point was placed at -R-offset)
    boundaries["bottom"].update(np.array([0.0, 0.0, offset]))

    # the first (trivial) substep at delta = 0 makes the ramp values of the previous
    # substep known to the CutbackPlugin, so that also the first load step can be cut
    # back; it is not recorded again
    deltas = np.linspace(0.0, delta_max, n_steps + 1)
    # plate at z = R - 2 R delta  ->  u_z(centre) = R - 2 R delta - z_top0
    table = (R - 2 * R * deltas) - z_top0
    step = fem.Step(
        items=[solid, contact_top, contact_bot],
        ramp={boundaries["move"]: table},
        boundaries=boundaries,
    )

    record = {
        "delta": [0.0],
        "force": [0.0],
        "force_bottom": [0.0],
        "rigid": [0.0],
        "cutbacks": [],
        "iterations": 0,
    }
    attempts = {"n": 0, "last": 0.0}

    class _Record(fem.Plugin):
        def before_newton(self, context, state):  # every Newton solve, incl. cutbacks
            attempts["n"] += 1

        def after_iteration(self, context, state):  # every iteration, incl. failed
            record["iterations"] += 1

        def before_substep(self, context, state):
            attempts["last"] = float(deltas[state.substepnumber])

        def after_substep(self, context, state):
            if state.substepnumber == 0:
                return
            res = context.substep
            f = res.fun.reshape(-1, 3)
            F = -f[itop, 2]  # reaction of the upper plate (ball pushes it up)
            record["delta"].append(float(deltas[state.substepnumber]))
            record["force"].append(float(F))
            record["force_bottom"].append(float(f[ibot, 2]))
            if getattr(state, "load_factors", None) is not None:  # cut back
                record["cutbacks"].append(float(deltas[state.substepnumber]))
            rig = np.abs(f[mask]).max()
            record["rigid"].append(float(rig / max(abs(F), 1e-300)))

    plugins = [_Record()]
    if linesearch:
        plugins.insert(0, fem.LinesearchPlugin())
    if hasattr(fem, "CutbackPlugin"):
        plugins.insert(0, fem.CutbackPlugin(factor=0.5, max_cutbacks=6, growth=2.0))
    job = fem.Job(steps=[step], plugins=plugins)

    converged, failed_at = True, None
    t1 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        # trial states with det F <= 0 (rejected, then cut back) warn in np.power
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            kw = {}
            if verbose:
                kw["callback"] = lambda dx, x, it, xn, fn, ok: print(
                    f"    it {it:2d} fnorm {fn:.3e}", flush=True
                )
            job.evaluate(solver=solver, verbose=False, tol=tol, maxiter=30, **kw)
        except Exception as err:  # convergence failure after all cutbacks
            converged, failed_at = False, attempts["last"]
            record["error"] = repr(err)
    wall_time = time.perf_counter() - t1
    if len(record["delta"]) < n_steps + 1:
        converged = False
        failed_at = attempts["last"] if failed_at is None else failed_at

    out = {
        "delta": np.array(record["delta"]),
        "force_per_E_R2": np.array(record["force"]) / (E * R**2),
        "wall_time_s": wall_time,
        "mesh_time_s": mesh_time,
        "n_nodes": int(n_nodes),
        "n_elements": int(n_elements),
        "newton_iterations": int(record["iterations"]),  # all, incl. failed tries
        "converged": converged,
        "failed_at_delta": failed_at,
        "n_increments": int(attempts["n"]),
        "cutback_at_delta": record["cutbacks"],
        "force_bottom_per_E_R2": np.array(record["force_bottom"]) / (E * R**2),
        "rigid_reaction_rel": np.array(record["rigid"]),
        "max_rigid_reaction": float(max(record["rigid"])),
        "penalty": float(penalty),
        "solver": solver_name,
        "felupe_version": fem.__version__,
    }
    if "error" in record:
        out["error"] = record["error"]
    return out


def hertz_force(delta, poisson_ratio=0.48):
    "Hertz F/(E R^2) for a sphere between two plates, delta = 1 - h/(2R)."
    return 4.0 / (3.0 * (1.0 - poisson_ratio**2)) * np.asarray(delta) ** 1.5


def interpolate_force(delta, d, f):
    """Interpolate F(delta) from a computed curve (d, f) linearly in F^(2/3), which is
    ~linear in delta for a Hertz-like contact (exact for F ~ delta^1.5)."""
    d, f = np.asarray(d), np.asarray(f)
    delta = np.asarray(delta, dtype=float)
    g = np.interp(delta, d, np.cbrt(f) ** 2, right=np.nan)
    return g**1.5


def _print_table(results, nu=0.48, page=None):
    probe = [0.1, 0.3, 0.5, 0.7]
    hertz_probe = [0.02, 0.03, 0.04, 0.05]
    rows = []
    for label, r in results:
        d, f = r["delta"], r["force_per_E_R2"]
        vals = interpolate_force(probe, d, f)
        ratio = interpolate_force(hertz_probe, d, f) / hertz_force(hertz_probe, nu)
        rows.append({"mesh:pole": label, "nodes": r["n_nodes"], "tets": r["n_elements"], "mesh_s": r["mesh_time_s"],
                     "solve_s": r["wall_time_s"], "Newton": r["newton_iterations"],
                     **{f"F@{p}": v for p, v in zip(probe, vals, strict=True)},
                     **{f"H@{p}": v for p, v in zip(hertz_probe, ratio, strict=True)},
                     "conv": r["converged"], "rigid": r["max_rigid_reaction"]})
    formats = {"mesh_s": ".2f", "solve_s": ".1f", "rigid": ".1e", **{f"F@{p}": ".4f" for p in probe},
               **{f"H@{p}": ".3f" for p in hertz_probe}}
    page.table(rows, formats=formats)


if __name__ == "__main__":
    import argparse

    from page import Page

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--delta-max", type=float, default=0.75)
    parser.add_argument("--n-steps", type=int, default=40)
    parser.add_argument("--nu", type=float, default=0.48)
    parser.add_argument(
        "--meshes",
        type=str,
        default="0.3,0.3:0.1,0.2",
        help="comma-separated mesh_size[:pole_size] list (relative to R)",
    )
    parser.add_argument("--solver", default="pypardiso", choices=["pypardiso", "pypardiso-sym", "scipy"])
    parser.add_argument("--threads", type=int, default=1, help="MKL threads")
    parser.add_argument("--curve", action="store_true", help="print the full curves")
    args = parser.parse_args()

    import felupe as fem

    page = Page("compression", "felupe_peer.py", intro=(
        "The peer alone: FElupe's curve of the homogeneous neo-Hookean ball between rigid frictionless plates (the "
        "problem of `validation/compression.py`, solved without elastocell) against Hertz's closed form "
        "F/(E R^2) = 4/(3 (1 - nu^2)) delta^1.5, which holds as delta -> 0: H@d = F_FElupe/F_Hertz at small "
        "delta d should tend to 1 as the mesh is refined. F@d is F/(E R^2) at delta d (interpolated linearly in "
        "F^(2/3)); rigid is the largest reaction at the supports that remove the rigid-body modes, over F."), versions=("felupe", "pypardiso"))
    page.print(f"FElupe {fem.__version__}, solver {_get_solver(args.solver)[1]}")
    page.print(f"material check (NeoHooke vs W, rel. err.): {check_material(args.nu):.1e}")

    results = []
    for spec in args.meshes.split(","):
        parts = spec.split(":")
        ms = float(parts[0])
        ps = float(parts[1]) if len(parts) > 1 and parts[1] else None
        r = felupe_compression_curve(
            ms,
            ps,
            delta_max=args.delta_max,
            n_steps=args.n_steps,
            poisson_ratio=args.nu,
            solver=args.solver,
            threads=args.threads,
        )
        label = f"{ms}" + (f":{ps}" if ps else "")
        results.append((label, r))
        page.print(
            f"  [{label}] nodes={r['n_nodes']} solve={r['wall_time_s']:.1f}s"
            f" increments={r['n_increments']} Newton={r['newton_iterations']}"
            f" converged={r['converged']} failed_at={r['failed_at_delta']}"
            f" cut back at delta={[round(x, 4) for x in r['cutback_at_delta']]}"
            f" F_top-F_bottom={np.abs(r['force_per_E_R2'] - r['force_bottom_per_E_R2']).max():.1e}",
        )
        if args.curve:
            for d, f in zip(r["delta"], r["force_per_E_R2"], strict=True):
                page.print(f"    {d:.5f} {f:.6f}")
    _print_table(results, args.nu, page)
    page.write()
