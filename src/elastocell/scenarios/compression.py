"""Quasistatic compression of a cell between two rigid, frictionless, parallel plates (AFM-like).

Geometry (units of R): the lower plate rests at z = -1, the upper plate at z = 1 - 2 delta, so that
``delta = 1 - h/(2R)`` with h the gap. Every point of the curve is a static equilibrium: the elastic energy is
minimised subject to the unilateral constraints ``-1 <= z_i <= 1 - 2 delta`` on every surface node (exact
frictionless node-to-plate contact: the plates push only along z, tangential motion is free). This is a
bound-constrained minimisation, solved by a projected Newton method (Bertsekas 1982): the active set is the
set of surface nodes on a plate whose force pushes into it, and of p2 surface corners among such nodes whose patch
pushes (a 6-node triangle's corner takes no share of a uniform pressure; see :func:`_surrounded`), Newton steps on the rest with the sparse
stiffness, a projected Armijo line search on the energy. The contact force on a plate is the sum of the
Lagrange multipliers, i.e. the internal forces of its active nodes, so ``F`` is exact at convergence.

The frictionless plates leave x- and y-translation and rotation about z free, and for a cell symmetric about
its centre (homogeneous, centred nucleus) rotating the *material* about any axis through the centre keeps the
shape and the energy: three more (near-)null modes along which Newton drifts and the discrete answer wanders
with the faceting. All are held: x, y of the node nearest the centre, x, y of a node on the z axis, y of a node
on the x axis. Translations cost no force at equilibrium (internal forces sum to zero and the plates push
only along z); the rotations cost none where the continuum problem is neutral or symmetric. The solver
reports the largest pin reaction relative to the plate force (``max_rigid_reaction``) so that any force
the pins add — e.g. a random cell that would tilt — is visible.

Load steps: ``steps`` equal increments of delta (each an output row); a step whose Newton iteration fails is
subdivided; the predictor is the linearised response to the plate increment with the current contact set. An element that would invert makes the energy
undefined and the line search backs off; if no step size is left, :class:`CompressionError` says where.
"""


from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pydantic import model_validator

from elastocell.body.cell import Cell
from elastocell.body.elements import (
    DEFAULT_QUADRATURE_DEGREE,
    jacobian_determinants,
    nodal_jacobians,
    quadrature_rule,
)
from elastocell.body.mesh import corners_surrounded, surface_corner_edges
from elastocell.parameters.cell import CellParameters, MeshParameters, ParameterModel, require
from elastocell.parameters.units import ParameterError
from elastocell.solvers.sparse import NotPositiveDefinite, SparseSolver

DEBUG = bool(os.environ.get('ELASTOCELL_DEBUG'))
MIN_SHIFT, MAX_SHIFT = 1e-10, 1e3  # Levenberg-Marquardt diagonal shift relative to the mean diagonal
RETRY_SHIFT = 1e-3
"""Smallest shift tried after a failed factorisation. A shift is needed mostly at the first iteration of a load
step (the stiffness at the predicted state has a negative eigenvalue of about -1e-6 to -4e-5 of the mean diagonal,
a global mode spread over some 3,000 of the 4,656 nodes), and there 1e-4 to 1 (measured on the reference cell's
default curve: 19 of 20 such iterations); each rung of the x100 ladder below 1e-4 was a failed factorisation (72
of 383). Retrying at 1e-3 instead of 1e-4 on the same curve: 256 instead of 277 factorisations and 213 instead
of 221 Newton iterations (1e-5: 267 and 208), F equal to 2e-8."""
FORCE_FLOOR = 1e-4  # smallest force scale of the convergence test (E_c R^2; Hertz's plate force near delta = 0.0015)
MAX_NODE_STEP = 0.05  # largest nodal move of one Newton iteration (units of R)


class CompressionError(RuntimeError):
    """The load stepping could not reach the requested deformation; ``partial`` holds the converged rows."""

    def __init__(self, message: str, partial: CompressionResult | None = None):
        super().__init__(message)
        self.partial = partial


class CompressionInterrupted(CompressionError):
    """The curve was interrupted (Ctrl-C, SIGTERM) between or during load steps; ``partial`` holds every row
    converged before, from which :func:`compress` can continue (``resume_from=``)."""


@dataclass
class CompressionResult:
    """A force-deformation curve (dimensionless: lengths in R, forces in E_c R^2).

    delta: deformation of each converged equilibrium, starting at 0.
    force: F/(E_c R^2), the normal force on the upper plate.
    force_lower: the normal force on the lower plate (equal and opposite at equilibrium).
    positions: nodal positions at each row, (n_rows, n_nodes, 3).
    """

    delta: np.ndarray
    force: np.ndarray
    force_lower: np.ndarray
    positions: np.ndarray
    contact_nodes_upper: np.ndarray
    unstable: np.ndarray  # per row: the equilibrium is a saddle of the discrete energy (see ``is_saddle``)
    min_nodal_jacobian: np.ndarray  # per row: see :func:`min_nodal_jacobian`; <= 0 means a folded element
    min_volume_ratio: np.ndarray  # per row: smallest J = det F at a quadrature point, see :func:`min_volume_ratio`
    newton_iterations: int
    factorisations: int
    analyses: int
    substeps: int
    max_rigid_reaction: float  # largest pin reaction over the plate force of the same row
    wall_time: float
    solver: str
    precision: str = "double"  # of the factorisations (``mixed``: single precision, solves refined in double)
    refinements: int = 0  # iterative-refinement steps of the mixed-precision solves
    history: list = field(default_factory=list)


