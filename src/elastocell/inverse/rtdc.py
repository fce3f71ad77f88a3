"""Young's moduli of real RT-DC measurements: the events of ``.rtdc`` files read through a look-up table.

RT-DC records, for every cell, its projected area ``area_um`` (um^2) and deformation ``deform`` = 1 - c
(c the circularity of its contour) in a channel of width ``channel width`` (um) at ``flow rate`` (uL/s), in a
medium at a temperature. A look-up table maps (area, deformation) to the Young's modulus E (kPa in dclab's files)
of a homogeneous cell at its own channel width, flow rate and viscosity; dclab scales it to the measurement's
(Mietke et al. 2015: E scales with the medium's viscosity, the flow rate and the channel width) and corrects the
deformation for the camera's pixelation. This module leaves all of that to dclab
(:func:`dclab.features.emodulus.get_emodulus`), so that a table elastocell writes (``elastocell lut``) and
dclab's own (``LE-2D-FEM-19``, ``HE-2D-FEM-22``, ``HE-3D-FEM-22``) are applied to the same events by the same
code, and adds what a user needs around it: the measurement conditions read from each file (or supplied where
the file lacks them), the coverage of each table (the fraction of events inside it: an event outside gets no
modulus, never an extrapolated one), one tidy table of every event, and a reason for each file that could not
be converted. Where dclab would still give a number with a warning only, an event gets none and says why: a
temperature outside the range of the medium's viscosity model (:func:`temperature_valid`); a modulus through a
table whose points are not converged is kept but marked as not trustworthy (:func:`table_caveats`).

dclab is needed here (``pip install dclab``); it is imported only when a file or a medium is read.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from elastocell.files import replace_atomically, save_figure, software_versions, write_json
from elastocell.inverse.shipped_luts import register_lut, shipped_luts
from elastocell.parameters.medium import MC_PBS_TEMPERATURES
from elastocell.parameters.units import ParameterError, parse_temperature

DCLAB_TABLES = ("LE-2D-FEM-19", "HE-2D-FEM-22", "HE-3D-FEM-22")
"""The look-up tables dclab ships: linear elastic axisymmetric (Mokbel et al. 2017), neo-Hookean axisymmetric
and 3D square channel in a shear-thinning medium (Wittwer et al. 2022)."""

MC_PBS_VISCOSITY_MODEL = "buyukurganci-2022"
"""dclab's viscosity model for the MC-PBS media (power law in the channel's wall shear rate, with temperature)."""

WATER_VISCOSITY_MODEL = "kestin-1978"

WATER_TEMPERATURES = (0.0, 40.0)
"""Temperature range (degC) of dclab's viscosity of water (Kestin et al. 1978: the range dclab's
``get_viscosity_water_kestin_1978`` checks); the MC-PBS media's is :data:`MC_PBS_TEMPERATURES` (22-37 degC, the
range dclab's ``get_viscosity_mc_pbs_buyukurganci_2022`` checks). Outside its range dclab extrapolates the
viscosity with a warning only; here such a temperature converts nothing."""

UNTRUSTED = "converted through a table that is not converged"
"""The label of an event converted only through a table whose metadata say its points are not converged."""

OUTSIDE = "outside the table"
"""The flag (and label) of an event whose (area, deformation) lies outside the table: no modulus."""

OUT_OF_RANGE = "temperature outside the viscosity model's range"
"""The label of an event whose temperature lies outside the range of its medium's viscosity model: no modulus."""


def _dclab():
    try:
        import dclab  # lazy: an optional dependency, needed only to read .rtdc files
    except ImportError:  # pragma: no cover - dclab is installed with the test extra
        raise ParameterError("files", "reading .rtdc files needs dclab: pip install dclab") from None
    return dclab


def _squeezed(name) -> str:
    return re.sub(r"\s+", "", str(name)).lower()


