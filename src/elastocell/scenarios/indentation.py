"""A rigid sphere (a bead of radius R_b) or a cone (a sharp tip) pressed quasistatically into a cell on a rigid
flat dish: the body and its support for each cell shape, on the axisymmetric solver
(:mod:`elastocell.scenarios.axisymmetric`).

Shapes (``cell_shape``):

- ``sphere``: a suspended cell of radius R resting on the dish, frictionless contact with it;
- ``cap``: an adherent cell, a spherical cap of base radius R and apex height H, its base bonded to the dish;
- ``layer``: a gel or tissue section of thickness h bonded to the dish, meshed in units of R_b, laterally wide
  enough that its extent does not change the force (:func:`elastocell.body.axisymmetric.layer_width`).

:func:`indentation_curve` takes every length in units of R (the cell radius; for the layer any length unit,
whose results then come in that unit) and returns the curve in those units, the force F/(E_c R^2): the arrays a
master surface is made of, without writing files. A cell that is not axisymmetric about z (random, a nucleus
offset along x or y, an ellipsoid not aligned with z) is refused before any computing by the axisymmetric
solver; :func:`indentation_solver` chooses, for the suspended sphere, the 3D solver
(:mod:`elastocell.scenarios.indentation_3d`) for such a cell.

Cone (``indenter="cone"``, half-angle alpha between the axis and the flank; ``"pyramid"``: a four-sided pyramid
of face half-angle alpha as the cone of the same cross-section area, tan(alpha_c) = 2/sqrt(pi) tan(alpha)): its
contact radius a = 2 depth tan(alpha)/pi has no length of its own, so the mesh is sized on the contact scale
s = depth_max max(tan(alpha), 1) (:func:`cone_mesh`): a layer is meshed in units of s (as the sphere's layer in units of
R_b), a sphere or cap keeps units of R with its pole size s/100 (the layer's, at most the bead's 0.01 R). The apex
is rounded by a sphere of radius :data:`CONE_TIP_RADIUS` s (the contact's projection needs a normal on the
axis); the layer's outputs are in units of its thickness h.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from elastocell.body.axisymmetric import (
    CELL_SHAPES,
    AxisymmetricCell,
    MeridianGeometry,
    MeridianMeshParameters,
    meridian_nucleus,
)
from elastocell.parameters.cell import CellParameters, cell_parameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.axisymmetric import (
    DEFAULT_TOLERANCE,
    AxisymmetricError,
    AxisymmetricResult,
    indent_axisymmetric,
)
from elastocell.scenarios.compression import compression_parameters_for

AXISYMMETRIC_ONLY = "indent runs the axisymmetric solver here; --solver 3d runs --cell-shape sphere in 3D"
SOLVERS = ("auto", "3d", "axisymmetric")
"""``solver`` of an indentation: ``auto`` (the axisymmetric solver for a cell symmetric about z, the 3D one for
any other suspended sphere), ``3d`` (the suspended sphere only) or ``axisymmetric``."""
INDENTERS = ("sphere", "cone", "pyramid")
"""``indenter`` of an indentation: a bead (``indenter_radius``), a cone or a four-sided pyramid (``half_angle``)."""
HALF_ANGLE_RANGE = (20.0, 85.0)
"""The half-angles (degrees) a cone or a pyramid may have: on a layer, 10 and 15 degree cones fold the elements
under the apex at 5-6 % of the final depth (the default cone mesh, depth h/4 and h/20)."""
CONE_TIP_RADIUS = 1e-4
"""Radius of the cone's rounded apex in units of the contact scale s = depth_max max(tan(alpha), 1). Its effect on F
(measured in validation/indentation_cone.py by doubling it) is ~ 2 rho (1/sin(alpha) - 1)/depth: the flanks
are the sharp cone's offset by rho."""
MESH_OPTIONS = ("element", "mesh_size", "pole_size", "interface_size", "quadrature_degree", "volumetric")
"""The 3D mesh's options, which the axisymmetric solver (its own meridian mesh) does not take."""


