"""Shape and motion observables of a deformed tetrahedral cell (docs/theory.md, "Shear flow").

All integrals are exact over the elements of the mesh in their deformed configuration ``x``:

* order 1 (4-node tetrahedra): closed forms, ``V = det[x1-x0, x2-x0, x3-x0]/6``,
  ``int x dV = V (x0+x1+x2+x3)/4`` and ``int x x^T dV = V/20 (sum_a x_a x_a^T + s s^T)``, ``s = sum_a x_a``;
* order 2 (10-node tetrahedra, curved): quadrature of the quadratic element map, whose Jacobian is a
  cubic polynomial, so ``x x^T det J`` has degree 7; a 4x4x4 collapsed (Stroud conical) Gauss-Jacobi rule,
  exact to degree 7 on the tetrahedron, integrates volume, centroid and second moments exactly.

The equivalent ellipsoid is the uniform ellipsoid with the same second-moment ("volume inertia") tensor
``M = int (x - c)(x - c)^T dV``: for semi-axes a >= b >= c, ``M`` has eigenvalues ``(4 pi/15) abc (a^2, b^2,
c^2)``. Taylor deformation ``D = (a - c)/(a + c)`` depends only on the ratio of the extreme eigenvalues.
Units follow the input (units of R for the cell model's coordinates).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from elastocell.body.elements import TET10_EDGES, conical_product_rule, local_gradients

FOUR_PI_OVER_15 = 4.0 * np.pi / 15.0


# --------------------------------------------------------------------------- quadrature (order 2)
@lru_cache(maxsize=4)
def _tet10_tables(points_per_direction: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(shape functions N (q, 10), local gradients dN/dxi (q, 10, 3), weights (q,)) for TET10, VTK order."""
    points, weights = conical_product_rule(points_per_direction)
    lam = np.column_stack([1 - points.sum(axis=1), points])  # barycentric (q, 4)
    a, b = TET10_EDGES[:, 0], TET10_EDGES[:, 1]
    shape = np.concatenate([lam * (2 * lam - 1), 4 * lam[:, a] * lam[:, b]], axis=1)
    return shape, local_gradients(2, points), weights


# --------------------------------------------------------------------------- moments
@dataclass(frozen=True)
class Moments:
    """Zeroth, first and second moments of a body.

    volume: V = int dV; centre: c = (1/V) int x dV; second_moment: M = int (x - c)(x - c)^T dV (3, 3).
    """

    volume: float
    centre: np.ndarray
    second_moment: np.ndarray


