"""Axisymmetric loadings of an axisymmetric cell (:mod:`elastocell.body.axisymmetric`): the two parallel plates
of ``elastocell compress`` and a rigid sphere pressed on the axis into a cell resting on a flat rigid dish.

Geometry (units of R, the meridian half-plane (r, z)):

- plates: the lower plate at z = -1, the upper at z = 1 - 2 delta (as :mod:`elastocell.scenarios.compression`);
- sphere: a rigid ball of radius R_b centred on the axis at z = 1 + R_b - depth above the cell, which rests on a
  rigid dish at z = -1; ``depth`` is the indenter's displacement after first contact (it includes the cell's
  deformation at the dish).

Contact is exact and frictionless, node to rigid surface, as in 3D: every surface node must stay outside each
obstacle (z >= -1, z <= 1 - 2 delta; |x - c| >= R_b). Each curve point is a minimum of the elastic energy under
those constraints, found by a projected Newton method with an active set: a surface node on an obstacle whose
energy gradient pushes into it is active; its dofs are turned into the obstacle's local frame (normal n, tangent t)
and the normal one is held (the linearised gap), the tangent one is free. For the sphere the Newton matrix is the
Hessian of the Lagrangian, the stiffness minus lambda_i / |x_i - c| on the tangent dof of each active node (the
curvature of the constraint), so that the iteration converges quadratically; the line search projects every
trial point back onto the feasible set (clip to a plate, radial projection out of the ball), retracts the nodes
held on an obstacle onto its surface (a tangent step would lift them off a curved one) and accepts on the energy
(Armijo). The contact force is the sum of the multipliers lambda_i = g_i . n_i of the active nodes (g the
energy gradient; the ring force of each node), exact at convergence; the sphere's vertical force is
sum lambda_i (-n_z,i).

The linear algebra is the 3D solver's: the stiffness pattern of :class:`elastocell.body.cell.StiffnessPattern`
(held dofs replaced by identity rows, one symbolic analysis per curve) and the Cholesky factorisation of
:class:`elastocell.solvers.sparse.SparseSolver`, which says when the free-dof matrix is not positive definite (a
Levenberg-Marquardt shift is then added, as in :mod:`elastocell.scenarios.compression`). Axis nodes keep r = 0.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from elastocell.body.axisymmetric import (
    AxisymmetricCell,
    MeridianGeometry,
    MeridianMeshParameters,
    meridian_nucleus,
)
from elastocell.parameters.cell import CellParameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.compression import MAX_NODE_STEP, MAX_SHIFT, MIN_SHIFT, RETRY_SHIFT, stagnated
from elastocell.solvers.sparse import NotPositiveDefinite, SparseSolver

FORCE_FLOOR = 1e-7
"""Smallest force scale (E_c R^2) of the convergence test, before the contacts carry any force."""
GAP_TOLERANCE = 1e-12
"""A node whose gap to an obstacle is below this (units of R) lies on it (projection puts it at gap 0 to
round-off)."""
DEFAULT_TOLERANCE = 1e-9
"""Largest unbalanced ring force over the contact force at convergence."""
RESIDUAL_NOISE = 1e-12
"""An unbalanced ring force below this times E_max L^2 (L the body's largest coordinate in the mesh's unit) that
no longer halves over three Newton iterations is round-off: converged."""


class AxisymmetricError(RuntimeError):
    """The load stepping could not reach the requested load; ``partial`` holds the converged rows."""

    def __init__(self, message: str, partial: AxisymmetricResult | None = None):
        super().__init__(message)
        self.partial = partial


class AxisymmetricInterrupted(AxisymmetricError):
    """The curve was interrupted (Ctrl-C, SIGTERM); ``partial`` holds every row converged before, from which
    :func:`compress_axisymmetric` can continue (``resume_from=``)."""


@dataclass
class Obstacle:
    """A rigid frictionless obstacle in the meridian plane.

    kind: ``lower`` (the body stays above z = level), ``upper`` (below z = level), ``sphere`` (outside the
    ball of ``radius`` centred at (0, level)) or ``cone`` (outside a cone of half-angle ``half_angle`` (radians,
    between the axis and the flank) opening upwards, its apex rounded by a sphere of ``radius`` centred at
    (0, level): the points within ``radius`` of the sharp cone with its apex at (0, level); the flanks are the
    sharp cone's offset by ``radius``, tangent to that sphere).
    velocity: d level / d load parameter (the upper plate -2 per unit delta, the sphere and cone -1 per unit depth).
    """

    kind: str
    level: float
    velocity: float = 0.0
    radius: float = 0.0
    half_angle: float = 0.0

    def _cone(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(signed distance to the sharp cone, unit normal out of it, True where the nearest point is the apex) of
        points ``x`` (n, 2), r >= 0: below the apex's normal plane of the flank the apex is nearest, elsewhere the
        flank (a point inside has a negative distance to it)."""
        offset = x - np.array([0.0, self.level])
        sin, cos = np.sin(self.half_angle), np.cos(self.half_angle)
        apex = offset @ np.array([sin, cos]) <= 0
        distance = np.where(apex, np.linalg.norm(offset, axis=1), offset @ np.array([cos, -sin]))
        normal = np.where(apex[:, None], offset / np.maximum(distance, 1e-300)[:, None], np.array([cos, -sin]))
        return distance, normal, apex

    def gaps_and_normals(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(gap, unit normal pointing from the obstacle into the body) of points ``x`` (n, 2)."""
        if self.kind == "lower":
            return x[:, 1] - self.level, np.broadcast_to([0.0, 1.0], x.shape)
        if self.kind == "upper":
            return self.level - x[:, 1], np.broadcast_to([0.0, -1.0], x.shape)
        if self.kind == "cone":
            distance, normal, _ = self._cone(x)
            return distance - self.radius, normal
        offset = x - np.array([0.0, self.level])
        distance = np.linalg.norm(offset, axis=1)
        return distance - self.radius, offset / np.maximum(distance, 1e-300)[:, None]

    def curvature_distance(self, x: np.ndarray) -> np.ndarray:
        """The radius of curvature of the obstacle's meridian at the nearest point of each of ``x`` (its distance
        to the centre of curvature), inf on a flat flank: the Hessian of the Lagrangian subtracts lambda / it."""
        if self.kind == "sphere":
            return np.linalg.norm(x - np.array([0.0, self.level]), axis=1)
        if self.kind == "cone":
            distance, _, apex = self._cone(x)
            return np.where(apex, distance, np.inf)
        return np.full(len(x), np.inf)

    def project(self, x: np.ndarray) -> np.ndarray:
        """The nearest point outside the obstacle (clip to a plate; radial projection out of the ball; out of the
        cone along its normal, a point on the axis along the axis to the apex)."""
        if self.kind == "lower":
            return np.column_stack([x[:, 0], np.maximum(x[:, 1], self.level)])
        if self.kind == "upper":
            return np.column_stack([x[:, 0], np.minimum(x[:, 1], self.level)])
        gap, normal = self.gaps_and_normals(x)
        inside = gap < 0
        axis = inside & (x[:, 0] == 0)
        x = x.copy()
        if self.kind == "cone":
            x[inside] -= gap[inside, None] * normal[inside]
            x[axis] = np.array([0.0, self.level - self.radius])
            return x
        x[inside] = np.array([0.0, self.level]) + self.radius * normal[inside]
        return x

    def vertical_force(self, multipliers: np.ndarray, normals: np.ndarray) -> float:
        """The force on the obstacle along -z for the upper plate, the sphere and the cone, +z for the lower
        plate."""
        if self.kind == "lower":
            return float(multipliers.sum())
        return float(np.sum(multipliers * -normals[:, 1]))


@dataclass
class AxisymmetricResult:
    """A force curve of the axisymmetric solver (lengths in R, forces in E_c R^2).

    load: delta (plates) or depth (sphere), starting at 0.
    force: the force on the moving obstacle (upper plate, sphere); force_support: on the lower plate or the dish.
    contact_radius: the largest r of the active nodes on the moving obstacle.
    positions: (n_rows, n_nodes, 2) nodal positions (r, z).
    """

    load: np.ndarray
    force: np.ndarray
    force_support: np.ndarray
    contact_radius: np.ndarray
    min_volume_ratio: np.ndarray
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
    """The contact state at an iterate: per candidate node the obstacle it lies on (-1: none), its normal and
    multiplier, which nodes are active, the node rotations and the held local dofs."""

    obstacle: np.ndarray
    normals: np.ndarray
    multipliers: np.ndarray
    active: np.ndarray
    rotations: np.ndarray  # (n_nodes, 2, 2): columns (n, t) for rotated nodes, identity elsewhere
    held: np.ndarray  # (2 n_nodes,) local dofs held


class _Problem:
    def __init__(self, cell: AxisymmetricCell, obstacles: list[Obstacle], solver: SparseSolver):
        self.cell = cell
        self.obstacles = obstacles
        self.solver = solver
        self.candidates = cell.mesh.surface_nodes
        self.n_nodes = cell.mesh.n_nodes
        self.on_axis = np.zeros(self.n_nodes, dtype=bool)
        self.on_axis[cell.mesh.axis_nodes] = True
        self.bonded = cell.mesh.base_nodes  # held in r and z (a base bonded to the dish)
        self.bonded_candidates = np.isin(self.candidates, self.bonded)
        self.pattern = cell.stiffness_pattern
        self.noise = 1e-13 * float(np.sum(cell.element_volumes * cell.youngs_moduli))
        # round-off of the ring forces: a wide layer's far field (r ~ 40 in the mesh's unit) leaves ~3e-11 E L^2
        # after quadratic convergence, above 1e-9 of a sharp cone's first small forces
        self.residual_noise = RESIDUAL_NOISE * float(np.max(cell.youngs_moduli)) * float(np.abs(cell.mesh.nodes).max()) ** 2
        self.poles, self.pole_neighbours = _pole_neighbours(cell.mesh.elements, self.candidates, self.on_axis)

    def set_load(self, load: float, start: list[float]) -> None:
        for obstacle, level in zip(self.obstacles, start, strict=True):
            obstacle.level = level + obstacle.velocity * load

    def project(self, x: np.ndarray) -> np.ndarray:
        x = x.copy()
        x[self.on_axis, 0] = 0.0
        x[self.bonded] = self.cell.mesh.nodes[self.bonded]
        for obstacle in self.obstacles:
            x[self.candidates] = obstacle.project(x[self.candidates])
        return x

    def retract(self, x: np.ndarray, on_surface: np.ndarray, obstacle_of: np.ndarray) -> np.ndarray:
        """``x`` with the candidates ``on_surface`` moved along the normal onto the obstacle ``obstacle_of`` each
        was held on (gap 0)."""
        if not on_surface.any():
            return x
        x = x.copy()
        for k, obstacle in enumerate(self.obstacles):
            nodes = self.candidates[on_surface & (obstacle_of == k)]
            if len(nodes):
                gap, normal = obstacle.gaps_and_normals(x[nodes])
                x[nodes] -= gap[:, None] * normal
        return x

    def violated(self, x: np.ndarray) -> bool:
        """True when any node (interior ones included) lies inside an obstacle: a folded element."""
        return any((obstacle.gaps_and_normals(x)[0] < -1e-9).any() for obstacle in self.obstacles)

    def contact(self, x: np.ndarray, gradient: np.ndarray) -> _Contact:
        candidates = x[self.candidates]
        count = len(self.candidates)
        obstacle_of = np.full(count, -1)
        normals = np.zeros((count, 2))
        best = np.full(count, np.inf)
        for k, obstacle in enumerate(self.obstacles):
            gap, normal = obstacle.gaps_and_normals(candidates)
            on = (gap <= GAP_TOLERANCE) & (gap < best)
            obstacle_of[on], normals[on], best[on] = k, normal[on], gap[on]
        multipliers = np.where(obstacle_of >= 0, np.einsum("ij,ij->i", gradient[self.candidates], normals), 0.0)
        active = (obstacle_of >= 0) & (multipliers > 0)
        # a pole (an axis node on the surface) lying on the obstacle its surface neighbour presses stays in contact
        # whatever the sign of its multiplier: that is the ring force of a point, whose consistent share of a
        # uniform pressure on its quadratic edge vanishes (int_0^1 (1 - s)(1 - 2 s) s ds = 0), so that it flipped
        # with the pressure's curvature, released the pole and let the pole element fold into a dimple of one
        # element (docs/validation/axisymmetric.md)
        pressed = active[self.pole_neighbours] & (obstacle_of[self.pole_neighbours] == obstacle_of[self.poles])
        active[self.poles] |= (obstacle_of[self.poles] >= 0) & pressed
        rotations = np.broadcast_to(np.eye(2), (self.n_nodes, 2, 2)).copy()
        rotated = (obstacle_of >= 0) & ~self.on_axis[self.candidates]
        n = normals[rotated]
        rotations[self.candidates[rotated]] = np.stack([n, np.column_stack([-n[:, 1], n[:, 0]])], axis=2)
        held = np.zeros(2 * self.n_nodes, dtype=bool)
        held[2 * np.flatnonzero(self.on_axis)] = True  # u_r = 0 on the axis
        held[2 * self.bonded] = held[2 * self.bonded + 1] = True  # a bonded base does not move
        nodes = self.candidates[active]
        # an active node's normal dof: local dof 0 where rotated; z (global 1) on the axis, where n = +-e_z
        held[2 * nodes + self.on_axis[nodes]] = True
        return _Contact(obstacle_of, normals, multipliers, active, rotations, held)

    def local(self, vector: np.ndarray, contact: _Contact) -> np.ndarray:
        """Q^T v per node, flattened."""
        return np.einsum("nic,ni->nc", contact.rotations, vector.reshape(-1, 2)).ravel()

    def glob(self, vector: np.ndarray, contact: _Contact) -> np.ndarray:
        """Q y per node, (n_nodes, 2)."""
        return np.einsum("nic,nc->ni", contact.rotations, vector.reshape(-1, 2))

    def stiffness(self, x: np.ndarray, contact: _Contact):
        """Upper triangle of the Hessian of the Lagrangian in the nodes' local frames."""
        elements = self.cell.mesh.elements
        matrices = self.cell.element_stiffness(x).reshape(-1, 6, 2, 6, 2)
        q = contact.rotations[elements]  # (e, 6, 2, 2)
        matrices = np.einsum("eaic,eaibj,ebjd->eacbd", q, matrices, q, optimize=True)
        upper = self.pattern.assemble_upper(matrices.reshape(len(elements), 12, 12))
        for k, obstacle in enumerate(self.obstacles):
            if obstacle.kind not in ("sphere", "cone"):
                continue
            on = contact.active & (contact.obstacle == k) & ~self.on_axis[self.candidates]
            nodes = self.candidates[on]
            distance = obstacle.curvature_distance(x[nodes])
            upper.data[self.pattern.upper_diagonal[2 * nodes + 1]] -= contact.multipliers[on] / distance
        return upper

    def shifted(self, upper, held: np.ndarray, shift: float):
        """The held-dof system with the shift. A wide bonded layer's ring stiffness grows with r, so that its mean
        diagonal is that of the far field, hundreds of times the contact's: a shift relative to it smothers the
        steps at the contact (a 20 R_b thick layer cycled between active sets); each dof's own diagonal
        (Marquardt's scaling) does not."""
        if not len(self.bonded):
            return self.pattern.constrained_upper(upper, held, shift)
        scaled = upper.copy()
        diagonal = self.pattern.upper_diagonal
        scaled.data[diagonal] += shift * np.abs(upper.data[diagonal])
        return self.pattern.constrained_upper(scaled, held, 0.0)

    def factorised_direction(self, upper, held: np.ndarray, rhs: np.ndarray, shift: float):
        """(direction, shift): the solution of the held-dof system with the smallest Levenberg-Marquardt shift
        (relative to the mean diagonal; on a body with a bonded base, to each dof's own diagonal) whose
        factorisation is positive definite and whose step descends."""
        while shift <= MAX_SHIFT:
            system = self.shifted(upper, held, shift)
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


def _pole_neighbours(elements: np.ndarray, candidates: np.ndarray, on_axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(poles, neighbours): the positions in ``candidates`` of each surface node on the axis and of the mid-side
    node of the surface edge that ends at it."""
    position = np.full(len(on_axis), -1)
    position[candidates] = np.arange(len(candidates))
    edges = elements[:, [[0, 3, 1], [1, 4, 2], [2, 5, 0]]].reshape(-1, 3)  # (corner, mid-side, corner)
    boundary = edges[(position[edges] >= 0).all(axis=1)]
    ends = np.concatenate([boundary[:, [0, 1]], boundary[:, [2, 1]]])
    ends = ends[on_axis[ends[:, 0]]]
    return position[ends[:, 0]], position[ends[:, 1]]


def _newton(problem: _Problem, x: np.ndarray, tolerance: float, max_iterations: int):
    """Projected Newton with an active set from ``x`` (feasible) at the current obstacle positions. Returns
    (x, iterations, converged, reason)."""
    cell = problem.cell
    energy = cell.energy(x)
    if not np.isfinite(energy):
        return x, 0, False, "inverted element in the predictor"
    shift = MIN_SHIFT
    residuals: list[float] = []
    absolute: list[float] = []
    for iteration in range(1, max_iterations + 1):
        gradient = cell.internal_forces(x)
        contact = problem.contact(x, gradient)
        local_gradient = problem.local(gradient, contact)
        free = ~contact.held
        residual = float(np.abs(local_gradient[free]).max())
        force = max(float(contact.multipliers[contact.active].sum()) / 2, 0.0)
        residuals.append(residual / max(force, 1e-300))
        absolute.append(residual)
        at_noise = (len(absolute) > 3 and residual < problem.residual_noise and residual > 0.5 * absolute[-4]
                    and np.isfinite(residual))  # a plateau at the ring forces' round-off
        if residual < tolerance * max(force, FORCE_FLOOR) or stagnated(residuals) or at_noise:
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
            normal_step = direction.reshape(-1, 2)[problem.candidates]
            into = np.where(problem.on_axis[problem.candidates], normal_step[:, 1] * contact.normals[:, 1],
                            normal_step[:, 0]) < 0
            blocked = (contact.obstacle >= 0) & ~contact.active & into
            dofs = 2 * problem.candidates[blocked] + problem.on_axis[problem.candidates[blocked]]
            if not blocked.any() or held[dofs].all():
                break
            held[dofs] = True
        step_vector = problem.glob(direction, contact)
        largest = np.abs(step_vector).max()
        if largest > MAX_NODE_STEP:
            step_vector *= MAX_NODE_STEP / largest
        # the nodes held on an obstacle stay on it: a tangent step of length s off a curved obstacle lifts a node
        # by s^2 / (2 rho) (1e-9 to 1e-5 R_b on a thick layer), which released the whole contact zone on the next
        # iteration and made the active set cycle; they are retracted onto the surface along its normal
        # (the normal dof only: an axis node's u_r = 0 is always held, a released pole must stay free to lift)
        normal_dofs = 2 * problem.candidates + problem.on_axis[problem.candidates]
        on_surface = held[normal_dofs] & (contact.obstacle >= 0) & ~problem.bonded_candidates
        step, accepted = 1.0, False
        for _ in range(40):
            trial = problem.retract(problem.project(x + step * step_vector), on_surface, contact.obstacle)
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
    """Linearised response to moving the obstacles by ``increment`` of the load with the current active set
    held: the active nodes follow their obstacle along its normal, the others from K_ff du_f = -K_fc du_c."""
    gradient = problem.cell.internal_forces(x)
    contact = problem.contact(x, gradient)
    if not contact.active.any():
        return x
    prescribed = np.zeros(2 * problem.n_nodes)
    nodes = problem.candidates[contact.active]
    motion = np.array([problem.obstacles[k].velocity for k in contact.obstacle[contact.active]]) * increment
    normals = contact.normals[contact.active]
    axis = problem.on_axis[nodes]
    prescribed[2 * nodes + axis] = np.where(axis, motion, motion * normals[:, 1])  # n . (0, v dt)
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


def _dent(x: np.ndarray, indenter: Obstacle, depth: float, bottom: float, height: float) -> np.ndarray:
    """The first step's guess under a sphere or a cone on a bonded body: the half-space's surface deflection w(rho)
    (Hertz's under a sphere, Sneddon's under a cone) taken as a function of the distance rho from the apex
    (0, bottom + height), times (z - bottom) / height so that the base stays put. On the surface it follows the
    indenter inside the contact (the sphere: w = depth - r^2 / (2 R_b) for r < a = sqrt(R_b depth); the cone:
    w = depth - r cot(alpha) for r < a = 2 depth tan(alpha) / pi; a sharper cone than 57.5 degrees takes the
    profile of that angle, below its flanks), so that the projection onto the indenter moves no node across its
    neighbours; an affine squeeze of a body much thicker than the contact strains all of it
    and its Newton iteration cycles between active sets."""
    if indenter.kind == "cone":  # the profile of a cone at least 57.5 degrees: a sharper one's inverts the axis
        contact_radius = max(2 * np.tan(indenter.half_angle) / np.pi, 1.0) * depth  # (dz/dZ = 1 - cot(alpha))
    else:
        contact_radius = np.sqrt(indenter.radius * depth)
    s = np.hypot(x[:, 0], x[:, 1] - bottom - height) / contact_radius
    outside = np.maximum(s, 1.0)
    if indenter.kind == "cone":
        deflection = np.where(s <= 1, 1 - 2 * s / np.pi, 2 / np.pi * (np.arcsin(1 / outside) - outside
                                                                      + np.sqrt(outside**2 - 1)))
    else:
        deflection = np.where(s <= 1, (2 - s**2) / 2, ((2 - outside**2) * np.arcsin(1 / outside)
                                                      + np.sqrt(outside**2 - 1)) / np.pi)
    guess = x.copy()
    guess[:, 1] -= depth * deflection * (x[:, 1] - bottom) / height
    return guess


def _forces(problem: _Problem, x: np.ndarray) -> tuple[float, float, float]:
    """(force on the moving obstacle, force on the support (the lower plate or dish; a bonded base: the sum of
    the z reactions of its held nodes), contact radius on the moving obstacle)."""
    gradient = problem.cell.internal_forces(x)
    contact = problem.contact(x, gradient)
    forces, radius = [], 0.0
    for k, obstacle in enumerate(problem.obstacles):
        on = contact.active & (contact.obstacle == k)
        forces.append(obstacle.vertical_force(contact.multipliers[on], contact.normals[on]))
        if obstacle.velocity != 0 and on.any():
            radius = float(x[problem.candidates[on], 0].max())
    moving = [k for k, obstacle in enumerate(problem.obstacles) if obstacle.velocity != 0][0]
    if len(problem.obstacles) == 1:
        return forces[moving], float(gradient[problem.bonded, 1].sum()), radius
    return forces[moving], forces[1 - moving], radius


def _curve(cell: AxisymmetricCell, obstacles: list[Obstacle], load_max: float, steps: int, tolerance: float,
           max_iterations: int, solver: str, precision: str, bottom: float = -1.0,
           height: float = 2.0, resume_from: AxisymmetricResult | None = None,
           on_row: Callable[[AxisymmetricResult], None] | None = None) -> AxisymmetricResult:
    """The force curve; ``bottom`` and ``height``: the z of the body's lowest point and its height, for the first
    step's guess. ``resume_from``: the rows of an interrupted curve of the same cell and loading, continued from
    its last row (the same load steps); ``on_row(result)`` after every converged row; an interruption
    (KeyboardInterrupt) raises :class:`AxisymmetricInterrupted` with the converged rows."""
    start_time = time.perf_counter()
    linear_solver = SparseSolver(solver, precision)
    problem = _Problem(cell, obstacles, linear_solver)
    start = [obstacle.level for obstacle in obstacles]
    top_velocity = min(obstacle.velocity for obstacle in obstacles)
    x = cell.mesh.nodes.copy()
    rows = {"load": [0.0], "force": [0.0], "support": [0.0], "radius": [0.0], "volume": [1.0], "positions": [x.copy()]}
    iterations_total, substeps, history = 0, 0, []
    load = 0.0
    if resume_from is not None:
        if resume_from.positions.shape[1:] != x.shape:
            raise ValueError(f"the curve to continue has {resume_from.positions.shape[1]} nodes, the cell {len(x)}")
        rows = {name: list(getattr(resume_from, attribute)) for name, attribute in RESULT_ROWS.items()}
        iterations_total, substeps, history = resume_from.newton_iterations, resume_from.substeps, list(resume_from.history)
        x, load = resume_from.positions[-1].copy(), float(resume_from.load[-1])
        problem.set_load(load, start)
        start_time -= resume_from.wall_time
    try:
        for target in np.linspace(0.0, load_max, steps + 1)[1:]:
            if target <= load + 1e-12:  # reached before the interruption this curve continues
                continue
            increment = target - load
            while load < target - 1e-14:
                trial_load = min(target, load + increment)
                if load == 0.0 and len(problem.bonded):
                    guess = _dent(x, obstacles[-1], trial_load, bottom, height)
                elif load == 0.0:  # first contact: squeeze the cell affinely between its new bounds
                    guess = x.copy()
                    guess[:, 1] = bottom + (guess[:, 1] - bottom) * (1.0 + top_velocity * trial_load / height)
                else:
                    guess = _predictor(problem, x, trial_load - load)
                problem.set_load(trial_load, start)
                guess = problem.project(guess)
                solution, iterations, converged, reason = _newton(problem, guess, tolerance, max_iterations)
                iterations_total += iterations
                history.append((trial_load, iterations, reason))
                if not converged:
                    problem.set_load(load, start)
                    increment /= 2
                    substeps += 1
                    if increment < 1e-7:
                        result = _result(rows, iterations_total, substeps, cell, start_time, history)
                        raise AxisymmetricError(f"stopped at load {load:.5f} (target {trial_load:.5f}): {reason}",
                                                result)
                    continue
                x, load = solution, trial_load
            force, support, radius = _forces(problem, x)
            rows["load"].append(load)
            rows["force"].append(force)
            rows["support"].append(support)
            rows["radius"].append(radius)
            rows["volume"].append(cell.min_volume_ratio(x))
            rows["positions"].append(x.copy())
            if on_row is not None:
                on_row(_result(rows, iterations_total, substeps, cell, start_time, history))
    except KeyboardInterrupt:  # the step in progress is lost, every converged row is kept
        result = _result(rows, iterations_total, substeps, cell, start_time, history)
        raise AxisymmetricInterrupted(f"interrupted at load {load:.4f} ({len(rows['load'])} rows converged)",
                                      result) from None
    finally:
        linear_solver.close()
    return _result(rows, iterations_total, substeps, cell, start_time, history)


RESULT_ROWS = {"load": "load", "force": "force", "support": "force_support", "radius": "contact_radius",
               "volume": "min_volume_ratio", "positions": "positions"}
"""The per-row lists of :func:`_curve` and the :class:`AxisymmetricResult` arrays they become."""


def _result(rows, iterations, substeps, cell, start_time, history) -> AxisymmetricResult:
    return AxisymmetricResult(
        load=np.array(rows["load"]), force=np.array(rows["force"]), force_support=np.array(rows["support"]),
        contact_radius=np.array(rows["radius"]), min_volume_ratio=np.array(rows["volume"]),
        positions=np.array(rows["positions"]), newton_iterations=iterations, substeps=substeps,
        n_nodes=cell.mesh.n_nodes, wall_time=time.perf_counter() - start_time, history=history)


def _cell(cell: CellParameters | AxisymmetricCell, mesh: MeridianMeshParameters | None,
          geometry: MeridianGeometry | None = None) -> AxisymmetricCell:
    if isinstance(cell, AxisymmetricCell):
        return cell
    meridian_nucleus(cell, geometry)  # refuses a cell that is not axisymmetric about z
    return AxisymmetricCell.from_parameters(cell, mesh, geometry=geometry)


def compress_axisymmetric(cell_parameters: CellParameters | AxisymmetricCell, delta_max: float = 0.75,
                          steps: int = 40, mesh: MeridianMeshParameters | None = None,
                          tolerance: float = DEFAULT_TOLERANCE, max_newton_iterations: int = 40,
                          solver: str = "auto", precision: str = "double",
                          resume_from: AxisymmetricResult | None = None,
                          on_row: Callable[[AxisymmetricResult], None] | None = None) -> AxisymmetricResult:
    """F(delta) between two rigid frictionless plates (lower at z = -1, upper at z = 1 - 2 delta), in the units
    of 3D compression: F/(E_c R^2) against delta, ``steps`` equal increments up to ``delta_max``. A cell not
    axisymmetric about z is refused (:class:`ParameterError`). ``resume_from``/``on_row``: continue an
    interrupted curve, a callback after every row (:func:`_curve`); Ctrl-C raises :class:`AxisymmetricInterrupted`."""
    if not 0 < delta_max < 1:
        raise ParameterError("delta_max", f"must be in (0, 1), got {delta_max}")
    if not 1 <= steps <= 100000:
        raise ParameterError("steps", f"must be in [1, 100000], got {steps}")
    cell = _cell(cell_parameters, mesh)
    obstacles = [Obstacle("lower", -1.0), Obstacle("upper", 1.0, velocity=-2.0)]
    return _curve(cell, obstacles, delta_max, steps, tolerance, max_newton_iterations, solver, precision,
                  resume_from=resume_from, on_row=on_row)


def indent_axisymmetric(cell_parameters: CellParameters | AxisymmetricCell, indenter_radius: float,
                        depth_max: float, steps: int = 20, mesh: MeridianMeshParameters | None = None,
                        tolerance: float = DEFAULT_TOLERANCE, max_newton_iterations: int = 40,
                        solver: str = "auto", precision: str = "double", geometry: MeridianGeometry | None = None,
                        on_row: Callable[[AxisymmetricResult], None] | None = None,
                        half_angle: float | None = None) -> AxisymmetricResult:
    """F(depth) of a rigid frictionless sphere of radius ``indenter_radius`` pressed on the axis into the body
    ``geometry`` (None: the sphere), starting in touch with its apex; depth is the sphere's displacement after
    first contact, the force F/(E_c L^2) on the sphere, L the geometry's length unit (R; a layer's R_b).
    With ``half_angle`` (radians) the indenter is a cone of that half-angle whose apex is rounded by a sphere of
    radius ``indenter_radius`` (:class:`Obstacle`), its tip touching the apex at depth 0.

    The sphere rests on a rigid frictionless dish at z = -1 (depth below 1 R); a cap or a layer is bonded to the
    dish at z = 0 (its base nodes held in r and z; depth below its height). ``on_row(result)`` after every
    converged row; an interruption raises :class:`AxisymmetricInterrupted` with the converged rows."""
    geometry = geometry or MeridianGeometry()
    if not indenter_radius > 0:
        raise ParameterError("indenter_radius", f"must be > 0 (units of R), got {indenter_radius}")
    reach = 1.0 if geometry.shape == "sphere" else geometry.height
    if not 0 < depth_max < reach:
        raise ParameterError("depth_max", f"must be in (0, {reach:g}) (the {geometry.shape}'s height), got "
                                          f"{depth_max:g}")
    cell = _cell(cell_parameters, mesh, geometry)
    if half_angle is not None and not 0 < half_angle < np.pi / 2:
        raise ParameterError("half_angle", f"must be in (0, 90) degrees, got {np.degrees(half_angle):g}")
    indenter = Obstacle("sphere" if half_angle is None else "cone", geometry.top + indenter_radius, velocity=-1.0,
                        radius=indenter_radius, half_angle=half_angle or 0.0)
    if geometry.shape == "sphere":
        obstacles = [Obstacle("lower", -1.0), indenter]
    else:
        obstacles = [indenter]
    return _curve(cell, obstacles, depth_max, steps, tolerance, max_newton_iterations, solver, precision,
                  bottom=geometry.bottom, height=geometry.top - geometry.bottom, on_row=on_row)


def hertz_half_space_force(depth, indenter_radius: float, poisson_ratio: float = 0.48):
    """Hertz's force of a rigid sphere (radius R_b) pressed to ``depth`` into an elastic half-space of modulus
    E = 1: F = 4/3 E/(1 - nu^2) sqrt(R_b) depth^(3/2)."""
    return 4 / (3 * (1 - poisson_ratio**2)) * np.sqrt(indenter_radius) * np.asarray(depth) ** 1.5


def sneddon_sphere_force(depth, indenter_radius: float, poisson_ratio: float = 0.48):
    """Sneddon's (1965) exact force of a rigid sphere (radius R_b, not Hertz's paraboloid) pressed to ``depth`` into
    a linear elastic half-space of modulus E = 1: with the contact radius a from
    depth = a/2 ln((R_b + a)/(R_b - a)), F = E/(2 (1 - nu^2)) [(a^2 + R_b^2) ln((R_b + a)/(R_b - a)) - 2 a R_b];
    Hertz's force to first order in depth/R_b, 5.0 % below it at depth R_b/2."""
    from scipy.optimize import brentq

    def force(d: float) -> float:
        relative = d / indenter_radius
        if relative <= 0:
            return 0.0
        if relative < 1e-6:  # the closed form cancels: its series, F (1 - nu^2)/R_b^2 = 4/3 x^3 + 8/15 x^5
            x = np.sqrt(relative * (1 - relative / 3))
            return (4 / 3 * x**3 + 8 / 15 * x**5) * indenter_radius**2 / (1 - poisson_ratio**2)
        x = brentq(lambda x: x * np.arctanh(x) - relative, 0.0, 1 - 1e-15, xtol=1e-15)
        return ((x**2 + 1) * 2 * np.arctanh(x) - 2 * x) * indenter_radius**2 / (2 * (1 - poisson_ratio**2))

    return np.vectorize(force, otypes=[float])(np.asarray(depth, float))


