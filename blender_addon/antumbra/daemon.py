"""The add-on's link to the antumbra daemon: find the binary, connect to a running daemon or
start one, say what state it is in, and reconnect (restarting it if it died) mid-animation."""

from __future__ import annotations

import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import client_loader

HERE = Path(__file__).resolve().parent
#: A binary shipped inside the add-on (``blender_addon/build.py --with-binary``).
BUNDLED_BINARY = HERE / "bin" / "antumbra"


class DaemonNotRunning(RuntimeError):
    """No daemon answers and none may or can be started; the message says how to fix it."""


def find_binary(preferred: str = "") -> str | None:
    """The antumbra executable: the preference, ``$ANTUMBRA_BIN``, the bundled copy, PATH."""
    for candidate in (preferred, os.environ.get("ANTUMBRA_BIN", "")):
        if candidate and os.path.isfile(candidate) and os.access(candidate, os.X_OK):
            return candidate
    if BUNDLED_BINARY.is_file():
        if not os.access(BUNDLED_BINARY, os.X_OK):
            # Blender unpacks extension zips without file modes.
            try:
                BUNDLED_BINARY.chmod(0o755)
            except OSError:
                pass
        if os.access(BUNDLED_BINARY, os.X_OK):
            return str(BUNDLED_BINARY)
    return shutil.which("antumbra")


@dataclass
class DaemonLink:
    """One session with the daemon, made on first use and remade after it breaks."""

    binary: str = ""
    socket_path: str = ""
    start_automatically: bool = True
    client_name: str = "antumbra-blender"
    client: object | None = None
    #: True when this link started the daemon (closing the link stops it).
    owns_daemon: bool = False
    reconnects: int = 0
    log: list[str] = field(default_factory=list)
    #: Called with each log line as it happens (batches print them).
    on_log: object = None

    def _log(self, line: str):
        self.log.append(line)
        if self.on_log is not None:
            self.on_log(line)

    @property
    def module(self):
        return client_loader.load()

    def socket(self) -> str:
        return self.socket_path or self.module.default_socket_path()

    def connected(self) -> bool:
        return self.client is not None and not self.client.closed

    def status(self) -> str:
        if self.connected():
            owner = "started here" if self.owns_daemon else "running"
            return f"{self.client.server} ({owner}) at {self.client.socket_path}"
        return "not running"

    def session(self):
        """A live session: the current one, a connection to a running daemon, or (if allowed)
        a daemon started for this link."""
        if self.connected():
            return self.client
        client = self.module
        try:
            self.client = client.Client.connect(self.socket(), client_name=self.client_name)
            self.owns_daemon = False
            return self.client
        except client.DaemonUnavailable:
            if not self.start_automatically:
                raise DaemonNotRunning(
                    f"no antumbra daemon at {self.socket()}: press Start daemon, or run "
                    "`antumbra serve`"
                ) from None
        return self.start()

    def start(self):
        if self.connected():
            return self.client
        client = self.module
        binary = find_binary(self.binary)
        if binary is None:
            raise DaemonNotRunning(
                "the antumbra binary was not found: set its path in the add-on's preferences "
                "(or $ANTUMBRA_BIN, or put antumbra on PATH)"
            )
        self.client = client.Client.spawn(
            binary, socket_path=self.socket(), client_name=self.client_name
        )
        self.owns_daemon = True
        self._log(f"started {binary} (pid {self.client.process.pid}) at {self.socket()}")
        return self.client

    def reconnect(self, attempts: int = 3):
        """After a lost connection: close what is left, then connect or restart."""
        self.drop()
        self.reconnects += 1
        self._log(f"lost the daemon; reconnecting (attempt {self.reconnects})")
        error = None
        for attempt in range(attempts):
            try:
                return self.session()
            except Exception as e:  # noqa: BLE001 - retried, then re-raised
                error = e
                time.sleep(0.2 * (attempt + 1))
        raise error

    def drop(self):
        """Forgets the session without asking the daemon anything (it may be dead)."""
        client, self.client = self.client, None
        if client is not None:
            try:
                client.close()
            except Exception:  # noqa: BLE001 - a dead daemon cannot be closed politely
                pass

    def stop(self):
        """Stops the daemon (whoever started it) and ends the session."""
        if self.connected():
            try:
                self.client.shutdown()
            finally:
                self.client = None
                self.owns_daemon = False

    def close(self):
        """Ends the session; a daemon this link started is stopped with it."""
        self.drop()
        self.owns_daemon = False


_LINK: DaemonLink | None = None


def link(binary: str = "", socket_path: str = "", start_automatically: bool = True) -> DaemonLink:
    """The add-on's shared link, updated to the current preferences."""
    global _LINK
    if _LINK is None:
        _LINK = DaemonLink()
    if (_LINK.binary, _LINK.socket_path) != (binary, socket_path):
        if _LINK.socket_path != socket_path:
            _LINK.close()
        _LINK.binary, _LINK.socket_path = binary, socket_path
    _LINK.start_automatically = start_automatically
    return _LINK


def shutdown_link():
    global _LINK
    if _LINK is not None:
        _LINK.close()
        _LINK = None
