"""Conforming tetrahedral meshes of the cell (gmsh), linear (4-node) or quadratic (10-node) elements.

The cell is the unit ball (radius R = 1; physical sizes are applied by scaling results). A nucleus,
sphere or ellipsoid, is its own volume, fragmented with the ball so that the interface is resolved by
element faces. The mesh is refined towards the poles z = +-R where the plates touch.

Node ordering of 10-node tetrahedra follows VTK: corners 0-3, then edges (0,1) (1,2) (0,2) (0,3) (1,3) (2,3).
Meshes are cached on disk (:func:`build_mesh`): one verified cache entry (``elastocell.files``) per set of
:func:`mesh_parameters`, an ``.npz`` payload under the hash of those parameters and :data:`MESH_FORMAT_VERSION`.
"""

from __future__ import annotations

import io
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from elastocell.body.elements import NODE_POINTS, TET10_EDGES, jacobian_determinants, reference_element
from elastocell.files import cache_directory, parameter_hash, read_cache_entry, write_cache_entry
from elastocell.parameters.cell import CellParameters, MeshParameters, NucleusParameters
from elastocell.parameters.units import ParameterError

CYTOPLASM, NUCLEUS = 0, 1
MESH_FORMAT_VERSION = 6
"""Version of what a cached mesh holds and how it is made from its parameters; raised when the generation or
the stored arrays change for the same :func:`mesh_parameters`."""

# Edges of a tetrahedron in VTK order (local corner indices) and gmsh's order for TET10.
GMSH_TO_VTK_TET10 = np.array([0, 1, 2, 3, 4, 5, 6, 7, 9, 8])
# Faces of a tetrahedron (corner indices), each with the local indices of its three edge nodes (TET10).
TET_FACES = np.array([(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)])
TET10_FACE_EDGE_NODES = np.array([(5, 9, 8), (6, 9, 7), (4, 8, 7), (4, 5, 6)])

_gmsh_lock = threading.Lock()


@dataclass(frozen=True)
class CellMesh:
    """A tetrahedral mesh of the unit ball.

    nodes: (n_nodes, 3) reference coordinates X (units of R).
    elements: (n_elements, 4 or 10) node indices.
    region: (n_elements,) CYTOPLASM (0) or NUCLEUS (1).
    surface_nodes: indices of the nodes on the outer cell surface (candidates for plate contact).
    surface_faces: (n_faces, 3) corner indices of the outer boundary triangles.
    """

    nodes: np.ndarray
    elements: np.ndarray
    region: np.ndarray
    surface_nodes: np.ndarray
    surface_faces: np.ndarray

    @property
    def order(self) -> int:
        return 1 if self.elements.shape[1] == 4 else 2

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def n_elements(self) -> int:
        return self.elements.shape[0]

    def quality(self) -> dict:
        """Mesh quality of the corner tetrahedra: normalised radius ratio 3 r_in / r_circ in (0, 1]."""
        corners = self.nodes[self.elements[:, :4]]
        edges = corners[:, [1, 2, 3, 2, 3, 3]] - corners[:, [0, 0, 0, 1, 1, 2]]
        volume = np.abs(np.einsum("ij,ij->i", edges[:, 0], np.cross(edges[:, 1], edges[:, 2]))) / 6
        faces = corners[:, TET_FACES]
        face_areas = 0.5 * np.linalg.norm(
            np.cross(faces[:, :, 1] - faces[:, :, 0], faces[:, :, 2] - faces[:, :, 0]), axis=-1
        ).sum(axis=1)
        r_in = 3 * volume / face_areas
        a, b, c = (np.linalg.norm(edges[:, k], axis=1) for k in range(3))
        a2, b2, c2 = (np.linalg.norm(edges[:, k], axis=1) for k in (5, 4, 3))
        products = np.array([a * a2, b * b2, c * c2])
        s = products.sum(axis=0) / 2
        r_circ = np.sqrt(np.clip(s * (s - products[0]) * (s - products[1]) * (s - products[2]), 0, None)) / (
            6 * volume
        )
        ratio = 3 * r_in / r_circ
        edge_lengths = np.linalg.norm(edges, axis=-1)
        return {
            "radius_ratio_min": float(ratio.min()),
            "radius_ratio_mean": float(ratio.mean()),
            "edge_length_min": float(edge_lengths.min()),
            "edge_length_max": float(edge_lengths.max()),
        }

    def counts(self) -> dict:
        return {
            "n_nodes": int(self.n_nodes),
            "n_elements": int(self.n_elements),
            "n_nucleus_elements": int((self.region == NUCLEUS).sum()),
            "element_order": self.order,
        }


