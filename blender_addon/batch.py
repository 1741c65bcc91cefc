"""Headless shadow-pass batches of a .blend's frames.

    blender -b scene.blend -P blender_addon/batch.py -- --frames 1-100 --out DIR
        [--build osah] [--width 8] [--order sorted:budget=0.05] [--spp 4] ... (every render
        setting, named as ``antumbra render`` names it: ``--help`` lists them)
        [--scale 1.0] [--no-heat-maps]
        [--socket PATH] [--binary PATH] [--spool DIR] [--restart] [--first-frame N] [--merge]
    blender -b scene.blend -P blender_addon/batch.py -- --frames 1-100 --out DIR
        --compare [LABEL=NAME=VALUE,... ...] [--baseline LABEL] [--repeat R] [settings]
    blender -b scene.blend -P blender_addon/batch.py -- --frames 1-100 --out DIR
        --trade [KNOB[=V1,V2,...] ...] [--repeat R] [settings]

Prints one line per frame and a summary, writes ``frame_NNNN.exr``, PNGs and
``frame_NNNN.stats.json`` per frame and ``stats.csv``/``stats.json`` for all finished frames into
DIR. A run over a half-done DIR renders only the frames that are missing (``--restart`` renders
everything again). The exit status is 0 only if every frame was rendered.

The daemon: the one at ``--socket`` (or the default socket) if it runs, otherwise one started for
the batch (``--binary``, ``$ANTUMBRA_BIN``, the add-on's bundled copy, or ``antumbra`` on PATH)
and stopped at the end. If it dies mid-run the batch restarts it and renders the frame again.

With ``--compare`` the batch compares methods instead (``docs/compare.md``): every frame is
rendered with each method (``LABEL=NAME=VALUE,...``; ``--compare`` alone: the default methods;
the settings flags set what the methods leave out), their answers are checked against the
baseline's, and the report (``compare.csv``, ``compare.json``, ``summary.md``, ``report.html``,
``diff/``) is written into DIR/compare. A run over a half-done report compares only the frames
it lacks (first warming every method up on the frame before the first of them: its trees and
visible set, no shadow rays, so each method's state is what one run would have). The exit
status is 1, the mismatches printed, when a method's answers differ from the baseline's.

With ``--first-frame N`` the frames are part of an animation that starts at N (a farm's chunk of
it, ``farm/``): before a frame whose predecessors the batch has not just rendered (the first
frame, a missing frame on resume) it warms the session up on up to two of them from N on (the
daemon builds their trees and traces their primary rays, no shadow rays, no files), so every
frame's trees and work counters are those of one run from N. ``--merge`` renders nothing:
it rebuilds DIR's tables (or with ``--compare`` its report) from every frame recorded there,
whichever run recorded it, and fails if a frame of ``--frames`` is missing.
With ``--trade`` the batch measures the trade of speed against accuracy instead
(``docs/trade.md``): every frame is swept over each knob (``--help`` lists them; ``--trade``
alone: every knob), and ``trade.csv``, ``plots/`` and ``trade.md`` are written into DIR/trade,
resumed as a comparison is. The exit status is 1 when a work knob's value changes an answer.

With ``--spool DIR`` the frames are exported once into a job in the daemon's spool folder
(``antumbra serve --spool DIR``; one is started for the batch if none watches DIR), the daemon
renders it crash-safely, and the batch collects each finished frame into ``--out``. Running the
same batch again follows the same job.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import bpy

# From a checkout the add-on package is beside this file; from an installed add-on (the zips ship
# this file inside the package) it is this file's own folder.
sys.path.insert(
    0,
    str(
        next(
            d
            for d in Path(__file__).resolve().parents
            if (d / "antumbra" / "__init__.py").is_file()
        )
    ),
)
from antumbra import client_loader, daemon
from antumbra.jobs import compare_results, results, spool
from antumbra.jobs.compare import CompareJob, baseline_of, report_dir, scene_name
from antumbra.jobs.frame_job import WARM_UP_FRAMES, RenderJob
from antumbra.jobs.trade import TradeJob, trade_dir
from antumbra.properties import method_settings
from antumbra.properties.options import RenderOptions


def parse_frames(text: str, scene) -> list[int]:
    if not text:
        return list(range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step)))
    first, sep, last = text.partition("-")
    try:
        a = int(first)
        b = int(last) if sep else a
    except ValueError:
        raise SystemExit(f"--frames: '{text}' is not A-B or N") from None
    if b < a:
        raise SystemExit(f"--frames: the range {a}-{b} is empty")
    return list(range(a, b + 1))


def parse_args(argv: list[str], knobs: list[dict]) -> argparse.Namespace:
    """``knobs``: the client's ``KNOBS``, which ``--trade`` takes (and ``--help`` lists)."""
    parser = argparse.ArgumentParser(prog="batch.py", description=__doc__.splitlines()[0])
    parser.add_argument("--frames", default="", help="A-B or N (default: the scene's range)")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument(
        "--scale",
        type=float,
        default=RenderOptions.resolution_scale,
        help="multiplies the scene's resolution percentage (default %(default)s, as the panel)",
    )
    parser.add_argument("--no-heat-maps", action="store_true")
    parser.add_argument("--no-png", action="store_true")
    parser.add_argument("--socket", default="", help="the daemon's socket")
    parser.add_argument("--binary", default="", help="the antumbra executable")
    parser.add_argument("--spool", type=Path, help="render through this spool folder")
    parser.add_argument("--restart", action="store_true", help="render finished frames again")
    parser.add_argument(
        "--first-frame",
        type=int,
        help="the animation's first frame: frames after a gap are rendered after a warm-up on "
        "their predecessors (trees and visible sets only), as in one run from it",
    )
    parser.add_argument(
        "--merge",
        action="store_true",
        help="render nothing: rebuild the tables (or the report) from every frame in OUT",
    )
    parser.add_argument(
        "--compare",
        nargs="*",
        metavar="LABEL=NAME=VALUE,...",
        help="compare these methods (none given: the default methods) into OUT/compare",
    )
    parser.add_argument("--baseline", help="--compare: the baseline's label (default: the first)")
    parser.add_argument(
        "--trade",
        nargs="*",
        metavar="KNOB[=V1,V2,...]",
        help="sweep these knobs (none given: every knob) into OUT/trade; knobs: "
        + ", ".join(f"{k['name']} ({k['kind']})" for k in knobs),
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=3,
        help="--compare, --trade: timed passes per method (or knob value) and frame",
    )
    method_settings.add_arguments(parser)
    args = parser.parse_args(argv)
    if not 0.0 < args.scale <= 1.0:
        parser.error("--scale must be in (0, 1]")
    if args.compare is None and args.baseline:
        parser.error("--baseline goes with --compare")
    if args.compare is None and args.trade is None and args.repeat != 3:
        parser.error("--repeat goes with --compare or --trade")
    if args.compare is not None and args.trade is not None:
        parser.error("--compare and --trade are two runs: give one")
    if (args.compare is not None or args.trade is not None) and args.spool:
        parser.error("--compare and --trade render through a session, not a spool")
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")
    if args.spool and (args.first_frame is not None or args.merge):
        parser.error("--first-frame and --merge go with a session, not a spool")
    # A binary asked for by name is used or refused, never quietly replaced by another one.
    if args.binary and not Path(args.binary).is_file():
        parser.error(f"--binary: {args.binary} does not exist")
    if args.binary and not os.access(args.binary, os.X_OK):
        parser.error(f"--binary: {args.binary} is not executable")
    problem = method_settings.check(method_settings.from_arguments(args))
    if problem:
        parser.error(problem)
    return args