def known_medium(name) -> str | None:
    """dclab's name of a medium whose viscosity dclab knows ("0.49% MC-PBS", "0.59% MC-PBS", "0.83% MC-PBS" or
    "water") from any of dclab's spellings (``dclab.features.emodulus.viscosity.ALIAS_MEDIA``: "CellCarrier",
    "CellCarrier B", "0.6% MC-PBS", ...), case and blanks ignored ("0.59%mc-pbs", "cellcarrierb"); None for
    anything else (such as "other")."""
    if name is None:
        return None
    _dclab()
    from dclab.features.emodulus.viscosity import ALIAS_MEDIA  # lazy: optional dependency (see _dclab)

    return {_squeezed(alias): canonical for alias, canonical in ALIAS_MEDIA.items()}.get(_squeezed(name))


def media_names() -> str:
    """The media dclab knows the viscosity of, each with its other names (for messages)."""
    _dclab()
    from dclab.features.emodulus.viscosity import SAME_MEDIA  # lazy: optional dependency (see _dclab)

    return ", ".join(name + (f" (= {', '.join(a for a in aliases if a != name)})" if len(aliases) > 1 else "")
                     for name, aliases in SAME_MEDIA.items())


def check_medium(medium: str | None) -> str | None:
    """dclab's name of ``medium`` (:func:`known_medium`; None stays None), refused in one line naming --medium with
    the accepted names when dclab does not know its viscosity (before any file is read)."""
    if medium is None:
        return None
    canonical = known_medium(medium)
    if canonical is None:
        raise ParameterError("medium", f"{medium!r} is not a medium dclab knows the viscosity of; use one of "
                                       f"{media_names()} (case and blanks ignored)")
    return canonical


def viscosity_model(medium: str) -> str:
    """dclab's viscosity model of a medium (dclab's name, :func:`known_medium`)."""
    return WATER_VISCOSITY_MODEL if medium == "water" else MC_PBS_VISCOSITY_MODEL


def temperature_range(medium: str) -> tuple[float, float]:
    """(lowest, highest) temperature in degC of the viscosity model of a medium (dclab's name)."""
    return WATER_TEMPERATURES if medium == "water" else MC_PBS_TEMPERATURES


def check_temperature(temperature, medium: str | None = None) -> float | None:
    """``temperature`` in degC (a quantity such as "23degC", "23°C", "296.15K"; a bare number in degC; None stays
    None), refused in one line naming --temperature outside the range of the viscosity model of ``medium``
    (dclab's name), or, without a medium, outside the range of every medium dclab knows (0-40 degC): no file could
    be converted at it."""
    celsius = parse_temperature(temperature)
    if celsius is None:
        return None
    if medium is not None:
        (lo, hi), model = temperature_range(medium), f"dclab's {viscosity_model(medium)} viscosity of {medium}"
    else:
        ranges = (MC_PBS_TEMPERATURES, WATER_TEMPERATURES)
        lo, hi = min(r[0] for r in ranges), max(r[1] for r in ranges)
        model = "dclab's viscosity models (MC-PBS 22-37 degC, water 0-40 degC)"
    if not lo <= celsius <= hi:
        given = str(temperature).strip()
        shown = given if given in (f"{celsius:g}", str(celsius)) else f"{given} = {celsius:g} degC"
        raise ParameterError("temperature", f"must be within {lo:g}-{hi:g} degC, the range of {model}, got {shown}")
    return celsius


