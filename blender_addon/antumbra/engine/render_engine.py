"""antumbra as one of Blender's render engines (``ANTUMBRA``): F12, Render Animation and
``blender -b file.blend -E ANTUMBRA -f N | -a`` render each frame through the daemon and fill the
Render Result with the passes of ``passes``; Blender's output settings write the files.

One daemon session per render job (every frame of ``-a``), so method state (OSAH from the
previous frame's visible set, tree reuse) follows the frames as in one ``antumbra render``; the
session ends with the job (``render_complete``/``render_cancel``) or when the next job starts.
With the scene's Animation start on (``scene.antumbra.use_animation_start``, as a farm's chunk
sets it), a job warms its session up before a frame whose predecessors it has not just rendered
(its first frame after the animation's start; a frame after one Blender skipped because its file
exists): the daemon builds their trees and traces their camera rays only
(``render(warm_up=True)``), so every frame equals one run's from the animation's start.
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import bpy

from .. import daemon
from ..export.exporter import Exporter, ExportError
from ..jobs import results
from ..jobs.frame_job import (
    RETRIES_PER_FRAME,
    WARM_UP_FRAMES,
    FrameDone,
    frames_to_warm_up,
    is_cancelled,
    is_lost,
    send_frame,
)
from ..properties import preferences
from ..properties.options import RenderOptions
from . import passes, view_settings

ENGINE_ID = "ANTUMBRA"
#: How often the render thread looks at Blender's cancel flag while the daemon works.
POLL_SECONDS = 0.05
#: Panels of Blender's own render pipeline that antumbra uses too (output, format, frame range,
#: colour management, ...); the rest are the panels of a particular engine.
EXCLUDED_PANELS = {"VIEWLAYER_PT_filter", "VIEWLAYER_PT_layer_passes"}


class Cancelled(Exception):
    """Blender's render job was cancelled (Esc, Ctrl-C in ``blender -b``)."""


@dataclass
class EngineJob:
    """A render job's state across its frames: the daemon session and the exporter's caches."""

    link: daemon.DaemonLink
    options: RenderOptions
    key: str
    exporter: Exporter | None = None
    #: Statistics of rendered frames not yet written (written once Blender saved the frame).
    pending: dict[int, dict] = field(default_factory=dict)
    #: The last frame the session rendered or warmed up on.
    last: int | None = None

    def close(self):
        self.link.close()

    def warm_up_frames(self, frame: int, start: int, step: int) -> list[int]:
        """The frames before ``frame`` (from ``start`` on, every ``step``) the session warms up
        on first (``jobs.frames_to_warm_up``, the one rule)."""
        run = [f for f in range(frame - WARM_UP_FRAMES * step, frame + 1, step) if f >= start]
        return frames_to_warm_up(run, frame, self.last)


_JOB: EngineJob | None = None


def _options(scene) -> RenderOptions:
    # The panel's method settings; the size and the files are Blender's (resolution, output).
    panel = scene.antumbra.options()
    return RenderOptions(settings=panel.settings, heat_maps=panel.heat_maps)


def _job(scene) -> EngineJob:
    global _JOB
    if _JOB is None:
        p = preferences.get()
        options = _options(scene)
        _JOB = EngineJob(
            link=daemon.DaemonLink(
                binary=p.binary_path,
                socket_path=p.socket_path,
                start_automatically=p.start_automatically,
                client_name="antumbra-engine",
                on_log=_say,
            ),
            options=options,
            key=results.run_key(bpy.data.filepath, options),
        )
    return _JOB


def end_job(*_args):
    """Ends the render job's session (a daemon it started stops with it)."""
    global _JOB
    job, _JOB = _JOB, None
    if job is not None:
        job.close()


def _say(line: str):
    print(f"antumbra: {line}", flush=True)


