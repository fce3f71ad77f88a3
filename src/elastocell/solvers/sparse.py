"""Sparse direct solves of the Newton systems.

MKL PARDISO (through ``pypardiso``) where it installs: measured 3-8x faster than SciPy's SuperLU on these
systems. The Newton solver needs the (shifted) stiffness to be positive definite, and it needs to know when it
is not. PARDISO's sparse Cholesky factorisation (real symmetric positive definite mode, on the upper triangle)
answers both: it succeeds exactly when every pivot is positive, i.e. when the matrix is positive definite
(Sylvester's law of inertia), and otherwise stops with PARDISO's "zero or negative pivot" error (-4). On these
systems it is 1.6x faster than the symmetric-indefinite LDL^T factorisation (13.0 against 20.5 ms for 4,776
dofs, `validation/compression.py`'s default mesh, same process), which would also count the negative
eigenvalues, a number the solver never needed. The sparsity pattern never changes during a curve
(constrained degrees of freedom are replaced by identity rows and columns instead of being removed), so the
symbolic analysis (ordering) runs once per pattern and every Newton iteration pays only the numerical
factorisation. Elsewhere SciPy's SuperLU is the fallback (no definiteness test; the caller then checks
descent instead).

Mixed precision (the default with PARDISO): the Cholesky factorisation is made in single precision (PARDISO's
iparm(28)) and every solve is refined in double precision against the double-precision matrix (classical iterative
refinement: r = b - K x, x += K32^-1 r) until the relative residual is below :data:`REFINEMENT_TOLERANCE`. Measured
on the reference cell's default mesh (13,968 dofs, 4.3 GFLOP per factorisation): 47 against 86-90 ms per
factorisation; on Newton systems taken from a curve the single-precision solve leaves a relative residual of 3-4e-4
and each refinement step divides it by about 2,000, so two steps reach 1e-10. Where refinement stalls (a matrix too
ill-conditioned for single precision) the same matrix is factorised in double precision and solved again (as
accurate as the double-precision solver; if that factorisation finds the matrix indefinite, ``solve`` raises
:class:`NotPositiveDefinite`). The positive-definiteness answer of a mixed factorisation is that of K rounded to
single precision: eigenvalues within about 1e-7 of the largest one can be misjudged, and a shift below that (the
Newton solver's smallest, 1e-10 of the mean diagonal) is lost. Where that matters (the saddle test of an
equilibrium) ``factorize(..., precision="double")`` answers in double precision.
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
REFINEMENT_TOLERANCE = 1e-8
"""Relative residual ||b - K x|| / ||b|| (per right-hand side) a mixed-precision solve is refined to. The Newton
directions need far less (an inexact Newton step with forcing 1e-8 converges as the exact one to the solver's
tolerances); the double-precision solve reaches 1e-11 to 1e-13."""
MAX_REFINEMENT_STEPS = 6
_MKL_RT: str | None = None  # the MKL runtime pypardiso found first: later solvers skip its file search


class SparseSolver:
    """Factorise and solve K u = b for a sequence of symmetric matrices sharing one CSR pattern (their upper
    triangles are passed: the symmetric storage PARDISO reads).

    backend: ``"pardiso"``, ``"superlu"`` or ``"auto"`` (PARDISO if available).
    precision: ``"mixed"`` (PARDISO: single-precision factorisation, solves refined in double precision) or
    ``"double"``; SuperLU is always double.
    ``factorisations`` counts numerical factorisations (a double-precision one made after refinement stalled
    included), ``analyses`` symbolic ones, ``refinements`` the refinement steps of all solves.
    """

    def __init__(self, backend: str = "auto", precision: str = "mixed"):
        if backend == "auto":
            backend = "pardiso" if HAVE_PARDISO else "superlu"
        if backend == "pardiso" and not HAVE_PARDISO:
            raise ValueError("solver: pardiso is not available here (pip install pypardiso); use superlu")
        if backend not in ("pardiso", "superlu"):
            raise ValueError(f"solver: must be auto, pardiso or superlu, got {backend!r}")
        if precision not in ("mixed", "double"):
            raise ValueError(f"precision: must be mixed or double, got {precision!r}")
        self.backend = backend
        self.precision = precision if backend == "pardiso" else "double"
        self.refinements = 0
        self.factorisations = 0
        self.analyses = 0
        self._pattern_key = None
        self._pardiso = None
        self._single = None
        self._matrix = None
        self._factorised_in_double = False
        self._lu = None

    def factorize(self, upper: sp.csr_matrix, precision: str | None = None) -> bool | None:
        """Factorise the symmetric matrix whose upper triangle (CSR, sorted indices) is ``upper``.

        Returns True when the matrix is not positive definite (the factorisation then cannot be used), False
        when it is, and None when the backend cannot tell (SuperLU). ``precision="double"`` factorises in double
        precision whatever the solver's precision (a definiteness answer that must not depend on rounding K to
        single precision)."""
        self.factorisations += 1
        if self.backend == "superlu":
            from scipy.sparse.linalg import splu

            self._lu = None
            self._lu = splu((upper + sp.triu(upper, k=1).T).tocsc())
            return None
        key = (upper.shape, upper.nnz, hash(upper.indices.tobytes()), hash(upper.indptr.tobytes()))
        if key != self._pattern_key:
            self.close()
            self._pattern_key = key
            rows = np.repeat(np.arange(upper.shape[0]), np.diff(upper.indptr))
            self._diagonal = np.flatnonzero(rows == upper.indices)  # positions of the diagonal in ``data``
        self._matrix = None
        if self.precision == "mixed" and precision != "double":
            if self._single is None:
                self._single = _SinglePrecisionCholesky(upper)
                self.analyses += 1
            if not self._single.factorize(upper):
                return True
            self._matrix = upper
            self._factorised_in_double = False
            return False
        return self._factorize_double(upper)

    def _factorize_double(self, upper: sp.csr_matrix) -> bool:
        """Double-precision Cholesky factorisation of ``upper`` (True: not positive definite)."""
        if self._pardiso is None:
            self._pardiso = _pardiso_solver()
            self._pardiso.set_phase(11)
            self._pardiso._check_A(upper)
            self._pardiso._call_pardiso(upper, np.zeros((upper.shape[0], 1)))
            # the analysis filled PARDISO's defaults into iparm; override the refinement after it
            self._pardiso.set_iparm(8, ITERATIVE_REFINEMENT_STEPS)
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
        self._factorised_in_double = True
        return False

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """K^-1 rhs with the last factorisation; ``rhs`` is a vector or an (n, m) block of m right-hand sides."""
        if self.backend == "superlu":
            if self._lu is None:
                raise RuntimeError("solve: the last factorisation failed")
            return self._lu.solve(rhs)
        if self._matrix is None:
            raise RuntimeError("solve: the last factorisation failed (matrix not positive definite)")
        block = np.asfortranarray(rhs.reshape(rhs.shape[0], -1), dtype=np.float64)
        if self.precision == "mixed" and not self._factorised_in_double:
            solution = self._refined_solve(block)
            if solution is None:  # too ill-conditioned for single precision: factorise this matrix in double
                self.factorisations += 1
                if self._factorize_double(self._matrix):
                    self._matrix = None
                    raise NotPositiveDefinite("solve: the matrix is not positive definite in double precision")
                solution = self._double_solve(block)
        else:
            solution = self._double_solve(block)
        return solution.ravel() if rhs.ndim == 1 else solution.reshape(rhs.shape)

    def _double_solve(self, block: np.ndarray) -> np.ndarray:
        self._pardiso.set_phase(33)
        return self._pardiso._call_pardiso(self._matrix, block)

    def _refined_solve(self, block: np.ndarray) -> np.ndarray | None:
        """Single-precision solve refined in double precision to :data:`REFINEMENT_TOLERANCE`; None if
        refinement stalls (the residual does not halve in a step) or needs more than
        :data:`MAX_REFINEMENT_STEPS` steps."""
        norms = np.linalg.norm(block, axis=0)
        norms[norms == 0.0] = 1.0
        solution = self._single.solve(block)
        previous = np.inf
        for step in range(MAX_REFINEMENT_STEPS + 1):
            residual = block - symmetric_product(self._matrix, solution, self._matrix.data[self._diagonal])
            relative = float((np.linalg.norm(residual, axis=0) / norms).max())
            if relative <= REFINEMENT_TOLERANCE:
                return solution
            if not relative < 0.5 * previous or step == MAX_REFINEMENT_STEPS:
                return None
            previous = relative
            solution += self._single.solve(residual)
            self.refinements += 1
        return None

    def close(self) -> None:
        """Release PARDISO's memory (both precisions); the solver stays usable (a new analysis on next use)."""
        try:
            if self._pardiso is not None:
                self._pardiso.free_memory(everything=True)
        finally:
            self._pardiso = None
            try:
                if self._single is not None:
                    self._single.close()
            finally:
                self._single = None
                self._matrix = None


