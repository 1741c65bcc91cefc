"""Type stubs of ``antumbra._native``, the Rust half of the package (``rust/python/src``).

Use the Python wrappers (``antumbra.Client``, ``antumbra.LocalSession``) rather than these
classes: they add the socket-path rules, the daemon process, and the ``Result`` type. ``render``
here returns the raw dict the wrappers turn into ``antumbra.Result``.
"""

from collections.abc import Callable, Iterable, Mapping
from os import PathLike
from typing import Any, TypedDict, final

import numpy as np
import numpy.typing as npt

__version__: str
PROTOCOL_VERSION: int

Matrix = Any  # 4x4, indexed [row][column]: mathutils.Matrix, numpy (4, 4), nested sequences
Progress = Callable[[str, int, int], bool | None]

class RawResult(TypedDict):
    frame: int
    width: int
    height: int
    request_id: int
    images: list[tuple[str, npt.NDArray[np.float32]]]
    stats: list[dict[str, Any]]
    visible: npt.NDArray[np.uint32] | None

def mesh_hash(
    positions: npt.NDArray[np.float32],
    triangles: npt.NDArray[np.integer],
    normals: npt.NDArray[np.float32] | None = None,
    material_slots: npt.NDArray[np.integer] | None = None,
    uv_maps: Mapping[str, npt.NDArray[np.float32]] | None = None,
) -> int:
    """The protocol's content hash of a mesh: positions float32 (n, 3), triangles integer
    (m, 3), optional corner normals float32 (3m, 3), material slots uint32 (m,) and UV maps
    {name: float32 (m, 3, 2)}. Values are not checked."""

def image_hash(texels: npt.NDArray[np.float32]) -> int:
    """The content hash of an alpha image, float32 (height, width) rows bottom first;
    checked (finite, not empty)."""

def read_recording(path: str) -> dict[str, Any]:
    """Meshes (numpy, with material slots and UV maps), alpha images (numpy, by hash) and
    frames (`frame_update` dicts, with alpha_materials) of an `.antrec` recording."""

def save_frame(
    dir: str,
    frame: int,
    width: int,
    height: int,
    planes: list[tuple[str, npt.NDArray[np.float32]]],
    exr: bool = True,
    png: bool = True,
) -> list[str]:
    """Writes a frame's planes (daemon order) as `antumbra render` does; returns file names."""

def read_exr(path: str) -> dict[str, npt.NDArray[np.float32]]:
    """Every channel of an EXR as float32 (h, w) arrays."""

def write_file_atomic(path: str, data: bytes) -> None:
    """Writes `data` to `path` atomically (unique temporary file, fsync, rename)."""

def write_stats(path: str, rows: list[dict[str, Any]], format: str) -> None:
    """Statistics rows as the CLI's `stats.csv` (format "csv") or `stats.json` ("json")."""

def colorize_heat(
    array: npt.NDArray[np.float32], max: float | None = None
) -> tuple[npt.NDArray[np.uint8], float]:
    """A heat map through the turbo colour map (sRGB uint8 (h, w, 3)) and the max it used."""

def colorize_difference(
    array: npt.NDArray[np.float32], scale: float | None = None
) -> tuple[npt.NDArray[np.uint8], float]:
    """A difference image through the diverging colour map (sRGB uint8 (h, w, 3)) and its scale."""

def settings_schema() -> list[dict[str, Any]]:
    """One dict per render setting: name, type, default, group, group_title, help, expected,
    and min/max/open, choices or syntax by type."""

def default_methods() -> list[str]:
    """The methods compare uses when none are given, as LABEL=NAME=VALUE,... (baseline first)."""

def compare_columns() -> list[str]:
    """The columns of compare's rows, in order (those of compare.csv)."""

class RawComparison(TypedDict):
    frame: int
    methods: list[str]
    baseline: str
    rows: list[dict[str, Any]]
    mismatches: list[dict[str, Any]]
    heat: dict[str, npt.NDArray[np.float32]]
    difference: dict[str, npt.NDArray[np.float32]]
    record: CompareRecord

@final
class CompareRecord:
    """One compared frame as the report folder records it (opaque)."""

@final
class CompareReport:
    """A comparison's report folder, recorded frame by frame and resumable; InvalidInput when
    the folder was recorded for another scene, other methods, baseline or repeat."""

    def __init__(
        self,
        out_dir: str,
        scene: str,
        methods: list[str],
        baseline: str | None = None,
        repeat: int = 3,
    ) -> None: ...
    def frames(self) -> list[int]: ...
    def add(self, record: CompareRecord) -> None: ...
    def write(self) -> str:
        """Writes the report from every recorded frame; returns report.html's path."""
    @property
    def mismatches(self) -> list[str]: ...
    @property
    def out_dir(self) -> str: ...

class RawTrade(TypedDict):
    frame: int
    knobs: list[str]
    rows: list[dict[str, Any]]
    mismatches: list[dict[str, Any]]
    record: TradeFrameRecord

def knobs() -> list[dict[str, Any]]:
    """Every knob of `antumbra trade` (KNOBS), in order: name, kind ('image' | 'work'), trades,
    base, sets, values, default."""

def trade_columns() -> list[str]:
    """The columns of trade's rows, in order (those of trade.csv)."""

@final
class TradeFrameRecord:
    """One traded frame as the trade folder records it (opaque)."""

