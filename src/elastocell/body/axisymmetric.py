"""The cell as a body of revolution about z: its meridian section and the elastic energy of it.

For a cell and a loading that are both axisymmetric about the plate normal z (homogeneous cell; nucleus a sphere
or a spheroid with its axis along z, centred or offset along z; plates or a sphere pressed on the axis), the
displacement has no hoop component and the problem lives in the meridian half-plane ``r >= 0`` with coordinates
``(r, z)``. The half-disk of the cell (units of R) is meshed by gmsh with quadratic 6-node triangles on the curved
boundary and nucleus interface (``setOrder(2)``), the nucleus region fragmented with the cell so that the
interface is resolved by element edges, the size graded from ``pole_size`` at the poles (0, +-1) where the plates
or the indenter and the dish touch, and ``interface_size`` on the nucleus boundary.

Kinematics: a material point at (R, Z) moves to (r, z); the deformation gradient in the (r, z, theta) frame is

    F = [[dr/dR, dr/dZ, 0], [dz/dR, dz/dZ, 0], [0, 0, r/R]]

(hoop stretch r/R), and the energy ``E = 2 pi sum_e sum_q w_q R_q det(J_q) W(F_q, p_e)`` with W the same law
function as the 3D cell (``elastocell.body.materials.law``: one source for every law). The quadrature points are
interior to the elements, so R > 0 wherever F is evaluated; nodes on the axis keep r = 0 (held by the solver).
Forces and element stiffness matrices are JAX derivatives of E in float64.

Degrees of freedom: node a has dofs ``2a`` (r) and ``2a + 1`` (z).
"""

from __future__ import annotations

import io
import threading
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from pydantic import model_validator

from elastocell.body.cell import StiffnessPattern
from elastocell.body.materials import Law, computes_in_float64, determinant, law, material_tangent
from elastocell.files import cache_directory, parameter_hash, read_cache_entry, write_cache_entry
from elastocell.parameters.cell import CellParameters, NucleusParameters, ParameterModel, require
from elastocell.parameters.units import ParameterError

CYTOPLASM, NUCLEUS = 0, 1
AXISYMMETRIC_MESH_FORMAT_VERSION = 2
"""Version of what a cached meridian mesh holds and how it is made from its parameters."""

TRIANGLE6_PERMUTATION_FLIP = np.array([0, 2, 1, 5, 4, 3])
TRIANGLE6_NODES = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]], dtype=float)
"""The nodes of the reference 6-node triangle (gmsh order)."""
"""Swapping corners 1 and 2 of a 6-node triangle (gmsh order: corners, then edges (0,1), (1,2), (2,0))."""

_lock = threading.Lock()


class MeridianMeshParameters(ParameterModel):
    """Mesh of the meridian half-disk (units of R).

    mesh_size: element size inside the cell, away from its surface and the nucleus.
    surface_size: size on the cell's surface (where the contact spreads at large deformation), growing to
    ``mesh_size`` over ``surface_width`` inwards.
    pole_size: size at the poles (0, +-1), growing linearly to ``surface_size`` over ``pole_radius``.
    interface_size: size on the nucleus boundary, growing to ``mesh_size`` over ``interface_width``.
    quadrature_points: n of the collapsed Gauss-Jacobi rule (n^2 points per triangle, exact to degree 2n - 1).
    """

    mesh_size: float = 0.1
    surface_size: float = 0.04
    surface_width: float = 0.2
    pole_size: float = 0.01
    pole_radius: float = 0.5
    interface_size: float = 0.04
    interface_width: float = 0.2
    quadrature_points: int = 3

    @model_validator(mode="after")
    def _check(self) -> MeridianMeshParameters:
        require(0.002 <= self.mesh_size <= 1.0, "mesh_size", f"must be in [0.002, 1] (units of R), got {self.mesh_size}")
        require(0.0005 <= self.surface_size <= self.mesh_size, "surface_size",
                f"must be in [0.0005, mesh_size={self.mesh_size}], got {self.surface_size}")
        require(0 < self.surface_width <= 1, "surface_width", f"must be in (0, 1], got {self.surface_width}")
        require(0.0005 <= self.pole_size <= self.surface_size, "pole_size",
                f"must be in [0.0005, surface_size={self.surface_size}], got {self.pole_size}")
        require(0 < self.pole_radius <= 2, "pole_radius", f"must be in (0, 2], got {self.pole_radius}")
        require(0.0005 <= self.interface_size, "interface_size", f"must be >= 0.0005, got {self.interface_size}")
        require(0 < self.interface_width <= 2, "interface_width", f"must be in (0, 2], got {self.interface_width}")
        require(2 <= self.quadrature_points <= 6, "quadrature_points", f"must be in [2, 6], got {self.quadrature_points}")
        return self

    def scaled(self, factor: float) -> MeridianMeshParameters:
        """Every size times ``factor`` (a refinement study's meshes)."""
        return self.model_copy(update={name: getattr(self, name) * factor
                                       for name in ("mesh_size", "surface_size", "pole_size", "interface_size")})


