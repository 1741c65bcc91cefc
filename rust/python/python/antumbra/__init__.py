"""antumbra: shadow passes and BVH traversal heat maps of animated scenes, from Python.

Two sessions with the same methods:

- :class:`Client`: a session with the antumbra daemon (``antumbra serve``) over its Unix socket;
  :meth:`Client.connect` to a running daemon, :meth:`Client.spawn` to start one;
- :class:`LocalSession`: renders in this process with the daemon's code path (tests, notebooks).

A frame: ``upload_mesh`` each mesh the session lacks, ``frame_update`` the scene state (objects,
camera, lights, resolution, with Blender's field names), then ``render`` it into a
:class:`Result` of float32 numpy images, or ``compare`` methods on it (``compare_frame`` into a
:class:`CompareFrame`, recorded by a :class:`CompareReport`), or ``trade`` speed against
accuracy over the :data:`KNOBS` (``trade_frame`` into a :class:`TradeFrame`, recorded by a
:class:`TradeReport`). See ``docs/python.md`` and ``docs/trade.md``.

:mod:`antumbra.rays` traces your own rays on your own triangles: an embreex-like ``Scene`` and
trimesh's ``RayMeshIntersector`` (``docs/ray-queries.md``).
"""

from . import errors, rays
from ._native import __version__
from .client import Client, default_socket_path
from .errors import (
    AnswersDiffer,
    AntumbraError,
    ConnectionLost,
    DaemonError,
    DaemonTimeout,
    DaemonUnavailable,
    InvalidInput,
    ProtocolMismatch,
    RequestError,
    SessionBusy,
)
from .files import (
    colorize_difference,
    colorize_heat,
    read_exr,
    read_recording,
    write_file_atomic,
    write_stats_csv,
    write_stats_json,
)
from .report import CompareFrame, CompareReport
from .result import Result
from .session import (
    COMPARE_COLUMNS,
    DEFAULT_METHODS,
    DEFAULT_PASSES,
    PROTOCOL_VERSION,
    LocalSession,
    Missing,
    ProgressCallback,
    image_hash,
    mesh_hash,
)
from .settings import render_settings, settings_schema
from .trade import KNOBS, TRADE_COLUMNS, TradeFrame, TradeReport

__all__ = [
    "COMPARE_COLUMNS",
    "DEFAULT_METHODS",
    "DEFAULT_PASSES",
    "KNOBS",
    "PROTOCOL_VERSION",
    "TRADE_COLUMNS",
    "AnswersDiffer",
    "AntumbraError",
    "Client",
    "CompareFrame",
    "CompareReport",
    "ConnectionLost",
    "DaemonError",
    "DaemonTimeout",
    "DaemonUnavailable",
    "InvalidInput",
    "LocalSession",
    "Missing",
    "ProgressCallback",
    "ProtocolMismatch",
    "RequestError",
    "Result",
    "SessionBusy",
    "TradeFrame",
    "TradeReport",
    "__version__",
    "colorize_difference",
    "colorize_heat",
    "default_socket_path",
    "errors",
    "image_hash",
    "mesh_hash",
    "rays",
    "read_exr",
    "read_recording",
    "render_settings",
    "settings_schema",
    "write_file_atomic",
    "write_stats_csv",
    "write_stats_json",
]
