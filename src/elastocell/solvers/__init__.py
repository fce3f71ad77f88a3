"""Numerical kernels of the quasistatic solvers: sparse symmetric factorisation (PARDISO or SuperLU) and the
compiled contraction of the material tangent into element stiffness matrices.
"""