def check_tables(tables: list[str]) -> list[str]:
    """The tables as given (dclab's names, the identifiers of the tables elastocell ships, or paths of tables in
    dclab's text format), without repeats (a file named twice, however written, counts once, and so does a shipped
    table given by identifier and by path; the first order is kept), refused in one line when one is neither, or
    when two would be reported under one name (before any file is read). The shipped tables given by identifier
    are registered with dclab once every table is checked."""
    if not tables:
        raise ParameterError("lut", f"give at least one table: {', '.join(DCLAB_TABLES)}, the identifier of one "
                                    "elastocell ships, or a file")
    checked, seen, names, shipped = [], set(), {}, []
    for table in tables:
        text = str(table)
        source = text
        if text in DCLAB_TABLES:
            key = text
        elif is_named(text):  # a table elastocell ships: the same file as its path, if that is given too
            source = str(shipped_luts()[text]["path"])
            key = str(Path(source).resolve())
        else:
            path = Path(text)
            if not path.is_file():
                raise ParameterError("lut", f"{text!r} is neither one of dclab's tables ({', '.join(DCLAB_TABLES)}), "
                                            f"one elastocell ships ({', '.join(shipped_luts()) or 'none'}), nor a "
                                            "file")
            key = str(path.resolve())
        if key in seen:
            continue
        if text not in DCLAB_TABLES:
            try:
                data, meta = _dclab().features.emodulus.load.load_lut(source)
            except Exception as error:  # noqa: BLE001 - dclab raises several kinds for a malformed table
                raise ParameterError("lut", f"{text}: not a look-up table dclab can read ({error})") from None
            counted = own_metadata(meta).get("rows", {}).get("computed", len(data))
            if counted < 3:  # the rows interpolated between fewer points do not make a surface
                raise ParameterError("lut", f"{text}: {counted} computed point(s), at least 3 are needed to "
                                            "interpolate")
        name = table_name(text)
        if name in names:
            raise ParameterError("lut", f"{names[name]} and {text} would both be reported as {name!r}: rename one")
        seen.add(key)
        names[name] = text
        checked.append(text)
        if source != text:
            shipped.append(text)
    for identifier in shipped:  # registered with dclab, which then reads them by identifier, once all are checked
        try:
            register_lut(identifier)
        except ParameterError as error:
            raise ParameterError("lut", str(error).removeprefix(f"{error.parameter}: ")) from None
    return checked


def own_metadata(meta) -> dict:
    """What ``elastocell lut`` records of a table (its metadata's ``elastocell``; {} for other tables), with the
    point bookkeeping of the table a scaled one comes from (``scaled_from_points``: its points, rows, hull
    points) in place."""
    own = meta.get("elastocell") if isinstance(meta, dict) else None
    if not isinstance(own, dict):
        return {}
    return {**own, **own.get("scaled_from_points", {})}


@cache
def _shipped_identifiers() -> frozenset[str]:
    """The identifiers of the tables in the package (read once: the package's data do not change while it runs)."""
    return frozenset(shipped_luts())


def is_named(table: str) -> bool:
    """Whether ``table`` is a table's name rather than a path: one of dclab's tables, or the identifier of one
    elastocell ships (:func:`elastocell.inverse.shipped_luts.shipped_luts`; a file or folder of that name wins, as
    in dclab's ``get_lut_path``)."""
    return table in DCLAB_TABLES or (not Path(table).exists() and table in _shipped_identifiers())


def table_name(table: str) -> str:
    """The name a table is reported under: its name (dclab's, or a shipped table's identifier), or the file's name
    without ``.txt`` (a dotted name such as ``lut_0.04uLs`` kept whole)."""
    return table if is_named(table) else Path(table).name.removesuffix(".txt")


def table_caveats(table: str) -> tuple[str, str]:
    """(why the table's moduli are not trustworthy, what else to know), each "" when nothing, from the metadata
    ``elastocell lut`` writes (:func:`elastocell.inverse.lut.compute_lut`): a ``--quick`` table (2 x 2 grid run for
    one unit of time) or points that reached ``--duration`` before their state (``elastocell.not_stationary``)
    are not converged; points left out because they were read on the nodes' hull (``elastocell.outline_fallback``,
    deformation biased high) are said. dclab's own tables have neither."""
    if table in DCLAB_TABLES:
        return "", ""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, meta = _dclab().features.emodulus.load.load_lut(str(table))
    own = own_metadata(meta)
    if not own:
        return "", ""
    points = own.get("finished", own.get("points"))
    of = f" of {points}" if points is not None else ""
    caveats, notes = [], []
    if own.get("quick"):
        caveats.append("made with --quick, a 2 x 2 grid run for one unit of time: no point converged")
    if own.get("not_stationary"):
        caveats.append(f"{len(own['not_stationary'])}{of} points not stationary, they reached --duration first "
                       "(elastocell.not_stationary)")
    if own.get("outline_fallback"):
        notes.append(f"{len(own['outline_fallback'])}{of} points left out, read on the nodes' hull (their "
                     "deformation biased high; elastocell.outline_fallback): events only they would cover are outside "
                     "the table")
    if own.get("volume_drift"):
        notes.append(f"{len(own['volume_drift'])}{of} points whose cell drifted in volume, their shape swollen "
                     "(elastocell.volume_drift; made without --volume-correction projection)")
    return "; ".join(caveats), "; ".join(notes)


