"""A cell in pressure-driven (Poiseuille) flow through a capillary: a cylinder (paper sections 2.6 and 3.3) or a
rectangular duct, in a Newtonian or shear-thinning medium.

Channel (docs/theory.md, "Pipe (capillary) flow"): a cylinder of radius R_ch along x, periodic along x,
driven by a uniform body-force density G along x (the pressure gradient). Lattice nodes (integer indices)
whose distance from the axis exceeds R_ch are solid; every fluid-solid link bounces back with the wall at r = R_ch
on the link (interpolated bounce-back, ``channel_wall`` "interpolated", the default) or half-way between its nodes
(the lattice's staircase, "staircase"). The empty channel reproduces Poiseuille flow

    u(r) = G (R_ch^2 - r^2) / (4 eta),      Q = pi G R_ch^4 / (8 eta),

to the accuracy measured by :func:`poiseuille_error` (second order with the interpolated wall, first order with
the staircase).

The channel may instead be a rectangular duct (``channel_shape`` "square" or "rectangle", RT-DC's chips):
width W = 2 R_ch along y, height H along z, plane walls half-way between nodes (the Newtonian series of
:func:`duct_velocity` / :func:`duct_flow_rate`, second order, :func:`duct_error`), and the medium a shear-thinning
power law (``medium``: the MC-PBS presets of :mod:`elastocell.parameters.medium` or "power-law"; per-node
viscosity from the local strain rate, :mod:`elastocell.lattice.rheology`). A duct or a power-law medium starts from
the lattice's own steady empty channel (:func:`channel_profile`).

Scenario: an elastic cell (mesh in units of R, every node an immersed-boundary marker; the coupled stepping
of :class:`~elastocell.coupling.immersed.ImmersedCell`, whose compiled path applies the lattice's uniform body force and
its solid mask) starts at the radial offset r0 from the axis, along +y. The driving is set by the capillary
number at the wall, Ca_w = G R_ch / (2 mu_ref) (mu_ref = mu_c, or mu_eff for the homogeneous equivalent),
so that the local value is Ca(r) = Ca_w r / R_ch. Time is measured in units of the inverse wall shear rate
1/gdot_w, gdot_w = G R_ch / (2 eta) (so that Ca_w = eta gdot_w / mu_ref, as Ca in shear flow).

Observables (a row every record): radial position of the volume centroid (units of R_ch), its axial
velocity (mean marker velocity, units of the empty channel's centre-line speed u_max = G R_ch^2/(4 eta)),
the local capillary number at the centre, the strains eps_x = l_x/(2R) (extent along the axis) and
eps_r = l_r/(2R) (extent along y, the radial direction of the start offset; by symmetry the cell stays in
the x-y plane; 2R is taken as the undeformed mesh's own extent along the same axis, so that a coarse mesh,
whose extreme nodes lie inside the sphere's poles, reads exactly 1 at rest), the projected side-view contour
(what a camera looking along z sees, RT-DC's convex cell outline: for linear elements, the convex hull of the
projection of the smooth surface fitted through the surface nodes, :func:`elastocell.body.observables.smooth_outline`
(the hull of the nodes alone, :func:`side_view`, is a polygon inside the outline that reads D = 0.0037 and an area
2.2 % short for the sphere at rest at R/dx 6); for quadratic elements, the convex hull of their own curved surface,
:func:`elastocell.body.observables.element_surface_outline`): its area (units of R^2; pi for the undeformed cell) and its deformation
1 - circularity, circularity = 2 sqrt(pi area)/perimeter; the volume change and the nucleus position.

Running (:class:`PipeRun`, :func:`pipe`): the simulation runner of the shear-flow scenario
(:class:`elastocell.simulation.runner.FlowRun` and its output-directory helpers: stop criteria on duration, wall clock
or a stationary running mean of ``strain_axial`` or ``deformation``, guards, observers, VTK snapshots,
progress bar, atomic checkpoints whose resumed series equals the uninterrupted one).
"""


from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import model_serializer, model_validator

from elastocell.body.mesh import outer_surface_triangles
from elastocell.body.observables import (
    OUTLINE_VIEWS,
    element_side_view_readings,
    mean_side_view,
    moments,
    side_view_readings,
)
from elastocell.coupling import ibm
from elastocell.coupling.immersed import ImmersedCell, immersed_cell
from elastocell.coupling.markers import FlowError
from elastocell.coupling.stability import shear_rate_limits
from elastocell.lattice import Lattice, LatticeParams
from elastocell.lattice.rheology import (
    DEFAULT_TAU_RANGE,
    PowerLaw,
    slab_flow_rate,
    slab_velocity,
    tube_flow_rate,
)
from elastocell.parameters.cell import require
from elastocell.parameters.flow import FlowLatticeParameters, check_capillary_number
from elastocell.parameters.medium import MC_PBS, Medium, medium
from elastocell.parameters.units import ParameterError
from elastocell.simulation.output import save_time_series_figure, time_series_figure
from elastocell.simulation.runner import FlowRun, StopCriteria, window_verdict

# =========================================================================== empty channel


def channel_shape(radius: float, length: int) -> tuple[int, int, int]:
    """Lattice shape (nx, ny, nz) of a channel of radius ``radius`` (dx) and ``length`` nodes along x: the
    cross-section holds the disc r <= radius plus at least one solid layer on every side."""
    n = 2 * int(math.ceil(radius)) + 2
    return (int(length), n, n)


def channel_axis(shape: tuple[int, int, int]) -> tuple[float, float]:
    """(y, z) of the channel axis in node coordinates: the centre of the cross-section."""
    return ((shape[1] - 1) / 2.0, (shape[2] - 1) / 2.0)


def channel_solid(shape: tuple[int, int, int], radius: float) -> np.ndarray:
    """Solid mask (nx, ny, nz): nodes farther than ``radius`` (dx) from the axis (a staircase cylinder)."""
    nx, ny, nz = shape
    ay, az = channel_axis(shape)
    y = np.arange(ny) - ay
    z = np.arange(nz) - az
    r2 = y[:, None] ** 2 + z[None, :] ** 2
    return np.broadcast_to(r2 > radius * radius, (nx, ny, nz)).copy()


PIPE_CHANNEL_WALL = "interpolated"
"""The cylinder's default wall (:data:`CHANNEL_WALLS`): the empty channel's profile error is 7-64 times the
staircase's smaller at R_ch 4.3-20.3 dx, and at the six LE-2D-FEM-19 cells of docs/validation/pipe_dclab.md
(section "pipe_wall.py") the deformation's error ranges -7.6/+15.9 % instead of -3.3/+25.4 %; a whole run costs 1.03
times the same run on the staircase (docs/validation/flow_default.md)."""

CHANNEL_WALLS = ("staircase", "interpolated")
"""How the lattice places a cylinder's wall: "staircase" (half-way bounce-back on the solid nodes r > R_ch, the
wall of each link half-way between its nodes) or "interpolated" (linearly interpolated bounce-back with the wall at
r = R_ch on every link, Bouzidi et al. 2001; :mod:`elastocell.lattice.geometry`). A duct's plane walls lie
half-way by construction: both are the same there."""


def cylinder_wall_fraction(shape: tuple[int, int, int], radius: float):
    """q(x, c) of the cylinder r = ``radius`` (dx) about the channel axis: the fraction of each link from a fluid
    node x along c_i at which it crosses the wall, from |p + q d| = R_ch in the cross-section (p, d the (y, z)
    parts of x - axis and c_i); for :class:`~elastocell.lattice.params.LatticeParams` ``wall_fraction``."""
    ay, az = channel_axis(shape)

    def wall_fraction(x: np.ndarray, c: np.ndarray) -> np.ndarray:
        py, pz, dy, dz = x[:, 1] - ay, x[:, 2] - az, c[:, 1], c[:, 2]
        a = dy * dy + dz * dz  # > 0: a link along x alone never leaves the cylinder
        half_b = py * dy + pz * dz
        inside = radius * radius - (py * py + pz * pz)  # >= 0 for a fluid node
        q = (-half_b + np.sqrt(half_b * half_b + np.maximum(a * inside, 0.0))) / a
        return np.clip(q, np.finfo(float).tiny, 1.0)  # a node on the wall itself, or round-off past the solid node

    return wall_fraction


def channel_wall_fraction(channel: str, wall: str, shape: tuple[int, int, int], half_width: float):
    """The lattice's ``wall_fraction`` for a channel and a :data:`CHANNEL_WALLS` choice: None unless an
    interpolated cylinder."""
    if wall not in CHANNEL_WALLS:
        raise ParameterError("channel_wall", f"must be one of {', '.join(CHANNEL_WALLS)}, got {wall!r}")
    return cylinder_wall_fraction(shape, half_width) if channel == "cylinder" and wall == "interpolated" else None


def radial_distance(shape: tuple[int, int, int]) -> np.ndarray:
    """Distance of every cross-section node (ny, nz) from the axis (dx)."""
    ay, az = channel_axis(shape)
    y = np.arange(shape[1]) - ay
    z = np.arange(shape[2]) - az
    return np.sqrt(y[:, None] ** 2 + z[None, :] ** 2)


