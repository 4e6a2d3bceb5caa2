"""A scheduler that is not Dask: real servers on the loopback, a deadline kept, one line, signals that work.

Each server is a real one on 127.0.0.1: a web server, a socket that
accepts and never speaks, and one that closes every connection at once.
``rollsim sweep --scheduler`` pointed at each must stop within its
``--connect-timeout`` with one line naming the address and what answered,
and leave no output directory; SIGTERM and SIGINT must stop it at any
moment of the wait.
"""

from __future__ import annotations

import http.server
import signal
import socket
import threading
import time

import pytest

from rollsim.errors import RollsimError, SystemFailure
from rollsim.sweeps.scheduler import connect_timeout_s, parse_scheduler_address, probe_scheduler
from clitools import assert_one_error, run_rollsim, start_rollsim, wait_for

SWEEP = ["sweep", "paper-default", "--grid", "link.distance_cm=5,10", "--quiet"]


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # the test's output stays readable
        pass


@pytest.fixture
def web_server():
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Quiet)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def _socket_server(on_accept):
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    accepted: list = []
    stop = threading.Event()

    def serve():
        listener.settimeout(0.2)
        while not stop.is_set():
            try:
                connection, _ = listener.accept()
            except (socket.timeout, OSError):
                continue
            accepted.append(connection)
            on_accept(connection)

    threading.Thread(target=serve, daemon=True).start()
    return listener, accepted, stop


class _Address(str):
    """A server's address, with the connections it has accepted."""

    accepted: list


@pytest.fixture
def silent_server():
    listener, accepted, stop = _socket_server(lambda connection: None)
    address = _Address(f"tcp://127.0.0.1:{listener.getsockname()[1]}")
    address.accepted = accepted
    yield address
    stop.set()
    for connection in accepted:
        connection.close()
    listener.close()


@pytest.fixture
def closing_server():
    listener, _, stop = _socket_server(lambda connection: connection.close())
    yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    stop.set()
    listener.close()


@pytest.mark.parametrize("server, answer", [("web_server", "a web server answered (HTTP/1.0 "),
                                            ("silent_server", "said nothing within 2 s"),
                                            ("closing_server", "closed it without a word")])
def test_a_server_that_is_not_dask_is_named_within_the_deadline(tmp_path, request, server, answer):
    address = request.getfixturevalue(server)
    result = run_rollsim(*SWEEP, "--out", "out", "--scheduler", address, "--connect-timeout", "2", cwd=tmp_path)
    assert_one_error(result, 1, address, answer, "not a Dask scheduler")
    assert result.seconds < 2 + 8  # the deadline, plus a Python start-up on a loaded machine
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("address, fragment", [
    ("http://127.0.0.1:8787", "a web page's"),
    ("garbage:::x", "expected tcp://HOST:PORT"),
    ("ftp://host:21", "unknown scheme 'ftp'"),
    ("tcp://:8786", "no host name"),
    ("tcp://host:99999", "not a number from 1 to 65535"),
])
def test_an_address_that_cannot_be_a_scheduler_is_refused_at_once(tmp_path, address, fragment):
    result = run_rollsim(*SWEEP, "--out", "out", "--scheduler", address, cwd=tmp_path)
    assert_one_error(result, 2, fragment)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_stops_the_wait_for_a_silent_scheduler(tmp_path, silent_server, sig):
    process = start_rollsim(*SWEEP, "--out", "out", "--scheduler", silent_server, "--connect-timeout", "120",
                            cwd=tmp_path)
    # Connected (the command's signal handlers are set before it connects):
    # now waiting on the silent peer, however long start-up took.
    wait_for(lambda: silent_server.accepted, timeout=60)
    time.sleep(0.5)
    assert process.poll() is None
    process.send_signal(sig)
    start = time.perf_counter()
    _, err = process.communicate(timeout=30)
    assert time.perf_counter() - start < 5
    assert process.returncode == 128 + sig
    assert err.splitlines() == [f"rollsim: stopped by {signal.Signals(sig).name}; nothing was written"]
    assert list(tmp_path.iterdir()) == []


def test_the_deadline_comes_from_the_environment_and_is_checked(monkeypatch):
    monkeypatch.setenv("ROLLSIM_CONNECT_TIMEOUT", "2.5")
    assert connect_timeout_s() == 2.5
    assert connect_timeout_s(4) == 4.0
    monkeypatch.setenv("ROLLSIM_CONNECT_TIMEOUT", "soon")
    with pytest.raises(RollsimError, match=r"\$ROLLSIM_CONNECT_TIMEOUT = 'soon'"):
        connect_timeout_s()
    for bad in (0.0, -1.0, float("nan"), float("inf"), 1e9):
        with pytest.raises(RollsimError, match="--connect-timeout"):
            connect_timeout_s(bad)


def test_a_bad_deadline_on_the_command_line_is_one_line(tmp_path):
    result = run_rollsim(*SWEEP, "--out", "out", "--scheduler", "tcp://127.0.0.1:1", "--connect-timeout", "nan",
                         cwd=tmp_path)
    assert_one_error(result, 2, "--connect-timeout = nan")


def test_addresses_are_split_as_dask_writes_them():
    assert parse_scheduler_address("tcp://10.0.0.1:8786").url == "tcp://10.0.0.1:8786"
    assert parse_scheduler_address("10.0.0.1").url == "tcp://10.0.0.1:8786"
    assert parse_scheduler_address("TLS://head:9000/").url == "tls://head:9000"
    assert parse_scheduler_address("tcp://[::1]:8786").url == "tcp://[::1]:8786"