def sneddon_cone_force(depth, half_angle: float, poisson_ratio: float = 0.48):
    """Sneddon's force of a rigid cone of half-angle ``half_angle`` (radians) pressed to ``depth`` into an
    elastic half-space of modulus E = 1: F = 2/pi E/(1 - nu^2) tan(alpha) depth^2."""
    return 2 / (np.pi * (1 - poisson_ratio**2)) * np.tan(half_angle) * np.asarray(depth) ** 2


def hertz_sphere_indentation_depth(force, indenter_radius: float, poisson_ratio: float = 0.48, radius: float = 1.0):
    """Hertz's small-load depth of a rigid sphere (radius R_b) pressed into an elastic sphere (radius R, modulus
    E = 1) lying on a rigid flat: the two contacts in series, each d_i = (3 F / (4 E*))^(2/3) R_i^(-1/3), with
    E* = E / (1 - nu^2), R_1 = R_b R / (R_b + R) at the sphere and R_2 = R at the dish."""
    effective = indenter_radius * radius / (indenter_radius + radius)
    scale = (3 * np.asarray(force) * (1 - poisson_ratio**2) / 4) ** (2 / 3)
    return scale * (effective ** (-1 / 3) + radius ** (-1 / 3))


def hertz_sphere_indentation_force(depth, indenter_radius: float, poisson_ratio: float = 0.48, radius: float = 1.0):
    """The force of :func:`hertz_sphere_indentation_depth` at ``depth``:
    F = 4/(3(1 - nu^2)) (depth / (R_1^(-1/3) + R_2^(-1/3)))^(3/2)."""
    effective = indenter_radius * radius / (indenter_radius + radius)
    return 4 / (3 * (1 - poisson_ratio**2)) * (np.asarray(depth) / (effective ** (-1 / 3) + radius ** (-1 / 3))) ** 1.5