CELL_SHAPES = ("sphere", "cap", "layer")


class MeridianGeometry(ParameterModel):
    """The body whose meridian section is meshed (lengths in the mesh's unit).

    shape: ``sphere`` (the unit half-disk, centre at the origin: a suspended cell of radius 1, resting on a
    dish at z = -1), ``cap`` (a spherical cap bonded to a dish at z = 0: base radius 1, apex (0, ``height``)) or
    ``layer`` (the rectangle [0, ``width``] x [0, ``height``] bonded to a dish at z = 0; its unit is the indenter
    radius R_b). The cap's sphere has radius (1 + H^2) / (2 H) and its centre at z = H - (1 + H^2) / (2 H).
    height: H of the cap, thickness of the layer (unused by the sphere).
    width: lateral extent of the layer (None: :func:`layer_width` of its thickness).
    """

    shape: str = "sphere"
    height: float = 1.0
    width: float | None = None

    @model_validator(mode="after")
    def _check(self) -> MeridianGeometry:
        require(self.shape in CELL_SHAPES, "cell_shape", f"must be one of {', '.join(CELL_SHAPES)}, got {self.shape!r}")
        limits = {"cap": ("cap_height", 0.05, 2.0), "layer": ("layer_thickness", 0.05, 200.0)}
        if self.shape in limits:
            name, low, high = limits[self.shape]
            unit = "R" if self.shape == "cap" else "R_b"
            require(low <= self.height <= high, name, f"must be in [{low:g}, {high:g}] (units of {unit}), got "
                                                      f"{self.height:g}")
        if self.width is not None:
            require(self.width >= 2 * self.height and self.width >= 4, "layer_width",
                    f"must be >= max(2 h, 4) (units of R_b), got {self.width:g}")
        return self

    @property
    def top(self) -> float:
        """z of the apex (the point the indenter touches first)."""
        return 1.0 if self.shape == "sphere" else self.height

    @property
    def bottom(self) -> float:
        """z of the lowest point (on the dish)."""
        return -1.0 if self.shape == "sphere" else 0.0

    @property
    def cap_sphere(self) -> tuple[float, float]:
        """(radius, centre z) of the cap's sphere."""
        radius = (1 + self.height**2) / (2 * self.height)
        return radius, self.height - radius

    @property
    def layer_extent(self) -> float:
        return self.width if self.width is not None else layer_width(self.height)


def layer_width(thickness: float) -> float:
    """Default lateral extent of a layer of ``thickness`` (units of R_b): 2 h + 4 (``validation/indentation.py``
    measures the force's change when it is doubled). Wider layers made the contact's Newton iteration cycle
    between active sets (a 5 R_b layer 35 R_b wide did not converge)."""
    return 2 * thickness + 4


NUCLEUS_MARGIN = 0.02
"""Smallest distance (units of R) between the nucleus of a cap and the cap's surface or base."""


