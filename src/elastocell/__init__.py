"""elastocell: mechanics of living cells as hyperelastic tetrahedral bodies.

Parameters -> mesh -> material -> cell -> scenario -> observables -> results. The Python API mirrors the
command line: ``elastocell.compress(out=...)`` is ``elastocell compress --out ...``.
"""

__version__ = "0.1.0"

from .api import cell_parameters, compress, equivalent  # noqa: E402
from .parameters import ParameterError  # noqa: E402


def __getattr__(name: str):
    """Flow scenarios load their compiled kernels (Numba) only when first used."""
    if name == "shear":
        from .runner import shear

        return shear
    if name == "pipe":
        from .pipe_flow import pipe

        return pipe
    if name == "reproduce":
        from .studies import reproduce

        return reproduce
    if name == "study":
        from .studies import run_study

        return run_study
    raise AttributeError(f"module 'elastocell' has no attribute {name!r}")

__all__ = ["cell_parameters", "compress", "equivalent", "shear", "pipe", "study", "reproduce", "ParameterError", "__version__"]