@dataclass
class _Factorised:
    """The system the linear solver has factorised: its held dofs, Levenberg-Marquardt shift and (upper)
    stiffness. Later solves with the same held dofs may reuse it instead of factorising again."""

    held: np.ndarray
    shift: float
    stiffness: object


@dataclass
class _Problem:
    cell: Cell
    surface_z: np.ndarray  # z dof indices of surface nodes
    pinned: np.ndarray  # dof indices held to remove rigid modes
    lower: np.ndarray
    upper: np.ndarray
    corners: np.ndarray  # surface corner nodes, one per end of a surface edge (``mesh.surface_corner_edges``)
    edge_nodes: np.ndarray  # the mid-side node of that edge
    factorised: _Factorised | None = None  # what the linear solver holds now

    def set_delta(self, delta: float) -> None:
        self.upper[self.surface_z] = 1.0 - 2.0 * delta

    def project(self, x: np.ndarray) -> np.ndarray:
        return np.clip(x, self.lower, self.upper)


def rigid_mode_pins(nodes: np.ndarray) -> np.ndarray:
    """Dofs held to remove the modes the plates leave free: x, y of the node nearest the centre
    (translation), x, y of a node on the z axis (rotation about x and y), y of a node on the x axis
    (rotation about z)."""

    def nearest(target, exclude):
        distance = np.linalg.norm(nodes - np.asarray(target), axis=1)
        distance[list(exclude)] = np.inf
        return int(np.argmin(distance))

    centre = nearest((0.0, 0.0, 0.0), [])
    on_z = nearest((0.0, 0.0, 0.5), [centre])
    on_x = nearest((0.5, 0.0, 0.0), [centre, on_z])
    return np.array([3 * centre, 3 * centre + 1, 3 * on_z, 3 * on_z + 1, 3 * on_x + 1])


def _setup(cell: Cell) -> _Problem:
    nodes = cell.mesh.nodes
    n_dof = 3 * len(nodes)
    surface_z = 3 * cell.mesh.surface_nodes + 2
    lower = np.full(n_dof, -np.inf)
    upper = np.full(n_dof, np.inf)
    lower[surface_z] = -1.0
    upper[surface_z] = 1.0
    corners, edge_nodes = surface_corner_edges(cell.mesh.elements)
    return _Problem(cell, surface_z, rigid_mode_pins(nodes), lower, upper, corners, edge_nodes)


def _surrounded(problem: _Problem, x: np.ndarray, gradient: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper): per dof, True at the z dof of a surface corner node (p2) every one of whose surface edges
    has its mid-side node on that plate, pushed by it, and whose own force with half its neighbours' pushes (the
    patch it shares with them) pushes too. Such a corner is in contact whatever the sign of its own force: a 6-node triangle's corner takes no share of a uniform pressure, so that its force follows the
    pressure's curvature, and a corner released for that lifts into a dimple (measured on the default mesh with a
    stiff nucleus: some 40 % of the corners inside the contact, gaps to 5e-3 R), the same fault the axisymmetric
    solver's pole rule mends (docs/theory.md, 'Contact of quadratic surfaces')."""
    lower = np.zeros(x.size, dtype=bool)
    upper = np.zeros(x.size, dtype=bool)
    if not len(problem.corners):
        return lower, upper
    pressed_lower = (x <= problem.lower) & (gradient > 0)
    pressed_upper = (x >= problem.upper) & (gradient < 0)
    # the corner's force with half of each of its mid-side neighbours' (the patch it shares) must push
    force = gradient[2::3]
    patch = force + np.bincount(problem.corners, weights=0.5 * force[problem.edge_nodes], minlength=len(force))
    lower[2::3] = corners_surrounded(pressed_lower[2::3], problem.corners, problem.edge_nodes) & (patch > 0)
    upper[2::3] = corners_surrounded(pressed_upper[2::3], problem.corners, problem.edge_nodes) & (patch < 0)
    return lower, upper


def _in_contact(problem: _Problem, x: np.ndarray, gradient: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper): per dof, True where a node lies on that plate and is in contact with it: pushed by it, or
    a surface corner among pushed mid-side nodes (:func:`_surrounded`)."""
    surrounded_lower, surrounded_upper = _surrounded(problem, x, gradient)
    at_lower = x <= problem.lower
    at_upper = x >= problem.upper
    return at_lower & ((gradient > 0) | surrounded_lower), at_upper & ((gradient < 0) | surrounded_upper)


PLACE_DISTANCE = 0.02
"""Farthest a surrounded corner is placed onto its plate from (units of R): four times the deepest dimple measured
(5e-3 R, stiffness ratio 20 on the default mesh); a corner farther off among touching mid-side nodes belongs to a
distorted element, which the Newton step is left to settle."""


def _place_surrounded(problem: _Problem, x: np.ndarray, gradient: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(x, its gradient) with every surrounded corner (:func:`_surrounded`) not yet on its plate but within
    :data:`PLACE_DISTANCE` of it placed on it (a dimple closed), keeping only the corners the new state still holds
    (a corner whose own pull, once placed, turns its patch's force would be released and lift again); None when
    none is placed."""
    lower, upper = _surrounded(problem, x, gradient)
    lower &= (x > problem.lower) & (x - problem.lower <= PLACE_DISTANCE)
    upper &= (x < problem.upper) & (problem.upper - x <= PLACE_DISTANCE)
    if not (lower.any() or upper.any()):
        return None
    placed = x.copy()
    placed[lower] = problem.lower[lower]
    placed[upper] = problem.upper[upper]
    forces = problem.cell.internal_forces(placed.reshape(-1, 3)).ravel()
    held_lower, held_upper = _surrounded(problem, placed, forces)
    released = (lower & ~held_lower) | (upper & ~held_upper)
    if not ((lower | upper) & ~released).any():
        return None
    if released.any():
        placed[released] = x[released]
        forces = problem.cell.internal_forces(placed.reshape(-1, 3)).ravel()
    return placed, forces