def meridian_nucleus(cell: CellParameters, geometry: MeridianGeometry | None = None) -> tuple[float, float, float] | None:
    """(equatorial semi-axis a_r, axial semi-axis a_z, centre z0) of the nucleus of ``cell`` in the meridian
    plane, None without a nucleus. A cell that is not axisymmetric about z (random, offset along x or y, an
    ellipsoid whose semi-axes across z differ) is refused with a :class:`ParameterError`.

    In a cap the nucleus (semi-axes in units of R, the base radius) is centred on the axis at half the apex
    height plus the offset along z, z0 = H/2 + offset, and must lie inside the cap at least ``NUCLEUS_MARGIN``
    from its surface and base. A layer (a gel or tissue section) is homogeneous: a nucleus is refused."""
    if cell.random is not None:
        raise ParameterError("random", "the random cell is not axisymmetric; the axisymmetric solver needs a "
                                       "cell symmetric about z")
    nucleus: NucleusParameters = cell.nucleus
    if nucleus.shape == "none":
        return None
    if geometry is not None and geometry.shape == "layer":
        raise ParameterError("nucleus", "the layer is homogeneous (a gel or tissue section): give --nucleus none")
    lengths, centre = nucleus.axes_lengths(), nucleus.centre()
    if nucleus.offset and nucleus.offset_axis != "z":
        raise ParameterError("offset_axis", f"the axisymmetric solver needs the nucleus offset along z (the plate "
                                            f"normal), got {nucleus.offset_axis}")
    if not np.isclose(lengths[0], lengths[1], rtol=1e-12, atol=0):
        raise ParameterError("nucleus_axis", f"the axisymmetric solver needs a spheroid with its axis along z "
                                             f"(equal semi-axes along x and y), got x {lengths[0]:g}, y {lengths[1]:g}")
    a_r, a_z, z0 = float(lengths[0]), float(lengths[2]), float(centre[2])
    if geometry is not None and geometry.shape == "cap":
        z0 = geometry.height / 2 + z0
        angle = np.linspace(0, np.pi, 721)
        r, z = a_r * np.sin(angle), z0 + a_z * np.cos(angle)
        radius, centre_z = geometry.cap_sphere
        clearance = min(float(z.min()), float(radius - np.hypot(r, z - centre_z).max()))
        if clearance < NUCLEUS_MARGIN:
            raise ParameterError("size_ratio", f"the nucleus (semi-axes r {a_r:g}, z {a_z:g}, centred at z {z0:g}: "
                                               f"half the apex height plus the offset) does not fit inside the cap "
                                               f"of height {geometry.height:g} R; a smaller nucleus, another "
                                               f"offset or --nucleus none")
    return a_r, a_z, z0


@dataclass(frozen=True)
class MeridianMesh:
    """A 6-node triangle mesh of the meridian section of a :class:`MeridianGeometry` (the sphere: the half-disk
    {R >= 0, R^2 + Z^2 <= 1}).

    nodes: (n_nodes, 2) reference coordinates (R, Z).
    elements: (n_elements, 6) node indices, gmsh order (corners, then edges (0,1), (1,2), (2,0)), positive.
    region: (n_elements,) CYTOPLASM or NUCLEUS.
    surface_nodes: nodes on the cell's free outer boundary that an indenter or plate can touch (the sphere's arc,
    the cap's arc, the layer's top), contact candidates.
    axis_nodes: nodes on the axis R = 0.
    base_nodes: nodes on the base bonded to the dish (cap and layer: z = 0), held in r and z; empty for the sphere.
    """

    nodes: np.ndarray
    elements: np.ndarray
    region: np.ndarray
    surface_nodes: np.ndarray
    axis_nodes: np.ndarray
    base_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @property
    def n_elements(self) -> int:
        return len(self.elements)


def meridian_mesh_parameters(cell: CellParameters, mesh: MeridianMeshParameters,
                             geometry: MeridianGeometry | None = None) -> dict:
    """Everything a meridian mesh is made from: the body's geometry (a cap or a layer; the sphere adds nothing),
    the nucleus geometry in the meridian plane, the mesh settings (not the quadrature) and gmsh's version."""
    import gmsh

    settings = mesh.model_dump(mode="json")
    settings.pop("quadrature_points")
    nucleus = meridian_nucleus(cell, geometry)
    if nucleus is None:
        settings.pop("interface_size")
        settings.pop("interface_width")
    parameters = {"nucleus": None if nucleus is None else list(nucleus), "mesh": settings, "gmsh": gmsh.__version__}
    if geometry is not None and geometry.shape != "sphere":
        parameters["geometry"] = {"shape": geometry.shape, "height": geometry.height, "width": geometry.layer_extent}
    return parameters


def _mesh_bytes(mesh: MeridianMesh) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **mesh.__dict__)
    return buffer.getvalue()


