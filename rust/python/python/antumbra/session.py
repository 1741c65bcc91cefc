"""What every session does, whatever renders it: upload meshes, update frames, render, compare
and trade (:class:`LocalSession` in this process; :class:`antumbra.Client` over a socket).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _native
from ._native import Connection as _Connection
from ._native import LocalSession as _LocalSession
from .errors import AnswersDiffer, InvalidInput
from .report import CompareFrame
from .result import Result
from .trade import Knobs, TradeFrame, TradeReport, knob_texts

if TYPE_CHECKING:  # typing.Self is Python 3.11+; annotations are not evaluated at run time
    from typing import Self


__all__ = [
    "COMPARE_COLUMNS",
    "DEFAULT_METHODS",
    "DEFAULT_PASSES",
    "PROTOCOL_VERSION",
    "LocalSession",
    "ProgressCallback",
    "mesh_hash",
]

PROTOCOL_VERSION: int = _native.PROTOCOL_VERSION

#: The passes ``render`` returns unless told otherwise.
DEFAULT_PASSES: tuple[str, ...] = ("masks", "combined", "heat_maps", "visible")

#: The methods ``compare`` uses when none are given (``LABEL=NAME=VALUE,...``), the
#: baseline first: antumbra-core's, as ``antumbra compare`` uses them.
DEFAULT_METHODS: tuple[str, ...] = tuple(_native.default_methods())

#: The columns of ``compare``'s rows, in order: those of ``compare.csv``.
COMPARE_COLUMNS: tuple[str, ...] = tuple(_native.compare_columns())

#: ``progress(stage, done, total)``; return False to cancel the render or comparison.
ProgressCallback = Callable[[str, int, int], "bool | None"]


def mesh_hash(
    positions: np.ndarray,
    triangles: np.ndarray,
    normals: np.ndarray | None = None,
    material_slots: np.ndarray | None = None,
    uv_maps: Mapping[str, np.ndarray] | None = None,
) -> int:
    """The protocol's content hash of a mesh (64-bit XXH3 over the vertex count, the float32
    positions, the triangle count and the uint32 indices, then any corner normals, material
    slots and UV maps; computed in Rust).

    ``positions``: float32 array of shape (n, 3); ``triangles``: integer array of shape (m, 3);
    ``normals``: None or float32 array of shape (3m, 3), each triangle's corner normals;
    ``material_slots`` and ``uv_maps`` as :meth:`Client.upload_mesh` takes them.
    """
    return _native.mesh_hash(positions, triangles, normals, material_slots, uv_maps)


def image_hash(texels: np.ndarray) -> int:
    """The content hash of an alpha image (float32 (height, width), rows bottom first), as
    :meth:`upload_image` returns it; NaN or infinite texels raise :class:`InvalidInput`."""
    return _native.image_hash(texels)


class Missing(list[int]):
    """What :meth:`frame_update` returns: the mesh hashes the frame uses that the session lacks
    (a list, as before alpha materials), and in ``images`` the alpha image hashes its
    materials read that the session lacks. Upload both before rendering."""

    images: list[int]

    def __init__(self, meshes: Iterable[int] = (), images: Iterable[int] = ()) -> None:
        super().__init__(meshes)
        self.images = list(images)

    def __repr__(self) -> str:
        return f"Missing(meshes={list(self)!r}, images={self.images!r})"


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
        material_slots: np.ndarray | None = None,
        uv_maps: Mapping[str, np.ndarray] | None = None,
    ) -> int:
        """Checks, hashes and uploads one mesh in object space; returns its content hash.

        ``positions``: float32 array of shape (n, 3); ``triangles``: integer array (uint32 or
        int) of shape (m, 3) of vertex indices; ``normals``: None (flat shading) or float32
        array of shape (3m, 3), the shading normals at each triangle's corners, read by
        ``facing="shading"`` (docs/facing.md). A NaN or infinite value, or an index out of
        range, raises :class:`InvalidInput` naming the mesh. The GIL is released while the
        arrays are hashed and sent.

        Alpha materials (docs/alpha_export.md): ``material_slots``, uint32 (m,), each
        triangle's material slot (Blender's ``material_index``; None: all slot 0), and
        ``uv_maps``, ``{name: float32 (m, 3, 2)}``, the (u, v) at each triangle's corners of
        the UV maps the alpha materials read. A count that is not one per triangle, or a NaN
        UV, raises :class:`InvalidInput` naming the mesh and the map.
        """
        return self._native.upload_mesh(
            name, positions, triangles, normals, material_slots, uv_maps
        )

    # -- alpha images ---------------------------------------------------------------------

    def missing_images(self, hashes: Iterable[int]) -> list[int]:
        """Which of these alpha image hashes the session lacks (upload those)."""
        return self._native.missing_images(hashes)

    def upload_image(self, texels: np.ndarray) -> int:
        """Checks and hashes an alpha image, float32 (height, width) with rows bottom first
        (Blender's order; the exporter's array), and uploads it unless the session holds it
        already; returns its content hash, which an ``alpha_materials`` dict's ``image``
        names. NaN or infinite texels, or more than the ``max_image_texels`` limit, raise
        :class:`InvalidInput`."""
        return self._native.upload_image(texels)

    # -- frames ---------------------------------------------------------------------------

    def frame_update(
        self,
        frame: int,
        objects: Iterable[Mapping[str, Any]],
        camera: Mapping[str, Any],
        lights: Iterable[Mapping[str, Any]] = (),
        resolution: Mapping[str, Any] | tuple[int, int] = (1920, 1080),
        instances: Iterable[Mapping[str, Any]] = (),
        alpha_materials: Iterable[Mapping[str, Any]] = (),
    ) -> Missing:
        """Sends the whole scene state of one frame, with Blender's field names; returns the
        hashes of the meshes it uses that the session lacks, and in ``.images`` those of the
        alpha images (upload them before rendering): a :class:`Missing`.

        ``objects``: dicts ``name``, ``mesh_hash``, ``matrix_world`` (4x4, indexed
        [row][column] as Blender's ``Matrix`` and numpy), ``visible_camera`` (True),
        ``visible_shadow`` (True; ``cast_shadow`` is accepted as its alias), ``materials``
        (per material slot None, opaque, or an index into ``alpha_materials``; default all
        opaque).

        ``alpha_materials``: the exporter's contract dicts (docs/alpha_export.md) with a
        ``name``: ``{"kind": "opaque"}``, ``{"kind": "constant", "alpha": a}`` or
        ``{"kind": "texture", "image": hash, "channel": "alpha" | "luminance", "uv_map": ""
        | name, "interpolation": "Linear" | "Closest" | "Cubic" | "Smart", "extension":
        "REPEAT" | "EXTEND" | "CLIP" | "MIRROR"}``, each with ``ops`` (``[["MULTIPLY", c],
        ["ONE_MINUS"], ...]``); ``image`` is the hash :meth:`upload_image` returned.

        ``instances``: every placement of a shared mesh as arrays, one dict per mesh and pair
        of visibility flags: ``name``, ``mesh_hash``, ``matrices`` (numpy (n, 4, 4) or
        (n, 3, 4) world matrices, [instance][row][column]; sent as float32, Blender's own
        precision), ``ids`` (n unsigned 32-bit integers naming the instances ``name[id]``;
        default: their index), ``visible_camera``, ``visible_shadow`` (True), ``materials``
        (as an object's, for every instance). Their objects
        follow ``objects`` in the frame's object order (the ``object_ids`` pass counts them
        so). An array equal to the one of its name in the last frame the session accepted
        travels as "unchanged", without its matrices.

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
        meshes, images = self._native.frame_update(
            frame, objects, camera, lights, resolution, instances, alpha_materials
        )
        return Missing(meshes, images)

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
                if missing or missing.images:
                    raise InvalidInput(
                        f"trade: frame {item.get('frame')} uses meshes or images this session "
                        f"lacks: {missing!r} (upload them first)"
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
    """A daemon session run in this process: every request is answered by the daemon's own
    session logic (its upload checks, frame checks, admission, renderer, comparison and trade),
    so a LocalSession and a daemon give the same replies, images bit for bit. It keeps the last
    8 frames sent, as a daemon session does. For tests and notebooks; there is no socket and no
    daemon.

    ``client_name`` fills the ``scene`` column of the statistics, as the daemon does with the
    client's name.
    """

    _native: _LocalSession

    def __init__(self, client_name: str = "antumbra-python") -> None:
        self._native = _LocalSession(client_name)

    def __repr__(self) -> str:
        return f"<antumbra.LocalSession{' closed' if self.closed else ''}>"