def _active_set(problem: _Problem, x: np.ndarray, gradient: np.ndarray, pinned: np.ndarray):
    """(active dofs, at_lower, at_upper, largest free force, plate force): a dof is active when pinned or in contact
    with a plate (:func:`_in_contact`); the plate force is the mean of the two plates' (signed: a held corner's
    pull counts against the pushes)."""
    at_lower = x <= problem.lower
    at_upper = x >= problem.upper
    contact_lower, contact_upper = _in_contact(problem, x, gradient)
    active = contact_lower | contact_upper | pinned
    residual = float(np.abs(gradient[~active]).max())
    plate_force = float(gradient[contact_lower].sum() - gradient[contact_upper].sum()) / 2
    return active, at_lower, at_upper, residual, plate_force


FOLDED = ("the mesh folded: a node lies beyond a plate although every surface node is within them (curved "
          "elements too distorted in a thin layer)")


def _folded(problem: _Problem, x: np.ndarray) -> bool:
    """True when any node lies outside the slab between the plates. Only surface nodes are bounded by the
    contact; an interior node outside the slab means the map from the reference cell is no longer one-to-one
    (a quadratic element folded with det F > 0 at its quadrature points), an equilibrium of the discrete energy
    that no body can reach."""
    z = x[2::3]
    slack = 1e-9
    return bool((z > problem.upper[problem.surface_z[0]] + slack).any() or (z < -1.0 - slack).any())


STAGNATION_TOLERANCE = 1e-7
"""Relative unbalanced force below which a Newton solve that stops making progress counts as converged."""
STAGNATION_WINDOW = 3
"""Iterations over which the residual must fall by half to count as progress."""


def stagnated(residuals: list[float]) -> bool:
    """True when the relative unbalanced forces of successive Newton iterates have reached a plateau below
    :data:`STAGNATION_TOLERANCE`: the last one did not halve over :data:`STAGNATION_WINDOW` iterations."""
    return (len(residuals) > STAGNATION_WINDOW and residuals[-1] < STAGNATION_TOLERANCE
            and residuals[-1] > 0.5 * residuals[-1 - STAGNATION_WINDOW])


def _descends(rhs: np.ndarray, direction: np.ndarray) -> bool:
    return bool(np.all(np.isfinite(direction))
                and rhs @ direction > 1e-8 * np.linalg.norm(rhs) * np.linalg.norm(direction))


def _into_plate(direction: np.ndarray, at_lower, at_upper, active) -> np.ndarray:
    """Free dofs on a plate that ``direction`` pushes into it."""
    return ((at_lower & (direction < 0)) | (at_upper & (direction > 0))) & ~active


def _newton_direction(problem: _Problem, x: np.ndarray, gradient: np.ndarray, solver: SparseSolver, pattern,
                      active: np.ndarray, at_lower, at_upper, shift: float):
    """(direction, shift) of a full Newton iteration with the stiffness at ``x``; direction None when no
    shift gives a descent direction.

    Levenberg-Marquardt safeguard: where the stiffness restricted to the free dofs is indefinite (far from
    equilibrium, or a faceted surface touching a plate at one node), its diagonal is shifted until the
    factorisation (Cholesky) succeeds (or, with SuperLU, which cannot tell, until the step descends)."""
    cell = problem.cell
    problem.factorised = None
    stiffness = pattern.assemble_upper(cell.element_stiffness(x.reshape(-1, 3)))
    rhs = np.where(active, 0.0, -gradient)
    direction, shift = _shifted_newton_direction(solver, stiffness, pattern, active, rhs, shift)
    if direction is None:
        return None, shift
    problem.factorised = _Factorised(active.copy(), shift, stiffness)
    # A node on a plate with a tensile force is free, but the coupled Newton step may still push it into the
    # plate; the projection would then clip it at every iteration and stall the solver. Hold such nodes for
    # this iteration: the factorisation already made gives the step with them held (Schur complement).
    held = active
    for _ in range(4):
        blocked = _into_plate(direction, at_lower, at_upper, held)
        if not blocked.any():
            break
        held = held | blocked
        direction = _held_direction(solver, direction, held & ~active)
        if direction is None or not _descends(np.where(held, 0.0, -gradient), direction):
            # fall back to factorising the system with the blocked dofs held
            rhs = np.where(held, 0.0, -gradient)
            direction, shift = _shifted_newton_direction(solver, stiffness, pattern, held, rhs, shift)
            problem.factorised = None if direction is None else _Factorised(held.copy(), shift, stiffness)
            if direction is None:
                return None, shift
            active = held
    return direction, shift


MAX_SCHUR_DOFS = 16
"""Most dofs held through the Schur complement of a factorised system before factorising a new one: one solve
costs about 5 ms against 80-100 ms for a factorisation (13,968 dofs, PARDISO without iterative refinement), and a
block of 16 right-hand sides about 23 ms."""


