"""A session with the daemon: :class:`Client` talks to ``antumbra serve`` over its Unix socket,
starting one when asked (the daemon process, its socket path and its output). It has the methods
of :class:`antumbra.LocalSession` (``session.py``) and returns the same :class:`antumbra.Result`.

The protocol itself lives in the native module (``antumbra._native``, Rust).
"""

from __future__ import annotations

import collections
import os
import shutil
import subprocess
import tempfile
import threading
import time
import weakref
from collections.abc import Mapping, Sequence

from ._native import Connection as _Connection
from .errors import AntumbraError, DaemonTimeout, DaemonUnavailable
from .session import _Session

__all__ = [
    "Client",
    "default_socket_path",
]

#: The line ``antumbra serve`` prints on stdout once it accepts connections.
READY_PREFIX = "antumbra: listening on "
#: How long stopping waits for the reader threads to drain the exited daemon's pipes (a child it
#: spawned could hold them open; the threads are daemon threads either way).
READER_JOIN_S = 2.0


def default_socket_path() -> str:
    """The daemon's default socket: ``$XDG_RUNTIME_DIR/antumbra/daemon.sock``, or
    ``/tmp/antumbra-$UID/daemon.sock`` when ``XDG_RUNTIME_DIR`` is unset or empty (the rule
    ``antumbra serve`` follows)."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    if runtime:
        return os.path.join(runtime, "antumbra", "daemon.sock")
    return f"/tmp/antumbra-{os.getuid()}/daemon.sock"


class _DaemonProcess:
    """A daemon started by :meth:`Client.spawn`: its process, its output (drained by threads
    so the daemon never blocks on a full pipe) and its private socket directory."""

    def __init__(self, command: list[str], env: Mapping[str, str] | None, tmpdir: str | None):
        self.command = command
        self.tmpdir = tmpdir
        self.stdout: collections.deque[str] = collections.deque(maxlen=200)
        self.stderr: collections.deque[str] = collections.deque(maxlen=200)
        self.ready = threading.Event()
        self.listening: str | None = None
        try:
            self.process = subprocess.Popen(
                command,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                env=None if env is None else dict(env),
                text=True,
                errors="replace",
                # Ctrl-C in a terminal goes to the client, which cancels its render; the
                # daemon is stopped by close().
                start_new_session=True,
            )
        except OSError as e:
            self._remove_tmpdir()
            raise DaemonUnavailable(
                f"cannot start the antumbra daemon `{' '.join(command)}`: {e} (install "
                f"antumbra, or pass binary='/path/to/antumbra')"
            ) from e
        self._readers = [
            threading.Thread(target=self._read_stdout, daemon=True),
            threading.Thread(target=self._read_stderr, daemon=True),
        ]
        for reader in self._readers:
            reader.start()

    def _read_stdout(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            line = line.rstrip("\n")
            self.stdout.append(line)
            if not self.ready.is_set() and line.startswith(READY_PREFIX):
                for endpoint in line[len(READY_PREFIX) :].split(" tcp:")[:1]:
                    if endpoint.startswith("unix:"):
                        self.listening = endpoint[len("unix:") :]
                self.ready.set()
        self.ready.set()  # end of output: the process is gone

    def _read_stderr(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.stderr.append(line.rstrip("\n"))

    def output(self) -> str:
        """The last lines the daemon wrote on stderr and stdout."""
        return "\n".join([*self.stderr, *self.stdout])

    def wait_ready(self, timeout: float) -> str:
        """Waits for the ready line; returns the socket path it names."""
        deadline = time.monotonic() + timeout
        while not self.ready.wait(0.05):
            if time.monotonic() > deadline:
                self.stop(grace=0)
                raise DaemonTimeout(
                    f"`{' '.join(self.command)}` did not print '{READY_PREFIX}unix:PATH' "
                    f"within {timeout} s; its output:\n{self.output()}"
                )
        if self.listening is None:
            try:
                code = self.process.wait(timeout=2)
            except subprocess.TimeoutExpired:
                code = None
            self.stop(grace=0)
            raise DaemonUnavailable(
                f"`{' '.join(self.command)}` exited (status {code}) before it listened; "
                f"its output:\n{self.output()}"
            )
        return self.listening

    def stop(self, grace: float = 5.0) -> None:
        """Waits up to ``grace`` seconds for the process to exit, then terminates it, and waits
        for its output to be read to the end (a reader thread left running past an embedding
        Python's exit is reported by Blender 4.2 as a thread left at exit)."""
        _stop_process(self.process, grace)
        for reader in self._readers:
            reader.join(timeout=READER_JOIN_S)
        self._remove_tmpdir()

    def _remove_tmpdir(self) -> None:
        if self.tmpdir is not None:
            shutil.rmtree(self.tmpdir, ignore_errors=True)
            self.tmpdir = None


def _stop_process(process: subprocess.Popen[str], grace: float = 5.0) -> None:
    if process.poll() is not None:
        return
    try:
        process.wait(timeout=grace)
        return
    except subprocess.TimeoutExpired:
        pass
    process.terminate()
    try:
        process.wait(timeout=5)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


class Client(_Session):
    """A session with the antumbra daemon over its Unix socket. Create one with
    :meth:`connect` (a running daemon) or :meth:`spawn` (start a daemon for this client)."""

    _native: _Connection

    def __init__(self, native: _Connection, daemon: _DaemonProcess | None = None) -> None:
        self._native = native
        self._daemon = daemon
        self._finalizer = (
            weakref.finalize(self, _stop_process, daemon.process, 0) if daemon else None
        )

    @classmethod
    def connect(
        cls,
        socket_path: str | os.PathLike[str] | None = None,
        timeout: float | None = 10.0,
        client_name: str = "antumbra-python",
        token: str | None = None,
    ) -> Client:
        """Connects to a running daemon (``socket_path`` None: :func:`default_socket_path`)
        and says Hello. ``timeout``: seconds to wait for each reply (None: no limit; renders
        wait without limit unless ``render(timeout=...)``).

        Raises :class:`DaemonUnavailable` when no daemon listens there, and
        :class:`ProtocolMismatch` when it speaks another protocol version.
        """
        path = default_socket_path() if socket_path is None else os.fspath(socket_path)
        return cls(_Connection(path, timeout, client_name, token))

    @classmethod
    def spawn(
        cls,
        binary: str | os.PathLike[str] = "antumbra",
        socket_path: str | os.PathLike[str] | None = None,
        args: Sequence[str] = (),
        timeout: float = 10.0,
        client_name: str = "antumbra-python",
        env: Mapping[str, str] | None = None,
    ) -> Client:
        """Starts ``BINARY serve --socket PATH ARGS...``, waits for it to print
        ``antumbra: listening on unix:PATH``, and connects. The client owns the daemon:
        :meth:`close` stops it (Shutdown, then SIGTERM if it lingers).

        ``socket_path`` None puts the socket in a new private directory under /tmp (so the
        spawned daemon never meets one already running at the default path). ``timeout``
        bounds the wait for the daemon to start and for each reply. ``env`` None runs the
        daemon in this environment with ``NO_COLOR=1``; its output is kept for
        :meth:`daemon_output`.
        """
        tmpdir = None
        if socket_path is None:
            tmpdir = tempfile.mkdtemp(prefix="antumbra-", dir="/tmp")
            socket_path = os.path.join(tmpdir, "daemon.sock")
        command = [os.fspath(binary), "serve", "--socket", os.fspath(socket_path), *args]
        if env is None:
            # Its log goes to a pipe (daemon_output()): plain text, no colour codes.
            env = {**os.environ, "NO_COLOR": "1"}
        daemon = _DaemonProcess(command, env, tmpdir)
        try:
            path = daemon.wait_ready(timeout)
            native = _Connection(path, timeout, client_name, None)
        except BaseException:
            daemon.stop(grace=0)
            raise
        return cls(native, daemon)

    @property
    def socket_path(self) -> str:
        return self._native.socket_path

    @property
    def server(self) -> str:
        """The daemon's name and version."""
        return self._native.server

    @property
    def protocol_version(self) -> int:
        return self._native.protocol_version

    @property
    def bytes_sent(self) -> int:
        """Bytes sent to the daemon so far (every request, framing included)."""
        return self._native.bytes_sent

    @property
    def process(self) -> subprocess.Popen[str] | None:
        """The daemon process this client started (:meth:`spawn`), else None."""
        return self._daemon.process if self._daemon else None

    def daemon_output(self) -> str:
        """The last lines a spawned daemon wrote (stderr, then stdout); '' if not spawned."""
        return self._daemon.output() if self._daemon else ""

    def close(self) -> None:
        """Ends the session (the daemon keeps its mesh cache). A spawned daemon is stopped."""
        if self._daemon is None:
            self._native.close()
            return
        try:
            if not self._native.closed:
                # Shutdown closes the socket too, even when it fails (a broken session).
                self._native.shutdown()
        except AntumbraError:
            pass
        finally:
            self._daemon.stop()
            if self._finalizer is not None:
                self._finalizer.detach()

    def shutdown(self) -> None:
        """Stops the daemon (whoever started it) and closes this client."""
        try:
            self._native.shutdown()
        finally:
            if self._daemon is not None:
                self._daemon.stop()

    def __repr__(self) -> str:
        state = " closed" if self.closed else ""
        return f"<antumbra.Client {self.socket_path} server={self.server!r}{state}>"
