"""Dask clusters. The local cluster elastocell starts listens on 127.0.0.1 only and serves no dashboard (no HTTP
pages at all) unless asked. A real cluster (``dask scheduler`` and two ``dask worker`` processes, reached
through ``scheduler=``) runs a study and a LUT, loses a worker to SIGKILL in the middle of the sweep, keeps
every run that had finished (files untouched), has the lost runs computed again by the surviving worker, and
gives the numbers of the same runs computed in this process. A TLS scheduler is reached with ``security`` or with Dask's own
configuration (the ``DASK_DISTRIBUTED__COMM__TLS__*`` environment variables)."""

from __future__ import annotations

import datetime
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from elastocell.parameters.units import ParameterError
from elastocell.simulation.distributed import dask_client, run_tasks

LOCAL = "127.0.0.1"


def _http_status(port: int, path: str) -> int:
    try:
        return urllib.request.urlopen(f"http://{LOCAL}:{port}/{path}", timeout=10).status
    except urllib.error.HTTPError as error:
        return error.code


def _listening_ports(pids: set[int]) -> list[tuple[str, int]]:
    """(address, port) of every TCP socket the processes ``pids`` listen on (Linux: /proc/net/tcp*)."""
    inodes = set()
    for pid in pids:
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
    found = []
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        if not Path(table).exists():
            continue
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] != "0A" or fields[9] not in inodes:  # 0A: LISTEN
                continue
            hex_address, hex_port = fields[1].split(":")
            if width == 8:
                address = ".".join(str(b) for b in bytes.fromhex(hex_address)[::-1])
            else:
                address = "::" if int(hex_address, 16) == 0 else hex_address
            found.append((address, int(hex_port, 16)))
    return found


def test_a_local_cluster_listens_on_localhost_only_and_has_no_dashboard():
    with dask_client(workers=2) as client:
        info = client.scheduler_info()
        assert info["address"].startswith(f"tcp://{LOCAL}:")
        assert client.cluster.scheduler_address == info["address"]
        assert len(info["workers"]) == 2
        for address, worker in info["workers"].items():
            assert address.startswith(f"tcp://{LOCAL}:") and worker["nanny"].startswith(f"tcp://{LOCAL}:")
        pids = {os.getpid()} | {pid for pid in client.run(os.getpid).values()}
        sockets = _listening_ports(pids)
        assert sockets and {address for address, _ in sockets} == {LOCAL}, sockets
        # Dask's nodes always run an HTTP server; it serves nothing: no dashboard, no cluster pages, no metrics
        http = [info["services"]["dashboard"]] + [w["services"]["dashboard"] for w in info["workers"].values()]
        assert 8787 not in http
        for port in http:
            assert {_http_status(port, path) for path in ("status", "health", "metrics", "info/main/workers.html",
                                                          "json/counts.json")} == {404}
        assert dict(run_tasks(math.sqrt, [4.0, 9.0], client=client)) == {0: 2.0, 1: 3.0}
    with dask_client(workers=1, dashboard=True) as client:  # asked for: on 127.0.0.1, a free port
        port = client.scheduler_info()["services"]["dashboard"]
        assert client.dashboard_link.startswith(f"http://{LOCAL}:")
        assert _http_status(port, "health") == 200
    with pytest.raises(ParameterError, match="dashboard"):
        with dask_client(workers=1, dashboard=8787):
            pass


# =========================================================================== a real cluster
def _dask(*arguments) -> list[str]:
    return [sys.executable, "-m", "dask", *arguments]