def _held_direction(solver: SparseSolver, direction: np.ndarray, extra: np.ndarray) -> np.ndarray | None:
    """The Newton direction of the factorised system K d = r with the dofs ``extra`` also held (d = 0 there),
    from the factorisation already made: d' = d + K^-1 E l with (K^-1)_BB l = -d_B, the Schur complement of
    the held block (``|B|`` solves with one factorisation instead of a new factorisation). None when too many
    dofs are held for that to pay."""
    held = np.flatnonzero(extra)
    if len(held) > MAX_SCHUR_DOFS:
        return None
    unit = np.zeros((direction.size, len(held)))
    unit[held, np.arange(len(held))] = 1.0
    try:
        columns = solver.solve(unit).reshape(direction.size, len(held))
    except NotPositiveDefinite:
        return None
    try:
        multipliers = np.linalg.solve(columns[held], -direction[held])
    except np.linalg.LinAlgError:
        return None
    corrected = direction + columns @ multipliers
    corrected[held] = 0.0
    return corrected


def _newton(problem: _Problem, x: np.ndarray, solver: SparseSolver, parameters: CompressionParameters,
            pattern) -> tuple[np.ndarray, int, bool, str, float | None]:
    """Projected Newton on E(x) subject to the plate bounds.

    Returns (x, iterations, converged, reason, last_shift): ``last_shift`` is the Levenberg-Marquardt shift of
    the last factorisation (None if none was needed); MIN_SHIFT means PARDISO's Cholesky factorisation of the
    free-dof stiffness at the last factorised iterate succeeded (no negative eigenvalue), i.e. (to within
    that step) the equilibrium is a minimum. Where that iteration held nodes pushed into a plate through the Schur
    complement, the factorisation covers the free dofs before that hold (the minimum test is for them); after a
    fallback factorisation it covers fewer free dofs than the equilibrium has, and the answer is for that subset."""
    cell = problem.cell
    pinned = np.zeros(x.size, dtype=bool)
    pinned[problem.pinned] = True
    energy = cell.energy(x.reshape(-1, 3))
    # round-off of the energy sum: changes below it cannot be resolved by the line search
    noise = 1e-13 * float(np.sum(cell.element_volumes * cell.youngs_moduli))
    if not np.isfinite(energy):
        return x, 0, False, "inverted element in the predictor", None
    shift, last_shift = MIN_SHIFT, None
    residuals: list[float] = []
    gradient = cell.internal_forces(x.reshape(-1, 3)).ravel()
    for iteration in range(1, parameters.max_newton_iterations + 1):
        placement = _place_surrounded(problem, x, gradient)
        if placement is not None and np.isfinite(placed_energy := cell.energy(placement[0].reshape(-1, 3))):
            (x, gradient), energy = placement, placed_energy
        active, at_lower, at_upper, residual, plate_force = _active_set(problem, x, gradient, pinned)
        if DEBUG:
            print(f"  it {iteration} residual {residual:.3e} dof {np.argmax(np.where(active, 0, np.abs(gradient)))} "
                  f"active {active.sum()} energy {energy:.12e}")
        # unbalanced force relative to the plate force (with a floor before the plates carry any)
        force_scale = max(FORCE_FLOOR, plate_force)
        residuals.append(residual / max(plate_force, 1e-300))
        if residual < parameters.tolerance * force_scale or stagnated(residuals):
            if _folded(problem, x):
                return x, iteration - 1, False, FOLDED, last_shift
            return x, iteration - 1, True, "", last_shift
        shift = max(MIN_SHIFT, shift * 1e-2)  # start one rung below the last accepted shift
        direction, shift = _newton_direction(problem, x, gradient, solver, pattern, active, at_lower, at_upper,
                                             shift)
        last_shift = shift
        if direction is None:
            return x, iteration, False, "no descent direction", last_shift
        largest = np.abs(direction).max()
        if largest > MAX_NODE_STEP:
            direction *= MAX_NODE_STEP / largest
        # projected Armijo line search on the energy
        step, accepted = 1.0, False
        for _ in range(30):
            trial = problem.project(x + step * direction)
            trial_energy = cell.energy(trial.reshape(-1, 3))
            if np.isfinite(trial_energy) and trial_energy <= energy + 1e-4 * gradient @ (trial - x) + noise:
                accepted = True
                break
            step *= 0.5
        if not accepted:
            return x, iteration, False, "line search failed (an element would invert)", last_shift
        if DEBUG:
            print(f"     shift {shift:g} step {step:g} max|d| {largest:.3e} clipped {(trial != x + step * direction).sum()}")
        x, energy = trial, trial_energy
        gradient = cell.internal_forces(x.reshape(-1, 3)).ravel()
    return (x, parameters.max_newton_iterations, False,
            f"no convergence in {parameters.max_newton_iterations} iterations", last_shift)


