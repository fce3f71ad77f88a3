"""A rigid sphere (a bead of radius R_b) pressed quasistatically on the z axis into the 3D tetrahedral cell
(:class:`elastocell.body.cell.Cell`, the body of ``elastocell compress``) resting on a rigid flat dish: the path of
``elastocell indent --cell-shape sphere`` for a cell that is not axisymmetric (a random cell, a nucleus offset
along x or y, an ellipsoid not aligned with z), or when the 3D solver is asked for.

Geometry (units of R): the dish at z = -1 (the lower plate of :mod:`elastocell.scenarios.compression`), the
sphere centred at (0, 0, 1 + R_b - depth); ``depth`` is the sphere's displacement after first contact (it
includes the cell's deformation at the dish), as in :func:`elastocell.scenarios.axisymmetric.indent_axisymmetric`.

Contact is exact and frictionless, node to rigid surface: every surface node stays outside both obstacles
(gap z + 1 >= 0 at the dish, g = |x - c| - R_b >= 0 at the sphere). Each row is a minimum of the elastic energy
under those constraints, by a projected Newton method with an active set, the 3D form of the axisymmetric
solver's: a surface node on an obstacle whose energy gradient pushes into it is active, and so is a p2 corner among
such mid-side nodes whose patch pushes (its own pull then counts in the force: docs/theory.md, 'Contact of
quadratic surfaces'); the dofs of every node
lying on an obstacle are turned into its local frame (normal n, two tangents) and an active node's normal dof is
held (the linearised gap), its tangent dofs free. The Newton matrix is the Hessian of the Lagrangian: the
stiffness minus lambda_i / |x_i - c| on the two tangent dofs of each active node on the sphere (the constraint's
curvature). The line search projects every trial point back onto the feasible set (clip to the dish, radial
projection out of the ball) and accepts on the energy (Armijo). The force on the sphere is
sum lambda_i (-n_z,i) over its active nodes, lambda_i = g_i . n_i the multipliers (g the energy gradient), exact at
convergence; no penalty.

Rigid modes: the dish and a frictionless sphere on the axis leave x, y translation and rotations free or
unstable (the cell would slide off the bead); the dofs of :func:`elastocell.scenarios.compression.rigid_mode_pins`
are held as in compression, and ``max_rigid_reaction`` reports their largest reaction over the sphere's force,
so that a force the pins add (a random cell that would tilt) is visible.

The linear algebra is compression's: the stiffness pattern, PARDISO's Cholesky factorisation (mixed precision)
with the Levenberg-Marquardt shift ladder when the free-dof matrix is not positive definite.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from elastocell.body.cell import Cell
from elastocell.body.mesh import corners_surrounded, surface_corner_edges
from elastocell.scenarios.axisymmetric import AxisymmetricError, AxisymmetricInterrupted
from elastocell.scenarios.compression import (
    MAX_NODE_STEP,
    MAX_SHIFT,
    MIN_SHIFT,
    PLACE_DISTANCE,
    RETRY_SHIFT,
    min_volume_ratio,
    rigid_mode_pins,
    stagnated,
)
from elastocell.solvers.sparse import NotPositiveDefinite, SparseSolver

GAP_TOLERANCE = 1e-12
"""A node whose gap to an obstacle is below this (units of R) lies on it (projection puts it at gap 0 to
round-off)."""
FORCE_FLOOR = 1e-7
"""Smallest force scale (E_c R^2) of the convergence test, before the contacts carry any force."""
DEFAULT_TOLERANCE = 1e-8
"""Largest unbalanced nodal force over the sphere's force at convergence."""
DISH = -1.0
DEBUG = bool(os.environ.get('ELASTOCELL_DEBUG'))


class Indentation3DError(AxisymmetricError):
    """The load stepping could not reach the requested depth; ``partial`` holds the converged rows (the
    exception of the axisymmetric curve, so that a caller handles both paths alike)."""


class Indentation3DInterrupted(AxisymmetricInterrupted, Indentation3DError):
    """The curve was interrupted (Ctrl-C, SIGTERM); ``partial`` holds every converged row, from which
    :func:`indent_3d` can continue (``resume_from=``)."""