def _mesh_from_bytes(payload: bytes) -> MeridianMesh:
    with np.load(io.BytesIO(payload), allow_pickle=False) as data:
        mesh = MeridianMesh(**{name: data[name] for name in MeridianMesh.__dataclass_fields__})
    if mesh.elements.ndim != 2 or mesh.elements.shape[1] != 6 or mesh.region.shape != mesh.elements.shape[:1]:
        raise ValueError("inconsistent arrays")
    return mesh


def build_meridian_mesh(cell: CellParameters, mesh: MeridianMeshParameters, use_cache: bool = True,
                        geometry: MeridianGeometry | None = None) -> MeridianMesh:
    """The meridian mesh of ``cell`` (its nucleus geometry) in the body ``geometry`` (None: the sphere) with the
    sizes ``mesh``, cached on disk like the 3D meshes (one verified entry per parameter set, under
    :func:`elastocell.files.cache_directory`)."""
    parameters = meridian_mesh_parameters(cell, mesh, geometry)
    key = parameter_hash(parameters, format_version=AXISYMMETRIC_MESH_FORMAT_VERSION)[:20]
    path = Path(cache_directory()) / f"meridian-{key}.npz"
    if use_cache:
        found = read_cache_entry(path, "meridian mesh", parameters, AXISYMMETRIC_MESH_FORMAT_VERSION, _mesh_from_bytes)
        if found is not None:
            return found
    result = _generate(meridian_nucleus(cell, geometry), mesh, geometry)
    if use_cache:
        write_cache_entry(path, _mesh_bytes(result), "meridian mesh", parameters, AXISYMMETRIC_MESH_FORMAT_VERSION)
    return result


