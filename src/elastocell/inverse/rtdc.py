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
be converted.

dclab is needed here (``pip install dclab``); it is imported only when a file is read.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from elastocell.files import replace_atomically, save_figure, software_versions, write_json
from elastocell.parameters.units import ParameterError, parse_temperature

DCLAB_TABLES = ("LE-2D-FEM-19", "HE-2D-FEM-22", "HE-3D-FEM-22")
"""The look-up tables dclab ships: linear elastic axisymmetric (Mokbel et al. 2017), neo-Hookean axisymmetric
and 3D square channel in a shear-thinning medium (Wittwer et al. 2022)."""

MC_PBS_VISCOSITY_MODEL = "buyukurganci-2022"
"""dclab's viscosity model for the MC-PBS media (power law in the channel's wall shear rate, with temperature)."""

WATER_VISCOSITY_MODEL = "kestin-1978"


def _dclab():
    try:
        import dclab  # lazy: an optional dependency, needed only to read .rtdc files
    except ImportError:  # pragma: no cover - dclab is installed with the test extra
        raise ParameterError("files", "reading .rtdc files needs dclab: pip install dclab") from None
    return dclab


def check_tables(tables: list[str]) -> list[str]:
    """The tables as given (dclab's names, or paths of tables in dclab's text format), refused in one line when
    one is neither (before any file is read)."""
    if not tables:
        raise ParameterError("lut", f"give at least one table: {', '.join(DCLAB_TABLES)} or a file")
    checked = []
    for table in tables:
        text = str(table)
        if text in DCLAB_TABLES:
            checked.append(text)
            continue
        path = Path(text)
        if not path.is_file():
            raise ParameterError("lut", f"{text!r} is neither one of dclab's tables ({', '.join(DCLAB_TABLES)}) "
                                        "nor a file")
        try:
            data, meta = _dclab().features.emodulus.load.load_lut(str(path))
        except Exception as error:  # noqa: BLE001 - dclab raises several kinds for a malformed table
            raise ParameterError("lut", f"{text}: not a look-up table dclab can read ({error})") from None
        if len(data) < 3:
            raise ParameterError("lut", f"{text}: {len(data)} point(s), at least 3 are needed to interpolate")
        checked.append(str(path))
    return checked


def table_name(table: str) -> str:
    """The name a table is reported under: dclab's name, or the file's stem."""
    return table if table in DCLAB_TABLES else Path(table).stem


@dataclass(frozen=True)
class Conditions:
    """What a measurement's conversion needs: channel width (um), flow rate (uL/s), pixel size (um), the medium
    as dclab names it (or a Newtonian viscosity in mPa s), its temperature (degC) and the viscosity model."""

    channel_width_um: float
    flow_rate_ul_s: float
    pixel_size_um: float
    medium: str | float
    temperature_c: float | np.ndarray | None  # an array: each event's own
    viscosity_model: str | None

    def record(self) -> dict:
        per_event = isinstance(self.temperature_c, np.ndarray)
        return {"channel_width_um": self.channel_width_um, "flow_rate_ul_s": self.flow_rate_ul_s,
                "pixel_size_um": self.pixel_size_um, "medium": self.medium,
                "temperature_c": float(np.nanmean(self.temperature_c)) if per_event else self.temperature_c,
                "temperature_source": "each event's (temp)" if per_event else "file or --temperature",
                "viscosity_model": self.viscosity_model}


class Unconvertible(ValueError):
    """A measurement whose conditions do not allow a conversion (the reason becomes the file's flag)."""