def run(argv: list[str]) -> int:
    client = client_loader.load()
    args = parse_args(argv, list(client.KNOBS))
    scene = bpy.context.scene
    frames = parse_frames(args.frames, scene)
    options = RenderOptions(
        settings=method_settings.from_arguments(args),
        resolution_scale=args.scale,
        heat_maps=not args.no_heat_maps,
        save_png=not args.no_png,
    )
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    if args.first_frame is not None and args.first_frame > frames[0]:
        raise SystemExit(f"--first-frame {args.first_frame} is after frame {frames[0]}")
    if args.merge:
        return run_merge(args, scene, frames, out, client)
    if args.spool:
        return run_spool(args, scene, frames, options, out, client)
    link = daemon.DaemonLink(
        binary=args.binary,
        socket_path=args.socket,
        client_name="antumbra-batch",
        on_log=_say,
    )
    if args.compare is not None:
        return run_compare(args, scene, frames, options, out, client, link)
    if args.trade is not None:
        return run_trade(args, scene, frames, options, out, client, link)

    def progress(job: RenderJob, done):
        n = len(job.done) + len(job.skipped)
        say_warnings(done)
        print(
            f"antumbra: frame {done.frame} ({n}/{len(job.frames)}) {done.seconds:.2f} s "
            f"(export {done.export_seconds:.3f} s) | " + " | ".join(done.stats_lines),
            flush=True,
        )

    job = RenderJob(
        scene=scene,
        frames=frames,
        options=options,
        link=link,
        out_dir=out,
        load_images=False,
        on_frame=progress,
        **warm_up(args, frames),
    )
    job.key = results.run_key(bpy.data.filepath, options)
    if not args.restart:
        job.skip_finished(set(results.finished_frames(out, job.key)))
        stale = set(results.finished_frames(out)) - set(job.skipped)
        if job.skipped:
            print(f"antumbra: resuming: {len(job.skipped)} frame(s) already done", flush=True)
        if stale & set(job.pending):
            print(
                f"antumbra: {len(stale & set(job.pending))} frame(s) in {out} were made from "
                "another .blend or other settings: rendering them again",
                flush=True,
            )
    name = Path(bpy.data.filepath).name or "(unsaved scene)"
    what = options.describe(method_settings.defaults())
    print(f"antumbra: {name}: {len(job.pending)} frame(s) to render, {what}")
    start = time.perf_counter()
    try:
        job.run()
    finally:
        link.close()
    elapsed = time.perf_counter() - start
    frames_csv, rows = results.write_tables(out)
    exported = [d.export_seconds for d in job.done]
    mean_export = sum(exported) / len(exported) if exported else 0.0
    print(
        f"antumbra: summary: {len(job.done)} rendered, {len(job.skipped)} already done, "
        f"{len(job.pending)} not rendered, {elapsed:.1f} s, mean export {mean_export:.3f} s, "
        f"daemon reconnects {link.reconnects}; {rows} frames in {frames_csv}",
        flush=True,
    )
    if job.warmed:
        _say("warmed up on (state only): " + ", ".join(map(str, job.warmed)))
    if job.error:
        print(f"antumbra: error: {job.error}", file=sys.stderr, flush=True)
        return 1
    if job.pending:
        print("antumbra: error: stopped before the last frame", file=sys.stderr, flush=True)
        return 1
    return 0