def poiseuille_velocity(r, body_force: float, viscosity: float, radius: float):
    """u(r) = G (R_ch^2 - r^2)/(4 eta) for r <= R_ch, 0 outside (eta = rho0 nu; any consistent units)."""
    r = np.asarray(r, dtype=float)
    return np.where(r <= radius, body_force * (radius**2 - r**2) / (4.0 * viscosity), 0.0)


def poiseuille_flow_rate(body_force: float, viscosity: float, radius: float) -> float:
    """Q = pi G R_ch^4 / (8 eta)."""
    return math.pi * body_force * radius**4 / (8.0 * viscosity)


CHANNEL_SHAPES = ("cylinder", "square", "rectangle")
"""Cross-sections of the channel: a staircase cylinder, or a duct whose plane walls lie half-way between nodes."""


def duct_nodes(half_width: float, half_height: float) -> tuple[int, int]:
    """Fluid nodes across a duct of half-width a (y) and half-height b (z), in dx: 2a and 2b rounded to whole
    nodes (>= 2), so that the half-way walls lie at +-(nodes/2) from the axis."""
    return max(2, int(round(2.0 * half_width))), max(2, int(round(2.0 * half_height)))


def duct_cell_radius(resolution: float, channel_radius_ratio: float) -> float:
    """The cell's radius R in lattice units (dx) in a duct: ``resolution`` moved (by at most 1/(4 R_ch/R)) so that
    the duct's width 2 (R_ch/R) R is whole nodes (:func:`duct_nodes`) and the lattice's channel is the channel
    asked for: rounding the width instead changed the confinement R/R_ch by up to 1.6 % between the standard
    table's radii, and D about 2.6 times as much (R 4.5 um / E 1.7 kPa in the 20 um duct: D 3.2 % higher in the
    exact duct than in the one rounded 1.25 % wider, the same mesh)."""
    nodes = duct_nodes(channel_radius_ratio * resolution, channel_radius_ratio * resolution)[0]
    return nodes / (2.0 * channel_radius_ratio)


def duct_shape(half_width: float, half_height: float, length: int) -> tuple[int, int, int]:
    """Lattice shape of a duct: the fluid nodes of :func:`duct_nodes` and one solid layer on every side."""
    wy, wz = duct_nodes(half_width, half_height)
    return (int(length), wy + 2, wz + 2)


def duct_solid(shape: tuple[int, int, int]) -> np.ndarray:
    """Solid mask of a duct: the outermost layer of nodes in y and z (walls half-way to the first fluid node)."""
    solid = np.zeros(shape, dtype=bool)
    solid[:, [0, -1], :] = True
    solid[:, :, [0, -1]] = True
    return solid


def channel_geometry(channel: str, half_width: float, aspect_ratio: float, length: int):
    """(shape, solid, half-width, half-height) of a channel: ``channel`` in :data:`CHANNEL_SHAPES`; for a duct the
    half-width a (dx) along y and the height 2b = aspect_ratio 2a along z, both rounded to whole nodes (the
    returned half-width and half-height are the lattice's own); a cylinder has radius ``half_width``."""
    if channel == "cylinder":
        shape = channel_shape(half_width, length)
        return shape, channel_solid(shape, half_width), float(half_width), float(half_width)
    if channel not in CHANNEL_SHAPES:
        raise ParameterError("channel_shape", f"must be one of {', '.join(CHANNEL_SHAPES)}, got {channel!r}")
    shape = duct_shape(half_width, aspect_ratio * half_width, length)
    return shape, duct_solid(shape), (shape[1] - 2) / 2.0, (shape[2] - 2) / 2.0


DUCT_TERMS = 60
"""Odd terms of the duct series (their sum converges like 1/i^3 at the walls, exponentially inside)."""