def indentation_geometry(cell_shape: str, indenter_radius: float, cap_height: float | None = None,
                         layer_thickness: float | None = None) -> tuple[MeridianGeometry, float]:
    """(the body's meridian geometry, its length unit in units of R): R for the sphere and the cap, R_b for the
    layer. Lengths in units of R; an option that does not belong to the shape, or a missing one, is refused."""
    if cell_shape not in CELL_SHAPES:
        raise ParameterError("cell_shape", f"must be one of {', '.join(CELL_SHAPES)}, got {cell_shape!r}")
    if not indenter_radius > 0:
        raise ParameterError("indenter_radius", f"must be > 0, got {indenter_radius:g}")
    if cap_height is not None and cell_shape != "cap":
        raise ParameterError("cap_height", f"applies to --cell-shape cap only, not {cell_shape}")
    if layer_thickness is not None and cell_shape != "layer":
        raise ParameterError("layer_thickness", f"applies to --cell-shape layer only, not {cell_shape}")
    if cell_shape == "sphere":
        return MeridianGeometry(), 1.0
    if cell_shape == "cap":
        height = 1.0 if cap_height is None else cap_height
        return MeridianGeometry(shape="cap", height=height), 1.0
    if layer_thickness is None:
        raise ParameterError("layer_thickness", "is required with --cell-shape layer")
    if not layer_thickness > 0:
        raise ParameterError("layer_thickness", f"must be > 0, got {layer_thickness:g}")
    return MeridianGeometry(shape="layer", height=layer_thickness / indenter_radius), indenter_radius


def cone_scale(half_angle: float, depth_max: float) -> float:
    """The contact scale s = depth_max max(tan(alpha), 1) of a cone of ``half_angle`` degrees: its contact radius
    at ``depth_max`` is 2 s/pi up to 45 degrees; a sharper cone is meshed on the depth itself (its layer in units
    of the contact radius was so deep that the far field's Newton iteration stalled)."""
    return float(depth_max * max(np.tan(np.radians(half_angle)), 1.0))


def pyramid_equivalent_cone(face_half_angle: float) -> float:
    """alpha_c (degrees): the half-angle of the cone whose cross-section has the area of a four-sided pyramid's of
    face half-angle ``face_half_angle`` alpha_p (degrees, axis to face), tan(alpha_c) = 2/sqrt(pi) tan(alpha_p)
    (4 d^2 tan^2 alpha_p = pi d^2 tan^2 alpha_c; a 35 degree pyramid: 38.3 degrees). Its Sneddon force,
    4/pi^1.5 = 0.718 E/(1 - nu^2) tan(alpha_p) d^2, is 3.6 % below Bilodeau's (1992) 0.7453 for the pyramid
    itself: a fit through this cone reads E about 3.8 % above a Bilodeau fit of the same curve."""
    return float(np.degrees(np.arctan(2 / np.sqrt(np.pi) * np.tan(np.radians(face_half_angle)))))


def cone_half_angle(indenter: str, half_angle: float | None) -> float:
    """The half-angle (degrees) of the cone that represents ``indenter`` of ``half_angle`` degrees (a pyramid's
    face half-angle: the cone of the same cross-section area); refused in one line outside
    :data:`HALF_ANGLE_RANGE`."""
    if indenter not in INDENTERS[1:]:
        raise ParameterError("indenter", f"must be one of {', '.join(INDENTERS)}, got {indenter!r}")
    if half_angle is None:
        raise ParameterError("half_angle", f"is required with --indenter {indenter}")
    low, high = HALF_ANGLE_RANGE
    cone = pyramid_equivalent_cone(half_angle) if indenter == "pyramid" and 0 < half_angle < 90 else float(
        half_angle)
    if not low <= cone <= high:  # the range is the cone's: a pyramid's equivalent cone is checked
        shown = f" (its equivalent cone {cone:.4g})" if indenter == "pyramid" else ""
        raise ParameterError("half_angle", f"must be in [{low:g}, {high:g}] degrees{shown}, got {half_angle:g}")
    return cone