def warm_up(args, frames: list[int]) -> dict:
    """The job's warm-up with ``--first-frame``: up to WARM_UP_FRAMES predecessors, from it on."""
    if args.first_frame is None:
        return {}
    lead_in = range(max(args.first_frame, frames[0] - WARM_UP_FRAMES), frames[0])
    return {"lead_in": list(lead_in), "warm_up": WARM_UP_FRAMES}


def compare_report(args, scene, client):
    """The report folder of ``--compare`` (its methods, baseline and repeat)."""
    methods = args.compare or list(client.DEFAULT_METHODS)
    baseline = baseline_of(methods, args.baseline)
    try:
        report = client.CompareReport(
            report_dir(args.out.resolve()),
            scene=scene_name(scene),
            methods=methods,
            baseline=baseline,
            repeat=args.repeat,
        )
    except client.InvalidInput as e:
        raise SystemExit(str(e)) from None
    return report, methods, baseline


def run_merge(args, scene, frames, out: Path, client) -> int:
    """``--merge``: the tables (or the report) of every frame in OUT, and the frames missing."""
    if args.compare is not None:
        report, _, _ = compare_report(args, scene, client)
        recorded = report.frames()
        written = report.write()
    else:
        recorded = results.finished_frames(out)
        written, _ = results.write_tables(out)
    missing = [f for f in frames if f not in recorded]
    _say(f"merged {len(recorded)} frame(s) into {written}")
    if missing:
        print(
            f"antumbra: error: {len(missing)} frame(s) missing: "
            + ", ".join(str(f) for f in missing),
            file=sys.stderr,
            flush=True,
        )
        return 1
    return 0


