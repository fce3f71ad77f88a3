"""Lattice and coupling settings shared by the flow scenarios, and the cell a flow run uses (a uniform mesh
whose edge is tied to the lattice spacing).
"""

from __future__ import annotations

import math
import warnings

# =========================================================================== shear flow
from typing import ClassVar, Literal  # noqa: E402

from pydantic import BaseModel, ConfigDict, model_validator  # noqa: E402

from elastocell.parameters.cell import cell_parameters, require
from elastocell.parameters.units import ParameterError


class FlowLatticeParameters(BaseModel):
    """Lattice and coupling settings shared by the flow scenarios
    (``elastocell.scenarios.shear.ShearFlowParameters``, ``elastocell.scenarios.pipe.PipeFlowParameters``); each
    scenario documents their defaults and adds its own driving.

    resolution: R/dx in [2, 64]. box_length: periodic length in units of R (>= 2.5: the cell is 2R across).
    relaxation_time: LB tau in [0.55, 5]. reynolds_number: upper limit of the particle Reynolds number, in
    (0, 0.1] (Stokes regime). velocity_limit: upper limit of the largest fluid speed, in (0, 0.1] dx/dt.
    kernel, dtype, backend: immersed-boundary kernel, LB storage precision, compute engine.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")
    automatic_relaxation_time: ClassVar[bool] = False  # a scenario that chooses tau itself accepts None

    resolution: float = 8.0
    box_length: float = 8.0
    relaxation_time: float | None = 1.0
    reynolds_number: float = 0.1
    velocity_limit: float = 0.05
    kernel: Literal["trilinear", "peskin4"] = "trilinear"
    dtype: Literal["float32", "float64"] = "float32"
    backend: Literal["numba", "jax"] = "numba"

    @model_validator(mode="after")
    def _check_lattice(self) -> FlowLatticeParameters:
        require(math.isfinite(self.resolution) and 2 <= self.resolution <= 64, "resolution",
                f"R/dx must be in [2, 64], got {self.resolution}")
        require(math.isfinite(self.box_length) and self.box_length >= 2.5, "box_length",
                f"must be >= 2.5 (units of R; the cell is 2R across), got {self.box_length}")
        automatic = self.relaxation_time is None and self.automatic_relaxation_time
        require(automatic or (self.relaxation_time is not None and math.isfinite(self.relaxation_time)
                              and 0.55 <= self.relaxation_time <= 5), "relaxation_time",
                f"tau must be in [0.55, 5], got {self.relaxation_time}")
        require(math.isfinite(self.reynolds_number) and 0 < self.reynolds_number <= 0.1, "reynolds_number",
                f"the particle Reynolds number must be in (0, 0.1] (Stokes regime), got {self.reynolds_number}")
        require(math.isfinite(self.velocity_limit) and 0 < self.velocity_limit <= 0.1, "velocity_limit",
                f"must be in (0, 0.1] dx/dt, got {self.velocity_limit}")
        return self


DEFAULT_MESH_EDGE = 2.0
"""Default element edge of a shear-flow cell mesh, in lattice spacings (uniform mesh, no pole refinement).

Linear tetrahedra (the paper's model and the shear default) with edges of 2 dx keep the run limited by the
Reynolds number, not by the elastic time step; finer meshes raise the stiffness eigenvalue (and p2 mid-edge
nodes lie 1 dx apart), which the elastic stability limit then charges in time steps."""


def shear_mesh_size(resolution: float, edge: float = DEFAULT_MESH_EDGE) -> float:
    """Mesh size (units of R) for an element edge of ``edge`` dx at R/dx = ``resolution``, within [0.1, 0.6]."""
    return float(min(0.6, max(0.1, edge / float(resolution))))


def flow_cell(cell, cell_options: dict, resolution: float):
    """The CellParameters of a flow run: ``cell`` or the CELL OPTIONS of ``cell_parameters``; without an
    explicit mesh size the mesh is uniform with edges of 2 dx (:func:`shear_mesh_size`) and linear
    tetrahedra (``element="p1"``) unless another element is given; a projected J takes quadrature degree 5
    (:func:`projected_quadrature`)."""

    if cell is not None and cell_options:
        raise ParameterError("cell", f"give either cell= or cell options, not both ({', '.join(cell_options)})")
    if cell is not None:
        return projected_quadrature(cell)
    cell_options = dict(cell_options)
    cell_options.setdefault("element", "p1")
    if cell_options.get("mesh_size") is None:
        cell_options["mesh_size"] = shear_mesh_size(resolution)
    if cell_options.get("pole_size") is None:  # uniform: no plate contacts to refine for
        cell_options["pole_size"] = cell_options["mesh_size"]
    if cell_options.get("interface_size") is None:
        cell_options["interface_size"] = cell_options["mesh_size"]
    return projected_quadrature(cell_parameters(**cell_options))


def projected_quadrature(cell):
    """``cell`` with quadrature degree 5 where its J is projected onto linear polynomials (``volumetric``
    projected) and no degree is given: with the default 4 points that projection is the identity (as a
    compression takes it, ``compression_parameters_for``)."""
    mesh = cell.mesh
    if mesh.volumetric == "projected" and mesh.quadrature_degree is None:
        return cell.model_copy(update={"mesh": mesh.model_copy(update={"quadrature_degree": 5})})
    return cell


def check_capillary_number(value: float, parameter: str, maximum: float, validated: float, refusal: str,
                           validated_range: str) -> None:
    """A capillary number must be finite, > 0 and at most ``maximum`` (``refusal`` says why larger ones are
    impossible); above ``validated`` one warning says the run leaves the range ``validated_range`` covers."""
    require(math.isfinite(value) and value > 0, parameter, f"must be > 0, got {value}")
    require(value <= maximum, parameter, f"must be <= {maximum:g}, got {value:g}: {refusal}")
    if value > validated:
        warnings.warn(f"{parameter} {value:g} is beyond the validated range (<= {validated:g}, {validated_range}): "
                      "expect large strains and possibly inverted elements", stacklevel=4)
