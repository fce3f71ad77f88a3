"""Elastic nodal forces of the cell for the compiled coupling loop (Numba), f = -dE/dx, in lattice units.

The first Piola-Kirchhoff stress P = dW/dF of the decoupled Mooney-Rivlin family, written out by hand for the
compiled loop:

    W = mu1/2 (J^(-2/3) I1 - 3) + mu2/2 (J^(-4/3) I2 - 3) + kappa/2 (J - 1)^2
    P = mu1 J^(-2/3) (F - I1/3 F^-T) + mu2 J^(-4/3) (I1 F - F C - 2/3 I2 F^-T) + kappa (J - 1) J F^-T

A law of :data:`elastocell.body.materials.LAWS` that belongs to the family names its (mu1, mu2, kappa) in its
entry (``Law.compiled_parameters``; neo-Hookean: mu2 = 0); the tests hold the compiled forces of every such law
to the JAX gradient of the law itself (``Cell.internal_forces``). A law without that entry has no compiled
kernel here: :func:`elastocell.coupling.immersed.immersed_cell` runs its flow on the JAX backend.

The cell's volumetric treatment (``MeshParameters.volumetric``) is the kernel's too: ``standard`` takes kappa (J - 1)
at each point; ``mean`` (p2) the element's mean dilatation, p = kappa_e (V_e/V_e0 - 1); ``nodal`` (p1) the averaged
nodal dilatation, p = the mean over the element's nodes of kappa_a (V_a/V_a0 - 1) (docs/theory.md). Both replace
kappa (J - 1) J F^-T by p J F^-T = p cof F, after a first pass over the elements for their volumes. ``projected``
has no kernel here: its flow runs on the JAX backend.

Why a kernel by hand and not the JAX law inside the Numba loop: the loop cannot call JAX, and a JAX call per
step from Python costs more than this kernel by itself (reference p2 cell, 4,656 nodes, 2 cores: 3.1 ms per
``Cell.internal_forces`` against 1.0 ms here; p1, 3,861 nodes: 4.0 against 1.3 ms). The JAX backend's whole
coupled step on a CPU took 38 ms against 2.4 ms here (R = 4 dx, 32 x 40 x 32, float32) and 111 against
10.6 ms (R = 8 dx): the price of a law without this kernel on a CPU.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

VOLUMETRIC_CODES = {"standard": 0, "nodal": 1, "mean": 2}
"""``MeshParameters.volumetric`` -> the kernel's code; ``projected`` has no compiled kernel (the JAX backend)."""


def compiled_law_parameters(cell) -> np.ndarray:
    """Per-element (mu1, mu2, kappa) in units of E_c for the compiled force kernel, from the cell's law entry
    (``Law.compiled_parameters``); ValueError for a law without a compiled kernel."""
    law = cell.law
    if not law.has_compiled_kernel:
        raise ValueError(f"the law {law.name!r} has no compiled force kernel (it is not of the decoupled "
                         "Mooney-Rivlin family): run its flow with backend='jax', which immersed_cell selects "
                         "for it")
    params = law.compiled_parameters(np.asarray(cell.material_parameters, dtype=np.float64))
    params = np.ascontiguousarray(params, dtype=np.float64)
    if params.shape != (cell.mesh.n_elements, 3):
        raise ValueError(f"the law {law.name!r}: compiled_parameters must give (n_elements, 3) = "
                         f"({cell.mesh.n_elements}, 3) values (mu1, mu2, kappa), got shape {params.shape}")
    return params


@njit(cache=True, inline="always", error_model="numpy")
def _inverse_cube_root(j):
    """j^(-1/3) for j > 0 by Newton's iteration y <- y (4 - j y^3)/3 (libm's cbrt/pow cost ~40 ns here).

    Near j = 1 (|j - 1| < 0.2, every element at nu = 0.48) the start is the quadratic Taylor guess and two
    or three iterations reach round-off; otherwise the start (4 - j)/3 or 1/j lies below the root, from
    where the iteration rises monotonically. Exact to about one rounding unit."""
    s = j - 1.0
    if -0.2 < s < 0.2:
        y = 1.0 - s * (1.0 / 3.0) + s * s * (2.0 / 9.0)
    else:
        y = (4.0 - j) * (1.0 / 3.0) if j < 3.5 else 1.0 / j
    for _ in range(200):
        y_new = y * (4.0 - j * y * y * y) * (1.0 / 3.0)
        if abs(y_new - y) <= 4e-16 * y:
            return y_new
        y = y_new
    return y


