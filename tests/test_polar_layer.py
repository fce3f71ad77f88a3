"""The polar layer's refinement (``MeshParameters.layer_size``), an option of the mesh whose effect on a stiff
nucleus validation/stiff_3d.py measures against the axisymmetric truth (docs/validation/axisymmetric.md)."""

import numpy as np
import pytest

from elastocell.body.cell import Cell
from elastocell.body.mesh import NUCLEUS, mesh_parameters
from elastocell.parameters.cell import MeshParameters, cell_parameters


def _with_layer(cell, **layer):
    return cell.model_copy(update={"mesh": MeshParameters(**{**cell.mesh.model_dump(), **layer})})


def test_polar_layer_sets_the_element_size_in_the_polar_cytoplasm_only():
    """gmsh's size field, approximate: measured mean edge of the cytoplasm elements within 35 degrees of the z axis
    and outside radius 0.6 is 0.195 for layer_size 0.15 and 0.133 for 0.1 (bulk 0.4: 0.49), i.e. 1.3 times the
    size asked (bound 1.0-1.5); near the equator the bulk size stays (0.45 and 0.43, bound > 2.5 x layer)."""
    base = cell_parameters(element="p1", mesh_size=0.4, pole_size=0.4)
    for layer_size in (0.15, 0.1):
        mesh = Cell.from_parameters(_with_layer(base, layer_size=layer_size, layer_angle=40)).mesh
        corners = mesh.nodes[mesh.elements[:, :4]]
        centroid = corners.mean(axis=1)
        radius = np.linalg.norm(centroid, axis=1)
        angle = np.degrees(np.arccos(np.abs(centroid[:, 2]) / radius))
        edges = np.linalg.norm(corners[:, [1, 2, 3, 2, 3, 3]] - corners[:, [0, 0, 0, 1, 1, 2]], axis=2).mean(axis=1)
        cytoplasm = mesh.region != NUCLEUS
        cone = edges[cytoplasm & (angle < 35) & (radius > 0.6)].mean()
        equator = edges[cytoplasm & (angle > 70)].mean()
        assert 1.0 < cone / layer_size < 1.5 and equator > 2.5 * layer_size


def test_a_mesh_without_the_layer_keeps_its_data_and_cache_key():
    """The layer fields are left out of the data of a mesh that does not refine it, so that the meshes, caches and
    run keys of every other cell are what they are without the fields; with a layer they are in the key."""
    plain = cell_parameters(stiffness_ratio=2)
    assert not {"layer_size", "layer_angle", "layer_depth"} & set(plain.mesh.model_dump())
    layered = _with_layer(plain, layer_size=0.1)
    assert mesh_parameters(plain.nucleus, layered.mesh) != mesh_parameters(plain.nucleus, plain.mesh)
    assert MeshParameters.model_validate(layered.mesh.model_dump()) == layered.mesh
    with pytest.raises(ValueError, match="layer_size"):  # pydantic wraps the ParameterError
        MeshParameters(layer_size=0.5)  # coarser than the bulk
