"""The panel's trade: the job its Trade operators run (the ticked knobs on this frame or the
frame range, recorded in the trade folder under the output folder), the recommendations it
shows after each frame, the mismatches it reports, and the operator that lists the knobs."""

from __future__ import annotations

import json
from pathlib import Path

import bpy

from . import client_loader, properties
from .compare_job import scene_name
from .trade_job import TradeJob, trade_dir


def make_job(scene, frames: list[int], link, out_dir: Path) -> TradeJob:
    settings = scene.antumbra
    knobs = settings.trade_texts()
    client = client_loader.load()
    folder = trade_dir(out_dir)
    # An unknown knob, a bad value or a folder of another trade is refused here, before any work.
    report = client.TradeReport(
        folder, scene=scene_name(scene), knobs=knobs, repeat=settings.trade_repeat
    )
    step = max(1, scene.frame_step)
    before = frames[0] - step if frames[0] - step >= scene.frame_start else None
    settings.trade_table = ""
    return TradeJob(
        scene=scene,
        frames=frames,
        options=settings.options(),
        link=link,
        out_dir=folder,
        load_images=False,
        knobs=knobs,
        repeat=settings.trade_repeat,
        report=report,
        before=before,
        on_frame=_on_frame(scene),
    )


def _on_frame(scene):
    def record(job: TradeJob, done):
        settings = scene.antumbra
        settings.last_frame = done.frame
        settings.trade_table = json.dumps(
            {
                "frames": len(job.done),
                "folder": str(job.out_dir),
                "recommendations": job.report.recommendations(),
            }
        )
        settings.progress = job.fraction

    return record


def report_mismatches(operator, job: TradeJob) -> None:
    """After the job ended as a render ends: the folder's place, and every mismatch (knob,
    frame, value, light, pixels) reported as an error."""
    settings = job.scene.antumbra
    if job.done:
        settings.status += f"; trade.md in {job.out_dir}"
    for m in job.mismatches:
        operator.report({"ERROR"}, f"antumbra: {m['message']}")
    if job.mismatches:
        settings.status = f"answers differ in {len(job.mismatches)} case(s): {settings.status}"


class ANTUMBRA_OT_trade_knobs_reset(bpy.types.Operator):
    """List the client's knobs again, keeping the ticks and values given"""

    bl_idname = "antumbra.trade_knobs_reset"
    bl_label = "List knobs"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        properties.fill_knobs(context.scene.antumbra)
        return {"FINISHED"}


CLASSES = (ANTUMBRA_OT_trade_knobs_reset,)