def conditions_of(config, medium: str | None = None, temperature: float | None = None,
                  event_temperature: np.ndarray | None = None) -> Conditions:
    """The :class:`Conditions` of a dataset's configuration (``dataset.config``). ``medium`` and ``temperature``
    stand in where the file records none (or a medium dclab does not know, such as "other"); a recorded value is
    kept. Raises :class:`Unconvertible` with the reason when something is still missing."""
    from dclab.features.emodulus.viscosity import ALIAS_MEDIA  # lazy: optional dependency (see _dclab)

    def known(name) -> str | None:
        if name is None:
            return None
        spaced = re.sub(r"%\s*", "% ", str(name))
        for candidate in (str(name), spaced, spaced.lower()):
            if candidate in ALIAS_MEDIA:
                return ALIAS_MEDIA[candidate]
        return None

    setup, imaging = config["setup"], config["imaging"]
    region = setup.get("chip region", "channel")
    if region != "channel":
        raise Unconvertible(f"measured in the {region} (setup: chip region), not in the channel: a look-up table "
                            "converts channel measurements only")
    missing = [key for key in ("channel width", "flow rate") if key not in setup]
    if "pixel size" not in imaging:
        missing.append("pixel size")
    if missing:
        raise Unconvertible(f"the file does not record its {', '.join(missing)}")
    recorded = setup.get("medium")
    canonical = known(recorded) or known(medium)
    if canonical is None:
        if medium is not None:
            raise Unconvertible(f"medium {medium!r} is not one dclab knows the viscosity of (an MC-PBS buffer, "
                                "CellCarrier, CellCarrierB or water)")
        raise Unconvertible(f"medium {recorded!r} is not one dclab knows the viscosity of (an MC-PBS buffer, "
                            "CellCarrier, CellCarrierB or water): give --medium")
    value = setup.get("temperature", temperature)
    if value is None and event_temperature is not None:
        value = np.asarray(event_temperature, dtype=float)  # each event's own (dclab's "temp" feature)
    if value is None:
        raise Unconvertible("the file does not record its temperature, which sets the medium's viscosity: give "
                            "--temperature")
    model = WATER_VISCOSITY_MODEL if canonical == "water" else MC_PBS_VISCOSITY_MODEL
    return Conditions(float(setup["channel width"]), float(setup["flow rate"]), float(imaging["pixel size"]),
                      canonical, value if isinstance(value, np.ndarray) else float(value), model)


def emodulus_of_events(area_um: np.ndarray, deform: np.ndarray, conditions: Conditions, table: str
                       ) -> tuple[np.ndarray, list[str]]:
    """E (Pa) of every event through ``table`` at ``conditions`` (NaN outside the table), and the warnings dclab
    gave (e.g. a temperature outside the viscosity model's range)."""
    from dclab.features.emodulus import get_emodulus  # lazy: optional dependency (see _dclab)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        emodulus_kpa = get_emodulus(deform=np.asarray(deform, dtype=float), area_um=np.asarray(area_um, dtype=float),
                                    medium=conditions.medium, channel_width=conditions.channel_width_um,
                                    flow_rate=conditions.flow_rate_ul_s, px_um=conditions.pixel_size_um,
                                    temperature=conditions.temperature_c, lut_data=table,
                                    visc_model=conditions.viscosity_model, extrapolate=False)
    notes = sorted({str(w.message).splitlines()[0] for w in caught})
    return 1e3 * np.asarray(emodulus_kpa, dtype=float), notes


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
    """The files as given, a folder contributing the ``.rtdc`` files in it and its sub-folders (sorted); a path
    that does not exist is refused in one line."""
    expanded = []
    for path in map(Path, files):
        if path.is_dir():
            expanded += sorted(p for p in path.rglob("*.rtdc") if p.is_file())
        elif path.exists():
            expanded.append(path)
        else:
            raise ParameterError("files", f"{path} does not exist")
    if not expanded:
        raise ParameterError("files", "no .rtdc file found")
    return expanded


