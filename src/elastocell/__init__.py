"""elastocell: mechanics of living cells as hyperelastic tetrahedral bodies.

Parameters -> mesh -> material -> cell -> scenario -> observables -> results. The Python API mirrors the
command line: ``elastocell.compress(out=...)`` is ``elastocell compress --out ...``.
"""

__version__ = "0.1.0"

from .api import cell_parameters, compress, equivalent  # noqa: E402
from .parameters import ParameterError  # noqa: E402

__all__ = ["cell_parameters", "compress", "equivalent", "ParameterError", "__version__"]