class Cluster:
    """``dask scheduler`` and single-threaded ``dask worker`` processes (no nanny: the process is the worker) on
    127.0.0.1, each started with subprocess.Popen and stopped by the finaliser whatever happens."""

    def __init__(self, directory: Path, finalizer, tls: list[str] | None = None):
        directory.mkdir(parents=True, exist_ok=True)
        self.directory, self.scheduler_file = directory, directory / "scheduler.json"
        self.environment = {**os.environ, **{name: "1" for name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS",
                                                                    "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")}}
        self.processes: list[subprocess.Popen] = []
        self.workers: dict[str, subprocess.Popen] = {}
        self.logs = []
        finalizer(self.stop)
        self.tls = ["--protocol", "tls", *tls] if tls else []
        # --no-dashboard alone leaves Dask's HTTP server (metrics, cluster pages) on 0.0.0.0 (the scheduler's on
        # port 8787): --dashboard-address puts it on 127.0.0.1 with the rest
        scheduler = self._start("scheduler", _dask("scheduler", "--host", LOCAL, "--port", "0", *self.tls,
                                                   "--scheduler-file", str(self.scheduler_file), "--no-dashboard",
                                                   "--dashboard-address", f"{LOCAL}:0"))
        deadline = time.monotonic() + 60
        while not self.scheduler_file.exists():
            assert time.monotonic() < deadline and scheduler.poll() is None, self.log("scheduler")
            time.sleep(0.1)
        time.sleep(0.2)  # written in one piece, but give the writer its moment
        self.address = json.loads(self.scheduler_file.read_text())["address"]

    def log(self, name: str) -> str:
        return (self.directory / f"{name}.log").read_text()

    def _start(self, name: str, arguments: list[str]) -> subprocess.Popen:
        log = open(self.directory / f"{name}.log", "w")  # noqa: SIM115 - written by the process until it ends
        self.logs.append(log)
        process = subprocess.Popen(arguments, stdout=log, stderr=subprocess.STDOUT, cwd=self.directory,
                                   env=self.environment)
        self.processes.append(process)
        return process

    def add_worker(self) -> None:
        name = f"worker-{len(self.workers)}"
        self.workers[name] = self._start(name, _dask(
            "worker", "--scheduler-file", str(self.scheduler_file), "--nthreads", "1", "--no-dashboard",
            "--dashboard-address", f"{LOCAL}:0", "--host", LOCAL, "--no-nanny", "--name", name, *self.tls))

    def alive(self) -> list[str]:
        return [name for name, process in self.workers.items() if process.poll() is None]

    def stop(self) -> None:  # the workers first: a worker whose scheduler has gone keeps trying to reach it
        for process in reversed(self.processes):
            if process.poll() is None:
                process.terminate()
            try:
                process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        for log in self.logs:
            log.close()


def _client(cluster: Cluster, workers: int, security=None):
    """A client of ``cluster`` once ``workers`` workers have joined."""
    from distributed import Client

    client = Client(cluster.address, timeout="30s", security=security)
    try:
        client.wait_for_workers(workers, timeout=120)
    except BaseException:
        client.close()
        raise
    return client


@dataclass
class Kill:
    """What the killer thread saw: the runs finished before the kill (their files' stamps), the worker killed,
    the tasks it was running, and where the scheduler ran them next."""

    marker: str
    finished: dict = field(default_factory=dict)  # run directory -> {file: (mtime_ns, size)}
    started: set = field(default_factory=set)  # run directories that existed, unfinished, at the kill
    victim: str = ""
    survivor: str = ""
    lost: list = field(default_factory=list)  # task keys processing on the victim at the kill
    rerun_on: dict = field(default_factory=dict)  # key -> worker address that ran it after the kill
    suspicious: dict = field(default_factory=dict)  # key -> the scheduler's count of workers lost running it
    time_ns: int = 0
    error: BaseException | None = None


