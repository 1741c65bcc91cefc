"""The socket client against no daemon and against fake servers (no antumbra binary needed):
DaemonUnavailable, ProtocolMismatch, ConnectionLost, DaemonTimeout."""

from __future__ import annotations

import _thread
import os
import socket
import subprocess
import sys
import threading

import pytest

import antumbra


def test_no_daemon_is_daemon_unavailable(short_tmp):
    path = str(short_tmp / "none.sock")
    with pytest.raises(antumbra.DaemonUnavailable) as e:
        antumbra.Client.connect(path)
    message = str(e.value)
    assert path in message and "antumbra serve" in message
    assert isinstance(e.value, ConnectionError)


def test_stale_socket_file_is_daemon_unavailable(short_tmp):
    path = str(short_tmp / "stale.sock")
    s = socket.socket(socket.AF_UNIX)
    s.bind(path)
    s.close()  # the file stays, nobody listens
    with pytest.raises(antumbra.DaemonUnavailable, match="no antumbra daemon is listening"):
        antumbra.Client.connect(path)


def test_spawn_of_a_missing_binary(short_tmp):
    with pytest.raises(antumbra.DaemonUnavailable, match="cannot start the antumbra daemon"):
        antumbra.Client.spawn(str(short_tmp / "no-such-antumbra"))