@dataclass(frozen=True)
class Conditions:
    """What a measurement's conversion needs: channel width (um), flow rate (uL/s), pixel size (um), the medium
    as dclab names it (or a Newtonian viscosity in mPa s), its temperature (degC), the viscosity model, and where
    the temperature came from ("setup:temperature", "temp" (each event's) or "--temperature")."""

    channel_width_um: float
    flow_rate_ul_s: float
    pixel_size_um: float
    medium: str | float
    temperature_c: float | np.ndarray | None  # an array: each event's own
    viscosity_model: str | None
    temperature_source: str | None = None

    def record(self) -> dict:
        per_event = isinstance(self.temperature_c, np.ndarray)
        return {"channel_width_um": self.channel_width_um, "flow_rate_ul_s": self.flow_rate_ul_s,
                "pixel_size_um": self.pixel_size_um, "medium": self.medium,
                "temperature_c": float(np.nanmean(self.temperature_c)) if per_event else self.temperature_c,
                "temperature_source": self.temperature_source or ("temp" if per_event else ""),
                "viscosity_model": self.viscosity_model}


class Unconvertible(ValueError):
    """A measurement whose conditions do not allow a conversion (the reason becomes the file's flag; ``label``
    the short reason of its events, as the figure and the summary name it)."""

    def __init__(self, message: str, label: str = "not convertible"):
        super().__init__(message)
        self.label = label


def conditions_of(config, medium: str | None = None, temperature: float | None = None,
                  event_temperature: np.ndarray | None = None) -> Conditions:
    """The :class:`Conditions` of a dataset's configuration (``dataset.config``). ``medium`` and ``temperature``
    (degC) stand in where the file records none (or a medium dclab does not know, such as "other"); a recorded
    value is kept. The temperature is, first found first, the file's ``setup:temperature``, each event's own
    (``event_temperature``: dclab's ``temp`` feature; ``temperature`` for the events whose ``temp`` is NaN, and for
    all of them when every one is), ``temperature``. Raises :class:`Unconvertible` with the
    reason when something is still missing."""
    setup, imaging = config["setup"], config["imaging"]
    region = setup.get("chip region", "channel")
    if region != "channel":
        raise Unconvertible(f"measured in the {region} (setup: chip region), not in the channel: a look-up table "
                            "converts channel measurements only", "not measured in the channel")
    missing = [key for key in ("channel width", "flow rate") if key not in setup]
    if "pixel size" not in imaging:
        missing.append("pixel size")
    if missing:
        raise Unconvertible(f"the file does not record its {', '.join(missing)}", "conditions not recorded")
    recorded = setup.get("medium")
    canonical = known_medium(recorded) or known_medium(medium)
    if canonical is None:
        if medium is not None:
            raise Unconvertible(f"medium {medium!r} is not one dclab knows the viscosity of (an MC-PBS buffer, "
                                "CellCarrier, CellCarrierB or water)", "medium unknown to dclab")
        raise Unconvertible(f"medium {recorded!r} is not one dclab knows the viscosity of (an MC-PBS buffer, "
                            "CellCarrier, CellCarrierB or water): give --medium", "medium unknown to dclab")
    if setup.get("temperature") is not None:
        value, source = float(setup["temperature"]), "setup:temperature"
    elif event_temperature is not None and np.isfinite(np.asarray(event_temperature, dtype=float)).any():
        value, source = np.asarray(event_temperature, dtype=float), "temp"  # each event's own (dclab's "temp")
        if temperature is not None and not np.isfinite(value).all():  # --temperature stands in where temp is NaN
            value, source = np.where(np.isfinite(value), value, float(temperature)), "temp (NaN: --temperature)"
    elif temperature is not None:
        value, source = float(temperature), "--temperature"
    else:
        raise Unconvertible("the file does not record its temperature, which sets the medium's viscosity: give "
                            "--temperature", "no temperature")
    return Conditions(float(setup["channel width"]), float(setup["flow rate"]), float(imaging["pixel size"]),
                      canonical, value, viscosity_model(canonical), source)


