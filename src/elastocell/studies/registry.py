"""The registry of studies: every study by name, and the claims a results directory holds."""

from __future__ import annotations

import json
from pathlib import Path

from elastocell.parameters.units import ParameterError
from elastocell.studies.base import Claim, Study
from elastocell.studies.cell_models import STUDY as CELL_MODELS
from elastocell.studies.compression import STUDIES as COMPRESSION_STUDIES
from elastocell.studies.equivalent_modulus import STUDY as EQUIVALENT_MODULUS
from elastocell.studies.flow import STUDIES as FLOW_STUDIES
from elastocell.studies.rtdc_nucleus import STUDY as RTDC_NUCLEUS

STUDIES: dict[str, Study] = {s.name: s for s in [CELL_MODELS, *COMPRESSION_STUDIES, *FLOW_STUDIES,
                                                EQUIVALENT_MODULUS, RTDC_NUCLEUS]}


def study_names() -> list[str]:
    return list(STUDIES)


def get_study(name: str) -> Study:
    if name not in STUDIES:
        raise ParameterError("name", f"unknown study {name!r}; one of: {', '.join(STUDIES)}")
    return STUDIES[name]


def load_claims(directory) -> list[Claim]:
    """Every claim recorded in ``directory``, in the order of the studies."""
    directory = Path(directory)
    claims = []
    for name in STUDIES:
        path = directory / f"{name}.claims.json"
        if path.exists():
            claims += [Claim(**c) for c in json.loads(path.read_text())["claims"]]
    return claims
