"""The exceptions of the antumbra client.

::

    AntumbraError
    ├── InvalidInput        (also TypeError and ValueError) an argument refused before sending
    ├── RequestError        a request refused, or a render failed: .code, .session_usable
    │   └── DaemonError     ... reported by the daemon
    ├── DaemonUnavailable   (also ConnectionError) no daemon at the socket path
    ├── ConnectionLost      (also ConnectionError) the connection broke or the client is closed
    ├── ProtocolMismatch    the daemon speaks another protocol version, or sent the unexpected
    ├── DaemonTimeout       (also TimeoutError) no reply in time
    ├── SessionBusy         another thread is using the session
    └── AnswersDiffer       compare(): a method's masks or primary ids differ from the baseline's

The native module raises these classes (it imports this module), so the socket session
(``Client``) and the in-process session (``LocalSession``) raise the same ones for the same
input: a NaN vertex is ``InvalidInput`` for both, an object whose mesh was never uploaded is a
``RequestError`` with code ``"UnknownMesh"`` (a ``DaemonError`` from the daemon).
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "AnswersDiffer",
    "AntumbraError",
    "ConnectionLost",
    "DaemonError",
    "DaemonTimeout",
    "DaemonUnavailable",
    "InvalidInput",
    "ProtocolMismatch",
    "RequestError",
    "SessionBusy",
]


class AntumbraError(Exception):
    """Base class of every error the antumbra client raises."""


class InvalidInput(AntumbraError, TypeError, ValueError):
    """An argument the client refuses before anything is sent: a wrong type, shape or dtype, a
    missing or unknown field, a NaN vertex, an index out of range, a setting out of range. The
    message names the field (``objects[2] 'Cube'.matrix_world: ...``, ``mesh 'Rock'...``)."""


class RequestError(AntumbraError):
    """A request refused, or a render that failed, with the protocol's error code.

    Attributes:
        code: the protocol's ``ErrorCode`` name: ``"InvalidInput"``, ``"UnknownMesh"``,
            ``"LimitExceeded"``, ``"Busy"``, ``"Cancelled"``, ``"TooLarge"``, ``"BadFrame"``,
            ``"VersionMismatch"`` or ``"Internal"``.
        session_usable: False when the session ended with this error.
        request_id: the render's request id when the error ends a render, else None.
    """

    def __init__(
        self,
        message: str,
        *,
        code: str = "Internal",
        session_usable: bool = True,
        request_id: int | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.code = code
        self.session_usable = session_usable
        self.request_id = request_id

    def __reduce__(self) -> tuple[Any, ...]:  # keep the attributes when pickled
        return (
            _rebuild,
            (type(self), self.message, self.code, self.session_usable, self.request_id),
        )


def _rebuild(
    cls: type[RequestError],
    message: str,
    code: str,
    session_usable: bool,
    request_id: int | None,
) -> RequestError:
    return cls(message, code=code, session_usable=session_usable, request_id=request_id)


class DaemonError(RequestError):
    """The daemon answered a request with an error; the message is the daemon's, and names the
    mesh, object, light, frame or field at fault."""


class DaemonUnavailable(AntumbraError, ConnectionError):
    """No antumbra daemon accepts connections at the socket path. Start one with
    ``antumbra serve`` (or ``antumbra serve --socket PATH``), or use ``Client.spawn()``."""


class ConnectionLost(AntumbraError, ConnectionError):
    """The connection to the daemon broke, the daemon ended the session, or the client was
    closed. Connect again to go on."""


class ProtocolMismatch(AntumbraError):
    """The daemon speaks another protocol version, or sent a reply this client cannot read."""


class DaemonTimeout(AntumbraError, TimeoutError):
    """The daemon did not answer in time; the session cannot be used any more."""


class SessionBusy(AntumbraError):
    """Another thread is using this session (one request at a time, except ``cancel()``)."""


class AnswersDiffer(AntumbraError):
    """``compare()``: a method's masks or primary ids differ from the baseline's on the frame.
    The message names frame, method, light (or primary ids) and the number of differing pixels.

    Attributes:
        mismatches: dicts ``frame``, ``label``, ``what`` (``"light 'NAME'"`` or
            ``"primary ids"``), ``pixels``, ``message``.
        rows: the comparison's rows all the same (as ``compare()`` returns them).
    """

    def __init__(self, message: str, mismatches: list[dict[str, Any]], rows: Any) -> None:
        super().__init__(message)
        self.mismatches = mismatches
        self.rows = rows