def temperature_valid(conditions: Conditions, events: int) -> np.ndarray:
    """Which of ``events`` events have a temperature inside the range of the medium's viscosity model
    (:func:`temperature_range`; a Newtonian viscosity given as a number: all)."""
    if not isinstance(conditions.medium, str) or conditions.temperature_c is None:
        return np.ones(events, dtype=bool)
    lo, hi = temperature_range(conditions.medium)
    temperature = np.broadcast_to(np.asarray(conditions.temperature_c, dtype=float), (events,))
    with np.errstate(invalid="ignore"):
        return np.isfinite(temperature) & (temperature >= lo) & (temperature <= hi)


def temperature_reason(conditions: Conditions, temperature) -> str:
    """Why an event at ``temperature`` (degC, NaN: none recorded) of ``conditions`` is not converted."""
    source = conditions.temperature_source or "temperature"
    if not np.isfinite(temperature):
        return f"no temperature recorded for this event ({source} is NaN)"
    lo, hi = temperature_range(conditions.medium)
    return (f"temperature {temperature:.4g} degC ({source}) outside {lo:g}-{hi:g} degC, the range of dclab's "
            f"{conditions.viscosity_model} viscosity of {conditions.medium}: the viscosity, and so E, would be "
            "extrapolated")


def emodulus_of_events(area_um: np.ndarray, deform: np.ndarray, conditions: Conditions, table: str
                       ) -> tuple[np.ndarray, list[str]]:
    """E (Pa) of every event through ``table`` at ``conditions`` (NaN outside the table, and NaN for an event whose
    temperature is outside the range of the medium's viscosity model, :func:`temperature_valid`: dclab would
    extrapolate the viscosity), and the warnings dclab gave."""
    from dclab.features.emodulus import get_emodulus  # lazy: optional dependency (see _dclab)

    area_um, deform = np.atleast_1d(np.asarray(area_um, dtype=float)), np.atleast_1d(np.asarray(deform, dtype=float))
    valid = temperature_valid(conditions, len(deform))
    emodulus_pa = np.full(len(deform), np.nan)
    if not valid.any():
        return emodulus_pa, []
    temperature = conditions.temperature_c
    if isinstance(temperature, np.ndarray):
        temperature = np.broadcast_to(temperature, valid.shape)[valid]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        emodulus_kpa = get_emodulus(deform=deform[valid], area_um=area_um[valid],
                                    medium=conditions.medium, channel_width=conditions.channel_width_um,
                                    flow_rate=conditions.flow_rate_ul_s, px_um=conditions.pixel_size_um,
                                    temperature=temperature, lut_data=table,
                                    visc_model=conditions.viscosity_model, extrapolate=False)
    emodulus_pa[valid] = 1e3 * np.asarray(emodulus_kpa, dtype=float)
    notes = sorted({str(w.message).splitlines()[0] for w in caught})
    return emodulus_pa, notes


def _read(path: Path):
    dclab = _dclab()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # dclab's warnings about unknown configuration keys of older files
        dataset = dclab.new_dataset(str(path))
        missing = [name for name in ("area_um", "deform") if name not in dataset]
        if missing:
            raise ValueError(f"no {' and no '.join(missing)} feature")
        return dataset, np.asarray(dataset["area_um"], dtype=float), np.asarray(dataset["deform"], dtype=float)