@final
class TradeReport:
    """A trade's folder, recorded frame by frame and resumable; InvalidInput when the folder
    was recorded for another scene, other knobs or repeat."""

    def __init__(
        self, out_dir: str, scene: str, knobs: list[str] = ..., repeat: int = 3
    ) -> None: ...
    def frames(self) -> list[int]: ...
    def add(self, record: TradeFrameRecord) -> None: ...
    def write(self) -> str:
        """Writes trade.csv, plots/ and trade.md from every recorded frame; returns trade.md's
        path."""
    def recommendations(self) -> list[dict[str, str]]:
        """Per knob: knob, default, recommended, why."""
    @property
    def mismatches(self) -> list[str]: ...
    @property
    def out_dir(self) -> str: ...

class RenderSettings:
    """Render settings by name (settings_schema()), checked when made (InvalidInput names a
    bad setting); the rest take their defaults."""

    def __init__(self, **settings: Any) -> None: ...
    def json(self) -> str:
        """Every setting by name as JSON (a render request's and a spool job's settings)."""

class _SessionMethods:
    @property
    def limits(self) -> dict[str, int]:
        """max_frame_bytes, max_triangles_per_mesh, max_meshes, max_objects,
        max_image_pixels, max_spp, max_lights, max_render_bytes, max_request_passes,
        max_image_texels, max_alpha_materials, max_alpha_ops, max_uv_maps,
        max_material_slots."""
    @property
    def closed(self) -> bool: ...
    @property
    def active_request(self) -> int | None: ...
    def missing_meshes(self, hashes: Iterable[int]) -> list[int]: ...
    def upload_mesh(
        self,
        name: str,
        positions: npt.NDArray[np.float32],
        triangles: npt.NDArray[np.integer],
        normals: npt.NDArray[np.float32] | None = None,
        material_slots: npt.NDArray[np.integer] | None = None,
        uv_maps: Mapping[str, npt.NDArray[np.float32]] | None = None,
    ) -> int: ...
    def missing_images(self, hashes: Iterable[int]) -> list[int]: ...
    def upload_image(self, texels: npt.NDArray[np.float32]) -> int: ...
    def frame_update(
        self,
        frame: int,
        objects: Iterable[Mapping[str, Any]],
        camera: Mapping[str, Any],
        lights: Iterable[Mapping[str, Any]],
        resolution: Mapping[str, Any] | tuple[int, int],
        instances: Iterable[Mapping[str, Any]] | None = None,
        alpha_materials: Iterable[Mapping[str, Any]] | None = None,
    ) -> tuple[list[int], list[int]]:
        """(mesh hashes missing, alpha image hashes missing)."""
    def render(
        self,
        frame: int,
        settings: RenderSettings,
        passes: Iterable[str],
        progress: Progress | None = None,
        timeout: float | None = None,
    ) -> RawResult: ...
    def compare(
        self,
        frame: int,
        methods: Mapping[str, Mapping[str, Any]] | Iterable[str] | None = None,
        baseline: str | None = None,
        repeat: int | None = None,
        settings: Mapping[str, Any] | None = None,
        timeout: float | None = None,
        images: bool = False,
        progress: Callable[[str, int, int], object] | None = None,
    ) -> RawComparison: ...
    def trade(
        self,
        frame: int,
        knobs: Iterable[str] | None = None,
        repeat: int | None = None,
        settings: Mapping[str, Any] | None = None,
        timeout: float | None = None,
        progress: Callable[[str, int, int], object] | None = None,
    ) -> RawTrade: ...
    def cancel(self, request_id: int | None = None) -> bool: ...
    def stats(self) -> dict[str, Any]:
        """sessions, sessions_total, meshes_cached, bytes_cached, renders_done,
        renders_cancelled, renders_failed, uptime_s, meshes_evicted."""
    def start_recording(self, path: str | PathLike[str]) -> None: ...
    def stop_recording(self) -> tuple[int, int]: ...
    def close(self) -> None: ...
    def shutdown(self) -> None: ...

@final
class Connection(_SessionMethods):
    """A session with the daemon over its Unix socket; connects and says Hello."""

    def __init__(
        self,
        socket_path: str,
        timeout: float | None = 10.0,
        client_name: str = "antumbra-python",
        token: str | None = None,
    ) -> None: ...
    @property
    def socket_path(self) -> str: ...
    @property
    def server(self) -> str: ...
    @property
    def protocol_version(self) -> int: ...
    @property
    def bytes_sent(self) -> int: ...
    @property
    def timeout(self) -> float | None: ...

@final
class LocalSession(_SessionMethods):
    """Renders in this process with the daemon's code path."""

    def __init__(self, client_name: str = "antumbra-python") -> None: ...

@final
class RayScene:
    """A BVH over float64 (n, 3) vertices and uint32 (m, 3) triangles (``antumbra.rays``)."""

    def __init__(
        self,
        vertices: npt.NDArray[np.float64],
        triangles: npt.NDArray[np.uint32],
        method: str = "sah",
        width: int = 8,
        collapse: str = "sah",
        threads: int = 0,
        visible: npt.NDArray[np.bool_] | None = None,
    ) -> None: ...
    def intersect(
        self,
        origins: npt.NDArray[np.float64],
        directions: npt.NDArray[np.float64],
        t_near: npt.NDArray[np.float32],
        t_far: npt.NDArray[np.float32],
        closed: bool = False,
        kernel: str = "auto",
        threads: int = 0,
        counters: bool = False,
    ) -> dict[str, npt.NDArray[Any]]: ...
    def occluded(
        self,
        origins: npt.NDArray[np.float64],
        directions: npt.NDArray[np.float64],
        t_near: npt.NDArray[np.float32],
        t_far: npt.NDArray[np.float32],
        closed: bool = False,
        order: str = "fbto",
        kernel: str = "auto",
        threads: int = 0,
        counters: bool = False,
    ) -> dict[str, npt.NDArray[Any]]: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def degenerate_count(self) -> int: ...
    @property
    def width(self) -> int: ...