def mesh_parameters(nucleus: NucleusParameters, mesh: MeshParameters) -> dict:
    """Everything a mesh is made from, resolved: the nucleus geometry (not its stiffness; ``{"shape": "none"}``
    without one), the mesh settings (not the quadrature degree; no interface settings when nothing refines an
    interface) and gmsh's version. Cells that differ in anything else share the mesh."""
    import gmsh

    geometry = nucleus.model_dump(mode="json")
    if nucleus.shape == "none":
        geometry = {"shape": "none"}
    else:
        geometry.pop("stiffness_ratio")
    settings = mesh.model_dump(mode="json")
    settings.pop("quadrature_degree")
    if nucleus.shape == "none" or not mesh.refines_interface:
        settings["interface_size"] = None
        settings.pop("interface_width")
    return {"nucleus": geometry, "mesh": settings, "gmsh": gmsh.__version__}


def mesh_cache_path(parameters: dict) -> Path:
    """The cache entry of the mesh made from :func:`mesh_parameters` ``parameters``."""
    return cache_directory() / f"mesh-{parameter_hash(parameters, format_version=MESH_FORMAT_VERSION)[:20]}.npz"


def _mesh_bytes(mesh: CellMesh) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **mesh.__dict__)
    return buffer.getvalue()


def _mesh_from_bytes(payload: bytes) -> CellMesh:
    with np.load(io.BytesIO(payload), allow_pickle=False) as data:
        mesh = CellMesh(**{name: data[name] for name in CellMesh.__dataclass_fields__})
    if mesh.elements.ndim != 2 or mesh.elements.shape[1] not in (4, 10) or mesh.region.shape != mesh.elements.shape[:1]:
        raise ValueError("inconsistent arrays")
    return mesh


def build_mesh(cell: CellParameters, use_cache: bool = True) -> CellMesh:
    """Mesh of the cell described by ``cell`` (geometry and mesh parameters only), cached on disk
    (``use_cache``): an entry made from other parameters or damaged is reported once (a warning naming the file)
    and made again, never used."""
    nucleus = cell.nucleus if cell.random is None else NucleusParameters(shape="none")
    parameters = mesh_parameters(nucleus, cell.mesh)
    path = mesh_cache_path(parameters)
    if use_cache:
        mesh = read_cache_entry(path, "mesh", parameters, MESH_FORMAT_VERSION, _mesh_from_bytes)
        if mesh is not None:
            return mesh
    mesh = _generate(nucleus, cell.mesh)
    _check_valid(mesh, cell.mesh)
    if use_cache:
        write_cache_entry(path, _mesh_bytes(mesh), "mesh", parameters, MESH_FORMAT_VERSION)
    return mesh


def _reinstall_signal_handlers() -> None:
    """Give the operating system back Python's handlers of SIGINT, SIGTERM and SIGPIPE (gmsh's initialize installs
    its own at the C level: a stop signal would kill the process without the run writing what it has, and a write
    to a closed socket, e.g. to a Dask worker that died, would kill it instead of raising BrokenPipeError)."""
    import signal

    if threading.current_thread() is not threading.main_thread():
        return
    for number in (signal.SIGINT, signal.SIGTERM, signal.SIGPIPE):  # SIGPIPE: Python ignores it, gmsh kills
        handler = signal.getsignal(number)
        if handler is not None:
            signal.signal(number, handler)


