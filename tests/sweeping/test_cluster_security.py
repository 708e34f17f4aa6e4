"""Who can reach a distributed sweep: a ``--workers`` cluster listens on loopback only, and a ``tls://`` scheduler is
reached with certificates (self-signed here), or refused in one line without them."""

import ipaddress
import shutil
import subprocess
import sys
import time

import psutil
import pytest

from tests.helpers import HERTZIAN, assert_refused, invoke
from tests.helpers.sweeps import GRID_SWEEP

SLOW_SWEEP = """
[scene.chain]
grains = 64

[scene.excitation]
impact = 1e-2

[scene.integrator]
method = "verlet"
dt = 1e-4
duration = 20.0

[scene.record]
every = 1.0

[[axis]]
name = "v_imp"
key = "excitation.impact"
logspace = [-3, -1, 8]
"""


def listeners(process: psutil.Process) -> set[tuple[str, int]]:
    """(address, port) of every listening TCP socket of ``process`` and its descendants."""
    found = set()
    for proc in [process, *process.children(recursive=True)]:
        try:
            connections = proc.net_connections(kind="inet")
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        found |= {(c.laddr.ip, c.laddr.port) for c in connections if c.status == psutil.CONN_LISTEN}
    return found


def test_a_workers_sweep_listens_on_loopback_only(tmp_path):
    sweep = tmp_path / "slow.toml"
    sweep.write_text(SLOW_SWEEP)
    out = tmp_path / "slow.zarr"
    args = [*HERTZIAN, "sweep", str(sweep), "--out", str(out), "--workers", "2", "--device", "cpu", "--quiet"]
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen: set[tuple[str, int]] = set()
    try:
        parent = psutil.Process(process.pid)
        deadline = time.monotonic() + 240
        while process.poll() is None and time.monotonic() < deadline:
            seen |= listeners(parent)
            time.sleep(0.2)
    finally:
        if process.poll() is None:
            process.kill()
        stdout, stderr = process.communicate()
    assert process.returncode == 0, stderr
    # the scheduler, two nannies and two workers (each worker also has its HTTP server) were seen listening
    assert len(seen) >= 5, seen
    outside = {(ip, port) for ip, port in seen if not ipaddress.ip_address(ip).is_loopback}
    assert not outside, f"listeners beyond loopback: {sorted(outside)}"


def make_certificates(folder):
    """A self-signed CA and one certificate it signs for 127.0.0.1 (used by scheduler, workers and client)."""
    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.fail("openssl is needed to make the test certificates")

    def run(*args):
        subprocess.run([openssl, *args], check=True, capture_output=True, cwd=folder)

    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
        "-subj", "/CN=hertzian test CA")  # fmt: skip
    run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "node.key", "-out", "node.csr", "-subj", "/CN=127.0.0.1")
    (folder / "ext.cnf").write_text("subjectAltName = IP:127.0.0.1\n")
    run("x509", "-req", "-in", "node.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial", "-out", "node.pem",
        "-days", "2", "-extfile", "ext.cnf")  # fmt: skip
    return folder / "ca.pem", folder / "node.pem", folder / "node.key"


def dask(*args) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_" + args[0], *args[1:]])


def test_a_tls_scheduler_is_reached_with_certificates(tmp_path):
    ca, cert, key = make_certificates(tmp_path)
    tls = ("--tls-ca-file", ca, "--tls-cert", cert, "--tls-key", key)
    scheduler_file = tmp_path / "scheduler.json"
    scheduler = dask(
        "scheduler", "--host", "127.0.0.1", "--protocol", "tls", "--port", "0", "--no-dashboard",
        "--scheduler-file", str(scheduler_file), *map(str, tls),
    )  # fmt: skip
    worker = None
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        import json

        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tls://127.0.0.1:")
        worker = dask("worker", address, "--host", "127.0.0.1", "--nworkers", "1", "--nthreads", "1",
                      "--no-dashboard", *map(str, tls))  # fmt: skip
        sweep = tmp_path / "sweep.toml"
        sweep.write_text(GRID_SWEEP)
        out = tmp_path / "tls.zarr"
        result = invoke("sweep", sweep, "--out", out, "--scheduler", address, "--device", "cpu", "--quiet", *tls)
        assert result.exit_code == 0, (result.stderr, result.exception)
        assert out.exists()
        # without certificates: one line, nothing written
        bare = tmp_path / "bare.zarr"
        result = invoke("sweep", sweep, "--out", bare, "--scheduler", address, "--device", "cpu")
        assert_refused(result, bare, "--scheduler")
        assert "needs certificates" in result.stderr
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.terminate()
                process.wait(30)


def test_tls_files_without_a_tls_scheduler_are_refused(tmp_path):
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(GRID_SWEEP)
    out = tmp_path / "out.zarr"
    ca = tmp_path / "ca.pem"
    ca.write_text("")
    result = invoke("sweep", sweep, "--out", out, "--workers", "2", "--tls-ca-file", ca, "--tls-cert", ca)
    assert_refused(result, out, "--tls-ca-file")
    result = invoke("sweep", sweep, "--out", out, "--scheduler", "tls://127.0.0.1:1", "--tls-ca-file", ca)
    assert_refused(result, out, "--tls-cert")


def test_a_peer_that_is_not_a_scheduler_is_refused_in_one_line(tmp_path):
    """A loopback listener that answers as a web server would: Dask reads "HTTP/1.1" as a frame count of 3.5e18 and
    fails to allocate it. One line, exit 2, nothing written. The listener serves one connection and stops."""
    import socket
    import threading

    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(30)

    def answer_garbage():
        try:
            peer, _ = server.accept()
            peer.settimeout(30)
            with peer:
                peer.sendall(b"HTTP/1.1 403 Forbidden\r\nContent-Length: 0\r\n\r\n")
                peer.recv(1024)
        except OSError:
            pass
        finally:
            server.close()

    thread = threading.Thread(target=answer_garbage, daemon=True)
    thread.start()
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(GRID_SWEEP)
    out = tmp_path / "out.zarr"
    result = invoke("sweep", sweep, "--out", out, "--scheduler", f"tcp://127.0.0.1:{server.getsockname()[1]}")
    assert_refused(result, out, "--scheduler")
    assert "cannot connect" in result.stderr
    thread.join(30)