def test_the_probe_accepts_a_peer_that_greets_in_binary():
    # Dask's greeting starts with a little-endian length: binary, at once.
    listener, _, stop = _socket_server(lambda connection: connection.sendall(b"\x01\x00\x00\x00\x00\x00\x00\x00"))
    try:
        probe_scheduler(parse_scheduler_address(f"tcp://127.0.0.1:{listener.getsockname()[1]}"), 2.0)
    finally:
        stop.set()
        listener.close()


def test_the_probe_names_a_text_banner():
    listener, _, stop = _socket_server(lambda connection: connection.sendall(b"SSH-2.0-OpenSSH_9.2\r\n"))
    try:
        with pytest.raises(SystemFailure, match="it answered 'SSH-2.0-OpenSSH_9.2'"):
            probe_scheduler(parse_scheduler_address(f"tcp://127.0.0.1:{listener.getsockname()[1]}"), 2.0)
    finally:
        stop.set()
        listener.close()


def test_a_second_signal_ends_a_clean_up_that_hangs(tmp_path):
    # A clean-up that never ends (a teardown waiting on a peer that is gone):
    # the first SIGTERM starts it, the second ends the process at once.
    script = tmp_path / "hang.py"
    script.write_text(
        "import os, signal, sys, time\n"
        "from rollsim.plumbing import signals\n"
        "from rollsim.errors import Interrupted\n"
        "signals.install_handlers()\n"
        "try:\n"
        "    print('ready', flush=True)\n"
        "    time.sleep(60)\n"
        "except Interrupted:\n"
        "    print('cleaning', flush=True)\n"
        "    time.sleep(60)\n"
        "sys.exit(0)\n")
    import subprocess
    import sys

    process = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "ready"
    process.send_signal(signal.SIGTERM)
    assert process.stdout.readline().strip() == "cleaning"
    start = time.perf_counter()
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=10)
    assert time.perf_counter() - start < 2
    assert process.returncode == 128 + signal.SIGINT
    assert err.splitlines() == ["rollsim: stopped by SIGINT again during clean-up; exiting now"]


def test_the_dashboard_link_is_given_only_when_its_page_is_served(tmp_path):
    import functools
    import importlib.util
    import types

    from distributed import Client, LocalCluster

    from rollsim.sweeps.engine import dashboard_link

    (tmp_path / "status").write_text("<html>Bokeh Application</html>")
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(_Quiet, directory=str(tmp_path)))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        base = f"http://127.0.0.1:{server.server_address[1]}"
        assert dashboard_link(types.SimpleNamespace(dashboard_link=f"{base}/status")) == f"{base}/status"
        assert dashboard_link(types.SimpleNamespace(dashboard_link=f"{base}/nothing/here")) is None
        assert dashboard_link(types.SimpleNamespace(dashboard_link=None)) is None
    finally:
        server.shutdown()
        server.server_close()
    if importlib.util.find_spec("bokeh") is None:
        # A real scheduler without bokeh serves a page that asks for it.
        with LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as cluster, \
                Client(cluster, set_as_default=False) as client:
            assert dashboard_link(client) is None


def test_a_dask_scheduler_without_workers_is_named_within_the_deadline(tmp_path):
    import json
    import subprocess
    import sys

    scheduler_file = tmp_path / "scheduler.json"
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--scheduler-file",
                                  str(scheduler_file), "--host", "127.0.0.1", "--port", "0", "--dashboard-address",
                                  ":0"], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: scheduler_file.exists() and "address" in scheduler_file.read_text(), timeout=60)
        address = json.loads(scheduler_file.read_text())["address"]
        work = tmp_path / "work"
        work.mkdir()
        result = run_rollsim(*SWEEP, "--out", "out", "--scheduler", address, "--connect-timeout", "2", cwd=work)
        assert_one_error(result, 1, f"--scheduler {address}: no worker joined it within 2 s",
                         f"dask worker {address}")
        assert list(work.iterdir()) == []
    finally:
        scheduler.terminate()
        scheduler.wait(timeout=30)


def test_a_sweep_whose_workers_all_leave_stops_within_the_deadline(tmp_path):
    import json
    import subprocess
    import sys

    def dask(*args):
        return subprocess.Popen([sys.executable, "-m", *args], cwd=tmp_path, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)

    scheduler_file = tmp_path / "scheduler.json"
    scheduler = dask("distributed.cli.dask_scheduler", "--scheduler-file", str(scheduler_file), "--host", "127.0.0.1",
                     "--port", "0", "--dashboard-address", ":0")
    worker = None
    try:
        wait_for(lambda: scheduler_file.exists() and "address" in scheduler_file.read_text(), timeout=60)
        address = json.loads(scheduler_file.read_text())["address"]
        worker = dask("distributed.cli.dask_worker", address, "--nthreads", "1", "--nworkers", "1", "--no-nanny")
        work = tmp_path / "work"
        work.mkdir()
        process = start_rollsim("sweep", "paper-default", "--grid", "link.distance_cm=5:30:5", "--stage", "run",
                                "--frames", "30", "--quiet", "--out", "out", "--scheduler", address,
                                "--connect-timeout", "3", cwd=work)
        wait_for(lambda: (work / "out" / "sweep.yaml").exists(), timeout=90)  # connected, cells submitted
        time.sleep(1)
        worker.kill()
        worker.wait()
        start = time.perf_counter()
        _, err = process.communicate(timeout=60)
        assert time.perf_counter() - start < 3 + 15  # the deadline, the poll and a loaded machine's slack
        assert_one_error(err, 1, "the cluster has had no worker for 3 s (--connect-timeout): its workers left after")
        assert process.returncode == 1
    finally:
        for part in (worker, scheduler):
            if part is not None and part.poll() is None:
                part.terminate()
                part.wait(timeout=30)
