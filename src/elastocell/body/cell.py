"""The elastic cell: mesh + per-element moduli + strain-energy law -> energy, forces, stiffness.

Dimensionless throughout: lengths in R, moduli in E_c (the cytoplasm's Young's modulus), forces in E_c R^2.
The total elastic energy is ``E(x) = sum_e sum_q w_eq W(F_eq(x), p_e)``; nodal forces are ``-dE/dx`` and the
element stiffness matrices ``d^2 E_e / dx_e^2``, both by automatic differentiation (JAX, float64, jit).

The homogeneous equivalent (the paper's eq. 2-3) replaces every element's modulus by the volume average
``E_eff = (1/V) sum_e V_e E_e`` over the actual mesh; it keeps the same mesh so that the comparison between a
cell and its equivalent measures the heterogeneity, not a difference of discretisation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import jax
import jax.numpy as jnp
import numpy as np

from elastocell.body.elements import ElementGeometry, dilatation_projections, reference_element
from elastocell.body.materials import Law, computes_in_float64, determinant, law, material_tangent
from elastocell.body.mesh import NUCLEUS, CellMesh, build_mesh, cache_directory
from elastocell.parameters.cell import CellParameters
from elastocell.parameters.units import ParameterError
from elastocell.solvers.sparse import symmetric_product


def enable_compilation_cache() -> None:
    """Let JAX keep the compiled energy, force and tangent kernels on disk (``<cache>/jax``, beside the mesh
    cache), so that a new process reuses them. Called by elastocell's entry points (the API functions and the
    command line), never on import; a cache directory the user configured is left as it is."""
    try:
        if not jax.config.jax_compilation_cache_dir:
            jax.config.update("jax_compilation_cache_dir", str(cache_directory() / "jax"))
            jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    except Exception:  # pragma: no cover - a JAX without a persistent cache
        pass


@computes_in_float64
@dataclass(frozen=True, eq=False)
class Cell:
    """An elastic body ready for any scenario.

    youngs_moduli: E_e / E_c per element (the stiffness ratio gamma_e of each element).
    """

    parameters: CellParameters
    mesh: CellMesh
    youngs_moduli: np.ndarray
    is_equivalent: bool = False
    _kernels: dict = field(default_factory=dict, repr=False)

    # ---- construction -------------------------------------------------------------------------------
    @classmethod
    def from_parameters(cls, parameters: CellParameters, use_cache: bool = True) -> Cell:
        mesh = build_mesh(parameters, use_cache=use_cache)
        return cls(parameters, mesh, element_stiffness_ratios(parameters, mesh))

    def equivalent(self) -> Cell:
        """The homogeneous equivalent: same mesh, every element at E_eff (the volume average)."""
        moduli = np.full(self.mesh.n_elements, self.effective_stiffness_ratio)
        return Cell(self.parameters, self.mesh, moduli, is_equivalent=True)

    # ---- geometry and moduli ------------------------------------------------------------------------
    @cached_property
    def geometry(self) -> ElementGeometry:
        degree = self.parameters.mesh.quadrature_degree
        try:
            return reference_element(self.mesh.order, degree).geometry(self.mesh.nodes, self.mesh.elements)
        except ValueError as error:  # the mesh is checked at the nodes and the default rule's points only
            if degree is None:
                raise
            raise ParameterError("quadrature_degree", f"{error} at the points of the degree-{degree} rule; use "
                                 "the default degree 2 or a finer mesh") from None

    @cached_property
    def element_volumes(self) -> np.ndarray:
        """V_e (units of R^3), exact for the element's own (possibly curved) map."""
        return self.geometry.weights.sum(axis=1)

    @property
    def volume(self) -> float:
        return float(self.element_volumes.sum())

    @property
    def nucleus_volume(self) -> float:
        return float(self.element_volumes[self.mesh.region == NUCLEUS].sum())

    @property
    def effective_stiffness_ratio(self) -> float:
        """gamma_eff = E_eff / E_c = (1/V) sum_e V_e E_e / E_c."""
        return float(np.sum(self.element_volumes * self.youngs_moduli) / self.volume)

    @property
    def law(self) -> Law:
        return law(self.parameters.material.law)

    @cached_property
    def material_parameters(self) -> np.ndarray:
        """Per-element law parameters (units of E_c), e.g. (mu, kappa) for neo-Hookean."""
        material = self.parameters.material
        return self.law.parameters(
            self.youngs_moduli, material.poisson_ratio, {"mooney_rivlin_mu1_fraction": material.mooney_rivlin_mu1_fraction}
        )

    # ---- compiled kernels ---------------------------------------------------------------------------
    def _compiled(self):
        if self._kernels:
            return self._kernels
        elements = jnp.asarray(self.mesh.elements)
        gradients = jnp.asarray(self.geometry.shape_gradients)
        weights = jnp.asarray(self.geometry.weights)
        params = jnp.asarray(self.material_parameters.T[:, :, None])  # [k, e, 1]: broadcast over the points
        energy_law = self.law
        projections = self.dilatation_projections
        projections = None if projections is None else jnp.asarray(projections)
        nodal = self.parameters.mesh.volumetric == "nodal"
        if nodal:
            node_volumes0 = jnp.asarray(self.nodal_reference_volumes)
            node_bulk = jnp.asarray(self.nodal_bulk_moduli)
            n_nodes, n_k = self.mesh.n_nodes, self.mesh.elements.shape[1]

        def element_gradients(x_elements):
            """F[i, j, e, q] = sum_k x_(e_k) i dN_k/dX_j (the materials' layout: the points last)."""
            return jnp.einsum("eki,eqkj->ijeq", x_elements, gradients)

        def deformation_gradients(x):
            return element_gradients(x[elements])

        def law_gradients(f):
            """The F the law is evaluated on: F itself, or F_bar = (J_bar/J)^(1/3) F with J_bar the projection of
            the points' J within each element (MeshParameters.volumetric)."""
            if projections is None:
                return f
            volume_ratio = determinant(f)
            return f * (jnp.einsum("eqr,er->eq", projections, volume_ratio) / volume_ratio) ** (1.0 / 3.0)

        def nodal_volume_ratios(f):
            """J_a = V_a/V_a0 per node, V_a the sum of 1/n_k of the current volumes of its elements."""
            shares = jnp.repeat(jnp.sum(weights * determinant(f), axis=1) / n_k, n_k)
            return jax.ops.segment_sum(shares, elements.ravel(), num_segments=n_nodes) / node_volumes0

        def energy(x):
            f = deformation_gradients(x)
            if nodal:  # the law's isochoric part per point, its volumetric part kappa/2 (J - 1)^2 per node
                isochoric = f * determinant(f) ** (-1.0 / 3.0)
                return (jnp.sum(weights * energy_law(isochoric, params))
                        + jnp.sum(0.5 * node_bulk * node_volumes0 * (nodal_volume_ratios(f) - 1.0) ** 2))
            return jnp.sum(weights * energy_law(law_gradients(f), params))

        def tangents(x):
            # w_q d2W/dF2 per quadrature point by autodiff, [i, j, k, l, e, q]; contracted with dN/dX into the
            # element matrices by stiffness_kernel.element_stiffness_matrices
            return material_tangent(energy_law, deformation_gradients(x), params) * weights

        def projected_tangents(x):
            """The element Hessian with a projected J in two parts. With W_hat(F, j) = W((j/det F)^(1/3) F) and
            E_e = sum_q w_q W_hat(F_q, J_bar_q), J_bar = P_e det F:
            d2E_e = sum_q B_q^T T_q B_q + sum_q [w_q B_q^T c_q G_q^T + transpose + w_q W_hat_jj,q G_q G_q^T], with
            B_q: x_e -> F_q, T_q = w_q W_hat_FF,q + pi_q d2(det F_q) (pi_r = sum_q P_qr w_q W_hat_j,q), c_q =
            W_hat_Fj,q and G_q = dJ_bar_q/dx_e. Returns T [i, j, k, l, e, q] for the compiled contraction (as the
            standard tangents) and the remaining (n_elements, 3k, 3k) by whole-array products."""
            f = deformation_gradients(x)
            projected = jnp.einsum("eqr,er->eq", projections, determinant(f))

            def hat(ff, jj):  # w_q W_hat(F_q, j_q) per point
                return weights * energy_law(ff * (jj / determinant(ff)) ** (1.0 / 3.0), params)

            def d_j(jj):
                return jax.grad(lambda j: jnp.sum(hat(f, j)))(jj)

            ones = jnp.ones_like(projected)
            w_hat_j, w_hat_jj = jax.jvp(d_j, (projected,), (ones,))
            pressure = jnp.einsum("eqr,eq->er", projections, w_hat_j)
            point = material_tangent(lambda ff, _: hat(ff, projected) + pressure * determinant(ff), f, params)
            w_hat_fj = jax.jvp(lambda jj: jax.grad(lambda ff: jnp.sum(hat(ff, jj)))(f), (projected,), (ones,))[1]
            cofactor = jax.grad(lambda ff: jnp.sum(determinant(ff)))(f)
            n = gradients.shape[2] * 3
            dilatation = jnp.einsum("eqr,ijer,erkj->eqki", projections, cofactor, gradients).reshape(*projected.shape, n)
            mixed = jnp.einsum("ijeq,eqkj->eqki", w_hat_fj, gradients).reshape(*projected.shape, n)
            coupled = jnp.einsum("eqa,eqb->eab", mixed, dilatation)
            return point, coupled + jnp.swapaxes(coupled, 1, 2) + jnp.einsum("eq,eqa,eqb->eab", w_hat_jj, dilatation,
                                                                            dilatation)

        def element_hessians(x):
            # reference for projected_tangents (tests): d2E_e/dx_e2 by forward-over-reverse autodiff of the element
            # energies, one direction (node, component) at a time
            x_elements = x[elements]
            gradient = jax.grad(lambda xe: jnp.sum(weights * energy_law(law_gradients(element_gradients(xe)), params)))
            n = x_elements.shape[1] * 3
            directions = jnp.eye(n).reshape(n, 1, -1, 3)
            columns = jax.lax.map(lambda d: jax.jvp(gradient, (x_elements,),
                                                    (jnp.broadcast_to(d, x_elements.shape),))[1], directions)
            return jnp.moveaxis(columns.reshape(n, len(x_elements), n), 0, 1)

        def stresses(x):
            f = deformation_gradients(x)
            if nodal:  # the isochoric part's Cauchy stress plus the element's pressure, the mean of kappa_a (J_a - 1)
                isochoric = jax.grad(lambda ff: jnp.sum(energy_law(ff * determinant(ff) ** (-1.0 / 3.0), params)))(f)
                sigma = jnp.einsum("ik...,jk...->ij...", isochoric, f) / determinant(f)
                pressure = jnp.mean((node_bulk * (nodal_volume_ratios(f) - 1.0))[elements], axis=1)
                sigma = sigma + pressure[None, None, :, None] * jnp.eye(3)[:, :, None, None]
            else:
                f = law_gradients(f)
                piola = jax.grad(lambda ff: jnp.sum(energy_law(ff, params)))(f)
                sigma = jnp.einsum("ik...,jk...->ij...", piola, f) / determinant(f)
            return jnp.einsum("eq,ijeq->eij", weights, sigma) / jnp.sum(weights, axis=1)[:, None, None]

        self._kernels.update(
            energy=jax.jit(energy),
            gradient=jax.jit(jax.grad(energy)),
            min_jacobian=jax.jit(lambda x: jnp.min(determinant(deformation_gradients(x)))),
            tangents=jax.jit(tangents),
            element_hessians=jax.jit(element_hessians),
            projected_tangents=jax.jit(projected_tangents),
            stresses=jax.jit(stresses),
        )
        return self._kernels

    @cached_property
    def nodal_reference_volumes(self) -> np.ndarray:
        """V_a0 per node (units of R^3): the sum over its elements of 1/n_k of their volumes (n_k nodes each); the
        volumes of the averaged nodal dilatation (``MeshParameters.volumetric`` nodal)."""
        elements = self.mesh.elements
        shares = np.repeat(self.element_volumes / elements.shape[1], elements.shape[1])
        return np.bincount(elements.ravel(), weights=shares, minlength=self.mesh.n_nodes)

    @cached_property
    def nodal_bulk_moduli(self) -> np.ndarray:
        """kappa_a per node (units of E_c): the bulk moduli of its elements averaged with the weights of
        :attr:`nodal_reference_volumes`; ValueError for a law that does not name its bulk modulus
        (``Law.compiled_parameters``: the decoupled Mooney-Rivlin family)."""
        if not self.law.has_compiled_kernel:
            raise ValueError(f"the law {self.law.name!r} does not name its bulk modulus (it is not of the "
                             "decoupled Mooney-Rivlin family): the nodal dilatation needs it")
        elements = self.mesh.elements
        bulk = self.law.compiled_parameters(np.asarray(self.material_parameters, dtype=np.float64))[:, 2]
        shares = np.repeat(self.element_volumes * bulk / elements.shape[1], elements.shape[1])
        return np.bincount(elements.ravel(), weights=shares, minlength=self.mesh.n_nodes) / self.nodal_reference_volumes

    def reference_stiffness_matrix(self):
        """K = d^2 E/dx^2 at the reference state x = X (CSR). For the nodal dilatation, which has no element
        matrices, by exchanging the volumetric parts: at J = 1 the elements' kappa_e/V_e0 grad V_e grad V_e^T
        for the nodes' kappa_a/V_a0 grad V_a grad V_a^T (V_a = sum of 1/n_k of its elements' volumes); the
        isochoric part is the same in both (a decoupled law)."""
        if self.parameters.mesh.volumetric != "nodal":
            return self.stiffness_matrix(self.mesh.nodes)
        import scipy.sparse as sp

        elements = self.mesh.elements
        n_elements, n_k = elements.shape
        n = 3 * self.mesh.n_nodes
        volumes = self.element_volumes
        columns = (3 * elements[:, :, None] + np.arange(3)).reshape(n_elements, -1)
        values = (volumes[:, None, None] * self.geometry.shape_gradients[:, 0]).reshape(n_elements, -1)
        volume_gradients = sp.csr_matrix((values.ravel(), (np.repeat(np.arange(n_elements), 3 * n_k), columns.ravel())),
                                         shape=(n_elements, n))  # row e: dV_e/dx at x = X (p1: one point)
        incidence = sp.csr_matrix((np.full(elements.size, 1.0 / n_k), (elements.ravel(),
                                   np.repeat(np.arange(n_elements), n_k))), shape=(self.mesh.n_nodes, n_elements))
        nodal_gradients = incidence @ volume_gradients
        bulk = self.law.compiled_parameters(np.asarray(self.material_parameters, dtype=np.float64))[:, 2]
        elementwise = volume_gradients.T @ sp.diags(bulk / volumes) @ volume_gradients
        nodal = nodal_gradients.T @ sp.diags(self.nodal_bulk_moduli / self.nodal_reference_volumes) @ nodal_gradients
        return (self.with_standard_volumetric().stiffness_matrix(self.mesh.nodes) - elementwise + nodal).tocsr()

    def with_standard_volumetric(self) -> Cell:
        """The same body (mesh, moduli) with J = det F at each point (``MeshParameters.volumetric`` standard)."""
        mesh = self.parameters.mesh.model_copy(update={"volumetric": "standard"})
        return Cell(self.parameters.model_copy(update={"mesh": mesh}), self.mesh, self.youngs_moduli,
                    is_equivalent=self.is_equivalent)

    @cached_property
    def dilatation_projections(self) -> np.ndarray | None:
        """J_bar = P_e J per element (``elements.dilatation_projections``), or None for ``volumetric`` standard."""
        reference = reference_element(self.mesh.order, self.parameters.mesh.quadrature_degree)
        return dilatation_projections(self.parameters.mesh.volumetric, reference.points, self.geometry.weights)

    @cached_property
    def _shape_gradients_points_last(self) -> np.ndarray:
        """dN_a/dX_j as [a, j, e, q], the layout of the stiffness kernel."""
        return np.ascontiguousarray(np.moveaxis(self.geometry.shape_gradients, (2, 3), (0, 1)))

    def energy(self, x: np.ndarray) -> float:
        """Total elastic energy E(x) (units of E_c R^3); NaN if an element is inverted."""
        return float(self._compiled()["energy"](jnp.asarray(x)))

    def internal_forces(self, x: np.ndarray) -> np.ndarray:
        """dE/dx per node, (n_nodes, 3): minus the elastic force on each node (units of E_c R^2)."""
        return np.asarray(self._compiled()["gradient"](jnp.asarray(x)))

    def element_stiffness(self, x: np.ndarray) -> np.ndarray:
        """Element Hessians d^2 E_e / dx_e^2, (n_elements, 3k, 3k), dof order (node, component): the material
        tangent at each quadrature point by JAX, contracted with the shape-function gradients by a compiled
        kernel (:func:`stiffness_kernel.element_stiffness_matrices`); with a projected J (the points of an element
        coupled) the same contraction of a modified point tangent plus the coupling of the points through the
        projected J (``projected_tangents``)."""
        from elastocell.solvers.stiffness_kernel import (
            element_stiffness_matrices,  # lazy: the Numba stiffness kernel compiles/loads only when a stiffness is needed
        )

        if self.parameters.mesh.volumetric == "nodal":
            raise ValueError("the nodal dilatation couples the elements that share a node: it has no element "
                             "stiffness matrices (it serves the flows, which need forces only)")
        if self.dilatation_projections is not None:
            tangents, coupling = self._compiled()["projected_tangents"](jnp.asarray(x))
            return element_stiffness_matrices(np.asarray(tangents), self._shape_gradients_points_last) + np.asarray(coupling)
        tangents = np.asarray(self._compiled()["tangents"](jnp.asarray(x)))
        return element_stiffness_matrices(tangents, self._shape_gradients_points_last)

    def element_cauchy_stress(self, x: np.ndarray) -> np.ndarray:
        """Volume-averaged Cauchy stress per element, (n_elements, 3, 3), units of E_c."""
        return np.asarray(self._compiled()["stresses"](jnp.asarray(x)))

    @cached_property
    def stiffness_pattern(self) -> StiffnessPattern:
        return StiffnessPattern(self.mesh.elements, self.mesh.n_nodes)

    def stiffness_matrix(self, x: np.ndarray):
        """Global tangent stiffness K = d^2 E/dx^2 as a CSR matrix (constant sparsity pattern)."""
        return self.stiffness_pattern.assemble(self.element_stiffness(x))

    def summary(self) -> dict:
        return {
            "effective_stiffness_ratio": self.effective_stiffness_ratio,
            "volume": self.volume,
            "nucleus_volume": self.nucleus_volume,
            "volume_exact": 4 / 3 * np.pi,
            **self.mesh.counts(),
        }