def _generate(nucleus: NucleusParameters, parameters: MeshParameters) -> CellMesh:
    import gmsh

    with _gmsh_lock:
        gmsh.initialize(interruptible=False)
        _reinstall_signal_handlers()  # gmsh's initialize resets SIGTERM's handler to the default (kill)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.option.setNumber("General.NumThreads", 1)
            gmsh.option.setNumber("Mesh.RandomSeed", 1)
            gmsh.model.add("cell")
            occ = gmsh.model.occ
            ball = occ.addSphere(0, 0, 0, 1.0)
            nucleus_volume_expected = None
            if nucleus.shape != "none":
                lengths, centre = nucleus.axes_lengths(), nucleus.centre()
                inclusion = occ.addSphere(0, 0, 0, 1.0)
                occ.dilate([(3, inclusion)], 0, 0, 0, *lengths)
                occ.translate([(3, inclusion)], *centre)
                occ.fragment([(3, ball)], [(3, inclusion)])
                nucleus_volume_expected = 4 / 3 * np.pi * float(np.prod(lengths))
            occ.synchronize()

            volumes = [tag for _, tag in gmsh.model.getEntities(3)]
            nucleus_tags: set[int] = set()
            if nucleus_volume_expected is not None:
                masses = {tag: occ.getMass(3, tag) for tag in volumes}
                nucleus_tags = {min(masses, key=lambda t: abs(masses[t] - nucleus_volume_expected))}

            interface = [] if not nucleus_tags else [
                tag for _, tag in gmsh.model.getBoundary([(3, t) for t in nucleus_tags], oriented=False)]
            _set_size_field(parameters, interface, [tag for tag in volumes if tag not in nucleus_tags])
            gmsh.model.mesh.generate(3)
            if parameters.element == "p2":
                # curved boundary and interface; untangle curved elements that would be invalid
                gmsh.model.mesh.setOrder(2)
            element_type = 4 if parameters.element == "p1" else 11

            node_tags, coordinates, _ = gmsh.model.mesh.getNodes()
            coordinates = coordinates.reshape(-1, 3)
            blocks, regions = [], []
            for tag in volumes:
                types, _, connectivity = gmsh.model.mesh.getElements(3, tag)
                for kind, conn in zip(types, connectivity, strict=True):
                    if kind != element_type:
                        continue
                    conn = np.asarray(conn, dtype=np.int64).reshape(-1, 4 if kind == 4 else 10)
                    blocks.append(conn)
                    regions.append(np.full(len(conn), NUCLEUS if tag in nucleus_tags else CYTOPLASM))
        finally:
            gmsh.finalize()

    elements_tags = np.concatenate(blocks)
    if element_type == 11:
        elements_tags = elements_tags[:, GMSH_TO_VTK_TET10]
    region = np.concatenate(regions).astype(np.int8)
    # compact numbering: only nodes used by volume elements
    used, inverse = np.unique(elements_tags, return_inverse=True)
    lookup = np.empty(int(node_tags.max()) + 1, dtype=np.int64)
    lookup[node_tags.astype(np.int64)] = np.arange(len(node_tags))
    nodes = coordinates[lookup[used]]
    elements = inverse.reshape(elements_tags.shape).astype(np.int64)
    elements = _orient_positive(nodes, elements)
    if elements.shape[1] == 10:
        nodes = _straighten_invalid(nodes, elements)
    surface_faces, surface_nodes = _outer_surface(elements)
    return CellMesh(nodes=nodes, elements=elements, region=region, surface_nodes=surface_nodes,
                    surface_faces=surface_faces)


def _check_valid(mesh: CellMesh, parameters: MeshParameters) -> None:

    try:
        reference_element(mesh.order).geometry(mesh.nodes, mesh.elements)
    except ValueError as error:
        raise ParameterError(
            "mesh_size", f"mesh too coarse for the geometry ({error}); use a smaller mesh_size than {parameters.mesh_size}"
        ) from None


