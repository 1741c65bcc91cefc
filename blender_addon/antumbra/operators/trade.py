"""The panel's trade: the job its Trade operators run (the ticked knobs on this frame or the
frame range, recorded in the trade folder under the output folder), the recommendations it
shows after each frame, the mismatches it reports, and the operator that lists the knobs."""

from __future__ import annotations

from pathlib import Path

import bpy

from .. import client_loader
from ..jobs.compare import scene_name
from ..jobs.trade import TradeJob, trade_dir
from ..properties import scene as properties
from . import sweep


def make_job(scene, frames: list[int], link, out_dir: Path) -> TradeJob:
    settings = scene.antumbra
    knobs = settings.trade_texts()
    client = client_loader.load()
    folder = trade_dir(out_dir)
    # An unknown knob, a bad value or a folder of another trade is refused here, before any work.
    report = client.TradeReport(
        folder, scene=scene_name(scene), knobs=knobs, repeat=settings.trade_repeat
    )
    settings.trade_table = ""
    return TradeJob(
        **sweep.job_args(
            scene, frames, link, folder, report, settings.trade_repeat, _on_frame(scene)
        ),
        load_images=False,
        knobs=knobs,
    )


def _table(job: TradeJob) -> dict:
    return {
        "frames": len(job.done),
        "folder": str(job.out_dir),
        "recommendations": job.report.recommendations(),
    }


def _on_frame(scene):
    return sweep.on_frame(scene, "trade_table", _table)


def report_mismatches(operator, job: TradeJob) -> None:
    """After the job ended as a render ends: the folder's place, and every mismatch (knob,
    frame, value, light, pixels) reported as an error."""
    sweep.report_mismatches(operator, job, "trade.md")


class ANTUMBRA_OT_trade_knobs_reset(bpy.types.Operator):
    """List the client's knobs again, keeping the ticks and values given"""

    bl_idname = "antumbra.trade_knobs_reset"
    bl_label = "List knobs"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        properties.fill_knobs(context.scene.antumbra)
        return {"FINISHED"}


CLASSES = (ANTUMBRA_OT_trade_knobs_reset,)