def expand_files(files: list[Path]) -> list[Path]:
    """The files as given, a folder contributing the ``.rtdc`` files in it and its sub-folders (sorted), each file
    once (a file given twice, or given and inside a folder given, however the paths are written: the first
    occurrence is kept, in order); a path that does not exist is refused in one line."""
    expanded, seen = [], set()
    for path in map(Path, files):
        if path.is_dir():
            found = sorted(p for p in path.rglob("*.rtdc") if p.is_file())
        elif path.exists():
            found = [path]
        else:
            raise ParameterError("files", f"{path} does not exist")
        for file in found:
            key = file.resolve()
            if key not in seen:
                seen.add(key)
                expanded.append(file)
    if not expanded:
        raise ParameterError("files", "no .rtdc file found")
    return expanded


def fit_rtdc(files: list[Path], lut: list[str] | str = ("LE-2D-FEM-19",), out: Path = Path("fits"),
             medium: str | None = None, temperature: float | str | None = None, plots: bool = True,
             tables: list[str] | None = None) -> dict:
    """Young's modulus of every event of every file through every table: ``lut`` as ``elastocell fit rtdc
    --lut`` (dclab's names, the identifiers of the tables elastocell ships, or files in dclab's format; one name or
    a list; ``tables`` is an older name of it).
    ``medium`` (any of dclab's names, case
    and blanks ignored: :func:`known_medium`) and ``temperature`` (a quantity such as "23degC", "23°C" or
    "296.15K"; a bare number in degC) stand in where a file records none; both are refused in one line (before
    any file is read) when dclab knows no viscosity for them (:func:`check_medium`, :func:`check_temperature`).
    A file counts once, however often given; so does a table.

    Writes ``out/rtdc_fits.csv`` (one row per event and table: ``file, event, area_um, deform, lut,
    youngs_modulus`` in Pa, NaN when not converted, ``flag``: empty when converted through a converged table,
    else why not (outside the table, no temperature, a temperature outside the viscosity model's range, ...) or,
    for a modulus through a table that is not converged (:func:`table_caveats`), why it is not trustworthy, and
    ``path``: the file as found, since instruments give many files one name),
    ``out/rtdc_coverage.csv`` (one row per file and table: events, converted, trusted (converted through a
    converged table), coverage, the median and quartiles of E, ``not_converted`` (the count of each reason), the
    conditions used, ``lut_caveat`` (why the table is not trustworthy), ``lut_notes``, dclab's warnings, the file's
    flag) and ``out/fit_settings.json`` (with the ``warnings``); with ``plots`` ``out/rtdc_events.png`` (every
    event on the area-deformation plane, per table, each not converted by its reason). A file that cannot be read
    or converted is a row with its reason; the others go on. Returns the rows, the counts (``totals``: {table:
    (converted, events)}, ``trusted``: {table: converted through it when it is converged, else 0}), the
    ``caveats`` ({table: why not trustworthy}), the ``warnings`` (one line each) and ``reasons`` ({label: events,
    each counted once, that no table converted for it; ``unreadable files``: files}).
    """
    import pandas as pd

    if tables is not None:
        lut = tables
    tables = check_tables([lut] if isinstance(lut, (str, Path)) else list(lut))
    medium = check_medium(medium)
    temperature = check_temperature(temperature, medium)
    files = expand_files(files)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    caveats, notes_of = {}, {}
    messages = []
    for table in tables:
        caveats[table], notes_of[table] = table_caveats(table)
        if caveats[table]:
            messages.append(f"table {table_name(table)} is not converged: {caveats[table]}; its moduli are not "
                            "trustworthy (flagged in rtdc_fits.csv)")
        if notes_of[table]:
            messages.append(f"table {table_name(table)}: {notes_of[table]}")
    events, coverage = [], []
    for path in files:
        try:
            dataset, area_um, deform = _read(path)
        except Exception as error:  # noqa: BLE001 - any reader failure becomes the file's flag
            coverage += [{"file": path.name, "path": str(path), "lut": table_name(t), "events": 0, "converted": 0,
                          "trusted": 0, "flag": f"unreadable: {error}".splitlines()[0]} for t in tables]
            continue
        try:
            conditions = conditions_of(dataset.config, medium, temperature,
                                       np.asarray(dataset["temp"]) if "temp" in dataset else None)
        except Unconvertible as reason:
            conditions, flag, label = None, str(reason), reason.label
        if conditions is not None:
            valid, temperature_flags, temperature_labels, temperature_flag, message = _temperature_check(
                conditions, len(deform))
            if message:
                messages.append(f"{path.name}: {message}")
        for table in tables:
            name = table_name(table)
            flags = np.full(len(deform), "", dtype=object)
            labels = np.full(len(deform), "converted", dtype=object)
            notes = []
            if conditions is None:
                values, row_flag = np.full(len(deform), np.nan), flag
                flags[:], labels[:] = flag, label
            else:
                values, notes = emodulus_of_events(area_um, deform, conditions, table)
                row_flag = temperature_flag
                outside = valid & ~np.isfinite(values)
                flags[outside], labels[outside] = OUTSIDE, OUTSIDE
                flags[~valid], labels[~valid] = temperature_flags, temperature_labels
            converted = np.isfinite(values)
            if caveats[table]:
                flags[converted] = f"not trustworthy: the table is not converged, {caveats[table]}"
                labels[converted] = UNTRUSTED
            events.append(pd.DataFrame({"file": path.name, "path": str(path), "event": np.arange(len(deform)),
                                        "area_um": area_um,
                                        "deform": deform, "lut": name, "youngs_modulus": values,
                                        "flag": flags, "reason": labels}))
            missed = pd.Series(labels[~converted]).value_counts()
            summary = {"file": path.name, "path": str(path), "lut": name, "events": int(len(deform)),
                       "converted": int(converted.sum()),
                       "trusted": 0 if caveats[table] else int(converted.sum()),
                       "coverage": float(converted.mean()) if len(deform) else float("nan"), "flag": row_flag,
                       "not_converted": "; ".join(f"{count} {reason}" for reason, count in missed.items()),
                       "lut_caveat": caveats[table], "lut_notes": notes_of[table],
                       "dclab_warnings": "; ".join(notes)}
            if converted.any():
                q1, median, q3 = np.percentile(values[converted], [25, 50, 75])
                summary.update(youngs_modulus_median=median, youngs_modulus_q1=q1, youngs_modulus_q3=q3)
            if conditions is not None:
                summary.update(conditions.record())
            coverage.append(summary)
    columns = ["file", "event", "area_um", "deform", "lut", "youngs_modulus", "flag", "path"]
    frame = pd.concat(events, ignore_index=True) if events else pd.DataFrame(columns=[*columns, "reason"])
    replace_atomically(out / "rtdc_fits.csv",
                       lambda temporary: frame[columns].to_csv(temporary, index=False, float_format="%.8g"))
    summary = pd.DataFrame(coverage)
    replace_atomically(out / "rtdc_coverage.csv",
                       lambda temporary: summary.to_csv(temporary, index=False, float_format="%.8g"))
    write_json(out / "fit_settings.json", {
        "tables": tables, "files": [str(p) for p in files], "medium": medium, "temperature_c": temperature,
        "table_caveats": {table_name(t): caveats[t] for t in tables},
        "method": "dclab.features.emodulus.get_emodulus (viscosity scaling, pixelation correction, no "
                  "extrapolation outside the table, none outside the viscosity model's temperature range)",
        "units": {"area_um": "um^2", "deform": "1", "youngs_modulus": "Pa", "channel_width_um": "um",
                  "flow_rate_ul_s": "uL/s", "pixel_size_um": "um", "temperature_c": "degC"},
        "warnings": messages, "versions": software_versions()})
    if plots and len(frame):
        _plot(frame, out / "rtdc_events.png")

    def total(table, column):
        return int(summary.loc[summary["lut"] == table_name(table), column].sum())

    totals = {table_name(t): (total(t, "converted"), total(t, "events")) for t in tables}
    trusted = {table_name(t): total(t, "trusted") for t in tables}
    reasons = {}
    if len(frame):
        events_of = frame.groupby(["path", "event"])["reason"]
        missed = events_of.agg(lambda r: "converted" if (r == "converted").any() else
                               (r[r != OUTSIDE].iloc[0] if (r != OUTSIDE).any() else OUTSIDE))
        reasons = {label: int(count) for label, count in missed[missed != "converted"].value_counts().items()}
    unreadable = len({row["path"] for row in coverage if str(row.get("flag", "")).startswith("unreadable")})
    if unreadable:
        reasons["unreadable files"] = unreadable
    return {"events": frame, "coverage": summary, "totals": totals, "trusted": trusted,
            "caveats": {table_name(t): caveats[t] for t in tables}, "warnings": messages, "reasons": reasons,
            "files": files, "tables": tables}


