"""The Python API: one function per scenario, with the same names and options as the command line
(``elastocell compress`` -> ``elastocell.compress``), each building the cell, running and writing one
directory. Import them from :mod:`elastocell`.
"""