def _generate(nucleus: tuple[float, float, float] | None, parameters: MeridianMeshParameters,
              geometry: MeridianGeometry | None = None) -> MeridianMesh:
    """gmsh (OpenCASCADE): the body (the unit disk; the cap's disk; the layer's rectangle), fragmented with the
    nucleus ellipse and the half-plane x < 0 (and, for the cap, y < 0), whose outside pieces are removed; x is R,
    y is Z."""
    import gmsh

    geometry = geometry or MeridianGeometry()
    shape = geometry.shape

    with _lock:
        gmsh.initialize(interruptible=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.option.setNumber("General.NumThreads", 1)
            gmsh.option.setNumber("Mesh.RandomSeed", 1)
            gmsh.model.add("meridian")
            occ = gmsh.model.occ
            if shape == "sphere":
                disk = occ.addDisk(0, 0, 0, 1, 1)
                tools = [(2, occ.addRectangle(-2, -2, 0, 2, 4))]
            elif shape == "cap":
                radius, centre = geometry.cap_sphere
                disk = occ.addDisk(0, centre, 0, radius, radius)
                reach = 4 * radius + 4
                tools = [(2, occ.addRectangle(-reach, -reach, 0, reach, 2 * reach)),
                         (2, occ.addRectangle(0, -reach, 0, reach, reach))]
            else:
                disk = occ.addRectangle(0, 0, 0, geometry.layer_extent, geometry.height)
                tools = [(2, occ.addRectangle(-2, -1, 0, 2, geometry.height + 2))]
            if nucleus is not None:
                a_r, a_z, z0 = nucleus
                inclusion = occ.addDisk(0, 0, 0, 1, 1)
                occ.dilate([(2, inclusion)], 0, 0, 0, a_r, a_z, 1)
                occ.translate([(2, inclusion)], 0, z0, 0)
                tools.append((2, inclusion))
            occ.fragment([(2, disk)], tools)
            occ.synchronize()
            left = [(2, tag) for _, tag in gmsh.model.getEntities(2)
                    if occ.getCenterOfMass(2, tag)[0] < 0 or (shape == "cap" and occ.getCenterOfMass(2, tag)[1] < 0)]
            occ.remove(left, recursive=True)
            occ.synchronize()
            surfaces = [tag for _, tag in gmsh.model.getEntities(2)]
            nucleus_tags = set()
            if nucleus is not None:
                expected = np.pi * a_r * a_z / 2
                masses = {tag: occ.getMass(2, tag) for tag in surfaces}
                nucleus_tags = {min(masses, key=lambda t: abs(masses[t] - expected))}
            interface = []
            if nucleus_tags:
                for _, curve in gmsh.model.getBoundary([(2, t) for t in nucleus_tags], oriented=False):
                    high = gmsh.model.getBoundingBox(1, curve)[3]
                    if high > 1e-9:  # not the axis segment
                        interface.append(curve)
            outer = [tag for _, tag in gmsh.model.getBoundary([(2, t) for t in surfaces], combined=True,
                                                               oriented=False)
                     if gmsh.model.getBoundingBox(1, abs(tag))[3] > 1e-9]  # not the axis
            if shape != "sphere":  # the free surface only: not the base, nor the layer's far side
                boxes = {tag: gmsh.model.getBoundingBox(1, abs(tag)) for tag in outer}
                outer = [tag for tag in outer if boxes[tag][4] > 1e-9
                         and (shape == "cap" or boxes[tag][1] > geometry.height - 1e-9)]
            _size_field(parameters, interface, [abs(tag) for tag in outer], geometry)
            gmsh.model.mesh.generate(2)
            gmsh.model.mesh.setOrder(2)
            node_tags, coordinates, _ = gmsh.model.mesh.getNodes()
            coordinates = coordinates.reshape(-1, 3)[:, :2]
            blocks, regions = [], []
            for tag in surfaces:
                types, _, connectivity = gmsh.model.mesh.getElements(2, tag)
                for kind, conn in zip(types, connectivity, strict=True):
                    if kind != 9:
                        raise RuntimeError(f"gmsh made elements of type {kind}, expected 6-node triangles (9)")
                    conn = np.asarray(conn, dtype=np.int64).reshape(-1, 6)
                    blocks.append(conn)
                    regions.append(np.full(len(conn), NUCLEUS if tag in nucleus_tags else CYTOPLASM))
        finally:
            gmsh.finalize()
    tags = np.concatenate(blocks)
    used, inverse = np.unique(tags, return_inverse=True)
    lookup = np.empty(int(node_tags.max()) + 1, dtype=np.int64)
    lookup[node_tags.astype(np.int64)] = np.arange(len(node_tags))
    nodes = coordinates[lookup[used]].copy()
    elements = inverse.reshape(tags.shape).astype(np.int64)
    on_axis = np.abs(nodes[:, 0]) < 1e-10
    nodes[on_axis, 0] = 0.0
    base = np.zeros(len(nodes), dtype=bool)
    if shape == "sphere":
        radius = np.hypot(nodes[:, 0], nodes[:, 1])
        on_surface = np.abs(radius - 1) < 1e-8
    else:
        nodes[np.abs(nodes[:, 1]) < 1e-10, 1] = 0.0
        base = nodes[:, 1] == 0.0
        if shape == "cap":
            radius, centre = geometry.cap_sphere
            on_surface = np.abs(np.hypot(nodes[:, 0], nodes[:, 1] - centre) - radius) < 1e-8
        else:
            on_surface = np.abs(nodes[:, 1] - geometry.height) < 1e-8
        on_surface &= ~base
    surface = np.flatnonzero(on_surface)
    elements = _orient_positive(nodes, elements)
    if (jacobians(nodes, elements, triangle_rule(3)[0]) <= 0).any():
        raise ParameterError("mesh_size", "a curved triangle of the meridian mesh is folded; use smaller sizes")
    return MeridianMesh(nodes=nodes, elements=elements, region=np.concatenate(regions).astype(np.int8),
                        surface_nodes=surface, axis_nodes=np.flatnonzero(on_axis), base_nodes=np.flatnonzero(base))


LAYER_GROWTH = 0.15
"""Growth of the element size with the distance d from the contact beyond d = 1 in a layer (units of R_b per
R_b): the far field of a thick, wide layer carries little strain."""


def _size_field(parameters: MeridianMeshParameters, interface: list[int], outer: list[int],
                geometry: MeridianGeometry) -> None:
    """The size: ``pole_size`` at the points the indenter or plates and the dish touch (the sphere's poles; the
    apex of a cap or layer), growing to ``mesh_size`` over ``pole_radius``; ``surface_size`` near the free
    surface (a layer: none, its pole grading covers the contact), ``interface_size`` near the nucleus; in a layer
    the size grows further by ``LAYER_GROWTH`` per unit of distance beyond 1 from the contact."""
    import gmsh

    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    h, hs, hp, radius = parameters.mesh_size, parameters.surface_size, parameters.pole_size, parameters.pole_radius
    field = gmsh.model.mesh.field
    if geometry.shape == "sphere":
        distance = "Min(Sqrt(x*x+(y-1)*(y-1)), Sqrt(x*x+(y+1)*(y+1)))"
    else:
        distance = f"Sqrt(x*x+(y-{geometry.height!r})*(y-{geometry.height!r}))"
    growth = f" + {LAYER_GROWTH}*Max(0, {distance} - 1)" if geometry.shape == "layer" else ""
    poles = field.add("MathEval")
    field.setString(poles, "F", f"{hp} + ({h}-{hp})*Min(1, {distance}/{radius}){growth}")
    fields = [poles]

    def near(curves, size, width):
        to_curves = field.add("Distance")
        field.setNumbers(to_curves, "CurvesList", curves)
        field.setNumber(to_curves, "Sampling", 1000)
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", to_curves)
        field.setNumber(threshold, "SizeMin", size)
        field.setNumber(threshold, "SizeMax", h)
        field.setNumber(threshold, "DistMin", 0.0)
        field.setNumber(threshold, "DistMax", width)
        fields.append(threshold)

    if hs < h and geometry.shape != "layer":
        near(outer, hs, parameters.surface_width)
    if interface and parameters.interface_size < h:
        near(interface, parameters.interface_size, parameters.interface_width)
    smallest = field.add("Min")
    field.setNumbers(smallest, "FieldsList", fields)
    field.setAsBackgroundMesh(smallest)


# ------------------------------------------------------------------------------------------- the element
@lru_cache(maxsize=8)
def triangle_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(points (n^2, 2), weights (n^2,)) on the unit triangle {xi, eta >= 0, xi + eta <= 1}: the collapsed
    (Duffy) Gauss-Jacobi product rule, weights positive and summing to 1/2, exact to degree 2n - 1, every point
    interior."""
    from scipy.special import roots_jacobi

    t, wt = roots_jacobi(n, 1, 0)  # weight (1 - t) on [-1, 1]
    x, wx = (t + 1) / 2, wt / 4
    s, ws = roots_jacobi(n, 0, 0)
    s, ws = (s + 1) / 2, ws / 2
    xx, ss = np.meshgrid(x, s, indexing="ij")
    points = np.column_stack([xx.ravel(), (ss * (1 - xx)).ravel()])
    weights = (wx[:, None] * ws[None, :]).ravel()
    points.flags.writeable = weights.flags.writeable = False
    return points, weights


def shape_functions(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N (n_points, 6), dN/dxi (n_points, 6, 2)) of the 6-node triangle at ``points``: corners L_i (2 L_i - 1),
    edge nodes 4 L_i L_j, with barycentric L = (1 - xi - eta, xi, eta)."""
    points = np.atleast_2d(points)
    barycentric = np.column_stack([1 - points.sum(axis=1), points])
    grad = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    edges = np.array([(0, 1), (1, 2), (2, 0)])
    values = np.concatenate([barycentric * (2 * barycentric - 1),
                             4 * barycentric[:, edges[:, 0]] * barycentric[:, edges[:, 1]]], axis=1)
    corners = (4 * barycentric[:, :, None] - 1) * grad[None]
    edge_gradients = 4 * (barycentric[:, edges[:, 1], None] * grad[edges[:, 0]][None]
                          + barycentric[:, edges[:, 0], None] * grad[edges[:, 1]][None])
    return values, np.concatenate([corners, edge_gradients], axis=1)


def jacobians(nodes: np.ndarray, elements: np.ndarray, points: np.ndarray) -> np.ndarray:
    """det(dX/dxi) of every element at ``points``, (n_elements, n_points)."""
    gradients = shape_functions(points)[1]
    return np.linalg.det(np.einsum("eki,qkj->eqij", nodes[elements], gradients))


def _orient_positive(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    centroid = np.array([[1 / 3, 1 / 3]])
    flip = jacobians(nodes, elements, centroid)[:, 0] < 0
    if flip.any():
        elements = elements.copy()
        elements[flip] = elements[flip][:, TRIANGLE6_PERMUTATION_FLIP]
    return elements


# ------------------------------------------------------------------------------------------- the body
def nucleus_stiffness_ratios(cell: CellParameters, mesh: MeridianMesh) -> np.ndarray:
    """E_e / E_c per element: 1 in the cytoplasm, the nucleus's stiffness ratio in it."""
    ratios = np.ones(mesh.n_elements)
    if cell.nucleus.shape != "none":
        ratios[mesh.region == NUCLEUS] = cell.nucleus.stiffness_ratio
    return ratios


@computes_in_float64
@dataclass(frozen=True, eq=False)
class AxisymmetricCell:
    """The meridian section of an axisymmetric cell: energy, forces and element stiffness matrices of the body
    of revolution (units: lengths R, moduli E_c, energies E_c R^3, forces E_c R^2 -- a nodal force is the
    force on the whole ring of the node)."""

    parameters: CellParameters
    mesh: MeridianMesh
    youngs_moduli: np.ndarray
    quadrature_points: int = 3
    is_equivalent: bool = False
    _kernels: dict = field(default_factory=dict, repr=False)

    @classmethod
    def from_parameters(cls, cell: CellParameters, mesh: MeridianMeshParameters | None = None,
                        use_cache: bool = True, geometry: MeridianGeometry | None = None) -> AxisymmetricCell:
        mesh = mesh or MeridianMeshParameters()
        meridian = build_meridian_mesh(cell, mesh, use_cache=use_cache, geometry=geometry)
        return cls(cell, meridian, nucleus_stiffness_ratios(cell, meridian), mesh.quadrature_points)

    @property
    def law(self) -> Law:
        return law(self.parameters.material.law)

    @cached_property
    def material_parameters(self) -> np.ndarray:
        material = self.parameters.material
        return self.law.parameters(self.youngs_moduli, material.poisson_ratio,
                                   {"mooney_rivlin_mu1_fraction": material.mooney_rivlin_mu1_fraction})

    @cached_property
    def geometry(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N at the points (q, 6), dN/dX (e, q, 6, 2), weights 2 pi w_q R_q det J (e, q)): the reference
        volume each point carries, so that the weights sum to the cell's volume."""
        points, point_weights = triangle_rule(self.quadrature_points)
        values, local = shape_functions(points)
        coordinates = self.mesh.nodes[self.mesh.elements]
        jacobian = np.einsum("eki,qkj->eqij", coordinates, local)
        det = np.linalg.det(jacobian)
        if (det <= 0).any():
            raise ParameterError("mesh_size", "the meridian mesh has a folded element")
        gradients = np.einsum("qkj,eqji->eqki", local, np.linalg.inv(jacobian))
        radius = np.einsum("qk,ek->eq", values, coordinates[:, :, 0])
        return values, gradients, 2 * np.pi * point_weights * radius * det

    @cached_property
    def element_volumes(self) -> np.ndarray:
        return self.geometry[2].sum(axis=1)

    @property
    def volume(self) -> float:
        return float(self.element_volumes.sum())

    @property
    def effective_stiffness_ratio(self) -> float:
        """E_eff/E_c, the volume average of the moduli over the body of revolution (each element's volume
        integrates 2 pi r over its section)."""
        return float(np.sum(self.element_volumes * self.youngs_moduli) / self.volume)

    def equivalent(self) -> AxisymmetricCell:
        """The homogeneous equivalent: same mesh, every element at E_eff (as the 3D ``Cell.equivalent``)."""
        moduli = np.full(self.mesh.n_elements, self.effective_stiffness_ratio)
        return AxisymmetricCell(self.parameters, self.mesh, moduli, self.quadrature_points, is_equivalent=True)

    @cached_property
    def stiffness_pattern(self) -> StiffnessPattern:
        return StiffnessPattern(self.mesh.elements, self.mesh.n_nodes, dofs_per_node=2)

    def _compiled(self) -> dict:
        if self._kernels:
            return self._kernels
        values, gradients, weights = (jnp.asarray(a) for a in self.geometry)
        elements = jnp.asarray(self.mesh.elements)
        reference_radius = jnp.asarray(np.einsum("qk,ek->eq", self.geometry[0],
                                                 self.mesh.nodes[self.mesh.elements][:, :, 0]))
        params = jnp.asarray(self.material_parameters.T[:, :, None])  # [k, e, 1]
        energy_law = self.law

        def deformation_gradients(x_elements, radius, grads, vals):
            """F[i, j, e, q] in (r, z, theta) from element positions x_elements (e, 6, 2)."""
            planar = jnp.einsum("eki,eqkj->ijeq", x_elements, grads)
            hoop = jnp.einsum("qk,ek->eq", vals, x_elements[:, :, 0]) / radius
            zero = jnp.zeros_like(hoop)
            return jnp.stack([jnp.stack([planar[0, 0], planar[0, 1], zero]),
                              jnp.stack([planar[1, 0], planar[1, 1], zero]),
                              jnp.stack([zero, zero, hoop])])

        def point_energies(x_elements, radius, grads, vals, w, p):
            return w * energy_law(deformation_gradients(x_elements, radius, grads, vals), p)

        nodal = jnp.asarray(shape_functions(TRIANGLE6_NODES)[1])  # dN/dxi at the six nodes

        def energy(x):
            # a map folded at a node (det dx/dxi <= 0 there) has no finite energy, as the 3D rule with the nodes
            # among its points: the interior points alone let a quadratic element crushed in the thin layer between a
            # stiff nucleus and a plate fold at a node, an equilibrium no body can reach
            x_elements = x[elements]
            folded = jnp.any(jnp.linalg.det(jnp.einsum("eki,qkj->eqij", x_elements, nodal)) <= 0)
            total = jnp.sum(point_energies(x_elements, reference_radius, gradients, values, weights, params))
            return total + jnp.where(folded, jnp.nan, 0.0)

        def tangents(x):
            # w_q d2W/dF2 by autodiff, [i, j, k, l, e, q]
            return material_tangent(energy_law, deformation_gradients(x[elements], reference_radius, gradients,
                                                                       values), params) * weights

        def stiffness(tangent):
            # the tangent contracted with dF/dx: dF_ij/dx_(a,c) = delta_ic dN_a/dX_j (i, j in r, z) and
            # dF_(theta theta)/dx_(a,r) = N_a / R. A separate kernel from the tangent's: compiled as one, XLA fused
            # the tangent into the contraction and took 3-4x longer (measured 0.24 against 0.07 s, 1,592 elements)
            hoop = values[None] / reference_radius[:, :, None]  # [e, q, a]
            planar = jnp.einsum("eqaj,cjdleq,eqbl->eacbd", gradients, tangent[:2, :2, :2, :2], gradients)
            mixed = jnp.einsum("eqa,dleq,eqbl->eabd", hoop, tangent[2, 2, :2, :2], gradients)
            radial = jnp.einsum("eqa,eq,eqb->eab", hoop, tangent[2, 2, 2, 2], hoop)
            planar = planar.at[:, :, 0, :, :].add(mixed)
            planar = planar.at[:, :, :, :, 0].add(jnp.transpose(mixed, (0, 2, 3, 1)))
            planar = planar.at[:, :, 0, :, 0].add(radial)
            return planar.reshape(planar.shape[0], 12, 12)

        def min_jacobian(x):
            return jnp.min(determinant(deformation_gradients(x[elements], reference_radius, gradients, values)))

        self._kernels.update(energy=jax.jit(energy), gradient=jax.jit(jax.grad(energy)),
                             tangents=jax.jit(tangents), stiffness=jax.jit(stiffness), min_jacobian=jax.jit(min_jacobian))
        return self._kernels

    def energy(self, x: np.ndarray) -> float:
        """E(x) for positions ``x`` (n_nodes, 2) (units E_c R^3); NaN where an element is inverted."""
        return float(self._compiled()["energy"](jnp.asarray(x)))

    def internal_forces(self, x: np.ndarray) -> np.ndarray:
        """dE/dx per node, (n_nodes, 2): minus the elastic force on each node's ring."""
        return np.asarray(self._compiled()["gradient"](jnp.asarray(x)))

    def element_stiffness(self, x: np.ndarray) -> np.ndarray:
        """d^2 E_e / dx_e^2, (n_elements, 12, 12), dof order (node, component)."""
        kernels = self._compiled()
        return np.asarray(kernels["stiffness"](kernels["tangents"](jnp.asarray(x))))

    def min_volume_ratio(self, x: np.ndarray) -> float:
        """Smallest det F over the quadrature points."""
        return float(self._compiled()["min_jacobian"](jnp.asarray(x)))
