"""A cell immersed in the lattice-Boltzmann fluid: immersed-boundary kernels, the compiled elastic forces,
the coupled system on each backend (Numba, JAX) and the stability limits of the explicit coupling.
"""

