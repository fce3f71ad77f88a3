"""The verified cache: an entry (mesh, master curve) made from other parameters, cut short, emptied or altered is
reported once in a warning naming the file, made again and never used; a write killed before its rename leaves
no entry that loads; every key is the hash of the resolved parameters."""

from __future__ import annotations

import shutil
import subprocess
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from elastocell.body.cell import Cell
from elastocell.body.mesh import build_mesh, mesh_cache_path, mesh_parameters
from elastocell.files import canonical_json, parameter_hash, read_cache_entry, write_cache_entry
from elastocell.parameters.cell import cell_parameters

COARSE = {"element": "p1", "mesh_size": 0.5}
DAMAGES = ("swapped", "truncated", "emptied", "bit-flipped")


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    directory = tmp_path / "cache"
    monkeypatch.setenv("ELASTOCELL_CACHE", str(directory))
    return directory


def damage(path: Path, how: str, other: Path | None = None) -> None:
    """Swap in ``other`` (another entry of the same kind), keep half of the file, empty it, or flip one bit of
    its payload."""
    data = path.read_bytes()
    if how == "swapped":
        shutil.copyfile(other, path)
    elif how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "emptied":
        path.write_bytes(b"")
    elif how == "bit-flipped":
        position = (data.index(b"\n") + len(data)) // 2  # inside the payload, after the header line
        path.write_bytes(data[:position] + bytes([data[position] ^ 0x10]) + data[position + 1:])
    else:
        raise ValueError(how)


def warned_once(record, path: Path) -> None:
    messages = [str(w.message) for w in record if issubclass(w.category, UserWarning)]
    assert len(messages) == 1, messages
    assert str(path) in messages[0] and "made again" in messages[0]


# =========================================================================== keys
def test_parameter_hash_is_of_the_values_not_their_spelling():
    reference = cell_parameters()
    assert parameter_hash(reference, format_version=1) == parameter_hash(
        cell_parameters(mesh_size=0.35, size_ratio=0.5, material="neo-hookean"), format_version=1)
    assert parameter_hash(reference, format_version=1) != parameter_hash(reference, format_version=2)
    assert parameter_hash(reference, format_version=1) != parameter_hash(cell_parameters(mesh_size=0.3),
                                                                         format_version=1)
    assert canonical_json({"b": (1, np.float64(0.5)), "a": None}) == '{"a":null,"b":[1,0.5]}'


def test_mesh_key_is_the_resolved_mesh_parameters(cache):
    """An explicit default gives the default's entry; the stiffness and the quadrature do not change the mesh."""
    default = cell_parameters(**COARSE)
    same = cell_parameters(**COARSE, pole_size=0.04, stiffness_ratio=5)
    assert mesh_parameters(default.nucleus, default.mesh) == mesh_parameters(same.nucleus, same.mesh)
    assert mesh_cache_path(mesh_parameters(default.nucleus, default.mesh)) != mesh_cache_path(
        mesh_parameters(default.nucleus, cell_parameters(element="p1", mesh_size=0.45).mesh))