def fit_rtdc(files: list[Path], tables: list[str], out: Path, medium: str | None = None,
             temperature: float | str | None = None, plots: bool = True) -> dict:
    """Young's modulus of every event of every file through every table. ``medium`` and ``temperature`` (a
    quantity such as "23degC", "23°C" or "296.15K"; a bare number in degC) stand in where a file records none.

    Writes ``out/rtdc_fits.csv`` (one row per event and table: ``file, event, area_um, deform, lut,
    youngs_modulus`` in Pa, NaN outside the table, ``flag``: empty when converted, else why not, and ``path``: the
    file as found, since instruments give many files one name),
    ``out/rtdc_coverage.csv`` (one row per file and table: events, converted, coverage, the median and quartiles
    of E, the conditions used, dclab's warnings, the file's flag) and ``out/fit_settings.json``; with ``plots``
    ``out/rtdc_events.png`` (every event on the area-deformation plane, converted or not, per table). A file that
    cannot be read or converted is a row with its reason; the others go on. Returns the rows and counts.
    """
    import pandas as pd

    tables = check_tables(list(tables))
    temperature = parse_temperature(temperature)
    files = expand_files(files)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    events, coverage = [], []
    for path in files:
        try:
            dataset, area_um, deform = _read(path)
        except Exception as error:  # noqa: BLE001 - any reader failure becomes the file's flag
            coverage += [{"file": path.name, "path": str(path), "lut": table_name(t), "events": 0, "converted": 0,
                          "flag": f"unreadable: {error}".splitlines()[0]} for t in tables]
            continue
        try:
            conditions = conditions_of(dataset.config, medium, temperature,
                                       np.asarray(dataset["temp"]) if "temp" in dataset else None)
        except Unconvertible as reason:
            conditions, flag = None, str(reason)
        for table in tables:
            name = table_name(table)
            if conditions is None:
                values, notes, row_flag = np.full(len(deform), np.nan), [], flag
            else:
                values, notes = emodulus_of_events(area_um, deform, conditions, table)
                row_flag = ""
            converted = np.isfinite(values)
            events.append(pd.DataFrame({"file": path.name, "path": str(path), "event": np.arange(len(deform)),
                                        "area_um": area_um,
                                        "deform": deform, "lut": name, "youngs_modulus": values,
                                        "flag": np.where(converted, "", row_flag or "outside the table")}))
            summary = {"file": path.name, "path": str(path), "lut": name, "events": int(len(deform)),
                       "converted": int(converted.sum()),
                       "coverage": float(converted.mean()) if len(deform) else float("nan"), "flag": row_flag,
                       "dclab_warnings": "; ".join(notes)}
            if converted.any():
                q1, median, q3 = np.percentile(values[converted], [25, 50, 75])
                summary.update(youngs_modulus_median=median, youngs_modulus_q1=q1, youngs_modulus_q3=q3)
            if conditions is not None:
                summary.update(conditions.record())
            coverage.append(summary)
    columns = ["file", "event", "area_um", "deform", "lut", "youngs_modulus", "flag", "path"]
    frame = pd.concat(events, ignore_index=True) if events else pd.DataFrame(columns=columns)
    replace_atomically(out / "rtdc_fits.csv",
                       lambda temporary: frame[columns].to_csv(temporary, index=False, float_format="%.8g"))
    summary = pd.DataFrame(coverage)
    replace_atomically(out / "rtdc_coverage.csv",
                       lambda temporary: summary.to_csv(temporary, index=False, float_format="%.8g"))
    write_json(out / "fit_settings.json", {
        "tables": tables, "files": [str(p) for p in files], "medium": medium, "temperature_c": temperature,
        "method": "dclab.features.emodulus.get_emodulus (viscosity scaling, pixelation correction, no "
                  "extrapolation outside the table)",
        "units": {"area_um": "um^2", "deform": "1", "youngs_modulus": "Pa", "channel_width_um": "um",
                  "flow_rate_ul_s": "uL/s", "pixel_size_um": "um", "temperature_c": "degC"},
        "versions": software_versions()})
    if plots and len(frame):
        _plot(frame, out / "rtdc_events.png")
    totals = {table_name(t): (int(summary.loc[summary["lut"] == table_name(t), "converted"].sum()),
                              int(summary.loc[summary["lut"] == table_name(t), "events"].sum())) for t in tables}
    return {"events": frame, "coverage": summary, "totals": totals, "files": files, "tables": tables}


def _plot(frame, path: Path) -> None:
    import matplotlib  # lazy: plotting only when asked

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(frame["lut"]))
    figure, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.6), squeeze=False, sharey=True)
    for axis, name in zip(axes[0], names, strict=True):
        part = frame[frame["lut"] == name]
        inside = np.isfinite(part["youngs_modulus"].to_numpy())
        axis.scatter(part["area_um"][~inside], part["deform"][~inside], s=10, c="0.6", label="outside the table")
        points = axis.scatter(part["area_um"][inside], part["deform"][inside], s=12,
                              c=part["youngs_modulus"][inside] / 1e3, cmap="viridis", label="converted")
        if inside.any():
            figure.colorbar(points, ax=axis, label="E (kPa)")
        axis.set_title(f"{name}: {inside.sum()} of {len(part)} events")
        axis.set_xlabel("area (um$^2$)")
        axis.legend(fontsize=7, loc="upper left")
    axes[0][0].set_ylabel("deformation")
    figure.tight_layout()
    save_figure(figure, path)
    plt.close(figure)