def element_moments(x: np.ndarray, elements: np.ndarray, origin=None,
                    points_per_direction: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per element: volume (e,), int (x - o) dV (e, 3), int (x - o)(x - o)^T dV (e, 3, 3), exact.

    x: (n_nodes, 3) deformed positions; elements: (e, 4) or (e, 10) (VTK order); o = origin (default 0).
    points_per_direction: of the order-2 rule (4 is exact; more only to check that)."""
    x = np.asarray(x, dtype=np.float64)
    if origin is not None:
        x = x - np.asarray(origin, dtype=np.float64)
    coordinates = x[elements]  # (e, k, 3)
    if elements.shape[1] == 4:
        edges = coordinates[:, 1:] - coordinates[:, :1]
        volume = np.linalg.det(edges) / 6.0
        total = coordinates.sum(axis=1)
        first = volume[:, None] * total / 4.0
        second = (volume / 20.0)[:, None, None] * (
            np.einsum("eki,ekj->eij", coordinates, coordinates) + total[:, :, None] * total[:, None, :]
        )
        return volume, first, second
    if elements.shape[1] != 10:
        raise ValueError(f"elements must have 4 or 10 nodes, got {elements.shape[1]}")
    shape, gradients, weights = _tet10_tables(points_per_direction)
    jacobian = np.einsum("eki,qkj->eqij", coordinates, gradients)
    dv = np.linalg.det(jacobian) * weights  # (e, q)
    points = np.einsum("qk,eki->eqi", shape, coordinates)
    volume = dv.sum(axis=1)
    first = np.einsum("eq,eqi->ei", dv, points)
    second = np.einsum("eq,eqi,eqj->eij", dv, points, points)
    return volume, first, second


def moments(x: np.ndarray, elements: np.ndarray, mask: np.ndarray | None = None) -> Moments:
    """Volume, centroid and second-moment tensor of the (sub)body made of ``elements[mask]``."""
    x = np.asarray(x, dtype=np.float64)
    if mask is not None:
        elements = elements[np.asarray(mask)]
    origin = x[np.unique(elements[:, :4])].mean(axis=0)  # shift first: no cancellation in M
    volume, first, second = element_moments(x, elements, origin)
    v = float(volume.sum())
    mean = first.sum(axis=0) / v
    m = second.sum(axis=0) - v * np.outer(mean, mean)
    return Moments(volume=v, centre=origin + mean, second_moment=0.5 * (m + m.T))


def volume(x: np.ndarray, elements: np.ndarray) -> float:
    """Exact volume of the deformed mesh (units of the coordinates cubed)."""
    return float(element_moments(x, elements)[0].sum())


# --------------------------------------------------------------------------- ellipsoid and shape
@dataclass(frozen=True)
class Ellipsoid:
    """The uniform ellipsoid with the body's second-moment tensor.

    semi_axes: (a, b, c), descending; axes: (3, 3) unit vectors, column k along semi-axis k; centre (3,).
    """

    semi_axes: np.ndarray
    axes: np.ndarray
    centre: np.ndarray

    @property
    def taylor_deformation(self) -> float:
        """D = (a - c)/(a + c), largest and smallest semi-axes."""
        a, c = self.semi_axes[0], self.semi_axes[-1]
        return float((a - c) / (a + c))


def equivalent_ellipsoid(m: Moments) -> Ellipsoid:
    """Semi-axes from the eigenvalues m_k of M: abc = (m1 m2 m3 / (4 pi/15)^3)^(1/5),
    a_k = sqrt(m_k / ((4 pi/15) abc))."""
    values, vectors = np.linalg.eigh(m.second_moment)
    order = np.argsort(values)[::-1]
    values, vectors = np.clip(values[order], 0.0, None), vectors[:, order]
    product = (np.prod(values) / FOUR_PI_OVER_15**3) ** 0.2
    semi_axes = np.sqrt(values / (FOUR_PI_OVER_15 * product)) if product > 0 else np.zeros(3)
    return Ellipsoid(semi_axes=semi_axes, axes=vectors, centre=m.centre)


def taylor_deformation(x: np.ndarray, elements: np.ndarray) -> float:
    """D = (a - c)/(a + c) of the inertia-equivalent ellipsoid (docs/theory.md)."""
    return equivalent_ellipsoid(moments(x, elements)).taylor_deformation


def inclination_deg(second_moment: np.ndarray, plane: tuple[int, int] = (0, 1)) -> float:
    """Inclination (degrees, in (-90, 90]) of the long axis within a plane, relative to its first axis.

    The long axis is the principal direction of the in-plane 2x2 block of M (for a tank-treading cell the
    vorticity axis is a principal axis, so this is the projection of the longest axis); for shear flow with
    u_x = shear_rate * y the plane is (x, y) and the angle is measured from the flow direction x towards +y
    (45 degrees at small Ca)."""
    i, j = plane
    mxx, myy, mxy = second_moment[i, i], second_moment[j, j], second_moment[i, j]
    angle = 0.5 * np.degrees(np.arctan2(2.0 * mxy, mxx - myy))
    return float(angle if angle > -90.0 else angle + 180.0)


@dataclass(frozen=True)
class ShapeObservables:
    """One snapshot: volume V, centre (3,), semi-axes (a, b, c), Taylor deformation D, inclination (deg),
    nucleus centre (3,) or None, second moment M about the centre (3, 3)."""

    volume: float
    centre: np.ndarray
    semi_axes: np.ndarray
    taylor_deformation: float
    inclination_deg: float
    nucleus_centre: np.ndarray | None
    second_moment: np.ndarray | None = None


def shape_observables(x: np.ndarray, elements: np.ndarray, nucleus_mask: np.ndarray | None = None,
                      plane: tuple[int, int] = (0, 1)) -> ShapeObservables:
    """All shape observables of a deformed mesh in one pass (coordinates in any unit, e.g. R)."""
    m = moments(x, elements)
    ellipsoid = equivalent_ellipsoid(m)
    nucleus_centre = None
    if nucleus_mask is not None and np.any(nucleus_mask):
        nucleus_centre = moments(x, elements, nucleus_mask).centre
    return ShapeObservables(
        volume=m.volume,
        centre=m.centre,
        semi_axes=ellipsoid.semi_axes,
        taylor_deformation=ellipsoid.taylor_deformation,
        inclination_deg=inclination_deg(m.second_moment, plane),
        nucleus_centre=nucleus_centre,
        second_moment=m.second_moment,
    )


# --------------------------------------------------------------------------- projected outline
OUTLINE_DEGREE = 6
"""Largest degree of the spherical-harmonic surface behind :func:`smooth_outline` (49 functions). Measured on the
pipe_dclab runs' last states at R/dx 8 (validation/pipe_contour.py): degrees 6 to 10 agree within 3-7 % in D,
degree 4 reads up to 25 % less on the bullet shapes (D ~ 0.05), too smooth."""

OUTLINE_SAMPLES = 256
"""Longitudes of the dense reference grid of :func:`smooth_outline` (half as many latitudes, poles included)."""

OUTLINE_MAX_AREA_RATIO = 1.1
"""Largest ratio of the area of :func:`smooth_outline` to that of the convex hull of the projected nodes it trusts.
The nodes' hull lies inside the true outline and, for the meshes of the flow scenarios, within a few percent of
it (2.2 % short at rest at R/dx 6, 4.5 % at R/dx 4). A surface that is not star-shaped from the centre (a cup, a
parachute: a ray crosses it twice) is no radial function, and its fit leaves that band: measured on cup-shaped
test cells (rear pole pushed forward), an area 12x the true one on the coarse mesh and below the nodes' hull on
a finer one. Outside [1, this] x the nodes' hull, the outline is the nodes' hull."""


def harmonic_basis(directions: np.ndarray, degree: int) -> np.ndarray:
    """(n, (degree+1)^2) basis of the polynomials of degree <= ``degree`` restricted to the unit sphere (the span of
    the spherical harmonics of degree <= ``degree``): the monomials X^a Y^b Z^c, c in {0, 1}, a + b + c <= degree
    (Z^2 = 1 - X^2 - Y^2 on the sphere makes higher powers of Z redundant). directions: (n, 3) unit vectors."""
    d = np.asarray(directions, dtype=np.float64)
    powers = [(a, b, c) for c in (0, 1) for a in range(degree + 1) for b in range(degree + 1 - a - c)]
    return np.stack([d[:, 0] ** a * d[:, 1] ** b * d[:, 2] ** c for a, b, c in powers], axis=1)


@lru_cache(maxsize=2)
def sphere_grid(samples: int = OUTLINE_SAMPLES) -> np.ndarray:
    """Unit vectors of a longitude-latitude grid: ``samples`` longitudes, samples/2 + 1 latitudes (the equator and
    both poles among them), (n, 3)."""
    phi = np.linspace(0.0, 2.0 * np.pi, samples, endpoint=False)
    theta = np.linspace(0.0, np.pi, samples // 2 + 1)
    st = np.sin(theta)[:, None]
    return np.stack([(st * np.cos(phi)).ravel(), (st * np.sin(phi)).ravel(), np.repeat(np.cos(theta), samples)],
                    axis=1)


@lru_cache(maxsize=4)
def grid_basis(samples: int, degree: int) -> np.ndarray:
    """:func:`harmonic_basis` on :func:`sphere_grid` (cached, read-only)."""
    out = harmonic_basis(sphere_grid(samples), degree)
    out.setflags(write=False)
    return out


def smooth_outline(x_surface: np.ndarray, centre: np.ndarray | None = None, plane: tuple[int, int] = (0, 1),
                   degree: int = OUTLINE_DEGREE, samples: int = OUTLINE_SAMPLES) -> tuple[float, float]:
    """(area, perimeter) of :func:`smooth_outline_checked` (the smooth outline, or the nodes' hull where the fit
    is not trusted)."""
    area, perimeter, _ = smooth_outline_checked(x_surface, centre, plane, degree, samples)
    return area, perimeter


def fitted_surface(x_surface: np.ndarray, centre: np.ndarray | None = None, degree: int = OUTLINE_DEGREE,
                   samples: int = OUTLINE_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """(points, centre): the smooth surface of :func:`smooth_outline_checked` (the radial function about ``centre``
    fitted through the nodes by least squares) evaluated on the dense grid :func:`sphere_grid`, (n, 3), and the
    centre used (default: the middle of the nodes' bounding box)."""
    x = np.asarray(x_surface, dtype=np.float64)
    centre = 0.5 * (x.min(axis=0) + x.max(axis=0)) if centre is None else np.asarray(centre, dtype=np.float64)
    offsets = x - centre
    radii = np.linalg.norm(offsets, axis=1)
    degree = min(int(degree), int(math.isqrt(len(x) // 2)) - 1)
    if degree < 1:
        raise ValueError(f"{len(x)} surface nodes cannot fix a smooth surface (at least 8 are needed)")
    basis = harmonic_basis(offsets / radii[:, None], degree)
    coefficients = np.linalg.lstsq(basis, radii, rcond=None)[0]
    return (grid_basis(samples, degree) @ coefficients)[:, None] * sphere_grid(samples) + centre, centre


def fitted_outline_hull(x_surface: np.ndarray, centre: np.ndarray | None = None, plane: tuple[int, int] = (0, 1),
                        degree: int = OUTLINE_DEGREE, samples: int = OUTLINE_SAMPLES):
    """The convex hull (``scipy.spatial.ConvexHull``, 2D: ``volume`` is the area, ``area`` the perimeter) of the
    projected radial fit of :func:`smooth_outline_checked`, without its guard: what the fit alone reads."""
    from scipy.spatial import ConvexHull  # lazy: qhull only where an outline is measured

    points, _ = fitted_surface(x_surface, centre, degree, samples)
    return ConvexHull(np.ascontiguousarray(points[:, list(plane)]))


def _guarded_outline(fitted_2d: np.ndarray, nodes_2d: np.ndarray) -> tuple[float, float, bool]:
    """(area, perimeter, fitted) of one projection: the hull of the fitted surface's projection, or the nodes' own
    hull where the fit's area leaves [1, :data:`OUTLINE_MAX_AREA_RATIO`] x theirs."""
    from scipy.spatial import ConvexHull  # lazy: qhull only where an outline is measured

    hull = ConvexHull(np.ascontiguousarray(fitted_2d))
    nodes = ConvexHull(np.ascontiguousarray(nodes_2d))
    if not nodes.volume <= hull.volume <= OUTLINE_MAX_AREA_RATIO * nodes.volume:
        return float(nodes.volume), float(nodes.area), False  # not star-shaped from the centre: the nodes' own hull
    return float(hull.volume), float(hull.area), True  # 2D: volume = area, area = perimeter


def smooth_outline_checked(x_surface: np.ndarray, centre: np.ndarray | None = None, plane: tuple[int, int] = (0, 1),
                           degree: int = OUTLINE_DEGREE, samples: int = OUTLINE_SAMPLES) -> tuple[float, float, bool]:
    """(area, perimeter) of the outline of a star-shaped surface projected on ``plane``, through a smooth surface
    fitted to its nodes rather than the polygon of the nodes.

    The surface nodes sample a smooth surface; the convex hull of the nodes alone is a polygon inscribed in its
    outline (for a sphere meshed with edge h, 1 - circularity ~ h^2 and the area short by ~h^2). Here the surface
    is the radial function r(n) about a centre c, n = (x - c)/|x - c|, fitted by least squares over the
    nodes as a polynomial of degree <= ``degree`` in n (:func:`harmonic_basis`: the spherical harmonics of degree
    <= ``degree``); it depends on the shape alone, not on where the material points slid along it. The fitted
    surface c + r(n) n is evaluated on a dense grid of directions (:func:`sphere_grid`) and the outline is the
    convex hull of its projection. Nodes on a sphere give r = const exactly, so the outline differs from the
    circle only by the grid's sampling, ~ (pi/samples)^2.

    x_surface: (n, 3) positions of the surface nodes. degree: at most this, lowered to the largest whose
    (degree + 1)^2 functions number at most half the nodes (least squares, not interpolation; 146 nodes, the
    R/dx 6 cell's, take 6; 48 take 3); fewer than 8 nodes are refused. centre: a point from which
    the surface is star-shaped, e.g. the body's volume centroid (default: the middle of the nodes' bounding box;
    not their mean, which the material sliding along the surface moves). A surface the radial fit cannot follow
    (:data:`OUTLINE_MAX_AREA_RATIO`) gets the convex hull of its projected nodes instead; the third value is False
    then (the outline is that hull, not the fit). The switch is discontinuous in D: a flow cell whose rear flattens
    to a rim the degree-6 fit rounds off (fit 1.3 % inside the hull) read D 0.056 by the fit and 0.082-0.100 by
    the hull, whose perimeter keeps the mesh-scale roughness (validation/pipe_resolution.py)."""
    x = np.asarray(x_surface, dtype=np.float64)
    points, _ = fitted_surface(x, centre, degree, samples)
    return _guarded_outline(points[:, list(plane)], x[:, list(plane)])


OUTLINE_VIEWS = 6
"""Side views about the channel axis that :func:`side_views_outline` averages: azimuths k pi/6, k = 0..5 (view 0 is
the x-y plane, the pipe's own side view along z). A centred cell's continuum shape is axisymmetric, so every view
reads the same D; the discrete cell's mesh makes it slightly non-axisymmetric, and one view reads one azimuth of
that. Measured on the last states of pipe runs at R/dx 8 (validation/pipe_orientation.py, docs/validation/
pipe_dclab.md): D differs by 3-10 % between views. Extrapolated from R/dx 6 and 8, the mean over six views came
within 10 % of LE-2D-FEM-19 in D and area at every pair read on the smooth outline (two cells, R/R_ch 0.55 and
0.70, the first also at t = 16 in four orientations, not yet stationary there), one view at half of them; in the
square duct the same extrapolation reads E 7-17 % above HE-3D-FEM-22 (docs/validation/lut_square.md)."""


def side_view_coordinates(points: np.ndarray, centre: np.ndarray, views: int = OUTLINE_VIEWS) -> list[np.ndarray]:
    """The (n, 2) coordinates of ``points`` in each of ``views`` side views about the x axis through ``centre``:
    (x - c_x, (y - c_y) cos phi + (z - c_z) sin phi), phi = k pi/views (view 0 is the x-y plane, shifted)."""
    offsets = np.asarray(points, dtype=np.float64) - np.asarray(centre, dtype=np.float64)
    return [np.stack([offsets[:, 0], offsets[:, 1] * math.cos(phi) + offsets[:, 2] * math.sin(phi)], axis=1)
            for phi in np.arange(views) * math.pi / views]


def circularity_deformation(area: float, perimeter: float) -> float:
    """RT-DC's deformation 1 - circularity, circularity = 2 sqrt(pi A)/P of an outline of area A and perimeter
    P."""
    return 1.0 - 2.0 * math.sqrt(math.pi * area) / perimeter


def side_view_readings(x_surface: np.ndarray, centre: np.ndarray | None = None, views: int = OUTLINE_VIEWS,
                       degree: int = OUTLINE_DEGREE, samples: int = OUTLINE_SAMPLES) -> list[tuple[float, float, bool]]:
    """(area, perimeter, fitted) of the outline of :func:`smooth_outline_checked` seen from each of ``views`` side
    views about the x axis through ``centre`` (:func:`side_view_coordinates`): the same fitted surface, projected
    on each view's plane, each projection guarded as :func:`smooth_outline_checked` guards its one (the nodes' hull
    where the fit is not trusted). View 0 is :func:`smooth_outline_checked`'s own (the x-y plane)."""
    x = np.asarray(x_surface, dtype=np.float64)
    points, centre = fitted_surface(x, centre, degree, samples)
    return [_guarded_outline(fit, nodes) for fit, nodes in zip(side_view_coordinates(points, centre, views),
                                                                  side_view_coordinates(x, centre, views),
                                                                  strict=True)]


def mean_side_view(readings: list[tuple[float, float, bool]]) -> tuple[float, float, int]:
    """(mean area, mean deformation, views on the nodes' hull) of :func:`side_view_readings`: the mean over the
    views read on the smooth outline (a view on the nodes' hull reads D biased high by the mesh-scale roughness,
    0.076-0.079 against 0.054-0.058 for the fitted views of one pipe cell), over all views only where none is.
    Deformation: 1 - circularity of each view, then averaged (:data:`OUTLINE_VIEWS` says why)."""
    fitted = [r for r in readings if r[2]] or readings
    return (float(np.mean([area for area, _, _ in fitted])),
            float(np.mean([circularity_deformation(area, perimeter) for area, perimeter, _ in fitted])),
            sum(not ok for _, _, ok in readings))


def side_views_outline(x_surface: np.ndarray, centre: np.ndarray | None = None, views: int = OUTLINE_VIEWS,
                       degree: int = OUTLINE_DEGREE, samples: int = OUTLINE_SAMPLES) -> tuple[float, float, int]:
    """(mean area, mean deformation, views read on the nodes' hull) over ``views`` side views about the x axis
    through ``centre``: :func:`mean_side_view` of :func:`side_view_readings`."""
    return mean_side_view(side_view_readings(x_surface, centre, views, degree, samples))


ELEMENT_OUTLINE_SUBDIVISIONS = 16
"""Subdivisions of each edge of a quadratic surface triangle in :func:`element_surface_outline` (153 points per
triangle): the chord between two samples lies within ~ kappa (h/16)^2/8 of the curved edge, 6e-5 R for an edge of
0.35 R on the unit sphere. Measured on the unit sphere's p2 flow mesh: D 1.5e-5 and area -0.021 % (8
subdivisions: 5.9e-5 and -0.046 %), some 3-8 ms per outline."""


@lru_cache(maxsize=2)
def _triangle6_samples(subdivisions: int) -> np.ndarray:
    """(n_samples, 6) values of the 6-node triangle's shape functions (corners L_i (2 L_i - 1), edge nodes
    4 L_i L_j, in the order c0 c1 c2, c0-c1, c1-c2, c2-c0) on the barycentric grid of ``subdivisions`` per edge."""
    n = int(subdivisions)
    a, b = np.array([(i / n, j / n) for i in range(n + 1) for j in range(n + 1 - i)]).T
    lam = np.stack([1.0 - a - b, a, b], axis=1)
    out = np.concatenate([lam * (2.0 * lam - 1.0),
                          4.0 * lam[:, [0, 1, 2]] * lam[:, [1, 2, 0]]], axis=1)
    out.setflags(write=False)
    return out


def element_surface_outline(x: np.ndarray, triangles: np.ndarray, plane: tuple[int, int] = (0, 1),
                            subdivisions: int = ELEMENT_OUTLINE_SUBDIVISIONS) -> tuple[float, float]:
    """(area, perimeter) of the convex hull of a surface of 6-node (quadratic) triangles projected on ``plane``:
    the outline of the body the quadratic elements describe, their curved faces included, as RT-DC measures the
    convex contour.

    Quadratic elements carry their own curved surface, so no smoothing is needed (:func:`smooth_outline` is for
    the flat facets of linear elements): the unit sphere's p2 flow mesh gives an area 0.02 % short and
    1 - circularity 1.5e-5 (tests/test_outline.py). The degree-6 fit through the same nodes rounds off the rim a
    quadratic cell forms at its rear in the pipe, and then either reads D low or falls back to the nodes' hull
    from one record to the next: on the last states of two sets of eleven quadratic pipe runs (R/dx 6 and 8),
    this outline and the nodes' hull agree within 3.2 % in D, while the fit read 7-19 % below this outline or
    fell back to the hull (on 10 and on 5 of the 11). Like the nodes' hull, this outline keeps the node-scale
    roughness a cell takes in flow: at small deformation (Ca_w 0.1-0.2) it read twice the fit's D (0.0017
    against 0.0007), a difference the fit's degree (4-8) does not change; which of the two the converged
    shape supports is not settled.

    x: (n_nodes, 3) positions; triangles: (n_faces, 6) node indices
    (:func:`elastocell.body.mesh.outer_surface_triangles`)."""
    from scipy.spatial import ConvexHull  # lazy: qhull only where an outline is measured

    points = element_surface_points(np.asarray(x, dtype=np.float64)[:, list(plane)], triangles, subdivisions)
    hull = ConvexHull(np.ascontiguousarray(points))
    return float(hull.volume), float(hull.area)  # 2D: volume = area, area = perimeter


def element_surface_points(x: np.ndarray, triangles: np.ndarray,
                           subdivisions: int = ELEMENT_OUTLINE_SUBDIVISIONS) -> np.ndarray:
    """Points of a surface of 6-node (quadratic) triangles: the barycentric grid of ``subdivisions`` per edge on
    each, mapped by its shape functions, (n_faces x samples, d) for positions ``x`` of dimension d."""
    triangles = np.asarray(triangles)
    if triangles.ndim != 2 or triangles.shape[1] != 6:
        raise ValueError(f"element_surface_outline takes 6-node triangles, got shape {triangles.shape}")
    corners = np.asarray(x, dtype=np.float64)[triangles]  # (n_faces, 6, d)
    return np.einsum("sk,fkd->fsd", _triangle6_samples(subdivisions), corners).reshape(-1, corners.shape[-1])


def element_side_view_readings(x: np.ndarray, triangles: np.ndarray, centre: np.ndarray,
                               views: int = OUTLINE_VIEWS,
                               subdivisions: int = ELEMENT_OUTLINE_SUBDIVISIONS) -> list[tuple[float, float, bool]]:
    """(area, perimeter, True) of :func:`element_surface_outline` seen from each of ``views`` side views about the
    x axis through ``centre`` (:func:`side_view_coordinates`; view 0 is its own, the x-y plane)."""
    from scipy.spatial import ConvexHull  # lazy: qhull only where an outline is measured

    hulls = [ConvexHull(np.ascontiguousarray(view)) for view in
             side_view_coordinates(element_surface_points(x, triangles, subdivisions), centre, views)]
    return [(float(h.volume), float(h.area), True) for h in hulls]  # 2D: volume = area, area = perimeter


def element_side_views_outline(x: np.ndarray, triangles: np.ndarray, centre: np.ndarray,
                               views: int = OUTLINE_VIEWS,
                               subdivisions: int = ELEMENT_OUTLINE_SUBDIVISIONS) -> tuple[float, float]:
    """(mean area, mean deformation) of :func:`element_side_view_readings` (:data:`OUTLINE_VIEWS` says why)."""
    area, deformation, _ = mean_side_view(element_side_view_readings(x, triangles, centre, views, subdivisions))
    return area, deformation


# --------------------------------------------------------------------------- tank treading
def inplane_angles(x: np.ndarray, centre: np.ndarray, plane: tuple[int, int] = (0, 1),
                   second_moment: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """In-plane angle of every point about ``centre`` and its squared in-plane distance.

    Without ``second_moment``: the polar angle atan2(r_y, r_x). With the body's second moment M (3, 3): the
    angle theta + phi, theta the in-plane long-axis angle of M and phi = atan2(v/b, u/a) the phase of the point
    in the principal frame scaled by the in-plane semi-axes (a, b proportional to the square roots of the
    eigenvalues of M's in-plane block). A point tank-treading on an ellipse, x = a cos(omega t), advances its
    phase uniformly at omega, whereas its polar angle does not (its r^2-weighted rate is 2ab/(a^2+b^2) omega);
    for a circle or a rigid rotation both angles agree."""
    i, j = plane
    r = np.asarray(x) - np.asarray(centre)
    radius2 = r[:, i] ** 2 + r[:, j] ** 2
    if second_moment is None:
        return np.arctan2(r[:, j], r[:, i]), radius2
    block = np.asarray(second_moment)[np.ix_([i, j], [i, j])]
    eigenvalues, vectors = np.linalg.eigh(block)  # ascending
    long_axis, short_axis = vectors[:, 1], np.array([-vectors[1, 1], vectors[0, 1]])  # short = long rotated +90
    theta = np.arctan2(long_axis[1], long_axis[0])
    planar = np.column_stack([r[:, i], r[:, j]])
    u = planar @ long_axis / np.sqrt(max(eigenvalues[1], 1e-300))
    v = planar @ short_axis / np.sqrt(max(eigenvalues[0], 1e-300))
    return theta + np.arctan2(v, u), radius2


class RotationTracker:
    """Unwrapped in-plane angles of material points (e.g. the surface nodes) about the cell centre.

    Call :meth:`record` with the time (e.g. strain = shear_rate * t) and the positions; consecutive
    records must be less than half a revolution apart. :meth:`angular_velocity` fits the mean angular
    velocity of the points over a time window."""

    def __init__(self, plane: tuple[int, int] = (0, 1)):
        self.plane = plane
        self.times: list[float] = []
        self._angles: list[np.ndarray] = []
        self._radii2: list[np.ndarray] = []

    def record(self, time: float, x: np.ndarray, centre: np.ndarray, second_moment: np.ndarray | None = None) -> None:
        """Add a record; with the body's ``second_moment`` the angles are ellipse phases (see
        :func:`inplane_angles`), which advance uniformly for tank treading."""
        angle, radius2 = inplane_angles(x, centre, self.plane, second_moment)
        if self._angles:
            previous = self._angles[-1]
            angle = previous + (angle - previous + np.pi) % (2 * np.pi) - np.pi
        self.times.append(float(time))
        self._angles.append(angle)
        self._radii2.append(radius2)

    @property
    def angles(self) -> np.ndarray:
        """Unwrapped angles (n_records, n_points)."""
        return np.array(self._angles)

    def angular_velocity(self, start: float = -np.inf, stop: float = np.inf) -> float:
        """Mean angular velocity (rad per unit of time) of the points over records with start <= t <= stop:
        a least-squares slope per point, averaged with weights r^2 (mean squared in-plane distance), so points
        near the rotation axis, whose angle is ill-defined, count little. Positive counter-clockwise."""
        return tracked_angular_velocity(np.array(self.times), self.angles, np.array(self._radii2), start, stop)

    def state(self) -> dict:
        """Arrays that restore the tracker (for checkpoints)."""
        return {"times": np.array(self.times), "angles": self.angles, "radii2": np.array(self._radii2)}

    @classmethod
    def from_state(cls, state: dict, plane: tuple[int, int] = (0, 1)) -> RotationTracker:
        tracker = cls(plane)
        tracker.times = [float(t) for t in state["times"]]
        tracker._angles = list(np.asarray(state["angles"]))
        tracker._radii2 = list(np.asarray(state["radii2"]))
        return tracker


def tracked_angular_velocity(times, angles, radii2, start: float = -np.inf, stop: float = np.inf) -> float:
    """Weighted mean of the per-point least-squares slopes d(angle)/dt over start <= t <= stop.

    times (n,), angles (n, p) unwrapped, radii2 (n, p) squared in-plane distances (weights)."""
    times = np.asarray(times, dtype=np.float64)
    keep = (times >= start) & (times <= stop)
    if keep.sum() < 2:
        return float("nan")
    t = times[keep]
    a = np.asarray(angles)[keep]
    w = np.asarray(radii2)[keep].mean(axis=0)
    tc = t - t.mean()
    slopes = tc @ (a - a.mean(axis=0)) / (tc @ tc)
    return float(np.sum(w * slopes) / np.sum(w))