def is_saddle(problem: _Problem, x: np.ndarray, solver: SparseSolver, pattern) -> bool:
    """True when the equilibrium ``x`` is a saddle of the discrete energy: the stiffness restricted to the free
    dofs (contacts and rigid-mode pins held) has a negative eigenvalue, i.e. PARDISO's Cholesky factorisation
    of it fails (SciPy's fallback cannot tell and reports False)."""
    cell = problem.cell
    pinned = np.zeros(x.size, dtype=bool)
    pinned[problem.pinned] = True
    gradient = cell.internal_forces(x.reshape(-1, 3)).ravel()
    active = _active_set(problem, x, gradient, pinned)[0]
    stiffness = cell.stiffness_pattern.assemble_upper(cell.element_stiffness(x.reshape(-1, 3)))
    system = pattern.constrained_upper(stiffness, active, MIN_SHIFT)
    problem.factorised = None
    try:
        not_definite = solver.factorize(system, precision="double")
    except Exception:
        return False
    if not_definite is False:
        problem.factorised = _Factorised(active, MIN_SHIFT, stiffness)
    return bool(not_definite)


def _shifted_newton_direction(solver: SparseSolver, stiffness, pattern, active: np.ndarray, rhs: np.ndarray,
                              shift: float):
    """Newton direction with the smallest Levenberg-Marquardt shift (``shift``, then :data:`RETRY_SHIFT` or x100
    whichever is larger) for which the factorised free-dof stiffness has no negative eigenvalue and the direction
    descends."""
    while shift <= MAX_SHIFT:
        system = pattern.constrained_upper(stiffness, active, shift)
        try:
            not_definite = solver.factorize(system)
        except Exception:  # a singular or failed factorisation: shift more
            not_definite = True
        if not not_definite:
            try:
                direction = solver.solve(rhs)
            except NotPositiveDefinite:  # definite in single precision only
                direction = None
            if direction is not None and _descends(rhs, direction):
                return direction, shift
        shift = max(shift * 100, RETRY_SHIFT)
    return None, shift


def _tangent_predictor(problem: _Problem, x: np.ndarray, increment: float, solver: SparseSolver, pattern) -> np.ndarray:
    """Linearised response to moving the upper plate by -2 increment with the current contact set held:
    K_ff du_f = -K_fc du_c, du = -2 increment on upper contacts, 0 on lower contacts and pins. The stiffness
    is the one the last Newton iteration factorised when it held the same dofs (an iterate or two before the
    converged ``x``: a guess needs no more), otherwise the stiffness at ``x``."""
    cell = problem.cell
    gradient = cell.internal_forces(x.reshape(-1, 3)).ravel()
    lower, upper = _in_contact(problem, x, gradient)
    held = upper | lower
    held[problem.pinned] = True
    prescribed = np.where(upper, -2.0 * increment, 0.0)
    factorised = problem.factorised
    if factorised is not None and factorised.shift == MIN_SHIFT and np.array_equal(factorised.held, held):
        stiffness = factorised.stiffness
    else:
        stiffness = pattern.assemble_upper(cell.element_stiffness(x.reshape(-1, 3)))
        problem.factorised = None
        try:
            indefinite = solver.factorize(pattern.constrained_upper(stiffness, held, MIN_SHIFT))
        except Exception:
            indefinite = True
        if indefinite:
            return x + prescribed  # fall back to moving only the contacts
        problem.factorised = _Factorised(held, MIN_SHIFT, stiffness)
    rhs = -pattern.symmetric_product(stiffness, prescribed)
    rhs[held] = 0.0
    try:
        return x + solver.solve(rhs) + prescribed
    except NotPositiveDefinite:
        problem.factorised = None
        return x + prescribed


def min_nodal_jacobian(cell: Cell, x: np.ndarray, reference: np.ndarray | None = None) -> float:
    """Smallest det(dx/dxi)/det(dX/dxi) over every element's nodes: the local volume ratio where the element map
    is evaluated at its nodes rather than its quadrature points. A linear element has one value (its J); a
    quadratic one can fold (a negative value at a node) while J stays positive at its four quadrature points, so
    that the energy, which sees only those, is finite: such a row is an equilibrium of the discrete energy whose
    map is not one-to-one near that node. ``reference``: det(dX/dxi) at the nodes, if already computed."""
    if reference is None:
        reference = nodal_jacobians(cell.mesh.nodes, cell.mesh.elements)
    return float((nodal_jacobians(x.reshape(-1, 3), cell.mesh.elements) / reference).min())


def min_volume_ratio(cell: Cell, x: np.ndarray) -> float:
    """Smallest volume ratio J = det F of the cell at positions ``x``, sampled at the points of the 4-point rule in
    every quadratic element (the centroid of a linear one), whatever rule the energy uses, so that the value does
    not depend on ``quadrature_degree`` (the 25-point rule's corner points would add extrapolated values): how far
    the material is compressed in volume somewhere. In the compressible laws of docs/theory.md, "Materials", the mean Cauchy
    stress is kappa (J - 1) (the isochoric term adds a traceless part), so its magnitude never exceeds
    kappa = E / (3 (1 - 2 nu)) (8.3 E at nu = 0.48): a thin soft layer pressed by a stiff nucleus carries the load
    by collapsing to a small J, its deviatoric stress growing like J^(-5/3). A physical cytoplasm (mostly water)
    would not."""
    points = quadrature_rule(1 if cell.mesh.order == 1 else DEFAULT_QUADRATURE_DEGREE)[0]
    elements = cell.mesh.elements
    deformed = jacobian_determinants(x.reshape(-1, 3), elements, points)
    return float((deformed / jacobian_determinants(cell.mesh.nodes, elements, points)).min())