@dataclass
class Indentation3DResult:
    """A force curve of the 3D solver (lengths in R, forces in E_c R^2), with the fields of
    :class:`~elastocell.scenarios.axisymmetric.AxisymmetricResult`.

    load: depth, starting at 0. force: on the sphere; force_support: on the dish. contact_radius: the largest
    distance from the z axis of the active nodes on the sphere. positions: (n_rows, n_nodes, 3).
    max_rigid_reaction: per row, the largest pin reaction over the sphere's force.
    """

    load: np.ndarray
    force: np.ndarray
    force_support: np.ndarray
    contact_radius: np.ndarray
    min_volume_ratio: np.ndarray
    max_rigid_reaction: np.ndarray
    positions: np.ndarray
    newton_iterations: int
    substeps: int
    n_nodes: int
    wall_time: float
    history: list = field(default_factory=list)

    @property
    def delta(self) -> np.ndarray:
        return self.load


@dataclass
class _Contact:
    """Per candidate (surface) node: the obstacle it lies on (-1 none, 0 dish, 1 sphere), its normal and
    multiplier, whether it is active; per node its rotation (columns n, t1, t2; identity off the obstacles) and
    the held local dofs."""

    obstacle: np.ndarray
    normals: np.ndarray
    multipliers: np.ndarray
    active: np.ndarray
    rotations: np.ndarray
    rotated: np.ndarray  # nodes whose frame is not the identity
    held: np.ndarray