def _set_size_field(parameters: MeshParameters, interface: list[int] = (), cytoplasm: list[int] = ()) -> None:
    """gmsh's background size: the bulk size graded to the poles, the finest of that, the nucleus surface's
    refinement and the polar layer's (``layer_size`` in the cytoplasm volumes ``cytoplasm`` within ``layer_angle``
    of the z axis, growing to the bulk size over 15 degrees more)."""
    import gmsh

    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    h, hp, r = parameters.mesh_size, parameters.pole_size, parameters.pole_radius
    field = gmsh.model.mesh.field
    if hp is None or hp >= h:
        expression = f"{h}"
    else:
        # size grows linearly from hp at a pole to h at distance r from it
        distance = "Min(Sqrt(x*x+y*y+(z-1)*(z-1)), Sqrt(x*x+y*y+(z+1)*(z+1)))"
        expression = f"{hp} + ({h}-{hp})*Min(1, {distance}/{r})"
    tag = field.add("MathEval")
    field.setString(tag, "F", expression)
    if interface and parameters.refines_interface:
        distance = field.add("Distance")
        field.setNumbers(distance, "SurfacesList", list(interface))
        field.setNumber(distance, "Sampling", 200)
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "SizeMin", parameters.interface_size)
        field.setNumber(threshold, "SizeMax", h)
        field.setNumber(threshold, "DistMin", 0.0)
        field.setNumber(threshold, "DistMax", parameters.interface_width)
        smallest = field.add("Min")
        field.setNumbers(smallest, "FieldsList", [tag, threshold])
        tag = smallest
    if parameters.layer_size is not None and parameters.layer_size < h and cytoplasm:
        # cosine of the polar angle about z; the size grows from layer_size at the cone to h 15 degrees further
        inner, outer = np.cos(np.radians(parameters.layer_angle)), np.cos(np.radians(min(parameters.layer_angle + 15, 90)))
        cosine = "Abs(z)/Max(Sqrt(x*x+y*y+z*z), 1e-9)"
        grade = f"Min(1, Max(0, ({inner:.9g} - {cosine})/{inner - outer:.9g}))"
        if parameters.layer_depth is not None:  # only near the surface: grows over 0.1 R inwards from the depth
            depth = f"Min(1, Max(0, (1 - Sqrt(x*x+y*y+z*z) - {parameters.layer_depth})/0.1))"
            grade = f"Max({grade}, {depth})"
        layer = field.add("MathEval")
        field.setString(layer, "F", f"{parameters.layer_size} + ({h}-{parameters.layer_size})*{grade}")
        restricted = field.add("Restrict")
        field.setNumber(restricted, "InField", layer)
        field.setNumbers(restricted, "VolumesList", list(cytoplasm))
        smallest = field.add("Min")
        field.setNumbers(smallest, "FieldsList", [tag, restricted])
        tag = smallest
    field.setAsBackgroundMesh(tag)


def _straighten_invalid(nodes: np.ndarray, elements: np.ndarray, sweeps: int = 5) -> np.ndarray:
    """Move the edge nodes of curved 10-node elements whose Jacobian is not positive everywhere back to the
    straight midpoints (a coarse element with two faces on a curved surface can fold when curved). The
    boundary is then locally straight there; every other element keeps its exact curved geometry."""

    check_points = np.vstack([NODE_POINTS, reference_element(2).points])
    nodes = nodes.copy()
    for _ in range(sweeps):
        invalid = (jacobian_determinants(nodes, elements, check_points) <= 0).any(axis=1)
        if not invalid.any():
            break
        bad = elements[invalid]
        nodes[bad[:, 4:]] = 0.5 * (nodes[bad[:, TET10_EDGES[:, 0]]] + nodes[bad[:, TET10_EDGES[:, 1]]])
    return nodes