def cone_geometry(cell_shape: str, half_angle: float, depth_max: float, cap_height: float | None = None,
                  layer_thickness: float | None = None) -> tuple[MeridianGeometry, float]:
    """(the body's meridian geometry, its mesh unit in units of R) under a cone of ``half_angle`` (degrees,
    the equivalent cone's) pressed to ``depth_max``: R for the sphere and the cap, the contact scale
    s = depth_max max(tan(alpha), 1) for the layer. Lengths in units of R."""
    if not depth_max > 0:
        raise ParameterError("depth_max", f"must be > 0, got {depth_max:g}")
    scale = cone_scale(half_angle, depth_max)
    geometry, _ = indentation_geometry(cell_shape, scale, cap_height, layer_thickness)
    return geometry, (scale if cell_shape == "layer" else 1.0)


CONE_POLE_SIZE = 0.02
"""The pole size under a cone in units of s (a layer: its mesh's pole size; a sphere or a cap: at most the bead
mesh's), twice the 0.01 s it had: with 0.01 s the element with a corner on the axis under the apex of a 35-40
degree cone degenerated (its Jacobian at that corner reached zero) before the final depth: on a layer at 0.85-0.96
of it (a 35 degree pyramid's equivalent cone, 38.3 degrees, among them; with 0.005 s at half of it for 20-38
degrees), on a sphere and a cap under a 35 degree pyramid or a 37.5-40 degree cone at 0.6-0.95 of it. With 0.02 s
every half-angle of 20-85 degrees (14 of them) reaches depth h/4 on a layer (h/20 checked at 20, 25, 38.3, 45, 70
and 80 degrees), and those tips their depth on a sphere and a cap, homogeneous or with a nucleus. On a layer it costs +1.0 % in F at depth h/4 at 20 degrees, +0.3 % at 30,
within 0.13 % from 35 on (against 0.01 s)."""


def cone_mesh(cell_shape: str, half_angle: float, depth_max: float,
              mesh: MeridianMeshParameters | None = None) -> MeridianMeshParameters:
    """The meridian mesh under a cone (:func:`cone_geometry`'s unit): in a layer ``mesh``, by default the default
    mesh with the pole size :data:`CONE_POLE_SIZE`; in a sphere or a cap (``mesh`` or the default) its pole size
    min(CONE_POLE_SIZE s, pole size) (s = depth_max max(tan(alpha), 1) in units of R, at least 0.0005 R)."""
    if cell_shape == "layer":
        return mesh or MeridianMeshParameters(pole_size=CONE_POLE_SIZE)
    mesh = mesh or MeridianMeshParameters()
    scale = cone_scale(half_angle, depth_max)
    return mesh.model_copy(update={"pole_size": float(max(min(CONE_POLE_SIZE * scale, mesh.pole_size), 0.0005))})


CONE_AXISYMMETRIC = "a cone or a pyramid runs the axisymmetric solver only"


def check_axisymmetric(cell: CellParameters, geometry: MeridianGeometry, why: str = AXISYMMETRIC_ONLY) -> None:
    """Refuse, in one line naming the option, a cell the axisymmetric solver cannot represent."""
    try:
        meridian_nucleus(cell, geometry)
    except ParameterError as error:
        message = str(error).split(": ", 1)[1]
        raise ParameterError(error.parameter, f"{message} ({why})") from None