def test_default_socket_path(monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", "/run/user/1234")
    assert antumbra.default_socket_path() == "/run/user/1234/antumbra/daemon.sock"
    monkeypatch.setenv("XDG_RUNTIME_DIR", "")
    assert antumbra.default_socket_path() == f"/tmp/antumbra-{os.getuid()}/daemon.sock"
    monkeypatch.delenv("XDG_RUNTIME_DIR")
    assert antumbra.default_socket_path() == f"/tmp/antumbra-{os.getuid()}/daemon.sock"


class FakeServer:
    """Accepts one connection, reads the Hello frame, then does ``behaviour(conn)``."""

    def __init__(self, path: str, behaviour):
        self.sock = socket.socket(socket.AF_UNIX)
        self.sock.bind(path)
        self.sock.listen(1)
        self.behaviour = behaviour
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        conn, _ = self.sock.accept()
        with conn:
            n = int.from_bytes(conn.recv(4), "little")
            while n > 0:
                n -= len(conn.recv(n))
            self.behaviour(conn)

    def close(self):
        self.sock.close()
        self.thread.join(5)


@pytest.fixture
def fake(short_tmp):
    servers = []

    def start(behaviour):
        path = str(short_tmp / f"fake{len(servers)}.sock")
        servers.append(FakeServer(path, behaviour))
        return path

    yield start
    for s in servers:
        s.close()


def test_garbage_reply_is_protocol_mismatch(fake):
    # 0xc1 is never used in MessagePack.
    path = fake(lambda conn: (conn.sendall(b"\x01\x00\x00\x00\xc1"), conn.recv(1)))
    with pytest.raises(antumbra.ProtocolMismatch, match="cannot read the daemon's reply"):
        antumbra.Client.connect(path, timeout=5)


def test_wrong_reply_is_protocol_mismatch(fake):
    # "Ack" as a MessagePack str: a valid reply, but not Welcome.
    path = fake(lambda conn: (conn.sendall(b"\x04\x00\x00\x00\xa3Ack"), conn.recv(1)))
    with pytest.raises(antumbra.ProtocolMismatch, match="answered Hello with Ack"):
        antumbra.Client.connect(path, timeout=5)


def test_closed_connection_is_connection_lost(fake):
    path = fake(lambda conn: None)
    with pytest.raises(antumbra.ConnectionLost, match="closed the connection"):
        antumbra.Client.connect(path, timeout=5)


def test_silent_server_is_timeout(fake):
    done = threading.Event()
    path = fake(lambda conn: done.wait(10))
    with pytest.raises(antumbra.DaemonTimeout, match="did not answer") as e:
        antumbra.Client.connect(path, timeout=0.3)
    assert isinstance(e.value, TimeoutError)
    done.set()


def test_bad_timeout_is_invalid_input(short_tmp):
    with pytest.raises(antumbra.InvalidInput, match="timeout"):
        antumbra.Client.connect(str(short_tmp / "x.sock"), timeout=-1)


# ---------------------------------------------------------------------------------------------
# A scripted fake daemon, for what a real one cannot be made to do on cue. The test encodes the
# few MessagePack replies it needs itself (the package never does).


def pack(value) -> bytes:
    """A minimal MessagePack encoder: dict, str, int >= 0, bool, None."""
    if value is None:
        return b"\xc0"
    if value is True or value is False:
        return b"\xc3" if value else b"\xc2"
    if isinstance(value, int):
        return b"\xcf" + value.to_bytes(8, "big")
    if isinstance(value, str):
        data = value.encode()
        assert len(data) < 256
        return bytes([0xD9, len(data)]) + data
    if isinstance(value, dict):
        assert len(value) < 16
        return bytes([0x80 | len(value)]) + b"".join(pack(k) + pack(v) for k, v in value.items())
    raise TypeError(value)


def frame(value) -> bytes:
    body = pack(value)
    return len(body).to_bytes(4, "little") + body


WELCOME = frame({"Welcome": {"version": antumbra.PROTOCOL_VERSION, "server": "fake", "limits": {}}})


def read_frame(conn) -> bytes:
    header = b""
    while len(header) < 4:
        chunk = conn.recv(4 - len(header))
        if not chunk:
            raise EOFError
        header += chunk
    n = int.from_bytes(header, "little")
    body = b""
    while len(body) < n:
        body += conn.recv(n - len(body))
    return body


def interrupt_soon(delay: float = 0.3) -> threading.Timer:
    timer = threading.Timer(delay, _thread.interrupt_main)
    timer.start()
    return timer


def test_ctrl_c_while_waiting_ends_the_session(fake):
    def script(conn):
        conn.sendall(WELCOME)
        read_frame(conn)  # Stats: never answered
        conn.recv(1)

    client = antumbra.Client.connect(fake(script), timeout=None)
    interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        client.stats()
    with pytest.raises(antumbra.ConnectionLost, match="interrupted while waiting"):
        client.stats()


def test_ctrl_c_cancels_a_render_and_keeps_the_session(fake):
    requests = []

    def script(conn):
        conn.sendall(WELCOME)
        requests.append(read_frame(conn))  # Render
        progress = {"request_id": 1, "stage": "render", "done": 0, "total": 2}
        conn.sendall(frame({"Progress": progress}))
        requests.append(read_frame(conn))  # Cancel
        conn.sendall(frame("Ack"))
        error = {
            "code": "Cancelled",
            "message": "Render frame 3 (request 1): cancelled by the client",
            "session_usable": True,
            "request_id": 1,
        }
        conn.sendall(frame({"Error": error}))
        requests.append(read_frame(conn))  # Stats
        conn.sendall(frame({"DaemonStats": {"renders_cancelled": 1}}))
        conn.recv(1)

    client = antumbra.Client.connect(fake(script), timeout=5)
    calls = []
    interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        client.render(3, progress=lambda *a: calls.append(a))
    assert calls == [("render", 0, 2)]
    assert client.active_request is None
    assert b"Cancel" in requests[1]
    # The Cancel's Ack was skipped: the next reply is the Stats'.
    assert client.stats()["renders_cancelled"] == 1


SIGPIPE_SCRIPT = r"""
import os, signal, socket, sys, threading, time
import numpy as np
import antumbra

signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # a host (Blender) that does not ignore SIGPIPE
path = sys.argv[1]
server = socket.socket(socket.AF_UNIX)
server.bind(path)
server.listen(1)
WELCOME = bytes.fromhex(sys.argv[2])

def run():
    conn, _ = server.accept()
    n = int.from_bytes(conn.recv(4), "little")
    conn.recv(n)
    conn.sendall(WELCOME)
    time.sleep(0.2)
    conn.close()

threading.Thread(target=run, daemon=True).start()
client = antumbra.Client.connect(path)
time.sleep(0.5)
try:
    client.upload_mesh("big", np.zeros((3_000_000, 3), np.float32), np.zeros((1, 3), np.uint32))
except antumbra.ConnectionLost as e:
    print("ConnectionLost:", e)
"""


def test_writing_to_a_closed_daemon_raises_instead_of_sigpipe(short_tmp):
    """Writes use MSG_NOSIGNAL (Rust's UnixStream), so a daemon that went away is an
    exception, not a SIGPIPE that would kill a host which does not ignore the signal."""
    run = subprocess.run(
        [sys.executable, "-c", SIGPIPE_SCRIPT, str(short_tmp / "p.sock"), WELCOME.hex()],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, (run.returncode, run.stderr)
    assert "ConnectionLost: connection to the daemon broken while sending UploadMesh" in run.stdout