def run_compare(args, scene, frames, options, out: Path, client, link) -> int:
    report, methods, baseline = compare_report(args, scene, client)
    job = CompareJob(
        **sweep_job(args, scene, frames, options, link, report_dir(out), report),
        methods=methods,
        baseline=baseline,
    )
    start = run_sweep(
        job, args, link, "compared", f"compare, {len(methods)} methods against {baseline}"
    )
    html = report.write()
    say_summary(job, "compared", "methods warmed up on (state only)", start, f"report {html}")
    for line in compare_results.frame_lines(job.rows, baseline, job.mismatches):
        _say(f"  {line}")
    return sweep_status(job, [m["message"] for m in job.mismatches])


def run_trade(args, scene, frames, options, out: Path, client, link) -> int:
    folder = trade_dir(out)
    try:
        report = client.TradeReport(
            folder, scene=scene_name(scene), knobs=args.trade, repeat=args.repeat
        )
    except client.InvalidInput as e:
        raise SystemExit(f"--trade: {e}") from None
    job = TradeJob(
        **sweep_job(args, scene, frames, options, link, folder, report), knobs=args.trade
    )
    start = run_sweep(
        job, args, link, "traded", f"trade over {', '.join(args.trade) or 'every knob'}"
    )
    md = report.write()
    say_summary(job, "traded", "traded again for the knobs' state", start, str(md))
    for r in report.recommendations():
        _say(f"  {r['knob']}: {r['recommended']} (default {r['default']}): {r['why']}")
    return sweep_status(job, report.mismatches)


# What --compare and --trade share: a job over the frames into a report folder, resumed from
# what the folder holds, said and summed up in the same words but for the verb.


def say_warnings(done) -> None:
    """A frame's export warnings (each said once per job), on stderr."""
    for w in done.warnings:
        print(f"antumbra: warning: {w}", file=sys.stderr, flush=True)


def sweep_job(args, scene, frames, options, link, folder: Path, report) -> dict:
    """The arguments a comparison's and a trade's job share (the batch loads no images)."""

    def progress(job: CompareJob, done):
        n = len(job.done) + len(job.skipped)
        say_warnings(done)
        print(
            f"antumbra: frame {done.frame} ({n}/{len(job.frames)}) {done.seconds:.2f} s | "
            + " | ".join(done.stats_lines),
            flush=True,
        )

    def stage(job: CompareJob, frame: int, stage: str, done: int, total: int):
        # Each method pass as it ends: a frame of a long comparison is not 40 s of silence.
        if stage in ("compare", "trade") and done > 0:
            print(f"antumbra: frame {frame}: {stage} pass {done}/{total}", flush=True)

    return dict(
        scene=scene,
        frames=frames,
        options=options,
        link=link,
        out_dir=folder,
        load_images=False,
        on_frame=progress,
        on_stage=stage,
        repeat=args.repeat,
        report=report,
        **warm_up(args, frames),
    )


def run_sweep(job: CompareJob, args, link, done: str, plan: str) -> float:
    """Runs the job on the frames its report lacks (``done``: "compared", "traded"; ``plan``:
    what is to be done to each frame); its start time."""
    if not args.restart:
        job.skip_finished(set(job.report.frames()))
        if job.skipped:
            _say(f"resuming: {len(job.skipped)} frame(s) already {done}")
    _say(
        f"{Path(bpy.data.filepath).name or '(unsaved scene)'}: {len(job.pending)} frame(s) to "
        f"{plan}, " + job.options.describe(method_settings.defaults())
    )
    start = time.perf_counter()
    try:
        job.run()
    finally:
        link.close()
    return start


def say_summary(job: CompareJob, done: str, warmed: str, start: float, written: str):
    """The summary line: frames done, skipped and left, the warm-ups, time, what was written."""
    again = ", ".join(str(f) for f in job.warmed) or "none"
    _say(
        f"summary: {len(job.done)} {done}, {len(job.skipped)} already done, "
        f"{len(job.pending)} not {done}, {warmed}: {again}, "
        f"{time.perf_counter() - start:.1f} s; {written}"
    )