def indentation_solver(solver: str, cell: CellParameters, geometry: MeridianGeometry, indenter: str = "sphere") -> str:
    """``3d`` or ``axisymmetric``: the solver an indentation of ``cell`` with ``geometry`` runs for the option
    ``solver`` (:data:`SOLVERS`); a combination no solver can run is refused in one line naming the option (the
    3D solver is built for the suspended sphere: a cap or a layer must be axisymmetric; the 3D mesh options
    apply to the 3D solver only; a cone or a pyramid runs the axisymmetric solver only)."""
    if solver not in SOLVERS:
        raise ParameterError("solver", f"must be one of {', '.join(SOLVERS)}, got {solver!r}")
    if indenter != "sphere" and solver == "3d":
        raise ParameterError("solver", f"3d presses a bead only; --indenter {indenter} runs the axisymmetric solver")
    if indenter != "sphere":
        solver = "axisymmetric"
    if solver == "3d" and geometry.shape != "sphere":
        raise ParameterError("solver", f"3d runs --cell-shape sphere only (a {geometry.shape} runs the axisymmetric "
                                       "solver)")
    if solver == "auto" and geometry.shape == "sphere":
        try:
            meridian_nucleus(cell, geometry)
        except ParameterError:
            return "3d"
    if solver == "3d":
        return "3d"
    check_axisymmetric(cell, geometry, AXISYMMETRIC_ONLY if indenter == "sphere" else CONE_AXISYMMETRIC)
    default = cell_parameters().mesh
    for name in MESH_OPTIONS:
        if getattr(cell.mesh, name) != getattr(default, name):
            raise ParameterError(name, "sets the 3D mesh, and this indentation runs the axisymmetric solver (its own "
                                       "meridian mesh); add --solver 3d (--cell-shape sphere) to use it")
    return "axisymmetric"


POLE_SIZE_FACTOR_3D = 0.35
"""The 3D indentation's element size at the poles (the bead's and the dish's contacts) over compression's default,
where the pole size is left at that default. Measured (docs/validation/indentation.md, section indentation_3d.py;
R_b = 0.5 R, against the axisymmetric solver): the homogeneous cell's F too high by 3.4 % at depth 0.1 R and 1.2 %
at 0.3 R on compression's mesh (3,350 nodes), 1.3 % and 0.7 % with the poles x 0.5 (5,352 nodes), 0.92 % and
0.63 % with the poles x 0.35 (6,663 nodes, 29 s on an idle 2-core machine); a nucleus (gamma 5, lambda 0.5) keeps
1.6 % at 0.1 R at x 0.35 (2.1 % at x 0.5): the nucleus's own discretisation error, as in compression."""


POLE_RADIUS_3D = 2.2
"""The 3D indentation's pole radius (units of R: the distance over which the size grows from the pole size to the
mesh size) for the p2 element, where the pole size and radius are compression's defaults (radius 1.4): the graded
size then reaches 0.24 R at the equator instead of 0.35 R, finer through the shell between the bead and a nucleus
and towards the dish. Measured (docs/validation/indentation.md, section indentation_3d.py; R_b = 0.5 R, against the
axisymmetric solver on its meridian mesh x 0.7): at depth 0.1 R the force is too high by 0.92/1.20/1.62 % for the
homogeneous cell and a nucleus of gamma 2/5 (lambda 0.5) with compression's pole radius, 0.33/0.50/0.79 % with
2.2 (gamma 10: 0.85 %), on 2.1-2.3 times the nodes, at 3.4-4.6 times the wall time per curve. What helps is the
finer mesh over the whole cell more than the radius as such: compression's mesh x 0.8 with the same poles (1.6
times the nodes) reads 0.56/0.94 % (homogeneous, gamma 5); the radius keeps a margin at gamma 10."""


def indentation_cell_3d(cell: CellParameters) -> CellParameters:
    """``cell`` as the 3D indentation meshes it: compression's cell (:func:`compression_parameters_for`) with the
    pole size, where it is compression's default, times :data:`POLE_SIZE_FACTOR_3D`, and then for p2 the pole
    radius, where it is compression's default too, :data:`POLE_RADIUS_3D` (a mesh given by its pole size is used as
    given)."""
    mesh = cell.mesh
    default = cell_parameters(element=mesh.element).mesh
    if mesh.pole_size is not None and mesh.pole_size == default.pole_size:
        update = {"pole_size": mesh.pole_size * POLE_SIZE_FACTOR_3D}
        if mesh.element == "p2" and mesh.pole_radius == default.pole_radius:
            update["pole_radius"] = POLE_RADIUS_3D
        mesh = mesh.model_copy(update=update)
    return compression_parameters_for(cell.model_copy(update={"mesh": mesh}))