class NotPositiveDefinite(RuntimeError):
    """A factorisation that looked positive definite in single precision is not in double precision."""


def symmetric_product(upper: sp.csr_matrix, vectors: np.ndarray, diagonal: np.ndarray | None = None) -> np.ndarray:
    """K v for the symmetric K whose upper triangle (CSR, diagonal stored) is ``upper``; ``vectors`` is one
    vector or a block of columns; ``diagonal``: K's diagonal, if already known."""
    if diagonal is None:
        diagonal = upper.diagonal()
    if vectors.ndim == 2:
        diagonal = diagonal[:, None]
    return upper @ vectors + upper.T @ vectors - diagonal * vectors


class _SinglePrecisionCholesky:
    """PARDISO's Cholesky factorisation in single precision (iparm(28) = 1), called directly through the MKL
    runtime pypardiso loads: with single precision PARDISO reads the matrix, right-hand sides and solutions as
    float32 arrays, which pypardiso's own call (float64 only) cannot pass. One symbolic analysis per sparsity
    pattern (zero-based CSR of the upper triangle), then numerical factorisations and solves."""

    def __init__(self, upper: sp.csr_matrix):
        import ctypes

        self._ctypes = ctypes
        self._pardiso = _pardiso_solver()._mkl_pardiso  # the MKL entry point pypardiso located
        self._pardiso.argtypes = [ctypes.c_void_p] * 16
        self._pardiso.restype = None
        self._handle = np.zeros(64, dtype=np.int64)
        self._iparm = np.zeros(64, dtype=np.int32)
        self._iparm[0] = 1  # parameters set here, not MKL's defaults
        self._iparm[1] = 2  # nested-dissection ordering (METIS), as MKL's default
        self._iparm[7] = 0  # no iterative refinement inside PARDISO (done in double precision by the caller)
        self._iparm[9] = 8  # pivot perturbation 1e-8 (unused by a Cholesky factorisation)
        self._iparm[17] = -1  # report the factor's non-zeros
        self._iparm[18] = -1  # report the factorisation's MFLOP
        self._iparm[27] = 1  # single precision
        self._iparm[34] = 1  # zero-based indices
        self._n = upper.shape[0]
        self._indptr = np.ascontiguousarray(upper.indptr, dtype=np.int32)
        self._indices = np.ascontiguousarray(upper.indices, dtype=np.int32)
        self._values = upper.data.astype(np.float32)
        self._call(11, np.zeros((self._n, 1), dtype=np.float32))

    def _call(self, phase: int, rhs: np.ndarray) -> tuple[int, np.ndarray]:
        ctypes = self._ctypes
        solution = np.zeros_like(rhs)
        error = ctypes.c_int32(0)
        self._pardiso(self._handle.ctypes.data, ctypes.byref(ctypes.c_int32(1)), ctypes.byref(ctypes.c_int32(1)),
                      ctypes.byref(ctypes.c_int32(SYMMETRIC_POSITIVE_DEFINITE)), ctypes.byref(ctypes.c_int32(phase)),
                      ctypes.byref(ctypes.c_int32(self._n)), self._values.ctypes.data, self._indptr.ctypes.data,
                      self._indices.ctypes.data, None, ctypes.byref(ctypes.c_int32(rhs.shape[1])),
                      self._iparm.ctypes.data, ctypes.byref(ctypes.c_int32(0)), rhs.ctypes.data,
                      solution.ctypes.data, ctypes.byref(error))
        if error.value != 0 and not (phase == 22 and error.value == NOT_POSITIVE_DEFINITE):
            raise RuntimeError(f"PARDISO (single precision) failed in phase {phase} with error {error.value}")
        return error.value, solution

    def factorize(self, upper: sp.csr_matrix) -> bool:
        """True when the single-precision Cholesky factorisation of ``upper`` succeeded (positive definite)."""
        self._values[:] = upper.data
        error, _ = self._call(22, np.zeros((self._n, 1), dtype=np.float32))
        return error == 0

    def solve(self, block: np.ndarray) -> np.ndarray:
        rhs = np.asfortranarray(block, dtype=np.float32)
        _, solution = self._call(33, rhs)
        return solution.astype(np.float64)

    def close(self) -> None:
        self._call(-1, np.zeros((self._n, 1), dtype=np.float32))


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
