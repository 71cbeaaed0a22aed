"""lumo serve with remote render workers run as Ray actors (lumo.ray.serve_workers) on a local
three-node cluster: a viewer receives samples from both workers, and keeps receiving while one
is killed and restarted by Ray."""

import base64
import json
import os
import re
import signal
import socket
import subprocess
import threading
import time
import urllib.request

import pytest

ray = pytest.importorskip("ray")

from lumo.ray.serve import serve_workers  # noqa: E402

from conftest import lumo_bin  # noqa: E402


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Viewer:
    """A WebSocket viewer (stdlib only) that counts the bytes the hub streams to it."""

    def __init__(self, port: int):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=10)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(
            (f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
             f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
             f"Origin: http://127.0.0.1:{port}\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            head += self.sock.recv(1)
        assert head.startswith(b"HTTP/1.1 101"), head
        self.received = 0
        self.closed = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        try:
            while not self.closed.is_set():
                data = self.sock.recv(65536)
                if not data:
                    break
                self.received += len(data)
        except OSError:
            pass

    def close(self):
        self.closed.set()
        self.sock.close()


def workers_of(port: int):
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/workers", timeout=5) as r:
        return json.load(r)


def wait_for(what, cond, timeout=60.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        got = cond()
        if got:
            return got
        time.sleep(0.2)
    pytest.fail(f"timed out waiting for {what}")




def test_a_viewer_gets_samples_from_two_ray_workers_and_keeps_them_when_one_dies(cluster):
    port, wport = free_port(), free_port()
    hub = subprocess.Popen(
        [lumo_bin(), "serve", "cornell", "--size", "64x64", "--threads", "1", "--port", str(port),
         "--remote-workers", "--worker-bind", f"127.0.0.1:{wport}"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    workers = viewer = None
    try:
        line = ""
        while "workers:" not in line:
            line = hub.stdout.readline()
            assert line, "lumo serve ended before printing the workers line"
        m = re.search(r"--hub (\S+) --token (\S+)", line)
        assert m, line
        viewer = Viewer(port)
        workers = serve_workers(m.group(1), m.group(2), workers=2, threads=1)
        def delivering():
            ws = [w for w in workers_of(port) if w["samples"] > 0]
            return ws if len(ws) >= 2 else None

        first = {w["name"] for w in wait_for("samples from both workers", delivering)}
        assert len(first) == 2
        pids = workers.pids()
        assert all(f":{p}" in " ".join(first) for p in pids), (pids, first)
        os.kill(pids[0], signal.SIGKILL)
        survivor = next(n for n in first if not n.endswith(f":{pids[0]}"))
        count = lambda: next((w["samples"] for w in workers_of(port) if w["name"] == survivor), 0)  # noqa: E731
        before, seen = count(), viewer.received
        # The other worker keeps delivering, and the viewer's stream never stops.
        time.sleep(1.0)
        assert count() > before and viewer.received > seen
        # Ray restarts the killed actor, which joins the hub again as a new worker.
        wait_for("the restarted worker's samples", lambda: any(
            w["samples"] > 0 and w["name"] not in first for w in workers_of(port)))
    finally:
        if workers is not None:
            workers.stop()
        if viewer is not None:
            viewer.close()
        hub.send_signal(signal.SIGTERM)
        try:
            hub.wait(timeout=10)
        except subprocess.TimeoutExpired:
            hub.kill()
