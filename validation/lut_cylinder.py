"""elastocell's look-up-table points in the RT-DC channel's equivalent cylinder with MC-PBS, against dclab's
HE-2D-FEM-22 (Wittwer et al. 2022: axisymmetric FEM, neo-Hookean cell, shear-thinning fluid, R_ch = 1.094 W/2).

    nice python validation/lut_cylinder.py [the options of lut_square.py]

``validation/lut_square.py --channel-shape cylinder``: the same cells and medium as the square-duct comparison,
in the geometry of dclab's axisymmetric tables, so that the pipe scenario's cylinder is checked against a
neo-Hookean FEM in the same run conditions as the duct. Its section goes into docs/validation/lut_square.md.
"""

from __future__ import annotations

import sys

from lut_square import main

if __name__ == "__main__":
    main(["--channel-shape", "cylinder", *sys.argv[1:]])