class AntumbraRenderEngine(bpy.types.RenderEngine):
    bl_idname = ENGINE_ID
    bl_label = "antumbra"
    bl_use_preview = False

    def update_render_passes(self, scene=None, renderlayer=None):
        try:
            names = passes.names(renderlayer, scene.antumbra.heat_maps)
        except Exception as e:  # noqa: BLE001 - the compositor must still get Combined
            print(f"antumbra: passes: {e}", flush=True)
            names = [passes.COMBINED]
        for name in names:
            self.register_pass(scene, renderlayer, name, *passes.channels(name))

    def render(self, depsgraph):
        if self.is_preview:
            return
        scene = depsgraph.scene
        frame = scene.frame_current
        job = _job(scene)
        try:
            self._warm_up(job, depsgraph, frame)
            done = self._render_frame(job, depsgraph, frame)
        except Cancelled:
            _say(f"frame {frame}: cancelled")
            return
        except Exception as e:  # noqa: BLE001 - Blender shows it and stops the job
            message = str(e) if isinstance(e, ExportError) else f"frame {frame}: {e}"
            self.report({"ERROR"}, f"antumbra: {message}")
            _say(f"error: {message}")
            return
        self._write_result(depsgraph.view_layer.name, done.result)
        if self.is_animation:
            job.pending[frame] = results.frame_record(done, job.key)
        _say(f"frame {frame} {done.seconds:.2f} s | " + " | ".join(done.stats_lines))

    # -- one frame --------------------------------------------------------------------------

    def _warm_up(self, job: EngineJob, depsgraph, frame: int):
        """The session's warm-up on the frames before ``frame`` it has not just rendered."""
        scene = depsgraph.scene
        first = scene.antumbra.first_frame()
        if first is None:
            return
        before = job.warm_up_frames(frame, first, max(1, scene.frame_step))
        if not before:
            return
        try:
            for f in before:
                # The render's own depsgraph at another frame (as for motion blur).
                self.frame_set(f, 0.0)
                label = f"warm-up on frame {f} for frame {frame}"
                self._request(job, self._export(job, depsgraph, f, label), label, warm_up=True)
                job.last = f
        finally:
            self.frame_set(frame, 0.0)
        _say("warmed up on (state only): " + ", ".join(map(str, before)))

    def _export(self, job: EngineJob, depsgraph, frame: int, label: str):
        """The frame exported; ``label`` names it on the status line (a frame or a warm-up)."""
        scene = depsgraph.scene
        if job.exporter is None:
            job.exporter = Exporter(job.link.module, normals=job.options.wants_normals())
        self.update_stats("", f"antumbra: {label}: export")
        return job.exporter.frame(depsgraph, scene, frame, scene.render.resolution_percentage)

    def _request(self, job: EngineJob, export, label: str, warm_up: bool = False):
        """Sends a frame and renders it (or warms up on it), through daemon losses."""
        client = job.link.module
        retries = 0
        while True:
            work = _Request(job, export, reconnect=retries > 0, warm_up=warm_up)
            work.start()
            self._wait(job, work, label)
            if work.error is None:
                return work.result
            if is_cancelled(client, work.error):
                raise Cancelled
            if is_lost(client, work.error) and retries < RETRIES_PER_FRAME:
                # The daemon went away: reconnect (restart it if the job started it) and send
                # the frame again with all its meshes.
                retries += 1
                job.last = None  # a new session: its state starts afresh
                continue
            raise work.error

    def _render_frame(self, job: EngineJob, depsgraph, frame: int) -> FrameDone:
        started = time.perf_counter()
        scene = depsgraph.scene
        label = f"frame {frame}"
        export = self._export(job, depsgraph, frame, label)
        r = scene.render
        size = job.options.size(r.resolution_x, r.resolution_y, r.resolution_percentage)
        if size != (self.resolution_x, self.resolution_y):
            raise ExportError(
                f"frame {frame}: Blender renders {self.resolution_x} x {self.resolution_y} px, "
                f"antumbra {size[0]} x {size[1]}"
            )
        self.update_progress(0.1)
        result = self._request(job, export, label)
        job.last = frame
        self.update_progress(1.0)
        return FrameDone(
            frame=frame,
            result=result,
            seconds=time.perf_counter() - started,
            export_seconds=export.seconds,
            stats_lines=results.stats_summary(result.stats),
            images={},
            files=[],
            objects=len(export.objects),
            triangles=export.triangles,
        )

    def _wait(self, job: EngineJob, work: _Request, label: str):
        """On the render thread while the daemon works: progress, and Blender's cancel flag
        passed on to the daemon (until a cancel is sent or the request ends)."""
        cancel_sent, shown = False, None
        while work.is_alive():
            work.join(POLL_SECONDS)
            stage, done, total = work.stage
            if stage and work.stage != shown:
                shown = work.stage
                self.update_stats("", f"antumbra: {label}: {stage}")
                self.update_progress(0.1 + 0.8 * (done + 1) / max(1, total + 1))
            if not cancel_sent and self.test_break():
                work.cancelled = True
                client = job.link.client
                cancel_sent = client is not None and client.cancel()
        if work.cancelled and work.error is None:
            # Cancelled before the request went out or after it ended: the frame is not kept.
            raise Cancelled

    def _write_result(self, layer_name: str, result):
        existing = self.get_result()
        layer = next((rl for rl in existing.layers if rl.name == layer_name), None)
        have = {p.name for p in layer.passes} if layer is not None else set()
        for plane, _ in result.planes:
            name = passes.pass_name(plane, layer_name)
            if name not in have and plane not in passes.SKIPPED:
                # A light the view layer did not show before evaluation (an instance).
                count, ids, _ = passes.channels(name)
                self.add_pass(name, count, ids, layer=layer_name)
        rr = self.begin_result(0, 0, self.resolution_x, self.resolution_y, layer=layer_name)
        try:
            target = next((rl for rl in rr.layers if rl.name == layer_name), rr.layers[0])
            passes.fill(target, result)
        finally:
            self.end_result(rr)


