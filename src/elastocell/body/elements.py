"""Tetrahedral finite elements: shape-function gradients and quadrature.

Order 1: 4-node tetrahedron, one quadrature point (F constant per element: the paper's model).
Order 2: 10-node tetrahedron (VTK node order). By default the 4-point rule of degree 2: it integrates the
small-strain stiffness exactly (the product of two linear gradients). At large strain the integrand is no
polynomial, and four points leave the element free to fold near a node without the energy seeing it: in a soft
layer crushed between a stiff nucleus and a plate, the discrete energy then descends into folded states. A rule
of higher degree (``quadrature_degree``) samples more of each element. The rule of degree 5 (25 points) contains
the element's ten nodes: a map folded at a node (J <= 0 there) has no finite energy, so no element folds at a
node (:func:`nodal_rule_25`). J can still turn negative between points, which the compression's check of nodes
beyond the plates catches when it matters there.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

TET10_EDGES = np.array([(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)])
"""Corner pairs of the six edges of a tetrahedron, in the order of the TET10 edge nodes 4-9 as the meshes store them
(VTK's order; gmsh's swaps nodes 8 and 9, ``mesh.GMSH_TO_VTK_TET10``)."""


@dataclass(frozen=True)
class ElementGeometry:
    """Per-element quadrature data in the reference configuration.

    shape_gradients: dN/dX, (n_elements, n_points, n_element_nodes, 3), units 1/R.
    weights: w_q det(dX/dxi), (n_elements, n_points): reference volume carried by each point (units R^3).
    """

    shape_gradients: np.ndarray
    weights: np.ndarray


@dataclass(frozen=True)
class ReferenceElement:
    order: int
    points: np.ndarray  # (n_points, 3) in the reference tetrahedron
    point_weights: np.ndarray  # (n_points,), summing to 1/6
    local_gradients: np.ndarray  # dN/dxi at the points, (n_points, n_nodes, 3)

    def geometry(self, nodes: np.ndarray, elements: np.ndarray) -> ElementGeometry:
        coordinates = nodes[elements]  # (e, k, 3)
        jacobian = np.einsum("eki,qkj->eqij", coordinates, self.local_gradients)  # dX/dxi
        determinant = np.linalg.det(jacobian)
        if (determinant <= 0).any():
            raise ValueError(
                f"mesh has {int((determinant <= 0).any(axis=1).sum())} element(s) with a non-positive Jacobian"
            )
        inverse = np.linalg.inv(jacobian)  # dxi/dX
        gradients = np.einsum("qkj,eqji->eqki", self.local_gradients, inverse)
        return ElementGeometry(shape_gradients=gradients, weights=determinant * self.point_weights)


NODE_POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0],
                        [0, 0, 0.5], [0.5, 0, 0.5], [0, 0.5, 0.5]], dtype=float)
"""The nodes of the reference tetrahedron in VTK order (corners, then edge midpoints); the first 4 for order 1."""


def nodal_jacobians(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """det(dx/dxi) of every element's map at its own nodes, (n_elements, n_element_nodes)."""
    return jacobian_determinants(nodes, elements, NODE_POINTS[: elements.shape[1]])


def jacobian_determinants(nodes: np.ndarray, elements: np.ndarray, points: np.ndarray) -> np.ndarray:
    """det(dx/dxi) of every element's map at ``points`` of the reference tetrahedron, (n_elements, n_points)."""
    order = 1 if elements.shape[1] == 4 else 2
    return np.linalg.det(np.einsum("eki,qkj->eqij", nodes[elements], local_gradients(order, points)))


