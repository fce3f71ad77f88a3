"""The element stiffness matrices of the Newton solver from the material tangent: a compiled (Numba) kernel,
where XLA's einsum was measured 4x slower. Imported only when a stiffness is needed, so that ``import elastocell``
does not set up Numba's on-disk cache.

The kernel is cached on disk like the flow kernels; several processes compiling it at once can leave that cache
inconsistent (numba issues 4807, 10128), so a study compiles it once (:func:`compile_kernel`) before starting
its workers.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(parallel=True, fastmath={"contract", "reassoc"}, cache=True)
def element_stiffness_matrices(tangents: np.ndarray, gradients: np.ndarray) -> np.ndarray:
    """K_e[3a + i, 3b + k] = sum_q sum_jl G_aj C_ijkl G_bl: the element stiffness matrices from the weighted
    material tangent ``tangents[i, j, k, l, e, q]`` (w_q d2W/dF_ij dF_kl) and the shape-function gradients
    ``gradients[a, j, e, q]`` (dN_a/dX_j). One pass per element over its points, in two contractions of 3 terms
    (C G, then G (C G)). Measured on the reference cell's default mesh (2,997 quadratic elements, 4 points
    each): 8.7 ms, against 35-38 ms for the same contraction by XLA's einsum in either layout."""
    n_nodes, n_elements, n_points = gradients.shape[0], gradients.shape[2], gradients.shape[3]
    out = np.empty((n_elements, 3 * n_nodes, 3 * n_nodes))
    for e in numba.prange(n_elements):
        half = np.empty((3, 3, 3, n_nodes))  # (C G)[i, j, k, b]
        matrix = np.zeros((3 * n_nodes, 3 * n_nodes))
        for q in range(n_points):
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        for b in range(n_nodes):
                            total = 0.0
                            for m in range(3):
                                total += tangents[i, j, k, m, e, q] * gradients[b, m, e, q]
                            half[i, j, k, b] = total
            for a in range(n_nodes):
                for i in range(3):
                    for b in range(n_nodes):
                        for k in range(3):
                            total = 0.0
                            for j in range(3):
                                total += gradients[a, j, e, q] * half[i, j, k, b]
                            matrix[3 * a + i, 3 * b + k] += total
        out[e] = matrix
    return out


def compile_kernel() -> None:
    """Compile (or load from Numba's cache) :func:`element_stiffness_matrices` for the argument types a cell passes
    (a read-only tangent, as JAX hands it to NumPy, and writable gradients), with a tiny input: about 9 s the first
    time, well under a second from the cache."""
    tangents = np.zeros((3, 3, 3, 3, 1, 1))
    tangents.setflags(write=False)
    element_stiffness_matrices(tangents, np.zeros((4, 3, 1, 1)))