def duct_velocity(y, z, body_force: float, viscosity: float, half_width: float, half_height: float):
    """Newtonian flow through a rectangular duct |y| < a, |z| < b driven by G (White, Viscous Fluid Flow, eq. 3-48):
    u = 16 a^2 G/(eta pi^3) sum_{i odd} (-1)^((i-1)/2) [1 - cosh(i pi z/2a)/cosh(i pi b/2a)] cos(i pi y/2a)/i^3."""
    y, z = np.broadcast_arrays(np.asarray(y, dtype=float), np.asarray(z, dtype=float))
    a, b = half_width, half_height
    inside = (np.abs(y) <= a) & (np.abs(z) <= b)
    u = np.zeros(y.shape)
    for i in range(1, 2 * DUCT_TERMS, 2):
        k = i * math.pi / (2 * a)
        # cosh(kz)/cosh(kb) written with exponentials of non-positive arguments (no overflow)
        ratio = (np.exp(k * (np.abs(z) - b)) + np.exp(-k * (np.abs(z) + b))) / (1 + math.exp(-2 * k * b))
        u += (-1) ** ((i - 1) // 2) * (1 - ratio) * np.cos(k * y) / i**3
    return np.where(inside, 16 * a * a * body_force / (viscosity * math.pi**3) * u, 0.0)


def duct_flow_rate(body_force: float, viscosity: float, half_width: float, half_height: float) -> float:
    """Q = 4 b a^3 G/(3 eta) [1 - 192 a/(pi^5 b) sum_{i odd} tanh(i pi b/2a)/i^5] (White, eq. 3-49)."""
    a, b = half_width, half_height
    series = sum(math.tanh(i * math.pi * b / (2 * a)) / i**5 for i in range(1, 2 * DUCT_TERMS, 2))
    return 4 * b * a**3 * body_force / (3 * viscosity) * (1 - 192 * a / (math.pi**5 * b) * series)


def duct_centre_factor(aspect_ratio: float) -> float:
    """kappa = u_max eta/(G a^2) of a Newtonian duct of height/width ``aspect_ratio`` (1/4 would be the cylinder's)."""
    return float(duct_velocity(0.0, 0.0, 1.0, 1.0, 1.0, aspect_ratio))


DUCT_CELLS = 64
"""Finite-volume cells across the square duct for q1(n) of a power law. Measured at n = 1 against White's series:
relative error 9.4e-4 (64 cells), 2.4e-4 (128); at n = 0.586 the 32, 64 and 128 cell values lie within 8.5e-5."""


@functools.lru_cache(maxsize=16)
def unit_flow_rate(channel: str, flow_index: float, aspect_ratio: float = 1.0) -> float:
    """q1(n): the flow rate at G = K = 1 through the cylinder of radius 1, or the duct of half-width 1 and
    half-height ``aspect_ratio`` (eta = K gdot^(n-1)); Q = q1 (G/K)^(1/n) a^(3+1/n) for any G, K and half-width a."""
    n = float(flow_index)
    if channel == "cylinder":
        return tube_flow_rate(1.0, 1.0, n, 1.0)
    if n == 1.0:
        return duct_flow_rate(1.0, 1.0, 1.0, float(aspect_ratio))
    return power_law_duct_unit_flow_rate(n, float(aspect_ratio))


def duct_cells(aspect_ratio: float, cells: int = DUCT_CELLS) -> int:
    """Finite volumes across the width of a duct of height/width ``aspect_ratio``: at least ``cells`` across its
    shorter side, and as many as make the height a whole number of cells most nearly (the scheme rounds it)."""
    base = cells if aspect_ratio >= 1 else math.ceil(cells / aspect_ratio)
    return min(range(base, 2 * base + 1), key=lambda c: abs(c * aspect_ratio - round(c * aspect_ratio)) / c)


def power_law_duct_unit_flow_rate(flow_index: float, aspect_ratio: float) -> float:
    """q1(n) of the duct of half-width 1 and half-height ``aspect_ratio`` by finite volumes
    (:func:`finite_difference_duct_flow_rate` on :func:`duct_cells`), the lattice law's tau clamp opened to nu in
    [1e-12, 1e9]: the continuum power law."""
    law = PowerLaw(flow_index, 1.0, relaxation_time_min=0.5 + 3e-12, relaxation_time_max=0.5 + 3e9)
    return finite_difference_duct_flow_rate(law, 1.0, 1.0, aspect_ratio, cells=duct_cells(aspect_ratio),
                                            tolerance=1e-12)


def ideal_flow_rate(units: PipeUnits) -> float:
    """Q (dx^3/dt) that the nominal body force ``units.body_force`` drives through the ideal channel of the run (the
    cylinder of radius R_ch or the duct of half-width R_ch and half-height ``channel_half_height``, smooth walls, no
    cell): Poiseuille, the duct series, or the power law's (:func:`unit_flow_rate`). The flow rate a pipe run holds
    (``hold_flow_rate``)."""
    a = units.channel_radius
    if units.rheology is None:
        k, n = units.viscosity, 1.0
    else:
        k, n = units.rheology.consistency, units.rheology.flow_index
    aspect = 1.0 if units.channel == "cylinder" else units.channel_half_height / a
    return unit_flow_rate(units.channel, n, aspect) * (units.body_force / k) ** (1.0 / n) * a ** (3.0 + 1.0 / n)


def empty_channel(radius: float, length: int = 4, relaxation_time: float = 1.0, body_force: float = 1e-6,
                  dtype: str = "float64", initialize: bool = True, channel: str = "cylinder",
                  aspect_ratio: float = 1.0, rheology: PowerLaw | None = None, wall: str = "staircase") -> Lattice:
    """Lattice of an empty channel driven by ``body_force`` along x: a cylinder of radius ``radius`` (dx) or a
    duct (``channel`` "square"/"rectangle") of half-width ``radius`` and height/width ``aspect_ratio``; with
    ``initialize`` the fluid starts from the Newtonian closed form at the viscosity of ``relaxation_time`` (the
    lattice then relaxes it to its own steady state). ``rheology``: a power-law medium (None: Newtonian).
    ``wall``: one of :data:`CHANNEL_WALLS`."""
    shape, solid, a, b = channel_geometry(channel, radius, aspect_ratio, length)
    viscosity = (relaxation_time - 0.5) / 3.0
    profile = newtonian_profile(shape, channel, body_force, viscosity, a, b)
    lattice = Lattice(LatticeParams(shape, relaxation_time=relaxation_time, dtype=dtype, solid=solid,
                                    body_force=(body_force, 0.0, 0.0), rheology=rheology,
                                    velocity_limit=min(0.5, max(0.05, 1.5 * float(profile.max()))),
                                    wall_fraction=channel_wall_fraction(channel, wall, shape, a)))
    if initialize:
        velocity = np.zeros((3,) + shape)
        velocity[0] = profile[None]
        lattice.initialize(velocity=velocity)
    return lattice


def newtonian_profile(shape, channel: str, body_force: float, viscosity: float, half_width: float,
                      half_height: float) -> np.ndarray:
    """The Newtonian closed form u_x on the cross-section (ny, nz) of a channel lattice (0 outside)."""
    if channel == "cylinder":
        return poiseuille_velocity(radial_distance(shape), body_force, viscosity, half_width)
    ay, az = channel_axis(shape)
    y = np.arange(shape[1])[:, None] - ay
    z = np.arange(shape[2])[None, :] - az
    return duct_velocity(y, z, body_force, viscosity, half_width, half_height)


def steady_profile(shape, solid: np.ndarray, body_force: float, relaxation_time: float,
                   rheology: PowerLaw | None, channel: str, half_width: float, half_height: float,
                   dtype: str = "float64", tolerance: float = 1e-7, wall: str = "staircase") -> np.ndarray:
    """The lattice's own steady u_x on the cross-section (ny, nz): one node-thick periodic slice of the channel
    relaxed from the Newtonian closed form (a few thousand steps on ny nz nodes; any medium and cross-section;
    ``wall`` one of :data:`CHANNEL_WALLS`)."""
    viscosity = (relaxation_time - 0.5) / 3.0
    profile = newtonian_profile(shape, channel, body_force, viscosity, half_width, half_height)
    limit = min(0.5, max(0.05, 3.0 * float(profile.max())))
    section = (1, shape[1], shape[2])
    lattice = Lattice(LatticeParams(section, relaxation_time=relaxation_time, dtype=dtype,
                                    solid=solid[:1], body_force=(body_force, 0.0, 0.0), rheology=rheology,
                                    velocity_limit=limit,
                                    wall_fraction=channel_wall_fraction(channel, wall, section, half_width)))
    velocity = np.zeros((3,) + section)
    velocity[0] = profile[None]
    lattice.initialize(velocity=velocity)
    relax_to_steady(lattice, tolerance)
    return np.where(solid[0], 0.0, lattice.velocity()[0, 0])


def flow_rate(lattice: Lattice, velocity: np.ndarray | None = None) -> float:
    """Volumetric flow rate along x (dx^3/dt): the mean over x of the sum of u_x over a cross-section; from
    ``velocity`` (the lattice's velocity field, (3, nx, ny, nz) in dx/dt) where the caller already has it."""
    u = (lattice.velocity() if velocity is None else velocity)[0]
    if lattice.solid is not None:
        u = np.where(lattice.solid, 0.0, u)
    return float(u.sum(axis=(1, 2)).mean())


def relax_to_steady(lattice: Lattice, tolerance: float = 1e-7, chunk: int | None = None,
                    max_steps: int = 200_000) -> int:
    """Step until the flow rate changes by less than ``tolerance`` (relative) over one chunk (default
    R_ch^2/(4 nu) steps, a quarter of a viscous time); returns the steps taken."""
    nu = lattice.kinematic_viscosity
    if chunk is None:
        chunk = max(50, int(0.25 * (lattice.shape[1] / 2.0) ** 2 / nu))
    q_old = flow_rate(lattice)
    steps = 0
    while steps < max_steps:
        lattice.step(chunk)
        steps += chunk
        q = flow_rate(lattice)
        if abs(q - q_old) <= tolerance * abs(q):
            break
        q_old = q
    return steps


def poiseuille_error(radius: float, relaxation_time: float = 1.0, body_force: float = 1e-6, length: int = 2,
                     dtype: str = "float64", tolerance: float = 1e-8, wall: str = "staircase") -> dict:
    """Steady empty channel (``wall`` one of :data:`CHANNEL_WALLS`) against the closed form at R_ch = ``radius`` dx.

    Returns the relative errors of the flow rate (Q_lattice/Q - 1), of the centre-line speed, and the L2
    error of the profile over the fluid nodes relative to the L2 norm of the closed form, plus the steps."""
    lattice = empty_channel(radius, length, relaxation_time, body_force, dtype, wall=wall)
    steps = relax_to_steady(lattice, tolerance)
    viscosity = lattice.kinematic_viscosity
    shape = lattice.shape
    r = radial_distance(shape)
    fluid = r <= radius
    u = lattice.velocity()[0].mean(axis=0)
    exact = poiseuille_velocity(r, body_force, viscosity, radius)
    q_exact = poiseuille_flow_rate(body_force, viscosity, radius)
    u_max = body_force * radius**2 / (4.0 * viscosity)
    centre = np.unravel_index(np.argmin(np.where(fluid, r, np.inf)), r.shape)
    return {
        "radius": float(radius),
        "flow_rate_error": flow_rate(lattice) / q_exact - 1.0,
        "profile_l2_error": float(np.sqrt(((u - exact)[fluid] ** 2).sum() / (exact[fluid] ** 2).sum())),
        "profile_max_error": float(np.abs(u - exact)[fluid].max() / u_max),
        "centre_speed_error": float(u[centre] / exact[centre] - 1.0),
        "steps": steps,
    }


def duct_error(half_width: float, aspect_ratio: float = 1.0, relaxation_time: float = 1.0,
               body_force: float = 1e-6, dtype: str = "float64", tolerance: float = 1e-8) -> dict:
    """Steady empty duct (Newtonian) against the series of :func:`duct_velocity` / :func:`duct_flow_rate` at
    the lattice's own half-width and half-height: relative flow-rate error, profile L2 and max errors (units of
    the closed form's centre speed), steps."""
    shape, solid, a, b = channel_geometry("rectangle", half_width, aspect_ratio, 1)
    u = steady_profile(shape, solid, body_force, relaxation_time, None, "rectangle", a, b, dtype, tolerance)
    viscosity = (relaxation_time - 0.5) / 3.0
    exact = newtonian_profile(shape, "rectangle", body_force, viscosity, a, b)
    fluid = ~solid[0]
    u_max = float(exact.max())
    return {"half_width": a, "half_height": b,
            "flow_rate_error": float(u.sum()) / duct_flow_rate(body_force, viscosity, a, b) - 1.0,
            "profile_l2_error": float(np.sqrt(((u - exact)[fluid] ** 2).sum() / (exact[fluid] ** 2).sum())),
            "profile_max_error": float(np.abs(u - exact)[fluid].max() / u_max)}


def finite_difference_duct_flow_rate(rheology: PowerLaw, body_force: float, half_width: float, half_height: float,
                                     cells: int = 64, tolerance: float = 1e-10, max_iterations: int = 300) -> float:
    """Flow rate of a power-law liquid (``rheology``, its tau clamp included) through a rectangular duct, by an
    independent method: finite volumes on ``cells`` x (cells H/W) cells (walls on cell faces), the nonlinear
    viscosity by Picard iteration (geometric damping), each step one sparse solve of
    div(nu grad u) = -G. Second order in the cell size; for the lattice's verification only (no lattice)."""
    import scipy.sparse as sparse  # lazy: verification only
    import scipy.sparse.linalg as linalg  # lazy: verification only

    ny = int(cells)
    nz = max(2, int(round(cells * half_height / half_width)))
    h = 2.0 * half_width / ny
    index = np.arange(ny * nz).reshape(ny, nz)
    nu_min, nu_max = ((t - 0.5) / 3.0 for t in (rheology.relaxation_time_min, rheology.relaxation_time_max))
    u = np.zeros((ny, nz))
    nu = None
    q = 0.0
    for iteration in range(max_iterations):
        ghost = np.pad(u, 1)  # u = 0 on the wall faces: the ghost cell holds -u
        ghost[0, 1:-1], ghost[-1, 1:-1], ghost[1:-1, 0], ghost[1:-1, -1] = -u[0], -u[-1], -u[:, 0], -u[:, -1]
        rate = np.hypot(ghost[2:, 1:-1] - ghost[:-2, 1:-1], ghost[1:-1, 2:] - ghost[1:-1, :-2]) / (2 * h)
        law = np.clip(rheology.consistency * np.maximum(rate, 1e-300) ** (rheology.flow_index - 1), nu_min, nu_max)
        nu = law if nu is None else np.sqrt(nu * law)
        diagonal = np.zeros((ny, nz))
        rows, cols, values = [index.ravel()], [index.ravel()], []
        for face, lo, hi in ((0.5 * (nu[1:] + nu[:-1]), index[:-1], index[1:]),
                             (0.5 * (nu[:, 1:] + nu[:, :-1]), index[:, :-1], index[:, 1:])):
            w = (face / h**2).ravel()
            rows += [lo.ravel(), hi.ravel()]
            cols += [hi.ravel(), lo.ravel()]
            values += [w, w]
            diagonal.ravel()[:] -= np.bincount(lo.ravel(), w, ny * nz) + np.bincount(hi.ravel(), w, ny * nz)
        for edge in ((0, slice(None)), (-1, slice(None)), (slice(None), 0), (slice(None), -1)):
            diagonal[edge] -= 2 * nu[edge] / h**2
        matrix = sparse.csr_matrix((np.concatenate([diagonal.ravel(), *values]),
                                    (np.concatenate(rows), np.concatenate(cols))), shape=(ny * nz, ny * nz))
        u = linalg.spsolve(matrix, np.full(ny * nz, -body_force)).reshape(ny, nz)
        q, q_old = float(u.sum() * h * h), q
        if iteration > 3 and abs(q - q_old) <= tolerance * abs(q):
            break
    return q


def power_law_slab_error(nodes: int, flow_index: float, wall_shear_rate: float = 1e-3,
                         relaxation_time: float = 1.0, dtype: str = "float64", tolerance: float = 1e-9,
                         tau_range: tuple[float, float] = DEFAULT_TAU_RANGE) -> dict:
    """A power-law liquid between plates (``nodes`` fluid nodes across, half-way walls at rest, periodic in x and
    z) driven to the wall shear rate ``wall_shear_rate`` (1/dt) where its viscosity is that of
    ``relaxation_time``, against :func:`~elastocell.lattice.rheology.slab_velocity`: relative flow-rate error,
    profile L2 and max errors (units of the closed form's centre speed), the range of local tau."""
    h = nodes / 2.0
    nu_wall = (relaxation_time - 0.5) / 3.0
    rheology = PowerLaw.matching(flow_index, nu_wall, wall_shear_rate, relaxation_time_min=tau_range[0],
                                 relaxation_time_max=tau_range[1])
    body_force = nu_wall * wall_shear_rate / h  # wall stress K gdot_w^n = G h
    lattice = Lattice(LatticeParams((1, nodes, 1), relaxation_time=relaxation_time, dtype=dtype,
                                    wall_velocity=(0.0, 0.0), body_force=(body_force, 0.0, 0.0), rheology=rheology))
    y = np.arange(nodes) - (nodes - 1) / 2.0
    exact = slab_velocity(y, body_force, rheology.consistency, flow_index, h)
    velocity = np.zeros((3, 1, nodes, 1))
    velocity[0, 0, :, 0] = exact
    lattice.initialize(velocity=velocity)
    steps = relax_to_steady(lattice, tolerance, chunk=max(200, int(h * h / nu_wall)))
    u = lattice.velocity()[0, 0, :, 0]
    q_exact = slab_flow_rate(body_force, rheology.consistency, flow_index, h)
    return {"nodes": nodes, "flow_index": flow_index, "flow_rate_error": float(u.sum()) / q_exact - 1.0,
            "profile_l2_error": float(np.sqrt(((u - exact) ** 2).sum() / (exact**2).sum())),
            "profile_max_error": float(np.abs(u - exact).max() / exact.max()), "steps": steps}


# =========================================================================== scenario parameters
DEFAULT_CAPILLARY_NUMBER_WALL = 0.2
"""Ca_w of the reference runs (validation/pipe.py): the local Ca at the cell's edge, Ca_w R/R_ch = 0.1 at the
default confinement, is in the range of the shear-flow studies (0.05 - 0.3)."""

DEFAULT_CHANNEL_RADIUS_RATIO = 2.0
"""R_ch/R default. The paper gives no value in its text and its figures are not in the source we have; a
cell filling half the channel diameter (R/R_ch = 0.5) is confined enough for the curvature of the profile
across the cell (u varies by ~25 % of u_max over its diameter) to produce the axisymmetric bullet-like
shape, while the gap to the wall (R = 8 dx at the default resolution) stays far larger than the
immersed-boundary kernel's reach, and the lattice stays small (34 x 34 nodes in the cross-section)."""


PIPE_HYDRODYNAMIC_RADIUS_CORRECTION = 0.3
"""The pipe's default c (dx): the markers at R - 0.3 dx, where a sphere held on the pipe's axis has its hydrodynamic
radius within 0.05-0.15 dx of R at R/dx 6-8 (0.36-0.46 dx above it with the markers at R; docs/validation/
pipe_dclab.md, 'a rigid sphere's hydrodynamic radius'; a force-free sphere, nearer a cell, stays 0.16-0.50 dx above
it). With it a single R/dx 8 run (``pipe``'s ``extrapolate=False``; the default in a duct; the cylinder's default
extrapolates from R/dx 8 and 6, ``elastocell.api.pipe.extrapolated_by_default``; the earlier default is ``extrapolate``
with c = 0): at the four cells of 'The flow rate held' (t = 16/gdot_w) its RT-DC deformation errs
+0.0, +18.1, +6.6 and +11.8 % against LE-2D-FEM-19 (the modulus dclab reads from it -8.2 to 0.0 %), where the
earlier default (markers at R, extrapolated from R/dx 6 and 8) erred +8.6, +8.5 and -20.4 % at three of them (the
modulus -4.1 to +11.7 %) and gave no reading at the fourth, its R/dx 6 run's outline having fallen back to the
nodes' hull; the single run costs 0.7-0.8x the pair (docs/validation/flow_default.md). Not yet within issue 24's
10 %: at t = 40/gdot_w it errs -3.3 to +25.4 % at five of six cells, the sixth read on the nodes' hull (section
'The stationary shape at R/dx 8', which also shows D moving by about a tenth with the cell's Poisson ratio)."""


class PipeFlowParameters(FlowLatticeParameters):
    """Pressure-driven flow of a cell through a cylindrical capillary; numbers are dimensionless unless stated.

    capillary_number_wall: Ca_w = G R_ch / (2 mu_ref) = eta gdot_w / mu_ref, mu_ref = mu_c = E_c/(2(1+nu))
        (mu_eff for the homogeneous equivalent); the local value is Ca(r) = Ca_w r/R_ch.
    channel_radius_ratio: R_ch/R (> 1). Default :data:`DEFAULT_CHANNEL_RADIUS_RATIO`.
    start_offset: r0/R_ch, the initial distance of the cell centre from the axis (along +y); the undeformed
        cell must lie inside the channel: r0/R_ch + R/R_ch < 1.
    resolution: R/dx (default 8, as shear flow).
    box_length: periodic length of the channel along x, in units of R (default 8, as shear flow).
    relaxation_time: LB tau (time steps); kinematic viscosity (tau - 1/2)/3.
    reynolds_number: upper limit of the particle Reynolds number gdot_w R^2/nu with the wall shear rate
        (the largest shear rate in the channel; Stokes regime).
    velocity_limit: upper limit of the centre-line speed u_max = gdot_w R_ch/2 (dx/dt).
    kernel: immersed-boundary kernel ("trilinear" or "peskin4").
    hydrodynamic_radius_correction: c in dx, as :class:`~elastocell.scenarios.shear.ShearFlowParameters`: the
        markers lie on a sphere of radius R - c dx, so that the body the fluid sees (larger than the marker surface
        by a constant 0.35 dx with the trilinear kernel and edges of 2 dx: a sphere held on the pipe's axis at
        R/dx 4-8, 0.05 dx with c = 0.3; docs/validation/pipe_dclab.md and flow_accuracy.md) has radius R and the
        confinement is R/R_ch. The shape observables (strains, side-view outline) are those of that body: the
        markers' shape in units of their own radius R - c dx. On the cell, c = 0.3 lowers D by 6-15 % at R/dx 6
        and 8 at the pipe_dclab points (less than the rigid sphere's confinement predicts). Default
        :data:`PIPE_HYDRODYNAMIC_RADIUS_CORRECTION` (0.3 dx). 0 puts the markers at R (and leaves the field out of
        the parameters' dump, so that the keys and records of runs made so are those they had).
    lattice_wall_shear_rate: impose gdot_w (1/dt) instead of the largest allowed one; refused if it breaks
        a limit.
    max_steps_per_time: refuse a run needing more LB steps per unit time 1/gdot_w.
    dtype: LB storage precision.
    backend: compute engine: "numba" (fused compiled CPU kernels, the fastest on a CPU) or "jax" (the same
        physics in JAX on its default device: a GPU when JAX has CUDA/ROCm, else the CPU).
    channel_shape: "cylinder" (radius R_ch), "square" or "rectangle" (a duct of width W = 2 R_ch along y, the
        start offset's direction, and height H = channel_aspect_ratio W along z; half-way bounce-back walls; W
        whole lattice nodes exactly, the cell's R/dx moved to make it so (:func:`duct_cell_radius`), H rounded to
        whole nodes). For a duct R_ch is the half-width and Ca_w = G R_ch/(2 mu_ref) is
        the mean wall shear stress over mu_ref for the square (G A/P).
    channel_aspect_ratio: H/W of a rectangle (1 for the square).
    channel_wall: how the lattice places the cylinder's wall (:data:`CHANNEL_WALLS`): "interpolated" (default,
        :data:`PIPE_CHANNEL_WALL`: the wall at r = R_ch on every link, linearly interpolated bounce-back; the empty
        channel's largest profile error 0.3-1.0 % of u_max at R_ch 6.6-14.6 dx instead of 3.8-6.2 %,
        :func:`poiseuille_error`)
        or "staircase" (the wall half-way on every link to the solid nodes r > R_ch, the only wall before the
        choice existed: it is left out of the parameters' dump, so that the keys of runs made so stay valid). A
        duct's walls are the same either way (left out of its dump too).
    hold_flow_rate: True (default): the flow rate Q is held at that of the nominal driving G in the ideal channel
        (a syringe pump, as RT-DC and dclab's tables: :func:`ideal_flow_rate`); the body force is rescaled after
        every record, G <- G (Q_ideal/Q)^n (n the flow index), so that the cell's own resistance in the periodic
        box and the wall's error in Q (the staircase's) do not slow the flow. False: G is held (a pressure-driven
        periodic channel; the field is then left out of the parameters' dump, as runs without it held G), and
        the flow rate falls below Q_ideal: by about a tenth for a cell of R/R_ch 0.70 in the default box at
        R/dx 8, which then deforms less (docs/validation/pipe_dclab.md, section "The flow rate held").
    volume_correction: "none" (default: the markers move with the interpolated fluid alone, and the cell's volume
        drifts with the immersed boundary's leak, by up to several % for soft cells in RT-DC channels) or
        "projection" (after every step the surface markers are moved along the gradient of the volume they enclose
        back to the undeformed cell's: :func:`~elastocell.coupling.immersed._project_volume`; the Numba backend
        and linear elements only; the restored volume is reported as ``volume_restored`` in the summary). "none"
        is left out of the parameters' dump, so that the keys and records of runs made without the choice stay.
    medium: "newtonian" or a shear-thinning power law: "0.49%MC-PBS", "0.59%MC-PBS", "0.83%MC-PBS" at
        ``temperature`` (degC, default 23; :mod:`elastocell.parameters.medium`), or "power-law" with ``flow_index``.
        The power law's consistency is set so that its viscosity at the nominal wall shear rate gdot_w is the
        lattice's eta = (tau - 1/2)/3: only n changes the flow, and Ca_w keeps its meaning with that viscosity.
    """

    capillary_number_wall: float
    channel_radius_ratio: float = DEFAULT_CHANNEL_RADIUS_RATIO
    start_offset: float = 0.0
    hydrodynamic_radius_correction: float = PIPE_HYDRODYNAMIC_RADIUS_CORRECTION
    hold_flow_rate: bool = True
    lattice_wall_shear_rate: float | None = None
    max_steps_per_time: float = 1.0e6
    channel_shape: Literal["cylinder", "square", "rectangle"] = "cylinder"
    channel_aspect_ratio: float = 1.0
    channel_wall: Literal["staircase", "interpolated"] = PIPE_CHANNEL_WALL
    volume_correction: Literal["none", "projection"] = "none"
    medium: str = "newtonian"
    temperature: float | None = None
    flow_index: float | None = None

    @model_validator(mode="after")
    def _check(self) -> PipeFlowParameters:
        check_capillary_number(self.capillary_number_wall, "capillary_number_wall", MAX_CAPILLARY_NUMBER_WALL,
                               VALIDATED_CAPILLARY_NUMBER_WALL, "near the wall the local capillary number would "
                               "stretch the cell beyond what its mesh can follow",
                               "the RT-DC conditions of the look-up tables")
        ratio = self.channel_radius_ratio
        require(math.isfinite(ratio) and 1 < ratio <= 20, "channel_radius_ratio",
                f"R_ch/R must be in (1, 20] (the cell must fit in the channel), got {ratio}")
        offset = self.start_offset
        require(math.isfinite(offset) and 0 <= offset < 1 - 1 / ratio, "start_offset",
                f"r0/R_ch must be in [0, {1 - 1 / ratio:.4g}) at R_ch/R = {ratio:g} (r0 + R < R_ch: the cell "
                f"inside the channel), got {offset}")
        aspect = self.channel_aspect_ratio
        require(math.isfinite(aspect) and 0.2 <= aspect <= 5, "channel_aspect_ratio",
                f"H/W must be in [0.2, 5], got {aspect}")
        require(self.channel_shape != "square" or aspect == 1.0, "channel_aspect_ratio",
                f"a square channel has H/W = 1, got {aspect}: use channel_shape rectangle")
        require(self.channel_shape != "cylinder" or aspect == 1.0, "channel_aspect_ratio",
                f"a cylinder has no aspect ratio (got {aspect}): use channel_shape rectangle")
        fluid = pipe_medium(self)  # refuses an unknown medium or an impossible temperature / flow index
        require(self.temperature is None or fluid.name in MC_PBS, "temperature",
                f"only an MC-PBS medium depends on temperature; the {fluid.name} medium's run is set by its "
                f"dimensionless numbers alone (give --medium 0.59%MC-PBS, or leave out --temperature), got "
                f"{self.temperature} degC")
        require(math.isfinite(self.hydrodynamic_radius_correction)
                and 0 <= self.hydrodynamic_radius_correction < 0.5 * self.resolution,
                "hydrodynamic_radius_correction", f"must be in [0, R/2) = [0, {0.5 * self.resolution:g}) dx, "
                f"got {self.hydrodynamic_radius_correction}")
        check_channel_fit(self.resolution, ratio, offset, self.kernel,
                          aspect if self.channel_shape != "cylinder" else 1.0)
        require(self.volume_correction == "none" or self.backend == "numba", "volume_correction",
                f"the projection runs on the Numba backend only, not {self.backend!r}")
        if self.lattice_wall_shear_rate is not None:
            rate = self.lattice_wall_shear_rate
            require(math.isfinite(rate) and rate > 0, "lattice_wall_shear_rate", f"must be > 0 (1/dt), got {rate}")
        return self

    @model_serializer(mode="wrap")
    def _dump(self, handler):
        data = handler(self)
        if self.hydrodynamic_radius_correction == 0.0:
            data.pop("hydrodynamic_radius_correction", None)
        if self.channel_wall == "staircase" or self.channel_shape != "cylinder":  # what runs made before the
            data.pop("channel_wall", None)  # choice existed had; a duct's plane walls are the same either way
        if self.volume_correction == "none":  # what runs made before the choice existed did
            data.pop("volume_correction", None)
        if not self.hold_flow_rate:  # G held: what runs without the field always did (their keys stay valid); so
            data.pop("hold_flow_rate", None)  # rebuild a model from dict(params), not from this dump
        return data


def pipe_medium(params) -> Medium:
    """The :class:`~elastocell.parameters.medium.Medium` of pipe parameters (medium, temperature, flow_index)."""
    return medium(params.medium, params.temperature, params.flow_index)


def check_channel_fit(resolution: float, channel_radius_ratio: float, start_offset: float,
                      kernel: str = "trilinear", aspect_ratio: float = 1.0) -> None:
    """Raise ParameterError unless the undeformed cell at r0 keeps the kernel's reach + 1 dx from the wall
    (a duct of height/width ``aspect_ratio``: from the nearer wall pair when centred)."""
    radius = float(resolution)
    if aspect_ratio < 1.0 and (channel_radius_ratio * aspect_ratio - 1) * radius < ibm.kernel_half_width(kernel) + 1:
        raise ParameterError("channel_aspect_ratio", f"H/W = {aspect_ratio:g} puts the centred cell within the "
                             "kernel's reach + 1 dx of the top and bottom walls: raise it or channel_radius_ratio")
    channel_radius = channel_radius_ratio * radius
    half_width = ibm.kernel_half_width(kernel)
    margin = half_width + 1.0
    if channel_radius - radius < margin:
        raise ParameterError(
            "channel_radius_ratio",
            f"the wall is {channel_radius - radius:.2f} dx from the centred cell at R_ch/R = "
            f"{channel_radius_ratio:g} and resolution {resolution:g}; need >= {margin:g} dx (kernel "
            f"half-width + 1): use R_ch/R >= {1 + margin / radius:.4g} or a higher resolution",
        )
    offset = start_offset * channel_radius
    if offset + radius + margin > channel_radius:
        raise ParameterError(
            "start_offset",
            f"r0/R_ch = {start_offset:g} puts the cell within {channel_radius - offset - radius:.2f} dx of the "
            f"wall; need >= {margin:g} dx: use r0/R_ch <= {(channel_radius - radius - margin) / channel_radius:.4g}",
        )


@dataclass(frozen=True)
class PipeUnits:
    """Lattice parameters of a pipe run (lattice units: dx = R/``radius``, dt = one step, rho0 = 1; ``radius`` is
    the resolution, in a duct moved by :func:`duct_cell_radius`).

    ``shape`` (nx, ny, nz), channel axis along x through ``axis`` (y, z); ``channel_radius`` R_ch (dx);
    ``body_force`` G; ``wall_shear_rate`` gdot_w = G R_ch/(2 eta) (1/dt); ``centre_speed`` u_max = G R_ch^2/(4 eta);
    ``youngs_modulus`` E_c such that G R_ch/(2 mu_ref) = Ca_w; ``limits`` the wall shear rates each
    constraint allows, ``limiting`` the binding one.
    """

    radius: float
    channel_radius: float
    shape: tuple[int, int, int]
    relaxation_time: float
    viscosity: float
    wall_shear_rate: float
    body_force: float
    centre_speed: float
    youngs_modulus: float
    reference_shear_modulus: float
    reynolds_number: float
    channel_reynolds_number: float
    start_offset: float
    stiffness_mobility: float
    stability_number: float
    min_node_spacing: float
    limits: dict = field(default_factory=dict)
    limiting: str = ""
    channel: str = "cylinder"
    channel_half_height: float = 0.0
    rheology: PowerLaw | None = None

    @property
    def steps_per_time(self) -> float:
        """LB steps per unit time 1/gdot_w."""
        return 1.0 / self.wall_shear_rate

    @property
    def axis(self) -> tuple[float, float]:
        return channel_axis(self.shape)

    @property
    def centre(self) -> np.ndarray:
        """Initial cell centre (dx): mid-box in x, r0 off the axis along +y."""
        ay, az = self.axis
        return np.array([self.shape[0] / 2.0, ay + self.start_offset * self.channel_radius, az])

    def as_dict(self) -> dict:
        out = {k: getattr(self, k) for k in (
            "radius", "channel_radius", "relaxation_time", "viscosity", "wall_shear_rate", "body_force",
            "centre_speed", "youngs_modulus", "reference_shear_modulus", "reynolds_number",
            "channel_reynolds_number", "start_offset", "stiffness_mobility", "stability_number",
            "min_node_spacing", "limiting", "channel", "channel_half_height")}  # fmt: skip
        out["flow_index"] = 1.0 if self.rheology is None else self.rheology.flow_index
        out["shape"] = list(self.shape)
        out["axis"] = list(self.axis)
        out["steps_per_time"] = self.steps_per_time
        out["limits"] = dict(self.limits)
        return out


def pipe_lattice_units(cell, params: PipeFlowParameters) -> PipeUnits:
    """Derive the lattice parameters of a pipe run from (Ca_w, R/dx, R_ch/R, r0) and the limits.

    R = resolution (in a duct :func:`duct_cell_radius`), R_ch = ratio R (dx), nu = eta = (tau - 1/2)/3. The wall shear rate is the largest one
    that keeps (1) the particle Reynolds number gdot_w R^2/nu <= reynolds_number, (2) the centre-line speed
    gdot_w R_ch/2 <= velocity_limit, (3) the explicit elastic step stable, E_c lambda_max(W K) <=
    C0 c(tau) c(d) (as :func:`elastocell.scenarios.shear.shear_lattice_units`), with E_c from Ca_w:
    mu_ref = eta gdot_w/Ca_w, E_c = 2 (1 + nu_p) mu_ref/(mu_ref/mu_c). Then G = 2 eta gdot_w/R_ch.
    Raises ParameterError when the channel cannot hold the cell with the kernel's reach to spare."""
    duct = params.channel_shape != "cylinder"
    check_channel_fit(params.resolution, params.channel_radius_ratio, params.start_offset, params.kernel,
                      params.channel_aspect_ratio if duct else 1.0)
    radius = duct_cell_radius(params.resolution, params.channel_radius_ratio) if duct else float(params.resolution)
    length = int(round(params.box_length * radius))
    shape, _, channel_radius, half_height = channel_geometry(params.channel_shape, params.channel_radius_ratio * radius,
                                                             params.channel_aspect_ratio, length)
    # centre speed of the Newtonian channel: gdot_w R_ch/2 (cylinder), 2 kappa gdot_w a (duct)
    velocity_length = 4.0 * duct_centre_factor(half_height / channel_radius) * channel_radius if duct else channel_radius
    tau = params.relaxation_time
    ca = params.capillary_number_wall
    rates = shear_rate_limits(cell, radius, tau, ca, params.kernel, params.reynolds_number,
                              params.velocity_limit, velocity_length)
    viscosity, modulus_per_rate, limits = rates.viscosity, rates.modulus_per_rate, rates.limits
    stiffness_mobility, spacing = rates.stiffness_mobility, rates.spacing
    if params.lattice_wall_shear_rate is None:
        limiting = min(limits, key=limits.get)
        rate = limits[limiting]
    else:
        rate = float(params.lattice_wall_shear_rate)
        limiting = "lattice_wall_shear_rate"
        for name, value in limits.items():
            if rate > value * (1 + 1e-12):
                raise ParameterError("lattice_wall_shear_rate",
                                     f"{rate:.4g} breaks the {name} limit; use <= {value:.4g}")
    if 1.0 / rate > params.max_steps_per_time:
        raise ParameterError(
            "capillary_number_wall",
            f"Ca_w = {ca} needs {1 / rate:.3g} LB steps per unit time 1/gdot_w (limited by {limiting}), more than "
            f"max_steps_per_time = {params.max_steps_per_time:.3g}: raise capillary_number_wall or lower resolution",
        )
    youngs_modulus = modulus_per_rate * rate
    body_force = 2.0 * viscosity * rate / channel_radius
    centre_speed = rate * velocity_length / 2.0
    fluid = pipe_medium(params)
    rheology = None if fluid.is_newtonian else PowerLaw.matching(fluid.flow_index, viscosity, rate)
    if rheology is not None:  # the empty channel's own centre speed
        centre_speed = float(channel_profile(shape, params.channel_shape, channel_radius, half_height, body_force,
                                             tau, rheology, params.channel_wall).max())
    return PipeUnits(
        radius=radius,
        channel_radius=channel_radius,
        shape=shape,
        relaxation_time=tau,
        viscosity=viscosity,
        wall_shear_rate=rate,
        body_force=body_force,
        centre_speed=centre_speed,
        youngs_modulus=youngs_modulus,
        reference_shear_modulus=viscosity * rate / ca,
        reynolds_number=rate * radius**2 / viscosity,
        channel_reynolds_number=0.5 * centre_speed * 2.0 * channel_radius / viscosity,  # mean speed u_max/2
        start_offset=float(params.start_offset),
        stiffness_mobility=stiffness_mobility,
        stability_number=youngs_modulus * stiffness_mobility,
        min_node_spacing=spacing,
        limits=limits,
        limiting=limiting,
        channel=params.channel_shape,
        channel_half_height=half_height,
        rheology=rheology,
    )


@functools.lru_cache(maxsize=8)
def channel_profile(shape, channel: str, half_width: float, half_height: float, body_force: float,
                    relaxation_time: float, rheology: PowerLaw | None, wall: str = "staircase") -> np.ndarray:
    """The steady u_x (ny, nz) of the empty channel on its lattice (:func:`steady_profile`, float64; cached)."""
    solid = channel_geometry(channel, half_width, half_height / half_width, 1)[1]
    out = steady_profile((1,) + tuple(shape[1:]), solid, body_force, relaxation_time, rheology, channel, half_width,
                         half_height, wall=wall)
    out.setflags(write=False)
    return out


def pipe_setup(cell, params: PipeFlowParameters, units: PipeUnits | None = None) -> ImmersedCell:
    """Channel lattice (Poiseuille profile already established) and the immersed cell at its start."""
    units = pipe_lattice_units(cell, params) if units is None else units
    shape = units.shape
    _, solid, a, b = channel_geometry(units.channel, units.channel_radius,
                                      units.channel_half_height / units.channel_radius, shape[0])
    lattice_params = LatticeParams(
        shape, relaxation_time=units.relaxation_time, dtype=params.dtype, solid=solid,
        body_force=(units.body_force, 0.0, 0.0), rheology=units.rheology,
        velocity_limit=max(params.velocity_limit, units.centre_speed) * 1.2,
        wall_fraction=channel_wall_fraction(units.channel, params.channel_wall, shape, units.channel_radius))
    velocity = np.zeros((3,) + shape)
    if units.channel == "cylinder" and units.rheology is None:
        velocity[0] = poiseuille_velocity(radial_distance(shape), units.body_force, units.viscosity,
                                          units.channel_radius)[None]
    else:  # the lattice's own steady empty channel
        velocity[0] = channel_profile(shape, units.channel, a, b, units.body_force, units.relaxation_time,
                                      units.rheology, params.channel_wall)[None]
    return immersed_cell(params.backend, lattice_params, velocity, cell, units, params.kernel,
                         params.hydrodynamic_radius_correction, params.volume_correction)


# =========================================================================== observables
def side_view(x: np.ndarray) -> tuple[float, float]:
    """(area, perimeter) of the convex hull of the points projected on the x-y plane (units of x): for mesh nodes,
    a polygon inscribed in the outline (the observables use :func:`~elastocell.body.observables.smooth_outline`
    or :func:`~elastocell.body.observables.element_surface_outline`)."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(np.ascontiguousarray(x[:, :2]))
    return float(hull.volume), float(hull.area)  # 2D: volume = area, area = perimeter


PIPE_COLUMNS = (
    "time", "radial_position", "axial_velocity", "local_capillary_number", "strain_axial", "strain_radial",
    "strain_transverse", "projected_area", "deformation", "volume_change", "axial_position", "centre_y",
    "centre_z", "nucleus_radial_position", "nucleus_axial_offset", "max_speed", "outline_fallback",
    "projected_area_views", "deformation_views", "outline_fallback_views",
)  # fmt: skip
"""Time-series columns: time (1/gdot_w); radial_position |r_c|/R_ch of the volume centroid; axial_velocity
(u_max); local_capillary_number Ca_w r_c/R_ch; strain_axial l_x/(2R); strain_radial l_y/(2R);
strain_transverse l_z/(2R); projected_area (R^2, side view along z); deformation 1 - circularity;
volume_change V/V0 - 1; axial_position (R, distance travelled); centre_y, centre_z (R_ch, from the axis);
nucleus_radial_position (R_ch) and nucleus_axial_offset (R, ahead of the cell centroid; NaN without a
nucleus); max_speed (largest marker speed in the last step, dx/dt); outline_fallback 1 where the side view of a
linear-element cell is the nodes' hull because the smooth fit left its trusted band
(:func:`~elastocell.body.observables.smooth_outline_checked`; D is then biased high by the mesh-scale roughness),
else 0; projected_area_views (R^2) and deformation_views: their means over the side views about the channel axis
through the centroid that see the same continuum shape (:func:`equivalent_side_views`: six in a cylinder, along z
and y in a square duct; view 0 the one along z; the discrete cell's shape is not quite that symmetric, and the
mean is the better estimate of its D: :func:`~elastocell.body.observables.side_views_outline`), with
outline_fallback_views the number of those views read on the nodes' hull. A run continued from a checkpoint written
before the last three columns existed has NaN in them up to where it continued (:data:`PIPE_ADDED_COLUMNS`)."""

def equivalent_side_views(params: PipeFlowParameters) -> int:
    """How many side views about the channel axis (azimuths k pi/views) see the same continuum shape of a centred
    cell, so that their mean reads it with less of the mesh's own scatter: every azimuth in a cylinder
    (:data:`~elastocell.body.observables.OUTLINE_VIEWS`), the views along z (RT-DC's camera, through the height)
    and y in a square duct (its four-fold symmetry; the diagonal ones see another outline), the one along z in a
    rectangle or for a cell started off the axis (``start_offset``). In the square duct six views would read E
    3.7-4 % apart from the two equivalent ones on the 7 um cells (E 1.5-3 kPa; validation/lut_square_views.py
    with --views 6 and 2)."""
    if params.start_offset != 0.0:  # an off-axis cell: no two views see the same shape
        return 1
    if params.channel_shape == "cylinder":
        return OUTLINE_VIEWS
    return 2 if params.channel_shape == "square" or params.channel_aspect_ratio == 1.0 else 1


PIPE_ADDED_COLUMNS = ("projected_area_views", "deformation_views", "outline_fallback_views")
"""Columns a checkpoint of the current layout may lack because it was written before they existed: a resumed run
fills them with NaN for the records before (``FlowRun.ADDED_COLUMNS``)."""

MAX_CAPILLARY_NUMBER_WALL = 50.0
"""Largest wall capillary number accepted (the RT-DC tables reach about 5)."""

VALIDATED_CAPILLARY_NUMBER_WALL = 10.0
"""Above this wall capillary number a run is warned about: beyond the RT-DC conditions the tables cover."""

WINDOW_OBSERVABLES = ("strain_axial", "deformation", "projected_area")
"""Observables whose averaging window the summary judges (``stationary`` in ``summary.json``): the shape RT-DC
reads."""

STATIONARY_OBSERVABLES = ("strain_axial", "deformation")
"""Observables the stationary stop criterion of :func:`pipe` may follow."""


def outline_hull_records(fallback_views: np.ndarray, views: int) -> tuple[int, int]:
    """(records with any side view read on the nodes' hull, records with every one of the ``views`` there) of a
    window's ``outline_fallback_views`` column: the second are the records whose side views' mean is the hull's
    (:func:`~elastocell.body.observables.mean_side_view` leaves the hull's views out where any view is fitted);
    NaN (a column resumed from an older checkpoint) counts in neither."""
    fallback_views = np.asarray(fallback_views, dtype=float)
    return int((fallback_views > 0).sum()), int((fallback_views >= views).sum())


class PipeRun(FlowRun):
    """A cell in a capillary, advanced record by record by the shared runner (:class:`~elastocell.simulation.runner.FlowRun`:
    compiled chunks, guards, stop criteria, observers, atomic checkpoints whose resumed series equals the
    uninterrupted one).

    Time in units of 1/gdot_w; a record every ``record_interval``. The scenario adds the channel lattice, the
    columns :data:`PIPE_COLUMNS`, the guard against the cylindrical wall and its summary.
    """

    COLUMNS = PIPE_COLUMNS
    ADDED_COLUMNS = PIPE_ADDED_COLUMNS
    TIME_UNIT = "units of 1/gdot_w"

    @property
    def _side_views(self) -> int:
        return equivalent_side_views(self.params)
    WHEN = "time {:.3g}/gdot_w"
    DRIVING = "capillary_number_wall"
    RATE = "wall_shear_rate"
    DEFAULT_RECORD_INTERVAL = 0.1
    PROGRESS = ("t {task.completed:.2f}/gdot_w", "strain_axial", "eps_x")
    lattice_units = staticmethod(pipe_lattice_units)
    setup = staticmethod(pipe_setup)
    units: PipeUnits
    params: PipeFlowParameters

    def _start(self) -> None:
        mesh = self.cell.mesh
        self._x0 = self.units.centre[0]
        self.reference_extent = mesh.nodes.max(axis=0) - mesh.nodes.min(axis=0)
        """Undeformed extent of the mesh along x, y, z (units of R): the 2R of the strains."""
        self.volume0 = moments(self.system.positions_in_radii(), mesh.elements).volume
        velocity = self.system.fluid_velocity_at(self.system.positions)
        self._append(self._row(velocity, 0.0))

    def advance_record(self) -> dict:
        """One record (:meth:`FlowRun.advance_record`), then, with ``hold_flow_rate``, the body force rescaled to
        carry the ideal channel's flow rate: G <- G (Q_ideal/Q)^n, the factor within [0.8, 1.25] per record. An
        integral control at full gain: the flow follows G with the channel's viscous lag, which grows with
        (R_ch/R)^2, so wide channels settle over more records (tests/test_pipe.py: within 2e-3 after 20 records at
        R_ch/R 1.5)."""
        row = super().advance_record()
        if self.params.hold_flow_rate:
            lattice = self.system.lattice
            n = 1.0 if self.units.rheology is None else self.units.rheology.flow_index
            ratio = flow_rate(lattice, self.record_velocity) / self._ideal_flow_rate()
            factor = min(1.25, max(0.8, ratio ** -n))
            lattice.set_body_force((lattice.params.body_force[0] * factor, 0.0, 0.0))
        return row

    def _ideal_flow_rate(self) -> float:
        if not hasattr(self, "_target_flow_rate"):
            self._target_flow_rate = ideal_flow_rate(self.units)
        return self._target_flow_rate

    @property
    def pressure_gradient_ratio(self) -> float:
        """G/G_nominal: the body force after the last update (the next record's) over the nominal one (1 without
        ``hold_flow_rate``)."""
        return self.system.lattice.params.body_force[0] / self.units.body_force

    def _extra_state(self) -> dict:
        return {"body_force": np.array(self.system.lattice.params.body_force[0])}

    def _load_extra(self, data) -> None:
        if "body_force" in data:
            self.system.lattice.set_body_force((float(data["body_force"]), 0.0, 0.0))

    def _quadratic_surface(self) -> np.ndarray | None:
        """The outer surface's 6-node triangles of a quadratic-element cell (None for linear elements)."""
        if not hasattr(self, "_surface_triangles"):
            mesh = self.cell.mesh
            self._surface_triangles = outer_surface_triangles(mesh.elements) if mesh.order == 2 else None
        return self._surface_triangles

    def _measure(self) -> dict:
        return self._row(self.system.marker_velocities, self.system.max_speed)

    def _row(self, marker_velocity: np.ndarray, max_speed: float) -> dict:
        units = self.units
        x = self.system.positions  # dx
        elements = self.cell.mesh.elements
        m = moments(x / units.radius, elements)
        ay, az = units.axis
        centre = m.centre * units.radius  # dx
        cy, cz = (centre[1] - ay) / units.channel_radius, (centre[2] - az) / units.channel_radius
        r_c = math.hypot(cy, cz)
        size = self.system.radius  # the markers' radius R - c dx: the shape of the body of hydrodynamic radius R
        extent = (x.max(axis=0) - x.min(axis=0)) / size / self.reference_extent
        triangles = self._quadratic_surface()
        if triangles is not None:  # quadratic elements: their own curved surface
            readings = element_side_view_readings(x / size, triangles, centre / size, self._side_views)
        else:
            readings = side_view_readings(x[self.cell.mesh.surface_nodes] / size, centre / size, self._side_views)
        area, perimeter, fitted = readings[0]  # view 0: the one along z
        views_area, views_deformation, views_fallback = mean_side_view(readings)
        circularity = 2.0 * math.sqrt(math.pi * area) / perimeter
        if self._nucleus_mask is not None:
            nc = moments(x / units.radius, elements, self._nucleus_mask).centre * units.radius
            nucleus_r = math.hypot(nc[1] - ay, nc[2] - az) / units.channel_radius
            nucleus_dx = (nc[0] - centre[0]) / units.radius
        else:
            nucleus_r = nucleus_dx = float("nan")
        return {
            "time": self.time, "radial_position": r_c,
            "axial_velocity": float(marker_velocity[:, 0].mean()) / units.centre_speed,
            "local_capillary_number": self.params.capillary_number_wall * r_c,
            "strain_axial": extent[0], "strain_radial": extent[1], "strain_transverse": extent[2],
            "projected_area": area, "deformation": 1.0 - circularity,
            "volume_change": m.volume * (units.radius / size) ** 3 / self.volume0 - 1.0,  # volume0 in marker radii
            "axial_position": (centre[0] - self._x0) / units.radius, "centre_y": cy, "centre_z": cz,
            "nucleus_radial_position": nucleus_r, "nucleus_axial_offset": nucleus_dx, "max_speed": max_speed,
            "outline_fallback": 0.0 if fitted else 1.0, "projected_area_views": views_area,
            "deformation_views": views_deformation, "outline_fallback_views": float(views_fallback),
        }  # fmt: skip

    def _check_walls(self) -> None:
        units, system = self.units, self.system
        ay, az = units.axis
        margin = ibm.kernel_half_width(self.params.kernel) + 0.5
        dy, dz = system.positions[:, 1] - ay, system.positions[:, 2] - az
        if units.channel == "cylinder":
            near = np.hypot(dy, dz).max() > units.channel_radius - margin
        else:
            near = (np.abs(dy).max() > units.channel_radius - margin
                    or np.abs(dz).max() > units.channel_half_height - margin)
        if near:
            raise FlowError(f"the cell reached the wall at time {self.time:.3g}/gdot_w (within the kernel support): "
                            "raise channel_radius_ratio or lower start_offset")

    def vtk_origin(self, x: np.ndarray) -> np.ndarray:
        """The current centroid: the displacement from the undeformed cell moved along with it."""
        return moments(x, self.cell.mesh.elements).centre

    def vtk_slice(self) -> tuple[int, float]:
        """The x-y plane through the axis, velocity in u_max."""
        return int(round(self.units.axis[1])), self.units.centre_speed

    # ------------------------------------------------------------------ results
    def summary(self, transient: float | None = None) -> dict:
        """Means and standard deviations over time >= transient (default: the second half of the run), the
        migration (initial and final radial position, time to halve the offset), lattice parameters, timings."""
        s = self.arrays()
        t = s["time"]
        end = float(t[-1])
        transient = 0.5 * end if transient is None else float(transient)
        keep = t >= transient
        out = {"capillary_number_wall": self.params.capillary_number_wall,
               "channel_radius_ratio": self.params.channel_radius_ratio,
               "start_offset": self.params.start_offset, "equivalent": bool(self.cell.is_equivalent),
               "channel_shape": self.params.channel_shape, "channel_aspect_ratio": self.params.channel_aspect_ratio,
               **pipe_medium(self.params).as_dict(),
               "transient_time": transient, "stationary_records": int(keep.sum())}
        for name in ("strain_axial", "strain_radial", "strain_transverse", "deformation", "projected_area",
                     "axial_velocity", "radial_position", "volume_change", "local_capillary_number"):
            values = s[name][keep]
            out[f"{name}_mean"] = float(values.mean()) if values.size else float("nan")
            out[f"{name}_std"] = float(values.std()) if values.size else float("nan")
        for name in ("deformation_views", "projected_area_views"):  # NaN before a resume from an older checkpoint
            values = s[name][keep]  # NaN unless every record of the window has them (the same window as the rest)
            out[f"{name}_mean"] = float(values.mean()) if values.size else float("nan")
            out[f"{name}_std"] = float(values.std()) if values.size else float("nan")
        out["outline_fallback_views_records"], out["outline_hull_views_records"] = outline_hull_records(
            s["outline_fallback_views"][keep], equivalent_side_views(self.params))
        out.update(window_verdict(s, keep, WINDOW_OBSERVABLES))
        out["radial_position_initial"] = float(s["radial_position"][0])
        fallback = np.asarray(s["outline_fallback"], dtype=float)
        out["outline_fallback_records"] = int((fallback[keep] > 0).sum())  # the window's, on the nodes' hull
        out["outline_fallback_first_time"] = float(t[np.argmax(fallback > 0)]) if (fallback > 0).any() else None
        out["deformation_initial"] = float(s["deformation"][0])  # the outline's own at rest (p1 ~2.5e-5, p2 ~1.5e-5)
        if self.params.volume_correction == "projection":  # the leak the projection answered, in V0 since the start
            out["volume_restored"] = self.system.volume_restored / self.system.target_volume
        out["projected_area_initial"] = float(s["projected_area"][0])
        out["reference_extent"] = [float(v) for v in self.reference_extent]
        out["radial_position"] = float(s["radial_position"][-1])
        out["migration_half_time"] = migration_time(t, s["radial_position"], 0.5)
        out["volume_change_max_abs"] = float(np.abs(s["volume_change"]).max())
        out["bullet_shape"] = bool(out["strain_axial_mean"] < 1.0 < out["strain_radial_mean"])
        out["duration"] = end
        out.update(self.run_summary())
        out["lattice_updates_per_s"] = (self.system.time_step * int(np.prod(self.units.shape)) / self.elapsed
                                        if self.elapsed > 0 else float("nan"))
        out["channel_reynolds_number"] = self.units.channel_reynolds_number
        out["record_interval"] = self.record_interval
        out["hold_flow_rate"] = bool(self.params.hold_flow_rate)
        out["pressure_gradient_ratio"] = self.pressure_gradient_ratio  # the last record's G/G_nominal
        out["flow_rate_ratio"] = flow_rate(self.system.lattice) / self._ideal_flow_rate()
        return out


def migration_time(times, radial_positions, fraction: float = 0.5) -> float:
    """First time the radial position falls to ``fraction`` of its initial value (linear interpolation
    between records); NaN when it does not within the run or when the cell starts on the axis."""
    t = np.asarray(times, dtype=float)
    r = np.asarray(radial_positions, dtype=float)
    if r.size < 2 or not r[0] > 1e-3:
        return float("nan")
    target = fraction * r[0]
    below = np.nonzero(r <= target)[0]
    if below.size == 0:
        return float("nan")
    i = int(below[0])
    if i == 0:
        return float(t[0])
    return float(t[i - 1] + (t[i] - t[i - 1]) * (r[i - 1] - target) / (r[i - 1] - r[i]))


@dataclass
class PipeResult:
    """Time series (:data:`PIPE_COLUMNS`) and stationary summary of a pipe run."""

    series: dict
    summary: dict
    units: PipeUnits

    def to_frame(self):
        import pandas as pd

        return pd.DataFrame(self.series)


def run_pipe(cell, params: PipeFlowParameters, duration: float = 10.0, record_interval: float = 0.1,
             transient: float | None = None, callback=None) -> PipeResult:
    """Run a cell in a capillary for ``duration`` units of 1/gdot_w, in memory; stationary values over
    time >= ``transient`` (default duration/2). ``callback(row, run)`` after every record. Raises
    :class:`~elastocell.coupling.markers.FlowError` if the run turns unstable or the cell reaches the wall."""
    start = time.perf_counter()
    stop = StopCriteria(duration=duration, unit=PipeRun.TIME_UNIT)
    run = PipeRun(cell, params, record_interval=record_interval)
    run.run(stop, observers=() if callback is None else (callback,))
    summary = run.summary(transient)
    summary["wall_time_s"] = time.perf_counter() - start
    return PipeResult(series=run.arrays(), summary=summary, units=run.units)


# =========================================================================== output
def plot_pipe(path: Path, series: dict, summary: dict, title: str = "") -> None:
    """Strains eps_x, eps_r (with their stationary means) and the radial position against time."""
    figure, top, bottom = time_series_figure()
    t = np.asarray(series["time"])
    start = summary.get("transient_time", 0.0)
    for name, label, colour in (("strain_axial", r"$\epsilon_x$", "C0"), ("strain_radial", r"$\epsilon_r$", "C1")):
        mean = summary.get(f"{name}_mean", np.nan)
        top.plot(t, series[name], lw=1.2, color=colour, label=f"{label} (mean {mean:.4g})")
        top.hlines(mean, start, t[-1], colors=colour, linestyles="--", lw=1)
    top.axhline(1.0, color="k", lw=0.6)
    top.set_ylabel("strain l/(2R)")
    top.legend(fontsize=8)
    bottom.plot(t, series["radial_position"], lw=1.2, color="C2")
    bottom.set_ylabel(r"radial position $r_c/R_{ch}$")
    save_time_series_figure(path, figure, r"time $\dot\gamma_w t$", title)
