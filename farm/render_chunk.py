"""One task of the farm job (``farm/template.yaml``, docs/farm.md): the Blender command that
renders a chunk of an animation's frames, or merges the chunks' statistics. The one place that
says how a chunk is rendered (today through ``blender_addon/batch.py``).

    python3 farm/render_chunk.py chunk --blend F --first S --last E --chunk-start A --chunk-size K
        --out DIR [--addon DIR] [--blender PATH] [--binary PATH] [--batch-args "--build osah ..."]
    python3 farm/render_chunk.py merge --blend F --first S --last E --out DIR [same options]

A chunk renders frames A..min(A+K-1, E) into DIR with a daemon of its own (on a socket of its
own, stopped at the end), after rendering and discarding up to two frames before A (from S on),
so its frames equal those of one run over S..E; run again, it renders only the frames DIR lacks.
The merge rebuilds DIR's frames.csv and stats.csv (or, with ``--compare`` in the batch
arguments, the compare report) from every frame and fails if one of S..E is missing. The exit
status is Blender's (batch.py's).
"""

from __future__ import annotations

import argparse
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

#: The add-on folder of a checkout, beside this folder.
CHECKOUT_ADDON = Path(__file__).resolve().parents[1] / "blender_addon"


def chunk_frames(first: int, last: int, start: int, size: int) -> tuple[int, int]:
    """The frames of the chunk that starts at ``start``: ``start``..``start + size - 1``, cut at
    ``last``."""
    if size < 1:
        raise SystemExit("--chunk-size must be at least 1")
    if not first <= start <= last:
        raise SystemExit(f"--chunk-start {start} is outside the frames {first}-{last}")
    return start, min(start + size - 1, last)


def blender_command(args: argparse.Namespace, frames: str, socket: Path | None) -> list[str]:
    """``blender -b FILE -P batch.py -- ...`` for ``frames`` (``A-B``)."""
    batch = Path(args.addon) / "batch.py"
    if not batch.is_file():
        raise SystemExit(f"no batch.py in {args.addon}: pass --addon, the add-on's folder")
    command = [args.blender, "-b", "--factory-startup", "-noaudio", args.blend, "-P", str(batch)]
    command += ["--", "--frames", frames, "--first-frame", str(args.first), "--out", args.out]
    if socket is not None:
        command += ["--socket", str(socket)]
    if args.binary:
        command += ["--binary", args.binary]
    if args.command == "merge":
        command.append("--merge")
    return command + shlex.split(args.batch_args)


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="render_chunk.py", description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["chunk", "merge"])
    parser.add_argument("--blend", required=True, help="the .blend")
    parser.add_argument("--first", type=int, required=True, help="the animation's first frame")
    parser.add_argument("--last", type=int, required=True, help="the animation's last frame")
    parser.add_argument("--chunk-start", type=int, help="chunk: its first frame")
    parser.add_argument("--chunk-size", type=int, help="chunk: frames per chunk")
    parser.add_argument("--out", required=True, help="the output folder (shared by the chunks)")
    parser.add_argument("--addon", default=str(CHECKOUT_ADDON), help="the folder of batch.py")
    parser.add_argument("--blender", default="blender", help="the Blender executable")
    parser.add_argument("--binary", default="", help="the antumbra executable (daemon)")
    parser.add_argument(
        "--batch-args", default="", help="more batch.py flags: settings, --compare ..."
    )
    args = parser.parse_args(argv)
    if args.last < args.first:
        parser.error(f"the frames {args.first}-{args.last} are empty")
    if args.command == "chunk" and (args.chunk_start is None or args.chunk_size is None):
        parser.error("chunk needs --chunk-start and --chunk-size")
    return args


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    if args.command == "merge":
        command = blender_command(args, f"{args.first}-{args.last}", None)
        print("render_chunk: " + shlex.join(command), flush=True)
        return subprocess.run(command).returncode
    a, b = chunk_frames(args.first, args.last, args.chunk_start, args.chunk_size)
    # A socket of the task's own (short: Unix socket paths are limited), so the batch starts a
    # daemon for this chunk alone and stops it at the end.
    folder = Path(tempfile.mkdtemp(prefix="antumbra-chunk-", dir="/tmp"))
    try:
        command = blender_command(args, f"{a}-{b}", folder / "d.sock")
        print("render_chunk: " + shlex.join(command), flush=True)
        return subprocess.run(command).returncode
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