def _frames(normals: np.ndarray) -> np.ndarray:
    """(m, 3, 3) rotations whose columns are n, t1, t2 (a right-handed orthonormal frame)."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    first = helper - np.einsum("ij,ij->i", helper, normals)[:, None] * normals
    first /= np.linalg.norm(first, axis=1)[:, None]
    return np.stack([normals, first, np.cross(normals, first)], axis=2)


class _Problem:
    def __init__(self, cell: Cell, indenter_radius: float, solver: SparseSolver):
        self.cell = cell
        self.radius = indenter_radius
        self.solver = solver
        self.candidates = cell.mesh.surface_nodes
        self.n_nodes = cell.mesh.n_nodes
        self.pins = rigid_mode_pins(cell.mesh.nodes)
        self.pattern = cell.stiffness_pattern
        self.noise = 1e-13 * float(np.sum(cell.element_volumes * cell.youngs_moduli))
        self.start = 1.0 + indenter_radius  # the sphere's centre at depth 0: touching the pole z = 1
        self.level = self.start
        corners, edge_nodes = surface_corner_edges(cell.mesh.elements)
        position = np.full(self.n_nodes, -1)
        position[self.candidates] = np.arange(len(self.candidates))
        assert (position[corners] >= 0).all() and (position[edge_nodes] >= 0).all()  # surface nodes, all of them
        self.corners, self.edge_nodes = position[corners], position[edge_nodes]  # as positions among the candidates

    def set_depth(self, depth: float) -> None:
        self.level = self.start - depth

    def gaps_and_normals(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(dish gap, sphere gap, sphere normal) of points ``x`` (m, 3); the dish normal is +z."""
        offset = x - np.array([0.0, 0.0, self.level])
        distance = np.linalg.norm(offset, axis=1)
        return x[:, 2] - DISH, distance - self.radius, offset / np.maximum(distance, 1e-300)[:, None], distance

    def project(self, x: np.ndarray) -> np.ndarray:
        """The nearest feasible positions: surface nodes clipped to the dish and pushed radially out of the ball."""
        x = x.copy()
        points = x[self.candidates]
        points[:, 2] = np.maximum(points[:, 2], DISH)
        _, gap, normal, _ = self.gaps_and_normals(points)
        inside = gap < 0
        points[inside] = np.array([0.0, 0.0, self.level]) + self.radius * normal[inside]
        x[self.candidates] = points
        return x

    def retract(self, x: np.ndarray, contact: _Contact) -> np.ndarray:
        """``x`` with the nodes active on the sphere at the iterate of ``contact`` put back on it radially: a
        step held in their tangent planes leaves the sphere by t^2 / (2 R_b), which would release them at the next
        iterate and make the active set alternate."""
        nodes = self.candidates[contact.active & (contact.obstacle == 1)]
        if not len(nodes):
            return x
        x = x.copy()
        offset = x[nodes] - np.array([0.0, 0.0, self.level])
        x[nodes] = np.array([0.0, 0.0, self.level]) + self.radius * offset / np.linalg.norm(offset, axis=1)[:, None]
        return x

    def surrounded(self, pressed: np.ndarray, multipliers: np.ndarray) -> np.ndarray:
        """Per candidate: a p2 surface corner every one of whose surface edges has its mid-side node ``pressed``
        and whose multiplier with half of each of theirs pushes. A 6-node triangle's corner takes no share of a
        uniform pressure, so that its own multiplier follows the pressure's curvature and, released for that,
        it lifts into a dimple (docs/theory.md, 'Contact of quadratic surfaces')."""
        if not len(self.corners):
            return np.zeros(len(pressed), dtype=bool)
        patch = multipliers + np.bincount(self.corners, weights=0.5 * multipliers[self.edge_nodes],
                                          minlength=len(multipliers))
        return corners_surrounded(pressed, self.corners, self.edge_nodes) & (patch > 0)

    def place_surrounded(self, x: np.ndarray, contact: _Contact) -> tuple[np.ndarray, np.ndarray, _Contact] | None:
        """(x, its gradient, its contact) with the surrounded corners (:meth:`surrounded`) that lie off their
        obstacle by at most :data:`~elastocell.scenarios.compression.PLACE_DISTANCE` placed on it (a dimple
        closed), keeping only those the new state holds (as compression's ``_place_surrounded``); None when none
        is placed."""
        if not len(self.corners):
            return None
        points = x[self.candidates]
        dish, sphere, normal, _ = self.gaps_and_normals(points)
        placed = x.copy()
        moved = np.zeros(len(self.candidates), dtype=bool)
        for k, gap in ((0, dish), (1, sphere)):
            pressed = contact.active & (contact.obstacle == k)
            off = self.surrounded(pressed, contact.multipliers) & (gap > GAP_TOLERANCE) & (gap <= PLACE_DISTANCE)
            off &= contact.obstacle < 0
            placed[self.candidates[off]] -= gap[off, None] * (normal[off] if k == 1 else np.array([0.0, 0.0, 1.0]))
            moved |= off
        if not moved.any():
            return None
        gradient = self.cell.internal_forces(placed)
        placed_contact = self.contact(placed, gradient)
        released = moved & ~placed_contact.active
        if not (moved & ~released).any():
            return None
        if released.any():
            placed[self.candidates[released]] = x[self.candidates[released]]
            gradient = self.cell.internal_forces(placed)
            placed_contact = self.contact(placed, gradient)
        return placed, gradient, placed_contact

    def violated(self, x: np.ndarray) -> bool:
        """True when any node (interior ones included) lies inside an obstacle: a folded element."""
        dish, sphere, _, _ = self.gaps_and_normals(x)
        return bool((dish < -1e-9).any() or (sphere < -1e-9).any())

    def contact(self, x: np.ndarray, gradient: np.ndarray) -> _Contact:
        points = x[self.candidates]
        dish, sphere, sphere_normal, _ = self.gaps_and_normals(points)
        obstacle = np.full(len(points), -1)
        obstacle[dish <= GAP_TOLERANCE] = 0
        obstacle[(sphere <= GAP_TOLERANCE) & (sphere < dish)] = 1
        normals = np.zeros_like(points)
        normals[obstacle == 0] = (0.0, 0.0, 1.0)
        normals[obstacle == 1] = sphere_normal[obstacle == 1]
        multipliers = np.where(obstacle >= 0, np.einsum("ij,ij->i", gradient[self.candidates], normals), 0.0)
        active = (obstacle >= 0) & (multipliers > 0)
        for k in (0, 1):  # a p2 corner among pressed mid-side nodes whose patch pushes (compression._surrounded)
            active |= (obstacle == k) & self.surrounded(active & (obstacle == k), multipliers)
        rotations = np.broadcast_to(np.eye(3), (self.n_nodes, 3, 3)).copy()
        on = obstacle >= 0
        rotated = self.candidates[on]
        rotations[rotated] = _frames(normals[on])
        held = np.zeros(3 * self.n_nodes, dtype=bool)
        held[self.pins] = True
        held[3 * self.candidates[active]] = True  # the normal dof, local 0
        return _Contact(obstacle, normals, multipliers, active, rotations, rotated, held)

    @staticmethod
    def local(vector: np.ndarray, contact: _Contact) -> np.ndarray:
        """Q^T v per node, flattened."""
        return np.einsum("nic,ni->nc", contact.rotations, vector.reshape(-1, 3)).ravel()

    @staticmethod
    def glob(vector: np.ndarray, contact: _Contact) -> np.ndarray:
        """Q y per node, (n_nodes, 3)."""
        return np.einsum("nic,nc->ni", contact.rotations, vector.reshape(-1, 3))

    def stiffness(self, x: np.ndarray, contact: _Contact):
        """Upper triangle of the Hessian of the Lagrangian in the nodes' local frames (only the elements with a
        rotated node are rotated)."""
        elements = self.cell.mesh.elements
        k = elements.shape[1]
        matrices = self.cell.element_stiffness(x)
        touched = np.zeros(self.n_nodes, dtype=bool)
        touched[contact.rotated] = True
        some = np.flatnonzero(touched[elements].any(axis=1))
        if len(some):
            q = contact.rotations[elements[some]]  # (e, k, 3, 3)
            block = matrices[some].reshape(-1, k, 3, k, 3)
            matrices = matrices.copy() if not matrices.flags.writeable else matrices
            matrices[some] = np.einsum("eaic,eaibj,ebjd->eacbd", q, block, q, optimize=True).reshape(-1, 3 * k, 3 * k)
        upper = self.pattern.assemble_upper(matrices)
        on = contact.active & (contact.obstacle == 1)
        nodes = self.candidates[on]
        distance = np.linalg.norm(x[nodes] - np.array([0.0, 0.0, self.level]), axis=1)
        curvature = contact.multipliers[on] / distance
        for tangent in (1, 2):
            upper.data[self.pattern.upper_diagonal[3 * nodes + tangent]] -= curvature
        return upper

    def factorised_direction(self, upper, held: np.ndarray, rhs: np.ndarray, shift: float):
        """(direction, shift): the solution of the held-dof system with the smallest Levenberg-Marquardt shift
        (relative to the mean diagonal) whose factorisation is positive definite and whose step descends."""
        while shift <= MAX_SHIFT:
            system = self.pattern.constrained_upper(upper, held, shift)
            try:
                not_definite = self.solver.factorize(system)
            except Exception:  # noqa: BLE001 - a failed factorisation: shift more
                not_definite = True
            if not not_definite:
                try:
                    direction = self.solver.solve(rhs)
                except NotPositiveDefinite:
                    direction = None
                if direction is not None and np.all(np.isfinite(direction)) and rhs @ direction > 0:
                    return direction, shift
            shift = max(shift * 100, RETRY_SHIFT)
        return None, shift

    def forces(self, x: np.ndarray) -> tuple[float, float, float, float]:
        """(force on the sphere, on the dish, contact radius on the sphere, largest pin reaction)."""
        gradient = self.cell.internal_forces(x)
        contact = self.contact(x, gradient)
        sphere = contact.active & (contact.obstacle == 1)
        dish = contact.active & (contact.obstacle == 0)
        force = float(np.sum(contact.multipliers[sphere] * -contact.normals[sphere, 2]))
        support = float(contact.multipliers[dish].sum())
        radius = float(np.hypot(*x[self.candidates[sphere], :2].T).max()) if sphere.any() else 0.0
        return force, support, radius, float(np.abs(gradient.ravel()[self.pins]).max())