@njit(cache=True, inline="always", error_model="numpy")
def _deformation_gradient(x, elements, gradients, e, q):
    """F = sum_k x_(e_k) (dN_k/dX)^T at point q of element e, as its nine entries row by row."""
    f00 = f01 = f02 = f10 = f11 = f12 = f20 = f21 = f22 = 0.0
    for k in range(elements.shape[1]):
        nd = elements[e, k]
        x0 = x[nd, 0]
        x1 = x[nd, 1]
        x2 = x[nd, 2]
        g0 = gradients[e, q, k, 0]
        g1 = gradients[e, q, k, 1]
        g2 = gradients[e, q, k, 2]
        f00 += x0 * g0
        f01 += x0 * g1
        f02 += x0 * g2
        f10 += x1 * g0
        f11 += x1 * g1
        f12 += x1 * g2
        f20 += x2 * g0
        f21 += x2 * g1
        f22 += x2 * g2
    return f00, f01, f02, f10, f11, f12, f20, f21, f22


@njit(parallel=True, cache=True, error_model="numpy")
def _element_forces(x, elements, gradients, weights, params, eforce, j_min, volumetric, pressure):
    """eforce[e, k] = -dE_e/dx_k per element (parallel over elements); j_min[e] = min det F of element e.

    volumetric 0: the volumetric stress at each point is kappa (J - 1) cof F (J = det F there); otherwise it is
    pressure[e] cof F with the element's pressure from :func:`_volumetric_pressure`."""
    n_el = elements.shape[0]
    n_q = gradients.shape[1]
    n_k = elements.shape[1]
    for e in prange(n_el):
        mu1 = params[e, 0]
        mu2 = params[e, 1]
        kappa = params[e, 2]
        jm = np.inf
        for k in range(n_k):
            eforce[e, k, 0] = 0.0
            eforce[e, k, 1] = 0.0
            eforce[e, k, 2] = 0.0
        for q in range(n_q):
            f00, f01, f02, f10, f11, f12, f20, f21, f22 = _deformation_gradient(x, elements, gradients, e, q)
            # cofactors: cof(F) = det(F) F^-T
            c00 = f11 * f22 - f12 * f21
            c01 = f12 * f20 - f10 * f22
            c02 = f10 * f21 - f11 * f20
            c10 = f02 * f21 - f01 * f22
            c11 = f00 * f22 - f02 * f20
            c12 = f01 * f20 - f00 * f21
            c20 = f01 * f12 - f02 * f11
            c21 = f02 * f10 - f00 * f12
            c22 = f00 * f11 - f01 * f10
            det = f00 * c00 + f01 * c01 + f02 * c02
            if not det > 0.0:  # inverted (or NaN): no force, reported through j_min
                jm = det if det == det else np.nan
                continue
            jm = min(jm, det)
            i1 = f00 * f00 + f01 * f01 + f02 * f02 + f10 * f10 + f11 * f11 + f12 * f12 + f20 * f20 + f21 * f21 + f22 * f22
            y = _inverse_cube_root(det)
            a1 = mu1 * y * y  # mu1 J^(-2/3)
            # P = a F - b (F C) + g cof(F)
            a = a1
            if volumetric == 0:
                g = -a1 * i1 / 3.0 + kappa * (det - 1.0) * det
            else:
                g = -a1 * i1 / 3.0 + pressure[e] * det
            fc00 = fc01 = fc02 = fc10 = fc11 = fc12 = fc20 = fc21 = fc22 = 0.0
            b = 0.0
            if mu2 != 0.0:
                m00 = f00 * f00 + f10 * f10 + f20 * f20  # C = F^T F
                m01 = f00 * f01 + f10 * f11 + f20 * f21
                m02 = f00 * f02 + f10 * f12 + f20 * f22
                m11 = f01 * f01 + f11 * f11 + f21 * f21
                m12 = f01 * f02 + f11 * f12 + f21 * f22
                m22 = f02 * f02 + f12 * f12 + f22 * f22
                i2 = 0.5 * (i1 * i1 - (m00 * m00 + m11 * m11 + m22 * m22 + 2.0 * (m01 * m01 + m02 * m02 + m12 * m12)))
                fc00 = f00 * m00 + f01 * m01 + f02 * m02
                fc01 = f00 * m01 + f01 * m11 + f02 * m12
                fc02 = f00 * m02 + f01 * m12 + f02 * m22
                fc10 = f10 * m00 + f11 * m01 + f12 * m02
                fc11 = f10 * m01 + f11 * m11 + f12 * m12
                fc12 = f10 * m02 + f11 * m12 + f12 * m22
                fc20 = f20 * m00 + f21 * m01 + f22 * m02
                fc21 = f20 * m01 + f21 * m11 + f22 * m12
                fc22 = f20 * m02 + f21 * m12 + f22 * m22
                a2 = mu2 * y * y * y * y  # mu2 J^(-4/3)
                a += a2 * i1
                b = a2
                g -= a2 * 2.0 / 3.0 * i2
            g /= det
            w = weights[e, q]
            p00 = a * f00 - b * fc00 + g * c00
            p01 = a * f01 - b * fc01 + g * c01
            p02 = a * f02 - b * fc02 + g * c02
            p10 = a * f10 - b * fc10 + g * c10
            p11 = a * f11 - b * fc11 + g * c11
            p12 = a * f12 - b * fc12 + g * c12
            p20 = a * f20 - b * fc20 + g * c20
            p21 = a * f21 - b * fc21 + g * c21
            p22 = a * f22 - b * fc22 + g * c22
            for k in range(n_k):
                g0 = gradients[e, q, k, 0]
                g1 = gradients[e, q, k, 1]
                g2 = gradients[e, q, k, 2]
                eforce[e, k, 0] -= w * (p00 * g0 + p01 * g1 + p02 * g2)
                eforce[e, k, 1] -= w * (p10 * g0 + p11 * g1 + p12 * g2)
                eforce[e, k, 2] -= w * (p20 * g0 + p21 * g1 + p22 * g2)
        j_min[e] = jm