def _orient_positive(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Swap corners 1 and 2 (and the matching edge nodes) of negatively oriented tetrahedra."""
    corners = nodes[elements[:, :4]]
    signed = np.einsum(
        "ij,ij->i", corners[:, 1] - corners[:, 0], np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 0])
    )
    flip = signed < 0
    if not flip.any():
        return elements
    elements = elements.copy()
    if elements.shape[1] == 4:
        permutation = [0, 2, 1, 3]
    else:  # swapping corners 1,2 maps edges (0,1)<->(0,2), (1,2) fixed, (1,3)<->(2,3)
        permutation = [0, 2, 1, 3, 6, 5, 4, 7, 9, 8]
    elements[flip] = elements[flip][:, permutation]
    return elements


def outer_surface_triangles(elements: np.ndarray) -> np.ndarray:
    """The boundary triangles (faces used by one element) with all their nodes: (n_faces, 3) corners for linear
    tetrahedra, (n_faces, 6) for quadratic ones in the 6-node triangle's order (corners c0 c1 c2, then the edge
    nodes of c0-c1, c1-c2, c2-c0)."""
    faces = elements[:, TET_FACES].reshape(-1, 3)
    key = np.sort(faces, axis=1)
    _, index, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    boundary = index[counts == 1]
    if elements.shape[1] == 4:
        return faces[boundary]
    edge_nodes = elements[:, TET10_FACE_EDGE_NODES].reshape(-1, 3)
    return np.concatenate([faces[boundary], edge_nodes[boundary]], axis=1)


TET_OUTWARD_FACES = np.array([(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)])
"""The faces of a positively oriented tetrahedron (corner indices), each ordered so that its normal
(b - a) x (c - a) points out of the tetrahedron."""


def outward_surface_triangles(elements: np.ndarray) -> np.ndarray:
    """The outer boundary's corner triangles (n_faces, 3) of positively oriented tetrahedra, each ordered so that
    its normal points out of the body: over them, sum a . (b x c) / 6 is the volume the surface encloses."""
    faces = elements[:, TET_OUTWARD_FACES].reshape(-1, 3)
    _, index, counts = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    return np.ascontiguousarray(faces[index[counts == 1]], dtype=np.int64)


def surface_corner_edges(elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(corners, edge_nodes): for quadratic tetrahedra, one pair per end of every outer surface edge, the corner
    node at that end and the edge's mid-side node (empty for linear ones). A 6-node triangle's corner takes no
    share of a uniform pressure on it (the integral of its shape function over the triangle is zero), so that in a
    contact the sign of a corner's force follows the curvature of the pressure, not the contact itself; the
    mid-side nodes around it tell whether the surface there presses (``corners_surrounded``)."""
    if elements.shape[1] != 10:
        empty = np.zeros(0, dtype=elements.dtype)
        return empty, empty
    triangles = outer_surface_triangles(elements)
    corner_pairs = np.array([(0, 3), (1, 3), (1, 4), (2, 4), (2, 5), (0, 5)])
    pairs = np.unique(triangles[:, corner_pairs].reshape(-1, 2), axis=0)
    return pairs[:, 0], pairs[:, 1]


def corners_surrounded(pressed: np.ndarray, corners: np.ndarray, edge_nodes: np.ndarray) -> np.ndarray:
    """Per node, True for a surface corner every one of whose surface edges has its mid-side node ``pressed``
    (a boolean per node): a corner inside a region of contact (pairs of :func:`surface_corner_edges`)."""
    size = len(pressed)
    edges = np.bincount(corners, minlength=size)
    pressed_edges = np.bincount(corners, weights=pressed[edge_nodes], minlength=size)
    return (edges > 0) & (pressed_edges == edges)


def _outer_surface(elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Boundary triangles (corners) and all nodes on them (edge nodes included)."""
    triangles = outer_surface_triangles(elements)
    return triangles[:, :3], np.unique(triangles.ravel())
