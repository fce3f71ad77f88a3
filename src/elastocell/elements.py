"""Tetrahedral finite elements: shape-function gradients and quadrature.

Order 1: 4-node tetrahedron, one quadrature point (F constant per element: the paper's model).
Order 2: 10-node tetrahedron (VTK node order), the 4-point rule of degree 2 (exact for the mass matrix of
linear fields and for the volume of curved elements with affine-per-point Jacobians to the order needed).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .mesh import TET10_EDGES


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
    order = 1 if elements.shape[1] == 4 else 2
    gradients = _local_gradients(order, NODE_POINTS[: elements.shape[1]])
    return np.linalg.det(np.einsum("eki,qkj->eqij", nodes[elements], gradients))


def _barycentric_gradients() -> np.ndarray:
    return np.array([[-1.0, -1.0, -1.0], [1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])


def _local_gradients(order: int, points: np.ndarray) -> np.ndarray:
    grad_l = _barycentric_gradients()
    if order == 1:
        return np.broadcast_to(grad_l, (len(points), 4, 3)).copy()
    barycentric = np.column_stack([1 - points.sum(axis=1), points])
    corners = (4 * barycentric[:, :, None] - 1) * grad_l[None]
    a, b = TET10_EDGES[:, 0], TET10_EDGES[:, 1]
    edges = 4 * (barycentric[:, b, None] * grad_l[a][None] + barycentric[:, a, None] * grad_l[b][None])
    return np.concatenate([corners, edges], axis=1)


@lru_cache(maxsize=2)
def reference_element(order: int) -> ReferenceElement:
    if order == 1:
        points = np.array([[0.25, 0.25, 0.25]])
        weights = np.array([1 / 6])
    elif order == 2:
        a, b = 0.5854101966249685, 0.1381966011250105
        points = np.array([[b, b, b], [a, b, b], [b, a, b], [b, b, a]])
        weights = np.full(4, 1 / 24)
    else:
        raise ValueError(f"element order must be 1 or 2, got {order}")
    return ReferenceElement(order, points, weights, _local_gradients(order, points))