@njit(parallel=True, cache=True, error_model="numpy")
def _element_volumes(x, elements, gradients, weights, volume):
    """volume[e] = sum_q w_q det F_q: the element's current volume (parallel over elements)."""
    for e in prange(elements.shape[0]):
        v = 0.0
        for q in range(gradients.shape[1]):
            f00, f01, f02, f10, f11, f12, f20, f21, f22 = _deformation_gradient(x, elements, gradients, e, q)
            v += weights[e, q] * (f00 * (f11 * f22 - f12 * f21) + f01 * (f12 * f20 - f10 * f22)
                                  + f02 * (f10 * f21 - f11 * f20))
        volume[e] = v


@njit(parallel=True, cache=True, error_model="numpy")
def _volumetric_pressure(x, elements, gradients, weights, volumetric, node_ptr, node_slots, reference_volume,
                         node_reference_volume, node_bulk, bulk, volume, node_pressure, pressure):
    """pressure[e]: the factor p of the volumetric stress p cof F of every point of element e (units of the moduli).

    volumetric 1 (``nodal``, the averaged nodal dilatation of linear tetrahedra): node a holds V_a = the sum of
    1/n_k of the current volumes of its elements, the volumetric energy is sum_a V_a0 kappa_a/2 (V_a/V_a0 - 1)^2,
    and an element's p is the mean over its nodes of kappa_a (J_a - 1). volumetric 2 (``mean``, P0 mean
    dilatation): the energy V_e0 kappa_e/2 (V_e/V_e0 - 1)^2 per element, p = kappa_e (J_e - 1)."""
    _element_volumes(x, elements, gradients, weights, volume)
    n_k = elements.shape[1]
    if volumetric == 2:
        for e in prange(elements.shape[0]):
            pressure[e] = bulk[e] * (volume[e] / reference_volume[e] - 1.0)
        return
    for a in prange(node_pressure.shape[0]):
        v = 0.0
        for s in range(node_ptr[a], node_ptr[a + 1]):
            v += volume[node_slots[s] // n_k]
        node_pressure[a] = node_bulk[a] * (v / n_k / node_reference_volume[a] - 1.0)
    for e in prange(elements.shape[0]):
        p = 0.0
        for k in range(n_k):
            p += node_pressure[elements[e, k]]
        pressure[e] = p / n_k


@njit(parallel=True, cache=True, error_model="numpy")
def _gather_node_forces(eforce, node_ptr, node_slots, out):
    """out[n] = sum of eforce over the (element, local node) slots of node n (CSR; parallel, race free)."""
    flat = eforce.reshape(-1, 3)
    for n in prange(out.shape[0]):
        sx = 0.0
        sy = 0.0
        sz = 0.0
        for s in range(node_ptr[n], node_ptr[n + 1]):
            slot = node_slots[s]
            sx += flat[slot, 0]
            sy += flat[slot, 1]
            sz += flat[slot, 2]
        out[n, 0] = sx
        out[n, 1] = sy
        out[n, 2] = sz


@njit(cache=True, error_model="numpy")
def elastic_forces(x, elements, gradients, weights, params, node_ptr, node_slots, eforce, j_elem, volumetric,
                   reference_volume, node_reference_volume, node_bulk, volume, node_pressure, pressure, out):
    if volumetric != 0:
        _volumetric_pressure(x, elements, gradients, weights, volumetric, node_ptr, node_slots, reference_volume,
                             node_reference_volume, node_bulk, params[:, 2], volume, node_pressure, pressure)
    _element_forces(x, elements, gradients, weights, params, eforce, j_elem, volumetric, pressure)
    _gather_node_forces(eforce, node_ptr, node_slots, out)
    j_min = np.inf
    for e in range(j_elem.shape[0]):
        v = j_elem[e]
        if not v > 0.0:
            return v
        j_min = min(j_min, v)
    return j_min


class ElasticForces:
    """Compiled nodal forces f = -dE/dx of a :class:`~elastocell.body.cell.Cell` (the same strain-energy law as
    ``Cell.internal_forces``, whose JAX autodiff it matches to round-off), in scaled units.

    Positions x are in units of ``length_scale`` (R = length_scale), forces in units of
    ``modulus_scale * length_scale^2`` with E_c = modulus_scale; e.g. lattice units: length_scale = R/dx,
    modulus_scale = E_c in lattice units. Cost: parallel over elements, then a race-free gather per node.
    """

    def __init__(self, cell, length_scale: float = 1.0, modulus_scale: float = 1.0):
        geometry = cell.geometry
        elements = np.ascontiguousarray(cell.mesh.elements, dtype=np.int64)
        self.elements = elements
        self.gradients = np.ascontiguousarray(geometry.shape_gradients / length_scale)
        self.weights = np.ascontiguousarray(geometry.weights * length_scale**3)
        self.params = np.ascontiguousarray(compiled_law_parameters(cell) * modulus_scale)
        n_nodes = cell.mesh.n_nodes
        slots = np.argsort(elements.ravel(), kind="stable")
        counts = np.bincount(elements.ravel(), minlength=n_nodes)
        self.node_ptr = np.zeros(n_nodes + 1, dtype=np.int64)
        np.cumsum(counts, out=self.node_ptr[1:])
        self.node_slots = slots.astype(np.int64)
        self._eforce = np.zeros(elements.shape + (3,))
        self._j = np.zeros(len(elements))
        treatment = cell.parameters.mesh.volumetric
        if treatment not in VOLUMETRIC_CODES:
            raise ValueError(f"the volumetric treatment {treatment!r} has no compiled force kernel: run its flow "
                             "with backend='jax', which immersed_cell selects for it")
        self.volumetric = VOLUMETRIC_CODES[treatment]
        self.reference_volume = np.ascontiguousarray(self.weights.sum(axis=1))
        nodal = treatment == "nodal"  # the node arrays are read by the nodal treatment only
        self.node_reference_volume = (cell.nodal_reference_volumes * length_scale**3 if nodal
                                      else np.ones(n_nodes))
        self.node_bulk = cell.nodal_bulk_moduli * modulus_scale if nodal else np.zeros(n_nodes)
        self._volume = np.zeros(len(elements))
        self._node_pressure = np.zeros(n_nodes)
        self._pressure = np.zeros(len(elements))

    def arguments(self) -> tuple:
        """The compiled kernel's arguments after x: (elements, gradients, weights, params, node_ptr,
        node_slots, element-force buffer, per-element det buffer, volumetric code, reference element volumes,
        reference node volumes, node bulk moduli, element-volume buffer, node-pressure buffer, element-pressure
        buffer)."""
        return (self.elements, self.gradients, self.weights, self.params, self.node_ptr, self.node_slots,
                self._eforce, self._j, self.volumetric, self.reference_volume, self.node_reference_volume,
                self.node_bulk, self._volume, self._node_pressure, self._pressure)

    def __call__(self, x: np.ndarray, out: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """(forces (n, 3), smallest det F); det F <= 0 or NaN flags an inverted element."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        if out is None:
            out = np.empty_like(x)
        j_min = elastic_forces(x, *self.arguments(), out)
        return out, float(j_min)