def _barycentric_gradients() -> np.ndarray:
    return np.array([[-1.0, -1.0, -1.0], [1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])


def local_gradients(order: int, points: np.ndarray) -> np.ndarray:
    grad_l = _barycentric_gradients()
    if order == 1:
        return np.broadcast_to(grad_l, (len(points), 4, 3)).copy()
    barycentric = np.column_stack([1 - points.sum(axis=1), points])
    corners = (4 * barycentric[:, :, None] - 1) * grad_l[None]
    a, b = TET10_EDGES[:, 0], TET10_EDGES[:, 1]
    edges = 4 * (barycentric[:, b, None] * grad_l[a][None] + barycentric[:, a, None] * grad_l[b][None])
    return np.concatenate([corners, edges], axis=1)


DEFAULT_QUADRATURE_DEGREE = 2
"""Of 10-node elements: the 4-point rule."""
MAX_QUADRATURE_DEGREE = 9


@lru_cache(maxsize=8)
def reference_element(order: int, degree: int | None = None) -> ReferenceElement:
    """Shape-function gradients at the points of a quadrature rule exact to polynomial ``degree`` on the
    reference tetrahedron (None: :data:`DEFAULT_QUADRATURE_DEGREE`). Order 1 always uses its single centroid
    point: F is constant in a straight-sided linear element, so that rule is exact for any law."""
    if order not in (1, 2):
        raise ValueError(f"element order must be 1 or 2, got {order}")
    points, weights = quadrature_rule(1 if order == 1 else degree or DEFAULT_QUADRATURE_DEGREE)
    return ReferenceElement(order, points, weights, local_gradients(order, points))


def quadrature_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """(points, weights) on the unit tetrahedron {x, y, z >= 0, x + y + z <= 1}, weights summing to 1/6 and
    all positive, exact for polynomials up to ``degree`` (1 to :data:`MAX_QUADRATURE_DEGREE`):

    - degree 1: the centroid; degree 2: 4 points (Hammer, Marlowe and Stroud 1956);
    - degree 4-5: 25 points that include the element's ten nodes (:func:`nodal_rule_25`);
    - otherwise the conical (collapsed Gauss-Jacobi) product rule of Stroud (1971) with n = ceil((degree+1)/2)
      points per direction, n^3 points, exact to degree 2n - 1 (8 points for degree 3, 64 for 6-7)."""
    if not 1 <= degree <= MAX_QUADRATURE_DEGREE:
        raise ValueError(f"quadrature degree must be in [1, {MAX_QUADRATURE_DEGREE}], got {degree}")
    if degree == 1:
        return np.array([[0.25, 0.25, 0.25]]), np.array([1 / 6])
    if degree == 2:
        a, b = 0.5854101966249685, 0.1381966011250105
        return np.array([[b, b, b], [a, b, b], [b, a, b], [b, b, a]]), np.full(4, 1 / 24)
    if degree in (4, 5):
        return nodal_rule_25()
    return conical_product_rule((degree + 2) // 2)


NODAL_RULE_ORBITS = (0.3283735500, 0.1111019300, 0.0913561900)
"""Parameters of the three free orbits of :func:`nodal_rule_25` (barycentric (a, a, a, 1 - 3a) twice and
(b, b, 1/2 - b, 1/2 - b)), found by a search for positive weights with a small weight at the corners."""


@lru_cache(maxsize=1)
def nodal_rule_25() -> tuple[np.ndarray, np.ndarray]:
    """A positive 25-point rule exact to degree 5 whose points include the ten nodes of the 10-node tetrahedron:
    the 4 corners (0.93 % of the volume in all), the 6 edge midpoints (8.9 %), the centroid (12.9 %) and the
    orbits of :data:`NODAL_RULE_ORBITS` (24.1 %, 37.8 %, 15.4 %). Its weights solve the six moment equations of
    the polynomials invariant under the tetrahedron's symmetries up to degree 5 (1, p2, p3, p4, p2^2, p2 p3 in the
    power sums p_k of the barycentric coordinates), which makes it exact for every polynomial of degree 5.

    Why the nodes: the energy density is undefined where J <= 0, so with the nodes among the points a state in
    which an element folds at a node has no finite energy and the line search refuses it, as for an inverted
    element; with interior points only (the 14-point rule of Walkington 2000, which this replaced) the same
    curve (stiffness ratio 20, default mesh) folded from delta = 0.656 on and stopped at 0.7105."""
    a1, a2, b = NODAL_RULE_ORBITS

    def orbit4(a):
        return [np.where(np.arange(4) == k, 1 - 3 * a, a) for k in range(4)]

    def orbit6(c):
        return [np.where(np.isin(np.arange(4), pair), c, 0.5 - c) for pair in itertools.combinations(range(4), 2)]

    orbits = [list(np.eye(4)), orbit6(0.5), [np.full(4, 0.25)], orbit4(a1), orbit4(a2), orbit6(b)]

    def invariants(barycentric):
        p2, p3, p4 = ((barycentric**k).sum(axis=-1) for k in (2, 3, 4))
        return np.stack([np.ones_like(p2), p2, p3, p4, p2**2, p2 * p3], axis=-1)

    exact_points, exact_weights = conical_product_rule(4)  # exact to degree 7
    moments = 6 * exact_weights @ invariants(np.column_stack([1 - exact_points.sum(axis=1), exact_points]))
    system = np.stack([invariants(orbit[0]) for orbit in orbits], axis=1)
    orbit_weights = np.linalg.solve(system, moments)  # fraction of the volume carried by each orbit
    barycentric = np.array([point for orbit in orbits for point in orbit])
    weights = np.concatenate([np.full(len(orbit), w / (6 * len(orbit))) for orbit, w in zip(orbits, orbit_weights,
                                                                                             strict=True)])
    return _read_only(barycentric[:, 1:]), _read_only(weights)


def _read_only(array: np.ndarray) -> np.ndarray:
    """A cached rule is shared by every caller: make it immutable."""
    array.flags.writeable = False
    return array


@lru_cache(maxsize=4)
def conical_product_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Stroud's conical (collapsed Gauss-Jacobi) product rule on the unit tetrahedron: (points (n^3, 3),
    weights (n^3,), positive, summing to 1/6), exact to degree 2n - 1."""
    from scipy.special import roots_jacobi

    def gauss_jacobi(alpha: int):  # on [0, 1] with weight (1 - t)^alpha
        t, w = roots_jacobi(n, alpha, 0)
        return (t + 1) / 2, w / 2 ** (alpha + 1)

    (x, wx), (s, ws), (t, wt) = gauss_jacobi(2), gauss_jacobi(1), gauss_jacobi(0)
    x, s, t = np.meshgrid(x, s, t, indexing="ij")
    points = np.stack([x, s * (1 - x), t * (1 - x) * (1 - s)], axis=-1).reshape(-1, 3)
    weights = (wx[:, None, None] * ws[None, :, None] * wt[None, None, :]).ravel()
    return _read_only(points), _read_only(weights)


VOLUMETRIC_TREATMENTS = ("standard", "projected", "mean", "nodal")
"""How J enters the law (``MeshParameters.volumetric``): as det F at each point; for a p2 element L2-projected onto
the linear polynomials of the element (P1, discontinuous) or onto the constants (P0, mean dilatation); for p1
elements averaged per node (the volumetric part of the law per node, ``Cell.nodal_reference_volumes``)."""


def dilatation_projections(treatment: str, points: np.ndarray, weights: np.ndarray) -> np.ndarray | None:
    """Per-element matrices P_e (n_elements, n_points, n_points) with J_bar = P_e J at the quadrature points:
    the L2 projection, weighted by the points' reference volumes ``weights`` (n_elements, n_points), onto the
    polynomials in the reference coordinates ``points`` (n_points, 3) of degree 1 (``projected``) or 0
    (``mean``); None for ``standard``. Exact per element, curved ones included; a J that is such a polynomial
    (a uniform deformation: a constant) is its own projection. None for ``nodal`` too: its J is not projected
    within an element."""
    if treatment in ("standard", "nodal"):
        return None
    if treatment not in VOLUMETRIC_TREATMENTS:
        raise ValueError(f"volumetric treatment must be one of {VOLUMETRIC_TREATMENTS}, got {treatment!r}")
    basis = np.ones((len(points), 1)) if treatment == "mean" else np.column_stack([np.ones(len(points)), points])
    mass = np.einsum("qa,eq,qb->eab", basis, weights, basis)  # (e, m, m)
    moments = np.einsum("ra,er->ear", basis, weights)  # (e, m, q)
    return np.einsum("qa,ear->eqr", basis, np.linalg.solve(mass, moments))
