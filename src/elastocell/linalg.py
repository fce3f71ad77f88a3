"""Sparse direct solves of the Newton systems.

MKL PARDISO (through ``pypardiso``) where it installs: measured 3-8x faster than SciPy's SuperLU on these
systems. The Newton solver needs the (shifted) stiffness to be positive definite, and it needs to know when it
is not. PARDISO's sparse Cholesky factorisation (real symmetric positive definite mode, on the upper triangle)
answers both: it succeeds exactly when every pivot is positive, i.e. when the matrix is positive definite
(Sylvester's law of inertia), and otherwise stops with PARDISO's "zero or negative pivot" error (-4). On these
systems it is 1.6x faster than the symmetric-indefinite LDL^T factorisation (13.0 against 20.5 ms for 4,776
dofs, `benchmarks/compression.py`'s default mesh, same process), which would also count the negative
eigenvalues, a number the solver never needed. The sparsity pattern never changes during a curve
(constrained degrees of freedom are replaced by identity rows and columns instead of being removed), so the
symbolic analysis (ordering) runs once per pattern and every Newton iteration pays only the numerical
factorisation. Elsewhere SciPy's SuperLU is the fallback (no definiteness test; the caller then checks
descent instead).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def _locate_mkl_runtime() -> None:
    """pypardiso looks for MKL's runtime under ``sys.prefix``. In a virtual environment that uses the base
    interpreter's packages (``--system-site-packages``) MKL lives under ``sys.base_prefix`` instead, pypardiso
    fails to import, and every curve would fall back to SuperLU (measured: the README's first command ran over
    10 minutes instead of about 1). Point pypardiso at the base installation's MKL in that case (its own
    ``PYPARDISO_MKL_RT`` setting; a value the user set is kept)."""
    import glob
    import os
    import sys

    if os.environ.get("PYPARDISO_MKL_RT") or sys.base_prefix == sys.prefix:
        return
    patterns = ("lib/libmkl_rt.so*", "lib/libmkl_rt*.dylib", "Library/bin/mkl_rt*.dll")
    if any(glob.glob(os.path.join(sys.prefix, pattern)) for pattern in patterns):
        return
    for pattern in patterns:
        found = sorted(glob.glob(os.path.join(sys.base_prefix, pattern)))
        if found:
            os.environ["PYPARDISO_MKL_RT"] = found[0]
            return


_locate_mkl_runtime()

try:  # pragma: no cover - depends on the platform
    from pypardiso.pardiso_wrapper import PyPardisoError, PyPardisoSolver

    HAVE_PARDISO = True
except Exception:  # pragma: no cover
    HAVE_PARDISO = False

SYMMETRIC_POSITIVE_DEFINITE = 2
NOT_POSITIVE_DEFINITE = -4  # PARDISO's error code for a zero or negative pivot
ITERATIVE_REFINEMENT_STEPS = 0
"""PARDISO's iparm(8), the most iterative-refinement steps per solve (MKL's default, filled in at the symbolic
analysis, is 2). A Cholesky factorisation has no perturbed pivots to refine, and each step costs a matrix product
and a solve: measured on the reference cell's default mesh (13,968 dofs), one solve took 4.6 ms without
refinement against 17.3 ms with two steps, with the same relative residual (9.3e-12)."""
_MKL_RT: str | None = None  # the MKL runtime pypardiso found first: later solvers skip its file search


class SparseSolver:
    """Factorise and solve K u = b for a sequence of symmetric matrices sharing one CSR pattern (their upper
    triangles are passed: the symmetric storage PARDISO reads).

    backend: ``"pardiso"``, ``"superlu"`` or ``"auto"`` (PARDISO if available).
    ``factorisations`` counts numerical factorisations, ``analyses`` symbolic ones.
    """

    def __init__(self, backend: str = "auto"):
        if backend == "auto":
            backend = "pardiso" if HAVE_PARDISO else "superlu"
        if backend == "pardiso" and not HAVE_PARDISO:
            raise ValueError("solver: pardiso is not available here (pip install pypardiso); use superlu")
        if backend not in ("pardiso", "superlu"):
            raise ValueError(f"solver: must be auto, pardiso or superlu, got {backend!r}")
        self.backend = backend
        self.factorisations = 0
        self.analyses = 0
        self._pattern_key = None
        self._pardiso = None
        self._matrix = None
        self._lu = None

    def factorize(self, upper: sp.csr_matrix) -> bool | None:
        """Factorise the symmetric matrix whose upper triangle (CSR, sorted indices) is ``upper``.

        Returns True when the matrix is not positive definite (the factorisation then cannot be used), False
        when it is, and None when the backend cannot tell (SuperLU)."""
        self.factorisations += 1
        if self.backend == "superlu":
            from scipy.sparse.linalg import splu

            self._lu = None
            self._lu = splu((upper + sp.triu(upper, k=1).T).tocsc())
            return None
        key = (upper.shape, upper.nnz, hash(upper.indices.tobytes()), hash(upper.indptr.tobytes()))
        if self._pardiso is None or key != self._pattern_key:
            self.close()
            self._pardiso = _pardiso_solver()
            self._pardiso.set_phase(11)
            self._pardiso._check_A(upper)
            self._pardiso._call_pardiso(upper, np.zeros((upper.shape[0], 1)))
            # the analysis filled PARDISO's defaults into iparm; override the refinement after it
            self._pardiso.set_iparm(8, ITERATIVE_REFINEMENT_STEPS)
            self._pattern_key = key
            self.analyses += 1
        self._pardiso.set_phase(22)
        self._matrix = None
        try:
            self._pardiso._call_pardiso(upper, np.zeros((upper.shape[0], 1)))
        except PyPardisoError as error:
            if error.value != NOT_POSITIVE_DEFINITE:
                raise
            return True
        self._matrix = upper
        return False

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """K^-1 rhs with the last factorisation; ``rhs`` is a vector or an (n, m) block of m right-hand sides."""
        if self.backend == "superlu":
            if self._lu is None:
                raise RuntimeError("solve: the last factorisation failed")
            return self._lu.solve(rhs)
        if self._matrix is None:
            raise RuntimeError("solve: the last factorisation failed (matrix not positive definite)")
        self._pardiso.set_phase(33)
        block = np.asfortranarray(rhs.reshape(rhs.shape[0], -1))
        solution = self._pardiso._call_pardiso(self._matrix, block)
        return solution.ravel() if rhs.ndim == 1 else solution.reshape(rhs.shape)

    def close(self) -> None:
        if self._pardiso is not None:
            self._pardiso.free_memory(everything=True)
            self._pardiso = None



def _pardiso_solver():
    """A PARDISO handle for symmetric positive-definite matrices. pypardiso looks for the MKL runtime on every
    construction, with a recursive file search where ``find_library`` fails (0.5 s here); the first path found
    is handed to the later ones through pypardiso's own ``PYPARDISO_MKL_RT`` setting (an environment variable,
    so processes started from this one inherit it; a value the user set is kept)."""
    import os

    global _MKL_RT
    if _MKL_RT is not None:
        os.environ.setdefault("PYPARDISO_MKL_RT", _MKL_RT)
    solver = PyPardisoSolver(mtype=SYMMETRIC_POSITIVE_DEFINITE)
    _MKL_RT = getattr(solver.libmkl, "_name", None)
    return solver