def _kill_after_first_finished(cluster: Cluster, runs: Path, kill: Kill) -> None:
    """Wait for the first finished run in ``runs``, SIGKILL a worker that is running a task, then follow the
    lost tasks on the scheduler until another worker has run them."""
    from distributed import Client

    def fate(dask_scheduler, keys):  # on the scheduler (nested: sent by value, this module is not there)
        found = {}
        for key in keys:
            task = dask_scheduler.tasks.get(key)
            if task is not None:
                found[key] = (task.state, task.processing_on.address if task.processing_on else None,
                              [worker.address for worker in (task.who_has or ())], task.suspicious)
        return found

    try:
        with Client(cluster.address, timeout="30s") as client:
            deadline = time.monotonic() + 150
            while not list(runs.glob(f"*/{kill.marker}")):
                assert time.monotonic() < deadline, "no run finished"
                time.sleep(0.05)
            for _ in range(200):
                processing = {address: keys for address, keys in client.processing().items() if keys}
                if processing:
                    break
                time.sleep(0.02)
            assert processing, "no worker was running a task after the first run finished"
            workers = client.scheduler_info()["workers"]
            victim = sorted(processing)[0]
            kill.victim, kill.lost = victim, list(processing[victim])
            kill.survivor = next(address for address in workers if address != victim)
            for directory in runs.iterdir():
                if (directory / kill.marker).exists():
                    kill.finished[directory.name] = {p.name: (p.stat().st_mtime_ns, p.stat().st_size)
                                                     for p in directory.iterdir()}
                else:
                    kill.started.add(directory.name)
            kill.time_ns = time.time_ns()
            process = cluster.workers[workers[victim]["name"]]
            os.kill(process.pid, signal.SIGKILL)
            process.wait(timeout=30)  # reaped, as its parent would: a zombie still counts as a running process
            deadline = time.monotonic() + 150
            while set(kill.rerun_on) < set(kill.lost) and time.monotonic() < deadline:
                for key, (_, on, holders, suspicious) in client.run_on_scheduler(fate, keys=kill.lost).items():
                    kill.suspicious[key] = max(suspicious, kill.suspicious.get(key, 0))
                    where = on or (holders[0] if holders else None)
                    if where is not None and where != victim:
                        kill.rerun_on[key] = where
                time.sleep(0.05)
    except BaseException as error:  # noqa: BLE001 - reported by the test
        kill.error = error


def _assert_kept_and_recomputed(kill: Kill, runs: Path, expected: int) -> None:
    assert kill.error is None, repr(kill.error)
    assert kill.finished, "the kill came before any run finished"
    finished = sorted(p.parent.name for p in runs.glob(f"*/{kill.marker}"))
    assert len(finished) == expected
    for name, stamps in kill.finished.items():  # kept: not one file written again
        assert {p.name: (p.stat().st_mtime_ns, p.stat().st_size) for p in (runs / name).iterdir()} == stamps, name
    for name in set(finished) - set(kill.finished):  # finished after the kill, by the survivor
        assert (runs / name / kill.marker).stat().st_mtime_ns > kill.time_ns, name
    assert kill.lost and set(kill.rerun_on) == set(kill.lost), (kill.lost, kill.rerun_on)
    assert set(kill.rerun_on.values()) == {kill.survivor}
    assert max(kill.suspicious.values()) >= 1  # the scheduler saw the task die with its worker


@pytest.fixture(scope="module")
def cluster(tmp_path_factory, request):
    """One scheduler for the module's tests; each test starts workers up to two (the previous test killed one)."""
    return Cluster(tmp_path_factory.mktemp("cluster"), request.addfinalizer)


def _two_workers(cluster: Cluster) -> None:
    while len(cluster.alive()) < 2:
        cluster.add_worker()
    with _client(cluster, 2) as client:
        assert sorted(w["name"] for w in client.scheduler_info()["workers"].values()) == sorted(cluster.alive())
    # the scheduler's and the workers' HTTP servers (no dashboard) listen on 127.0.0.1 like everything else
    processes = [cluster.processes[0]] + [cluster.workers[name] for name in cluster.alive()]
    assert {address for address, _ in _listening_ports({p.pid for p in processes})} == {LOCAL}