def check_depth(geometry: MeridianGeometry, unit: float, depth_max: float, steps: int) -> None:
    """Refuse a depth beyond the body's height (units of R) or a step count out of range."""
    if not 1 <= steps <= 100000:
        raise ParameterError("steps", f"must be in [1, 100000], got {steps}")
    reach = (1.0 if geometry.shape == "sphere" else geometry.height) * unit
    if not 0 < depth_max < reach:
        raise ParameterError("depth_max", f"must be in (0, {reach:g}) (below the {geometry.shape}'s height), got "
                                          f"{depth_max:g}")


def indentation_body(cell: CellParameters, cell_shape: str = "sphere", indenter_radius: float = 0.5,
                     cap_height: float | None = None, layer_thickness: float | None = None,
                     mesh: MeridianMeshParameters | None = None) -> tuple[AxisymmetricCell, MeridianGeometry, float]:
    """(the meshed body, its geometry, its length unit in units of R) of an indentation (lengths in units of R;
    ``mesh`` in the body's unit)."""
    geometry, unit = indentation_geometry(cell_shape, indenter_radius, cap_height, layer_thickness)
    check_axisymmetric(cell, geometry)
    return AxisymmetricCell.from_parameters(cell, mesh, geometry=geometry), geometry, unit


def indent_body(body: AxisymmetricCell, geometry: MeridianGeometry, unit: float, indenter_radius: float,
                depth_max: float, steps: int = 20, tolerance: float = DEFAULT_TOLERANCE,
                max_newton_iterations: int = 40, solver: str = "auto",
                on_row: Callable[[AxisymmetricResult], None] | None = None,
                half_angle: float | None = None) -> AxisymmetricResult:
    """The force curve of :func:`indentation_body`'s body, lengths in units of R, force F/(E_c R^2) (``on_row``
    receives the rows so far in the body's unit). With ``half_angle`` (degrees) a cone whose apex is rounded by
    ``indenter_radius``. An interruption raises
    :class:`~elastocell.scenarios.axisymmetric.AxisymmetricInterrupted` with the converged rows in units of R."""
    check_depth(geometry, unit, depth_max, steps)
    try:
        result = indent_axisymmetric(body, indenter_radius / unit, depth_max / unit, steps=steps,
                                     tolerance=tolerance, max_newton_iterations=max_newton_iterations, solver=solver,
                                     geometry=geometry, on_row=on_row,
                                     half_angle=None if half_angle is None else float(np.radians(half_angle)))
    except AxisymmetricError as error:
        error.partial = None if error.partial is None else scaled_result(error.partial, unit)
        raise
    return scaled_result(result, unit)


def scaled_result(result: AxisymmetricResult, unit: float) -> AxisymmetricResult:
    """A curve computed in a length unit ``unit`` (units of R) expressed in units of R."""
    if unit == 1.0:
        return result
    return replace(result, load=result.load * unit, force=result.force * unit**2,
                   force_support=result.force_support * unit**2, contact_radius=result.contact_radius * unit,
                   positions=result.positions * unit)


