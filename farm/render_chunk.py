"""One task of the farm job (``farm/template.yaml``, docs/farm.md), run inside Blender: render a
chunk of an animation's frames, or merge the chunks' statistics. The one place that says how a
chunk is rendered (today through ``blender_addon/batch.py``).

    blender -b scene.blend --python-exit-code 1 -P farm/render_chunk.py -- chunk
        --first S --last E --chunk-start A --chunk-size K --out DIR --addon DIR
        [--binary PATH] [--batch-args "--build osah --spp 4 ..."]
    blender -b scene.blend --python-exit-code 1 -P farm/render_chunk.py -- merge
        --first S --last E --out DIR --addon DIR [--batch-args "..."]

A chunk renders frames A..min(A+K-1, E) into DIR with a daemon of its own (on a socket of its
own, stopped at the end), after rendering and discarding up to two frames before A (from S on),
so its frames equal those of one run over S..E; run again, it renders only the frames DIR lacks.
The merge rebuilds DIR's frames.csv and stats.csv (or, with ``--compare`` in the batch
arguments, the compare report) from every frame, and fails if one of S..E is missing. The exit
status is the batch's.
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import sys
import tempfile
from pathlib import Path


def chunk_frames(first: int, last: int, start: int, size: int) -> tuple[int, int]:
    """The frames of the chunk that starts at ``start``: up to ``size`` of them, cut at
    ``last``."""
    if size < 1:
        raise SystemExit("--chunk-size must be at least 1")
    if not first <= start <= last:
        raise SystemExit(f"--chunk-start {start} is outside the frames {first}-{last}")
    return start, min(start + size - 1, last)


def batch_arguments(args: argparse.Namespace, socket: Path | None) -> list[str]:
    """batch.py's arguments for this task."""
    if args.command == "merge":
        frames = f"{args.first}-{args.last}"
    else:
        frames = "-".join(
            map(str, chunk_frames(args.first, args.last, args.chunk_start, args.chunk_size))
        )
    argv = ["--frames", frames, "--first-frame", str(args.first), "--out", args.out]
    if socket is not None:
        argv += ["--socket", str(socket)]
    if args.binary:
        argv += ["--binary", args.binary]
    if args.command == "merge":
        argv.append("--merge")
    return argv + shlex.split(args.batch_args)


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="render_chunk.py", description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["chunk", "merge"])
    parser.add_argument("--first", type=int, required=True, help="the animation's first frame")
    parser.add_argument("--last", type=int, required=True, help="the animation's last frame")
    parser.add_argument("--chunk-start", type=int, help="chunk: its first frame")
    parser.add_argument("--chunk-size", type=int, help="chunk: frames per chunk")
    parser.add_argument("--out", required=True, help="the output folder (shared by the chunks)")
    parser.add_argument("--addon", required=True, help="the add-on's folder (batch.py)")
    parser.add_argument("--binary", default="", help="the antumbra executable (daemon)")
    parser.add_argument("--batch-args", default="", help="more batch.py flags: settings, --compare")
    args = parser.parse_args(argv)
    if args.last < args.first:
        parser.error(f"the frames {args.first}-{args.last} are empty")
    if args.command == "chunk" and (args.chunk_start is None or args.chunk_size is None):
        parser.error("chunk needs --chunk-start and --chunk-size")
    return args


def run(argv: list[str]) -> int:
    args = parse_args(argv)
    batch_py = Path(args.addon) / "batch.py"
    if not batch_py.is_file():
        raise SystemExit(f"no batch.py in {args.addon}: --addon is the add-on's folder")
    sys.path.insert(0, str(batch_py.parent))
    import batch

    # A socket of the task's own (short: Unix socket paths are limited), so the batch starts a
    # daemon for this chunk alone and stops it at the end.
    folder = Path(tempfile.mkdtemp(prefix="antumbra-chunk-", dir="/tmp"))
    try:
        batch_argv = batch_arguments(args, None if args.command == "merge" else folder / "d.sock")
        print("render_chunk: batch.py " + shlex.join(batch_argv), flush=True)
        return batch.exit_status(batch_argv)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def main():
    try:
        code = run(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else [])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 2
        if not isinstance(e.code, int):
            print(f"render_chunk: error: {e.code}", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    # Blender exits 0 after a -P script whatever happened: an explicit exit sets the status.
    os._exit(code)


if __name__ == "__main__":
    main()
