"""Operators: start and stop the daemon, render the shadow pass of this frame or of the frame
range, compare methods or trade knobs on them. Renders, comparisons and trades are modal when
invoked from the UI (a timer steps the job; Blender stays responsive; Esc cancels) and run to the
end when called from scripts (``execute``)."""

from __future__ import annotations

import json
from pathlib import Path

import bpy

from .. import daemon
from ..jobs import results
from ..jobs.compare import CompareJob
from ..jobs.frame_job import RenderJob
from ..properties import preferences
from . import compare, trade

#: The job the UI is running (one at a time).
_ACTIVE: RenderJob | None = None


def current_link() -> daemon.DaemonLink:
    p = preferences.get()
    return daemon.link(p.binary_path, p.socket_path, p.start_automatically)


def output_dir(settings) -> Path:
    path = bpy.path.abspath(settings.output_dir) if settings.output_dir else ""
    if not path or path.startswith("//"):
        # An unsaved .blend has no folder for "//": use Blender's temporary folder.
        path = str(Path(bpy.app.tempdir or "/tmp") / "antumbra")
    return Path(path)


def _on_frame(scene):
    def record(job: RenderJob, done):
        settings = scene.antumbra
        settings.last_frame = done.frame
        settings.last_stats = json.dumps(done.result.stats)
        settings.progress = job.fraction
        name = results.COMBINED_IMAGE if results.COMBINED_IMAGE in done.images.values() else None
        if name:
            results.show_in_image_editors(name)

    return record


def frames_of(scene, animation: bool) -> list[int]:
    """The scene's frame range, or its current frame."""
    if animation:
        return list(range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step)))
    return [scene.frame_current]


def _make_job(context, animation: bool) -> RenderJob:
    scene = context.scene
    settings = scene.antumbra
    frames = frames_of(scene, animation)
    return RenderJob(
        scene=scene,
        frames=frames,
        options=settings.options(),
        link=current_link(),
        out_dir=output_dir(settings) if settings.save_files or animation else None,
        on_frame=_on_frame(scene),
    )


def _report_end(operator, job: RenderJob) -> set[str]:
    settings = job.scene.antumbra
    settings.running = False
    if job.error:
        settings.status = f"failed: {job.error}"
        operator.report({"ERROR"}, f"antumbra: {job.error}")
        return {"CANCELLED"}
    if job.cancelled:
        settings.status = f"cancelled after {len(job.done)} of {job.total} frames"
        operator.report({"WARNING"}, f"antumbra: {settings.status}")
        return {"CANCELLED"}
    seconds = sum(d.seconds for d in job.done)
    settings.status = f"{len(job.done)} frame(s) in {seconds:.2f} s"
    operator.report({"INFO"}, f"antumbra: {settings.status}")
    return {"FINISHED"}


class _JobOperator:
    """A job run to the end from scripts (``execute``) or step by step from a timer when
    invoked from the UI (modal: progress in the panel and the status bar, Esc cancels)."""

    _timer = None
    _job: RenderJob | None = None

    @classmethod
    def poll(cls, context):
        return context.scene is not None and _ACTIVE is None

    def make_job(self, context) -> RenderJob:
        raise NotImplementedError

    def report_end(self, job) -> set[str]:
        return _report_end(self, job)

    def _start(self, context) -> RenderJob | None:
        try:
            return self.make_job(context)
        except Exception as e:  # noqa: BLE001 - shown to the user (bad methods, folder)
            context.scene.antumbra.status = f"failed: {e}"
            self.report({"ERROR"}, f"antumbra: {e}")
            return None

    def execute(self, context):
        job = self._start(context)
        if job is None:
            return {"CANCELLED"}
        context.scene.antumbra.running = True
        job.run()
        return self.report_end(job)

    def invoke(self, context, event):
        global _ACTIVE
        self._job = self._start(context)
        if self._job is None:
            return {"CANCELLED"}
        _ACTIVE = self._job
        settings = context.scene.antumbra
        settings.running = True
        settings.progress = 0.0
        settings.status = "starting"
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.05, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 1000)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC" and event.value == "PRESS":
            job.cancel()
            context.scene.antumbra.status = "cancelling"
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        finished = job.step()
        self._show_progress(context, job)
        if finished:
            return self._end(context)
        return {"PASS_THROUGH"}

    def _show_progress(self, context, job: RenderJob):
        settings = context.scene.antumbra
        frame = job.current_frame
        stage = job.stage[0] or "export"
        if getattr(job, "warming_up", False):
            stage = f"methods' state ({stage})"
        if frame is not None:
            settings.status = f"frame {frame}: {stage} ({len(job.done)}/{job.total} done)"
        settings.progress = job.fraction
        context.window_manager.progress_update(int(1000 * job.fraction))
        if context.workspace is not None:
            context.workspace.status_text_set(f"antumbra: {settings.status}  (Esc to cancel)")
        for area in context.screen.areas if context.screen else ():
            if area.type in {"PROPERTIES", "VIEW_3D"}:
                area.tag_redraw()

    def _end(self, context):
        global _ACTIVE
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        _ACTIVE = None
        return self.report_end(self._job)

    def cancel(self, context):
        # Blender ends the modal operator (file load, quit): stop the job with it.
        global _ACTIVE
        if self._job is not None:
            self._job.cancel()
            self._job.run()
        _ACTIVE = None


