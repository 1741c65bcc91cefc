"""The one frame driver: frames exported, sent, rendered and collected, as steps that never block
Blender. Each frame is exported on the main thread (Blender's data is not thread-safe), sent and
rendered on a worker thread (the client releases the GIL while it waits), and collected on the
main thread. The modal operators call :meth:`RenderJob.step` from a timer; batches, ``execute``
and the render engine (on Blender's render thread, one job per frame Blender asks for, on the
render job's session) call :meth:`RenderJob.run`.

What differs between the drivers is a parameter: where a frame is evaluated (``frames``: the
scene's frame, or the render's own depsgraph), what a finished frame becomes (images, files and
statistics in ``out_dir``, or the engine's Render Result from ``done``), who may stop it (Esc,
Blender's render break) and what the daemon is asked (``_request``: a render, a comparison, a
trade).

A lost daemon is reconnected (or restarted) and the frame sent again; a frame counts as done
only once its files and statistics are written, so a cancelled or failed job leaves complete
frames only. A job that warms up (``warm_up``) first warms its session up on the frames before
one whose predecessors its session has not just rendered (a farm's chunk, a resumed batch): the
daemon builds their trees and traces their primary rays only (``render(warm_up=True)``), so
every frame's trees and work counters are those of one run over the animation.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import bpy

from ..export.exporter import Exporter, ExportError, FrameExport, send
from ..properties.options import RenderOptions
from . import results

#: How often one frame is sent again after the daemon went away.
RETRIES_PER_FRAME = 2

#: The predecessors a warm-up goes through: the frame before gives the previous-frame visible
#: set, and the one before that the trees a run would still hold, reused when the set did not
#: change.
WARM_UP_FRAMES = 2


def frames_to_warm_up(
    run: list[int], frame: int, last_rendered: int | None, count: int = WARM_UP_FRAMES
) -> list[int]:
    """The warm-up rule, for every frame driver (jobs, batches, the render engine): the frames
    of ``run`` (the animation's frames in order) before ``frame`` that a session renders state
    only before it, up to ``count``, fewer when the session has just rendered some of them (up
    to ``last_rendered``)."""
    if frame not in run:  # before the animation's start: nothing to warm up on
        return []
    i = run.index(frame)
    before = run[max(0, i - count) : i]
    if last_rendered in before:
        before = before[before.index(last_rendered) + 1 :]
    return before


class JobFailed(RuntimeError):
    """A frame could not be rendered; the message names the frame (and object or field)."""


class SceneFrames:
    """Frames evaluated by setting the scene's frame (the panel's jobs, batches); the scene's
    frame is put back at the job's end."""

    def __init__(self, scene):
        self.scene = scene
        self.start = scene.frame_current

    def evaluate(self, frame: int):
        """The evaluated depsgraph of ``frame``."""
        if self.scene.frame_current != frame:
            self.scene.frame_set(frame)
        return bpy.context.evaluated_depsgraph_get()

    def restore(self):
        if self.scene.frame_current != self.start:
            self.scene.frame_set(self.start)


def is_lost(client, error: BaseException) -> bool:
    """Whether the daemon went away (killed, crashed, restarted): the frame is sent again."""
    return isinstance(
        error, (client.ConnectionLost, client.DaemonUnavailable, client.DaemonTimeout)
    )


def is_cancelled(client, error: BaseException) -> bool:
    return isinstance(error, client.DaemonError) and getattr(error, "code", "") == "Cancelled"


@dataclass
class FrameDone:
    frame: int
    result: object
    seconds: float
    export_seconds: float
    stats_lines: list[str]
    images: dict[str, str]
    files: list[str]
    objects: int
    triangles: int
    #: Export warnings first said at this frame (``FrameExport.warnings``).
    warnings: list[str] = field(default_factory=list)


@dataclass
class _Work:
    frame: int
    export: FrameExport
    thread: threading.Thread | None = None
    result: object = None
    error: BaseException | None = None
    started: float = field(default_factory=time.perf_counter)