def _newton(problem: _Problem, x: np.ndarray, tolerance: float, max_iterations: int):
    """Projected Newton with an active set from ``x`` (feasible) at the current sphere position. Returns
    (x, iterations, converged, reason)."""
    cell = problem.cell
    energy = cell.energy(x)
    if not np.isfinite(energy):
        return x, 0, False, "inverted element in the predictor"
    shift = MIN_SHIFT
    residuals: list[float] = []
    for iteration in range(1, max_iterations + 1):
        gradient = cell.internal_forces(x)
        contact = problem.contact(x, gradient)
        placement = problem.place_surrounded(x, contact)
        if placement is not None and np.isfinite(placed_energy := cell.energy(placement[0])):
            (x, gradient, contact), energy = placement, placed_energy
        local_gradient = problem.local(gradient, contact)
        residual = float(np.abs(local_gradient[~contact.held]).max())
        force = max(float(contact.multipliers[contact.active].sum()) / 2, 0.0)
        residuals.append(residual / max(force, 1e-300))
        if DEBUG:
            print(f"  it {iteration} residual {residual:.3e} force {force:.4e} active {contact.active.sum()} "
                  f"on {(contact.obstacle >= 0).sum()} energy {energy:.12e}")
        if residual < tolerance * max(force, FORCE_FLOOR) or stagnated(residuals):
            if problem.violated(x):
                return x, iteration - 1, False, "a node lies inside an obstacle (a folded element)"
            return x, iteration - 1, True, ""
        upper = problem.stiffness(x, contact)
        held = contact.held.copy()
        shift = max(MIN_SHIFT, shift * 1e-2)
        direction = None
        for _ in range(6):
            rhs = np.where(held, 0.0, -local_gradient)
            direction, shift = problem.factorised_direction(upper, held, rhs, shift)
            if direction is None:
                return x, iteration, False, "no descent direction"
            # a free node lying on an obstacle (tensile multiplier) that the step pushes into it: hold it too
            into = direction.reshape(-1, 3)[problem.candidates, 0] < 0
            blocked = (contact.obstacle >= 0) & ~contact.active & into
            dofs = 3 * problem.candidates[blocked]
            if not blocked.any() or held[dofs].all():
                break
            held[dofs] = True
        step_vector = problem.glob(direction, contact)
        largest = np.abs(step_vector).max()
        if largest > MAX_NODE_STEP:
            step_vector *= MAX_NODE_STEP / largest
        step, accepted = 1.0, False
        for _ in range(40):
            trial = problem.retract(problem.project(x + step * step_vector), contact)
            trial_energy = cell.energy(trial)
            if np.isfinite(trial_energy) and trial_energy <= energy + 1e-4 * np.sum(gradient * (trial - x)) + problem.noise:
                accepted = True
                break
            step *= 0.5
        if not accepted:
            return x, iteration, False, "line search failed (an element would invert)"
        x, energy = trial, trial_energy
    return x, max_iterations, False, f"no convergence in {max_iterations} iterations"


