"""elastocell: mechanics of living cells as hyperelastic tetrahedral bodies.

The package is laid out along its data flow, each stage importing only the stages before it:
``parameters`` (validated inputs, units) -> ``solvers`` (sparse factorisation, element stiffness kernel) ->
``body`` (elements, mesh, materials, cell, observables, effective moduli) -> ``lattice`` (lattice Boltzmann)
-> ``coupling`` (immersed boundary, immersed cell on each backend, stability) -> ``simulation`` (flow runner,
checkpoints, output writers, Dask execution, throughput) -> ``scenarios`` (compression, shear, pipe) -> ``api``
(one function per scenario: build, run, write one directory) -> ``inverse`` (master curves, fits, look-up
tables) -> ``studies`` (the paper's figures and claims) -> ``cli``.

The Python API mirrors the command line: ``elastocell.compress(out=...)`` is ``elastocell compress --out ...``.
Names are loaded on first use (PEP 562), so that ``import elastocell`` and ``elastocell --help`` do not pay
for JAX and Numba (about 2 s) before a command needs them.
"""

from importlib import import_module

from elastocell.version import __version__

_PUBLIC = {
    "cell_parameters": "elastocell.parameters.cell",
    "ParameterError": "elastocell.parameters.units",
    "compress": "elastocell.api.compression",
    "equivalent": "elastocell.api.compression",
    "indent": "elastocell.api.indentation",
    "shear": "elastocell.api.shear",
    "pipe": "elastocell.api.pipe",
    "lut": ("elastocell.inverse.lut", "compute_lut"),
    "fit_rtdc": "elastocell.inverse.rtdc",
    "register_lut": "elastocell.inverse.shipped_luts",
    "shipped_luts": "elastocell.inverse.shipped_luts",
    "study": ("elastocell.studies", "run_study"),
    "reproduce": ("elastocell.studies", "reproduce"),
}


def __getattr__(name: str):
    target = _PUBLIC.get(name)
    if target is None:
        raise AttributeError(f"module 'elastocell' has no attribute {name!r}")
    module, attribute = target if isinstance(target, tuple) else (target, name)
    value = getattr(import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__():
    return sorted(list(globals()) + list(_PUBLIC))


__all__ = ["cell_parameters", "compress", "equivalent", "indent", "shear", "pipe", "lut", "fit_rtdc", "register_lut",
           "shipped_luts", "study",
           "reproduce", "ParameterError", "__version__"]