class StiffnessPattern:
    """CSR sparsity pattern of the global stiffness and the maps from element-matrix entries into it.

    The full matrix (``assemble``) serves general use; the Newton solvers work on its upper triangle
    (``assemble_upper``, row <= col), the symmetric storage the factorisation reads, assembled by one sparse
    matrix-vector product with a fixed 0/1 operator (1.0 against 5.0 ms for the full bincount, 1,592-node p2
    mesh).
    """

    def __init__(self, elements: np.ndarray, n_nodes: int, dofs_per_node: int = 3):
        import scipy.sparse as sp

        k, d = elements.shape[1], dofs_per_node  # d = 2: the meridian section of body.axisymmetric
        dofs = (d * elements[:, :, None] + np.arange(d)).reshape(len(elements), d * k)
        rows = np.repeat(dofs, d * k, axis=1).ravel()
        cols = np.tile(dofs, (1, d * k)).ravel()
        n = d * n_nodes
        keys = rows.astype(np.int64) * n + cols
        unique_keys, self.entry_to_data = np.unique(keys, return_inverse=True)
        self.rows = (unique_keys // n).astype(np.int64)
        self.cols = (unique_keys % n).astype(np.int64)
        self.shape = (n, n)
        self._template = _csr(np.zeros(len(unique_keys)), self.rows, self.cols, self.shape)
        self.diagonal_entries = np.flatnonzero(self.rows == self.cols)
        # upper triangle: its rows and columns, where the diagonal sits among them, and the operator that sums
        # the element-matrix entries into it
        upper = np.flatnonzero(self.rows <= self.cols)
        self.upper_rows, self.upper_cols = self.rows[upper], self.cols[upper]
        self.upper_diagonal = np.flatnonzero(self.upper_rows == self.upper_cols)
        self._upper_template = _csr(np.zeros(len(upper)), self.upper_rows, self.upper_cols, self.shape)
        position = np.full(len(unique_keys), -1, dtype=np.int64)
        position[upper] = np.arange(len(upper))
        entries = np.flatnonzero(rows <= cols)
        self._upper_assembly = sp.csr_matrix(
            (np.ones(len(entries)), (position[self.entry_to_data[entries]], entries)), shape=(len(upper), rows.size)
        )

    @property
    def nnz(self) -> int:
        return len(self.rows)

    def assemble(self, element_matrices: np.ndarray):
        """The full global matrix (CSR) from the element matrices (n_elements, 3k, 3k)."""
        data = np.bincount(self.entry_to_data, weights=element_matrices.ravel(), minlength=self.nnz)
        matrix = self._template.copy()
        matrix.data = data
        return matrix

    def assemble_upper(self, element_matrices: np.ndarray):
        """The upper triangle (CSR, sorted indices, row <= col) of the global matrix."""
        matrix = self._upper_template.copy()
        matrix.data = self._upper_assembly @ element_matrices.ravel()
        return matrix

    def constrained_upper(self, upper, constrained: np.ndarray, regularisation: float = 0.0):
        """Copy of the upper triangle ``upper`` with the ``constrained`` dofs' rows and columns zeroed and
        their diagonal set to the mean diagonal magnitude; ``regularisation`` (relative to that mean) is added
        to the free diagonal: it changes a Newton path, never an equilibrium. The pattern is kept, so a
        factorisation's symbolic analysis can be reused."""
        data = upper.data.copy()
        data[constrained[self.upper_rows] | constrained[self.upper_cols]] = 0.0
        diagonal = self.upper_diagonal
        scale = np.abs(upper.data[diagonal]).mean()
        data[diagonal] = np.where(constrained[self.upper_rows[diagonal]], scale, data[diagonal] + regularisation * scale)
        result = self._upper_template.copy()
        result.data = data
        return result

    def symmetric_product(self, upper, vector: np.ndarray) -> np.ndarray:
        """K v for the symmetric K whose upper triangle is ``upper``."""

        return symmetric_product(upper, vector, upper.data[self.upper_diagonal])


def _csr(data: np.ndarray, rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]):
    """CSR matrix from entries already sorted by (row, col)."""
    import scipy.sparse as sp

    indptr = np.zeros(shape[0] + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=shape[0]), out=indptr[1:])
    return sp.csr_matrix((data, cols, indptr), shape=shape)


def element_stiffness_ratios(parameters: CellParameters, mesh: CellMesh) -> np.ndarray:
    """gamma_e = E_e / E_c per element: 1 in the cytoplasm, gamma in the nucleus, U[1, 10] for the random cell."""
    if parameters.random is not None:
        rng = np.random.default_rng(parameters.random.seed)
        return rng.uniform(parameters.random.low, parameters.random.high, mesh.n_elements)
    ratios = np.ones(mesh.n_elements)
    if parameters.nucleus.shape != "none":
        ratios[mesh.region == NUCLEUS] = parameters.nucleus.stiffness_ratio
    return ratios
