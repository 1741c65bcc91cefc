"""The sessions: :class:`Client` talks to ``antumbra serve`` over its Unix socket,
:class:`LocalSession` renders in this process with the daemon's code path. Both have the same
methods and return the same :class:`Result`.

The protocol itself lives in the native module (``antumbra._native``, Rust): this module only
manages the daemon process, the socket path and the shape of the results.
"""

from __future__ import annotations

import collections
import dataclasses
import json
import os
import shutil
import subprocess
import tempfile
import threading
import time
import weakref
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _native
from ._native import Connection as _Connection
from ._native import LocalSession as _LocalSession
from .errors import AnswersDiffer, AntumbraError, DaemonTimeout, DaemonUnavailable, InvalidInput
from .report import CompareFrame
from .trade import Knobs, TradeFrame, TradeReport, knob_texts

if TYPE_CHECKING:  # typing.Self is Python 3.11+; annotations are not evaluated at run time
    from typing import Self

__all__ = [
    "COMPARE_COLUMNS",
    "DEFAULT_METHODS",
    "DEFAULT_PASSES",
    "PROTOCOL_VERSION",
    "Client",
    "LocalSession",
    "ProgressCallback",
    "Result",
    "colorize_difference",
    "colorize_heat",
    "default_socket_path",
    "mesh_hash",
    "read_exr",
    "read_recording",
    "render_settings",
    "settings_schema",
    "write_file_atomic",
    "write_stats_csv",
    "write_stats_json",
]

PROTOCOL_VERSION: int = _native.PROTOCOL_VERSION

#: The passes ``render`` returns unless told otherwise.
DEFAULT_PASSES: tuple[str, ...] = ("masks", "combined", "heat_maps", "visible")

#: The methods ``compare`` uses when none are given (``LABEL=NAME=VALUE,...``), the
#: baseline first: antumbra-core's, as ``antumbra compare`` uses them.
DEFAULT_METHODS: tuple[str, ...] = tuple(_native.default_methods())

#: The columns of ``compare``'s rows, in order: those of ``compare.csv``.
COMPARE_COLUMNS: tuple[str, ...] = tuple(_native.compare_columns())

#: The image of the ``object_ids`` pass.
OBJECT_PLANE = "primary.object"

#: ``progress(stage, done, total)``; return False to cancel the render or comparison.
ProgressCallback = Callable[[str, int, int], "bool | None"]

#: The line ``antumbra serve`` prints on stdout once it accepts connections.
READY_PREFIX = "antumbra: listening on "


def default_socket_path() -> str:
    """The daemon's default socket: ``$XDG_RUNTIME_DIR/antumbra/daemon.sock``, or
    ``/tmp/antumbra-$UID/daemon.sock`` when ``XDG_RUNTIME_DIR`` is unset or empty (the rule
    ``antumbra serve`` follows)."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    if runtime:
        return os.path.join(runtime, "antumbra", "daemon.sock")
    return f"/tmp/antumbra-{os.getuid()}/daemon.sock"


def mesh_hash(
    positions: np.ndarray, triangles: np.ndarray, normals: np.ndarray | None = None
) -> int:
    """The protocol's content hash of a mesh (64-bit XXH3 over the vertex count, the float32
    positions, the triangle count and the uint32 indices, then any corner normals; computed in
    Rust).

    ``positions``: float32 array of shape (n, 3); ``triangles``: integer array of shape (m, 3);
    ``normals``: None or float32 array of shape (3m, 3), each triangle's corner normals.
    """
    return _native.mesh_hash(positions, triangles, normals)


def read_recording(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The meshes and frames of a recording (``.antrec``, from ``start_recording``,
    ``antumbra serve --record`` or ``antumbra record``).

    Returns ``{"meshes": {hash: {"name", "positions", "triangles"}}, "frames": [dict, ...]}``:
    positions float32 (n, 3) and triangles uint32 (m, 3) numpy arrays, checked as the daemon
    checks an upload; each frame a dict with ``frame``, ``objects``, ``camera``, ``lights`` and
    ``resolution`` in the form ``frame_update`` takes (Blender's field names, row-major 4x4
    matrices as nested lists).
    """
    return _native.read_recording(os.fspath(path))