@dataclass
class RenderJob:
    scene: object
    frames: list[int]
    options: RenderOptions
    link: object
    out_dir: Path | None = None
    load_images: bool = True
    on_frame: object = None
    #: ``on_stage(job, frame, stage, done, total)`` on the main thread as a frame's export starts
    #: (stage ``export``) and as ``run`` sees the daemon's progress move (a comparison: each
    #: method pass).
    on_stage: object = None
    #: Where the frames are evaluated (``evaluate(frame)``, ``restore()``); None: the scene's
    #: frame (:class:`SceneFrames`).
    frame_source: object = None
    #: Reads meshes from Blender, keeping static ones between frames; a driver that keeps its
    #: session across jobs (the engine) passes it on from job to job, as it does ``last_rendered``.
    exporter: Exporter | None = None
    #: The last frame the session rendered or warmed up on.
    last_rendered: int | None = None
    #: Recorded with each frame's statistics (``results.run_key``): what a resume compares.
    key: str | None = None
    #: The animation's frames before ``frames[0]``, in order, that a warm-up may render.
    lead_in: list[int] = field(default_factory=list)
    #: How many predecessors of a frame the session warms up on first when it has not just
    #: rendered them (0: every frame as it comes).
    warm_up: int = 0
    #: Frames the session warmed up on (their state only: no images, no rows).
    warmed: list[int] = field(default_factory=list)
    #: Frames left, in order.
    pending: deque = field(init=False)
    done: list[FrameDone] = field(default_factory=list)
    skipped: list[int] = field(default_factory=list)
    error: str | None = None
    cancelled: bool = False
    finished: bool = False
    #: (stage, done, total) of the render in flight, for progress displays.
    stage: tuple[str, int, int] = ("", 0, 0)

    def __post_init__(self):
        self.pending = deque(self.frames)
        if self.frame_source is None:
            self.frame_source = SceneFrames(self.scene)
        self._work: _Work | None = None
        self._retries = 0
        self._reconnect = False
        self._shown_stage: tuple[str, int, int] | None = None

    # -- the steps --------------------------------------------------------------------------

    def skip_finished(self, finished: set[int]):
        """Leaves out frames already complete in the output folder (resuming a batch)."""
        self.skipped = [f for f in self.pending if f in finished]
        self.pending = deque(f for f in self.pending if f not in finished)

    def step(self) -> bool:
        """Advances the job without blocking; True once it has finished."""
        if self.finished:
            return True
        if self._work is None:
            if self.cancelled or not self.pending:
                return self._finish()
            try:
                self._begin(self.pending[0])
            except ExportError as e:
                return self._fail(str(e))  # it names the frame and object
            except Exception as e:  # noqa: BLE001 - reported, job ends
                return self._fail(f"frame {self.pending[0]}: {e}")
            return False
        if self._work.thread.is_alive():
            return False
        work, self._work = self._work, None
        if work.error is None:
            try:
                self._collect(work)
            except Exception as e:  # noqa: BLE001 - reported, job ends
                return self._fail(f"frame {work.frame}: writing results: {e}")
            # A frame done before the pending one (a warm-up) leaves it pending.
            if self.pending and self.pending[0] == work.frame:
                self.pending.popleft()
            self._retries = 0
            return False
        return self._failed_frame(work)

    def run(self, poll: float = 0.005, stop=None) -> RenderJob:
        """Runs to the end in this thread (batches, ``execute``, the engine); ``stop()``, asked
        every ``poll`` seconds, cancels the job when it says so (Blender's render break)."""
        while not self.step():
            if self._work is not None and self._work.thread is not None:
                self._work.thread.join(poll)
                self._show_stage()
            if stop is not None and not self.cancelled and stop():
                self.cancel()
        return self

    def _show_stage(self):
        if self.on_stage is None or self._work is None or not self.stage[0]:
            return
        if self.stage != self._shown_stage:
            self._shown_stage = self.stage
            self.on_stage(self, self._work.frame, *self.stage)

    def cancel(self):
        """Stops after the frame in flight (which the daemon is asked to abandon)."""
        self.cancelled = True
        client = self._cancel_target()
        if client is not None and self._work is not None:
            try:
                client.cancel()
            except Exception:  # noqa: BLE001 - nothing in flight, or the daemon is gone
                pass

    def _cancel_target(self):
        """The session whose request in flight ``cancel`` stops."""
        return self.link.client

    # -- which frame goes next --------------------------------------------------------------

    def _next_to_render(self, frame: int) -> int:
        """``frame``, or the first of its predecessors a warm-up still has to render."""
        if not self.warm_up:
            return frame
        run = self.lead_in + self.frames
        before = frames_to_warm_up(run, frame, self.last_rendered, self.warm_up)
        return before[0] if before else frame

    def is_warm_up(self, frame: int) -> bool:
        """Whether ``frame``, in flight, is a warm-up (not the pending frame)."""
        return not self.pending or frame != self.pending[0]

    @property
    def warming_up(self) -> bool:
        return self._work is not None and self.is_warm_up(self._work.frame)

    # -- inside a step ----------------------------------------------------------------------

    def _begin(self, frame: int):
        frame = self._next_to_render(frame)
        if self.exporter is None:
            self.exporter = Exporter(self.link.module, normals=self.options.wants_normals())
        self.stage = self._shown_stage = ("export", 0, 0)
        if self.on_stage is not None:
            self.on_stage(self, frame, *self.stage)
        depsgraph = self.frame_source.evaluate(frame)
        percentage = self.options.percentage(self.scene.render.resolution_percentage)
        export = self.exporter.frame(depsgraph, self.scene, frame, percentage)
        self._work = _Work(frame, export)
        # A daemon thread: a request the daemon never answers does not keep Blender from exiting.
        self._work.thread = threading.Thread(
            target=self._send_and_render,
            args=(self._work,),
            name=f"antumbra frame {frame}",
            daemon=True,
        )
        self._work.thread.start()

    def _send_and_render(self, work: _Work):
        """On the worker thread: everything that waits for the daemon."""
        try:
            session = self._session()
            send(session, work.export)
            work.result = self._request(session, work.frame)
        except BaseException as error:  # noqa: BLE001 - handed to the main thread
            work.error = error

    def _session(self):
        """On the worker thread: the session to send the frame on (a new one after a loss)."""
        if self._reconnect:
            self._reconnect = False
            return self.link.reconnect()
        return self.link.session()

    def _request(self, session, frame: int):
        """On the worker thread: what the job asks of the daemon for a frame it has sent."""
        kwargs = self.options.render_kwargs()
        if self.is_warm_up(frame):
            kwargs.update(passes=(), warm_up=True)  # only the session's state is wanted
        return session.render(frame, progress=self._progress, **kwargs)

    def _progress(self, stage: str, done: int, total: int):
        self.stage = (stage, done, total)
        return not self.cancelled

    def _collect(self, work: _Work):
        self.last_rendered = work.frame
        if self.is_warm_up(work.frame):
            self.warmed.append(work.frame)  # the session's state: not a result
            return
        self._record(work)

    def _record(self, work: _Work):
        """Records a rendered frame (not a warm-up) and reports it done."""
        result = work.result
        client = self.link.module
        images = results.load_images(client, result) if self.load_images else {}
        files: list[str] = []
        if self.out_dir is not None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            if self.options.save_exr or self.options.save_png:
                files = result.save(
                    self.out_dir, exr=self.options.save_exr, png=self.options.save_png
                )
        done = FrameDone(
            frame=work.frame,
            result=result,
            seconds=time.perf_counter() - work.started + work.export.seconds,
            export_seconds=work.export.seconds,
            stats_lines=results.stats_summary(result.stats),
            images=images,
            files=files,
            objects=work.export.placements(),
            triangles=work.export.triangles,
            warnings=work.export.warnings,
        )
        if self.out_dir is not None:
            results.write_frame_stats(self.out_dir, results.frame_record(done, self.key))
            results.write_tables(self.out_dir)
        self.done.append(done)
        if self.on_frame is not None:
            self.on_frame(self, done)

    def _failed_frame(self, work: _Work) -> bool:
        client = self.link.module
        error = work.error
        if self.cancelled or is_cancelled(client, error):
            self.cancelled = True
            return self._finish()
        if is_lost(client, error) and self._retries < RETRIES_PER_FRAME:
            # The daemon went away (killed, crashed, restarted): reconnect and send the frame
            # again with all its meshes; nothing of it was kept.
            self._retries += 1
            self._reconnect = True
            self.last_rendered = None  # a new session: its state starts afresh
            return False
        return self._fail(f"frame {work.frame}: {error}")

    def _fail(self, message: str) -> bool:
        self.error = message
        return self._finish()

    def _finish(self) -> bool:
        self.finished = True
        self.frame_source.restore()
        return True

    # -- for displays -----------------------------------------------------------------------

    @property
    def total(self) -> int:
        return len(self.frames) - len(self.skipped)

    @property
    def fraction(self) -> float:
        if not self.total:
            return 1.0
        return min(1.0, len(self.done) / self.total)

    @property
    def current_frame(self) -> int | None:
        return self._work.frame if self._work is not None else None
