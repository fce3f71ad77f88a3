"""The RT-DC look-up tables that ship with elastocell, and their registration in dclab by one call.

A shipped table is a file ``elastocell/data/lut_<name>.txt`` written by ``elastocell lut`` (dclab's text format,
:mod:`elastocell.inverse.lut`), with its isoelastics beside it (``lut_<name>_isoelastics.txt``). Its metadata
hold dclab's ``identifier``, channel, flow rate and fluid viscosity, and elastocell's settings (medium,
temperature, resolution, which points reached a stationary shape).

    import elastocell, dclab
    from dclab.features.emodulus import get_emodulus
    elastocell.register_lut()            # every shipped table, by its identifier
    ds = dclab.new_dataset("measurement.rtdc")
    setup = ds.config["setup"]
    emodulus_kpa = get_emodulus(area_um=ds["area_um"], deform=ds["deform"], medium=setup["medium"],
                                channel_width=setup["channel width"], flow_rate=setup["flow rate"],
                                px_um=ds.config["imaging"]["pixel size"], temperature=setup["temperature"],
                                lut_data="elastocell-...", visc_model="buyukurganci-2022")

dclab then scales the table to the measurement's flow rate, channel width and viscosity as for its own tables
(``temperature`` in degC, within the viscosity model's range: 22-37 degC for MC-PBS with "buyukurganci-2022",
0-40 degC for water with "kestin-1978"; outside it dclab only warns and extrapolates). Calling
:func:`~dclab.features.emodulus.get_emodulus` on the file's ``area_um`` and ``deform`` is the reliable way:
dclab's shortcut, setting ``ds.config["calculation"]`` ("emodulus lut", "emodulus medium", "emodulus
temperature", "emodulus viscosity model") and reading ``ds["emodulus"]``, computes the modulus only when the file
stores none: where ``"emodulus" in ds.features_innate`` (files whose instrument computed it, e.g. dclab's
``fmt-hdf5_fl_wide-channel_2023`` test file) ``ds["emodulus"]`` is the stored modulus, silently, whatever table
is configured. ``elastocell fit rtdc FILES --lut <the table's identifier>`` does all of this and recomputes every
event.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from elastocell.parameters.units import ParameterError

SHIPPED_PREFIX = "lut_"
"""File names of shipped tables: ``lut_<name>.txt`` in ``elastocell/data`` (the isoelastics end in
``_isoelastics.txt``)."""


def data_directory() -> Path:
    """The package's data directory (``elastocell/data``)."""
    return Path(str(resources.files("elastocell") / "data"))


def shipped_luts(directory: Path | None = None) -> dict[str, dict]:
    """The shipped tables by dclab identifier: ``{"path", "isoelastics" (or None), "metadata"}`` each, in file
    name order. ``directory``: where to look (default :func:`data_directory`)."""
    from elastocell.inverse.lut import (  # lazy: the table module imports the flow solver
        isoelastics_path,
        read_lut,
    )

    directory = data_directory() if directory is None else Path(directory)
    tables = {}
    for path in sorted(directory.glob(f"{SHIPPED_PREFIX}*.txt")):
        if path.name.endswith("_isoelastics.txt"):
            continue
        _, metadata, _ = read_lut(path)
        identifier = metadata.get("identifier")
        if not identifier:
            raise ParameterError("identifier", f"the shipped table {path} names no identifier in its metadata")
        if identifier in tables:
            raise ValueError(f"two shipped tables have the identifier {identifier!r}: {tables[identifier]['path']} "
                             f"and {path}")
        isoelastics = isoelastics_path(path)
        tables[identifier] = {"path": path, "isoelastics": isoelastics if isoelastics.is_file() else None,
                              "metadata": metadata}
    return tables


def register_lut(identifier: str | None = None, directory: Path | None = None) -> dict[str, Path]:
    """Register the shipped tables (or the one named ``identifier``: a table's identifier, not a path; a table of
    your own is registered with dclab's ``dclab.features.emodulus.register_lut(path)``) with dclab
    (``dclab.features.emodulus.register_lut``), so that dclab computes ``emodulus`` with ``"emodulus lut"`` set to
    their identifier; returns {identifier: path}. A table already registered from the same file is left as it is
    (calling twice is harmless); an identifier dclab already holds for another file is refused (ParameterError), as
    is an unknown ``identifier`` or a package that ships no table."""
    try:
        from dclab.features.emodulus import load  # lazy: dclab only for this call
    except ImportError:
        raise ParameterError("identifier", "registering a table needs dclab (pip install dclab), which computes "
                             "the moduli from it") from None

    tables = shipped_luts(directory)
    if not tables:
        raise ParameterError("identifier", f"this version of elastocell ships no look-up table (none in "
                             f"{data_directory() if directory is None else directory}); make one with elastocell lut "
                             "and register it with dclab.features.emodulus.register_lut(FILE)")
    if identifier is not None:
        if identifier not in tables:
            raise ParameterError("identifier", f"no shipped table {identifier!r}; shipped: {', '.join(tables)}")
        tables = {identifier: tables[identifier]}
    for name, table in tables.items():  # every clash refused before any table is registered
        held = load.EXTERNAL_LUTS.get(name)
        if held is not None and Path(held).resolve() != table["path"].resolve():
            raise ParameterError("identifier", f"dclab already holds a table {name!r} from {held}, not "
                                 f"{table['path']}")
        if name in load.get_internal_lut_names_dict():
            raise ParameterError("identifier", f"{name!r} is the name of one of dclab's own tables")
    for name, table in tables.items():
        if name not in load.EXTERNAL_LUTS:
            load.register_lut(table["path"], identifier=name)
    return {name: table["path"] for name, table in tables.items()}