class ANTUMBRA_OT_render(_JobOperator, bpy.types.Operator):
    """Render antumbra's shadow pass, heat maps and statistics"""

    bl_idname = "antumbra.render"
    bl_label = "Render shadow pass"
    bl_options = {"REGISTER"}

    animation: bpy.props.BoolProperty(
        name="Animation", description="Render the scene's frame range", default=False
    )

    def make_job(self, context) -> RenderJob:
        return _make_job(context, self.animation)


class _SweepOperator(_JobOperator):
    """A comparison or a trade: ``_ops`` (``operators.compare``, ``operators.trade``) makes its
    job and reports its mismatches after the render's end."""

    _ops = None

    def make_job(self, context) -> CompareJob:
        scene = context.scene
        frames = frames_of(scene, self.animation)
        return self._ops.make_job(scene, frames, current_link(), output_dir(scene.antumbra))

    def report_end(self, job) -> set[str]:
        ended = _report_end(self, job)
        self._ops.report_mismatches(self, job)
        return ended


class ANTUMBRA_OT_compare(_SweepOperator, bpy.types.Operator):
    """Compare the methods of the list on this frame or the frame range: work per ray, time and
    answers per method, a report folder under the output folder, heat maps and differences"""

    bl_idname = "antumbra.compare"
    bl_label = "Compare methods"
    bl_options = {"REGISTER"}
    _ops = compare

    animation: bpy.props.BoolProperty(
        name="Animation", description="Compare over the scene's frame range", default=False
    )


class ANTUMBRA_OT_trade(_SweepOperator, bpy.types.Operator):
    """Trade speed against accuracy on this frame or the frame range: each ticked knob (none:
    every knob) swept over its values, trade.csv, plots and trade.md under the output folder"""

    bl_idname = "antumbra.trade"
    bl_label = "Trade speed against accuracy"
    bl_options = {"REGISTER"}
    _ops = trade

    animation: bpy.props.BoolProperty(
        name="Animation", description="Trade over the scene's frame range", default=False
    )


class ANTUMBRA_OT_daemon_start(bpy.types.Operator):
    """Connect to the antumbra daemon, starting it if none is running"""

    bl_idname = "antumbra.daemon_start"
    bl_label = "Start daemon"

    def execute(self, context):
        link = current_link()
        try:
            link.start_automatically = True
            link.session()
        except Exception as e:  # noqa: BLE001 - shown to the user
            self.report({"ERROR"}, f"antumbra: {e}")
            return {"CANCELLED"}
        context.scene.antumbra.status = f"daemon: {link.status()}"
        return {"FINISHED"}


class ANTUMBRA_OT_daemon_stop(bpy.types.Operator):
    """Stop the antumbra daemon"""

    bl_idname = "antumbra.daemon_stop"
    bl_label = "Stop daemon"

    @classmethod
    def poll(cls, context):
        return _ACTIVE is None

    def execute(self, context):
        link = current_link()
        try:
            link.stop()
        except Exception as e:  # noqa: BLE001 - shown to the user
            self.report({"WARNING"}, f"antumbra: {e}")
        context.scene.antumbra.status = "daemon stopped"
        return {"FINISHED"}


CLASSES = (
    ANTUMBRA_OT_render,
    ANTUMBRA_OT_compare,
    ANTUMBRA_OT_trade,
    ANTUMBRA_OT_daemon_start,
    ANTUMBRA_OT_daemon_stop,
)