def _predictor(problem: _Problem, x: np.ndarray, increment: float) -> np.ndarray:
    """Linearised response to lowering the sphere by ``increment`` with the current active set held: an active
    node on the sphere follows it along its normal (n . dx = -n_z increment), on the dish it stays, the others from
    K_ff du_f = -K_fc du_c."""
    gradient = problem.cell.internal_forces(x)
    contact = problem.contact(x, gradient)
    if not contact.active.any():
        return x
    on = contact.active & (contact.obstacle == 1)
    prescribed = np.zeros(3 * problem.n_nodes)
    prescribed[3 * problem.candidates[on]] = -contact.normals[on, 2] * increment
    upper = problem.stiffness(x, contact)
    rhs = -problem.pattern.symmetric_product(upper, prescribed)
    rhs[contact.held] = 0.0
    try:
        if problem.solver.factorize(problem.pattern.constrained_upper(upper, contact.held, MIN_SHIFT)):
            return x + problem.glob(prescribed, contact)
        solution = problem.solver.solve(rhs)
    except Exception:  # noqa: BLE001 - an indefinite or failed system: move the contacts only
        return x + problem.glob(prescribed, contact)
    return x + problem.glob(solution + prescribed, contact)


RESULT_ROWS = {"load": "load", "force": "force", "support": "force_support", "radius": "contact_radius",
               "volume": "min_volume_ratio", "reaction": "max_rigid_reaction", "positions": "positions"}
"""The per-row lists of :func:`indent_3d` and the :class:`Indentation3DResult` arrays they become."""


def _result(rows: dict, iterations: int, substeps: int, cell: Cell, start_time: float,
            history: list) -> Indentation3DResult:
    return Indentation3DResult(
        **{attribute: np.array(rows[name]) for name, attribute in RESULT_ROWS.items()},
        newton_iterations=iterations, substeps=substeps, n_nodes=cell.mesh.n_nodes,
        wall_time=time.perf_counter() - start_time, history=history)


