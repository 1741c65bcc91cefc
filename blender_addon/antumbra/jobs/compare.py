"""A comparison of methods over frames: a :class:`RenderJob` whose request is ``compare_frame``.
Each frame is exported once and compared with every method on a session of the job's own (so
every method's state starts fresh and runs through the frames in order, as in ``antumbra
compare``), then recorded in the report folder. Before a frame whose predecessors this session
has not compared (a resumed batch, "Compare frame", a farm's chunk), every method warms up on
them (``RenderJob``'s warm-up, ``compare_frame(warm_up=True)``: trees and primary rays only), so
OSAH from the previous frame's visibility and tree reuse see what one run would."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import bpy

from . import compare_results
from .frame_job import FrameDone, RenderJob

#: The report folder's name under the output folder (panel and batch).
COMPARE_DIR = "compare"


def report_dir(out_dir: Path) -> Path:
    return out_dir / COMPARE_DIR


def scene_name(scene) -> str:
    """What the report calls the scene: the .blend's name and the scene's."""
    blend = Path(bpy.data.filepath).stem or "unsaved"
    return f"{blend}:{scene.name}"


def baseline_of(methods: list[str], baseline: str | None) -> str:
    """The baseline's label: the one given, or the first method's."""
    return baseline or methods[0].partition("=")[0]


@dataclass
class CompareJob(RenderJob):
    #: ``LABEL=NAME=VALUE,...`` per method, the baseline among them.
    methods: list[str] = field(default_factory=list)
    baseline: str | None = None
    repeat: int = 3
    #: ``antumbra.CompareReport`` the frames are added to (None: nothing written).
    report: object = None
    #: The animation's frame before ``frames[0]``, compared first to set the methods' state
    #: (the ``lead_in`` of one frame).
    before: int | None = None
    #: A frame whose predecessor this session has not compared comes after it.
    warm_up: int = 1
    #: Every mismatch of the recorded frames (dicts: frame, label, what, pixels, message).
    mismatches: list[dict] = field(default_factory=list)
    #: The recorded frames' rows (compare.csv's columns), in order.
    rows: list[dict] = field(default_factory=list)

    def __post_init__(self):
        super().__post_init__()
        if self.before is not None and not self.lead_in:
            self.lead_in = [self.before]
        self._own = None  # the job's session: its own comparison state

    # -- the daemon -------------------------------------------------------------------------

    def _session(self):
        if self._reconnect:
            # The daemon went away and the methods' state with it (see _failed_frame).
            self._reconnect = False
            self._close_own()
            self.link.reconnect()
        if self._own is None or self._own.closed:
            self.link.session()  # a daemon to talk to, started if the link may
            self._own = self.link.module.Client.connect(
                self.link.socket(), client_name=f"{self.link.client_name}-compare"
            )
        return self._own

    def _request(self, session, frame: int):
        return session.compare_frame(
            frame,
            self.methods,
            baseline=self.baseline,
            repeat=self.repeat,
            progress=self._progress,
            warm_up=self.is_warm_up(frame),
            **self.options.settings_kwargs(),
        )

    def _cancel_target(self):
        return self._own

    def _close_own(self):
        own, self._own = self._own, None
        if own is not None:
            try:
                own.close()
            except Exception:  # noqa: BLE001 - a dead daemon cannot be closed politely
                pass

    def _finish(self) -> bool:
        self._close_own()
        return super()._finish()

    # -- the result -------------------------------------------------------------------------

    def _record(self, work):
        """Records a compared frame (not a warm-up) and reports it done."""
        compared = work.result
        if self.report is not None:
            self.report.add(compared)
            self.report.write()
        images = self._images(compared)
        self.rows.extend(compared.rows)
        self.mismatches.extend(compared.mismatches)
        done = FrameDone(
            frame=work.frame,
            result=compared.rows,  # the images stay out: a long run would hold them all
            seconds=time.perf_counter() - work.started + work.export.seconds,
            export_seconds=work.export.seconds,
            stats_lines=self._frame_lines(compared),
            images=images,
            files=[],
            objects=work.export.placements(),
            triangles=work.export.triangles,
            warnings=work.export.warnings,
        )
        self.done.append(done)
        if self.on_frame is not None:
            self.on_frame(self, done)

    # What a trade (``TradeJob``) records otherwise: its lines per frame, and no images.

    def _images(self, compared) -> dict:
        client = self.link.module
        return compare_results.load_images(client, compared) if self.load_images else {}

    def _frame_lines(self, compared) -> list[str]:
        return compare_results.frame_lines(compared.rows, compared.baseline, compared.mismatches)