# =========================================================================== meshes
@pytest.mark.parametrize("how", DAMAGES)
def test_a_damaged_or_foreign_mesh_is_reported_once_and_rebuilt(cache, how):
    """The reference cell's entry replaced by the homogeneous cell's mesh (no nucleus: E_eff/E_c 1.0), cut in
    half, emptied or with one bit flipped: one warning naming the file, the mesh rebuilt (E_eff/E_c as a fresh
    build, near 1.125), the rebuilt entry used silently afterwards."""
    reference = cell_parameters(**COARSE)
    fresh = Cell.from_parameters(reference, use_cache=False).effective_stiffness_ratio
    assert fresh == pytest.approx(1.125, abs=0.03)
    assert Cell.from_parameters(reference).effective_stiffness_ratio == fresh  # writes the entry
    path = mesh_cache_path(mesh_parameters(reference.nucleus, reference.mesh))
    homogeneous = cell_parameters(**COARSE, nucleus="none")
    build_mesh(homogeneous)
    damage(path, how, other=mesh_cache_path(mesh_parameters(homogeneous.nucleus, homogeneous.mesh)))

    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        rebuilt = Cell.from_parameters(reference)
    warned_once(record, path)
    assert rebuilt.effective_stiffness_ratio == pytest.approx(fresh, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert Cell.from_parameters(reference).effective_stiffness_ratio == pytest.approx(fresh, rel=1e-12)


def test_a_mesh_write_killed_before_its_rename_leaves_no_entry(cache):
    """A process killed between writing the temporary file and renaming it: the entry's path holds nothing, the
    temporary file is never read, and the next build makes the mesh without a warning."""
    script = (
        "import os, elastocell.files as files\n"
        "files.os.replace = lambda *a, **k: os._exit(9)\n"
        "from elastocell.body.mesh import build_mesh\n"
        "from elastocell.parameters.cell import cell_parameters\n"
        "build_mesh(cell_parameters(element='p1', mesh_size=0.5))\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 9, result.stderr[-2000:]
    reference = cell_parameters(**COARSE)
    path = mesh_cache_path(mesh_parameters(reference.nucleus, reference.mesh))
    assert not path.exists()
    assert [p.name for p in cache.iterdir() if p.name.startswith(f".{path.name}.")]  # the killed write's file
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cell = Cell.from_parameters(reference)
    assert cell.effective_stiffness_ratio == pytest.approx(1.125, abs=0.03)
    assert path.exists()


def test_an_interrupted_entry_write_leaves_the_old_entry_or_none(cache, monkeypatch):
    import elastocell.files as files

    cache.mkdir()
    path = cache / "entry.bin"
    write_cache_entry(path, b"old", "test", {"a": 1}, 1)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(files.os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_cache_entry(path, b"new", "test", {"a": 1}, 1)
    with pytest.raises(KeyboardInterrupt):
        write_cache_entry(cache / "other.bin", b"new", "test", {"a": 1}, 1)
    monkeypatch.undo()
    assert read_cache_entry(path, "test", {"a": 1}, 1, bytes) == b"old"
    assert not (cache / "other.bin").exists()
    assert sorted(p.name for p in cache.iterdir()) == ["entry.bin"]  # no temporary file left


# =========================================================================== master curves
class FakeCell:
    """Stands for the cell of a master-curve mesh (no mesh is made)."""

    def __init__(self, parameters):
        self.parameters = parameters
        self.mesh = SimpleNamespace(n_nodes=int(100 / parameters.mesh.mesh_size))

    @classmethod
    def from_parameters(cls, parameters):
        return cls(parameters)


@pytest.fixture
def fake_compression(monkeypatch):
    """The compression of a master curve replaced by a deterministic curve of the cell's inputs; counts calls."""
    import elastocell.inverse.mastercurve as mastercurve

    calls = []

    def compress(cell, scenario, progress=None):
        calls.append(cell.parameters)
        delta = np.linspace(0.0, scenario.delta_max, scenario.steps + 1)
        force = mastercurve.hertz_force(delta, cell.parameters.material.poisson_ratio) * (
            1 + 0.1 * delta + cell.parameters.mesh.mesh_size * delta**2)
        return SimpleNamespace(delta=delta, force=force, unstable=np.zeros(delta.size, bool), max_rigid_reaction=0.0)

    monkeypatch.setattr(mastercurve, "compress", compress)
    monkeypatch.setattr(mastercurve, "Cell", FakeCell)
    return calls


@pytest.mark.parametrize("how", DAMAGES)
def test_a_damaged_or_foreign_compression_master_curve_is_reported_once_and_computed_again(cache, fake_compression,
                                                                                           how):
    from elastocell.inverse.mastercurve import cache_path, compute_master_curve, load_master_curve
    from elastocell.parameters.units import ParameterError

    first = compute_master_curve(0.47)
    assert len(fake_compression) == 2 and cache_path(0.47).exists()
    assert np.allclose(load_master_curve(0.47).force, first.force, rtol=1e-9)  # read back, not computed
    assert len(fake_compression) == 2
    compute_master_curve(0.46)
    damage(cache_path(0.47), how, other=cache_path(0.46))

    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        with pytest.raises(ParameterError, match="elastocell mastercurve compression"):
            load_master_curve(0.47)  # never used: the command that computes it is named
    warned_once(record, cache_path(0.47))
    assert not cache_path(0.47).exists()

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        compute_master_curve(0.47)  # no entry now: computed silently
    damage(cache_path(0.47), how, other=cache_path(0.46))
    calls = len(fake_compression)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        again = compute_master_curve(0.47)
    warned_once(record, cache_path(0.47))
    assert len(fake_compression) == calls + 2  # computed again
    assert again.poisson_ratio == 0.47 and np.allclose(again.force, first.force, rtol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.allclose(load_master_curve(0.47).force, first.force, rtol=1e-9)


def test_compression_master_curve_key_is_the_resolved_parameters(cache, fake_compression):
    from elastocell.inverse.mastercurve import MESHES, cache_path, compute_master_curve

    assert cache_path(0.47) == cache_path(0.47, "neo-hookean", dict(MESHES), 60, "p2")
    assert cache_path(0.47) != cache_path(0.47, steps=61)
    assert cache_path(0.47) != cache_path(0.47, meshes={"default": (0.35, 0.1), "fine": (0.2, 0.05)})
    compute_master_curve(0.47, meshes={"default": (0.6, 0.6), "fine": (0.5, 0.5)}, steps=8, element="p1")
    assert cache_path(0.47, meshes={"default": (0.6, 0.6), "fine": (0.5, 0.5)}, steps=8, element="p1").exists()
    assert not cache_path(0.47).exists()


@pytest.fixture
def fake_shear_runs(monkeypatch):
    """The shear runs of the shear master curve replaced by deterministic summaries; counts calls."""
    import elastocell.inverse.mastercurve_shear as mastercurve_shear

    calls = []

    def run_one(poisson_ratio, material, ca, resolution, duration, directory, use_cache):
        calls.append((ca, resolution))
        deformation = 1.25 * ca * (1 + 0.2 * ca) * (1 + 4 / resolution**2) * (1 + (0.48 - poisson_ratio))
        return {"taylor_deformation_mean": deformation, "inclination_deg_mean": 45 - 40 * ca,
                "tank_treading_frequency": 0.5 - 0.3 * ca, "taylor_deformation_std": 1e-4,
                "volume_change_max_abs": 1e-5, "duration_strain": duration, "wall_time_s": 1.0,
                "mesh": {"n_nodes": 100}, "lattice": {"shape": [8, 8, 8]}}

    monkeypatch.setattr(mastercurve_shear, "_run_one", run_one)
    return calls


@pytest.mark.parametrize("how", DAMAGES)
def test_a_damaged_or_foreign_shear_master_curve_is_reported_once_and_computed_again(cache, fake_shear_runs, how):
    from elastocell.inverse.mastercurve_shear import cache_path, compute_shear_master_curve

    first = compute_shear_master_curve(0.47)
    runs = len(fake_shear_runs)
    assert runs == 14 and cache_path(0.47).exists()
    compute_shear_master_curve(0.47)
    assert len(fake_shear_runs) == runs  # read back
    compute_shear_master_curve(0.46)
    damage(cache_path(0.47), how, other=cache_path(0.46))
    calls = len(fake_shear_runs)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        again = compute_shear_master_curve(0.47)
    warned_once(record, cache_path(0.47))
    assert len(fake_shear_runs) == calls + 14
    assert np.allclose(again.table["deformation"], first.table["deformation"], rtol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.allclose(compute_shear_master_curve(0.47).table["deformation"], first.table["deformation"],
                           rtol=1e-9)


def test_shear_runs_in_a_shared_work_directory_are_reused_only_when_made_from_the_same_parameters(
        cache, tmp_path, monkeypatch):
    """Two curves computed in one ``work_directory`` (its run directories are named by Ca and R/dx only): the
    second curve's runs are made again, with a warning, not read from the first curve's summaries; a curve
    computed again reads all its own runs back."""
    import json

    import elastocell.inverse.mastercurve_shear as mastercurve_shear

    calls = []

    def shear(out, resume=False, progress=True, **options):
        calls.append((options["poisson_ratio"], options["capillary_number"], options["resolution"]))
        summary = {"taylor_deformation_mean": 1.25 * options["capillary_number"] * (1.48 - options["poisson_ratio"]),
                   "inclination_deg_mean": 40.0, "tank_treading_frequency": 0.4, "taylor_deformation_std": 1e-4,
                   "volume_change_max_abs": 1e-5, "duration_strain": options["duration"], "mesh": {"n_nodes": 10}}
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").write_text(json.dumps(summary))
        return summary

    monkeypatch.setattr(mastercurve_shear, "shear", shear)
    work = tmp_path / "work"
    grid = {"capillary_numbers": (0.05, 0.1, 0.2), "resolutions": (4, 6), "duration": 1.0, "work_directory": work}
    first = mastercurve_shear.compute_shear_master_curve(0.47, **grid)
    assert len(calls) == 6
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        other = mastercurve_shear.compute_shear_master_curve(0.40, **grid)
    assert len(calls) == 12 and {call[0] for call in calls[6:]} == {0.40}
    assert sum("made from other parameters" in str(w.message) for w in record) == 6
    assert np.allclose(other.table["deformation_rdx6"] / first.table["deformation_rdx6"], 1.08 / 1.01)
    mastercurve_shear.cache_path(0.40, "neo-hookean", grid["capillary_numbers"], grid["resolutions"], 1.0).unlink()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = mastercurve_shear.compute_shear_master_curve(0.40, **grid)  # from the runs' summaries
    assert len(calls) == 12 and np.array_equal(again.table["deformation"], other.table["deformation"])
