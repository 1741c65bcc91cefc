"""What the panel's comparison and trade share: the job's arguments from the scene, the
per-frame update of the panel's table, and the mismatches reported when the job has ended."""

from __future__ import annotations

import json
from pathlib import Path


def job_args(scene, frames: list[int], link, folder: Path, report, repeat: int, on_frame) -> dict:
    """The arguments of a :class:`CompareJob` (or a trade's) run from the panel."""
    step = max(1, scene.frame_step)
    # The animation's frame before the first sets the state, as in one run over the range.
    before = frames[0] - step if frames[0] - step >= scene.frame_start else None
    return dict(
        scene=scene,
        frames=frames,
        options=scene.antumbra.options(),
        link=link,
        out_dir=folder,
        repeat=repeat,
        report=report,
        before=before,
        on_frame=on_frame,
    )


def on_frame(scene, table_property: str, table, show=None):
    """After each frame: the frame, the panel's table (``table(job)`` as JSON in the settings'
    ``table_property``), the progress, then ``show(done)`` if given."""

    def record(job, done):
        settings = scene.antumbra
        settings.last_frame = done.frame
        setattr(settings, table_property, json.dumps(table(job)))
        settings.progress = job.fraction
        if show is not None:
            show(done)

    return record


def report_mismatches(operator, job, written: str | None) -> None:
    """After the job ended as a render ends: where ``written`` (the report) is, if anything was
    done, and every mismatch reported as an error."""
    settings = job.scene.antumbra
    if written is not None and job.done:
        settings.status += f"; {written} in {job.out_dir}"
    for m in job.mismatches:
        operator.report({"ERROR"}, f"antumbra: {m['message']}")
    if job.mismatches:
        settings.status = f"answers differ in {len(job.mismatches)} case(s): {settings.status}"