def _temperature_check(conditions: Conditions, events: int) -> tuple[np.ndarray, list, list, str, str]:
    """(which events have a temperature in the viscosity model's range, the flag and the label of each other
    event, the file's flag when none has, the console's line when some have not ("" when all have))."""
    valid = temperature_valid(conditions, events)
    if valid.all():
        return valid, [], [], "", ""
    temperatures = np.broadcast_to(np.asarray(conditions.temperature_c, dtype=float), valid.shape)
    flags = [temperature_reason(conditions, t) for t in temperatures[~valid]]
    labels = ["no temperature for the event" if not np.isfinite(t) else OUT_OF_RANGE for t in temperatures[~valid]]
    if np.ndim(conditions.temperature_c) == 0:
        return valid, flags, labels, flags[0], f"not converted: {flags[0]}"
    lo, hi = temperature_range(conditions.medium)
    outside = temperatures[~valid][np.isfinite(temperatures[~valid])]
    parts = [f"{len(outside)} at {outside.min():.4g} to {outside.max():.4g} degC, outside {lo:g}-{hi:g} degC, the "
             f"range of dclab's {conditions.viscosity_model} viscosity of {conditions.medium}"] if len(outside) else []
    if len(outside) < (~valid).sum():
        parts.append(f"{int((~valid).sum()) - len(outside)} without a temperature (NaN)")
    message = (f"{int((~valid).sum())} of {events} events not converted for their temperature "
               f"({conditions.temperature_source}): {'; '.join(parts)}")
    return valid, flags, labels, (message if not valid.any() else ""), message