def write_file_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Writes ``data`` to ``path`` as every antumbra file is written: into a uniquely named
    temporary file beside it, synced to disk, then renamed over ``path`` (so a reader never sees
    half a file, and two writers never share a temporary file)."""
    _native.write_file_atomic(os.fspath(path), bytes(data))


def write_stats_csv(path: str | os.PathLike[str], rows: list[dict[str, Any]]) -> None:
    """Writes statistics rows (``Result.stats`` dicts, or those dicts read back from JSON) as
    ``stats.csv``, with the Rust writer ``antumbra render`` uses: the same bytes for the same
    rows, written atomically."""
    _native.write_stats(os.fspath(path), list(rows), "csv")


def write_stats_json(path: str | os.PathLike[str], rows: list[dict[str, Any]]) -> None:
    """Writes statistics rows as ``stats.json``, as ``antumbra render`` does (atomically)."""
    _native.write_stats(os.fspath(path), list(rows), "json")


def colorize_heat(array: np.ndarray, max: float | None = None) -> tuple[np.ndarray, float]:
    """A heat map (float32 (h, w)) through the turbo colour map as the PNGs draw it: 0 is the
    first colour, ``max`` (default: the image's largest value) the last. Returns the sRGB uint8
    array of shape (h, w, 3) and the max used."""
    return _native.colorize_heat(array, max)


def colorize_difference(array: np.ndarray, scale: float | None = None) -> tuple[np.ndarray, float]:
    """A difference image (float32 (h, w), e.g. one method's node visits minus the baseline's)
    as the comparison's PNGs draw it: blue at ``-scale``, white at 0, red at ``+scale``
    (default: the largest absolute difference, at least 1). Returns the sRGB uint8 array of
    shape (h, w, 3) and the scale used."""
    return _native.colorize_difference(array, scale)


def settings_schema() -> list[dict[str, Any]]:
    """Every render setting, as the core defines them once: one dict per setting with ``name``,
    ``type`` ('bool', 'int', 'float', 'choice' or 'text'), ``default``, ``group`` and
    ``group_title`` (the panel's sections), ``help``, ``expected`` (what it takes, in words)
    and, by type, ``min``/``max`` (``open``: bounds excluded), ``choices`` or ``syntax``.
    :meth:`Client.render` and :func:`render_settings` take these names as keywords."""
    return _native.settings_schema()


def render_settings(**settings: Any) -> dict[str, Any]:
    """Every render setting by name, with the given ones (named as :func:`settings_schema`
    names them) checked as the daemon checks them and the rest at their defaults: the
    ``settings`` of a render request and of a spool job's ``job.json``. A setting left as None
    takes its default; an unknown name or a bad value raises :class:`InvalidInput` naming it."""
    return json.loads(_native.RenderSettings(**settings).json())


def read_exr(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Every channel of an EXR file (such as ``frame_NNNN.exr`` from ``antumbra render`` or
    :meth:`Result.save`) as float32 arrays of shape (height, width), rows top to bottom."""
    return _native.read_exr(os.fspath(path))


@dataclass(frozen=True, eq=False)
class Result:
    """One rendered frame.

    Attributes:
        frame, width, height: the frame number and the image size in pixels.
        request_id: the render's request id.
        planes: every image in the daemon's order, as (name, array) pairs: the masks
            ``shadow.<light>`` (light order), ``combined``, ``primary.N_B|N_L|N_T``,
            ``shadow.N_B|N_L|N_T``; each a float32 array of shape (height, width), rows top to
            bottom.
        images: the planes by name; every name is unique (a light named like a heat map, or
            like an earlier light, gets ``#2``, ``#3``, ... after its name).
        masks: the shadow mask of each shadow-casting light (1 lit, 0 shadowed), by the light's
            part of its plane name: the light's name, made unique as in ``images``.
        stats: one dict per pass (the primary pass, then each shadow-casting light) with the
            columns of ``antumbra_core::stats::StatsRow``.
        visible: the visible set, a uint32 array of shape (k, 2) of (object index, triangle
            index) rows, sorted; None unless the ``visible`` pass was asked for.
        object_ids: (property) the ``primary.object`` plane of the ``object_ids`` pass.
    """

    frame: int
    width: int
    height: int
    request_id: int
    planes: list[tuple[str, np.ndarray]]
    stats: list[dict[str, Any]]
    visible: np.ndarray | None
    images: dict[str, np.ndarray] = field(default_factory=dict)
    masks: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def _from_native(cls, raw: dict[str, Any], passes: Sequence[str]) -> Result:
        planes = list(raw["images"])
        stats = list(raw["stats"])
        masks: dict[str, np.ndarray] = {}
        if "masks" in passes:
            # The masks come first, one per shadow row, named shadow.<unique light name>.
            count = sum(1 for row in stats if row["pass"] == "shadow")
            masks = {name.removeprefix("shadow."): array for name, array in planes[:count]}
        return cls(
            frame=raw["frame"],
            width=raw["width"],
            height=raw["height"],
            request_id=raw["request_id"],
            planes=planes,
            stats=stats,
            visible=raw["visible"],
            images=dict(planes),
            masks=masks,
        )

    @property
    def combined(self) -> np.ndarray | None:
        """The mean of the masks (None unless the ``combined`` pass was asked for)."""
        return self.images.get("combined")

    @property
    def object_ids(self) -> np.ndarray | None:
        """The ``object_ids`` pass (plane ``primary.object``): float32 (height, width), rows top
        to bottom, per pixel the index of the object the camera ray hit in the frame's object
        list (the order of :meth:`frame_update`'s ``objects``), -1 where it hit nothing. None
        unless the pass was asked for."""
        return self.images.get(OBJECT_PLANE)

    def save(
        self, directory: str | os.PathLike[str], *, exr: bool = True, png: bool = True
    ) -> list[str]:
        """Writes the frame's files into ``directory`` as ``antumbra render`` does (same Rust
        writer, so the same bytes for the same images): ``frame_NNNN.exr`` with every plane,
        mask PNGs and turbo heat-map PNGs with their scale. Needs the ``masks`` and
        ``combined`` passes. The ``object_ids`` plane is not written. Returns the file names
        written."""
        planes = [(name, array) for name, array in self.planes if name != OBJECT_PLANE]
        return _native.save_frame(
            os.fspath(directory), self.frame, self.width, self.height, planes, exr, png
        )

    def __repr__(self) -> str:
        names = ", ".join(name for name, _ in self.planes)
        return (
            f"<antumbra.Result frame={self.frame} {self.width}x{self.height} "
            f"images=[{names}] stats={len(self.stats)} rows>"
        )


def _rows_frame(rows: list[dict[str, Any]]) -> Any:
    """Rows as a pandas DataFrame with the columns in order when pandas imports, else as is."""
    try:
        import pandas as pd
    except ImportError:
        return rows
    return pd.DataFrame(rows, columns=list(COMPARE_COLUMNS))


class _Session:
    """The methods both sessions share; ``self._native`` is a ``_native.Connection`` or a
    ``_native.LocalSession``."""

    _native: _Connection | _LocalSession

    # -- meshes ---------------------------------------------------------------------------

    def missing_meshes(self, hashes: Iterable[int]) -> list[int]:
        """Which of these mesh hashes the session lacks (upload those)."""
        return self._native.missing_meshes(hashes)

    def upload_mesh(
        self,
        name: str,
        positions: np.ndarray,
        triangles: np.ndarray,
        normals: np.ndarray | None = None,
    ) -> int:
        """Checks, hashes and uploads one mesh in object space; returns its content hash.

        ``positions``: float32 array of shape (n, 3); ``triangles``: integer array (uint32 or
        int) of shape (m, 3) of vertex indices; ``normals``: None (flat shading) or float32
        array of shape (3m, 3), the shading normals at each triangle's corners, read by
        ``facing="shading"`` (docs/facing.md). A NaN or infinite value, or an index out of
        range, raises :class:`InvalidInput` naming the mesh. The GIL is released while the
        arrays are hashed and sent.
        """
        return self._native.upload_mesh(name, positions, triangles, normals)

    # -- frames ---------------------------------------------------------------------------

    def frame_update(
        self,
        frame: int,
        objects: Iterable[Mapping[str, Any]],
        camera: Mapping[str, Any],
        lights: Iterable[Mapping[str, Any]] = (),
        resolution: Mapping[str, Any] | tuple[int, int] = (1920, 1080),
    ) -> list[int]:
        """Sends the whole scene state of one frame, with Blender's field names; returns the
        hashes of the meshes it uses that the session lacks (upload them before rendering).

        ``objects``: dicts ``name``, ``mesh_hash``, ``matrix_world`` (4x4, indexed
        [row][column] as Blender's ``Matrix`` and numpy), ``visible_camera`` (True),
        ``visible_shadow`` (True; ``cast_shadow`` is accepted as its alias).

        ``camera``: ``matrix_world``, ``lens`` (50), ``sensor_width`` (36),
        ``sensor_height`` (24), ``sensor_fit`` ('AUTO' | 'HORIZONTAL' | 'VERTICAL'),
        ``shift_x``, ``shift_y`` (0), ``clip_start`` (0.1), ``clip_end`` (1000).

        ``lights``: ``name``, ``matrix_world``, ``type`` ('POINT' | 'SUN' | 'SPOT' | 'AREA'),
        ``shadow_soft_size`` (0.25; point and spot radius), ``angle`` (sun, radians, 0.00918),
        ``spot_size`` (pi/4), ``spot_blend`` (0.15), ``shape`` ('SQUARE' | 'RECTANGLE' |
        'DISK' | 'ELLIPSE'), ``size`` (0.25), ``size_y`` (0.25), ``use_shadow`` (True).

        ``resolution``: ``x``, ``y``, ``percentage`` (100), ``pixel_aspect_x``,
        ``pixel_aspect_y`` (1), or an (x, y) pair; ``resolution_x``, ``resolution_y`` and
        ``resolution_percentage`` are accepted too.

        A field of the wrong type, a missing or unknown field raises :class:`InvalidInput`
        naming it.
        """
        return self._native.frame_update(frame, objects, camera, lights, resolution)

    def camera_path(
        self, frames: Iterable[tuple[int, Mapping[str, Any]]] | Mapping[int, Mapping[str, Any]]
    ) -> None:
        """Sends the camera of every frame of the animation up front: (frame, camera dict)
        pairs, or a dict from frame to camera dict."""
        self._native.camera_path(frames)

    # -- rendering ------------------------------------------------------------------------

    def render(
        self,
        frame: int,
        *,
        passes: Iterable[str] = DEFAULT_PASSES,
        progress: ProgressCallback | None = None,
        timeout: float | None = None,
        warm_up: bool = False,
        **settings: Any,
    ) -> Result:
        """Renders a frame sent with :meth:`frame_update`.

        Args:
            settings: the render settings by name, as :func:`settings_schema` lists them
                (``antumbra render --help`` shows the same with dashes): for example
                ``spp=16``, ``build='osah'``, ``visibility='exact'``, ``width=8``,
                ``order='sorted:budget=0.1'``, ``leaf_size=4``, ``osah_w=0.5``,
                ``timing=True`` (or 'on', 'off', 'only'). Those left out, or None, take their
                defaults; an unknown name or a bad value raises :class:`InvalidInput` naming it
                before anything is sent.
            passes: any of 'masks', 'combined', 'heat_maps', 'visible', 'object_ids'.
            progress: ``progress(stage, done, total)``, called for each progress report (with
                the GIL); returning False cancels the render (it then raises a
                :class:`RequestError` with code 'Cancelled'), raising cancels it and the
                exception propagates. Ctrl-C cancels too.
            timeout: seconds to wait between two replies of the daemon (None: no limit).
            warm_up: render the frame only for the session's state, as the frame before the
                first of a chunk of an animation (a farm's task): its trees and its visible
                set (OSAH from the previous frame, tree reuse), with a primary pass and no
                shadow ray, so the next frames render what one run over the animation
                renders. The result has no planes and no stats (``visible`` if asked for).
        """
        passes = tuple(passes) if not isinstance(passes, str) else (passes,)
        checked = _native.RenderSettings(**settings)
        raw = self._native.render(frame, checked, passes, progress, timeout, warm_up)
        return Result._from_native(dict(raw), passes)

    def compare_frame(
        self,
        frame: int,
        methods: Mapping[str, Mapping[str, Any]] | Iterable[str] | None = None,
        *,
        baseline: str | None = None,
        repeat: int = 3,
        progress: ProgressCallback | None = None,
        timeout: float | None = None,
        images: bool = True,
        warm_up: bool = False,
        **settings: Any,
    ) -> CompareFrame:
        """Renders a frame sent with :meth:`frame_update` with every method, as
        ``antumbra compare`` does: one request for all methods (the frame and its meshes are
        sent once), each method keeping its own state across the frames of the session
        (previous-frame visibility, tree reuse) while the methods stay the same.

        Args:
            methods: ``{label: {setting: value}}``, or ``LABEL=NAME=VALUE,...`` strings
                (``"osah8=build=osah,visibility=previous,width=8,order=sorted"``); None:
                :data:`DEFAULT_METHODS`. A bad label, setting or value raises
                :class:`InvalidInput` naming it before anything is sent.
            baseline: the label whose answers the others must equal (default: the first).
            repeat: timed passes per method, interleaved across methods; timings are their
                median and spread, work counters come from one counted pass.
            progress: ``progress(stage, done, total)``, called with stage ``'compare'`` before
                the first method pass and after each (``total``: one counted and ``repeat``
                timed passes per method), and ``'queued'`` while it waits for a render slot;
                returning False cancels the comparison (it then raises a
                :class:`RequestError` with code 'Cancelled'), raising cancels it and the
                exception propagates. Ctrl-C cancels too, and the session goes on: a cancelled
                frame leaves every method's state as before it.
            timeout: seconds to wait between two replies of the daemon (None: no limit).
            images: also return each method's shadow-ray node visits per pixel
                (``CompareFrame.heat``) and their differences to the baseline's.
            warm_up: advance every method's state only, as :meth:`render`'s ``warm_up``
                (``progress`` counts one step per method): the frame has no rows, mismatches
                or images, and :meth:`CompareReport.add` refuses it.
            settings: settings every method shares (``spp``, ``seed``), by name.

        Returns:
            A :class:`CompareFrame`: rows, mismatches (not raised), heat and difference
            images; :meth:`CompareReport.add` records it in a report folder.
        """
        raw = self._native.compare(
            frame,
            methods,
            baseline,
            repeat,
            settings,
            timeout,
            images,
            progress=progress,
            warm_up=warm_up,
        )
        cf = CompareFrame._from_native(dict(raw))
        return dataclasses.replace(cf, _record=None) if warm_up else cf

    def compare(
        self,
        frame: int,
        methods: Mapping[str, Mapping[str, Any]] | Iterable[str] | None = None,
        *,
        baseline: str | None = None,
        repeat: int = 3,
        progress: ProgressCallback | None = None,
        timeout: float | None = None,
        **settings: Any,
    ) -> Any:
        """Renders a frame sent with :meth:`frame_update` with every method: the rows of
        :meth:`compare_frame` (``images=False``; the same arguments).

        Returns:
            One row per method x pass x light with the columns of ``compare.csv``
            (:data:`COMPARE_COLUMNS`): a pandas DataFrame when pandas imports, else a list of
            dicts.

        Raises:
            AnswersDiffer: a method's masks or primary ids differ from the baseline's on this
                frame; it names frame, method, light and pixels, and carries the rows.
        """
        cf = self.compare_frame(
            frame,
            methods,
            baseline=baseline,
            repeat=repeat,
            progress=progress,
            timeout=timeout,
            images=False,
            **settings,
        )
        rows = _rows_frame(cf.rows)
        if cf.mismatches:
            raise AnswersDiffer(
                "; ".join(m["message"] for m in cf.mismatches),
                mismatches=cf.mismatches,
                rows=rows,
            )
        return rows

    def trade_frame(
        self,
        frame: int,
        knobs: Knobs = None,
        *,
        repeat: int = 3,
        progress: ProgressCallback | None = None,
        timeout: float | None = None,
        **settings: Any,
    ) -> TradeFrame:
        """Sweeps a frame sent with :meth:`frame_update` over every knob, as ``antumbra trade``
        does (``docs/trade.md``): each knob's values are the methods of a comparison, its
        default value the baseline, each value keeping its state across the frames of the
        session while the knobs stay the same; image knobs are measured against a reference
        rendered once per frame (spp 256, full size).

        Args:
            knobs: ``["spp", "osah_w=0.5,0.9"]`` or ``{"spp": [1, 4, 16], "width": None}``;
                None: every knob of :data:`KNOBS`. An unknown knob or a bad value raises
                :class:`InvalidInput` naming the knob and the value before anything is sent.
            repeat: timed passes per value, interleaved across a knob's values.
            progress: ``progress(stage, done, total)``, called with stage ``'trade'`` before
                the first pass and after each (the reference's, then every value's counted
                and timed passes), and ``'queued'`` while it waits for a render slot;
                returning False or raising cancels, as in :meth:`compare_frame`. A cancelled
                or failed frame leaves every knob's state as before it.
            timeout: seconds to wait between two replies of the daemon (None: no limit).
            settings: settings every value shares (``seed``, ``spp``, ...), by name; a knob's
                base method and value win over them.

        Returns:
            A :class:`TradeFrame`: rows and mismatches (not raised); :meth:`TradeReport.add`
            records it in a trade folder.
        """
        raw = self._native.trade(
            frame, knob_texts(knobs), repeat, settings, timeout, progress=progress
        )
        return TradeFrame._from_native(dict(raw))

    def trade(
        self,
        frames: Iterable[int | Mapping[str, Any]],
        knobs: Knobs = None,
        *,
        out: str | os.PathLike[str],
        scene: str = "scene",
        repeat: int = 3,
        progress: ProgressCallback | None = None,
        timeout: float | None = None,
        **settings: Any,
    ) -> TradeReport:
        """Sweeps every frame of ``frames`` in order with :meth:`trade_frame`, records each in
        the trade folder ``out`` (:class:`TradeReport`, resumed when it holds the same trade)
        and writes it; returns the report (``report.write()`` has written trade.md).

        Each item of ``frames`` is a frame number already sent with :meth:`frame_update`, or a
        dict of :meth:`frame_update`'s arguments (``frame``, ``objects``, ``camera``,
        ``lights``, ``resolution``), sent first; its meshes must have been uploaded (a missing
        one raises :class:`InvalidInput`). The other arguments are :meth:`trade_frame`'s.
        """
        report = TradeReport(out, scene=scene, knobs=knobs, repeat=repeat)
        for item in frames:
            if isinstance(item, Mapping):
                missing = self.frame_update(**item)
                if missing:
                    raise InvalidInput(
                        f"trade: frame {item.get('frame')} uses meshes this session lacks: "
                        f"{missing} (upload them first)"
                    )
                item = item["frame"]
            tf = self.trade_frame(
                item, knobs, repeat=repeat, progress=progress, timeout=timeout, **settings
            )
            report.add(tf)
        report.write()
        return report

    def cancel(self, request_id: int | None = None) -> bool:
        """Cancels the render or comparison in progress on this session (call it from another
        thread); returns whether a cancel was sent. ``request_id`` None cancels whichever runs.
        """
        return self._native.cancel(request_id)

    @property
    def active_request(self) -> int | None:
        """The request id of the render or comparison in progress, or None."""
        return self._native.active_request

    def stats(self) -> dict[str, Any]:
        """The daemon's statistics: sessions, sessions_total, meshes_cached, bytes_cached,
        renders_done, renders_cancelled, renders_failed, uptime_s, meshes_evicted."""
        return self._native.stats()

    @property
    def limits(self) -> dict[str, int]:
        """The limits the session applies (the daemon's, from its Welcome)."""
        return self._native.limits

    # -- recordings -----------------------------------------------------------------------

    def start_recording(self, path: str | os.PathLike[str]) -> None:
        """Writes the meshes and frames sent from now on to a recording (``.antrec``) that
        ``antumbra render --scene FILE.antrec`` replays. While recording, meshes the file lacks
        are reported as missing by :meth:`frame_update` and :meth:`missing_meshes`, so the
        usual upload loop puts them in the file."""
        self._native.start_recording(os.fspath(path))

    def stop_recording(self) -> tuple[int, int]:
        """Closes the recording; returns (frames written, frames left out because a mesh they
        use was never uploaded)."""
        return self._native.stop_recording()

    # -- lifetime -------------------------------------------------------------------------

    @property
    def closed(self) -> bool:
        return self._native.closed

    def close(self) -> None:
        self._native.close()

    def shutdown(self) -> None:
        self._native.shutdown()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class LocalSession(_Session):
    """Renders in this process, with the daemon's code path: meshes go through the daemon's
    upload checks, frames through its scene conversion, results through its reply conversion,
    so a LocalSession and a daemon give the same images bit for bit. For tests and notebooks;
    there is no socket and no daemon.

    ``client_name`` fills the ``scene`` column of the statistics, as the daemon does with the
    client's name.
    """

    _native: _LocalSession

    def __init__(self, client_name: str = "antumbra-python") -> None:
        self._native = _LocalSession(client_name)

    def __repr__(self) -> str:
        return f"<antumbra.LocalSession{' closed' if self.closed else ''}>"


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
        threading.Thread(target=self._read_stdout, daemon=True).start()
        threading.Thread(target=self._read_stderr, daemon=True).start()

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
            time.sleep(0.05)  # let the stderr thread catch up
            self.stop(grace=0)
            raise DaemonUnavailable(
                f"`{' '.join(self.command)}` exited (status {code}) before it listened; "
                f"its output:\n{self.output()}"
            )
        return self.listening

    def stop(self, grace: float = 5.0) -> None:
        """Waits up to ``grace`` seconds for the process to exit, then terminates it."""
        _stop_process(self.process, grace)
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