def indent_3d(cell: Cell, indenter_radius: float, depth_max: float, steps: int = 20,
              tolerance: float = DEFAULT_TOLERANCE, max_newton_iterations: int = 40, solver: str = "auto",
              precision: str = "mixed", resume_from: Indentation3DResult | None = None,
              on_row: Callable[[Indentation3DResult], None] | None = None) -> Indentation3DResult:
    """F(depth) of a rigid frictionless sphere of radius ``indenter_radius`` (units of R) pressed on the z axis
    into the 3D ``cell`` resting on a rigid frictionless dish at z = -1, ``steps`` equal depth increments up to
    ``depth_max`` (units of R, below 1); the force F/(E_c R^2). ``solver``/``precision``: the sparse solver
    (:class:`elastocell.solvers.sparse.SparseSolver`). ``resume_from``: the rows of an interrupted curve of the
    same cell and loading, continued from its last row; ``on_row(result)`` after every converged row; an
    interruption (KeyboardInterrupt) raises :class:`Indentation3DInterrupted` with the converged rows, a failed
    step :class:`Indentation3DError` with them. OpenBLAS runs on one thread meanwhile (as in
    :func:`elastocell.scenarios.compression.compress`)."""
    from threadpoolctl import ThreadpoolController

    with ThreadpoolController().select(internal_api="openblas").limit(limits=1):
        return _curve(cell, indenter_radius, depth_max, steps, tolerance, max_newton_iterations, solver, precision,
                      resume_from, on_row)


def _curve(cell: Cell, indenter_radius: float, depth_max: float, steps: int, tolerance: float,
           max_iterations: int, solver: str, precision: str, resume_from: Indentation3DResult | None,
           on_row: Callable[[Indentation3DResult], None] | None) -> Indentation3DResult:
    start_time = time.perf_counter()
    linear_solver = SparseSolver(solver, precision)
    problem = _Problem(cell, indenter_radius, linear_solver)
    x = cell.mesh.nodes.copy()
    rows = {"load": [0.0], "force": [0.0], "support": [0.0], "radius": [0.0], "volume": [1.0], "reaction": [0.0],
            "positions": [x.copy()]}
    iterations_total, substeps, history = 0, 0, []
    depth = 0.0
    if resume_from is not None:
        if resume_from.positions.shape[1:] != x.shape:
            raise ValueError(f"the curve to continue has {resume_from.positions.shape[1]} nodes, the cell {len(x)}")
        rows = {name: list(getattr(resume_from, attribute)) for name, attribute in RESULT_ROWS.items()}
        iterations_total, substeps, history = resume_from.newton_iterations, resume_from.substeps, list(resume_from.history)
        x, depth = resume_from.positions[-1].copy(), float(resume_from.load[-1])
        problem.set_depth(depth)
        start_time -= resume_from.wall_time
    try:
        for target in np.linspace(0.0, depth_max, steps + 1)[1:]:
            if target <= depth + 1e-12:  # reached before the interruption this curve continues
                continue
            increment = target - depth
            while depth < target - 1e-14:
                trial = min(target, depth + increment)
                if depth == 0.0:  # first contact: squeeze the cell affinely between the dish and the sphere
                    guess = x.copy()
                    guess[:, 2] = DISH + (guess[:, 2] - DISH) * (1.0 - trial / 2.0)
                else:
                    guess = _predictor(problem, x, trial - depth)
                problem.set_depth(trial)
                guess = problem.project(guess)
                solution, iterations, converged, reason = _newton(problem, guess, tolerance, max_iterations)
                iterations_total += iterations
                history.append((trial, iterations, reason))
                if not converged:
                    problem.set_depth(depth)
                    increment /= 2
                    substeps += 1
                    if increment < 1e-7:
                        raise Indentation3DError(f"stopped at depth {depth:.5f} (target {trial:.5f}): {reason}",
                                                 _result(rows, iterations_total, substeps, cell, start_time, history))
                    continue
                x, depth = solution, trial
            force, support, radius, reaction = problem.forces(x)
            rows["load"].append(depth)
            rows["force"].append(force)
            rows["support"].append(support)
            rows["radius"].append(radius)
            rows["volume"].append(min_volume_ratio(cell, x))
            rows["reaction"].append(reaction / max(force, 1e-300))
            rows["positions"].append(x.copy())
            if on_row is not None:
                on_row(_result(rows, iterations_total, substeps, cell, start_time, history))
    except KeyboardInterrupt:  # the step in progress is lost, every converged row is kept
        result = _result(rows, iterations_total, substeps, cell, start_time, history)
        raise Indentation3DInterrupted(f"interrupted at depth {depth:.4f} ({len(rows['load'])} rows converged)",
                                       result) from None
    finally:
        linear_solver.close()
    return _result(rows, iterations_total, substeps, cell, start_time, history)
