"""Faults and half-finished runs: nothing lost, nothing silently wrong (interrupted curves, resume, one run per
output directory, damaged checkpoints, atomic outputs)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

import elastocell
import elastocell.api.compression as api_compression
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.compression import CompressionInterrupted
from elastocell.simulation.directory import LOCK_NAME, output_directory

COARSE = dict(element="p1", mesh_size=0.5, pole_size=0.25, delta_max=0.3, steps=6, vtk=False, progress=False)


def interrupt_after(rows: int, monkeypatch):
    """Make the next curve raise KeyboardInterrupt (as Ctrl-C would) once ``rows`` rows have converged."""
    original = api_compression.compress_cell

    def compress_cell(*args, on_row=None, **kwargs):
        def row(result):
            on_row(result)
            if len(result.delta) >= rows:
                raise KeyboardInterrupt

        return original(*args, on_row=row, **kwargs)

    monkeypatch.setattr(api_compression, "compress_cell", compress_cell)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("whole")
    elastocell.compress(out=out, **COARSE)
    return np.genfromtxt(out / "compression.csv", delimiter=",", names=True)


@pytest.mark.slow
def test_an_interrupted_curve_keeps_its_rows_and_resumes_to_the_uninterrupted_curve(tmp_path, monkeypatch,
                                                                                     uninterrupted):
    # Reference: the same curve run without interruption. The resumed rows repeat the same load steps from the
    # last converged state; they differ from the uninterrupted ones only by where Newton stopped within its
    # tolerance (the predictor of the first resumed step is factorised anew): measured 2e-13 relative here.
    interrupt_after(3, monkeypatch)
    with pytest.raises(CompressionInterrupted, match="--resume"):
        elastocell.compress(out=tmp_path, **COARSE)
    rows = np.genfromtxt(tmp_path / "compression.csv", delimiter=",", names=True)
    metadata = json.loads((tmp_path / "metadata.json").read_text())
    assert len(rows) == 3 and metadata["complete"] is False and metadata["interrupted"] is True
    assert metadata["interrupted_at_delta"] == pytest.approx(rows["delta"][-1])
    assert (tmp_path / "checkpoint.npz").exists() and not (tmp_path / LOCK_NAME).exists()
    np.testing.assert_allclose(rows["force"], uninterrupted["force"][:3], rtol=1e-12)

    monkeypatch.undo()
    summary = elastocell.compress(out=tmp_path, resume=True, **COARSE)
    resumed = np.genfromtxt(tmp_path / "compression.csv", delimiter=",", names=True)
    assert summary["complete"] is True and not (tmp_path / "checkpoint.npz").exists()
    np.testing.assert_allclose(resumed["delta"], uninterrupted["delta"], rtol=0, atol=1e-14)
    # Compared as written (compression.csv, 10 significant digits): a 2e-13 difference can move the last printed
    # digit, so the tolerance is one unit of the 10th digit, 1e-9 relative (measured: every printed digit equal in
    # 3 runs of this curve, max |difference| 0.0).
    np.testing.assert_allclose(resumed["force"], uninterrupted["force"], rtol=1e-9, atol=0)


def test_compare_interrupted_during_the_equivalent_resumes_the_equivalent_only(tmp_path, monkeypatch):
    """The first curve of ``compare=True`` is complete on disk when the equivalent is interrupted: resuming reads
    it back (same fingerprint) and computes only the equivalent."""
    original, curves = api_compression.compress_cell, []

    def compress_cell(body, *args, on_row=None, **kwargs):
        curves.append(body.is_equivalent)

        def row(result):
            on_row(result)
            if body.is_equivalent and len(result.delta) >= 3:
                raise KeyboardInterrupt

        return original(body, *args, on_row=row, **kwargs)

    monkeypatch.setattr(api_compression, "compress_cell", compress_cell)
    with pytest.raises(CompressionInterrupted, match="--resume"):
        elastocell.compress(out=tmp_path, compare=True, **COARSE)
    first = (tmp_path / "compression.csv").read_bytes()
    assert curves == [False, True] and json.loads((tmp_path / "metadata.json").read_text())["complete"] is True
    monkeypatch.setattr(api_compression, "compress_cell", original)
    counted = []
    monkeypatch.setattr(api_compression, "compress_cell",
                        lambda body, *a, **k: counted.append(body.is_equivalent) or original(body, *a, **k))
    summary = elastocell.compress(out=tmp_path, compare=True, resume=True, **COARSE)
    assert counted == [True] and (tmp_path / "compression.csv").read_bytes() == first
    assert summary["complete"] is True and summary["equivalent_summary"]["complete"] is True
    assert (tmp_path / "comparison.csv").exists()
    # without resume both curves are computed again
    counted.clear()
    elastocell.compress(out=tmp_path, compare=True, **COARSE)
    assert counted == [False, True]


def test_a_checkpoint_of_another_mesh_with_the_same_parameters_is_refused(tmp_path, monkeypatch):
    """The checkpoint's fingerprint hashes the mesh arrays: a mesh that changed under the same parameters (another
    mesher version, another cached mesh; here every node moved by 1e-3 R) does not continue the curve made on the
    first mesh."""
    import dataclasses

    from elastocell.body.cell import Cell

    interrupt_after(3, monkeypatch)
    with pytest.raises(CompressionInterrupted):
        elastocell.compress(out=tmp_path, **COARSE)
    monkeypatch.undo()

    class MovedCell(Cell):
        @classmethod
        def from_parameters(cls, parameters, use_cache=True):
            body = Cell.from_parameters(parameters, use_cache)
            mesh = dataclasses.replace(body.mesh, nodes=body.mesh.nodes * (1 + 1e-3))
            return Cell(parameters, mesh, body.youngs_moduli)

    monkeypatch.setattr(api_compression, "Cell", MovedCell)
    with pytest.raises(ParameterError, match="resume: .* other parameters"):
        elastocell.compress(out=tmp_path, resume=True, **COARSE)
    monkeypatch.undo()
    assert elastocell.compress(out=tmp_path, resume=True, **COARSE)["complete"] is True  # the same mesh continues


def test_resume_refuses_a_damaged_or_foreign_checkpoint_naming_resume(tmp_path, monkeypatch):
    interrupt_after(2, monkeypatch)
    with pytest.raises(CompressionInterrupted):
        elastocell.compress(out=tmp_path, **COARSE)
    monkeypatch.undo()
    checkpoint = tmp_path / "checkpoint.npz"
    with pytest.raises(ParameterError, match="other parameters") as error:
        elastocell.compress(out=tmp_path, resume=True, **{**COARSE, "steps": 7})
    assert error.value.parameter == "resume"
    good = checkpoint.read_bytes()
    for damage in (good[: len(good) // 2], b"", good[:100] + bytes(b ^ 0xFF for b in good[100:200]) + good[200:],
                   b"not a checkpoint at all"):
        checkpoint.write_bytes(damage)
        with pytest.raises(ParameterError, match="damaged|inconsistent") as error:
            elastocell.compress(out=tmp_path, resume=True, **COARSE)
        assert error.value.parameter == "resume" and "pickle" not in str(error.value)
    # a pickled object array is refused, not loaded
    np.savez(checkpoint, fingerprint=np.array("x"), delta=np.array([object()], dtype=object))
    with pytest.raises(ParameterError, match="damaged"):
        elastocell.compress(out=tmp_path, resume=True, **COARSE)


def test_a_second_run_into_the_same_directory_is_refused_and_a_stale_lock_taken_over(tmp_path):
    with output_directory(tmp_path):
        holder = json.loads((tmp_path / LOCK_NAME).read_text())
        assert holder["pid"] == os.getpid()
        with pytest.raises(ParameterError, match="in use by process"):
            elastocell.compress(out=tmp_path, **COARSE)
    assert not (tmp_path / LOCK_NAME).exists()
    # a lock left by a process that is gone: taken over with a warning
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / LOCK_NAME).write_text(json.dumps({"pid": dead.pid, "host": os.uname().nodename, "command": "x"}))
    with pytest.warns(UserWarning, match="no longer runs"):
        with output_directory(tmp_path):
            pass


def test_options_are_validated_before_any_file_is_written(tmp_path):
    out = tmp_path / "never"
    with pytest.raises(ValueError, match="stiffness_ratio"):  # ParameterError, or pydantic's error wrapping it
        elastocell.compress(out=out, stiffness_ratio=-1, **COARSE)
    with pytest.raises(ValueError, match="delta_max"):
        elastocell.compress(out=out, **{**COARSE, "delta_max": 2.0})
    assert not out.exists()


@pytest.mark.slow
def test_sigterm_during_a_curve_writes_the_converged_rows(tmp_path):
    """A batch system's stop (SIGTERM) is handled as Ctrl-C: the converged rows and an incomplete metadata."""
    out = tmp_path / "run"
    script = (f"import elastocell; elastocell.compress(out={str(out)!r}, element='p1', mesh_size=0.4, "
              "pole_size=0.2, delta_max=0.6, steps=60, vtk=False, progress=False)")
    environment = {**os.environ, "ELASTOCELL_CACHE": str(tmp_path / "cache")}  # a fresh mesh: gmsh runs too
    process = subprocess.Popen([sys.executable, "-c", script], stderr=subprocess.PIPE, text=True, env=environment)
    deadline = time.time() + 120
    while not (out / "checkpoint.npz").exists() and time.time() < deadline and process.poll() is None:
        time.sleep(0.1)
    process.terminate()
    _, stderr = process.communicate(timeout=60)
    assert "CompressionInterrupted" in stderr and "--resume" in stderr
    metadata = json.loads((out / "metadata.json").read_text())
    assert metadata["interrupted"] is True and metadata["complete"] is False
    rows = np.genfromtxt(out / "compression.csv", delimiter=",", names=True)
    assert 2 <= len(rows) < 61 and rows["delta"][-1] == pytest.approx(metadata["interrupted_at_delta"])


