"""The scenarios, one module each with its parameters, lattice units and run: compression between two plates,
shear flow, pipe (capillary) flow.
"""

