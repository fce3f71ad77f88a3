"""Studies: registry contract, shared runs, claim verdicts on constructed tables, and one tiny study end to end
through a one-worker Dask cluster (tables, figure, report, resume)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from elastocell.cli.app import app
from elastocell.studies import STUDIES, get_study, load_claims, plot_study, run_studies
from elastocell.studies.base import Member, Run, Study, read_study_table
from elastocell.studies.cell_models import cross_section
from elastocell.studies.compression import (
    claims_normalised,
    claims_stiffness,
    plot_stiffness,
    size_peak,
    tidy,
)
from elastocell.studies.flow import claims_pipe

ISSUE_NAMES = ["cell-models", "compression-stiffness", "compression-normalised", "compression-position-shape",
               "compression-mooney-rivlin", "shear-capillary", "shear-offset", "pipe-centred", "equivalent-modulus",
               "rtdc-nucleus"]


def test_every_study_of_the_issue_is_registered_and_listed():
    assert list(STUDIES) == ISSUE_NAMES
    result = CliRunner().invoke(app, ["study", "list"])
    assert result.exit_code == 0
    assert [line.split()[0] for line in result.output.strip().splitlines()] == ISSUE_NAMES


def test_shared_runs_have_one_identity():
    """The reference cell of four figures is one run (computed once by `reproduce`)."""
    ids = {name: {m.run.run_id for m in get_study(name).members(False)} for name in STUDIES}
    reference = Run.of("compress", stiffness_ratio=2, size_ratio=0.5).run_id
    for name in ("compression-stiffness", "compression-normalised", "compression-position-shape",
                 "compression-mooney-rivlin"):
        assert reference in ids[name], name
    assert Run.of("compress", stiffness_ratio=2).run_id != Run.of("compress", stiffness_ratio=2, equivalent=True).run_id
    everything = [m.run for name in STUDIES for m in get_study(name).members(True)]
    assert len({r.run_id for r in everything}) == len(set(everything))  # one id per distinct run


def test_run_id_changes_when_and_only_when_a_resolved_parameter_changes():
    """The id hashes the run's resolved parameters: spelling out a default (the mesh size, the size ratio) keeps
    it, another value changes it; the readable prefix stays."""
    from elastocell.parameters.cell import DEFAULT_MESH_SIZES

    default = Run.of("compress", stiffness_ratio=2)
    assert default.run_id.startswith("compress-g2-")
    assert Run.of("compress", stiffness_ratio=2, mesh_size=DEFAULT_MESH_SIZES["p2"]["mesh_size"],
                  size_ratio=0.5, material="neo-hookean").run_id == default.run_id
    assert Run.of("compress", stiffness_ratio=2, mesh_size=0.3).run_id != default.run_id
    assert Run.of("compress", stiffness_ratio=2, steps=41).run_id != default.run_id
    assert Run.of("compress", stiffness_ratio=2, progress=True).run_id == default.run_id  # not computed

    shear = Run.of("shear", capillary_number=0.1)
    assert shear.run_id.startswith("shear-g2-ca0.1-")
    assert Run.of("shear", capillary_number=0.1, resolution=8.0, element="p1").run_id == shear.run_id
    assert Run.of("shear", capillary_number=0.1, resolution=6.0).run_id != shear.run_id
    assert Run.of("shear", capillary_number=0.1, duration=7.0).run_id != shear.run_id


def test_run_id_holds_the_quadrature_rule_the_compression_resolves():
    """A stiff neo-Hookean nucleus (ratio 20) resolves quadrature degree 5 on p2 elements: its id is that of the
    same run with quadrature_degree=5 given, not that of degree 2; the reference cell resolves no degree."""
    stiff = Run.of("compress", stiffness_ratio=20)
    assert stiff.run_id == Run.of("compress", stiffness_ratio=20, quadrature_degree=5).run_id
    assert stiff.run_id != Run.of("compress", stiffness_ratio=20, quadrature_degree=2).run_id
    mooney = Run.of("compress", stiffness_ratio=20, material="mooney-rivlin")
    assert mooney.run_id != Run.of("compress", stiffness_ratio=20, material="mooney-rivlin",
                                   quadrature_degree=5).run_id
    assert Run.of("compress").run_id != Run.of("compress", quadrature_degree=5).run_id


def test_the_resolved_parameters_of_a_run_id_are_those_the_api_runs(tmp_path, monkeypatch):
    """What the id hashes (api.resolved) is the cell and the compression the API records in metadata.json,
    here for a stiff nucleus whose quadrature degree the compression resolves."""
    from elastocell.api.compression import compress
    from elastocell.api.resolved import resolved_parameters
    from elastocell.files import canonical_json

    monkeypatch.setenv("ELASTOCELL_NO_VTK", "1")
    options = dict(element="p2", mesh_size=0.6, pole_size=0.6, steps=1, delta_max=0.05, stiffness_ratio=20, vtk=False)
    summary = compress(out=tmp_path / "run", progress=False, **options)
    resolved = resolved_parameters("compress", options)
    assert resolved["cell"].mesh.quadrature_degree == 5
    assert canonical_json(summary["cell"]) == canonical_json(resolved["cell"])
    assert canonical_json(summary["compression"]) == canonical_json(resolved["compression"])


def _curve_rows(pair, equivalent, delta, force, series="stiffness", gamma=2.0, size=0.5, reached=None):
    return [{"series": series, "cell": pair, "pair": pair, "equivalent": equivalent, "stiffness_ratio": gamma,
             "size_ratio": size, "delta": d, "force_per_Ec_R2": f, "force_per_Eeff_R2": f / (1 + (gamma - 1) / 8),
             "status": "complete", "delta_reached": reached or delta[-1], "effective_stiffness_ratio": 1 + (gamma - 1) / 8}
            for d, f in zip(delta, force, strict=True)]


def test_compression_claims_follow_the_measured_deviation():
    """Constructed curves: F_eq = delta^1.5; the cells deviate by known factors, so every verdict is known."""
    delta = np.linspace(0, 0.75, 16)
    base = delta ** 1.5
    factors = {1: 1.0, 2: 1 + 0.04 * delta, 5: 1 + 0.08 * delta, 10: 1.0 + 0.001, 20: 1 + 0.30 * (0.75 - delta)}
    rows = []
    for gamma, factor in factors.items():
        scale = 1 + (gamma - 1) / 8
        rows += _curve_rows(f"gamma {gamma}", False, delta, base * scale * factor, gamma=gamma)
        rows += _curve_rows(f"gamma {gamma}", True, delta, base * scale, gamma=gamma)
    frame = pd.DataFrame(rows)
    verdicts = [c.verdict for c in claims_stiffness(frame)]
    assert verdicts[0] == "agree"  # force grows with gamma
    assert verdicts[1] == "disagree"  # gamma 20 deviates by up to 0.3 * 0.7 = 21 % > 15 %
    assert verdicts[2] == "agree"  # gamma 10 within 0.1 % and the smallest
    assert verdicts[3] == "agree"  # slopes + for gamma 2, 5 and - for 20
    assert len(verdicts) == 4  # no random cell in this table: no random claim


def test_size_ratio_peak_is_found():
    delta = np.linspace(0, 0.75, 16)
    rows = []
    for size, amplitude in ((0.1, 0.001), (0.3, 0.01), (0.5, 0.02), (0.7, 0.03), (0.9, 0.015)):
        pair = f"lambda {size:g}"
        rows += _curve_rows(pair, False, delta, delta ** 1.5 * (1 + amplitude), series="size", size=size)
        rows += _curve_rows(pair, True, delta, delta ** 1.5, series="size", size=size)
    means, peak = size_peak(pd.DataFrame(rows))
    assert peak == pytest.approx(0.7)
    assert means[0.7] == pytest.approx(0.03, rel=1e-9)
    claim = [c for c in claims_normalised(pd.DataFrame(rows)) if "peaks" in c.claim][0]
    assert claim.verdict == "agree"


def test_pipe_claims_read_the_strains():
    rows = []
    for cell, eq, ex, er in (("gamma 1", False, 0.95, 1.03), ("gamma 1", True, 0.95, 1.03),
                             ("gamma 2", False, 0.96, 1.03), ("gamma 2", True, 0.97, 1.02),
                             ("gamma 10", False, 0.98, 1.029), ("gamma 10", True, 0.99, 1.01)):
        rows.append({"cell": cell, "equivalent": eq, "status": "complete", "strain_axial_mean": ex,
                     "strain_radial_mean": er, "strain_axial_std": 0.001, "strain_radial_std": 0.001})
    claims = claims_pipe(pd.DataFrame(rows))
    assert claims[0].verdict == "agree"  # every cell is a bullet
    assert claims[1].verdict == "disagree"  # axial strain differs by 1 point of 3 = 33 % of |eps - 1| (gamma 2)
    assert claims[2].verdict == "agree"  # cells 0.03/0.03/0.029 vs equivalents 0.03/0.02/0.01


def test_cross_section_of_a_meshed_ball_is_a_disc():
    """Reference: the cut of the unit ball through its centre, area pi. The p1 mesh (edge 0.3 R) is inscribed in
    the sphere; its cut measured 2.2 % smaller, so the tolerance is 4 %."""
    from elastocell.body.cell import Cell
    from elastocell.parameters.cell import cell_parameters

    body = Cell.from_parameters(cell_parameters(nucleus="none", element="p1", mesh_size=0.3))
    cut, polygons = cross_section(body.mesh.nodes, body.mesh.elements)
    area = sum(0.5 * abs(np.dot(p[:, 0], np.roll(p[:, 1], 1)) - np.dot(p[:, 1], np.roll(p[:, 0], 1))) for p in polygons)
    assert len(cut) == len(polygons) > 20
    assert area == pytest.approx(np.pi, rel=0.04)
    assert area < np.pi  # inscribed


@pytest.fixture
def tiny_study(monkeypatch):
    """Two coarse compression runs (a gamma-2 cell and its equivalent to delta 0.2) as a registered study."""
    options = {"element": "p1", "mesh_size": 0.5, "pole_size": 0.5, "steps": 4, "delta_max": 0.2, "vtk": False}

    def members(quick):
        labels = {"series": "stiffness", "cell": "gamma 2", "pair": "gamma 2", "stiffness_ratio": 2.0,
                  "size_ratio": 0.5}
        return [Member(Run.of("compress", **options, stiffness_ratio=2), {**labels, "equivalent": False}),
                Member(Run.of("compress", **options, stiffness_ratio=2, equivalent=True), {**labels, "equivalent": True})]

    study = Study("tiny", "tiny", "fig-none", "two coarse curves", members, tidy, plot_stiffness, claims_stiffness)
    monkeypatch.setitem(STUDIES, "tiny", study)
    return study


@pytest.mark.slow
def test_a_study_runs_through_dask_writes_its_outputs_and_resumes(tiny_study, tmp_path):
    summary = run_studies(["tiny"], tmp_path, quick=True, workers=1)
    assert summary["_failures"] == []
    frame, metadata = read_study_table(tmp_path, "tiny")
    assert metadata["study"] == "tiny" and metadata["quick"] is True and metadata["runs"] == 2
    assert set(frame["equivalent"]) == {True, False}
    assert frame["delta"].max() == pytest.approx(0.2)
    assert {"run_id", "status", "option_stiffness_ratio", "force_per_Ec_R2", "run_directory"} <= set(frame.columns)
    for suffix in (".png", ".pdf", ".csv", ".claims.json"):
        assert (tmp_path / f"tiny{suffix}").exists(), suffix
    assert (tmp_path / "report.md").exists() and (tmp_path / "report.html").exists()
    records = sorted(tmp_path.glob("runs/*/run.json"))
    assert len(records) == 2 and all((p.parent / "compression.csv").exists() for p in records)
    stamps = [p.stat().st_mtime_ns for p in records]
    # resume: finished runs are read back (no cluster, no computation), the table is identical
    again = run_studies(["tiny"], tmp_path, quick=True, workers=1)
    assert [p.stat().st_mtime_ns for p in records] == stamps
    assert again["_wall_time_s"] < summary["_wall_time_s"]
    pd.testing.assert_frame_equal(read_study_table(tmp_path, "tiny")[0], frame)
    # interrupted: a run killed before it finished has no run.json; only that run is computed again
    records[0].unlink()
    run_studies(["tiny"], tmp_path, quick=True, workers=1)
    assert records[0].exists() and records[0].stat().st_mtime_ns > stamps[0]
    assert records[1].stat().st_mtime_ns == stamps[1]
    pd.testing.assert_frame_equal(read_study_table(tmp_path, "tiny")[0].drop(columns="wall_time_s"),
                                  frame.drop(columns="wall_time_s"))
    # plot re-derives the same claims from the table alone
    before = json.loads((tmp_path / "tiny.claims.json").read_text())
    plot_study("tiny", tmp_path)
    assert json.loads((tmp_path / "tiny.claims.json").read_text()) == before
    assert len(load_claims(tmp_path)) == len(before["claims"]) > 0


def test_study_cli_refuses_impossible_input(tmp_path):
    runner = CliRunner()
    result = runner.invoke(app, ["study", "run", "no-such-study", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "unknown study" in result.output and "compression-stiffness" in result.output
    result = runner.invoke(app, ["study", "run", "cell-models", "--workers", "0", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "--workers" in result.output
    result = runner.invoke(app, ["reproduce", "--scheduler", "tcp://h:8786", "--workers", "2", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "not both" in result.output
    result = runner.invoke(app, ["study", "plot", "cell-models", str(tmp_path)])
    assert result.exit_code == 2 and "study run cell-models" in result.output
    (tmp_path / "study_mode.json").write_text('{"mode": "full"}')
    result = runner.invoke(app, ["study", "run", "cell-models", "--quick", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "full results" in result.output


def test_best_fit_modulus_recovers_a_known_scaling():
    """Compression: a cell whose force is exactly 1.7/gamma_eff times its equivalent's has E_fit = 1.7 E_c.
    Shear: a cell with D(Ca) = D_hom(Ca/2.3) has E_fit = 2.3 E_c (homogeneous D(Ca) = 1.25 Ca/(1 + Ca))."""
    from elastocell.studies.equivalent_modulus import compression_fits, shear_fits

    delta = np.linspace(0, 0.7, 15)
    gamma_eff = 2.125
    rows = _curve_rows("gamma 10", True, delta, gamma_eff * delta ** 1.5, gamma=10)
    rows += _curve_rows("gamma 10", False, delta, 1.7 * delta ** 1.5, gamma=10)
    frame = pd.DataFrame(rows)
    frame["effective_stiffness_ratio"] = gamma_eff
    frame["discretisation"] = "p2"
    (fit,) = compression_fits(frame)
    assert fit["best_fit"] == pytest.approx(1.7, rel=1e-12)
    assert fit["voigt"] == pytest.approx(2.125, rel=1e-12)
    assert fit["voigt_error"] == pytest.approx(2.125 / 1.7 - 1, rel=1e-12)

    def d_hom(ca):
        return 1.25 * ca / (1 + ca)

    shear = []
    for ca in (0.0125, 0.025, 0.05, 0.1, 0.2, 0.3):
        shear.append({"cell": "homogeneous mu_c", "equivalent": False, "status": "complete", "stiffness_ratio": 1.0,
                      "capillary_number_mu_c": ca, "effective_stiffness_ratio": 1.0, "taylor_deformation_mean": d_hom(ca)})
        shear.append({"cell": "gamma 5", "equivalent": False, "status": "complete", "stiffness_ratio": 5.0,
                      "capillary_number_mu_c": ca, "effective_stiffness_ratio": 1.5,
                      "taylor_deformation_mean": d_hom(ca / 2.3)})
    (fit,) = shear_fits(pd.DataFrame(shear))
    assert fit["best_fit"] == pytest.approx(2.3, rel=1e-3)  # the log-log interpolation of D_hom between samples


def test_report_lists_every_verdict(tmp_path):
    """Synthetic claims with each verdict: the report counts them and shows each with its numbers."""
    from elastocell.studies.base import Claim
    from elastocell.studies.report import write_report

    verdicts = ["agree", "partly", "disagree", "not measured"]
    claims = [Claim("compression-stiffness", f"claim {v}", "Sec. 0", f"measured {i}.5 %", v, "rule").__dict__
              for i, v in enumerate(verdicts)]
    (tmp_path / "compression-stiffness.claims.json").write_text(json.dumps({"claims": claims}))
    (tmp_path / "study_mode.json").write_text('{"mode": "quick"}')
    text = write_report(tmp_path).read_text()
    assert "1 agree, 1 partly, 1 disagree, 1 not measured" in text
    for i, verdict in enumerate(verdicts):
        assert f"measured {i}.5 %" in text and f"**{verdict if verdict != 'disagree' else 'DISAGREE'}**" in text
    assert "quick" in (tmp_path / "report.html").read_text()


def test_a_failed_run_leaves_the_analysis_standing(tmp_path):
    """One failed run (no curve) and one curve that stopped after its first row: tables, claims, figures and the
    equivalent-modulus fits still come out, the failed cell simply absent."""
    from elastocell.studies.base import rows_per_delta
    from elastocell.studies.compression import plot_stiffness, stiffness_members
    from elastocell.studies.equivalent_modulus import compression_fits

    delta = list(np.linspace(0, 0.5, 6))
    pairs = []
    for member in stiffness_members(True):
        gamma = member.labels["stiffness_ratio"] if member.labels["cell"] != "random" else 5.5
        record = {"run_id": member.run.run_id, "options": member.run.kwargs, "status": "complete",
                  "effective_stiffness_ratio": 1.5, "delta_reached": 0.5, "nodes": 10, "wall_time_s": 1.0,
                  "curve": {"delta": delta, "force_per_Ec_R2": [d ** 1.5 * (1 + gamma / 10) for d in delta],
                            "force_per_Eeff_R2": [d ** 1.5 for d in delta]}}
        if member.labels["cell"] == "gamma 5" and member.labels["equivalent"]:
            record = {"run_id": member.run.run_id, "options": member.run.kwargs, "status": "failed", "error": "boom"}
        if member.labels["cell"] == "gamma 10" and not member.labels["equivalent"]:
            record["curve"] = {k: v[:1] for k, v in record["curve"].items()}
            record["status"] = "partial"
        pairs.append((member, record))
    frame = pd.DataFrame(rows_per_delta(pairs))
    claims = claims_stiffness(frame)
    assert claims[0].verdict == "agree"  # gamma 1, 2, 20 still ordered; 5 and 10 left out
    assert "gamma 5" not in claims[0].measured and "gamma 10" not in claims[0].measured
    assert plot_stiffness(frame, tmp_path, "s")[0].exists()
    assert {row["cell"] for row in compression_fits(frame)} == {"gamma 2", "gamma 20", "random"}


def test_run_tasks_prepares_once_before_a_local_cluster_only():
    # prepare (e.g. compiling the flow kernels once, so that the workers load them from the cache) runs in the
    # caller before a local cluster starts, and not when the caller hands over a running client.
    import math

    from elastocell.simulation.distributed import dask_client, run_tasks

    calls = []
    results = dict(run_tasks(math.sqrt, [4.0, 9.0], workers=1, prepare=lambda: calls.append("local")))
    assert results == {0: 2.0, 1: 3.0} and calls == ["local"]
    with dask_client(workers=1) as client:
        results = dict(run_tasks(math.sqrt, [16.0], client=client, prepare=lambda: calls.append("client")))
    assert results == {0: 4.0} and calls == ["local"]