PLOT_STYLE = {OUTSIDE: ("0.6", "o"), "no temperature": ("tab:red", "v"),
              "no temperature for the event": ("tab:red", "1"), OUT_OF_RANGE: ("tab:orange", "^"),
              "medium unknown to dclab": ("tab:purple", "s"), "not measured in the channel": ("tab:brown", "D"),
              "conditions not recorded": ("tab:pink", "P")}
"""Colour and marker of the events not converted, by reason (others: black x)."""


def _plot(frame, path: Path) -> None:
    import matplotlib  # lazy: plotting only when asked

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(frame["lut"]))
    figure, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.6), squeeze=False, sharey=True)
    for axis, name in zip(axes[0], names, strict=True):
        part = frame[frame["lut"] == name]
        inside = np.isfinite(part["youngs_modulus"].to_numpy())
        reasons = part["reason"].to_numpy()
        for reason in dict.fromkeys(reasons[~inside]):
            chosen = reasons == reason
            colour, marker = PLOT_STYLE.get(reason, ("k", "x"))
            axis.scatter(part["area_um"][chosen], part["deform"][chosen], s=10, c=colour, marker=marker,
                         label=f"{reason} ({chosen.sum()})")
        untrusted = (reasons == UNTRUSTED)[inside]
        points = axis.scatter(part["area_um"][inside], part["deform"][inside], s=12,
                              c=part["youngs_modulus"][inside] / 1e3, cmap="viridis",
                              marker="^" if untrusted.any() else "o",
                              label=f"{UNTRUSTED if untrusted.any() else 'converted'} ({inside.sum()})")
        if inside.any():
            figure.colorbar(points, ax=axis, label="E (kPa)")
        axis.set_title(f"{name}: {inside.sum()} of {len(part)} events"
                       + (" (not trustworthy)" if untrusted.any() else ""))
        axis.set_xlabel("area (um$^2$)")
        axis.legend(fontsize=6, loc="best")
    axes[0][0].set_ylabel("deformation")
    figure.tight_layout()
    save_figure(figure, path)
    plt.close(figure)