def indentation_curve(cell_parameters: CellParameters, cell_shape: str = "sphere", indenter_radius: float = 0.5,
                      cap_height: float | None = None, layer_thickness: float | None = None,
                      depth_max: float = 0.3, steps: int = 20, mesh: MeridianMeshParameters | None = None,
                      tolerance: float = DEFAULT_TOLERANCE, max_newton_iterations: int = 40,
                      solver: str = "auto", indenter: str = "sphere",
                      half_angle: float | None = None) -> AxisymmetricResult:
    """F(depth) of a rigid frictionless sphere of radius ``indenter_radius`` pressed into a cell of shape
    ``cell_shape`` on a rigid dish, lengths in units of R (the cell radius; the cap's base radius), the force
    F/(E_c R^2) (``result.load`` is the depth, ``result.force`` the force on the sphere, ``result.force_support``
    the dish's). ``cap_height`` H (cap; None: a hemisphere), ``layer_thickness`` h (layer; required); ``mesh``
    sizes in units of R (the layer: of R_b, the unit it is meshed in). Nothing is written.

    ``indenter="cone"`` or ``"pyramid"`` with ``half_angle`` (degrees) presses a cone instead
    (:func:`cone_curve`; ``indenter_radius`` is not used)."""
    if indenter != "sphere":
        return cone_curve(cell_parameters, cell_shape, indenter, half_angle, cap_height, layer_thickness, depth_max,
                          steps, mesh, tolerance, max_newton_iterations)
    geometry, unit = indentation_geometry(cell_shape, indenter_radius, cap_height, layer_thickness)
    check_depth(geometry, unit, depth_max, steps)
    body, geometry, unit = indentation_body(cell_parameters, cell_shape, indenter_radius, cap_height,
                                            layer_thickness, mesh)
    return indent_body(body, geometry, unit, indenter_radius, depth_max, steps, tolerance, max_newton_iterations,
                       solver)


def cone_body(cell: CellParameters, cell_shape: str, half_angle: float, depth_max: float,
              cap_height: float | None = None, layer_thickness: float | None = None,
              mesh: MeridianMeshParameters | None = None) -> tuple[AxisymmetricCell, MeridianGeometry, float]:
    """(the meshed body, its geometry, its mesh unit in units of R) under a cone of ``half_angle`` degrees (the
    equivalent cone's) pressed to ``depth_max`` (units of R); ``mesh`` in the mesh unit, None: :func:`cone_mesh`."""
    geometry, unit = cone_geometry(cell_shape, half_angle, depth_max, cap_height, layer_thickness)
    check_axisymmetric(cell, geometry, CONE_AXISYMMETRIC)
    mesh = cone_mesh(cell_shape, half_angle, depth_max, mesh)
    return AxisymmetricCell.from_parameters(cell, mesh, geometry=geometry), geometry, unit


def cone_tip_radius(half_angle: float, depth_max: float) -> float:
    """The rounded apex's radius (units of R): :data:`CONE_TIP_RADIUS` times s = depth_max max(tan(alpha), 1)."""
    return CONE_TIP_RADIUS * cone_scale(half_angle, depth_max)


def cone_curve(cell_parameters: CellParameters, cell_shape: str = "layer", indenter: str = "cone",
               half_angle: float | None = 20.0, cap_height: float | None = None,
               layer_thickness: float | None = None, depth_max: float = 0.3, steps: int = 20,
               mesh: MeridianMeshParameters | None = None, tolerance: float = DEFAULT_TOLERANCE,
               max_newton_iterations: int = 40, tip_radius: float | None = None) -> AxisymmetricResult:
    """F(depth) of a rigid frictionless cone (``indenter="pyramid"``: the four-sided pyramid's equivalent cone)
    of ``half_angle`` degrees pressed into a cell of shape ``cell_shape`` on a rigid dish, lengths in units of R,
    force F/(E_c R^2) (a layer: give R = h, ``layer_thickness=1``, for F/(E h^2) over depth/h). ``tip_radius``:
    the rounded apex's radius in units of R (None: :func:`cone_tip_radius`); ``mesh`` in the mesh unit
    (:func:`cone_geometry`; None: :func:`cone_mesh`). Nothing is written."""
    angle = cone_half_angle(indenter, half_angle)
    geometry, unit = cone_geometry(cell_shape, angle, depth_max, cap_height, layer_thickness)
    check_depth(geometry, unit, depth_max, steps)
    body, geometry, unit = cone_body(cell_parameters, cell_shape, angle, depth_max, cap_height, layer_thickness,
                                     mesh)
    rho = cone_tip_radius(angle, depth_max) if tip_radius is None else tip_radius
    return indent_body(body, geometry, unit, rho, depth_max, steps, tolerance, max_newton_iterations,
                       half_angle=angle)