class _Request(threading.Thread):
    """The frame sent and rendered on a worker thread (the client releases the GIL)."""

    def __init__(self, job: EngineJob, export, reconnect: bool, warm_up: bool):
        super().__init__(name=f"antumbra frame {export.frame}", daemon=True)
        self.job, self.export, self.reconnect = job, export, reconnect
        self.warm_up = warm_up
        self.result = None
        self.error: BaseException | None = None
        self.stage: tuple[str, int, int] = ("", 0, 0)
        self.cancelled = False

    def run(self):
        try:
            link = self.job.link
            session = link.reconnect() if self.reconnect else link.session()
            send_frame(session, self.export)
            if self.cancelled:
                return
            kwargs = self.job.options.render_kwargs()
            if self.warm_up:
                kwargs.update(passes=(), warm_up=True)  # only the session's state
            self.result = session.render(self.export.frame, progress=self._progress, **kwargs)
        except BaseException as error:  # noqa: BLE001 - handed to the render thread
            self.error = error

    def _progress(self, stage: str, done: int, total: int):
        self.stage = (stage, done, total)
        return not self.cancelled


# -- the job's end, and its statistics beside Blender's output ---------------------------------


@bpy.app.handlers.persistent
def _on_write(scene, *_args):
    """After Blender saved a frame: its statistics, then the tables, beside the output."""
    job = _JOB
    frame = scene.frame_current
    if job is None or frame not in job.pending:
        return
    record = job.pending.pop(frame)
    out = stats_folder(scene, frame)
    out.mkdir(parents=True, exist_ok=True)
    results.write_frame_stats(out, record)
    results.write_tables(out)


def stats_folder(scene, frame: int) -> Path:
    """Where the job's statistics go. Beside Blender's frames when the output path names their
    files (``//render/shot_####``: the user's own name for this job's frames); when it names
    only a folder (Blender's default ``/tmp/``, shared by every scene), in a folder of the
    .blend's own inside it (``/tmp/bedroom.antumbra/``), so another scene's render does not
    overwrite the tables."""
    frames = Path(bpy.path.abspath(scene.render.frame_path(frame=frame))).parent
    if os.path.basename(bpy.path.abspath(scene.render.filepath)):
        return frames
    return frames / f"{Path(bpy.data.filepath).stem or 'untitled'}.antumbra"


@bpy.app.handlers.persistent
def _on_init(scene=None, *_args):
    end_job()  # a job left over (a render whose end Blender did not report)
    scene = scene if isinstance(scene, bpy.types.Scene) else bpy.context.scene
    if scene is not None:
        # Before any frame is written: antumbra's values as values, another engine's own view.
        view_settings.follow_engine(scene, ENGINE_ID)


@bpy.app.handlers.persistent
def _on_end(*_args):
    end_job()


_HANDLERS = (
    ("render_init", _on_init),
    ("render_write", _on_write),
    ("render_complete", _on_end),
    ("render_cancel", _on_end),
)


def _panels():
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if engines is not None and "BLENDER_RENDER" in engines:
            if panel.__name__ not in EXCLUDED_PANELS:
                yield panel


def register():
    bpy.utils.register_class(AntumbraRenderEngine)
    for panel in _panels():
        panel.COMPAT_ENGINES.add(ENGINE_ID)
    for name, handler in _HANDLERS:
        getattr(bpy.app.handlers, name).append(handler)
    view_settings.register(ENGINE_ID)


def unregister():
    end_job()
    view_settings.unregister()
    for name, handler in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if handler in handlers:
            handlers.remove(handler)
    for panel in _panels():
        panel.COMPAT_ENGINES.discard(ENGINE_ID)
    bpy.utils.unregister_class(AntumbraRenderEngine)