def plate_forces(problem: _Problem, x: np.ndarray) -> tuple[float, float, int, float]:
    """(F_upper, F_lower, n_upper_contacts, max rigid-pin reaction) from the converged multipliers: the sum over
    the nodes in contact (:func:`_in_contact`), a surrounded corner's pull included (it is part of the consistent
    nodal forces of a pressure that is positive everywhere)."""
    gradient = problem.cell.internal_forces(x.reshape(-1, 3)).ravel()
    lower, upper = _in_contact(problem, x, gradient)
    force_upper = float(-gradient[upper].sum())
    force_lower = float(gradient[lower].sum())
    return force_upper, force_lower, int(upper.sum()), float(np.abs(gradient[problem.pinned]).max())


def compress(cell: Cell, parameters: CompressionParameters | None = None, solver: str = "auto",
             progress: Callable[[float], None] | None = None, precision: str = "mixed",
             resume_from: CompressionResult | None = None,
             on_row: Callable[[CompressionResult], None] | None = None) -> CompressionResult:
    """Force-deformation curve of ``cell`` from delta = 0 to ``parameters.delta_max``. ``solver`` and
    ``precision``: the sparse solver (see :class:`elastocell.solvers.sparse.SparseSolver`).

    ``resume_from``: the rows of an interrupted curve of the same cell and parameters; the curve continues from its
    last row (the load steps are the same, so the rows equal an uninterrupted curve's up to the solver's
    tolerance). ``on_row(result)`` is called with the curve so far after every converged row (a checkpoint).
    An interruption (KeyboardInterrupt) raises :class:`CompressionInterrupted` holding the converged rows.

    OpenBLAS (NumPy's and SciPy's BLAS) runs on one thread meanwhile: its only work here is dot products and
    small matrix products, and after each one its worker threads busy-wait for more, taking a core from PARDISO's
    factorisation, JAX and the stiffness kernel. Measured on the reference cell's default curve: a factorisation
    took 60-90 ms inside the curve against 44 ms with one OpenBLAS thread, and the curve 36.0 s against 22.6 s."""
    from threadpoolctl import ThreadpoolController

    with ThreadpoolController().select(internal_api="openblas").limit(limits=1):
        return _compress(cell, parameters, solver, progress, precision, resume_from, on_row)


def _compress(cell: Cell, parameters: CompressionParameters | None, solver: str,
              progress: Callable[[float], None] | None, precision: str, resume_from: CompressionResult | None,
              on_row: Callable[[CompressionResult], None] | None) -> CompressionResult:
    parameters = parameters or CompressionParameters()
    start = time.perf_counter()
    problem = _setup(cell)
    pattern = cell.stiffness_pattern
    linear_solver = SparseSolver(solver, precision)
    x = cell.mesh.nodes.ravel().copy()
    targets = np.linspace(0.0, parameters.delta_max, parameters.steps + 1)
    rows_delta, rows_force, rows_lower, rows_positions, rows_contacts = [0.0], [0.0], [0.0], [x.copy()], [0]
    rows_unstable, row_shift, rows_jacobian, rows_volume_ratio = [False], None, [1.0], [1.0]
    reference_jacobians = nodal_jacobians(cell.mesh.nodes, cell.mesh.elements)
    iterations_total, substeps, max_reaction = 0, 0, 0.0
    history: list = []
    delta, failure, interrupted = 0.0, None, False
    if resume_from is not None:
        if resume_from.positions.shape[1:] != cell.mesh.nodes.shape:
            raise ValueError(f"the curve to continue has {resume_from.positions.shape[1]} nodes, the cell {cell.mesh.n_nodes}")
        rows_delta, rows_force, rows_lower = list(resume_from.delta), list(resume_from.force), list(resume_from.force_lower)
        rows_positions = [p.ravel().copy() for p in resume_from.positions]
        rows_contacts, rows_unstable = list(resume_from.contact_nodes_upper), list(resume_from.unstable)
        rows_jacobian, rows_volume_ratio = list(resume_from.min_nodal_jacobian), list(resume_from.min_volume_ratio)
        iterations_total, substeps, max_reaction = resume_from.newton_iterations, resume_from.substeps, resume_from.max_rigid_reaction
        history = list(resume_from.history)
        x, delta = rows_positions[-1].copy(), float(rows_delta[-1])
        problem.set_delta(delta)  # the plates where the interrupted curve left them
        elapsed_before = resume_from.wall_time
    else:
        elapsed_before = 0.0

    def result_so_far() -> CompressionResult:
        return CompressionResult(
            delta=np.array(rows_delta),
            force=np.array(rows_force),
            force_lower=np.array(rows_lower),
            positions=np.array(rows_positions).reshape(len(rows_delta), -1, 3),
            contact_nodes_upper=np.array(rows_contacts),
            unstable=np.array(rows_unstable, dtype=bool),
            min_nodal_jacobian=np.array(rows_jacobian),
            min_volume_ratio=np.array(rows_volume_ratio),
            newton_iterations=iterations_total,
            factorisations=linear_solver.factorisations,
            analyses=linear_solver.analyses,
            substeps=substeps,
            max_rigid_reaction=max_reaction,
            wall_time=elapsed_before + time.perf_counter() - start,
            solver=linear_solver.backend,
            precision=linear_solver.precision,
            refinements=linear_solver.refinements,
            history=history,
        )

    try:
        for target in targets[1:]:
            if target <= delta + 1e-12:  # reached before the interruption this curve continues
                continue
            increment = target - delta
            while delta < target - 1e-14:
                trial_delta = min(target, delta + increment)
                if delta == 0.0:  # first step: shift down by half the gap change
                    guess = x.copy()
                    guess[2::3] -= (trial_delta - delta)
                else:  # linearised response with the current contact set
                    guess = _tangent_predictor(problem, x, trial_delta - delta, linear_solver, pattern)
                problem.set_delta(trial_delta)
                guess = problem.project(guess)
                solution, iterations, converged, reason, last_shift = _newton(problem, guess, linear_solver, parameters,
                                                                             pattern)
                iterations_total += iterations
                history.append((trial_delta, iterations, reason))
                if not converged:
                    increment /= 2
                    substeps += 1
                    problem.set_delta(delta)  # back to the last converged plate position
                    problem.factorised = None  # the failed trial's stiffness is no tangent of the converged x
                    if increment < 1e-6:
                        failure = (f"compression stopped at delta={delta:.4f} (target {trial_delta:.4f}): {reason}; "
                                   f"try {_remedies(cell)}")
                        break
                    continue
                x, delta, row_shift = solution, trial_delta, last_shift
            if failure:
                break
            force_upper, force_lower, contacts, reaction = plate_forces(problem, x)
            max_reaction = max(max_reaction, reaction / max(force_upper, 1e-12))
            rows_delta.append(delta)
            rows_force.append(force_upper)
            rows_lower.append(force_lower)
            rows_positions.append(x.copy())
            rows_contacts.append(contacts)
            # the last factorisation answers for free when it needed no shift (in mixed precision: for K rounded
            # to single precision, blind to eigenvalues within ~1e-7 of the largest); otherwise check in double
            rows_unstable.append(row_shift != MIN_SHIFT and is_saddle(problem, x, linear_solver, pattern))
            rows_jacobian.append(min_nodal_jacobian(cell, x, reference_jacobians))
            rows_volume_ratio.append(min_volume_ratio(cell, x))
            if on_row is not None:
                on_row(result_so_far())
            if progress is not None:
                progress(delta)
    except KeyboardInterrupt:  # the step in progress is lost, every converged row is kept
        interrupted = True
    finally:
        linear_solver.close()
    result = result_so_far()
    if interrupted:
        raise CompressionInterrupted(f"interrupted at delta={delta:.4f} ({len(rows_delta)} rows converged)", result)
    if failure:
        raise CompressionError(failure, result)
    return result