def test_a_failed_figure_write_names_the_file_and_leaves_none(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from elastocell.files import save_figure

    figure = plt.figure()
    target = tmp_path / "missing-directory" / "plot.png"
    with pytest.raises(OSError, match="plot.png"):
        save_figure(figure, target)
    assert not target.exists()
    plt.close(figure)


@pytest.mark.parametrize("scenario, options", [("shear", {"capillary_number": 0.1}),
                                               ("pipe", {"capillary_number_wall": 0.2})])
def test_flow_options_are_validated_before_any_file_and_one_run_per_directory(tmp_path, scenario, options):
    run = getattr(elastocell, scenario)
    out = tmp_path / "flow"
    with pytest.raises(ParameterError, match="whole number >= 1") as error:
        run(out=out, checkpoint_every=0, resolution=3, duration=0.1, progress=False, **options)
    assert error.value.parameter == "checkpoint_every" and not out.exists()
    with output_directory(out):
        with pytest.raises(ParameterError, match="in use by process"):
            run(out=out, resolution=3, duration=0.1, progress=False, **options)
    assert sorted(p.name for p in out.iterdir()) == []


@pytest.mark.parametrize("options, refused", [
    (dict(random=True, stiffness_ratio=5), "random"),
    (dict(random=True, size_ratio=0.3), "random"),
    (dict(random=True, nucleus="ellipsoid"), "random"),
    (dict(nucleus="none", stiffness_ratio=5), "stiffness_ratio"),
    (dict(nucleus="ellipsoid", size_ratio=0.3), "size_ratio"),
    (dict(nucleus="sphere", semi_axes=(0.5, 0.3, 0.3)), "semi_axes"),
    (dict(offset_axis="y"), "offset_axis"),
])
def test_options_that_cannot_apply_together_are_refused(options, refused):
    with pytest.raises(ParameterError) as error:
        elastocell.cell_parameters(**options)
    assert error.value.parameter == refused


def test_compare_and_equivalent_together_are_refused(tmp_path):
    with pytest.raises(ParameterError, match="--compare already runs the equivalent"):
        elastocell.compress(out=tmp_path / "x", compare=True, equivalent=True, **COARSE)
    assert not (tmp_path / "x").exists()


def test_stationarity_verdict_tells_a_drift_from_noise():
    # Reference: a linear rise drifts by sqrt(3 n) standard errors of the half means (here n = 40: ~11, far
    # above the bound of 3); white noise by about one (bound 3: false alarms at the 0.3 % level of a normal).
    from elastocell.simulation.runner import stationarity

    rng = np.random.default_rng(3)
    time_ = np.linspace(0.0, 1.0, 40)
    assert not stationarity(1.0 + 3e-3 * time_ + 2e-4 * rng.standard_normal(40))["stationary"]
    assert stationarity(1.0 + 2e-4 * rng.standard_normal(40))["stationary"]
    assert stationarity(np.full(40, 0.3))["stationary"]  # exactly constant
    assert stationarity(1.0 + 1e-5 * time_)["stationary"]  # rises by less than the 1e-3 tolerance
    assert not stationarity([1.0, 1.0, 1.0])["stationary"]  # too few records to judge


def test_a_short_pipe_run_is_flagged_not_stationary_with_a_warning(tmp_path):
    """The drifting series of a run far shorter than its relaxation is not called stationary (summary field and
    a warning); the stationary-looking mean +- std alone hid that."""
    with pytest.warns(UserWarning, match="not stationary"):
        summary = elastocell.pipe(out=tmp_path, capillary_number_wall=0.2, resolution=3, duration=1.0,
                                  start_offset=0.0, progress=False, vtk_interval=None)
    assert summary["stationary"] is False
    # the deformation is flagged drifting on both walls (drift 6.7e-4 on the interpolated one, 7.6e-4 on the
    # staircase); strain_axial is borderline (flagged stationary on the interpolated wall, not on the staircase)
    assert not summary["stationary_observables"]["deformation"]["stationary"]
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert saved["stationary"] is False


def test_a_run_that_would_need_years_is_refused_before_any_file(tmp_path):
    out = tmp_path / "years"
    with pytest.raises(ParameterError, match="years") as error:
        elastocell.shear(out=out, capillary_number=0.1, resolution=12, duration=1e7, progress=False)
    assert error.value.parameter == "duration" and not out.exists()


def test_implausible_capillary_numbers_are_refused_or_warned():
    from elastocell.scenarios.pipe import PipeFlowParameters
    from elastocell.scenarios.shear import ShearFlowParameters

    with pytest.raises(ValueError, match="5/4 Ca"):
        ShearFlowParameters(capillary_number=1000)
    with pytest.warns(UserWarning, match="beyond the validated range"):
        ShearFlowParameters(capillary_number=3)
    with pytest.raises(ValueError, match="capillary_number_wall"):
        PipeFlowParameters(capillary_number_wall=1000)


def test_a_damaged_flow_checkpoint_is_one_line_naming_resume(tmp_path):
    options = dict(capillary_number=0.1, resolution=3, progress=False, vtk_interval=None)
    elastocell.shear(out=tmp_path, duration=0.2, **options)
    checkpoint = tmp_path / "checkpoint.npz"
    good = checkpoint.read_bytes()
    for damage in (good[: len(good) // 3], b"", b"garbage" * 100,
                   good[:200] + bytes(b ^ 0x5A for b in good[200:400]) + good[400:]):
        checkpoint.write_bytes(damage)
        with pytest.raises(ParameterError) as error:
            elastocell.shear(out=tmp_path, duration=0.4, resume=True, **options)
        message = str(error.value)
        assert error.value.parameter == "resume" and str(checkpoint) in message
        assert "allow_pickle" not in message and "pickle" not in message


@pytest.mark.parametrize("failing", ["metadata.json", "compression.png"])
def test_a_full_disk_names_the_file_and_leaves_nothing_that_looks_complete(tmp_path, monkeypatch, failing):
    """A write that fails (here ENOSPC, as a full disk gives; root ignores read-only permissions, so the error is
    injected) removes the result's other files and names the one that failed."""
    import errno

    import elastocell.files as files

    original = files.replace_atomically

    def replace_atomically(path, write):
        if path.name == failing:
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(path, write)

    monkeypatch.setattr(files, "replace_atomically", replace_atomically)
    with pytest.raises(OSError, match=failing) as error:
        elastocell.compress(out=tmp_path, **COARSE)
    assert error.value.errno == errno.ENOSPC
    left = sorted(p.name for p in tmp_path.iterdir())
    assert "compression.csv" not in left and "metadata.json" not in left and "compression.png" not in left


@pytest.mark.slow
def test_ctrl_c_on_the_command_line_exits_130_in_one_line_and_resume_finishes(tmp_path):
    import signal

    out = tmp_path / "run"
    command = [sys.executable, "-m", "elastocell", "compress", "--out", str(out), "--element", "p1", "--mesh-size",
               "0.4", "--pole-size", "0.2", "--delta-max", "0.6", "--steps", "200", "--quiet"]
    # 200 rows, so that the signal reaches a running curve (the poll below fails the test if it did not). A shell
    # that starts the suite in the background (``pytest &`` in a script) ignores SIGINT for it, and an ignored
    # signal is inherited: the child gets the terminal's disposition back, as a Ctrl-C at a prompt finds it
    process = subprocess.Popen(command, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 120
    while not (out / "checkpoint.npz").exists() and time.time() < deadline and process.poll() is None:
        time.sleep(0.01)
    assert process.poll() is None, "the curve finished before it could be interrupted"
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert len(stderr.strip().splitlines()) == 1 and "--resume" in stderr
    assert json.loads((out / "metadata.json").read_text())["interrupted"] is True
    finished = subprocess.run(command + ["--resume"], capture_output=True, text=True, timeout=300)
    assert finished.returncode == 0, finished.stderr
    rows = np.genfromtxt(out / "compression.csv", delimiter=",", names=True)
    assert len(rows) == 201 and rows["delta"][-1] == pytest.approx(0.6)


def test_a_study_directory_and_a_lut_in_use_are_refused(tmp_path):
    from elastocell.inverse.lut import compute_lut, runs_directory
    from elastocell.studies import run_studies

    with output_directory(tmp_path / "paper"):
        with pytest.raises(ParameterError, match="in use by process"):
            run_studies(["cell-models"], tmp_path / "paper", quick=True, workers=1)
    lut = tmp_path / "lut.txt"
    with output_directory(runs_directory(lut)):
        with pytest.raises(ParameterError, match="in use by process"):
            compute_lut(lut, channel_radius="10um", flow_rate="0.04uL/s", viscosity="15mPa*s", radii=[5],
                        moduli=[1000], quick=True, workers=1)


def test_progress_is_reported_in_plain_lines_when_output_is_not_a_terminal(tmp_path):
    command = [sys.executable, "-m", "elastocell", "compress", "--out", str(tmp_path / "run"), "--element", "p1",
               "--mesh-size", "0.5", "--pole-size", "0.25", "--delta-max", "0.3", "--steps", "6"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "delta 0.300 of 0.3 (100 %)" in result.stderr


def test_a_lock_whose_holder_went_silent_is_taken_over(tmp_path):
    """On a cluster the holder of a lock may have died with its node: another host's lock untouched for longer
    than STALE_AFTER is taken over (a live holder touches it every HEARTBEAT seconds)."""
    from elastocell.simulation import directory

    lock = tmp_path / LOCK_NAME
    lock.write_text(json.dumps({"pid": 1, "host": "another-node", "command": "x"}))
    with pytest.raises(ParameterError, match="in use by process 1 on another-node"):
        with output_directory(tmp_path):
            pass
    old = time.time() - directory.STALE_AFTER - 5
    os.utime(lock, (old, old))
    with pytest.warns(UserWarning, match="silent for more than"):
        with output_directory(tmp_path):
            assert json.loads(lock.read_text())["pid"] == os.getpid()


def test_two_runs_taking_over_the_same_stale_lock_do_not_both_hold_it(tmp_path, monkeypatch):
    """Two runs that judged the same lock stale (its process is gone; both judged before either acted): one takes
    it over, the other is refused, and the winner's fresh lock stays (a second run that unlinks the lock it
    judged would remove the winner's fresh lock, and both would run)."""
    import threading

    from elastocell.simulation import directory

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    lock = tmp_path / LOCK_NAME
    lock.write_text(json.dumps({"pid": dead.pid, "host": os.uname().nodename, "command": "x"}))
    judged, local, alive = threading.Barrier(2, timeout=10), threading.local(), directory._process_alive

    def process_alive(pid):  # both threads judge the stale lock before either acts; one acts 0.2 s later
        answer = alive(pid)
        if not getattr(local, "judged", False):
            local.judged = True
            if judged.wait() == 0:
                time.sleep(0.2)
        return answer

    monkeypatch.setattr(directory, "_process_alive", process_alive)
    entered, refused = [], []

    def take():
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                with output_directory(tmp_path):
                    entered.append(json.loads(lock.read_text())["pid"])
                    time.sleep(0.5)  # hold it while the other run looks
        except ParameterError:
            refused.append(True)

    threads = [threading.Thread(target=take) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert entered == [os.getpid()] and refused == [True]
    assert not lock.exists() and not list(tmp_path.glob("*takeover*"))


def test_a_sweep_task_waits_for_the_lock_of_its_dead_node_to_go_stale(tmp_path, monkeypatch):
    """A study or LUT task rescheduled after its node died meets that node's lock, still touched seconds ago: it
    waits until the lock is stale and takes it over, instead of being recorded failed. A lock of a live run on
    this host is still refused after that wait."""
    from elastocell.simulation import directory
    from elastocell.simulation.runner import resume_or_restart

    monkeypatch.setattr(directory, "HEARTBEAT", 0.1)
    monkeypatch.setattr(directory, "STALE_AFTER", 0.6)

    def simulate(out, resume, **options):
        with output_directory(out):
            return {"resume": resume, **options}

    (tmp_path / LOCK_NAME).write_text(json.dumps({"pid": 1, "host": "another-node", "command": "x"}))
    start = time.monotonic()
    with pytest.warns(UserWarning, match="silent for more than"):
        assert resume_or_restart(simulate, tmp_path, mesh_size=0.5) == {"resume": True, "mesh_size": 0.5}
    assert time.monotonic() - start >= 0.6
    with output_directory(tmp_path):  # this process is alive: its lock never goes stale
        with pytest.raises(ParameterError, match="in use by process"):
            resume_or_restart(simulate, tmp_path)


@pytest.mark.slow
def test_ctrl_c_in_a_flow_keeps_every_finished_record_and_resume_matches_an_uninterrupted_run(tmp_path):
    """SIGINT takes effect at the next record, with a checkpoint of that record (not only the periodic ones), so
    nothing finished is lost and the resumed series equals the uninterrupted one (the compiled steps are
    deterministic: compared to 1e-12)."""
    import signal

    common = ["--capillary-number", "0.1", "--resolution", "3", "--duration", "4", "--record-interval", "0.05",
              "--checkpoint-every", "7", "--vtk-interval", "1000", "--quiet"]
    whole = subprocess.run([sys.executable, "-m", "elastocell", "shear", "--out", str(tmp_path / "whole"), *common],
                           capture_output=True, text=True, timeout=600)
    assert whole.returncode == 0, whole.stderr
    out = tmp_path / "cut"
    process = subprocess.Popen([sys.executable, "-m", "elastocell", "shear", "--out", str(out), *common],
                               stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 600
    while not (out / "checkpoint.npz").exists() and time.time() < deadline and process.poll() is None:
        time.sleep(0.01)
    process.send_signal(signal.SIGINT)  # while the run is recording (its first periodic checkpoint is written)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    kept = np.genfromtxt(out / "timeseries.csv", delimiter=",", names=True)
    with np.load(out / "checkpoint.npz") as saved:
        assert len(saved["series_strain"]) == len(kept) < 81  # the checkpoint holds every record kept
    resumed = subprocess.run([sys.executable, "-m", "elastocell", "shear", "--out", str(out), *common, "--resume"],
                             capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    a = np.genfromtxt(tmp_path / "whole" / "timeseries.csv", delimiter=",", names=True)
    b = np.genfromtxt(out / "timeseries.csv", delimiter=",", names=True)
    assert len(a) == len(b) == 81
    for name in ("strain", "taylor_deformation", "inclination_deg", "centre_x"):
        np.testing.assert_allclose(b[name], a[name], rtol=1e-12, atol=1e-12)