@pytest.fixture
def cluster_study(monkeypatch):
    """Four coarse compression runs (gamma 2 and 5, each with its equivalent homogeneous cell) as a study."""
    from elastocell.studies import STUDIES
    from elastocell.studies.base import Member, Run, Study
    from elastocell.studies.compression import claims_stiffness, plot_stiffness, tidy

    options = {"element": "p1", "mesh_size": 0.6, "pole_size": 0.6, "steps": 6, "delta_max": 0.3, "vtk": False}

    def members(quick):
        out = []
        for gamma in (2, 5):
            labels = {"series": "stiffness", "cell": f"gamma {gamma}", "pair": f"gamma {gamma}",
                      "stiffness_ratio": float(gamma), "size_ratio": 0.5}
            out += [Member(Run.of("compress", **options, stiffness_ratio=gamma), {**labels, "equivalent": False}),
                    Member(Run.of("compress", **options, stiffness_ratio=gamma, equivalent=True),
                           {**labels, "equivalent": True})]
        return out

    study = Study("cluster", "cluster", "fig-none", "four coarse curves", members, tidy, plot_stiffness,
                  claims_stiffness)
    monkeypatch.setitem(STUDIES, "cluster", study)
    return study


def _sweep_with_a_kill(cluster: Cluster, runs: Path, marker: str, sweep) -> Kill:
    """Run ``sweep()`` on the cluster while a thread kills a busy worker once the first run has finished."""
    _two_workers(cluster)
    alive = cluster.alive()
    runs.mkdir(parents=True, exist_ok=True)
    kill = Kill(marker)
    killer = threading.Thread(target=_kill_after_first_finished, args=(cluster, runs, kill), daemon=True)
    killer.start()
    try:
        sweep()
    finally:
        killer.join(timeout=60)
    assert not killer.is_alive()
    (killed,) = set(alive) - set(cluster.alive())
    assert cluster.workers[killed].returncode == -signal.SIGKILL
    return kill


class _InProcess:
    """A client that runs each task here, at once: the local reference, without a cluster."""

    def submit(self, function, *args, pure=False):
        from concurrent.futures import Future

        future = Future()
        future.set_result(function(*args))
        return future


@pytest.mark.slow
def test_a_study_on_a_cluster_survives_a_killed_worker(cluster, cluster_study, tmp_path):
    from elastocell.studies import run_studies
    from elastocell.studies.base import execute_run, read_study_table

    out = tmp_path / "cluster-out"
    summaries = []
    kill = _sweep_with_a_kill(cluster, out / "runs", "run.json", lambda: summaries.append(
        run_studies(["cluster"], out, quick=True, scheduler=cluster.address)))
    assert summaries[0]["_failures"] == []
    _assert_kept_and_recomputed(kill, out / "runs", 4)
    # the same runs in this process; the study then reads them back (no cluster) and must give the same table
    local = tmp_path / "local-out"
    for member in cluster_study.members(True):
        execute_run((member.run, str(local / "runs")))
    assert run_studies(["cluster"], local, quick=True)["_failures"] == []
    here, _ = read_study_table(out, "cluster")
    there, _ = read_study_table(local, "cluster")
    assert len(here) == len(there) > 4 and here["force_per_Ec_R2"].notna().all()
    pd.testing.assert_frame_equal(here.drop(columns="wall_time_s"), there.drop(columns="wall_time_s"),
                                  check_exact=False, rtol=1e-10, atol=1e-14)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:.*not stationary:UserWarning")  # 0.3 units of time: a transient, on purpose
def test_a_lut_on_a_cluster_survives_a_killed_worker(cluster, tmp_path, monkeypatch):
    import distributed

    from elastocell.inverse.lut import compute_lut, read_lut
    from elastocell.scenarios.shear import compile_kernels

    compile_kernels(("float32",))  # the workers load the kernels from the shared cache instead of compiling
    arguments = dict(channel_radius="10um", flow_rate="0.04uL/s", viscosity="15mPa*s", radii="5um",
                     moduli="1kPa,2kPa,3kPa", quick=True, duration=0.3)
    out = tmp_path / "cluster-lut" / "lut.txt"
    results = []
    kill = _sweep_with_a_kill(cluster, out.parent / "lut_runs", "point.json", lambda: results.append(
        compute_lut(out, scheduler=cluster.address, **arguments)))
    assert results[0]["failures"] == []
    _assert_kept_and_recomputed(kill, out.parent / "lut_runs", 3)
    # the same points in this process
    local = tmp_path / "local-lut" / "lut.txt"
    monkeypatch.setattr(distributed, "as_completed", lambda futures: list(futures))
    assert compute_lut(local, client=_InProcess(), **arguments)["failures"] == []
    here, there = read_lut(out)[0], read_lut(local)[0]
    # the 3 computed points and the 2 x 7 rows interpolated between them (--subdivisions 8, the default)
    assert here.shape == there.shape == (17, 3) and np.all(np.isfinite(here))
    np.testing.assert_allclose(here, there, rtol=1e-10, atol=0)