NODAL_RULE_FROM_STIFFNESS_RATIO = 5.5
"""Nucleus stiffness ratio from which a compression with p2 elements (neo-Hookean, default sizes) uses the refined
mesh of :data:`STIFF_NUCLEUS_MESHES` and, unless a degree is given, the quadrature rule with the nodes (degree 5).
The rule: on the default mesh the 4-point rule's smallest nodal det ratio is 0.205 at stiffness ratio 5 and 0.064
at 6; 7 folds at delta = 0.75, 10 from 0.694, and 20 stops at 0.600 (README); with the rule with the nodes they
reach 0.75 unfolded. The threshold lies below where the default mesh's error crosses 3 % (validation/stiff_mesh.py, against the
axisymmetric truth at delta 0.7, 40 steps): +2.44 % at stiffness ratio 5, +2.67 % at 5.4, +3.39 % at 6.9 (the
crossing near 6.1 by interpolation); refined, 5.5 errs +1.72 % and 7 +2.18 %. 3D indentation
(``indentation_cell_3d``) takes the degree from here too (its own mesh is never the refined one)."""

STIFF_NUCLEUS_MESHES = (  # (up to stiffness ratio, nucleus surface size, its width, bulk size; units of R)
    (10.0, 0.075, 0.4, 0.35),
    (np.inf, 0.06, 0.4, 0.25),
)
"""The default mesh of a compression of a nucleus at least :data:`NODAL_RULE_FROM_STIFFNESS_RATIO` times stiffer
than the cytoplasm (p2, neo-Hookean), the first whose stiffness ratio is not exceeded; the poles keep the default
0.08 over 1.4 R. The soft layer a stiff nucleus crushes against a plate is where the default p2 mesh (nucleus
surface 0.15 over 0.25 R, bulk 0.35) errs (validation/stiff_mesh.py, against the axisymmetric truth at delta 0.7,
14 load steps): stiffness ratio 10, +5.2 % on the default mesh, +2.8 % with the nucleus surface at 0.075 over
0.4 R (11,684 nodes); stiffness ratio 20, +7.4 % on the default mesh, +4.2 % with that surface, +2.65 % with the
surface at 0.06 and the bulk at 0.25 (21,178 nodes). It replaces the default p2 mesh only: a mesh whose sizes
differ from the default's (compared by value: the default sizes given explicitly are the default mesh) is used as
given."""


def stiff_nucleus_mesh(cell: CellParameters) -> CellParameters:
    """``cell`` with the default mesh a compression gives its nucleus (:data:`STIFF_NUCLEUS_MESHES`) where its mesh
    is the default p2 mesh; unchanged below stiffness ratio 5.5 (:data:`NODAL_RULE_FROM_STIFFNESS_RATIO`), for a law
    other than neo-Hookean, a random cell or any other mesh."""
    mesh, nucleus = cell.mesh, cell.nucleus
    if (cell.random is not None or nucleus.shape == "none" or cell.material.law != "neo-hookean"
            or nucleus.stiffness_ratio < NODAL_RULE_FROM_STIFFNESS_RATIO or _sizes(mesh) != _sizes(MeshParameters.default_for("p2"))):
        return cell
    _, surface, width, bulk = next(entry for entry in STIFF_NUCLEUS_MESHES if nucleus.stiffness_ratio <= entry[0])
    refined = MeshParameters(**{**mesh.model_dump(), "interface_size": surface, "interface_width": width,
                                "mesh_size": bulk})
    return cell.model_copy(update={"mesh": refined})


