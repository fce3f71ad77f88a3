"""Validated inputs of every scenario, and the one parser of physical quantities.

Every model validates before any meshing or computing; an impossible value raises :class:`ParameterError`
with one line naming the parameter and its allowed range. Symbols follow the paper: cell radius ``R``,
cytoplasm Young's modulus ``E_c``, Poisson ratio ``nu``, stiffness ratio ``gamma = E_n/E_c``, size ratio
``lambda = R_n/R``, offset ``d`` (in R). Scenario-specific parameters live with their scenario
(:mod:`elastocell.scenarios`).
"""

from elastocell.parameters.cell import (
    AXIS_INDEX,
    DEFAULT_MESH_SIZES,
    Axis,
    CellParameters,
    MaterialParameters,
    MeshParameters,
    NucleusParameters,
    RandomParameters,
    cell_parameters,
    describe_cell,
)
from elastocell.parameters.flow import FlowLatticeParameters, flow_cell, shear_mesh_size
from elastocell.parameters.units import ParameterError, parse_quantity

__all__ = ["AXIS_INDEX", "DEFAULT_MESH_SIZES", "Axis", "CellParameters", "FlowLatticeParameters", "MaterialParameters",
           "MeshParameters", "NucleusParameters", "ParameterError", "RandomParameters", "cell_parameters",
           "describe_cell", "flow_cell", "parse_quantity", "shear_mesh_size"]
