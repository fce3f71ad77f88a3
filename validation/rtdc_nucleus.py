"""The rtdc-nucleus study's result: which modulus a homogeneous RT-DC table assigns a cell with a stiff nucleus.

    nice python validation/rtdc_nucleus.py --dir results/rtdc-nucleus

reads the finished runs of ``elastocell study run rtdc-nucleus --out DIR`` (``DIR/runs/<run_id>/run.json``;
nothing is computed: runs not finished yet are listed as missing), builds the study's table and claims from
them (:mod:`elastocell.studies.rtdc_nucleus`, the same functions as the study) and writes the section into
docs/validation/rtdc_nucleus.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

try:
    import elastocell  # noqa: F401
except ImportError:  # a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page

from elastocell.studies.base import RUN_FILE
from elastocell.studies.rtdc_nucleus import (
    CAPILLARY_NUMBER_WALL,
    CHANNEL_RADIUS_RATIO,
    CHANNEL_WIDTH_UM,
    CYTOPLASM_KPA,
    FLOW_RATE_UL_S,
    FULL_SETTINGS,
    RADIUS_UM,
    STUDY,
    TABLE,
    VISCOSITY_MPA_S,
)

COLUMNS = {"cell": "cell", "stop": "stop (t)", "deformation": "D", "area_um": "area_um", "e_eff_over_ec": "E_eff/E_c",
           "e_rtdc_over_ec": "E_RTDC/E_c", "e_rtdc_over_eeff": "E_RTDC/E_eff",
           "position_ec_to_eeff": "(E_RTDC-E_c)/(E_eff-E_c)",
           "e_rtdc_mesh_corrected_over_ec": "E_RTDC,mesh/E_c", "e_fit_over_ec": "E_fit/E_c",
           "e_rtdc_dclab_over_ec": "E_dclab/E_c", "e_rtdc_dclab_over_eeff": "E_dclab/E_eff",
           "volume_change_max_abs": "max |dV/V|", "wall_time_s": "wall (s)"}


def finished_pairs(directory: Path, quick: bool):
    """(member, record) of every member whose run is finished in ``directory/runs``; the members missing."""
    pairs, missing = [], []
    for member in STUDY.members(quick):
        path = directory / "runs" / member.run.run_id / RUN_FILE
        if path.exists():
            pairs.append((member, json.loads(path.read_text())))
        else:
            missing.append(member)
    return pairs, missing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", type=Path, required=True, help="results directory of `elastocell study run`")
    parser.add_argument("--quick", action="store_true", help="the study's --quick members")
    args = parser.parse_args()
    settings = "quick settings (R/dx 5, 4 units of 1/gdot_w)" if args.quick else (
        f"R/dx {FULL_SETTINGS['resolution']:g} (one resolution: the homogeneous reading cells share it, so the "
        f"discretisation error largely cancels in E_RTDC), each run until its mean deformation over a unit of "
        f"1/gdot_w changed by less than {FULL_SETTINGS['stationary_tolerance']:g} or at "
        f"{FULL_SETTINGS['duration']:g} units of 1/gdot_w")
    page = Page("rtdc_nucleus", "rtdc_nucleus.py", intro=(
        f"Cells of radius R = {RADIUS_UM:g} um with a centred nucleus (gamma = E_n/E_c, lambda = R_n/R) and the "
        f"random cell, cytoplasm E_c = {CYTOPLASM_KPA:g} kPa (neo-Hookean, nu = 0.48), centred in the cylinder "
        f"of {TABLE} (R_ch = 1.094 x {CHANNEL_WIDTH_UM / 2:g} um, R_ch/R = {CHANNEL_RADIUS_RATIO:.4f}), "
        f"Q = {FLOW_RATE_UL_S:g} uL/s, eta = {VISCOSITY_MPA_S:g} mPa s: Ca_w = G R_ch/(2 mu_c) = "
        f"{CAPILLARY_NUMBER_WALL:.4f} for every cell (one pressure gradient), {settings}. D and area_um are means "
        "over the last unit of 1/gdot_w. E_RTDC: the modulus of the homogeneous cell with the same deformation at "
        "the same radius, from homogeneous runs at the same settings (log-log interpolation; NaN outside them). "
        f"E_dclab: {TABLE} at the cell's (area_um, deform) through `dclab.features.emodulus.get_emodulus`, "
        "converted to nu = 0.48 at equal shear modulus (NaN: outside the table). E_eff = gamma_eff E_c, the "
        "volume average of the meshed cell; E_fit: the homogeneous modulus closest to the whole stationary shape "
        "(D, eps_x - 1, eps_r - 1) in log. `stop`: `stationary` or the duration cap (`cap`: a transient mean, "
        "not a stationary shape). E_RTDC,mesh: E_RTDC read from the deformation times D(homogeneous mesh, E_c)/D(the "
        "gamma 1 control on the cell's nucleus mesh), the mesh's own error divided out."))
    pairs, missing = finished_pairs(args.dir, args.quick)
    frame = STUDY.table(pairs, args.dir, args.quick) if pairs else None
    if frame is not None:
        frame = frame.copy()
        durations = [json.loads((args.dir / d / "summary.json").read_text()).get("duration")
                     if (args.dir / d / "summary.json").exists() else np.nan for d in frame["run_directory"]]
        frame["stop"] = [f"{'stationary' if s else 'cap'} ({t:.1f})" for s, t in
                         zip(frame["stationary"], durations, strict=True)]
        for kind, heading in (("nucleus", "Nucleus cells"), ("random", "Random cell"),
                              ("mesh control", "Mesh controls: the nucleus mesh with gamma = 1 (what the mesh alone "
                               "does to D; read as a cell)"),
                              ("homogeneous", "Homogeneous reading cells (E/E_c in the name)")):
            rows = frame[frame["kind"] == kind]
            page.table([{label: row[column] for column, label in COLUMNS.items()} for _, row in rows.iterrows()],
                       heading, formats={label: ".4g" for label in COLUMNS.values() if label not in ("cell", "stop (t)")})
        page.heading("Claims (elastocell.studies.rtdc_nucleus, from the rows above)")
        for claim in STUDY.claims(frame):
            page.print(f"[{claim.verdict}] {claim.claim}\n    {claim.measured}\n    criterion: {claim.criterion}")
    if missing:
        page.print("Not finished (no run.json in the results directory): "
                   + ", ".join(m.labels["cell"] for m in missing))
    page.write()


if __name__ == "__main__":
    main()