def _sizes(mesh: MeshParameters) -> dict:
    """What of ``mesh`` makes its geometry: its data without the quadrature and the volumetric treatment (the
    polar layer's fields are left out of the data when it has none)."""
    data = mesh.model_dump()
    data.pop("quadrature_degree", None)
    data.pop("volumetric", None)
    return data


def compression_parameters_for(cell: CellParameters) -> CellParameters:
    """``cell`` with the mesh and quadrature a compression of it uses: a stiff nucleus's refined mesh
    (:func:`stiff_nucleus_mesh`); the degree given, else, for p2 elements, a neo-Hookean cell and a nucleus at
    least :data:`NODAL_RULE_FROM_STIFFNESS_RATIO` times stiffer than the cytoplasm, degree 5 (its points include
    the nodes, so no element of the crushed soft layer folds at a node). The Mooney-Rivlin law keeps degree 2:
    its reference cell stops at delta = 0.619 with degree 5 (README). A cell whose J is projected onto linear
    polynomials (``volumetric`` projected) takes degree 5 too: with 4 points that projection is the identity."""
    if cell.mesh.volumetric == "nodal":
        raise ParameterError("volumetric", "nodal serves the flows only (their forces; the static solvers need the "
                             "element stiffness matrices it does not have): use standard for p1, or p2 with "
                             "projected or mean")
    cell = stiff_nucleus_mesh(cell)
    mesh, nucleus = cell.mesh, cell.nucleus
    if mesh.volumetric == "projected" and mesh.quadrature_degree is None:
        return cell.model_copy(update={"mesh": mesh.model_copy(update={"quadrature_degree": 5})})
    if (mesh.element == "p2" and mesh.quadrature_degree is None and cell.random is None and nucleus.shape != "none"
            and nucleus.stiffness_ratio >= NODAL_RULE_FROM_STIFFNESS_RATIO and cell.material.law == "neo-hookean"):
        return cell.model_copy(update={"mesh": mesh.model_copy(update={"quadrature_degree": 5})})
    return cell


def _remedies(cell: Cell) -> str:
    """What the user can change when the load stepping stops, the one measured to help most first (README: the
    rule with the nodes takes stiffness ratio 20 to delta = 0.75 where the default stops at 0.600)."""
    remedies = []
    degree = cell.parameters.mesh.quadrature_degree or DEFAULT_QUADRATURE_DEGREE
    if cell.mesh.order == 2 and degree not in (4, 5) and cell.law.name != "mooney-rivlin":  # it stops earlier there
        remedies.append("the quadrature whose points include the nodes, so that no element folds at a node "
                        "(quadrature_degree 5)")
    remedies += ["a finer mesh (mesh_size/pole_size, interface_size for a stiff nucleus)", "more steps"]
    if cell.mesh.order == 2:
        remedies.append("linear elements (element p1)")
    return ", ".join(remedies[:-1]) + f" or {remedies[-1]}"


def hertz_force(delta, poisson_ratio: float = 0.48):
    """Hertz's two-contact small-deformation limit F/(E R^2) = 4/(3(1-nu^2)) delta^(3/2)."""
    return 4.0 / (3.0 * (1.0 - poisson_ratio**2)) * np.asarray(delta) ** 1.5


class CompressionParameters(ParameterModel):
    """Quasistatic compression between two rigid frictionless plates (normal along z).

    delta_max: final deformation delta = 1 - h/(2R), in (0, 1).
    steps: number of equal load increments from 0 to ``delta_max`` (each is one output row; the solver
    subdivides an increment when Newton needs it).
    tolerance: Newton stops when the largest unbalanced nodal force is below ``tolerance`` times the plate
    force (or times 1e-4 E_c R^2, Hertz's plate force near delta = 0.0015, while the plate force is smaller).
    Measured on the default mesh: the default 1e-7 moves F by less than 2e-7 of itself against a 1e-10 solve.
    Newton also stops, converged, when that unbalanced force relative to the plate force is below 1e-7 and has
    not halved in 3 iterations (this matters for tolerances tighter than the default): on fine meshes past the
    point where the symmetric equilibrium turns into a saddle of the discrete energy, Newton with its
    Levenberg-Marquardt shift otherwise creeps along the unstable direction (measured: homogeneous p2 cell,
    7,705 nodes, delta = 0.51: largest unbalanced force 7.9e-9 -> 9.3e-9 E_c R^2 over 20 iterations, energy
    falling by 1.2e-9 E_c R^3 per iteration). Such rows are flagged in ``unstable``.
    """

    delta_max: float = 0.75
    steps: int = 40
    tolerance: float = 1e-7
    max_newton_iterations: int = 30

    @model_validator(mode="after")
    def _check(self) -> CompressionParameters:
        require(0 < self.delta_max < 1, "delta_max", f"must be in (0, 1), got {self.delta_max}")
        require(1 <= self.steps <= 100000, "steps", f"must be in [1, 100000], got {self.steps}")
        require(0 < self.tolerance < 1e-2, "tolerance", f"must be in (0, 1e-2), got {self.tolerance}")
        return self
