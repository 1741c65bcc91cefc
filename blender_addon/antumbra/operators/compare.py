"""The panel's comparison: the job its Compare operators run (the list's methods on this frame
or the frame range, recorded under the output folder), what it shows after each frame and at
the end (the table, images, mismatches reported), and the operators that edit the list."""

from __future__ import annotations

from pathlib import Path

import bpy

from .. import client_loader
from ..jobs import compare_results, results
from ..jobs.compare import CompareJob, report_dir, scene_name
from ..properties import scene as properties
from . import sweep


def make_job(scene, frames: list[int], link, out_dir: Path) -> CompareJob:
    settings = scene.antumbra
    specs = settings.compare_specs()
    baseline = settings.compare_baseline_label()
    client = client_loader.load()
    folder = report_dir(out_dir)
    # A folder holding another comparison (other methods) is refused here, before any work.
    report = client.CompareReport(
        folder,
        scene=scene_name(scene),
        methods=specs,
        baseline=baseline,
        repeat=settings.compare_repeat,
    )
    settings.compare_table = ""
    return CompareJob(
        **sweep.job_args(
            scene, frames, link, folder, report, settings.compare_repeat, _on_frame(scene)
        ),
        methods=specs,
        baseline=baseline,
    )


def _table(job: CompareJob) -> dict:
    return {
        "baseline": job.baseline,
        "frames": len(job.done),
        "methods": compare_results.table(job.rows, job.baseline, job.mismatches),
    }


def _show_difference(done) -> None:
    shown = [name for name in done.images.values() if " - " in name]
    if shown:
        results.show_in_image_editors(shown[-1])


def _on_frame(scene):
    return sweep.on_frame(scene, "compare_table", _table, show=_show_difference)


def report_mismatches(operator, job: CompareJob) -> None:
    """After the job ended as a render ends: the report's place, and every mismatch (frame,
    method, light, pixels) reported as an error."""
    sweep.report_mismatches(operator, job, "report" if job.report is not None else None)


class ANTUMBRA_OT_compare_method_add(bpy.types.Operator):
    """Add a method to the comparison (a copy of the selected one)"""

    bl_idname = "antumbra.compare_method_add"
    bl_label = "Add method"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        settings = context.scene.antumbra
        methods = settings.compare_methods
        source = (
            methods[settings.compare_index] if 0 <= settings.compare_index < len(methods) else None
        )
        labels = {m.name for m in methods}
        label = next(f"m{i}" for i in range(1, len(methods) + 2) if f"m{i}" not in labels)
        item = methods.add()
        item.name, item.settings = label, source.settings if source else ""
        settings.compare_index = len(methods) - 1
        return {"FINISHED"}


class ANTUMBRA_OT_compare_method_remove(bpy.types.Operator):
    """Remove the selected method from the comparison"""

    bl_idname = "antumbra.compare_method_remove"
    bl_label = "Remove method"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        settings = context.scene.antumbra
        return 0 <= settings.compare_index < len(settings.compare_methods)

    def execute(self, context):
        settings = context.scene.antumbra
        settings.compare_methods.remove(settings.compare_index)
        settings.compare_index = max(
            0, min(settings.compare_index, len(settings.compare_methods) - 1)
        )
        return {"FINISHED"}


class ANTUMBRA_OT_compare_defaults(bpy.types.Operator):
    """Replace the comparison's methods with the default ones (binary SAH front to back as the
    baseline, 8-wide SATO, 8-wide sorted, OSAH from the previous frame, SRDH)"""

    bl_idname = "antumbra.compare_defaults"
    bl_label = "Default methods"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        properties.fill_default_methods(context.scene.antumbra)
        return {"FINISHED"}


CLASSES = (
    ANTUMBRA_OT_compare_method_add,
    ANTUMBRA_OT_compare_method_remove,
    ANTUMBRA_OT_compare_defaults,
)
