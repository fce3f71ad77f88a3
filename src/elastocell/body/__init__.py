"""The cell as a body: reference elements and quadrature, the tetrahedral mesh, the strain-energy laws, the
assembled cell (energy, forces, stiffness), shape observables and effective-modulus estimates.
"""