def sweep_status(job: CompareJob, mismatches: list[str]) -> int:
    """Prints the mismatches and what stopped the job; the exit status (1 on any of them)."""
    for m in mismatches:
        print(f"antumbra: error: {m}", file=sys.stderr, flush=True)
    if job.error:
        print(f"antumbra: error: {job.error}", file=sys.stderr, flush=True)
    if job.pending and not job.error:
        print("antumbra: error: stopped before the last frame", file=sys.stderr, flush=True)
    return 1 if mismatches or job.error or job.pending else 0


def run_spool(args, scene, frames, options, out: Path, client) -> int:
    folder = args.spool.resolve()
    folder.mkdir(parents=True, exist_ok=True)
    jid = spool.job_id(bpy.data.filepath, frames, options)
    key = results.run_key(bpy.data.filepath, options)
    finished = {} if args.restart else results.finished_frames(out, key)
    started = None
    if not spool.daemon_watching(folder):
        binary = daemon.find_binary(args.binary)
        if binary is None:
            raise SystemExit(
                f"no daemon watches {folder} and the antumbra binary was not found: start "
                f"`antumbra serve --spool {folder}`, or pass --binary"
            )
        started = client.Client.spawn(
            binary, args=["--spool", str(folder)], client_name="antumbra-batch"
        )
        print(f"antumbra: started {binary} (pid {started.process.pid}) on {folder}", flush=True)
    done, skipped = [], []
    start = time.perf_counter()

    def collect(frame: int, folder_of_frame: Path):
        if frame in finished:
            skipped.append(frame)
            return
        rows = json.loads((folder_of_frame / "stats.json").read_text())
        for f in folder_of_frame.iterdir():
            if f.name != "stats.json" and not f.name.startswith("."):
                # Atomically, as every antumbra file: a reader never sees half a copied EXR.
                client.write_file_atomic(out / f.name, f.read_bytes())
        record = {
            "frame": frame,
            "key": key,
            "seconds": sum(r["build_ms"] + r["trace_ms"] for r in rows) / 1000.0,
            "export_seconds": 0.0,
            "objects": None,
            "triangles": None,  # a recording's sent triangles are not counted here
            "rows": rows,
        }
        results.write_frame_stats(out, record)
        results.write_tables(out)
        done.append(frame)
        n = len(done) + len(skipped)
        print(
            f"antumbra: frame {frame} ({n}/{len(frames)}) "
            + " | ".join(results.stats_summary(rows)),
            flush=True,
        )

    try:
        if (folder / "jobs" / jid).exists():
            print(f"antumbra: following job {jid} (submitted before)", flush=True)
        else:
            spool.submit(folder, jid, scene, frames, options, client, log=_say)
        spool.follow(folder, jid, len(frames), collect)
    except spool.SpoolError as e:
        print(f"antumbra: error: {e}", file=sys.stderr, flush=True)
        return 1
    finally:
        if started is not None:
            started.close()
    frames_csv, rows = results.write_tables(out)
    print(
        f"antumbra: summary: {len(done)} rendered, {len(skipped)} already done, "
        f"0 not rendered, {time.perf_counter() - start:.1f} s, spool job {jid}; "
        f"{rows} frames in {frames_csv}",
        flush=True,
    )
    return 0


def _say(line: str):
    print(f"antumbra: {line}", flush=True)


def exit_status(argv: list[str]) -> int:
    """Runs the batch; its exit status (1 on any failure, 2 on bad arguments)."""
    try:
        code = run(argv)
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 2
        if not isinstance(e.code, int):
            print(f"antumbra: error: {e.code}", file=sys.stderr)
    except Exception as e:  # noqa: BLE001 - any failure is the exit status
        print(f"antumbra: error: {type(e).__name__}: {e}", file=sys.stderr)
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    return code


def main():
    code = exit_status(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else [])
    # Blender exits 0 after a -P script whatever happened; the batch's status must mean
    # something, and an explicit exit is the only way to set it.
    os._exit(code)


if __name__ == "__main__":
    main()
