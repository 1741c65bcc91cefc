"""Batches through the daemon's spool folder (``antumbra serve --spool DIR``, docs/daemon.md):
the frames are exported once into a job (``job.json`` + ``scene.antrec``), the daemon renders
it crash-safely on its own schedule, and the batch follows ``manifest.json`` and collects the
finished frames into its output folder. A job's id is derived from the .blend, its modification
time, the frames and the settings, so running the same batch again finds the same job (finished
or half-done) instead of submitting a new one."""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import time
from pathlib import Path

import bpy

from ..export.exporter import Exporter, send
from ..properties.options import RenderOptions


class SpoolError(RuntimeError):
    pass


def job_id(blend: str, frames: list[int], options: RenderOptions) -> str:
    stem = Path(blend).stem or "unsaved"
    mtime = os.stat(blend).st_mtime_ns if blend and os.path.exists(blend) else 0
    key = json.dumps([blend, mtime, frames, options.render_kwargs()], sort_keys=True, default=str)
    # A short readable part (48 characters, at most 192 bytes): the daemon bounds job ids
    # (MAX_JOB_ID_BYTES), and a long .blend name must not make the job impossible to submit.
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in stem)[:48]
    return f"{safe}-{hashlib.sha1(key.encode()).hexdigest()[:12]}"


def job_settings(options: RenderOptions, client) -> dict:
    """The job's settings as the protocol spells them, checked by the client."""
    return client.render_settings(**options.settings_kwargs())


def daemon_watching(spool: Path) -> bool:
    """Whether a daemon holds the spool's lock (``antumbra serve --spool`` keeps it locked)."""
    lock = spool / "daemon.lock"
    if not lock.exists():
        return False
    with open(lock, "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(f, fcntl.LOCK_UN)
        return False


def submit(
    spool: Path, jid: str, scene, frames: list[int], options: RenderOptions, client, log
) -> None:
    """Exports every frame into ``incoming/<jid>`` and renames it into ``jobs/<jid>``."""
    incoming = spool / "incoming" / f".{jid}-{os.getpid()}"
    shutil.rmtree(incoming, ignore_errors=True)
    incoming.mkdir(parents=True)
    exporter = Exporter(client, normals=options.wants_normals())
    start_frame = scene.frame_current
    started = time.perf_counter()
    try:
        with client.LocalSession(client_name="antumbra-batch") as recorder:
            recorder.start_recording(str(incoming / "scene.antrec"))
            for f in frames:
                scene.frame_set(f)
                e = exporter.frame(
                    bpy.context.evaluated_depsgraph_get(),
                    scene,
                    f,
                    options.percentage(scene.render.resolution_percentage),
                )
                send(recorder, e)
            recorded, dropped = recorder.stop_recording()
    finally:
        scene.frame_set(start_frame)
    if dropped:
        raise SpoolError(f"{dropped} frame(s) could not be recorded")
    job = {
        "version": 1,
        "name": jid,
        "frames": frames,
        "settings": job_settings(options, client),
        "outputs": {"exr": options.save_exr, "png": options.save_png, "stats": True},
    }
    (incoming / "job.json").write_text(json.dumps(job, indent=1))
    (spool / "jobs").mkdir(exist_ok=True)
    os.rename(incoming, spool / "jobs" / jid)
    log(
        f"submitted job {jid}: {recorded} frames exported in "
        f"{time.perf_counter() - started:.2f} s to {spool / 'jobs' / jid}"
    )


def follow(spool: Path, jid: str, total: int, on_frame, timeout: float | None = None):
    """Waits for the job; calls ``on_frame(frame, folder)`` once per finished frame, in the
    manifest's order. Returns when ``DONE`` appears; raises on ``ERROR`` or the timeout."""
    results = spool / "results" / jid
    seen: set[int] = set()
    start = time.monotonic()
    while True:
        manifest = results / "manifest.json"
        if manifest.exists():
            try:
                entries = json.loads(manifest.read_text())["frames"]
            except (json.JSONDecodeError, KeyError):
                entries = []  # being replaced: read it on the next round
            for entry in entries:
                if entry["frame"] not in seen:
                    seen.add(entry["frame"])
                    on_frame(entry["frame"], results / entry["dir"])
        # results/<job>.ERROR: the daemon refused to write into an unsafe results/<job>.
        for error in (results / "ERROR", results.parent / f"{jid}.ERROR"):
            if error.exists():
                raise SpoolError(f"job {jid}: {error.read_text().strip()}")
        if (results / "DONE").exists() and len(seen) >= total:
            return
        if timeout is not None and time.monotonic() - start > timeout:
            raise SpoolError(f"job {jid}: {len(seen)} of {total} frames after {timeout:.0f} s")
        time.sleep(0.2)
