"""Inverse problems: master curves (plates, shear), fits of measured AFM curves and flow deformations to a
Young's modulus, and RT-DC look-up tables for dclab.
"""

