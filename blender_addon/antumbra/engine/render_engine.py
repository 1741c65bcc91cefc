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
from dataclasses import dataclass, field
from pathlib import Path

import bpy

from .. import daemon
from ..export.exporter import Exporter, ExportError
from ..jobs import results
from ..jobs.frame_job import WARM_UP_FRAMES, FrameDone, JobFailed, RenderJob
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
    """A render job's state across its frames: the daemon session, the exporter's caches and
    the frame the session last rendered, handed to the frame job of each frame Blender asks
    for."""

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

    def frame_job(self, scene, frame: int, frame_source, on_stage) -> RenderJob:
        """The frame job of ``frame`` on this render job's session. With the scene's animation
        start on, it warms up on up to WARM_UP_FRAMES predecessors (every ``frame_step``, from
        the start on) that the session has not just rendered."""
        first = scene.antumbra.first_frame()
        step = max(1, scene.frame_step)
        before = range(frame - WARM_UP_FRAMES * step, frame, step)
        return RenderJob(
            scene=scene,
            frames=[frame],
            options=self.options,
            link=self.link,
            load_images=False,
            on_stage=on_stage,
            lead_in=[f for f in before if first is not None and f >= first],
            warm_up=WARM_UP_FRAMES if first is not None else 0,
            frame_source=frame_source,
            exporter=self.exporter,
            last_rendered=self.last,
        )

    def ended(self, job: RenderJob):
        """What the next frame's job takes over from ``job``."""
        self.exporter, self.last = job.exporter, job.last_rendered


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


class _RenderFrames:
    """Frames evaluated in the render's own depsgraph, moved with ``RenderEngine.frame_set`` (as
    for motion blur); it is back at the frame being rendered at the job's end."""

    def __init__(self, engine: bpy.types.RenderEngine, depsgraph, frame: int):
        self.engine, self.depsgraph = engine, depsgraph
        self.frame = self.at = frame

    def evaluate(self, frame: int):
        if frame != self.at:
            self.engine.frame_set(frame, 0.0)
            self.at = frame
        return self.depsgraph

    def restore(self):
        self.evaluate(self.frame)


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
            self._check_size(job, scene, frame)
            done = self._render_frame(job, depsgraph, frame)
        except Cancelled:
            _say(f"frame {frame}: cancelled")
            return
        except Exception as e:  # noqa: BLE001 - Blender shows it and stops the job
            named = isinstance(e, (ExportError, JobFailed))  # their messages name the frame
            message = str(e) if named else f"frame {frame}: {e}"
            self.report({"ERROR"}, f"antumbra: {message}")
            _say(f"error: {message}")
            return
        self._write_result(depsgraph.view_layer.name, done.result)
        if self.is_animation:
            job.pending[frame] = results.frame_record(done, job.key)
        for w in done.warnings:
            self.report({"WARNING"}, f"antumbra: {w}")
            _say(f"warning: {w}")
        _say(f"frame {frame} {done.seconds:.2f} s | " + " | ".join(done.stats_lines))

    # -- one frame, through the frame job ----------------------------------------------------

    def _check_size(self, job: EngineJob, scene, frame: int):
        r = scene.render
        size = job.options.size(r.resolution_x, r.resolution_y, r.resolution_percentage)
        if size != (self.resolution_x, self.resolution_y):
            raise ExportError(
                f"frame {frame}: Blender renders {self.resolution_x} x {self.resolution_y} px, "
                f"antumbra {size[0]} x {size[1]}"
            )

    def _render_frame(self, job: EngineJob, depsgraph, frame: int) -> FrameDone:
        """The frame (after its warm-up) rendered by the frame job, which stops on Blender's
        render break; the status line and progress follow it."""

        def on_stage(frame_job: RenderJob, f: int, stage: str, done: int, total: int):
            warm_up = frame_job.is_warm_up(f)
            label = f"warm-up on frame {f} for frame {frame}" if warm_up else f"frame {f}"
            self.update_stats("", f"antumbra: {label}: {stage}")
            if stage != "export":
                self.update_progress(0.1 + 0.8 * (done + 1) / max(1, total + 1))

        frame_job = job.frame_job(
            depsgraph.scene, frame, _RenderFrames(self, depsgraph, frame), on_stage
        )
        try:
            frame_job.run(POLL_SECONDS, stop=self.test_break)
        finally:
            job.ended(frame_job)
        if frame_job.warmed:
            _say("warmed up on (state only): " + ", ".join(map(str, frame_job.warmed)))
        if frame_job.cancelled:
            raise Cancelled
        if frame_job.error:
            raise JobFailed(frame_job.error)
        self.update_progress(1.0)
        return frame_job.done[-1]

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
