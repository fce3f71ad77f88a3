"""The cell's parameters: nucleus (none, sphere, ellipsoid; stiffness ratio, size ratio, offset, axis), random
heterogeneity, material law, mesh; :func:`cell_parameters`, which builds them from the flat CELL OPTIONS
shared by the command line and the API.

Lengths and moduli are dimensionless (units of ``R`` and ``E_c``) unless given with physical units, e.g.
``radius="8um"``, ``youngs_modulus="1kPa"``; the simulation runs on the unit sphere with ``E_c = 1`` and
results are scaled back.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, field_validator, model_serializer, model_validator

from elastocell.parameters.units import MODULUS_SCALE, RADIUS_SCALE, ParameterError, parse_quantity

Axis = Literal["x", "y", "z"]
AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


class ParameterModel(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


def require(condition: bool, parameter: str, message: str) -> None:
    if not condition:
        raise ParameterError(parameter, message)


class NucleusParameters(ParameterModel):
    """The stiffer inclusion ("nucleus").

    shape: ``none``, ``sphere`` (radius ``size_ratio * R``) or ``ellipsoid`` (semi-axes ``semi_axes * R``,
    the first along ``nucleus_axis``, the others along the next axes in cyclic order).
    stiffness_ratio: gamma = E_n / E_c (> 0).
    offset: d, centre displacement in units of R along ``offset_axis``.
    """

    shape: Literal["none", "sphere", "ellipsoid"] = "sphere"
    stiffness_ratio: float = 2.0
    size_ratio: float = 0.5
    offset: float = 0.0
    offset_axis: Axis = "x"
    semi_axes: tuple[float, float, float] = (0.8, 0.4, 0.4)
    nucleus_axis: Axis = "x"

    @model_validator(mode="after")
    def _check(self) -> NucleusParameters:
        if self.shape == "none":
            return self
        require(
            math.isfinite(self.stiffness_ratio) and self.stiffness_ratio > 0,
            "stiffness_ratio",
            f"must be > 0, got {self.stiffness_ratio}",
        )
        require(math.isfinite(self.offset) and self.offset >= 0, "offset", f"must be >= 0, got {self.offset}")
        if self.shape == "sphere":
            require(0 < self.size_ratio < 1, "size_ratio", f"must be in (0, 1), got {self.size_ratio}")
            require(
                self.size_ratio + self.offset < 1,
                "offset",
                f"nucleus must lie inside the cell: size_ratio + offset must be < 1, "
                f"got {self.size_ratio} + {self.offset}",
            )
        else:
            require(
                all(math.isfinite(a) and a > 0 for a in self.semi_axes),
                "semi_axes",
                f"must all be > 0, got {self.semi_axes}",
            )
            reach = self.farthest_point_distance()
            require(
                reach < 1,
                "semi_axes",
                f"ellipsoid must lie inside the cell (farthest point at {reach:.3f} R, must be < 1 R)",
            )
        return self

    def axes_lengths(self) -> np.ndarray:
        """Semi-axis lengths along x, y, z (units of R)."""
        if self.shape == "sphere":
            return np.full(3, self.size_ratio)
        lengths = np.empty(3)
        first = AXIS_INDEX[self.nucleus_axis]
        for k in range(3):
            lengths[(first + k) % 3] = self.semi_axes[k]
        return lengths

    def centre(self) -> np.ndarray:
        """Nucleus centre (units of R)."""
        centre = np.zeros(3)
        centre[AXIS_INDEX[self.offset_axis]] = self.offset
        return centre

    def volume_fraction(self) -> float:
        """Analytic V_n / V of the inclusion."""
        if self.shape == "none":
            return 0.0
        return float(np.prod(self.axes_lengths()))

    def farthest_point_distance(self) -> float:
        """Largest distance from the cell centre to a point of the inclusion (units of R).

        Exact: maximise |c + A u| over the unit sphere by a dense angular search refined by Newton-free
        polishing (the function is smooth, the error of a 200x400 grid plus local refinement is < 1e-6).
        """
        lengths, centre = self.axes_lengths(), self.centre()
        theta = np.linspace(0, np.pi, 201)
        phi = np.linspace(0, 2 * np.pi, 401)
        t, p = np.meshgrid(theta, phi, indexing="ij")
        u = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
        distance = np.linalg.norm(centre + u * lengths, axis=-1)
        i, j = np.unravel_index(np.argmax(distance), distance.shape)
        t0, p0 = theta[i], phi[j]
        span = np.pi / 200
        tt, pp = np.meshgrid(
            np.linspace(t0 - span, t0 + span, 101), np.linspace(p0 - span, p0 + span, 101), indexing="ij"
        )
        u = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1)
        return float(np.linalg.norm(centre + u * lengths, axis=-1).max())


class RandomParameters(ParameterModel):
    """Random heterogeneous cell: each tetrahedron gets ``gamma_i ~ U[low, high]`` (seeded)."""

    seed: int = 0
    low: float = 1.0
    high: float = 10.0

    @model_validator(mode="after")
    def _check(self) -> RandomParameters:
        require(0 < self.low <= self.high, "random stiffness range", f"need 0 < low <= high, got {self.low}, {self.high}")
        return self


LAWS: dict = {}
"""The strain-energy laws by name, ``elastocell.body.materials.LAWS`` (the same dict): that module fills it when
imported (its built-in laws) and with every ``register_law``. It lives here, below the laws, so that a cell's
``material.law`` is checked against it; before that module is imported it is empty and a name is checked when
the cell is built."""


class MaterialParameters(ParameterModel):
    """Hyperelastic law and Poisson ratio.

    law: ``neo-hookean``, ``mooney-rivlin`` or a law added with ``elastocell.body.materials.register_law``
    (a name in :data:`LAWS`); for Mooney-Rivlin ``mu1 = mooney_rivlin_mu1_fraction * mu``,
    ``mu2 = (1 - fraction) * mu`` (the paper's appendix: 0.25).
    poisson_ratio: nu in (-1, 0.5) (default 0.48, the paper's value).
    """

    law: str = "neo-hookean"
    poisson_ratio: float = 0.48
    mooney_rivlin_mu1_fraction: float = 0.25

    @field_validator("law", mode="before")
    @classmethod
    def _law(cls, value):
        if not isinstance(value, str) or not value or (LAWS and value not in LAWS):
            raise ParameterError("material", f"must be one of {', '.join(LAWS) or 'the laws'} (or a law added "
                                 f"with elastocell.body.materials.register_law), got {value!r}")
        return value

    @model_validator(mode="after")
    def _check(self) -> MaterialParameters:
        require(
            -1 < self.poisson_ratio < 0.5, "poisson_ratio", f"must be in (-1, 0.5), got {self.poisson_ratio}"
        )
        require(
            0 <= self.mooney_rivlin_mu1_fraction <= 1,
            "mooney_rivlin_mu1_fraction",
            f"must be in [0, 1], got {self.mooney_rivlin_mu1_fraction}",
        )
        return self


class MeshParameters(ParameterModel):
    """Tetrahedral mesh of the unit ball.

    element: ``p1`` (4-node, the paper's model) or ``p2`` (10-node, curved boundary).
    mesh_size: characteristic element edge length far from the poles (units of R).
    pole_size: edge length at the two poles z = +-R where the plates touch (units of R); ``None`` = uniform.
    pole_radius: distance from a pole over which the size grows from ``pole_size`` to ``mesh_size`` (above
    sqrt(2), the equator's distance from the nearer pole, no point reaches ``mesh_size``: the whole cell is graded;
    at most 4).
    interface_size: edge length on the nucleus surface (units of R); ``None`` (or >= ``mesh_size``) = no interface
    refinement.
    interface_width: distance from the nucleus surface over which the size grows from ``interface_size`` to
    ``mesh_size``. A compression of a stiff nucleus on the default mesh takes a refined one
    (``compression.STIFF_NUCLEUS_MESHES``); a mesh whose sizes differ from the default's is used as given.
    quadrature_degree: polynomial degree the p2 elements' quadrature rule integrates exactly, 2 to 9 (None: 2, the
    4-point rule, exact for the small-strain stiffness). Higher degrees cost more per assembly (25 points for 4-5,
    64 for 6-7) and see more of a quadratic element folding at large strain. The rule of degree 4-5 contains the
    ten nodes, so that no element folds at a node (``elements.nodal_rule_25``): the choice for a stiff nucleus at
    large delta, and the one ``elastocell.compress`` takes when None is given for such a cell
    (``compression.compression_parameters_for``).
    Linear elements always use their exact one-point rule, so the option does not apply to them. Does not
    change the mesh.
    layer_size: edge length in the cytoplasm within ``layer_angle`` (degrees) of the plate axis z, i.e. the soft
    layer a stiff nucleus crushes against the plates, growing to the other sizes over 15 degrees; ``None`` (the
    default: validation/stiff_3d.py measured it to remove only part of a stiff nucleus's error) = no such
    refinement (the layer fields are then left out of the model's data, so that every mesh, cache key and run key
    without it is what it is without the fields).
    layer_depth: if set, the polar layer's refinement only within this distance of the cell surface, growing to
    the other sizes over 0.1 R inwards (the contact zone alone: a diagnostic of the contact's resolution).
    volumetric: how the volume ratio J enters the law. ``standard``: J = det F at each quadrature point.
    ``projected``: J is L2-projected, element by element, onto the linear polynomials (a discontinuous P1
    dilatation, statically condensed) and the law is evaluated on F_bar = (J_bar/J)^(1/3) F; ``mean``: onto
    the constants (mean dilatation, P0). Both relieve the volumetric locking of a nearly incompressible layer
    crushed between a stiff nucleus and a plate (docs/theory.md). p2 only; with the 4-point rule the P1
    projection is the identity (four points, four polynomials), so ``projected`` refuses degree 2 and a
    compression or a flow takes degree 5 for it when none is given. ``nodal`` (p1 only, the flows only: the static
    solvers refuse it): the law's volumetric part per node, from the volumes of its elements (the averaged nodal
    dilatation, which relieves the volumetric locking of linear tetrahedra; docs/theory.md). Does not change the mesh; ``standard`` is left out of
    the model's data (cache and run keys unchanged).
    """

    element: Literal["p1", "p2"] = "p2"
    mesh_size: float = 0.35
    pole_size: float | None = 0.08
    pole_radius: float = 1.4
    interface_size: float | None = 0.15
    interface_width: float = 0.25
    quadrature_degree: int | None = None
    layer_size: float | None = None
    layer_angle: float = 40.0
    layer_depth: float | None = None
    volumetric: str = "standard"

    @model_serializer(mode="wrap")
    def _dump(self, handler):
        data = handler(self)
        if self.layer_size is None:
            data.pop("layer_size", None)
            data.pop("layer_angle", None)
        if self.layer_depth is None:
            data.pop("layer_depth", None)
        if self.volumetric == "standard":
            data.pop("volumetric", None)
        return data

    @property
    def refines_interface(self) -> bool:
        """True when ``interface_size`` is finer than the bulk, i.e. changes a mesh that has a nucleus."""
        return self.interface_size is not None and self.interface_size < self.mesh_size

    @classmethod
    def default_for(cls, element: str) -> MeshParameters:
        """Default sizes per element order, chosen by ``validation/compression.py`` (errors against a 24,389-node p2
        mesh of the reference cell, README):

        - p2: bulk 0.35, poles 0.08 graded over 1.4 R, nucleus surface 0.15 (4,656 nodes for the reference
          cell): F within 0.81/0.41/0.31/0.24 % at delta = 0.1/0.3/0.5/0.7. The refined nucleus surface is what
          lets a stiffness-ratio-10 nucleus reach delta = 0.75 (the soft layer between nucleus and plate).
        - p1: 3,861 nodes; linear tetrahedra need a finer mesh and still lock (see docs/validation/compression.md).
        """
        return cls(**DEFAULT_MESH_SIZES.get(element, {}), element=element)

    @field_validator("element", mode="before")
    @classmethod
    def _element(cls, value):
        if value not in ("p1", "p2"):
            raise ParameterError("element", f"must be p1 or p2, got {value!r}")
        return value

    @model_validator(mode="after")
    def _check(self) -> MeshParameters:
        require(0.02 <= self.mesh_size <= 1.0, "mesh_size", f"must be in [0.02, 1] (units of R), got {self.mesh_size}")
        if self.pole_size is not None:
            require(
                0.005 <= self.pole_size <= self.mesh_size,
                "pole_size",
                f"must be in [0.005, mesh_size={self.mesh_size}], got {self.pole_size}",
            )
        require(0 < self.pole_radius <= 4, "pole_radius", f"must be in (0, 4], got {self.pole_radius}")
        if self.interface_size is not None:  # at or above mesh_size: no refinement
            require(0.005 <= self.interface_size, "interface_size", f"must be >= 0.005 (units of R), got {self.interface_size}")
        require(0 < self.interface_width <= 2, "interface_width", f"must be in (0, 2], got {self.interface_width}")
        if self.layer_size is not None:
            require(0.005 <= self.layer_size <= self.mesh_size, "layer_size",
                    f"must be in [0.005, mesh_size={self.mesh_size}], got {self.layer_size}")
        require(0 < self.layer_angle <= 90, "layer_angle", f"must be in (0, 90] degrees, got {self.layer_angle}")
        if self.layer_depth is not None:
            require(0 < self.layer_depth <= 1, "layer_depth", f"must be in (0, 1] (units of R), got {self.layer_depth}")
        require(self.volumetric in ("standard", "projected", "mean", "nodal"), "volumetric",
                f"must be standard, projected, mean or nodal, got {self.volumetric!r}")
        require(self.volumetric in ("standard", "nodal") or self.element == "p2", "volumetric",
                f"{self.volumetric} applies to p2 elements only (a p1 element has one point: nothing to project)")
        require(self.volumetric != "nodal" or self.element == "p1", "volumetric",
                "nodal applies to p1 elements only (the averaged nodal dilatation of linear tetrahedra)")
        require(not (self.volumetric == "projected" and self.quadrature_degree == 2), "volumetric",
                "projected needs a quadrature degree above 2: the linear projection of the 4-point rule's J is J")
        if self.quadrature_degree is not None:
            require(self.element == "p2", "quadrature_degree",
                     "applies to p2 elements only (p1 uses its exact one-point rule)")
            require(2 <= self.quadrature_degree <= 9, "quadrature_degree",
                     f"must be in [2, 9] for p2 elements, got {self.quadrature_degree}")
        return self


DEFAULT_MESH_SIZES = {
    "p2": {"mesh_size": 0.35, "pole_size": 0.08, "pole_radius": 1.4, "interface_size": 0.15},
    "p1": {"mesh_size": 0.12, "pole_size": 0.04, "pole_radius": 0.9, "interface_size": None},
}


class CellParameters(ParameterModel):
    """A cell: geometry, heterogeneity, material, mesh, and its physical scales.

    radius: R in metres when ``physical_units`` (else 1, dimensionless).
    youngs_modulus: E_c in pascals when ``physical_units`` (else 1, dimensionless).
    random: if set, the random heterogeneous cell (the nucleus is ignored and must be ``none``).
    """

    nucleus: NucleusParameters = NucleusParameters()
    random: RandomParameters | None = None
    material: MaterialParameters = MaterialParameters()
    mesh: MeshParameters = MeshParameters()
    radius: float = 1.0
    youngs_modulus: float = 1.0
    radius_is_physical: bool = False
    youngs_modulus_is_physical: bool = False

    @model_validator(mode="after")
    def _check(self) -> CellParameters:
        require(
            math.isfinite(self.radius) and self.radius > 0, "radius", f"must be > 0, got {self.radius}"
        )
        require(
            math.isfinite(self.youngs_modulus) and self.youngs_modulus > 0,
            "youngs_modulus",
            f"must be > 0, got {self.youngs_modulus}",
        )
        if self.random is not None:
            require(
                self.nucleus.shape == "none",
                "random",
                "the random cell has no nucleus: use nucleus shape 'none' with random",
            )
        return self

    def force_scale(self) -> float:
        """E_c R^2: the force unit (N when both are physical)."""
        return self.youngs_modulus * self.radius**2


def cell_parameters(
    nucleus: str = "sphere",
    stiffness_ratio: float = 2.0,
    size_ratio: float = 0.5,
    offset: float = 0.0,
    offset_axis: str = "x",
    semi_axes: tuple[float, float, float] = (0.8, 0.4, 0.4),
    nucleus_axis: str = "x",
    random: bool = False,
    seed: int | None = None,
    mesh_size: float | None = None,
    pole_size: float | None = None,
    interface_size: float | None = None,
    pole_radius: float | None = None,
    element: str = "p2",
    quadrature_degree: int | None = None,
    volumetric: str = "standard",
    material: str = "neo-hookean",
    poisson_ratio: float = 0.48,
    youngs_modulus: float | str = 1.0,
    radius: float | str = 1.0,
) -> CellParameters:
    """Validated :class:`CellParameters` from the flat CELL OPTIONS shared by every scenario.

    With no arguments: the paper's reference cell (spherical nucleus, stiffness ratio 2, size ratio 0.5,
    centred, nu = 0.48, neo-Hookean). ``radius``/``youngs_modulus`` accept physical units ("8um", "1kPa"); a bare
    number is dimensionless (units of R, of E_c), the one exception to the bare-number rule of parse_quantity.
    """
    radius_value, radius_physical = parse_quantity(radius, "m", "radius", scale=RADIUS_SCALE)
    modulus_value, modulus_physical = parse_quantity(youngs_modulus, "Pa", "youngs_modulus", scale=MODULUS_SCALE)
    _refuse_conflicts(nucleus, random, {"stiffness_ratio": stiffness_ratio, "size_ratio": size_ratio,
                                        "offset": offset, "offset_axis": offset_axis,
                                        "semi_axes": tuple(semi_axes), "nucleus_axis": nucleus_axis})
    _refuse_unread(nucleus, random, seed, mesh_size, interface_size)
    if random:
        nucleus = "none"
    defaults = MeshParameters.default_for(element) if element in ("p1", "p2") else MeshParameters()
    mesh_size = defaults.mesh_size if mesh_size is None else mesh_size
    if pole_size is None:  # keep the default pole refinement unless the bulk size is already finer
        pole_size = defaults.pole_size if defaults.pole_size < mesh_size else None
    if interface_size is None and defaults.interface_size is not None:  # in proportion to the bulk size
        interface_size = defaults.interface_size * mesh_size / defaults.mesh_size
    mesh = MeshParameters(element=element, mesh_size=mesh_size, pole_size=pole_size, interface_size=interface_size,
                          pole_radius=defaults.pole_radius if pole_radius is None else pole_radius,
                          quadrature_degree=quadrature_degree, volumetric=volumetric)
    return CellParameters(
        nucleus=NucleusParameters(
            shape=nucleus, stiffness_ratio=stiffness_ratio, size_ratio=size_ratio, offset=offset,
            offset_axis=offset_axis, semi_axes=tuple(semi_axes), nucleus_axis=nucleus_axis,
        ),
        random=RandomParameters(seed=0 if seed is None else seed) if random else None,
        material=MaterialParameters(law=material, poisson_ratio=poisson_ratio),
        mesh=mesh,
        radius=radius_value,
        youngs_modulus=modulus_value,
        radius_is_physical=radius_physical,
        youngs_modulus_is_physical=modulus_physical,
    )


NUCLEUS_OPTION_DEFAULTS = {"stiffness_ratio": 2.0, "size_ratio": 0.5, "offset": 0.0, "offset_axis": "x",
                           "semi_axes": (0.8, 0.4, 0.4), "nucleus_axis": "x"}
"""Defaults of the nucleus options of :func:`cell_parameters`; an option set away from its default must apply."""

NUCLEUS_OPTIONS_USED = {
    "sphere": {"stiffness_ratio", "size_ratio", "offset", "offset_axis"},
    "ellipsoid": {"stiffness_ratio", "semi_axes", "nucleus_axis", "offset", "offset_axis"},
    "none": set(),
}
"""The nucleus options each nucleus shape reads; a random cell reads none of them."""


def _refuse_conflicts(nucleus: str, random: bool, options: dict) -> None:
    """Options that cannot apply together are refused in one line, not silently ignored: nucleus options with
    ``random`` (the random cell has no nucleus) or with a shape that does not read them (``size_ratio`` of an
    ellipsoid, ``semi_axes`` of a sphere, anything of ``nucleus="none"``), and an offset axis without an offset."""
    given = [name for name, value in options.items() if value != NUCLEUS_OPTION_DEFAULTS[name]]
    if random:
        if nucleus != "sphere" or given:
            shown = [name for name in given] + (["nucleus"] if nucleus != "sphere" else [])
            raise ParameterError("random", "the random cell has no nucleus; do not combine it with "
                                           + ", ".join(sorted(shown)))
        return
    unused = [name for name in given if name not in NUCLEUS_OPTIONS_USED.get(nucleus, set())]
    if unused:
        raise ParameterError(unused[0], f"does not apply to nucleus {nucleus!r} (it reads "
                                        f"{', '.join(sorted(NUCLEUS_OPTIONS_USED.get(nucleus, ()))) or 'none'})")
    if options["offset_axis"] != NUCLEUS_OPTION_DEFAULTS["offset_axis"] and options["offset"] == 0:
        raise ParameterError("offset_axis", "needs an offset (--offset > 0) to apply")


def _refuse_unread(nucleus: str, random: bool, seed: int | None, mesh_size: float | None,
                   interface_size: float | None) -> None:
    """Cell options that nothing would read, given away from their defaults, are refused in one line: ``seed``
    (any value, 0 included; None stands for the default seed 0) without ``random``, and ``interface_size`` (the
    element size on the nucleus surface) of a cell without a
    nucleus (``nucleus="none"`` or ``random``). An interface size equal to ``mesh_size`` refines nothing and is
    accepted (the flow scenarios' uniform mesh sets it so)."""
    if seed is not None and not random:
        raise ParameterError("seed", "applies only to the random cell; add --random (random=True) or drop it")
    if (interface_size is not None and (nucleus == "none" or random)
            and (mesh_size is None or interface_size != mesh_size)):
        raise ParameterError("interface_size", "the element size on the nucleus surface does not apply to a cell "
                                               "without a nucleus (" + ("random" if random else "nucleus 'none'")
                             + "); drop it")


def describe_cell(cell: CellParameters) -> str:
    if cell.random is not None:
        return f"random cell (seed {cell.random.seed})"
    n = cell.nucleus
    if n.shape == "none":
        return "homogeneous cell"
    if n.shape == "sphere":
        text = f"nucleus cell (gamma={n.stiffness_ratio:g}, lambda={n.size_ratio:g}"
    else:
        text = f"ellipsoid nucleus cell (gamma={n.stiffness_ratio:g}, axes={n.semi_axes}, along {n.nucleus_axis}"
    if n.offset:
        text += f", d={n.offset:g} along {n.offset_axis}"
    return text + ")"