# =========================================================================== TLS
def _self_signed(directory: Path) -> tuple[Path, Path]:
    """A self-signed certificate for 127.0.0.1 (its own CA) and its key, as PEM files."""
    import ipaddress

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "elastocell test")])
    now = datetime.datetime.now(datetime.timezone.utc)
    certificate = (x509.CertificateBuilder().subject_name(name).issuer_name(name).public_key(key.public_key())
                   .serial_number(x509.random_serial_number()).not_valid_before(now - datetime.timedelta(minutes=5))
                   .not_valid_after(now + datetime.timedelta(days=1))
                   .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
                   .add_extension(x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address(LOCAL))]),
                                  critical=False)
                   .sign(key, hashes.SHA256()))
    cert_path, key_path = directory / "cert.pem", directory / "key.pem"
    cert_path.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))
    return cert_path, key_path


@pytest.mark.slow
def test_a_tls_cluster_takes_security_or_dask_configuration(tmp_path, request):
    pytest.importorskip("cryptography")
    from distributed import Security

    cert, key = _self_signed(tmp_path)
    files = ["--tls-ca-file", str(cert), "--tls-cert", str(cert), "--tls-key", str(key)]
    started = Cluster(tmp_path / "cluster", request.addfinalizer, tls=files)
    started.add_worker()
    assert started.address.startswith(f"tls://{LOCAL}:")
    security = Security(tls_ca_file=str(cert), tls_client_cert=str(cert), tls_client_key=str(key),
                        require_encryption=True)
    _client(started, 1, security=security).close()
    assert dict(run_tasks(math.sqrt, [4.0, 9.0], scheduler=started.address, security=security)) == {0: 2.0, 1: 3.0}
    # without the files: refused, not connected in the clear
    with pytest.raises(ParameterError, match="TLS"):
        with dask_client(started.address):
            pass
    # the files from Dask's configuration, as the command line's --scheduler tls://... takes them
    environment = {**os.environ, "DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(cert),
                   "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(cert),
                   "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": str(key)}
    code = ("import math, sys; from elastocell.simulation.distributed import run_tasks; "
            "print(dict(run_tasks(math.sqrt, [16.0], scheduler=sys.argv[1])))")
    done = subprocess.run([sys.executable, "-c", code, started.address], env=environment, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "{0: 4.0}"
    # the local cluster takes security too: throwaway certificates, still on 127.0.0.1 only
    with dask_client(workers=1, security=Security.temporary()) as client:
        assert client.scheduler_info()["address"].startswith(f"tls://{LOCAL}:")
        assert dict(run_tasks(math.sqrt, [25.0], client=client)) == {0: 5.0}


def test_task_progress_is_plain_lines_when_output_is_not_a_terminal(capsys):
    """Under pytest's capture standard error is not a terminal (as in a log file or a batch job): run_tasks writes
    a line when the tasks start, one per finished task at most every PLAIN_PROGRESS_INTERVAL seconds, and one at
    the end, instead of rich's bar, which prints nothing there."""
    with dask_client(workers=1) as client:
        assert dict(run_tasks(math.sqrt, [4.0, 9.0, 16.0], client=client, progress=True, description="roots")) == {
            0: 2.0, 1: 3.0, 2: 4.0}
    lines = [line.rsplit(",", 1)[0] for line in capsys.readouterr().err.splitlines() if line.startswith("roots: ")]
    assert lines == ["roots: tasks finished: 0 of 3 (0 %)", "roots: tasks finished: 3 of 3 (100 %)"]
